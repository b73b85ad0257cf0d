#include "model/fem/fibres.h"

#include "model/fem/element.h"

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {
constexpr double kDeg = std::numbers::pi / 180.0;

// Completes an orthonormal right-handed (e_c, e_l, e_t) from possibly degenerate inputs.
void orthonormalise(Eigen::Vector3d& e_c, Eigen::Vector3d& e_l, Eigen::Vector3d& e_t) {
  e_t.normalize();
  e_l -= e_l.dot(e_t) * e_t;
  if (e_l.norm() < 1e-12) e_l = e_t.unitOrthogonal();
  e_l.normalize();
  e_c = e_l.cross(e_t);
}
}  // namespace

std::string FibreOptions::validate() const {
  if (std::abs(alpha_endo_deg) > 180 || std::abs(alpha_epi_deg) > 180) return "helix angles must lie in [-180, 180] deg";
  return {};
}

Frame helix_frame(const Eigen::Vector3d& e_c, const Eigen::Vector3d& e_l, const Eigen::Vector3d& e_t, double alpha) {
  Frame R;
  const Eigen::Vector3d f = (std::cos(alpha) * e_c + std::sin(alpha) * e_l).normalized();
  const Eigen::Vector3d n = e_t.normalized();
  R.col(0) = f;
  R.col(1) = n.cross(f);
  R.col(2) = n;
  return R;
}

std::vector<Frame> ellipsoid_fibres(const Mesh& mesh, const EllipsoidGeometry& g, const FibreOptions& o,
                                    int quadrature_degree) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("FibreOptions: " + m);
  return frames_at_quadrature_points(mesh, quadrature_degree, [&](Eigen::Index e, const Eigen::VectorXd& N) {
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int a = 0; a < mesh.nodes_per_tet(); ++a) x += N[a] * mesh.nodes.row(mesh.tets(e, a)).transpose();
    const Eigen::Vector3d c = g.coordinates(x);
    const double t = std::clamp(c[0], 0.0, 1.0), th = c[1], v = c[2];
    const double rs = g.r_short(t), rl = g.r_long(t);
    // d/dtheta of the position (apex -> base) and d/dv (counter-clockwise about +z).
    Eigen::Vector3d e_l(rs * std::cos(th) * std::cos(v), rs * std::cos(th) * std::sin(v), rl * std::sin(th));
    Eigen::Vector3d e_c;  // = e_l x e_t, counter-clockwise about +z
    // Outward normal of the ellipsoid through x (endo -> epi).
    Eigen::Vector3d e_t(std::sin(th) * std::cos(v) / rs, std::sin(th) * std::sin(v) / rs, -std::cos(th) / rl);
    if (th < 1e-9) {  // on the axis: any circumferential direction; the fibre angle is a convention
      e_t = Eigen::Vector3d(0, 0, -1);
      e_l = Eigen::Vector3d(1, 0, 0);
    }
    orthonormalise(e_c, e_l, e_t);
    const double alpha = (o.alpha_endo_deg + t * (o.alpha_epi_deg - o.alpha_endo_deg)) * kDeg;
    return helix_frame(e_c, e_l, e_t, alpha);
  });
}

std::vector<Frame> frames_at_quadrature_points(
    const Mesh& mesh, int quadrature_degree,
    const std::function<Frame(Eigen::Index e, const Eigen::VectorXd& N)>& frame) {
  const auto& rule = tet_rule(quadrature_degree);
  std::vector<Frame> out;
  out.reserve(static_cast<size_t>(mesh.n_tets()) * rule.size());
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e)
    for (const auto& qp : rule) {
      tet_shape(mesh.order, qp.xi, N, dN);
      out.push_back(frame(e, N));
    }
  return out;
}

