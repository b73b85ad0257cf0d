#include "model/fem/material.h"

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {

// T with vec(R^T E R) = T vec(E) (row-major vec): T(3a+b, 3I+J) = R(I,a) R(J,b).
Matrix9d rotation_operator(const Frame& R) {
  Matrix9d T;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int I = 0; I < 3; ++I)
        for (int J = 0; J < 3; ++J) T(3 * a + b, 3 * I + J) = R(I, a) * R(J, b);
  return T;
}

Eigen::Matrix<double, 9, 1> vec(const Eigen::Matrix3d& A) {
  Eigen::Matrix<double, 9, 1> v;
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J) v[3 * I + J] = A(I, J);
  return v;
}

Eigen::Matrix3d unvec(const Eigen::Matrix<double, 9, 1>& v) {
  Eigen::Matrix3d A;
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J) A(I, J) = v[3 * I + J];
  return A;
}

}  // namespace

Matrix9d tensor_outer(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) { return vec(A) * vec(B).transpose(); }

// Symmetrised "A dC B" operator for symmetric A: X -> 1/2 (A X A^T + A X^T A^T) components
// (A_IK A_JL + A_IL A_JK)/2.
Matrix9d tensor_sym_product(const Eigen::Matrix3d& A) {
  Matrix9d M;
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J)
      for (int K = 0; K < 3; ++K)
        for (int L = 0; L < 3; ++L) M(3 * I + J, 3 * K + L) = 0.5 * (A(I, K) * A(J, L) + A(I, L) * A(J, K));
  return M;
}

IsochoricInvariants isochoric_invariants(const Eigen::Matrix3d& E, bool second) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d C = I + 2.0 * E;
  const Eigen::Matrix3d Ci = C.inverse();
  const double I1 = C.trace(), I2 = 0.5 * (I1 * I1 - (C * C).trace()), I3 = C.determinant();
  const double a = std::pow(I3, -1.0 / 3.0), b = a * a;
  const Eigen::Matrix3d dg = I1 * I - C;  // dI2/dC
  IsochoricInvariants f;
  f.f1 = a * I1;
  f.f2 = b * I2;
  f.df1 = a * (I - I1 / 3.0 * Ci);
  f.df2 = b * (dg - 2.0 / 3.0 * I2 * Ci);
  if (!second) return f;
  const Matrix9d ICi = tensor_sym_product(Ci);
  f.d2f1 = -a / 3.0 * (tensor_outer(I, Ci) + tensor_outer(Ci, I) - I1 / 3.0 * tensor_outer(Ci, Ci) - I1 * ICi);
  const Matrix9d d2g = tensor_outer(I, I) - tensor_sym_product(I);
  f.d2f2 = -2.0 / 3.0 * b * tensor_outer(dg - 2.0 / 3.0 * I2 * Ci, Ci) +
           b * (d2g - 2.0 / 3.0 * tensor_outer(Ci, dg) + 2.0 / 3.0 * I2 * ICi);
  return f;
}

std::string GuccioneParameters::validate() const {
  if (!(C > 0)) return "Guccione C must be positive";
  if (!(bf >= 0 && bt >= 0 && bfs >= 0)) return "Guccione bf, bt, bfs must be non-negative";
  return {};
}

namespace {
Eigen::Matrix<double, 9, 1> guccione_weights(const GuccioneParameters& p) {
  // Local components ordered (f, s, n) x (f, s, n).
  Eigen::Matrix<double, 9, 1> b;
  b << p.bf, p.bfs, p.bfs,  //
      p.bfs, p.bt, p.bt,    //
      p.bfs, p.bt, p.bt;
  return b;
}
}  // namespace

namespace {
Eigen::Matrix3d isochoric_strain(const Eigen::Matrix3d& E) {
  const Eigen::Matrix3d C = Eigen::Matrix3d::Identity() + 2.0 * E;
  return 0.5 * (std::pow(C.determinant(), -1.0 / 3.0) * C - Eigen::Matrix3d::Identity());
}
}  // namespace

double Guccione::energy(const Eigen::Matrix3d& E_in, const Frame& R) const {
  const Eigen::Matrix3d E = p_.isochoric ? isochoric_strain(E_in) : E_in;
  const Eigen::Matrix3d El = R.transpose() * E * R;
  const auto b = guccione_weights(p_);
  const double Q = (b.array() * vec(El).array().square()).sum();
  return 0.5 * p_.C * (std::exp(Q) - 1.0);
}

