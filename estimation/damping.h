// The two step rules the MAP iterations share (the UT calibration's, docs/estimation.md s.3.3,
// and the ROUKF's whole-data refinement, s.4.7).
#pragma once

#include <algorithm>
#include <cmath>

namespace sigmaheart::estimation {

// Levenberg-Marquardt damping after an accepted step with gain ratio rho (actual over predicted
// decrease): lambda *= max(1/3, 1 - (2 rho - 1)^3) (Nielsen 1999, IMM-REP-1999-05, eq. 2.6),
// and 0 (the undamped Gauss-Newton step) once below `floor`.
inline double damping_after_accepted_step(double lambda, double rho, double floor) {
  lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
  return lambda < floor ? 0.0 : lambda;
}

// The finishing step along a valley: with the last two step lengths in the ratio q = s(k) / s(k-1)
// the centres approach their limit like a geometric series whose remainder is q / (1 - q) times
// the last step (Aitken's extrapolation of a linearly converging sequence; Brezinski & Redivo
// Zaglia 1991, s.1.3), capped at `cap`; with q outside (0, 1) one more step of the same length.
inline double valley_extrapolation_factor(double q, double cap) {
  return q > 0 && q < 1 ? std::min(q / (1 - q), cap) : 1.0;
}

}  // namespace sigmaheart::estimation
