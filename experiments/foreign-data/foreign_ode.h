// Adaptive Dormand-Prince 5(4) integrator for the foreign-data bench (Eigen + std only).
//
// Dormand JR, Prince PJ. A family of embedded Runge-Kutta formulae. J Comput Appl Math
// 1980;6:19-26 (the RK5(4)7M tableau, FSAL). Step-size control as in Hairer, Norsett & Wanner,
// Solving ODEs I, 2nd ed., s. II.4, eqs. (4.11)-(4.13): scaled RMS error, safety factor 0.9,
// growth limited to [0.2, 5].
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

namespace foreign {

/// dy/dt = f(t, y); f writes into dy (already sized like y).
using Rhs = std::function<void(double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy)>;

struct Dopri5Options {
  double rtol = 1e-9;       ///< relative tolerance per component
  double atol = 1e-9;       ///< absolute tolerance per component (state units)
  double h_max = 5e-3;      ///< [s] largest step; keeps valve openings from being stepped over
  double h_min = 1e-12;     ///< [s] a step below this is a failure (std::runtime_error)
  long max_steps = 10'000'000;
};

/// Advances y from t0 to t1 (t1 > t0) with error control. `h` carries the step-size guess
/// between calls (pass 0 to let the integrator choose). Throws std::runtime_error when the step
/// size underflows h_min or max_steps is exceeded.
inline void dopri5(const Rhs& f, double t0, double t1, Eigen::VectorXd& y, double& h,
                   const Dopri5Options& opt = {}) {
  // Butcher tableau of Dormand & Prince (1980), Table 2 (RK5(4)7M).
  constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  constexpr double a21 = 1.0 / 5;
  constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                   a54 = -212.0 / 729;
  constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                   a65 = -5103.0 / 18656;
  constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
                   b6 = 11.0 / 84;
  // error coefficients: 5th-order minus embedded 4th-order weights
  constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920,
                   e5 = -17253.0 / 339200, e6 = 22.0 / 525, e7 = -1.0 / 40;

  const Eigen::Index n = y.size();
  Eigen::VectorXd k1(n), k2(n), k3(n), k4(n), k5(n), k6(n), k7(n), ytmp(n), ynew(n), err(n);
  double t = t0;
  if (!(h > 0.0)) h = std::min(1e-4, t1 - t0);
  f(t, y, k1);
  long steps = 0;
  while (t < t1) {
    if (++steps > opt.max_steps) throw std::runtime_error("dopri5: too many steps");
    const double h_free = std::min(h, opt.h_max);  // the controller's proposal
    const bool last = (t + h_free >= t1);
    h = last ? t1 - t : h_free;
    ytmp = y + h * a21 * k1;
    f(t + c2 * h, ytmp, k2);
    ytmp = y + h * (a31 * k1 + a32 * k2);
    f(t + c3 * h, ytmp, k3);
    ytmp = y + h * (a41 * k1 + a42 * k2 + a43 * k3);
    f(t + c4 * h, ytmp, k4);
    ytmp = y + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4);
    f(t + c5 * h, ytmp, k5);
    ytmp = y + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5);
    const double t_new = last ? t1 : t + h;
    f(t_new, ytmp, k6);
    ynew = y + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    f(t_new, ynew, k7);
    err = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
    double norm = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double sc = opt.atol + opt.rtol * std::max(std::abs(y(i)), std::abs(ynew(i)));
      norm += (err(i) / sc) * (err(i) / sc);
    }
    norm = std::sqrt(norm / static_cast<double>(n));
    if (!std::isfinite(norm)) norm = 1e10;
    const double fac = norm > 0.0 ? std::clamp(0.9 * std::pow(norm, -0.2), 0.2, 5.0) : 5.0;
    if (norm <= 1.0) {
      t = t_new;
      y = ynew;
      k1 = k7;  // first-same-as-last
      // a step shortened to land on t1 does not shrink the next call's first step
      h = last ? std::max(h * fac, h_free) : h * fac;
    } else {
      h *= std::min(fac, 1.0);
      if (h < opt.h_min) throw std::runtime_error("dopri5: step size underflow");
    }
  }
}

}  // namespace foreign