void Guccione::stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const {
  if (!p_.isochoric) {
    stress_full(E, R, S, D);
    return;
  }
  // Isochoric split (Holzapfel, Nonlinear Solid Mechanics, eq. 6.91 and 6.168):
  //   S = J^-2/3 DEV(S_bar), DEV(X) = X - (X:C)/3 C^-1,
  //   D = P (J^-4/3 D_bar) P^T + 2/3 (J^-2/3 S_bar:C) P~ - 2/3 (C^-1 (x) S + S (x) C^-1),
  //   P = I - 1/3 C^-1 (x) C,  P~ = C^-1 (.) C^-1 - 1/3 C^-1 (x) C^-1.
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d C = I + 2.0 * E;
  const Eigen::Matrix3d Ci = C.inverse();
  const double j23 = std::pow(C.determinant(), -1.0 / 3.0);  // J^-2/3
  Eigen::Matrix3d Sb;
  Matrix9d Db;
  stress_full(0.5 * (j23 * C - I), R, Sb, Db);
  const double trS = (Sb.array() * C.array()).sum();
  S = j23 * (Sb - trS / 3.0 * Ci);
  const Matrix9d Pm = tensor_sym_product(I) - vec(Ci) * vec(C).transpose() / 3.0;
  const Matrix9d Pt = tensor_sym_product(Ci) - tensor_outer(Ci, Ci) / 3.0;
  D = Pm * (j23 * j23 * Db) * Pm.transpose() + 2.0 / 3.0 * j23 * trS * Pt - 2.0 / 3.0 * (tensor_outer(Ci, S) + tensor_outer(S, Ci));
}

