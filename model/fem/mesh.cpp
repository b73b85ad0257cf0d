#include "model/fem/mesh.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace sigmaheart::model::fem {
namespace {

double signed_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     const Eigen::Vector3d& d) {
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

// The six tetrahedra of the Kuhn split of a unit cube: paths 000 -> 111 changing one axis at a
// time; perm[k] is the axis changed at step k.
constexpr std::array<std::array<int, 3>, 6> kKuhnPerms = {
    {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};

struct Key {
  long long v;
  bool operator==(const Key& o) const { return v == o.v; }
};
struct KeyHash {
  size_t operator()(const Key& k) const { return std::hash<long long>()(k.v); }
};

// Linear structured-grid mesher shared by the ellipsoid and the box: corners are indexed on a
// grid (ni+1, nj+1, nk+1); `canonical` maps a fine-grid index (2x resolution) to a unique key
// (handles periodicity and the collapsed apex); `position` maps a fine index to a point.
// Mid-edge nodes go to the mapped parametric midpoint when `curved(a, b)` holds for the edge's
// fine-grid ends, and to the chord midpoint otherwise.
template <class Canonical, class Position, class KeepTet, class Curved, class Midpoint>
Mesh structured_mesh(int ni, int nj, int nk, int order, Canonical canonical, Position position,
                     KeepTet keep_tet, Curved curved, Midpoint midpoint, bool mirror_odd_k = false) {
  std::vector<std::array<std::array<int, 3>, 4>> cells;  // fine-grid corner indices per tet
  for (int i = 0; i < ni; ++i)
    for (int j = 0; j < nj; ++j)
      for (int k = 0; k < nk; ++k)
        for (const auto& perm : kKuhnPerms) {
          // Cells with odd k use the split mirrored in k (alternating chirality, so that the
          // mesh has no preferred sense of twist about the long axis); conforming for even nk.
          const bool mirror = mirror_odd_k && (k % 2 == 1);
          std::array<int, 3> c = {2 * i, 2 * j, 2 * (mirror ? k + 1 : k)};
          std::array<std::array<int, 3>, 4> t{};
          t[0] = c;
          for (int s = 0; s < 3; ++s) {
            const int ax = perm[static_cast<size_t>(s)];
            c[static_cast<size_t>(ax)] += (mirror && ax == 2) ? -2 : 2;
            t[static_cast<size_t>(s + 1)] = c;
          }
          if (keep_tet(i, j, k, perm)) cells.push_back(t);
        }

  std::unordered_map<Key, int, KeyHash> id;
  std::vector<std::array<int, 3>> fine_of_node;
  std::vector<Eigen::Vector3d> pos;
  auto node_of = [&](const std::array<int, 3>& f, const Eigen::Vector3d& x) {
    const Key key{canonical(f)};
    auto it = id.find(key);
    if (it != id.end()) return it->second;
    const int n = static_cast<int>(fine_of_node.size());
    id.emplace(key, n);
    fine_of_node.push_back(f);
    pos.push_back(x);
    return n;
  };
  Mesh mesh;
  mesh.order = order;
  const int npt = order == 1 ? 4 : 10;
  mesh.tets.resize(static_cast<Eigen::Index>(cells.size()), npt);
  // Pass 1: corners (vertex-first numbering).
  for (size_t e = 0; e < cells.size(); ++e)
    for (int a = 0; a < 4; ++a)
      mesh.tets(static_cast<Eigen::Index>(e), a) = node_of(cells[e][static_cast<size_t>(a)], position(cells[e][static_cast<size_t>(a)]));
  mesh.n_vertices = static_cast<int>(fine_of_node.size());
  // Orientation.
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
    const double v = signed_volume(pos[static_cast<size_t>(mesh.tets(e, 0))], pos[static_cast<size_t>(mesh.tets(e, 1))],
                                   pos[static_cast<size_t>(mesh.tets(e, 2))], pos[static_cast<size_t>(mesh.tets(e, 3))]);
    if (v < 0) {
      std::swap(mesh.tets(e, 1), mesh.tets(e, 2));
      std::swap(cells[static_cast<size_t>(e)][1], cells[static_cast<size_t>(e)][2]);
    }
  }
  // Pass 2: mid-edge nodes, one per edge (keyed by its two corner nodes, so collapsed corners
  // cannot duplicate an edge), at the mapped parametric midpoint (`midpoint` gives the fine-grid
  // index) for curved edges, else at the chord midpoint.
  if (order == 2) {
    const long long nvert = mesh.n_vertices;
    std::unordered_map<Key, int, KeyHash> edge_id;
    for (size_t e = 0; e < cells.size(); ++e)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) {
          const Eigen::Index ee = static_cast<Eigen::Index>(e);
          long long na = mesh.tets(ee, a), nb = mesh.tets(ee, b);
          const Key key{std::min(na, nb) * nvert + std::max(na, nb)};
          auto it = edge_id.find(key);
          int mid;
          if (it != edge_id.end()) {
            mid = it->second;
          } else {
            const auto& fa = cells[e][static_cast<size_t>(a)];
            const auto& fb = cells[e][static_cast<size_t>(b)];
            const Eigen::Vector3d x = curved(fa, fb) ? position(midpoint(fa, fb))
                                                     : Eigen::Vector3d(0.5 * (pos[static_cast<size_t>(na)] + pos[static_cast<size_t>(nb)]));
            mid = static_cast<int>(pos.size());
            pos.push_back(x);
            edge_id.emplace(key, mid);
          }
          mesh.tets(ee, tet10_edge_slot(a, b)) = mid;
        }
  }
  mesh.nodes.resize(static_cast<Eigen::Index>(pos.size()), 3);
  for (size_t n = 0; n < pos.size(); ++n) mesh.nodes.row(static_cast<Eigen::Index>(n)) = pos[n].transpose();
  mesh.tet_tag.assign(cells.size(), 0);
  extract_boundary_faces(mesh);
  return mesh;
}

}  // namespace

