// Quadrature exactness and shape-function identities on the reference elements.
#include "model/fem/element.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::model::fem {
namespace {

double factorial(int n) { return n <= 1 ? 1.0 : n * factorial(n - 1); }

// int over the reference tetrahedron of x^a y^b z^c = a! b! c! / (a + b + c + 3)!
TEST(Element, TetrahedronRulesIntegrateMonomialsExactly) {
  for (int degree : {1, 2, 5}) {
    const auto& rule = tet_rule(degree);
    for (int a = 0; a <= degree; ++a)
      for (int b = 0; a + b <= degree; ++b)
        for (int c = 0; a + b + c <= degree; ++c) {
          double q = 0;
          for (const auto& p : rule) q += p.weight * std::pow(p.xi[0], a) * std::pow(p.xi[1], b) * std::pow(p.xi[2], c);
          const double exact = factorial(a) * factorial(b) * factorial(c) / factorial(a + b + c + 3);
          EXPECT_NEAR(q, exact, 1e-14) << "degree " << degree << " monomial " << a << b << c;
        }
    for (const auto& p : rule) EXPECT_GT(p.weight, 0.0);
  }
}

TEST(Element, TriangleRulesIntegrateMonomialsExactly) {
  for (int degree : {2, 4}) {
    const auto& rule = tri_rule(degree);
    for (int a = 0; a <= degree; ++a)
      for (int b = 0; a + b <= degree; ++b) {
        double q = 0;
        for (const auto& p : rule) q += p.weight * std::pow(p.xi[0], a) * std::pow(p.xi[1], b);
        EXPECT_NEAR(q, factorial(a) * factorial(b) / factorial(a + b + 2), 1e-12) << degree << " " << a << b;
      }
  }
}

TEST(Element, ShapeFunctionsPartitionUnityAndInterpolateNodes) {
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  const Eigen::Vector3d xi(0.2, 0.3, 0.1);
  for (int order : {1, 2}) {
    tet_shape(order, xi, N, dN);
    EXPECT_NEAR(N.sum(), 1.0, 1e-14);
    EXPECT_LT(dN.colwise().sum().norm(), 1e-13);
  }
  // Quadratic: N_a(node b) = delta_ab at the corners and mid-edges.
  const Eigen::Vector3d corners[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const int E[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}};
  for (int a = 0; a < 10; ++a) {
    const Eigen::Vector3d p = a < 4 ? corners[a] : Eigen::Vector3d(0.5 * (corners[E[a - 4][0]] + corners[E[a - 4][1]]));
    tet_shape(2, p, N, dN);
    for (int b = 0; b < 10; ++b) EXPECT_NEAR(N[b], a == b ? 1.0 : 0.0, 1e-14);
  }
  tri_shape(2, Eigen::Vector2d(0.25, 0.4), N, dN);
  EXPECT_NEAR(N.sum(), 1.0, 1e-14);
}

}  // namespace
}  // namespace sigmaheart::model::fem