void Guccione::stress_full(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const {
  // Q = e_l^T B e_l with e_l = T e, B diagonal: dQ/de = 2 T^T B e_l.
  const Matrix9d T = rotation_operator(R);
  const auto b = guccione_weights(p_);
  const Eigen::Matrix<double, 9, 1> el = T * vec(E);
  const double Q = (b.array() * el.array().square()).sum();
  const double eQ = std::exp(Q);
  const Eigen::Matrix<double, 9, 1> g = T.transpose() * (b.array() * el.array()).matrix();  // dQ/de / 2
  S = unvec(p_.C * eQ * g);
  // T^T B T treats E_fs and E_sf as independent; the symmetric projection gives the minor-
  // symmetric tangent that acts correctly on any (also non-symmetric) F^T dF.
  const Matrix9d Psym = tensor_sym_product(Eigen::Matrix3d::Identity());
  D = p_.C * eQ * (Psym * T.transpose() * b.asDiagonal() * T * Psym + 2.0 * g * g.transpose());
}

std::string MooneyRivlinParameters::validate() const {
  if (!(c1 > 0) || !(c2 >= 0)) return "Mooney-Rivlin needs c1 > 0, c2 >= 0";
  return {};
}

double MooneyRivlin::energy(const Eigen::Matrix3d& E, const Frame&) const {
  const Eigen::Matrix3d C = Eigen::Matrix3d::Identity() + 2.0 * E;
  const double I1 = C.trace(), I2 = 0.5 * (I1 * I1 - (C * C).trace()), I3 = C.determinant();
  return p_.c1 * (std::pow(I3, -1.0 / 3.0) * I1 - 3.0) + p_.c2 * (std::pow(I3, -2.0 / 3.0) * I2 - 3.0);
}

void MooneyRivlin::stress(const Eigen::Matrix3d& E, const Frame&, Eigen::Matrix3d& S, Matrix9d& D) const {
  // W(C) = c1 f1 + c2 f2 (isochoric invariants); S = 2 dW/dC, D = 4 d2W/dC2.
  const IsochoricInvariants f = isochoric_invariants(E);
  S = 2.0 * (p_.c1 * f.df1 + p_.c2 * f.df2);
  D = 4.0 * (p_.c1 * f.d2f1 + p_.c2 * f.d2f2);
}

void MooneyRivlin::stress_only(const Eigen::Matrix3d& E, const Frame&, Eigen::Matrix3d& S) const {
  const IsochoricInvariants f = isochoric_invariants(E, false);
  S = 2.0 * (p_.c1 * f.df1 + p_.c2 * f.df2);
}

std::string HolzapfelOgdenParameters::validate() const {
  if (!(a > 0 && b > 0)) return "Holzapfel-Ogden a and b must be positive (a in Pa)";
  if (!(a_f >= 0 && a_s >= 0 && a_fs >= 0)) return "Holzapfel-Ogden a_f, a_s, a_fs must be >= 0 [Pa]";
  if (!(b_f > 0 && b_s > 0 && b_fs > 0)) return "Holzapfel-Ogden b_f, b_s, b_fs must be positive";
  if (!(k > 0)) return "Holzapfel-Ogden switch sharpness k must be positive";
  if (!(kappa >= 0) || std::isinf(kappa)) return "Holzapfel-Ogden kappa must be finite and >= 0 [Pa]";
  return {};
}

namespace {
// psi(I4) = a/(2b) chi(I4) [exp(b (I4 - 1)^2) - 1] and its first two derivatives in I4.
struct Scalar3 {
  double v, d1, d2;
};
Scalar3 switched_fibre_term(double I4, double a, double b, double k) {
  const double x = I4 - 1.0;
  const double chi = 1.0 / (1.0 + std::exp(-k * x));
  const double chi1 = k * chi * (1.0 - chi);
  const double chi2 = k * chi1 * (1.0 - 2.0 * chi);
  const double e = std::exp(b * x * x);
  const double c = a / (2.0 * b);
  const double g = e - 1.0, g1 = 2.0 * b * x * e, g2 = e * (2.0 * b + 4.0 * b * b * x * x);
  return {c * chi * g, c * (chi1 * g + chi * g1), c * (chi2 * g + 2.0 * chi1 * g1 + chi * g2)};
}
}  // namespace

double HolzapfelOgden::energy(const Eigen::Matrix3d& E, const Frame& R) const {
  const Eigen::Matrix3d C = Eigen::Matrix3d::Identity() + 2.0 * E;
  const Eigen::Vector3d f = R.col(0), s = R.col(1);
  const double I3 = C.determinant();
  const double I1b = std::pow(I3, -1.0 / 3.0) * C.trace();
  const double I4f = f.dot(C * f), I4s = s.dot(C * s), I8 = f.dot(C * s);
  double W = p_.a / (2 * p_.b) * (std::exp(p_.b * (I1b - 3.0)) - 1.0);
  W += switched_fibre_term(I4f, p_.a_f, p_.b_f, p_.k).v + switched_fibre_term(I4s, p_.a_s, p_.b_s, p_.k).v;
  W += p_.a_fs / (2 * p_.b_fs) * (std::exp(p_.b_fs * I8 * I8) - 1.0);
  if (p_.kappa > 0) W += 0.25 * p_.kappa * (I3 - 1.0 - std::log(I3));  // J^2 - 1 - 2 ln J
  return W;
}

void HolzapfelOgden::stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const {
  // S = 2 dW/dC, D = 4 d2W/dC2 on the invariants' derivatives.
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d C = I + 2.0 * E;
  const Eigen::Vector3d f = R.col(0), s = R.col(1);
  const IsochoricInvariants iso = isochoric_invariants(E);
  const double e1 = std::exp(p_.b * (iso.f1 - 3.0));
  Eigen::Matrix3d dW = 0.5 * p_.a * e1 * iso.df1;
  Matrix9d d2W = 0.5 * p_.a * e1 * (p_.b * tensor_outer(iso.df1, iso.df1) + iso.d2f1);
  const Eigen::Matrix3d Af = f * f.transpose(), As = s * s.transpose();
  const Eigen::Matrix3d Afs = 0.5 * (f * s.transpose() + s * f.transpose());
  const Scalar3 pf = switched_fibre_term(f.dot(C * f), p_.a_f, p_.b_f, p_.k);
  const Scalar3 ps = switched_fibre_term(s.dot(C * s), p_.a_s, p_.b_s, p_.k);
  dW += pf.d1 * Af + ps.d1 * As;
  d2W += pf.d2 * tensor_outer(Af, Af) + ps.d2 * tensor_outer(As, As);
  const double I8 = f.dot(C * s);
  const double e8 = std::exp(p_.b_fs * I8 * I8);
  dW += p_.a_fs * I8 * e8 * Afs;
  d2W += p_.a_fs * e8 * (1.0 + 2.0 * p_.b_fs * I8 * I8) * tensor_outer(Afs, Afs);
  S = 2.0 * dW;
  D = 4.0 * d2W;
  if (p_.kappa > 0) {
    // Simo-Taylor 1991: S_vol = kappa/2 (J^2 - 1) C^-1, D_vol = kappa [J^2 C^-1 (x) C^-1 - (J^2 - 1) C^-1 (.) C^-1].
    const Eigen::Matrix3d Ci = C.inverse();
    const double J2 = C.determinant();
    S += 0.5 * p_.kappa * (J2 - 1.0) * Ci;
    D += p_.kappa * (J2 * tensor_outer(Ci, Ci) - (J2 - 1.0) * tensor_sym_product(Ci));
  }
}

}  // namespace sigmaheart::model::fem