int tet10_edge_slot(int i, int j) {
  if (i > j) std::swap(i, j);
  if (i == 0 && j == 1) return 4;
  if (i == 1 && j == 2) return 5;
  if (i == 0 && j == 2) return 6;
  if (i == 0 && j == 3) return 7;
  if (i == 1 && j == 3) return 8;
  if (i == 2 && j == 3) return 9;
  throw std::invalid_argument("tet10_edge_slot: not an edge");
}

std::vector<int> Mesh::nodes_with_tag(int tag) const {
  std::vector<int> out;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    if (face_tag[static_cast<size_t>(f)] == tag)
      for (Eigen::Index a = 0; a < faces.cols(); ++a) out.push_back(faces(f, a));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

double Mesh::volume() const {
  double v = 0.0;
  for (Eigen::Index e = 0; e < tets.rows(); ++e)
    v += signed_volume(nodes.row(tets(e, 0)).transpose(), nodes.row(tets(e, 1)).transpose(),
                       nodes.row(tets(e, 2)).transpose(), nodes.row(tets(e, 3)).transpose());
  return v;
}

std::string Mesh::check() const {
  std::ostringstream os;
  if (order != 1 && order != 2) return "order must be 1 or 2";
  if (tets.cols() != nodes_per_tet()) return "tets has the wrong number of columns for the order";
  if (static_cast<size_t>(tets.rows()) != tet_tag.size()) return "tet_tag size differs from tets";
  if (static_cast<size_t>(faces.rows()) != face_tag.size()) return "face_tag size differs from faces";
  for (Eigen::Index e = 0; e < tets.rows(); ++e) {
    for (Eigen::Index a = 0; a < tets.cols(); ++a) {
      const int n = tets(e, a);
      if (n < 0 || n >= n_nodes()) {
        os << "tetrahedron " << e << " references node " << n << " (mesh has " << n_nodes() << ")";
        return os.str();
      }
      if (a < 4 && n >= n_vertices) {
        os << "tetrahedron " << e << ": corner node " << n << " is not among the first " << n_vertices;
        return os.str();
      }
    }
    const double v = signed_volume(nodes.row(tets(e, 0)).transpose(), nodes.row(tets(e, 1)).transpose(),
                                   nodes.row(tets(e, 2)).transpose(), nodes.row(tets(e, 3)).transpose());
    if (!(v > 0)) {
      os << "tetrahedron " << e << " has non-positive volume " << v;
      return os.str();
    }
  }
  if (order == 2) {  // conformity: an edge has one mid-edge node whichever tetrahedron holds it
    std::map<std::pair<int, int>, int> mid;
    for (Eigen::Index e = 0; e < tets.rows(); ++e)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) {
          const int i = std::min(tets(e, a), tets(e, b)), j = std::max(tets(e, a), tets(e, b));
          const int m = tets(e, tet10_edge_slot(a, b));
          auto [it, fresh] = mid.emplace(std::make_pair(i, j), m);
          if (!fresh && it->second != m) {
            os << "edge (" << i << ", " << j << ") has two mid-edge nodes " << it->second << " and " << m
               << " (non-conforming quadratic mesh)";
            return os.str();
          }
        }
  }
  return {};
}

