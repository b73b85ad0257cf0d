#include "mooney_rivlin_lv.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace foreign {
namespace {
constexpr double kMmHgPerKPa = 7.500615758;
}  // namespace

double MooneyRivlinLv::activation(double t) const {
  const double T = period();
  const double s = t - T * std::floor(t / T);
  if (s < p_.T1) return 0.5 * (1.0 - std::cos(std::numbers::pi * s / p_.T1));
  if (s < p_.T2) return 0.5 * (1.0 + std::cos(std::numbers::pi * (s - p_.T1) / (p_.T2 - p_.T1)));
  return 0.0;
}

double MooneyRivlinLv::atrial_activation(double t) const {
  return raised_cosine_atrium(t, period(), p_);
}

double MooneyRivlinLv::passive_stress(double lambda) const {
  const double l2 = lambda * lambda;
  return 2.0 * (l2 - 1.0 / (l2 * l2)) * (p_.C1 + p_.C2 * l2);
}

double MooneyRivlinLv::lv_pressure(double t, double V) const {
  const double lambda = std::cbrt(V / p_.V0);
  const double length = std::max(0.0, 1.0 + p_.beta * (lambda - 1.0));
  const double sigma = passive_stress(lambda) + p_.T_max * activation(t) * length;  // [kPa]
  return kMmHgPerKPa * (2.0 / 3.0) * (p_.V_wall / V) * sigma;
}

}  // namespace foreign
