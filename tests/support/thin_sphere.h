// The thin-sphere relations of docs/models.md s.2.1 written out again for the tests, apart from
// model/lumped/shell.h: a test that compares the simulator's channels with these does not
// compare the code with itself.
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <cmath>
#include <numbers>
#include <string>

namespace sigmaheart::testing {

struct ThinSphere {
  double rho = 0, R0 = 0, d0 = 0, eta = 0;    // [kg/m^3], [m], [m], [Pa s]
  double c1 = 0, c2 = 0, c_exp = 0, b_exp = 0;  // passive law [Pa], [Pa], [Pa], [1]

  static ThinSphere from(const model::ParameterSpace& space, const Eigen::VectorXd& theta) {
    auto at = [&](const std::string& name) { return theta(space.index_or_throw(name)); };
    ThinSphere s;
    s.rho = at("rho");
    s.R0 = at("R0");
    s.d0 = at("d0");
    s.eta = at("eta");
    s.c1 = at("c1");
    s.c2 = at("c2");
    s.c_exp = at("c_exp");
    s.b_exp = at("b_exp");
    return s;
  }

  // Strain energy per unit reference volume [J/m^3] at the areal stretch C = (R/R0)^2:
  // W = c1 (J1 - 3) + c2 (J2 - 3) + c_exp (exp(b_exp (J1 - 3)^2) - 1), J1 = 2C + C^-2,
  // J2 = C^2 + 2/C (docs/models.md s.2.1).
  double strain_energy(double C) const {
    const double I1 = 2.0 * C + 1.0 / (C * C) - 3.0, I2 = C * C + 2.0 / C - 3.0;
    return c1 * I1 + c2 * I2 + c_exp * (std::exp(b_exp * I1 * I1) - 1.0);
  }
  // Passive stress Sigma_pas = 2 dW/dC [Pa].
  double passive_stress(double C) const {
    const double g = 1.0 - 1.0 / (C * C * C), I1 = 2.0 * C + 1.0 / (C * C) - 3.0;
    return 4.0 * g * (c1 + C * c2) + 8.0 * b_exp * c_exp * I1 * g * std::exp(b_exp * I1 * I1);
  }
  // Viscous stress Sigma_vis = eta dC/dt (1 + 2 C^-6) [Pa].
  double viscous_stress(double C, double dC_dt) const {
    return eta * dC_dt * (1.0 + 2.0 / std::pow(C, 6));
  }
  // Mid-wall radius [m] from the fibre strain e = (C - 1)/2 (channel e_fibre).
  double radius(double e) const { return R0 * std::sqrt(1.0 + 2.0 * e); }
  // Reference wall volume 4 pi R0^2 d0 [m^3] (thin shell).
  double wall_volume() const { return 4.0 * std::numbers::pi * R0 * R0 * d0; }
};

}  // namespace sigmaheart::testing
