#include "model/fem/tracked_volumes.h"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <queue>
#include <sstream>

namespace sigmaheart::model::fem {

namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

std::string mm(double metres) {
  std::ostringstream s;
  s.precision(3);
  s << metres * 1e3 << " mm";
  return s.str();
}

// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection, 2005, s.5.1.5).
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Distance of p to the faces of `faces` (corner triangles) at positions x.
double distance_to_faces(const Eigen::Vector3d& p, const Eigen::MatrixXi& faces, const Eigen::MatrixX3d& x) {
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d q = closest_on_triangle(p, x.row(faces(f, 0)), x.row(faces(f, 1)), x.row(faces(f, 2)));
    best = std::min(best, (q - p).norm());
  }
  return best;
}

Eigen::Vector3d face_centroid(const Eigen::MatrixXi& faces, Eigen::Index f, const Eigen::MatrixX3d& x) {
  return (x.row(faces(f, 0)) + x.row(faces(f, 1)) + x.row(faces(f, 2))).transpose() / 3.0;
}

Eigen::Vector3d face_normal(const Eigen::MatrixXi& faces, Eigen::Index f, const Eigen::MatrixX3d& x) {
  const Eigen::Vector3d p0 = x.row(faces(f, 0)), p1 = x.row(faces(f, 1)), p2 = x.row(faces(f, 2));
  return (p1 - p0).cross(p2 - p0);
}

// Reverses a face's orientation: corners (0, 2, 1), mid-edge nodes (0,2) (2,1) (1,0).
void flip_face(Eigen::MatrixXi& faces, Eigen::Index f) {
  std::swap(faces(f, 1), faces(f, 2));
  if (faces.cols() == 6) std::swap(faces(f, 3), faces(f, 5));
}

using Edge = std::pair<int, int>;  // sorted corner pair
Edge edge_key(int a, int b) { return a < b ? Edge{a, b} : Edge{b, a}; }

// Faces using each edge (corner pairs), with the direction they traverse it (true: key order).
std::map<Edge, std::vector<std::pair<int, bool>>> edge_faces(const Eigen::MatrixXi& faces) {
  std::map<Edge, std::vector<std::pair<int, bool>>> m;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      m[edge_key(a, b)].emplace_back(static_cast<int>(f), a < b);
    }
  return m;
}

// Makes neighbouring faces traverse their shared edge in opposite directions (breadth first from
// face 0 of each patch). Returns the number of faces flipped.
int orient_consistently(Eigen::MatrixXi& faces) {
  auto edges = edge_faces(faces);
  for (const auto& [e, users] : edges)
    if (users.size() > 2)
      throw std::invalid_argument("the endocardium has a non-manifold edge (nodes " + std::to_string(e.first) + ", " +
                                  std::to_string(e.second) + " shared by " + std::to_string(users.size()) + " faces)");
  const auto n = static_cast<size_t>(faces.rows());
  std::vector<char> done(n, 0), flipped(n, 0);
  int count = 0;
  for (size_t seed = 0; seed < n; ++seed) {
    if (done[seed]) continue;
    std::queue<size_t> q;
    q.push(seed);
    done[seed] = 1;
    while (!q.empty()) {
      const size_t f = q.front();
      q.pop();
      for (int k = 0; k < 3; ++k) {
        const int a = faces(static_cast<Eigen::Index>(f), k), b = faces(static_cast<Eigen::Index>(f), (k + 1) % 3);
        for (const auto& [g, forward] : edges[edge_key(a, b)]) {
          const auto gi = static_cast<size_t>(g);
          if (gi == f) continue;
          // g's current direction along the edge (its record is of its original orientation).
          const bool g_forward = flipped[gi] ? !forward : forward;
          const bool same = g_forward == (a < b);
          if (done[gi]) {
            if (same) throw std::invalid_argument("the endocardium is not orientable (face " + std::to_string(g) + ")");
            continue;
          }
          if (same) {
            flip_face(faces, g);
            flipped[gi] = 1;
            ++count;
          }
          done[gi] = 1;
          q.push(gi);
        }
      }
    }
  }
  return count;
}

