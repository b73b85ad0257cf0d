#include "model/fem/elastodynamics.h"

#include "model/fem/element.h"

#include <Eigen/Dense>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {

// Newmark average acceleration: a_{n+1} = c0 (u_{n+1} - u_n) - c1 v_n - a_n, c0 = 4/h^2,
// c1 = 4/h; v_{n+1} = v_n + h/2 (a_n + a_{n+1}).
struct Newmark {
  double h, c0, c1;
  explicit Newmark(double step) : h(step), c0(4.0 / (step * step)), c1(4.0 / step) {}
  Eigen::VectorXd acceleration(const DynamicState& xn, const Eigen::VectorXd& u) const {
    return c0 * (u - xn.s.u) - c1 * xn.v - xn.a;
  }
  Eigen::VectorXd velocity(const DynamicState& xn, const Eigen::VectorXd& a) const {
    return xn.v + 0.5 * h * (xn.a + a);
  }
};

const Matrix9d& symmetric_identity() {
  static const Matrix9d I = tensor_sym_product(Eigen::Matrix3d::Identity());
  return I;
}

}  // namespace

std::string ElastodynamicsOptions::validate() const {
  if (!(density > 0) || !std::isfinite(density)) return "density must be positive [kg/m^3]";
  if (!(viscosity >= 0) || !std::isfinite(viscosity)) return "viscosity must be >= 0 [Pa s]";
  if (!(time_step > 0) || !std::isfinite(time_step)) return "time_step must be positive [s]";
  for (const auto& r : robin)
    if (!(r.stiffness >= 0 && r.damping >= 0) || !std::isfinite(r.stiffness) || !std::isfinite(r.damping))
      return "Robin stiffness [Pa/m] and damping [Pa s/m] must be finite and >= 0";
  if (max_newton_iterations < 1) return "max_newton_iterations must be >= 1";
  if (!(displacement_tolerance > 0) || !(pressure_tolerance > 0)) return "Newton tolerances must be positive";
  if (!(chord_contraction > 0 && chord_contraction < 1)) return "chord_contraction must be in (0, 1)";
  return {};
}

Elastodynamics::Elastodynamics(const Mechanics& mechanics, ElastodynamicsOptions options)
    : mech_(mechanics), opt_(std::move(options)) {
  if (auto m = opt_.validate(); !m.empty()) throw std::invalid_argument("ElastodynamicsOptions: " + m);
  const Mesh& mesh = mech_.mesh();
  const int n = mech_.n_unknowns();
  const int npt = mesh.nodes_per_tet();
  using Trip = Eigen::Triplet<double, int>;
  // Consistent mass: degree-5 rule, exact for P2 x P2 on straight tetrahedra.
  {
    std::vector<Trip> trip;
    trip.reserve(static_cast<size_t>(mesh.n_tets()) * static_cast<size_t>(npt * npt * 3));
    const auto& rule = tet_rule(5);
    Eigen::VectorXd N;
    Eigen::MatrixXd dN;
    Eigen::MatrixXd X(npt, 3), Me(npt, npt);
    for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
      for (int a = 0; a < npt; ++a) X.row(a) = mesh.nodes.row(mesh.tets(e, a));
      Me.setZero();
      for (const auto& qp : rule) {
        tet_shape(mesh.order, qp.xi, N, dN);
        const double dV = qp.weight * (X.transpose() * dN).determinant();
        Me.noalias() += opt_.density * dV * N * N.transpose();
      }
      for (int a = 0; a < npt; ++a)
        for (int b = 0; b < npt; ++b)
          for (int i = 0; i < 3; ++i) trip.emplace_back(3 * mesh.tets(e, a) + i, 3 * mesh.tets(e, b) + i, Me(a, b));
    }
    mass_.resize(n, n);
    mass_.setFromTriplets(trip.begin(), trip.end());
  }
  // Robin spring-dashpots on the reference faces: int N_a N_b (I or N (x) N) dA.
  {
    std::vector<Trip> tk, tc;
    const int npf = mesh.nodes_per_face();
    const auto& rule = tri_rule(4);
    Eigen::VectorXd N;
    Eigen::MatrixXd dN;
    Eigen::MatrixXd X(npf, 3);
    for (const auto& r : opt_.robin) {
      bool found = false;
      for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        if (mesh.face_tag[static_cast<size_t>(f)] != r.tag) continue;
        found = true;
        for (int a = 0; a < npf; ++a) X.row(a) = mesh.nodes.row(mesh.faces(f, a));
        for (const auto& qp : rule) {
          tri_shape(mesh.order, qp.xi, N, dN);
          const Eigen::Vector3d xa = X.transpose() * dN.col(0), xb = X.transpose() * dN.col(1);
          const Eigen::Vector3d nrm = xa.cross(xb);
          const double dA = qp.weight * nrm.norm();
          const Eigen::Vector3d unit = nrm.normalized();
          const Eigen::Matrix3d B =
              r.normal_only ? Eigen::Matrix3d(unit * unit.transpose()) : Eigen::Matrix3d::Identity();
          for (int a = 0; a < npf; ++a)
            for (int b = 0; b < npf; ++b)
              for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) {
                  const double w = dA * N[a] * N[b] * B(i, j);
                  if (w == 0.0) continue;
                  const int row = 3 * mesh.faces(f, a) + i, col = 3 * mesh.faces(f, b) + j;
                  if (r.stiffness != 0.0) tk.emplace_back(row, col, r.stiffness * w);
                  if (r.damping != 0.0) tc.emplace_back(row, col, r.damping * w);
                }
        }
      }
      if (!found) throw std::invalid_argument("Elastodynamics: no boundary face carries Robin tag " + std::to_string(r.tag));
    }
    k_robin_.resize(n, n);
    k_robin_.setFromTriplets(tk.begin(), tk.end());
    c_robin_.resize(n, n);
    c_robin_.setFromTriplets(tc.begin(), tc.end());
  }
  {
    const Newmark nm(opt_.time_step);
    step_tangent_ = nm.c0 * mass_ + k_robin_ + 0.5 * nm.c1 * c_robin_;  // dv/du = gamma c0 h = 2/h
  }
  solver_ = std::make_unique<SparseSolver>(opt_.linear_solver);
  solver_->set_saddle_point(3 * mesh.n_nodes());
  for (int i = 0; i < 3 * mesh.n_nodes(); ++i)
    if (mech_.is_fixed(i))
      throw std::invalid_argument("Elastodynamics: displacement Dirichlet conditions are not supported (dof " +
                                  std::to_string(i) + " is fixed); use Robin conditions");
}

