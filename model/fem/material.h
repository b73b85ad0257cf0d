// Hyperelastic laws of the myocardium, written as W(E) in the reference configuration.
//
// The incompressibility constraint is not part of these laws: the mechanics adds the mixed
// pressure term -p (J - 1) (and -p^2 / (2 kappa) for a finite bulk modulus), so W here is the
// deviatoric/anisotropic part only (Land et al. 2015, section 2, for Guccione).
//
// Fourth-order tensors are 9x9 matrices acting on full (not Voigt) vectors of 3x3 tensors with
// row-major index 3*I + J, so vec(S) = D vec(E) holds for the linearisation dS = D : dE.
// Units: stresses and parameters C, c1, c2 in Pa.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>

namespace sigmaheart::model::fem {

using Matrix9d = Eigen::Matrix<double, 9, 9>;

// Local material frame: columns (f, s, n) = fibre, sheet, sheet-normal, orthonormal.
using Frame = Eigen::Matrix3d;

class Material {
 public:
  virtual ~Material() = default;
  // Strain energy density [Pa] at Green-Lagrange strain E.
  virtual double energy(const Eigen::Matrix3d& E, const Frame& R) const = 0;
  // Second Piola-Kirchhoff stress S = dW/dE and tangent D = d2W/dE2 (9x9, see above).
  virtual void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const = 0;
  virtual std::unique_ptr<Material> clone() const = 0;
  virtual std::string name() const = 0;
};

// Guccione et al. 1991 transversely isotropic law, as in Land et al. 2015 (section 2):
//   W = C/2 (exp(Q) - 1),
//   Q = bf E_ff^2 + bt (E_ss^2 + E_nn^2 + E_sn^2 + E_ns^2) + bfs (E_fs^2 + E_sf^2 + E_fn^2 + E_nf^2),
// with E expressed in the local frame (f, s, n).
struct GuccioneParameters {
  double C = 2e3;   // [Pa]
  double bf = 8.0;
  double bt = 2.0;
  double bfs = 4.0;
  // Evaluate Q on the isochoric strain E_bar = (J^-2/3 C - I)/2 (the same law when J = 1). With a
  // weakly enforced constraint (u-p elements) the full-E law lets elements collapse through the
  // compression instability of E-quadratic energies (S -> 0 as a stretch -> 0); the isochoric
  // form does not, and is what the public FEniCS reproduction (pulse) uses. Default on.
  bool isochoric = true;
  std::string validate() const;
};

class Guccione final : public Material {
 public:
  explicit Guccione(const GuccioneParameters& p);
  double energy(const Eigen::Matrix3d& E, const Frame& R) const override;
  void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const override;
  std::unique_ptr<Material> clone() const override { return std::make_unique<Guccione>(p_); }
  std::string name() const override { return "guccione"; }
  const GuccioneParameters& parameters() const { return p_; }

 private:
  void stress_full(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const;
  GuccioneParameters p_;
};

// Tensor operators on the row-major vec of 3x3 tensors (vec(A)[3I + J] = A(I, J)), shared by the
// laws here and in electromechanics.cpp.
Matrix9d tensor_outer(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B);  // A_IJ B_KL
Matrix9d tensor_sym_product(const Eigen::Matrix3d& A);  // (A_IK A_JL + A_IL A_JK) / 2

// The isochoric invariants of C = I + 2E, f1 = I3^-1/3 I1 and f2 = I3^-2/3 I2, with their
// derivatives with respect to C: df (3x3) and d2f (9x9, on the vec above).
struct IsochoricInvariants {
  double f1 = 0.0, f2 = 0.0;
  Eigen::Matrix3d df1, df2;
  Matrix9d d2f1, d2f2;
};
IsochoricInvariants isochoric_invariants(const Eigen::Matrix3d& E);

// Mooney-Rivlin on the isochoric invariants (the thesis law, docs/models.md s.4):
//   W = c1 (J^-2/3 I1 - 3) + c2 (J^-4/3 I2 - 3); the volumetric penalty kappa/2 (J - 1)^2 is the
// mixed formulation's bulk modulus (MechanicsOptions::bulk_modulus).
struct MooneyRivlinParameters {
  double c1 = 1.0e3;  // [Pa]
  double c2 = 0.2e3;  // [Pa]
  std::string validate() const;
};

class MooneyRivlin final : public Material {
 public:
  explicit MooneyRivlin(const MooneyRivlinParameters& p);
  double energy(const Eigen::Matrix3d& E, const Frame& R) const override;
  void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const override;
  std::unique_ptr<Material> clone() const override { return std::make_unique<MooneyRivlin>(p_); }
  std::string name() const override { return "mooney-rivlin"; }

 private:
  MooneyRivlinParameters p_;
};

}  // namespace sigmaheart::model::fem
