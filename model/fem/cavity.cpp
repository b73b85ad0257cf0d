#include "model/fem/cavity.h"

#include "model/fem/element.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace sigmaheart::model::fem {

std::string AhaOptions::validate() const {
  if (!(reference_direction.norm() > 0)) return "reference_direction must be non-zero";
  if (apical_cap_fraction < 0 || apical_cap_fraction >= 1.0 / 3.0) return "apical_cap_fraction must be in [0, 1/3)";
  return {};
}

std::vector<int> base_ring(const Mesh& mesh, int endo_tag, int base_tag) {
  const auto endo = mesh.nodes_with_tag(endo_tag);
  const auto base = mesh.nodes_with_tag(base_tag);
  std::vector<int> ring;
  std::set_intersection(endo.begin(), endo.end(), base.begin(), base.end(), std::back_inserter(ring));
  return ring;
}

int aha_segment(double h, double phi_deg, double cap) {
  if (h < 0.0 || h < cap) return 17;
  auto wrap = [](double a) {
    a = std::fmod(a, 360.0);
    return a < 0 ? a + 360.0 : a;
  };
  if (h < 1.0 / 3.0) return 13 + std::min(3, static_cast<int>(wrap(phi_deg + 75.0) / 90.0));
  const int k = std::min(5, static_cast<int>(wrap(phi_deg + 60.0) / 60.0));
  return (h < 2.0 / 3.0 ? 7 : 1) + k;
}

AhaLabels aha_labels(const Mesh& mesh, const AhaOptions& o) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("AhaOptions: " + m);
  const auto ring = base_ring(mesh, o.endo_tag, o.base_tag);
  if (ring.empty()) throw std::invalid_argument("aha_labels: the mesh has no endocardial base ring");
  AhaFrame f;
  f.centre.setZero();
  for (int n : ring) f.centre += mesh.nodes.row(n).transpose();
  f.centre /= static_cast<double>(ring.size());
  // Axis: mean outward normal of the base faces (points apex -> base).
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k)
    if (mesh.face_tag[static_cast<size_t>(k)] == o.base_tag) {
      const Eigen::Vector3d p0 = mesh.nodes.row(mesh.faces(k, 0)), p1 = mesh.nodes.row(mesh.faces(k, 1)),
                            p2 = mesh.nodes.row(mesh.faces(k, 2));
      a += (p1 - p0).cross(p2 - p0);
    }
  f.axis = a.normalized();
  double hmin = 0;
  bool first = true;
  for (int n : mesh.nodes_with_tag(o.endo_tag)) {
    const double h = (mesh.nodes.row(n).transpose() - f.centre).dot(f.axis);
    if (first || h < hmin) {
      hmin = h;
      f.apex = mesh.nodes.row(n).transpose();
      first = false;
    }
  }
  f.length = -hmin;
  return aha_labels_in_frame(mesh, mesh.nodes, f, o.reference_direction, o, ring);
}

