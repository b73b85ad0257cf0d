// The central-difference neighbours of a mechanics state: the columns of the tangent checks
// (mechanics_test, elastodynamics_test).
#pragma once

#include "model/fem/mechanics.h"

#include <utility>

namespace sigmaheart::model::fem {

// `s` with unknown j (displacements first, then pressures) moved by +h and by -h.
inline std::pair<State, State> perturbed(const State& s, int j, double h) {
  const int nu = static_cast<int>(s.u.size());
  State plus = s, minus = s;
  if (j < nu) {
    plus.u[j] += h;
    minus.u[j] -= h;
  } else {
    plus.p[j - nu] += h;
    minus.p[j - nu] -= h;
  }
  return {plus, minus};
}

}  // namespace sigmaheart::model::fem