// Nodes of the rim (edges used by one face): corners and, for quadratic faces, the edge's mid node.
// Throws unless the rim is one closed loop.
std::vector<int> rim_nodes(const Eigen::MatrixXi& faces) {
  const auto edges = edge_faces(faces);
  std::map<int, int> parent;
  auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  std::vector<int> ring;
  for (const auto& [e, users] : edges) {
    if (users.size() != 1) continue;
    for (int v : {e.first, e.second})
      if (!parent.count(v)) parent[v] = v;
    parent[find(e.first)] = find(e.second);
    ring.push_back(e.first);
    ring.push_back(e.second);
    if (faces.cols() == 6) {
      const Eigen::Index f = users[0].first;
      for (int k = 0; k < 3; ++k)
        if (edge_key(faces(f, k), faces(f, (k + 1) % 3)) == e) ring.push_back(faces(f, 3 + k));
    }
  }
  if (ring.empty())
    throw std::invalid_argument("the endocardium is a closed surface: give landmarks.base (points on the base plane) "
                                "to cut it open at the base");
  int loops = 0;
  for (const auto& [v, p] : parent)
    if (find(v) == v) ++loops;
  if (loops != 1)
    throw std::invalid_argument("the endocardium's rim has " + std::to_string(loops) +
                                " loops; expected one (the base ring): holes in the surface or several pieces");
  std::sort(ring.begin(), ring.end());
  ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  return ring;
}

}  // namespace

std::string TrackedOptions::validate() const {
  if (!(landmark_tolerance > 0)) return "landmark_tolerance must be > 0";
  if (apical_cap_fraction < 0 || apical_cap_fraction >= 1.0 / 3.0) return "apical_cap_fraction must be in [0, 1/3)";
  return {};
}

std::vector<char> inner_boundary_faces(const Mesh& mesh, const Eigen::MatrixX3d& x) {
  const Eigen::MatrixXi& F = mesh.faces;
  std::vector<char> inner(static_cast<size_t>(F.rows()), 0);
  if (F.rows() == 0) return inner;
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  std::vector<int> nodes(F.data(), F.data() + F.size());
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  for (int n : nodes) m += x.row(n).transpose();
  m /= static_cast<double>(nodes.size());
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    inner[static_cast<size_t>(f)] = face_normal(F, f, x).dot(m - face_centroid(F, f, x)) > 0;
  // The largest edge-connected patch of the candidates.
  const auto edges = edge_faces(F);
  std::vector<int> patch(inner.size(), -1);
  std::vector<int> sizes;
  for (size_t s = 0; s < inner.size(); ++s) {
    if (!inner[s] || patch[s] >= 0) continue;
    const int id = static_cast<int>(sizes.size());
    sizes.push_back(0);
    std::queue<size_t> q;
    q.push(s);
    patch[s] = id;
    while (!q.empty()) {
      const size_t f = q.front();
      q.pop();
      ++sizes.back();
      for (int k = 0; k < 3; ++k)
        for (const auto& [g, fw] : edges.at(edge_key(F(static_cast<Eigen::Index>(f), k), F(static_cast<Eigen::Index>(f), (k + 1) % 3)))) {
          const auto gi = static_cast<size_t>(g);
          if (inner[gi] && patch[gi] < 0) {
            patch[gi] = id;
            q.push(gi);
          }
        }
    }
  }
  if (sizes.empty()) return inner;
  const int best = static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  for (size_t f = 0; f < inner.size(); ++f) inner[f] = patch[f] == best;
  return inner;
}