AhaLabels aha_labels_in_frame(const Mesh& mesh, const Eigen::MatrixX3d& x, const AhaFrame& f,
                              const Eigen::Vector3d& reference_direction, const AhaOptions& o, std::vector<int> ring) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("AhaOptions: " + m);
  if (x.rows() != mesh.n_nodes()) throw std::invalid_argument("aha_labels_in_frame: x needs one row per node");
  AhaLabels L;
  L.frame = f;
  L.base_ring = std::move(ring);
  Eigen::Vector3d ref = reference_direction - reference_direction.dot(f.axis) * f.axis;
  if (ref.norm() < 1e-12) throw std::invalid_argument("aha_labels: reference direction is parallel to the axis");
  ref.normalize();
  const Eigen::Vector3d ref2 = f.axis.cross(ref);
  // A centroid on a boundary (the apex fan's triangles bisect 30-deg cells at -75, 15, 105, 195
  // deg) would be classified by round-off, differently for the same mesh in another frame (the
  // simulator's, or landmarks read back by `observe`): h and phi are rounded to 1e-12 and 1e-9
  // deg first, so such a face goes to the segment counter-clockwise of (or below) the boundary.
  auto classify = [&](const Eigen::Vector3d& p) {
    const double h = std::round((p - f.apex).dot(f.axis) / f.length * 1e12) / 1e12;
    const Eigen::Vector3d d = p - f.centre;
    const double phi = std::round(std::atan2(d.dot(ref2), d.dot(ref)) * 180.0 / std::numbers::pi * 1e9) / 1e9;
    return aha_segment(h, phi, 0.0);
  };
  auto centroid = [&](auto&& row, int n) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < n; ++k) c += x.row(row(k)).transpose();
    return Eigen::Vector3d(c / static_cast<double>(n));
  };
  L.element_segment.resize(static_cast<size_t>(mesh.n_tets()));
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
    const Eigen::Vector3d c = centroid([&](int k) { return mesh.tets(e, k); }, 4);
    int s = classify(c);
    // The cap rule applies to the wall too when a cap fraction is requested.
    if (o.apical_cap_fraction > 0 && (c - f.apex).dot(f.axis) / f.length < o.apical_cap_fraction) s = 17;
    L.element_segment[static_cast<size_t>(e)] = s;
  }
  L.face_segment.assign(static_cast<size_t>(mesh.faces.rows()), 0);
  for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k) {
    if (mesh.face_tag[static_cast<size_t>(k)] != o.endo_tag) continue;
    const Eigen::Vector3d c = centroid([&](int j) { return mesh.faces(k, j); }, 3);
    const double h = (c - f.apex).dot(f.axis) / f.length;
    int s = classify(c);
    if (h < o.apical_cap_fraction) s = 17;
    L.face_segment[static_cast<size_t>(k)] = s;
  }
  return L;
}

CavityVolumes cavity_volumes(const Mesh& mesh, const Eigen::MatrixX3d& x, const AhaLabels& labels, bool with_gradient) {
  if (x.rows() != mesh.n_nodes()) throw std::invalid_argument("cavity_volumes: x needs one row per node");
  if (labels.face_segment.size() != static_cast<size_t>(mesh.faces.rows()))
    throw std::invalid_argument("cavity_volumes: labels do not belong to this mesh");
  const Eigen::Vector3d a = labels.frame.axis;
  const std::vector<int>& ring = labels.base_ring;
  if (ring.empty()) throw std::invalid_argument("cavity_volumes: no base ring");
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int n : ring) c += x.row(n).transpose();
  c /= static_cast<double>(ring.size());
  CavityVolumes out;
  if (with_gradient) out.gradient = Eigen::VectorXd::Zero(3 * mesh.n_nodes());
  const int npf = mesh.nodes_per_face();
  const auto& rule = tri_rule(mesh.order == 2 ? 4 : 2);
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Eigen::MatrixXd xf(npf, 3);
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - a * a.transpose();
  double dV_dc_scalar = 0.0;  // dV/dc = dV_dc_scalar * a
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const int seg = labels.face_segment[static_cast<size_t>(f)];
    if (seg == 0) continue;
    for (int k = 0; k < npf; ++k) xf.row(k) = x.row(mesh.faces(f, k));
    for (const auto& qp : rule) {
      tri_shape(mesh.order, qp.xi, N, dN);
      const Eigen::Vector3d xq = xf.transpose() * N;
      const Eigen::Vector3d xa = xf.transpose() * dN.col(0), xb = xf.transpose() * dN.col(1);
      const Eigen::Vector3d n = -xa.cross(xb);  // leaves the cavity (the face normal leaves the solid)
      const Eigen::Vector3d d = xq - c;
      const double s = d.dot(a), na = n.dot(a);
      out.cavity += qp.weight * s * na;
      out.regional[static_cast<size_t>(seg - 1)] += qp.weight * 0.5 * (P * d).dot(n);
      if (with_gradient) {
        dV_dc_scalar -= qp.weight * na;
        for (int b = 0; b < npf; ++b) {
          // d(s)/dx_b = N_b a ; d(na)/dx_b = -(dN_b,xi (x_eta x a) + dN_b,eta (a x x_xi)).
          const Eigen::Vector3d g = qp.weight * (N[b] * na * a - s * (dN(b, 0) * xb.cross(a) + dN(b, 1) * a.cross(xa)));
          out.gradient.segment<3>(3 * mesh.faces(f, b)) += g;
        }
      }
    }
  }
  if (with_gradient)
    for (int n : ring) out.gradient.segment<3>(3 * n) += dV_dc_scalar / static_cast<double>(ring.size()) * a;
  return out;
}

}  // namespace sigmaheart::model::fem