void extract_boundary_faces(Mesh& mesh) {
  struct FaceRec {
    std::array<int, 3> sorted;
    long long elem;
    int local;
  };
  std::vector<FaceRec> recs;
  recs.reserve(static_cast<size_t>(mesh.tets.rows()) * 4);
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e)
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> s{};
      for (int a = 0; a < 3; ++a) s[static_cast<size_t>(a)] = mesh.tets(e, kTetFaces[static_cast<size_t>(f)][static_cast<size_t>(a)]);
      std::sort(s.begin(), s.end());
      recs.push_back({s, e, f});
    }
  std::sort(recs.begin(), recs.end(), [](const FaceRec& a, const FaceRec& b) { return a.sorted < b.sorted; });
  std::vector<std::pair<long long, int>> boundary;
  for (size_t i = 0; i < recs.size();) {
    size_t j = i + 1;
    while (j < recs.size() && recs[j].sorted == recs[i].sorted) ++j;
    if (j - i == 1) boundary.emplace_back(recs[i].elem, recs[i].local);
    i = j;
  }
  const int npf = mesh.nodes_per_face();
  mesh.faces.resize(static_cast<Eigen::Index>(boundary.size()), npf);
  for (size_t b = 0; b < boundary.size(); ++b) {
    const auto [e, f] = boundary[b];
    const auto& lf = kTetFaces[static_cast<size_t>(f)];
    for (int a = 0; a < 3; ++a) mesh.faces(static_cast<Eigen::Index>(b), a) = mesh.tets(e, lf[static_cast<size_t>(a)]);
    if (npf == 6)
      for (int a = 0; a < 3; ++a)
        mesh.faces(static_cast<Eigen::Index>(b), 3 + a) =
            mesh.tets(e, tet10_edge_slot(lf[static_cast<size_t>(a)], lf[static_cast<size_t>((a + 1) % 3)]));
  }
  mesh.face_tag.assign(boundary.size(), kNoTag);
}

Mesh make_quadratic(const Mesh& linear) {
  if (linear.order != 1) throw std::invalid_argument("make_quadratic: mesh is not linear");
  Mesh q;
  q.order = 2;
  q.n_vertices = linear.n_vertices;
  q.tet_tag = linear.tet_tag;
  q.physical_names = linear.physical_names;
  q.tets.resize(linear.tets.rows(), 10);
  std::unordered_map<Key, int, KeyHash> edge_id;
  std::vector<Eigen::Vector3d> extra;
  const long long nv = linear.n_nodes();
  for (Eigen::Index e = 0; e < linear.tets.rows(); ++e) {
    for (int a = 0; a < 4; ++a) q.tets(e, a) = linear.tets(e, a);
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        long long i = linear.tets(e, a), j = linear.tets(e, b);
        if (i > j) std::swap(i, j);
        const Key key{i * nv + j};
        auto it = edge_id.find(key);
        int id;
        if (it == edge_id.end()) {
          id = static_cast<int>(nv + static_cast<long long>(extra.size()));
          edge_id.emplace(key, id);
          extra.push_back(0.5 * (linear.nodes.row(i) + linear.nodes.row(j)).transpose());
        } else {
          id = it->second;
        }
        q.tets(e, tet10_edge_slot(a, b)) = id;
      }
  }
  q.nodes.resize(static_cast<Eigen::Index>(nv + static_cast<long long>(extra.size())), 3);
  q.nodes.topRows(nv) = linear.nodes;
  for (size_t k = 0; k < extra.size(); ++k) q.nodes.row(static_cast<Eigen::Index>(nv + static_cast<long long>(k))) = extra[k].transpose();
  // Keep the tags of the linear boundary faces (matched by corner set).
  std::map<std::array<int, 3>, int> tag_of;
  for (Eigen::Index f = 0; f < linear.faces.rows(); ++f) {
    std::array<int, 3> s = {linear.faces(f, 0), linear.faces(f, 1), linear.faces(f, 2)};
    std::sort(s.begin(), s.end());
    tag_of[s] = linear.face_tag[static_cast<size_t>(f)];
  }
  extract_boundary_faces(q);
  for (Eigen::Index f = 0; f < q.faces.rows(); ++f) {
    std::array<int, 3> s = {q.faces(f, 0), q.faces(f, 1), q.faces(f, 2)};
    std::sort(s.begin(), s.end());
    auto it = tag_of.find(s);
    if (it != tag_of.end()) q.face_tag[static_cast<size_t>(f)] = it->second;
  }
  return q;
}

