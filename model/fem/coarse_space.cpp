#include "model/fem/coarse_space.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <vector>

namespace sigmaheart::model::fem {

std::string EllipsoidCoarseOptions::validate() const {
  if (transmural < 1) return "transmural must be >= 1";
  if (meridian < 2) return "meridian must be >= 2";
  if (around < 3) return "around must be >= 3";
  return {};
}

EllipsoidCoarseOptions ellipsoid_coarse_options(int n_transmural, int n_longitudinal, int n_circumferential,
                                                CoarseGrid grid) {
  EllipsoidCoarseOptions o;
  // The mesh has n + 1 node layers transmurally and meridionally (apex to base), n around.
  o.transmural = std::clamp(n_transmural + 1, 1, 3);
  if (grid == CoarseGrid::kHalfMesh) {
    o.meridian = std::max(n_longitudinal / 2 + 1, 2);
    o.around = std::max(n_circumferential / 2, 3);
    o.pressure = false;
  } else {
    o.meridian = std::clamp(n_longitudinal / 2 + 1, 2, 5);
    o.around = std::clamp(n_circumferential / 2, 3, 8);
  }
  return o;
}

namespace {

// Nonzero hats of `n` uniform nodes on [0, 1] at x: up to two (index, value) pairs. n = 1: the
// constant.
int hats(double x, int n, std::pair<int, double> out[2]) {
  if (n == 1) {
    out[0] = {0, 1.0};
    return 1;
  }
  const double u = std::clamp(x, 0.0, 1.0) * (n - 1);
  const int i = std::min(static_cast<int>(u), n - 2);
  const double f = u - i;
  out[0] = {i, 1.0 - f};
  out[1] = {i + 1, f};
  return 2;
}

}  // namespace

Eigen::SparseMatrix<double, Eigen::ColMajor, int> ellipsoid_coarse_space(const Mesh& mesh, const EllipsoidGeometry& g,
                                                                         const EllipsoidCoarseOptions& o, int trailing) {
  if (const std::string m = o.validate(); !m.empty()) throw std::invalid_argument("EllipsoidCoarseOptions: " + m);
  if (trailing < 0) throw std::invalid_argument("ellipsoid_coarse_space: trailing must be >= 0");
  // Scalar hats: per transmural node a, the apex hat (meridian node 0) and (meridian - 1) x around.
  const int per_layer = 1 + (o.meridian - 1) * o.around;
  const int n_scalar = o.transmural * per_layer;
  const int nn = mesh.n_nodes(), nv = mesh.n_vertices;
  const Eigen::Index n = 3 * static_cast<Eigen::Index>(nn) + nv + trailing;
  const int per_hat = o.pressure ? 4 : 3;  // columns per scalar hat
  const Eigen::Index nc = per_hat * static_cast<Eigen::Index>(n_scalar) + trailing;
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(static_cast<size_t>(16 * nn + 8 * nv + trailing));
  const double dv = 2 * std::numbers::pi / o.around;
  for (int node = 0; node < nn; ++node) {
    const Eigen::Vector3d c = g.coordinates(mesh.nodes.row(node).transpose());
    const double t = c[0], s = c[1] / g.theta_base(std::clamp(t, 0.0, 1.0)), v = c[2];
    std::pair<int, double> ht[2], hs[2];
    const int kt = hats(t, o.transmural, ht), ks = hats(s, o.meridian, hs);
    // Periodic hats in v.
    const double w = v / dv;
    const int j0 = static_cast<int>(std::floor(w));
    const double fv = w - j0;
    const std::pair<int, double> hv[2] = {{((j0 % o.around) + o.around) % o.around, 1.0 - fv},
                                          {((j0 + 1) % o.around + o.around) % o.around, fv}};
    for (int a = 0; a < kt; ++a)
      for (int b = 0; b < ks; ++b) {
        const double wab = ht[a].second * hs[b].second;
        if (wab == 0.0) continue;
        const int base = ht[a].first * per_layer;
        const int nj = hs[b].first == 0 ? 1 : 2;
        for (int c2 = 0; c2 < nj; ++c2) {
          const double val = hs[b].first == 0 ? wab : wab * hv[c2].second;
          if (val == 0.0) continue;
          const int col = hs[b].first == 0 ? base : base + 1 + (hs[b].first - 1) * o.around + hv[c2].first;
          for (int d = 0; d < 3; ++d) trip.emplace_back(3 * node + d, per_hat * col + d, val);
          if (o.pressure && node < nv) trip.emplace_back(3 * nn + node, per_hat * col + 3, val);
        }
      }
  }
  for (int k = 0; k < trailing; ++k)
    trip.emplace_back(static_cast<int>(n - trailing + k), static_cast<int>(nc - trailing + k), 1.0);
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> P(n, nc);
  P.setFromTriplets(trip.begin(), trip.end());
  return P;
}

}  // namespace sigmaheart::model::fem