Eigen::Vector3d aha_reference_direction(const Landmarks& lm, const Eigen::Vector3d& centre, const Eigen::Vector3d& axis,
                                        double* beta_deg) {
  const double L = (centre - lm.apex).norm();
  auto radial = [&](const Eigen::Vector3d& p, const char* name) {
    const Eigen::Vector3d d = p - centre;
    const Eigen::Vector3d r = d - d.dot(axis) * axis;
    if (r.norm() < 1e-3 * L) throw LandmarkError(name, std::string(name) + " lies on the long axis; expected a point on the wall");
    return Eigen::Vector3d(r.normalized());
  };
  Eigen::Vector3d ref = radial(lm.rv_anterior, "rv_anterior");
  if (beta_deg) *beta_deg = std::numeric_limits<double>::quiet_NaN();
  if (!lm.rv_inferior) return ref;
  const Eigen::Vector3d q = radial(*lm.rv_inferior, "rv_inferior");
  double beta = std::atan2(q.dot(axis.cross(ref)), q.dot(ref)) * kDeg;
  if (beta < 0) beta += 360.0;
  if (beta_deg) *beta_deg = beta;
  if (beta < 40.0 || beta > 200.0) {
    std::ostringstream s;
    s.precision(4);
    s << "rv_inferior lies " << beta << " deg from rv_anterior counter-clockwise seen from the apex; expected "
      << "40-200 deg (about 120: the septum between them). Swapped points, or apex and base reversed?";
    throw LandmarkError("rv_inferior", s.str());
  }
  const double turn = (beta - 120.0) / 2.0 / kDeg;
  return (std::cos(turn) * ref + std::sin(turn) * axis.cross(ref)).normalized();
}

TrackedEndocardium make_tracked_endocardium(const Mesh& mesh, const std::vector<char>& endo, const Eigen::MatrixX3d& x_ref,
                                            bool oriented, const Landmarks& lm, const TrackedOptions& o) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("TrackedOptions: " + m);
  if (endo.size() != static_cast<size_t>(mesh.faces.rows()))
    throw std::invalid_argument("make_tracked_endocardium: one flag per face expected");
  if (x_ref.rows() != mesh.n_nodes()) throw std::invalid_argument("make_tracked_endocardium: x_ref needs one row per node");
  // Landmarks near the surface of the mesh.
  auto near_mesh = [&](const Eigen::Vector3d& p, const std::string& name) {
    const double d = distance_to_faces(p, mesh.faces, x_ref);
    if (d > o.landmark_tolerance)
      throw LandmarkError(name, name + " is " + mm(d) + " from the mesh's surface (at most " + mm(o.landmark_tolerance) +
                                    " expected): outside the mesh, or in other units or coordinates");
  };
  near_mesh(lm.apex, "apex");
  near_mesh(lm.rv_anterior, "rv_anterior");
  if (lm.rv_inferior) near_mesh(*lm.rv_inferior, "rv_inferior");
  for (size_t i = 0; i < lm.base.size(); ++i) near_mesh(lm.base[i], "base[" + std::to_string(i) + "]");

  TrackedEndocardium out;
  Mesh& s = out.surface;
  s.order = mesh.faces.cols() == 6 ? 2 : 1;
  s.nodes = mesh.nodes;
  s.n_vertices = mesh.n_nodes();
  s.tets.resize(0, s.order == 2 ? 10 : 4);
  // The base plane through the base points (least squares), normal from the apex to the base.
  Eigen::Vector3d plane_point = Eigen::Vector3d::Zero(), plane_normal = Eigen::Vector3d::Zero();
  if (!lm.base.empty()) {
    if (lm.base.size() < 3) throw LandmarkError("base", "base needs at least 3 points on the base plane (or 'rim')");
    Eigen::MatrixX3d P(static_cast<Eigen::Index>(lm.base.size()), 3);
    for (size_t i = 0; i < lm.base.size(); ++i) P.row(static_cast<Eigen::Index>(i)) = lm.base[i].transpose();
    plane_point = P.colwise().mean().transpose();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(P.rowwise() - plane_point.transpose(), Eigen::ComputeFullV);
    if (svd.singularValues()(1) < 1e-3 * svd.singularValues()(0))
      throw LandmarkError("base", "the base points lie on a line; expected points around the base ring");
    plane_normal = svd.matrixV().col(2);
    if (plane_normal.dot(plane_point - lm.apex) < 0) plane_normal = -plane_normal;
  }
  std::vector<Eigen::Index> keep;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    if (!endo[static_cast<size_t>(f)]) continue;
    if (!lm.base.empty() && (face_centroid(mesh.faces, f, x_ref) - plane_point).dot(plane_normal) > 0) {
      ++out.faces_cut;
      continue;
    }
    keep.push_back(f);
  }
  if (keep.empty()) throw std::invalid_argument("no endocardial faces (below the base plane, when base points are given)");
  s.faces.resize(static_cast<Eigen::Index>(keep.size()), mesh.faces.cols());
  for (size_t i = 0; i < keep.size(); ++i) s.faces.row(static_cast<Eigen::Index>(i)) = mesh.faces.row(keep[i]);
  s.face_tag.assign(keep.size(), kEndocardium);
  if (!oriented) out.faces_flipped = orient_consistently(s.faces);
  std::vector<int> ring = rim_nodes(s.faces);

  AhaFrame f;
  f.apex = lm.apex;
  f.centre.setZero();
  for (int n : ring) f.centre += x_ref.row(n).transpose();
  f.centre /= static_cast<double>(ring.size());
  f.length = (f.centre - f.apex).norm();
  if (!(f.length > o.landmark_tolerance))
    throw LandmarkError("apex", "apex is " + mm(f.length) + " from the centre of the base ring; expected the far end of the cavity");
  f.axis = (f.centre - f.apex) / f.length;
  out.reference_direction = aha_reference_direction(lm, f.centre, f.axis, &out.insertion_angle_deg);
  AhaOptions ao;
  ao.apical_cap_fraction = o.apical_cap_fraction;
  out.labels = aha_labels_in_frame(s, x_ref, f, out.reference_direction, ao, std::move(ring));
  const double V = cavity_volumes(s, x_ref, out.labels).cavity;
  if (!(V > 0)) {
    if (oriented)
      throw std::invalid_argument("the endocardium encloses a volume of " + std::to_string(V * 1e6) +
                                  " mL (expected > 0): the chosen faces are not the inner boundary");
    for (Eigen::Index k = 0; k < s.faces.rows(); ++k) flip_face(s.faces, k);
    out.faces_flipped = static_cast<int>(s.faces.rows()) - out.faces_flipped;
  }
  return out;
}

