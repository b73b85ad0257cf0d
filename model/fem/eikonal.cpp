#include "model/fem/eikonal.h"

#include "model/fem/cavity.h"
#include "model/fem/element.h"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace sigmaheart::model::fem {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string vec_str(const Eigen::Vector3d& x) {
  std::ostringstream os;
  os << "(" << x[0] << ", " << x[1] << ", " << x[2] << ") m";
  return os.str();
}

double norm_m(const Eigen::Matrix3d& M, const Eigen::Vector3d& d) { return std::sqrt(std::max(0.0, d.dot(M * d))); }

// min over l in [0, 1] of t_j + l (t_i - t_j) + |r - l e|_M with r = v - x_j, e = x_i - x_j: the
// interior stationary point when it exists and lies inside the edge, else +inf (the end points
// are candidates of their own).
double edge_update(const Eigen::Matrix3d& M, const Eigen::Vector3d& xv, const Eigen::Vector3d& xi, double ti,
                   const Eigen::Vector3d& xj, double tj) {
  const Eigen::Vector3d r = xv - xj, e = xi - xj;
  const Eigen::Vector3d Me = M * e;
  const double A = e.dot(Me), b = r.dot(Me), c = r.dot(M * r);
  const double delta = ti - tj;
  if (!(A > 0) || delta * delta >= A) return kInf;  // a steeper time difference than the metric allows
  const double w0 = std::max(0.0, c - b * b / A);   // |r|_M^2 minus its M-projection on e
  const double n = std::sqrt(w0 / (1.0 - delta * delta / A));
  const double l = (b - n * delta) / A;
  if (l < 0.0 || l > 1.0) return kInf;
  return tj + l * delta + n;
}

// min over the face (x1, x2, x3) of the linear interpolant plus |v - x|_M (derivation: with
// E = [x1 - x3, x2 - x3], A = E^T M E, b = E^T M r, d = (t1 - t3, t2 - t3), the stationary point
// satisfies E^T M (r - E l) = |r - E l|_M d, so r - E l = w0 + n E A^-1 d with w0 M-orthogonal to
// the face, n^2 = |w0|^2 / (1 - d^T A^-1 d) and l = A^-1 (b - n d)). +inf when it is outside.
double face_update(const Eigen::Matrix3d& M, const Eigen::Vector3d& xv, const Eigen::Vector3d& x1, double t1,
                   const Eigen::Vector3d& x2, double t2, const Eigen::Vector3d& x3, double t3) {
  Eigen::Matrix<double, 3, 2> E;
  E.col(0) = x1 - x3;
  E.col(1) = x2 - x3;
  const Eigen::Vector3d r = xv - x3;
  const Eigen::Matrix<double, 3, 2> ME = M * E;
  const Eigen::Matrix2d A = E.transpose() * ME;
  const double det = A.determinant();
  if (!(det > 1e-14 * A.trace() * A.trace())) return kInf;  // flat face
  const Eigen::Matrix2d Ai = A.inverse();
  const Eigen::Vector2d b = ME.transpose() * r;
  const Eigen::Vector2d d(t1 - t3, t2 - t3);
  const double psq = d.dot(Ai * d);
  if (psq >= 1.0) return kInf;
  const double w0 = std::max(0.0, r.dot(M * r) - b.dot(Ai * b));
  const double n = std::sqrt(w0 / (1.0 - psq));
  const Eigen::Vector2d l = Ai * (b - n * d);
  if (l[0] < 0.0 || l[1] < 0.0 || l[0] + l[1] > 1.0) return kInf;
  return t3 + l.dot(d) + n;
}

// Best time of vertex `xv` from the points `x[0..k)` with finite times `t[0..k)`, k in 1..3.
double local_update(const Eigen::Matrix3d& M, const Eigen::Vector3d& xv, const Eigen::Vector3d* x, const double* t,
                    int k) {
  double best = kInf;
  for (int i = 0; i < k; ++i) best = std::min(best, t[i] + norm_m(M, xv - x[i]));
  for (int i = 0; i < k; ++i)
    for (int j = i + 1; j < k; ++j) best = std::min(best, edge_update(M, xv, x[i], t[i], x[j], t[j]));
  if (k == 3) best = std::min(best, face_update(M, xv, x[0], t[0], x[1], t[1], x[2], t[2]));
  return best;
}