bool Elastodynamics::residual(const DynamicState& xn, const State& trial, const Load& load, Eigen::VectorXd* G,
                              SparseMatrix* K, std::vector<Eigen::Matrix3d>* strains) const {
  const Newmark nm(opt_.time_step);
  const int nqp = mech_.n_quadrature_points();
  const double eta = opt_.viscosity;
  const double eta2h = 2.0 * eta / nm.h;
  // S_visc = eta (2 (E - E_n)/h - Edot_n): the trapezoidal strain rate.
  const StressHook hook = [&](int e, int q, const Eigen::Matrix3d& E, const Frame&, Eigen::Matrix3d& S, Matrix9d& D) {
    const size_t i = static_cast<size_t>(e) * static_cast<size_t>(nqp) + static_cast<size_t>(q);
    if (strains) (*strains)[i] = E;
    if (eta == 0.0) return;
    S += eta2h * (E - xn.E[i]) - eta * xn.Edot[i];
    D += eta2h * symmetric_identity();
  };
  if (strains) strains->resize(xn.E.size());
  if (!mech_.assemble(trial, load, G, K, hook)) return false;
  const Eigen::VectorXd a = nm.acceleration(xn, trial.u);
  const Eigen::VectorXd v = nm.velocity(xn, a);
  const Eigen::Index nu = trial.u.size();
  if (G) {
    G->head(nu) += mass_.topLeftCorner(nu, nu) * a + k_robin_.topLeftCorner(nu, nu) * trial.u +
                   c_robin_.topLeftCorner(nu, nu) * v;
    if (!G->allFinite()) return false;
  }
  if (K) *K += step_tangent_;
  return true;
}