Eigen::VectorXd transmural_coordinate(const Mesh& mesh, int endo_tag, int epi_tag) {
  // Linear Laplace problem on the vertices (P1), mid-edge nodes interpolated.
  const int nv = mesh.n_vertices;
  std::vector<Eigen::Triplet<double>> trip;
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
    Eigen::Matrix3d J;
    for (int d = 0; d < 3; ++d) J.col(d) = (mesh.nodes.row(mesh.tets(e, d + 1)) - mesh.nodes.row(mesh.tets(e, 0))).transpose();
    const double vol = J.determinant() / 6.0;
    Eigen::Matrix<double, 4, 3> dL;
    dL.row(0) = Eigen::RowVector3d(-1, -1, -1);
    dL.bottomRows<3>() = Eigen::Matrix3d::Identity();
    const Eigen::Matrix<double, 4, 3> G = dL * J.inverse();
    const Eigen::Matrix4d k = vol * G * G.transpose();
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) trip.emplace_back(mesh.tets(e, a), mesh.tets(e, b), k(a, b));
  }
  Eigen::SparseMatrix<double> K(nv, nv);
  K.setFromTriplets(trip.begin(), trip.end());
  Eigen::VectorXd val = Eigen::VectorXd::Constant(nv, -1.0);
  for (int n : mesh.nodes_with_tag(endo_tag))
    if (n < nv) val[n] = 0.0;
  for (int n : mesh.nodes_with_tag(epi_tag))
    if (n < nv) val[n] = 1.0;
  std::vector<int> free_idx(static_cast<size_t>(nv), -1);
  int nf = 0;
  for (int i = 0; i < nv; ++i)
    if (val[i] < 0) free_idx[static_cast<size_t>(i)] = nf++;
  if (nf == nv) throw std::invalid_argument("transmural_coordinate: no endocardial or epicardial faces");
  std::vector<Eigen::Triplet<double>> tf;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(nf);
  for (int c = 0; c < K.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(K, c); it; ++it) {
      const int r = static_cast<int>(it.row());
      const int fr = free_idx[static_cast<size_t>(r)], fc = free_idx[static_cast<size_t>(c)];
      if (fr < 0) continue;
      if (fc >= 0) tf.emplace_back(fr, fc, it.value());
      else rhs[fr] -= it.value() * val[c];
    }
  Eigen::SparseMatrix<double> Kf(nf, nf);
  Kf.setFromTriplets(tf.begin(), tf.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(Kf);
  if (ldlt.info() != Eigen::Success) throw std::runtime_error("transmural_coordinate: factorisation failed");
  const Eigen::VectorXd xf = ldlt.solve(rhs);
  Eigen::VectorXd t(mesh.n_nodes());
  for (int i = 0; i < nv; ++i) t[i] = free_idx[static_cast<size_t>(i)] >= 0 ? xf[free_idx[static_cast<size_t>(i)]] : val[i];
  if (mesh.order == 2)
    for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) t[mesh.tets(e, tet10_edge_slot(a, b))] = 0.5 * (t[mesh.tets(e, a)] + t[mesh.tets(e, b)]);
  return t;
}

std::vector<Frame> rule_based_fibres(const Mesh& mesh, const Eigen::VectorXd& t, const Eigen::Vector3d& axis,
                                     const FibreOptions& o, int quadrature_degree) {
  if (t.size() != mesh.n_nodes()) throw std::invalid_argument("rule_based_fibres: t needs one value per node");
  const auto& rule = tet_rule(quadrature_degree);
  std::vector<Frame> out;
  out.reserve(static_cast<size_t>(mesh.n_tets()) * rule.size());
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
    const int npt = mesh.nodes_per_tet();
    Eigen::MatrixXd X(npt, 3);
    Eigen::VectorXd te(npt);
    for (int a = 0; a < npt; ++a) {
      X.row(a) = mesh.nodes.row(mesh.tets(e, a));
      te[a] = t[mesh.tets(e, a)];
    }
    for (const auto& qp : rule) {
      tet_shape(mesh.order, qp.xi, N, dN);
      const Eigen::Matrix3d J0 = X.transpose() * dN;
      Eigen::Vector3d e_t = J0.inverse().transpose() * (dN.transpose() * te);
      if (e_t.norm() < 1e-300) e_t = Eigen::Vector3d::UnitX();
      Eigen::Vector3d e_l = axis, e_c;
      orthonormalise(e_c, e_l, e_t);
      const double tq = std::clamp(N.dot(te), 0.0, 1.0);
      const double alpha = (o.alpha_endo_deg + tq * (o.alpha_epi_deg - o.alpha_endo_deg)) * kDeg;
      out.push_back(helix_frame(e_c, e_l, e_t, alpha));
    }
  }
  return out;
}

std::vector<Frame> uniform_fibres(const Mesh& mesh, const Eigen::Vector3d& f, const Eigen::Vector3d& s) {
  Frame R;
  R.col(0) = f.normalized();
  R.col(1) = (s - s.dot(R.col(0)) * R.col(0)).normalized();
  R.col(2) = R.col(0).cross(R.col(1));
  return std::vector<Frame>(static_cast<size_t>(mesh.n_tets()), R);
}

}  // namespace sigmaheart::model::fem