void check_velocities(const ConductionVelocities& v, size_t index) {
  const double c[3] = {v.fibre, v.sheet, v.normal};
  const char* names[3] = {"fibre", "sheet", "normal"};
  for (int k = 0; k < 3; ++k)
    if (!(c[k] > 0.0) || !std::isfinite(c[k]))
      throw std::invalid_argument("solve_eikonal: " + std::string(names[k]) + " conduction velocity " +
                                  std::to_string(c[k]) + " m/s of entry " + std::to_string(index) +
                                  " is not positive and finite");
}

void check_frame(const Frame& R, size_t index) {
  const double err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(err < 1e-6))
    throw std::invalid_argument("solve_eikonal: frame " + std::to_string(index) +
                                " is not orthonormal (|R^T R - I| = " + std::to_string(err) + ")");
}

Eigen::Vector3d vertex(const Mesh& mesh, int e, int a) { return mesh.nodes.row(mesh.tets(e, a)).transpose(); }

}  // namespace

Eigen::Matrix3d conduction_metric(const Frame& R, const ConductionVelocities& v) {
  const Eigen::Vector3d inv(1.0 / (v.fibre * v.fibre), 1.0 / (v.sheet * v.sheet), 1.0 / (v.normal * v.normal));
  return R * inv.asDiagonal() * R.transpose();
}

int locate_point(const Mesh& mesh, const Eigen::Vector3d& x, Eigen::Vector4d* barycentric) {
  int best = -1;
  double best_min = -1e-9;
  Eigen::Vector4d best_l = Eigen::Vector4d::Zero();
  for (int e = 0; e < mesh.n_tets(); ++e) {
    const Eigen::Vector3d x0 = vertex(mesh, e, 0);
    Eigen::Matrix3d J;
    J.col(0) = vertex(mesh, e, 1) - x0;
    J.col(1) = vertex(mesh, e, 2) - x0;
    J.col(2) = vertex(mesh, e, 3) - x0;
    // Cheap rejection by bounding box.
    const Eigen::Vector3d lo = x0.cwiseMin(x0 + J.col(0)).cwiseMin(x0 + J.col(1)).cwiseMin(x0 + J.col(2));
    const Eigen::Vector3d hi = x0.cwiseMax(x0 + J.col(0)).cwiseMax(x0 + J.col(1)).cwiseMax(x0 + J.col(2));
    const double pad = 1e-9 * (hi - lo).norm();
    if ((x.array() < lo.array() - pad).any() || (x.array() > hi.array() + pad).any()) continue;
    const Eigen::Vector3d l = J.partialPivLu().solve(x - x0);
    const Eigen::Vector4d L(1.0 - l.sum(), l[0], l[1], l[2]);
    const double m = L.minCoeff();
    if (m > best_min) {
      best_min = m;
      best = e;
      best_l = L;
    }
  }
  if (barycentric && best >= 0) *barycentric = best_l;
  return best;
}