// ---------------------------------------------------------------------------------------------
EllipsoidGeometry EllipsoidGeometry::human() {
  EllipsoidGeometry g;
  g.r_short_endo = 25e-3;
  g.r_long_endo = 45e-3;
  g.r_short_epi = 35e-3;
  g.r_long_epi = 55e-3;
  g.z_base = 5e-3 * 45.0 / 17.0;  // the Land base plane scaled with the long axis
  return g;
}

std::string EllipsoidGeometry::validate() const {
  if (!(r_short_endo > 0 && r_long_endo > 0)) return "endocardial radii must be positive";
  if (!(r_short_epi > r_short_endo && r_long_epi > r_long_endo))
    return "epicardial radii must exceed the endocardial ones";
  if (!(z_base > -r_long_endo && z_base < r_long_endo)) return "z_base must cut the endocardium";
  if (!std::isnan(z_base_epi) && !(z_base_epi > -r_long_epi && z_base_epi < r_long_epi))
    return "z_base_epi must cut the epicardium (or be NaN for a plane base)";
  return {};
}

double EllipsoidGeometry::theta_base(double t) const { return std::acos(-base_height(t) / r_long(t)); }

Eigen::Vector3d EllipsoidGeometry::position(double t, double theta, double v) const {
  const double rs = r_short(t), rl = r_long(t);
  return {rs * std::sin(theta) * std::cos(v), rs * std::sin(theta) * std::sin(v), -rl * std::cos(theta)};
}

Eigen::Vector3d EllipsoidGeometry::coordinates(const Eigen::Vector3d& x) const {
  const double rho = std::hypot(x.x(), x.y());
  auto g = [&](double t) {
    const double a = rho / r_short(t), b = x.z() / r_long(t);
    return a * a + b * b - 1.0;  // decreasing in t
  };
  double lo = -0.5, hi = 1.5;
  for (int it = 0; it < 80; ++it) {
    const double mid = 0.5 * (lo + hi);
    (g(mid) > 0 ? lo : hi) = mid;
  }
  const double t = 0.5 * (lo + hi);
  const double theta = std::atan2(rho / r_short(t), -x.z() / r_long(t));
  double v = std::atan2(x.y(), x.x());
  if (v < 0) v += 2 * std::numbers::pi;
  return {t, theta, v};
}

std::string EllipsoidMeshOptions::validate() const {
  if (n_transmural < 1 || n_longitudinal < 1 || n_circumferential < 3)
    return "need n_transmural >= 1, n_longitudinal >= 1, n_circumferential >= 3";
  if (order != 1 && order != 2) return "order must be 1 or 2";
  return {};
}

