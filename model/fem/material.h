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
#include <stdexcept>
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
  // S alone, for residual-only assemblies (the line search and chord iterations of a Newton solve);
  // the same bits as stress()'s S. The default evaluates the tangent too.
  virtual void stress_only(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S) const {
    Matrix9d D;
    stress(E, R, S, D);
  }
  virtual std::unique_ptr<Material> clone() const = 0;
  virtual std::string name() const = 0;
};

// What every law with a parameter struct shares: the constructor keeps the parameters after
// Parameters::validate() (std::invalid_argument with its message otherwise), clone() copies the
// law, parameters() returns them. A law derives as `class X final : public MaterialLaw<X, XParameters>`.
template <class Law, class Parameters>
class MaterialLaw : public Material {
 public:
  explicit MaterialLaw(const Parameters& p) : p_(p) {
    if (std::string m = p_.validate(); !m.empty()) throw std::invalid_argument(m);
  }
  std::unique_ptr<Material> clone() const override { return std::make_unique<Law>(p_); }
  const Parameters& parameters() const { return p_; }

 protected:
  Parameters p_;
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

class Guccione final : public MaterialLaw<Guccione, GuccioneParameters> {
 public:
  using MaterialLaw::MaterialLaw;
  double energy(const Eigen::Matrix3d& E, const Frame& R) const override;
  void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const override;
  std::string name() const override { return "guccione"; }

 private:
  void stress_full(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const;
};

// Tensor operators on the row-major vec of 3x3 tensors (vec(A)[3I + J] = A(I, J)), shared by the
// laws here and in electromechanics.cpp.
Matrix9d tensor_outer(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B);  // A_IJ B_KL
Matrix9d tensor_sym_product(const Eigen::Matrix3d& A);  // (A_IK A_JL + A_IL A_JK) / 2

// The isochoric invariants of C = I + 2E, f1 = I3^-1/3 I1 and f2 = I3^-2/3 I2, with their
// derivatives with respect to C: df (3x3) and d2f (9x9, on the vec above; left unset when
// `second` is false).
struct IsochoricInvariants {
  double f1 = 0.0, f2 = 0.0;
  Eigen::Matrix3d df1, df2;
  Matrix9d d2f1, d2f2;
};
IsochoricInvariants isochoric_invariants(const Eigen::Matrix3d& E, bool second = true);

// Mooney-Rivlin on the isochoric invariants (the thesis law, docs/models.md s.4):
//   W = c1 (J^-2/3 I1 - 3) + c2 (J^-4/3 I2 - 3); the volumetric penalty kappa/2 (J - 1)^2 is the
// mixed formulation's bulk modulus (MechanicsOptions::bulk_modulus).
struct MooneyRivlinParameters {
  double c1 = 1.0e3;  // [Pa]
  double c2 = 0.2e3;  // [Pa]
  std::string validate() const;
};

class MooneyRivlin final : public MaterialLaw<MooneyRivlin, MooneyRivlinParameters> {
 public:
  using MaterialLaw::MaterialLaw;
  double energy(const Eigen::Matrix3d& E, const Frame& R) const override;
  void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const override;
  void stress_only(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S) const override;
  std::string name() const override { return "mooney-rivlin"; }
};

// Modified Holzapfel-Ogden law of the cardiac elastodynamics benchmark (Arostica et al. 2025,
// CMAME 435:117485, doi:10.1016/j.cma.2024.117485, Benchmark 1;
// experiments/arostica-benchmark/specification.md s.2):
//   W = a/(2b) [exp(b (I1bar - 3)) - 1]
//     + sum_{i=f,s} a_i/(2 b_i) chi(I4i) [exp(b_i (I4i - 1)^2) - 1]
//     + a_fs/(2 b_fs) [exp(b_fs I8fs^2) - 1]
//     + W_vol,
// I1bar = J^-2/3 tr C (isochoric), I4f = f.Cf, I4s = s.Cs, I8fs = f.Cs on the full C, and the
// smooth tension switch chi(I4) = 1 / (1 + exp(-k (I4 - 1))). W_vol is the Simo-Taylor 1991
// penalty kappa/4 (J^2 - 1 - 2 ln J) when kappa > 0 (then the mechanics runs displacement-only,
// MechanicsOptions::displacement_only); kappa = 0 leaves compressibility to the mixed u-p term.
struct HolzapfelOgdenParameters {
  double a = 59.0;        // [Pa]
  double b = 8.023;
  double a_f = 18472.0;   // [Pa]
  double b_f = 16.026;
  double a_s = 2481.0;    // [Pa]
  double b_s = 11.120;
  double a_fs = 216.0;    // [Pa]
  double b_fs = 11.436;
  double k = 100.0;       // switch sharpness
  double kappa = 1.0e6;   // [Pa] Simo-Taylor 1991 penalty; 0: none
  std::string validate() const;
};

class HolzapfelOgden final : public MaterialLaw<HolzapfelOgden, HolzapfelOgdenParameters> {
 public:
  using MaterialLaw::MaterialLaw;
  double energy(const Eigen::Matrix3d& E, const Frame& R) const override;
  void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const override;
  std::string name() const override { return "holzapfel-ogden"; }
};

}  // namespace sigmaheart::model::fem