EikonalResult solve_eikonal(const Mesh& mesh, const EikonalOptions& o) {
  const int nt = mesh.n_tets(), nv = mesh.n_vertices;
  const auto ntz = static_cast<size_t>(nt);
  if (o.velocities.size() != 1 && o.velocities.size() != ntz)
    throw std::invalid_argument("solve_eikonal: " + std::to_string(o.velocities.size()) +
                                " velocity entries; expected 1 or one per tetrahedron (" + std::to_string(nt) + ")");
  if (o.frames.size() != 1 && o.frames.size() != ntz)
    throw std::invalid_argument("solve_eikonal: " + std::to_string(o.frames.size()) +
                                " frames; expected 1 or one per tetrahedron (" + std::to_string(nt) + ")");
  for (size_t k = 0; k < o.velocities.size(); ++k) check_velocities(o.velocities[k], k);
  for (size_t k = 0; k < o.frames.size(); ++k) check_frame(o.frames[k], k);
  if (o.sites.empty() && o.vertex_onsets.empty()) throw std::invalid_argument("solve_eikonal: no onset site");
  if (!(o.source_radius >= 0.0) || !std::isfinite(o.source_radius))
    throw std::invalid_argument("solve_eikonal: source radius " + std::to_string(o.source_radius) + " m is negative");
  if (!(o.tolerance >= 0.0)) throw std::invalid_argument("solve_eikonal: tolerance " + std::to_string(o.tolerance) + " s is negative");

  std::vector<Eigen::Matrix3d> metric(ntz);
  for (size_t e = 0; e < ntz; ++e)
    metric[e] = conduction_metric(o.frames[o.frames.size() == 1 ? 0 : e], o.velocities[o.velocities.size() == 1 ? 0 : e]);

  EikonalResult res;
  res.times = Eigen::VectorXd::Constant(nv, kInf);
  Eigen::VectorXd& t = res.times;
  for (const auto& s : o.sites) {
    if (!std::isfinite(s.time))
      throw std::invalid_argument("solve_eikonal: onset time " + std::to_string(s.time) + " s at " + vec_str(s.position) +
                                  " is not finite");
    const int e = locate_point(mesh, s.position);
    if (e < 0) throw std::invalid_argument("solve_eikonal: onset site " + vec_str(s.position) + " lies outside the mesh");
    const Eigen::Matrix3d& Me = metric[static_cast<size_t>(e)];
    for (int a = 0; a < 4; ++a) {
      const int v = mesh.tets(e, a);
      t[v] = std::min(t[v], s.time + norm_m(Me, vertex(mesh, e, a) - s.position));
    }
    if (o.source_radius > 0.0)
      for (int v = 0; v < nv; ++v) {
        const Eigen::Vector3d d = mesh.nodes.row(v).transpose() - s.position;
        if (d.norm() <= o.source_radius) t[v] = std::min(t[v], s.time + norm_m(Me, d));
      }
  }

  for (const auto& s : o.vertex_onsets) {
    if (s.vertex < 0 || s.vertex >= nv)
      throw std::invalid_argument("solve_eikonal: onset vertex " + std::to_string(s.vertex) + " is not a vertex (0.." +
                                  std::to_string(nv - 1) + ")");
    if (!std::isfinite(s.time))
      throw std::invalid_argument("solve_eikonal: onset time " + std::to_string(s.time) + " s at vertex " +
                                  std::to_string(s.vertex) + " is not finite");
    t[s.vertex] = std::min(t[s.vertex], s.time);
  }

  // Tetrahedra around each vertex (CSR).
  std::vector<int> start(static_cast<size_t>(nv) + 1, 0), adj(4 * ntz);
  for (int e = 0; e < nt; ++e)
    for (int a = 0; a < 4; ++a) ++start[static_cast<size_t>(mesh.tets(e, a)) + 1];
  for (size_t v = 0; v < static_cast<size_t>(nv); ++v) start[v + 1] += start[v];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int e = 0; e < nt; ++e)
      for (int a = 0; a < 4; ++a) adj[static_cast<size_t>(fill[static_cast<size_t>(mesh.tets(e, a))]++)] = e;
  }

  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> heap;
  std::vector<char> popped(static_cast<size_t>(nv), 0);
  for (int v = 0; v < nv; ++v)
    if (std::isfinite(t[v])) heap.emplace(t[v], v);
  Eigen::Vector3d xs[3];
  double ts[3];
  while (!heap.empty()) {
    const auto [tv, v] = heap.top();
    heap.pop();
    if (tv > t[v]) continue;  // stale entry
    ++res.heap_pops;
    if (popped[static_cast<size_t>(v)]) ++res.reopened;
    popped[static_cast<size_t>(v)] = 1;
    for (int k = start[static_cast<size_t>(v)]; k < start[static_cast<size_t>(v) + 1]; ++k) {
      const int e = adj[static_cast<size_t>(k)];
      for (int a = 0; a < 4; ++a) {
        const int w = mesh.tets(e, a);
        if (w == v) continue;
        int n = 0;
        for (int b = 0; b < 4; ++b) {
          if (b == a) continue;
          const int u = mesh.tets(e, b);
          if (!std::isfinite(t[u])) continue;
          xs[n] = vertex(mesh, e, b);
          ts[n] = t[u];
          ++n;
        }
        const double cand = local_update(metric[static_cast<size_t>(e)], vertex(mesh, e, a), xs, ts, n);
        if (cand < t[w] - o.tolerance) {
          t[w] = cand;
          heap.emplace(cand, w);
        }
      }
    }
  }
  res.earliest = kInf;
  res.latest = -kInf;
  for (int v = 0; v < nv; ++v)
    if (std::isfinite(t[v])) {
      res.earliest = std::min(res.earliest, t[v]);
      res.latest = std::max(res.latest, t[v]);
    }
  return res;
}

// --- Interpolation ---------------------------------------------------------------------------------

