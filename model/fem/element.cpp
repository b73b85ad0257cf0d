#include "model/fem/element.h"

#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {

std::vector<QuadraturePoint3> make_tet(int degree) {
  std::vector<QuadraturePoint3> r;
  auto sym4 = [&](double a, double w) {  // (a,a,a,1-3a) and permutations
    const double b = 1.0 - 3.0 * a;
    const double L[4][4] = {{b, a, a, a}, {a, b, a, a}, {a, a, b, a}, {a, a, a, b}};
    for (auto& l : L) r.push_back({Eigen::Vector3d(l[1], l[2], l[3]), w});
  };
  auto sym6 = [&](double a, double w) {  // (a,a,b,b) with b = 1/2 - a, 6 permutations
    const double b = 0.5 - a;
    const double L[6][4] = {{a, a, b, b}, {a, b, a, b}, {a, b, b, a}, {b, a, a, b}, {b, a, b, a}, {b, b, a, a}};
    for (auto& l : L) r.push_back({Eigen::Vector3d(l[1], l[2], l[3]), w});
  };
  if (degree <= 1) {
    r.push_back({Eigen::Vector3d(0.25, 0.25, 0.25), 1.0 / 6.0});
  } else if (degree == 2) {
    sym4(0.1381966011250105, 1.0 / 24.0);
  } else if (degree <= 5) {
    sym4(0.0927352503108912, 0.01224884051939366);
    sym4(0.3108859192633006, 0.01878132095300264);
    sym6(0.0455037041256496, 0.007091003462846911);
  } else {
    throw std::invalid_argument("tet_rule: degree above 5 not available");
  }
  return r;
}

std::vector<QuadraturePoint2> make_tri(int degree) {
  std::vector<QuadraturePoint2> r;
  auto sym3 = [&](double a, double w) {
    const double b = 1.0 - 2.0 * a;
    r.push_back({Eigen::Vector2d(a, a), w});
    r.push_back({Eigen::Vector2d(b, a), w});
    r.push_back({Eigen::Vector2d(a, b), w});
  };
  if (degree <= 2) {
    sym3(1.0 / 6.0, 1.0 / 6.0);
  } else if (degree <= 4) {
    sym3(0.445948490915965, 0.5 * 0.223381589678011);
    sym3(0.091576213509771, 0.5 * 0.109951743655322);
  } else {
    throw std::invalid_argument("tri_rule: degree above 4 not available");
  }
  return r;
}

}  // namespace

const std::vector<QuadraturePoint3>& tet_rule(int degree) {
  static const std::vector<QuadraturePoint3> r1 = make_tet(1), r2 = make_tet(2), r5 = make_tet(5);
  if (degree <= 1) return r1;
  if (degree == 2) return r2;
  if (degree <= 5) return r5;
  throw std::invalid_argument("tet_rule: degree above 5 not available");
}

const std::vector<QuadraturePoint2>& tri_rule(int degree) {
  static const std::vector<QuadraturePoint2> r2 = make_tri(2), r4 = make_tri(4);
  if (degree <= 2) return r2;
  if (degree <= 4) return r4;
  throw std::invalid_argument("tri_rule: degree above 4 not available");
}

namespace {

// Lagrange shape functions of order 1 (the V vertices) or 2 (the vertices, then one node per edge
// in the order of `edges`) on a D-simplex, from the barycentric coordinates L and their
// derivatives dL[i][d] = dL_i / dxi_d.
template <int V, int D, int NE>
void simplex_shape(int order, const double (&L)[V], const double (&dL)[V][D],
                   const int (&edges)[NE][2], Eigen::VectorXd& N, Eigen::MatrixXd& dN) {
  if (order == 1) {
    N.resize(V);
    dN.resize(V, D);
    for (int a = 0; a < V; ++a) {
      N[a] = L[a];
      for (int d = 0; d < D; ++d) dN(a, d) = dL[a][d];
    }
    return;
  }
  N.resize(V + NE);
  dN.resize(V + NE, D);
  for (int a = 0; a < V; ++a) {
    N[a] = L[a] * (2 * L[a] - 1);
    for (int d = 0; d < D; ++d) dN(a, d) = (4 * L[a] - 1) * dL[a][d];
  }
  for (int e = 0; e < NE; ++e) {
    const int i = edges[e][0], j = edges[e][1];
    N[V + e] = 4 * L[i] * L[j];
    for (int d = 0; d < D; ++d) dN(V + e, d) = 4 * (dL[i][d] * L[j] + L[i] * dL[j][d]);
  }
}

}  // namespace

void tet_shape(int order, const Eigen::Vector3d& xi, Eigen::VectorXd& N, Eigen::MatrixXd& dN) {
  const double L[4] = {1.0 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]};
  // dL_i / dxi_d
  const double dL[4][3] = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const int E[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}};
  simplex_shape(order, L, dL, E, N, dN);
}

void tri_shape(int order, const Eigen::Vector2d& xi, Eigen::VectorXd& N, Eigen::MatrixXd& dN) {
  const double L[3] = {1.0 - xi[0] - xi[1], xi[0], xi[1]};
  const double dL[3][2] = {{-1, -1}, {1, 0}, {0, 1}};
  const int E[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  simplex_shape(order, L, dL, E, N, dN);
}

}  // namespace sigmaheart::model::fem