ElementQuality element_quality(const Mesh& mesh, const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& x_ref) {
  ElementQuality q;
  auto keep = [&](double value, Eigen::Index e) {
    if (value < q.min_quality || q.worst_element < 0) {
      q.min_quality = value;
      q.worst_element = static_cast<int>(e);
    }
  };
  if (mesh.tets.rows() > 0) {
    for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
      std::array<Eigen::Vector3d, 4> p;
      for (int k = 0; k < 4; ++k) p[static_cast<size_t>(k)] = x.row(mesh.tets(e, k));
      const double V = (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) / 6.0;
      double l2 = 0.0;
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) l2 += (p[static_cast<size_t>(a)] - p[static_cast<size_t>(b)]).squaredNorm();
      if (!(V > 0)) ++q.inverted;
      keep(12.0 * std::cbrt(9.0 * V * V) / l2 * (V > 0 ? 1.0 : -1.0), e);
    }
    return q;
  }
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Eigen::Vector3d n = face_normal(mesh.faces, f, x);
    double l2 = 0.0;
    for (int k = 0; k < 3; ++k) l2 += (x.row(mesh.faces(f, k)) - x.row(mesh.faces(f, (k + 1) % 3))).squaredNorm();
    const bool turned = !(n.dot(face_normal(mesh.faces, f, x_ref)) > 0);
    if (turned) ++q.inverted;
    keep(2.0 * std::sqrt(3.0) * n.norm() / l2 * (turned ? -1.0 : 1.0), f);
  }
  return q;
}

}  // namespace sigmaheart::model::fem