Eigen::VectorXd activation_at_nodes(const Mesh& mesh, const Eigen::VectorXd& vt) {
  if (vt.size() != mesh.n_vertices)
    throw std::invalid_argument("activation_at_nodes: " + std::to_string(vt.size()) + " times for " +
                                std::to_string(mesh.n_vertices) + " vertices");
  Eigen::VectorXd t = Eigen::VectorXd::Zero(mesh.n_nodes());
  t.head(mesh.n_vertices) = vt;
  if (mesh.order == 2)
    for (int e = 0; e < mesh.n_tets(); ++e)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
          t[mesh.tets(e, tet10_edge_slot(a, b))] = 0.5 * (vt[mesh.tets(e, a)] + vt[mesh.tets(e, b)]);
  return t;
}

double activation_at(const Mesh& mesh, const Eigen::VectorXd& vt, int tet, const Eigen::Vector4d& l) {
  if (tet < 0 || tet >= mesh.n_tets())
    throw std::invalid_argument("activation_at: tetrahedron " + std::to_string(tet) + " out of range");
  double s = 0.0;
  for (int a = 0; a < 4; ++a) s += l[a] * vt[mesh.tets(tet, a)];
  return s;
}

std::vector<double> activation_at_quadrature(const Mesh& mesh, const Eigen::VectorXd& vt, int degree) {
  if (vt.size() != mesh.n_vertices)
    throw std::invalid_argument("activation_at_quadrature: " + std::to_string(vt.size()) + " times for " +
                                std::to_string(mesh.n_vertices) + " vertices");
  const auto& rule = tet_rule(degree);
  std::vector<double> out;
  out.reserve(static_cast<size_t>(mesh.n_tets()) * rule.size());
  for (int e = 0; e < mesh.n_tets(); ++e)
    for (const auto& qp : rule) {
      // Reference coordinates xi are the barycentric coordinates of vertices 1..3 (element.h).
      const Eigen::Vector4d l(1.0 - qp.xi.sum(), qp.xi[0], qp.xi[1], qp.xi[2]);
      out.push_back(activation_at(mesh, vt, e, l));
    }
  return out;
}

// --- Patterns ------------------------------------------------------------------------------------

Eigen::VectorXd surface_depth(const Mesh& mesh, int tag) {
  EikonalOptions o;
  o.velocities = {ConductionVelocities::isotropic(1.0)};
  for (int n : mesh.nodes_with_tag(tag))
    if (n < mesh.n_vertices) o.vertex_onsets.push_back({n, 0.0});
  if (o.vertex_onsets.empty())
    throw std::invalid_argument("surface_depth: the mesh has no faces tagged " + std::to_string(tag));
  return solve_eikonal(mesh, o).times;  // [s] at 1 m/s = [m]
}

std::vector<ConductionVelocities> layered_velocities(const Mesh& mesh, const ConductionVelocities& bulk, double fast,
                                                     double depth, int tag) {
  if (!(fast > 0.0) || !std::isfinite(fast))
    throw std::invalid_argument("layered_velocities: fast layer velocity " + std::to_string(fast) +
                                " m/s is not positive and finite");
  if (!(depth >= 0.0) || !std::isfinite(depth))
    throw std::invalid_argument("layered_velocities: depth " + std::to_string(depth) + " m is negative");
  check_velocities(bulk, 0);
  std::vector<ConductionVelocities> v(static_cast<size_t>(mesh.n_tets()), bulk);
  if (depth > 0.0) {
    const Eigen::VectorXd d = surface_depth(mesh, tag);
    for (int e = 0; e < mesh.n_tets(); ++e) {
      double c = 0.0;
      for (int a = 0; a < 4; ++a) c += 0.25 * d[mesh.tets(e, a)];
      if (c <= depth) v[static_cast<size_t>(e)] = ConductionVelocities::isotropic(fast);
    }
  }
  // A tetrahedron owns a tagged face when the three corners of the face are among its own.
  std::vector<std::array<int, 3>> tagged;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    if (mesh.face_tag[static_cast<size_t>(f)] == tag) {
      std::array<int, 3> s = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
      std::sort(s.begin(), s.end());
      tagged.push_back(s);
    }
  std::sort(tagged.begin(), tagged.end());
  for (int e = 0; e < mesh.n_tets(); ++e)
    for (const auto& lf : kTetFaces) {
      std::array<int, 3> s = {mesh.tets(e, lf[0]), mesh.tets(e, lf[1]), mesh.tets(e, lf[2])};
      std::sort(s.begin(), s.end());
      if (std::binary_search(tagged.begin(), tagged.end(), s)) {
        v[static_cast<size_t>(e)] = ConductionVelocities::isotropic(fast);
        break;
      }
    }
  return v;
}