Mesh ellipsoid_mesh(const EllipsoidGeometry& g, const EllipsoidMeshOptions& o) {
  if (auto m = g.validate(); !m.empty()) throw std::invalid_argument("EllipsoidGeometry: " + m);
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("EllipsoidMeshOptions: " + m);
  const int ni = o.n_transmural, nj = o.n_longitudinal, nk = o.n_circumferential;
  const int fi = 2 * ni, fj = 2 * nj, fk = 2 * nk;
  const bool aligned = o.align_aha_levels && nj % 3 == 0;
  const double z_apex = -g.r_long_endo, cavity = g.z_base - z_apex;
  // theta of fine meridional index j on layer t.
  auto theta_of = [&](double t, int j) {
    const double s = static_cast<double>(j) / fj;
    if (!aligned) return s * g.theta_base(t);
    const double rl = g.r_long(t);
    const std::array<double, 4> br = {0.0, std::acos(-(z_apex + cavity / 3.0) / rl),
                                      std::acos(-(z_apex + 2.0 * cavity / 3.0) / rl), g.theta_base(t)};
    const double u = 3.0 * s;
    const int seg = std::min(2, static_cast<int>(u));
    return br[static_cast<size_t>(seg)] + (u - seg) * (br[static_cast<size_t>(seg + 1)] - br[static_cast<size_t>(seg)]);
  };
  auto canonical = [&](const std::array<int, 3>& f) -> long long {
    const int i = f[0], j = f[1];
    const int k = j == 0 ? 0 : ((f[2] % fk) + fk) % fk;
    return (static_cast<long long>(i) * (fj + 1) + j) * (fk + 1) + k;
  };
  auto position = [&](const std::array<int, 3>& f) -> Eigen::Vector3d {
    const double t = static_cast<double>(f[0]) / fi;
    const double v = 2.0 * std::numbers::pi * f[2] / fk;
    return g.position(t, theta_of(t, f[1]), v);
  };
  // In the apex column (j = 0) keep the tetrahedra whose path steps in theta before v.
  auto keep = [](int, int j, int, const std::array<int, 3>& perm) {
    if (j != 0) return true;
    for (int s : perm) {
      if (s == 1) return true;
      if (s == 2) return false;
    }
    return true;
  };
  // Edges within one ellipsoidal layer follow it (exact endocardium and epicardium); edges that
  // cross layers are straight: the (t, theta) map is singular on the axis, and mapped midpoints
  // of apex-to-ring diagonals would sit far off the chord and spoil the element Jacobians.
  auto curved = [](const std::array<int, 3>& a, const std::array<int, 3>& b) { return a[0] == b[0]; };
  // On the axis (j = 0) the angle v is undefined: a mid-edge node toward the apex takes the v of
  // the other end, so apex edges run along meridians.
  auto midpoint = [](std::array<int, 3> a, std::array<int, 3> b) {
    if (a[1] == 0) a[2] = b[2];
    if (b[1] == 0) b[2] = a[2];
    return std::array<int, 3>{(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
  };
  Mesh mesh = structured_mesh(ni, nj, nk, o.order, canonical, position, keep, curved, midpoint, nk % 2 == 0);
  // Tags from the parametric position of the face corners.
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    bool endo = true, epi = true, base = true;
    for (int a = 0; a < 3; ++a) {
      const Eigen::Vector3d x = mesh.nodes.row(mesh.faces(f, a)).transpose();
      const Eigen::Vector3d c = g.coordinates(x);
      endo = endo && std::abs(c[0]) < 1e-6;
      epi = epi && std::abs(c[0] - 1.0) < 1e-6;
      base = base && std::abs(x.z() - g.base_height(c[0])) < 1e-9 * g.r_long_epi;
    }
    mesh.face_tag[static_cast<size_t>(f)] = base ? kBase : endo ? kEndocardium : epi ? kEpicardium : kNoTag;
  }
  return mesh;
}

Mesh box_mesh(double lx, double ly, double lz, int nx, int ny, int nz, int order) {
  if (nx < 1 || ny < 1 || nz < 1 || !(lx > 0 && ly > 0 && lz > 0) || (order != 1 && order != 2))
    throw std::invalid_argument("box_mesh: need positive sizes and divisions, order 1 or 2");
  auto canonical = [&](const std::array<int, 3>& f) -> long long {
    return (static_cast<long long>(f[0]) * (2 * ny + 1) + f[1]) * (2 * nz + 1) + f[2];
  };
  auto position = [&](const std::array<int, 3>& f) -> Eigen::Vector3d {
    return {lx * f[0] / (2.0 * nx), ly * f[1] / (2.0 * ny), lz * f[2] / (2.0 * nz)};
  };
  auto keep = [](int, int, int, const std::array<int, 3>&) { return true; };
  auto straight = [](const std::array<int, 3>&, const std::array<int, 3>&) { return false; };
  auto midpoint = [](const std::array<int, 3>& a, const std::array<int, 3>& b) {
    return std::array<int, 3>{(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
  };
  Mesh mesh = structured_mesh(nx, ny, nz, order, canonical, position, keep, straight, midpoint);
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    bool x0 = true, z0 = true;
    for (int a = 0; a < 3; ++a) {
      x0 = x0 && std::abs(mesh.nodes(mesh.faces(f, a), 0)) < 1e-12 * lx;
      z0 = z0 && std::abs(mesh.nodes(mesh.faces(f, a), 2)) < 1e-12 * lz;
    }
    mesh.face_tag[static_cast<size_t>(f)] = x0 ? kClamped : z0 ? kBottom : kNoTag;
  }
  return mesh;
}

}  // namespace sigmaheart::model::fem