DynamicState Elastodynamics::initial_state(const Load& load, double time) const {
  const Eigen::Index nqp = static_cast<Eigen::Index>(mech_.mesh().n_tets()) * mech_.n_quadrature_points();
  DynamicState x;
  x.time = time;
  x.s = mech_.initial_state();
  const Eigen::Index nu = x.s.u.size();
  x.v = Eigen::VectorXd::Zero(nu);
  x.a = Eigen::VectorXd::Zero(nu);
  x.E.assign(static_cast<size_t>(nqp), Eigen::Matrix3d::Zero());
  x.Edot.assign(static_cast<size_t>(nqp), Eigen::Matrix3d::Zero());
  Eigen::VectorXd R;
  if (!mech_.assemble(x.s, load, &R, nullptr)) throw std::invalid_argument("Elastodynamics: invalid initial state");
  const Eigen::VectorXd f = -R.head(nu);
  if (f.norm() > 0) {
    SparseMatrix M = mass_.topLeftCorner(nu, nu);
    SparseSolver solver(opt_.linear_solver);
    if (!solver.factorize(M)) throw std::invalid_argument("Elastodynamics: singular mass matrix");
    x.a = solver.solve(f);
  }
  return x;
}

StepRecord Elastodynamics::step(DynamicState& x, const Load& load_next) const {
  StepRecord rec;
  const Newmark nm(opt_.time_step);
  const Eigen::Index nu = x.s.u.size();
  State trial = x.s;
  trial.u += nm.h * x.v + 0.5 * nm.h * nm.h * x.a;  // constant-acceleration predictor
  SparseSolver& solver = *solver_;
  Eigen::VectorXd G;
  SparseMatrix K;
  std::vector<Eigen::Matrix3d> strains;
  // The chord (modified Newton) iteration: the factors of the tangent at the step's first
  // iterate serve while the updates contract by chord_contraction or better (Kelley 1995,
  // s.5.4: linear convergence at a rate set by the change of the tangent). The tangent of a
  // Newmark step is dominated by c0 M + K_robin, which the iterates do not change, so the rate
  // is small and one factorisation usually serves the whole step.
  bool have_factors = false;
  double previous_du = 0.0;
  for (int it = 0; it < opt_.max_newton_iterations; ++it) {
    const bool refactor = !opt_.chord || !have_factors;
    if (!residual(x, trial, load_next, &G, refactor ? &K : nullptr)) {
      rec.failure = "inverted element or non-finite residual";
      return rec;
    }
    if (refactor) {
      if (!solver.factorize(K)) {
        rec.failure = "singular tangent";
        return rec;
      }
      have_factors = true;
      ++rec.factorizations;
    }
    const Eigen::VectorXd dx = solver.solve(-G);
    if (!dx.allFinite()) {
      rec.failure = "non-finite Newton update";
      return rec;
    }
    trial.u += dx.head(nu);
    trial.p += dx.tail(trial.p.size());
    ++rec.iterations;
    const double du = dx.head(nu).lpNorm<Eigen::Infinity>();
    const double dp = trial.p.size() ? dx.tail(trial.p.size()).lpNorm<Eigen::Infinity>() : 0.0;
    rec.update_norms.push_back(du);
    // A chord update is accepted as the last only when it contracted by chord_contraction
    // (r <= 1/4): the error after it is then at most du r / (1 - r) < du, so the test is no
    // weaker than Newton's.
    const bool contracted = refactor || du <= opt_.chord_contraction * previous_du;
    if (du <= opt_.displacement_tolerance && dp <= opt_.pressure_tolerance && contracted) {
      // Strains of the accepted state for the strain-rate history.
      if (!residual(x, trial, load_next, nullptr, nullptr, &strains)) {
        rec.failure = "inverted element at the converged state";
        return rec;
      }
      rec.converged = true;
      break;
    }
    if (!contracted) have_factors = false;
    previous_du = du;
  }
  if (!rec.converged) {
    rec.failure = "Newton did not converge in " + std::to_string(opt_.max_newton_iterations) + " iterations";
    return rec;
  }
  const Eigen::VectorXd a = nm.acceleration(x, trial.u);
  const Eigen::VectorXd v = nm.velocity(x, a);
  for (size_t i = 0; i < strains.size(); ++i) {
    x.Edot[i] = 2.0 / nm.h * (strains[i] - x.E[i]) - x.Edot[i];
    x.E[i] = strains[i];
  }
  x.s = std::move(trial);
  x.v = v;
  x.a = a;
  x.time += nm.h;
  return rec;
}

double Elastodynamics::kinetic_energy(const DynamicState& x) const {
  const Eigen::Index nu = x.v.size();
  return 0.5 * x.v.dot(mass_.topLeftCorner(nu, nu) * x.v);
}

}  // namespace sigmaheart::model::fem