ActivationPattern parse_activation_pattern(const std::string& name) {
  if (name == "healthy") return ActivationPattern::kHealthy;
  if (name == "lbbb") return ActivationPattern::kLbbb;
  throw std::invalid_argument("unknown activation pattern '" + name + "' (expected healthy or lbbb)");
}

std::string to_string(ActivationPattern p) { return p == ActivationPattern::kHealthy ? "healthy" : "lbbb"; }

Eigen::Vector3d surface_site(const Mesh& mesh, const AhaFrame& f, const Eigen::Vector3d& reference_direction, int tag,
                             double h, double phi_deg) {
  const auto nodes = mesh.nodes_with_tag(tag);
  if (nodes.empty()) throw std::invalid_argument("surface_site: the mesh has no faces tagged " + std::to_string(tag));
  Eigen::Vector3d ref = reference_direction - reference_direction.dot(f.axis) * f.axis;
  ref.normalize();
  const Eigen::Vector3d ref2 = f.axis.cross(ref);
  const double phi = phi_deg * std::numbers::pi / 180.0;
  double best = kInf;
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  for (int n : nodes) {
    if (n >= mesh.n_vertices) continue;
    const Eigen::Vector3d p = mesh.nodes.row(n).transpose();
    const double hv = (p - f.apex).dot(f.axis) / f.length;
    const Eigen::Vector3d d = p - f.centre;
    const double radius = (d - d.dot(f.axis) * f.axis).norm();
    double dphi = std::atan2(d.dot(ref2), d.dot(ref)) - phi;
    dphi = std::remainder(dphi, 2.0 * std::numbers::pi);
    const double dist = std::hypot((hv - h) * f.length, dphi * radius);
    if (dist < best) {
      best = dist;
      x = p;
    }
  }
  return x;
}

std::string ActivationPatternOptions::validate() const {
  for (double v : {myocardium.fibre, myocardium.sheet, myocardium.normal, fast_endocardial_speed})
    if (!(v > 0.0) || !std::isfinite(v)) return "conduction velocity " + std::to_string(v) + " m/s is not positive";
  if (!(fast_endocardial_depth >= 0.0) || !std::isfinite(fast_endocardial_depth))
    return "fast endocardial depth " + std::to_string(fast_endocardial_depth) + " m is negative";
  if (!std::isfinite(lbbb_septal_onset) || !std::isfinite(lbbb_insertion_onset)) return "LBBB onset times must be finite";
  if (reference_direction.norm() < 1e-12) return "reference direction is zero";
  return {};
}

EikonalOptions activation_pattern(const Mesh& mesh, const std::vector<Frame>& tet_frames, ActivationPattern pattern,
                                  const ActivationPatternOptions& o) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("ActivationPatternOptions: " + m);
  if (tet_frames.size() != static_cast<size_t>(mesh.n_tets()))
    throw std::invalid_argument("activation_pattern: " + std::to_string(tet_frames.size()) +
                                " frames; expected one per tetrahedron (" + std::to_string(mesh.n_tets()) + ")");
  AhaOptions ao;
  ao.reference_direction = o.reference_direction;
  const AhaFrame f = aha_labels(mesh, ao).frame;
  auto site_on = [&](int tag, double h, double phi_deg) {
    return surface_site(mesh, f, o.reference_direction, tag, h, phi_deg);
  };
  EikonalOptions e;
  e.frames = tet_frames;
  if (pattern == ActivationPattern::kHealthy) {
    e.velocities = layered_velocities(mesh, o.myocardium, o.fast_endocardial_speed, o.fast_endocardial_depth, kEndocardium);
    e.sites = {{site_on(kEndocardium, 0.8, 0.0), 0.0},
               {site_on(kEndocardium, 0.5, 60.0), 0.0},
               {site_on(kEndocardium, 1.0 / 3.0, 120.0), 0.0}};
  } else {
    e.velocities = {o.myocardium};
    for (double h : {1.0 / 3.0, 0.5, 2.0 / 3.0}) {
      for (double phi : {30.0, 60.0, 90.0}) e.sites.push_back({site_on(kEpicardium, h, phi), o.lbbb_septal_onset});
      for (double phi : {0.0, 120.0}) e.sites.push_back({site_on(kEpicardium, h, phi), o.lbbb_insertion_onset});
    }
  }
  return e;
}

}  // namespace sigmaheart::model::fem
