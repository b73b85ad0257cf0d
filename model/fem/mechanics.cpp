#include "model/fem/mechanics.h"

#include "model/fem/element.h"

#include <Eigen/Dense>
#include "model/fem/solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

BaseCondition parse_base_condition(const std::string& s) {
  const auto l = lower(s);
  if (l == "fixed") return BaseCondition::kFixed;
  if (l == "sliding") return BaseCondition::kSliding;
  throw std::invalid_argument("unknown base condition '" + s + "' (expected fixed or sliding)");
}

LinearSolver parse_linear_solver(const std::string& s) {
  const auto l = lower(s);
  if (l == "auto") return LinearSolver::kAuto;
  if (l == "sparselu") return LinearSolver::kSparseLU;
  if (l == "umfpack") return LinearSolver::kUmfPack;
  if (l == "amg") return LinearSolver::kAmg;
  throw std::invalid_argument("unknown linear solver '" + s + "' (expected auto, sparselu, umfpack or amg)");
}

std::string MechanicsOptions::validate() const {
  if (bulk_modulus < 0) return "bulk_modulus must be >= 0 (0 means incompressible)";
  if (quadrature_degree < 1 || quadrature_degree > 5) return "quadrature_degree must be in 1..5";
  if (load_steps < 1) return "load_steps must be >= 1";
  if (max_newton_iterations < 1) return "max_newton_iterations must be >= 1";
  if (!(residual_tolerance > 0) || !(volume_tolerance > 0)) return "tolerances must be positive";
  if (max_step_cuts < 0) return "max_step_cuts must be >= 0";
  if (!(pressure_stabilization >= 0) || std::isinf(pressure_stabilization))
    return "pressure_stabilization must be finite and >= 0";
  if (pressure_stabilization > 0 && displacement_only) return "pressure_stabilization needs the pressure unknowns";
  if (!(grad_div >= 0) || std::isinf(grad_div)) return "grad_div must be finite and >= 0";
  if (grad_div > 0 && displacement_only) return "grad_div needs the pressure unknowns";
  return {};
}

IterativeOptions iterative_options_for(const MechanicsOptions& o) {
  IterativeOptions io;
  // With the stabilisation the Schur complement is bounded below by tau int grad p . grad q on
  // the spurious modes too, and SIMPLE's diagonal is the better approximation (docs/solvers.md
  // s.3).
  // One aggressively coarsened level halves the displacement hierarchy and keeps its size nearly in
  // proportion to the mesh; each iteration is cheaper, and the beat 12-35 % faster although it takes
  // 20-30 % more of them (bench/fem_bench BM_Lv3dGmresIterationBySize,
  // experiments/lv3d-solver/NOTES.md, "Where the time per iteration goes, and aggressive
  // coarsening").
  if (o.pressure_stabilization > 0) {
    io.schur = IterativeOptions::Schur::kDiagonal;
    io.aggressive_levels = 1;
  }
  // With the grad-div term the displacement block is stiff against dilatations too, and the true
  // Schur complement is spectrally the pressure mass over the stiffness (Stokes-like): on the
  // unloaded lv-3d tangent GMRES then takes 9-10 iterations to 1e-2 from 10 384 to 43 224 unknowns
  // (docs/models.md s.4.4, "Grad-div term").
  // That matrix is a mass plus a small Laplacian, so one V-cycle applies it as well as two (the same
  // GMRES iterations on the lv-3d tangents of 3 468-43 224 unknowns).
  if (o.grad_div > 0) {
    io.schur = IterativeOptions::Schur::kMass;
    io.schur_cycles = 1;
  }
  return io;
}

std::string Summary::brief_report() const {
  std::ostringstream os;
  os << (converged ? "converged" : "FAILED") << ": " << message << "; " << steps.size() << " load steps, "
     << newton_iterations << " Newton iterations, assembly " << assembly_seconds << " s, linear solves "
     << solve_seconds << " s";
  return os.str();
}

Mechanics::Mechanics(const Mesh& mesh, std::vector<Frame> frames, std::unique_ptr<Material> material,
                     MechanicsOptions options)
    : mesh_(mesh), frames_(std::move(frames)), material_(std::move(material)), opt_(std::move(options)) {
  if (auto m = opt_.validate(); !m.empty()) throw std::invalid_argument("MechanicsOptions: " + m);
  if (auto m = mesh_.check(); !m.empty()) throw std::invalid_argument("Mechanics: bad mesh: " + m);
  if (!material_) throw std::invalid_argument("Mechanics: no material");
  npt_ = mesh_.nodes_per_tet();
  const auto& rule = tet_rule(opt_.quadrature_degree);
  nqp_ = static_cast<int>(rule.size());
  const size_t ne = static_cast<size_t>(mesh_.n_tets());
  if (frames_.size() == ne * static_cast<size_t>(nqp_)) {
    frames_per_qp_ = true;
  } else if (frames_.size() != ne) {
    throw std::invalid_argument("Mechanics: need one frame per tetrahedron or per quadrature point (got " +
                                std::to_string(frames_.size()) + ", tets " + std::to_string(ne) + ")");
  }
  active_scale_.assign(ne, 1.0);
  ndof_ = 3 * mesh_.n_nodes() + mesh_.n_vertices;
  fixed_.assign(static_cast<size_t>(ndof_), 0);
  if (opt_.displacement_only)
    std::fill(fixed_.begin() + 3 * mesh_.n_nodes(), fixed_.end(), static_cast<char>(1));

  grad_.resize(ne * static_cast<size_t>(nqp_ * npt_ * 3));
  dv_.resize(ne * static_cast<size_t>(nqp_));
  np_.resize(static_cast<size_t>(nqp_));
  std::vector<Eigen::VectorXd> Nq(static_cast<size_t>(nqp_));
  std::vector<Eigen::MatrixXd> dNq(static_cast<size_t>(nqp_));
  for (int q = 0; q < nqp_; ++q) {
    tet_shape(mesh_.order, rule[static_cast<size_t>(q)].xi, Nq[static_cast<size_t>(q)], dNq[static_cast<size_t>(q)]);
    const auto& xi = rule[static_cast<size_t>(q)].xi;
    np_[static_cast<size_t>(q)] = Eigen::Vector4d(1 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]);
  }
  ref_volume_ = 0.0;
  for (size_t e = 0; e < ne; ++e) {
    Eigen::MatrixXd X(npt_, 3);
    for (int a = 0; a < npt_; ++a) X.row(a) = mesh_.nodes.row(mesh_.tets(static_cast<Eigen::Index>(e), a));
    for (int q = 0; q < nqp_; ++q) {
      const Eigen::Matrix3d J0 = X.transpose() * dNq[static_cast<size_t>(q)];  // dX/dxi
      const double det = J0.determinant();
      if (!(det > 0))
        throw std::invalid_argument("Mechanics: tetrahedron " + std::to_string(e) + " has a non-positive Jacobian");
      const Eigen::MatrixXd g = dNq[static_cast<size_t>(q)] * J0.inverse();  // npt x 3
      double* out = &grad_[(e * static_cast<size_t>(nqp_) + static_cast<size_t>(q)) * static_cast<size_t>(npt_ * 3)];
      for (int a = 0; a < npt_; ++a)
        for (int d = 0; d < 3; ++d) out[a * 3 + d] = g(a, d);
      dv_[e * static_cast<size_t>(nqp_) + static_cast<size_t>(q)] = rule[static_cast<size_t>(q)].weight * det;
      ref_volume_ += rule[static_cast<size_t>(q)].weight * det;
    }
  }
  if (opt_.quadrature_degree < 2 && opt_.bulk_modulus > 0 && !std::isinf(opt_.bulk_modulus)) {
    // A one-point rule would make each element's pressure mass int N_k N_l dV of rank one, and
    // pressure fields with zero element means would escape both the constraint and the
    // penalty: the element pressure mass matrices are integrated exactly (degree 2) instead.
    const auto& rule2 = tet_rule(2);
    pressure_mass_.assign(ne, Eigen::Matrix4d::Zero());
    Eigen::VectorXd N;
    Eigen::MatrixXd dN;
    for (size_t e = 0; e < ne; ++e) {
      Eigen::MatrixXd X(npt_, 3);
      for (int a = 0; a < npt_; ++a) X.row(a) = mesh_.nodes.row(mesh_.tets(static_cast<Eigen::Index>(e), a));
      for (const auto& qp : rule2) {
        tet_shape(mesh_.order, qp.xi, N, dN);
        const Eigen::Vector4d Np(1 - qp.xi[0] - qp.xi[1] - qp.xi[2], qp.xi[0], qp.xi[1], qp.xi[2]);
        pressure_mass_[e] += qp.weight * (X.transpose() * dN).determinant() * Np * Np.transpose();
      }
    }
  }
  for (Eigen::Index f = 0; f < mesh_.faces.rows(); ++f)
    if (std::find(opt_.pressure_surfaces.begin(), opt_.pressure_surfaces.end(), mesh_.face_tag[static_cast<size_t>(f)]) !=
        opt_.pressure_surfaces.end())
      load_faces_.push_back(static_cast<int>(f));
  build_pattern();
  if (opt_.pressure_stabilization > 0) {
    // Brezzi & Pitkaranta 1984 (in Efficient Solutions of Elliptic Systems, Notes Numer. Fluid
    // Mech. 10:11-19): -tau_e int grad p . grad q dV on the pressure rows of each element, with the
    // P1 gradients of its four vertices (constant on the element; the pressure is P1 on the
    // vertices for both element orders).
    stab_laplacian_.resize(ne);
    stab_h2_.resize(ne);
    Eigen::VectorXd N1;
    Eigen::MatrixXd dN1;  // d(lambda_k)/d(xi), constant
    tet_shape(1, Eigen::Vector3d::Zero(), N1, dN1);
    for (size_t e = 0; e < ne; ++e) {
      Eigen::Matrix3d J0;
      for (int c = 0; c < 3; ++c)
        J0.col(c) = (mesh_.nodes.row(mesh_.tets(static_cast<Eigen::Index>(e), c + 1)) -
                     mesh_.nodes.row(mesh_.tets(static_cast<Eigen::Index>(e), 0)))
                        .transpose();
      const double vol = J0.determinant() / 6.0;
      const Eigen::MatrixXd G = dN1 * J0.inverse();  // 4 x 3 vertex P1 gradients
      stab_laplacian_[e] = vol * G * G.transpose();
      // Edge of the regular tetrahedron of volume vol: vol = a^3 / (6 sqrt 2).
      stab_h2_[e] = std::pow(6.0 * std::sqrt(2.0) * vol, 2.0 / 3.0);
    }
  }
  if (opt_.pressure_stabilization > 0 || opt_.grad_div > 0) {
    stab_mu_ref_.assign(ne, 0.0);
    if (opt_.pressure_stabilization > 0) stab_tau_.assign(ne, 0.0);
    if (opt_.grad_div > 0) grad_div_gamma_.assign(ne, 0.0);
    std::vector<double> mu;
    if (!assemble_impl(initial_state(), Load{}, nullptr, nullptr, {}, &mu))
      throw std::invalid_argument("Mechanics: the unloaded reference could not be assembled");
    for (size_t e = 0; e < ne; ++e)
      if (!(mu[e] > 0))
        throw std::invalid_argument("Mechanics: pressure_stabilization and grad_div need a material with a "
                                    "positive shear stiffness in the reference (element " +
                                    std::to_string(e) + ")");
    stab_mu_ref_ = mu;
    set_stabilization_tau(mu);
  }
}

void Mechanics::set_stabilization_tau(const std::vector<double>& mu) {
  elem_mu_.resize(mu.size());
  for (size_t e = 0; e < mu.size(); ++e) elem_mu_[e] = std::max(mu[e], stab_mu_ref_[e]);
  for (size_t e = 0; e < stab_tau_.size(); ++e)
    stab_tau_[e] = opt_.pressure_stabilization * stab_h2_[e] / (2.0 * elem_mu_[e]);
  for (size_t e = 0; e < grad_div_gamma_.size(); ++e) grad_div_gamma_[e] = 2.0 * opt_.grad_div * elem_mu_[e];
}

SparseMatrix Mechanics::schur_mass() const {
  const int nv = mesh_.n_vertices;
  SparseMatrix M(nv, nv);
  if (grad_div_gamma_.empty()) return M;
  const int nu = 3 * mesh_.n_nodes();
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(static_cast<size_t>(mesh_.n_tets()) * 16);
  for (Eigen::Index e = 0; e < mesh_.tets.rows(); ++e) {
    // int N_k N_l dV = V (1 + delta_kl) / 20 for the P1 functions of a straight tetrahedron, V the
    // sum of the element's quadrature weights (dv_).
    const size_t es = static_cast<size_t>(e);
    double vol = 0.0;
    for (int q = 0; q < nqp_; ++q) vol += dv_[es * static_cast<size_t>(nqp_) + static_cast<size_t>(q)];
    const double w = vol / 20.0 / (2.0 * elem_mu_[es] + grad_div_gamma_[es]);
    for (int k = 0; k < 4; ++k)
      for (int l = 0; l < 4; ++l) {
        const int a = mesh_.tets(e, k), b = mesh_.tets(e, l);
        if (fixed_[static_cast<size_t>(nu + a)] || fixed_[static_cast<size_t>(nu + b)]) continue;
        trip.emplace_back(a, b, w * (k == l ? 2.0 : 1.0));
      }
  }
  M.setFromTriplets(trip.begin(), trip.end());
  return M;
}

bool Mechanics::update_stabilization(const State& s, const Load& load, const StressHook& hook) {
  if (stab_mu_ref_.empty()) return true;
  std::vector<double> mu;
  if (!assemble_impl(s, load, nullptr, nullptr, hook, &mu)) return false;
  set_stabilization_tau(mu);
  return true;
}

void Mechanics::build_pattern() {
  const int nv = mesh_.n_nodes();
  const int nloc = 3 * npt_ + 4;
  auto dofs_of = [&](Eigen::Index e, std::vector<int>& d) {
    d.resize(static_cast<size_t>(nloc));
    for (int a = 0; a < npt_; ++a)
      for (int i = 0; i < 3; ++i) d[static_cast<size_t>(3 * a + i)] = 3 * mesh_.tets(e, a) + i;
    for (int q = 0; q < 4; ++q) d[static_cast<size_t>(3 * npt_ + q)] = 3 * nv + mesh_.tets(e, q);
  };
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(static_cast<size_t>(mesh_.n_tets()) * static_cast<size_t>(nloc * nloc));
  std::vector<int> d;
  for (Eigen::Index e = 0; e < mesh_.tets.rows(); ++e) {
    dofs_of(e, d);
    for (int r : d)
      for (int c : d) trip.emplace_back(r, c, 0.0);
  }
  // Greedy element colouring: an element takes the first colour none of its nodes has yet.
  {
    std::vector<std::vector<int>> node_colours(static_cast<size_t>(nv));
    colours_.clear();
    for (Eigen::Index e = 0; e < mesh_.tets.rows(); ++e) {
      size_t c = 0;
      for (;; ++c) {
        bool free = true;
        for (int a = 0; a < npt_ && free; ++a) {
          const auto& used = node_colours[static_cast<size_t>(mesh_.tets(e, a))];
          free = std::find(used.begin(), used.end(), static_cast<int>(c)) == used.end();
        }
        if (free) break;
      }
      if (c == colours_.size()) colours_.emplace_back();
      colours_[c].push_back(static_cast<int>(e));
      for (int a = 0; a < npt_; ++a) node_colours[static_cast<size_t>(mesh_.tets(e, a))].push_back(static_cast<int>(c));
    }
  }
  pattern_.resize(ndof_, ndof_);
  pattern_.setFromTriplets(trip.begin(), trip.end());
  pattern_.makeCompressed();
  trip.clear();
  trip.shrink_to_fit();
  auto pos = [&](int r, int c) {
    const int* inner = pattern_.innerIndexPtr();
    const int b = pattern_.outerIndexPtr()[c], en = pattern_.outerIndexPtr()[c + 1];
    const int* it = std::lower_bound(inner + b, inner + en, r);
    return static_cast<int>(it - inner);
  };
  elem_pos_.resize(static_cast<size_t>(mesh_.n_tets()) * static_cast<size_t>(nloc * nloc));
  for (Eigen::Index e = 0; e < mesh_.tets.rows(); ++e) {
    dofs_of(e, d);
    int* out = &elem_pos_[static_cast<size_t>(e) * static_cast<size_t>(nloc * nloc)];
    for (int r = 0; r < nloc; ++r)
      for (int c = 0; c < nloc; ++c) out[r * nloc + c] = pos(d[static_cast<size_t>(r)], d[static_cast<size_t>(c)]);
  }
  const int npf = mesh_.nodes_per_face();
  const int nf = 3 * npf;
  face_pos_.resize(load_faces_.size() * static_cast<size_t>(nf * nf));
  for (size_t k = 0; k < load_faces_.size(); ++k) {
    const Eigen::Index f = load_faces_[k];
    for (int a = 0; a < npf; ++a)
      for (int i = 0; i < 3; ++i)
        for (int b = 0; b < npf; ++b)
          for (int j = 0; j < 3; ++j)
            face_pos_[k * static_cast<size_t>(nf * nf) + static_cast<size_t>((3 * a + i) * nf + 3 * b + j)] =
                pos(3 * mesh_.faces(f, a) + i, 3 * mesh_.faces(f, b) + j);
  }
}

void Mechanics::fix_dof(int node, int component) {
  if (node < 0 || node >= mesh_.n_nodes() || component < 0 || component > 2)
    throw std::invalid_argument("fix_dof: node or component out of range");
  fixed_[static_cast<size_t>(3 * node + component)] = 1;
}

void Mechanics::fix_surface(int tag) {
  for (int n : mesh_.nodes_with_tag(tag))
    for (int i = 0; i < 3; ++i) fix_dof(n, i);
}

void Mechanics::apply_base_condition(int tag, BaseCondition bc) {
  const auto nodes = mesh_.nodes_with_tag(tag);
  if (nodes.empty()) throw std::invalid_argument("apply_base_condition: no face carries tag " + std::to_string(tag));
  if (bc == BaseCondition::kFixed) {
    fix_surface(tag);
    return;
  }
  // Sliding: the normal (z) component everywhere; in-plane rigid modes removed at the node with
  // the largest x (x and y fixed) and the node with the smallest x (y fixed).
  int imax = nodes.front(), imin = nodes.front();
  for (int n : nodes) {
    fix_dof(n, 2);
    if (mesh_.nodes(n, 0) > mesh_.nodes(imax, 0)) imax = n;
    if (mesh_.nodes(n, 0) < mesh_.nodes(imin, 0)) imin = n;
  }
  fix_dof(imax, 0);
  fix_dof(imax, 1);
  fix_dof(imin, 1);
}

void Mechanics::set_active_scale(std::vector<double> scale) {
  if (scale.size() != static_cast<size_t>(mesh_.n_tets()))
    throw std::invalid_argument("set_active_scale: need one value per tetrahedron");
  active_scale_ = std::move(scale);
}

State Mechanics::initial_state() const {
  return {Eigen::VectorXd::Zero(3 * mesh_.n_nodes()), Eigen::VectorXd::Zero(mesh_.n_vertices)};
}

Eigen::Vector3d Mechanics::position(const State& s, int node) const {
  return mesh_.nodes.row(node).transpose() + s.u.segment<3>(3 * node);
}

std::vector<Frame> Mechanics::element_frames() const {
  std::vector<Frame> out(static_cast<size_t>(mesh_.n_tets()));
  for (size_t e = 0; e < out.size(); ++e) out[e] = frames_per_qp_ ? frames_[e * static_cast<size_t>(nqp_)] : frames_[e];
  return out;
}

bool Mechanics::assemble(const State& s, const Load& load, Eigen::VectorXd* residual, SparseMatrix* tangent,
                         const StressHook& hook) const {
  return assemble_impl(s, load, residual, tangent, hook, nullptr);
}

bool Mechanics::assemble_impl(const State& s, const Load& load, Eigen::VectorXd* residual, SparseMatrix* tangent,
                              const StressHook& hook, std::vector<double>* element_mu) const {
  if (element_mu) element_mu->assign(static_cast<size_t>(mesh_.n_tets()), 0.0);
  const int nv = mesh_.n_nodes();
  const int nloc = 3 * npt_ + 4;
  const bool incompressible = !(opt_.bulk_modulus > 0) || std::isinf(opt_.bulk_modulus);
  const double inv_kappa = incompressible ? 0.0 : 1.0 / opt_.bulk_modulus;
  if (residual) residual->setZero(ndof_);
  if (tangent) {
    *tangent = pattern_;
    std::fill(tangent->valuePtr(), tangent->valuePtr() + tangent->nonZeros(), 0.0);
  }
  double* kv = tangent ? tangent->valuePtr() : nullptr;
  bool ok = true;
  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();

#pragma omp parallel
  {
    Eigen::MatrixXd ue(npt_, 3);
    Eigen::Vector4d pe;
    Eigen::VectorXd Re(nloc);
    Eigen::MatrixXd Ke(nloc, nloc);
    Eigen::Matrix3d S;
    Matrix9d D, G, A;
    Eigen::Matrix<double, 3, 9> M;
    bool ok_local = true;
    for (const auto& colour : colours_) {
#pragma omp for schedule(static)
    for (size_t ci = 0; ci < colour.size(); ++ci) {
      const Eigen::Index e = colour[ci];
      for (int a = 0; a < npt_; ++a) ue.row(a) = s.u.segment<3>(3 * mesh_.tets(e, a)).transpose();
      for (int q = 0; q < 4; ++q) pe[q] = s.p[mesh_.tets(e, q)];
      Re.setZero();
      if (tangent) Ke.setZero();
      double grad2 = 0.0, element_diag = 0.0;  // sum_q sum_a |grad N_a|^2 dV, the diagonal (element_mu)
      const double ta = load.active_tension * active_scale_[static_cast<size_t>(e)];
      const double gd = grad_div_gamma_.empty() ? 0.0 : grad_div_gamma_[static_cast<size_t>(e)];
      for (int q = 0; q < nqp_; ++q) {
        const size_t eq = static_cast<size_t>(e) * static_cast<size_t>(nqp_) + static_cast<size_t>(q);
        const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>> g(
            &grad_[eq * static_cast<size_t>(npt_ * 3)], npt_, 3);
        const double dV = dv_[eq];
        const Frame& R = frames_per_qp_ ? frames_[eq] : frames_[static_cast<size_t>(e)];
        const Eigen::Matrix3d F = I3 + ue.transpose() * g;
        const double J = F.determinant();
        if (!(J > 0) || !std::isfinite(J)) {
          ok_local = false;
          break;
        }
        const Eigen::Matrix3d E = 0.5 * (F.transpose() * F - I3);
        if (tangent || element_mu) {
          material_->stress(E, R, S, D);
        } else {
          material_->stress_only(E, R, S);
          if (hook) D.setZero();
        }
        if (hook) hook(static_cast<int>(e), q, E, R, S, D);
        if (ta != 0.0) S += ta * R.col(0) * R.col(0).transpose();
        const Eigen::Matrix3d FiT = F.inverse().transpose();
        const Eigen::Vector4d& Np = np_[static_cast<size_t>(q)];
        const double pq = Np.dot(pe);
        // Grad-div term gd / 2 (J - 1 + p / kappa)^2: the displacement rows see the pressure
        // pq - gd c, the pressure rows -(1 - gd / kappa) c (c the constraint's value at the point).
        const double cq = (J - 1.0) + pq * inv_kappa;
        const double peff = pq - gd * cq;
        const Eigen::Matrix3d P = F * S - peff * J * FiT;
        // Residual.
        const Eigen::MatrixXd gP = g * P.transpose();  // npt x 3: (a, i) = sum_I g(a,I) P(i,I)
        for (int a = 0; a < npt_; ++a)
          for (int i = 0; i < 3; ++i) Re[3 * a + i] += dV * gP(a, i);
        const double pen = pressure_mass_.empty() ? pq * inv_kappa : 0.0;  // else below, exactly
        for (int k = 0; k < 4; ++k) Re[3 * npt_ + k] -= dV * ((J - 1.0) + pen) * Np[k];
        if (gd != 0.0 && inv_kappa != 0.0)
          for (int k = 0; k < 4; ++k) Re[3 * npt_ + k] += dV * gd * inv_kappa * cq * Np[k];
        if (element_mu) {
          // The displacement diagonal of the element tangent, sum_a sum_i g_a^T A_i g_a with the
          // 3x3 blocks A_i(I, J) = A(iI, iJ) = sum_KL F_iK D(KI, LJ) F_iL + S_IJ (the pressure's
          // geometric term vanishes on them), without the rest of the element matrix.
          double diag = 0.0;
          for (int i = 0; i < 3; ++i) {
            Eigen::Matrix3d Ai = S;
            for (int I = 0; I < 3; ++I)
              for (int Jj = 0; Jj < 3; ++Jj)
                for (int K = 0; K < 3; ++K)
                  for (int L = 0; L < 3; ++L) Ai(I, Jj) += F(i, K) * D(3 * K + I, 3 * L + Jj) * F(i, L);
            for (int a = 0; a < npt_; ++a) diag += g.row(a) * Ai * g.row(a).transpose();
          }
          element_diag += dV * diag;
          grad2 += dV * g.squaredNorm();
        }
        if (!tangent) continue;
        // A(iI, jJ) = delta_ij S_IJ + F_iK D(KI, LJ) F_jL - p J (FiT_iI FiT_jJ - FiT_iJ FiT_jI).
        for (int i = 0; i < 3; ++i)
          for (int I = 0; I < 3; ++I)
            for (int c = 0; c < 9; ++c)
              G(3 * i + I, c) = F(i, 0) * D(I, c) + F(i, 1) * D(3 + I, c) + F(i, 2) * D(6 + I, c);
        for (int r = 0; r < 9; ++r)
          for (int j = 0; j < 3; ++j)
            for (int Jj = 0; Jj < 3; ++Jj)
              A(r, 3 * j + Jj) = G(r, Jj) * F(j, 0) + G(r, 3 + Jj) * F(j, 1) + G(r, 6 + Jj) * F(j, 2);
        for (int i = 0; i < 3; ++i)
          for (int I = 0; I < 3; ++I)
            for (int Jj = 0; Jj < 3; ++Jj) {
              A(3 * i + I, 3 * i + Jj) += S(I, Jj);
              for (int j = 0; j < 3; ++j)
                A(3 * i + I, 3 * j + Jj) -= peff * J * (FiT(i, I) * FiT(j, Jj) - FiT(i, Jj) * FiT(j, I));
            }
        for (int a = 0; a < npt_; ++a) {
          for (int i = 0; i < 3; ++i)
            for (int c = 0; c < 9; ++c)
              M(i, c) = g(a, 0) * A(3 * i, c) + g(a, 1) * A(3 * i + 1, c) + g(a, 2) * A(3 * i + 2, c);
          for (int b = 0; b < npt_; ++b)
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j)
                Ke(3 * a + i, 3 * b + j) +=
                    dV * (M(i, 3 * j) * g(b, 0) + M(i, 3 * j + 1) * g(b, 1) + M(i, 3 * j + 2) * g(b, 2));
          // K_up(a i, k) = -J FiT_iI g(a, I) Np_k (1 - gd / kappa)
          const Eigen::Vector3d fg = FiT * g.row(a).transpose();
          if (gd != 0.0) {
            // gd dJ (x) dJ, dJ = J F^-T : grad v
            for (int b = 0; b < npt_; ++b) {
              const Eigen::Vector3d fgb = FiT * g.row(b).transpose();
              for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) Ke(3 * a + i, 3 * b + j) += dV * gd * J * J * fg[i] * fgb[j];
            }
          }
          for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 4; ++k) {
              const double v = -dV * J * fg[i] * Np[k] * (1.0 - gd * inv_kappa);
              Ke(3 * a + i, 3 * npt_ + k) += v;
              Ke(3 * npt_ + k, 3 * a + i) += v;
            }
        }
        if (inv_kappa != 0.0 && pressure_mass_.empty())
          for (int k = 0; k < 4; ++k)
            for (int l = 0; l < 4; ++l) Ke(3 * npt_ + k, 3 * npt_ + l) -= dV * inv_kappa * Np[k] * Np[l];
        if (gd != 0.0 && inv_kappa != 0.0)
          for (int k = 0; k < 4; ++k)
            for (int l = 0; l < 4; ++l)
              Ke(3 * npt_ + k, 3 * npt_ + l) += dV * gd * inv_kappa * inv_kappa * Np[k] * Np[l];
      }
      if (!ok_local) continue;
      if (!pressure_mass_.empty()) {
        const Eigen::Matrix4d& Mp = pressure_mass_[static_cast<size_t>(e)];
        Re.tail<4>() -= inv_kappa * (Mp * pe);
        if (tangent) Ke.bottomRightCorner<4, 4>() -= inv_kappa * Mp;
      }
      if (!stab_tau_.empty()) {
        const double tau = stab_tau_[static_cast<size_t>(e)];
        const Eigen::Matrix4d& Lp = stab_laplacian_[static_cast<size_t>(e)];
        Re.tail<4>() -= tau * (Lp * pe);
        if (tangent) Ke.bottomRightCorner<4, 4>() -= tau * Lp;
      }
      if (element_mu) (*element_mu)[static_cast<size_t>(e)] = element_diag / (4.0 * grad2);
      if (residual) {
        // No two elements of a colour share a node: plain adds, no race, a fixed order.
        for (int a = 0; a < npt_; ++a)
          for (int i = 0; i < 3; ++i) (*residual)[3 * mesh_.tets(e, a) + i] += Re[3 * a + i];
        for (int k = 0; k < 4; ++k) (*residual)[3 * nv + mesh_.tets(e, k)] += Re[3 * npt_ + k];
      }
      if (tangent) {
        const int* pos = &elem_pos_[static_cast<size_t>(e) * static_cast<size_t>(nloc * nloc)];
        for (int r = 0; r < nloc; ++r)
          for (int c = 0; c < nloc; ++c) {
            const double v = Ke(r, c);
            // Column-major storage: Ke(r, c) goes to entry (row r, column c).
            kv[pos[r * nloc + c]] += v;
          }
      }
    }
    }  // colours
    if (!ok_local) {
#pragma omp atomic write
      ok = false;
    }
  }
  if (!ok) return false;

  // Follower pressure: R_a += P int N_a (x_xi x x_eta), K_ab += P int N_a (dN_b,xi (-[x_eta]x) + dN_b,eta [x_xi]x).
  if (load.pressure != 0.0 && !load_faces_.empty()) {
    const int npf = mesh_.nodes_per_face();
    const int nf = 3 * npf;
    const auto& rule = tri_rule(mesh_.order == 2 ? 4 : 2);
    Eigen::VectorXd N;
    Eigen::MatrixXd dN;
    Eigen::MatrixXd x(npf, 3);
    for (size_t k = 0; k < load_faces_.size(); ++k) {
      const Eigen::Index f = load_faces_[k];
      for (int a = 0; a < npf; ++a) x.row(a) = position(s, mesh_.faces(f, a)).transpose();
      for (const auto& qp : rule) {
        tri_shape(mesh_.order, qp.xi, N, dN);
        const Eigen::Vector3d xa = x.transpose() * dN.col(0), xb = x.transpose() * dN.col(1);
        const Eigen::Vector3d n = xa.cross(xb);
        const double w = load.pressure * qp.weight;
        if (residual)
          for (int a = 0; a < npf; ++a) residual->segment<3>(3 * mesh_.faces(f, a)) += w * N[a] * n;
        if (tangent) {
          const Eigen::Matrix3d Sa = skew(xa), Sb = skew(xb);
          const int* pos = &face_pos_[k * static_cast<size_t>(nf * nf)];
          for (int a = 0; a < npf; ++a)
            for (int b = 0; b < npf; ++b) {
              const Eigen::Matrix3d Kab = w * N[a] * (-dN(b, 0) * Sb + dN(b, 1) * Sa);
              for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) kv[pos[(3 * a + i) * nf + 3 * b + j]] += Kab(i, j);
            }
        }
      }
    }
  }

  // Dirichlet rows and columns -> identity.
  if (residual)
    for (int i = 0; i < ndof_; ++i)
      if (fixed_[static_cast<size_t>(i)]) (*residual)[i] = 0.0;
  if (tangent) {
    for (int c = 0; c < ndof_; ++c)
      for (int k = tangent->outerIndexPtr()[c]; k < tangent->outerIndexPtr()[c + 1]; ++k) {
        const int r = tangent->innerIndexPtr()[k];
        if (fixed_[static_cast<size_t>(r)] || fixed_[static_cast<size_t>(c)]) kv[k] = (r == c) ? 1.0 : 0.0;
      }
  }
  if (residual && !residual->allFinite()) return false;
  return true;
}

Eigen::VectorXd Mechanics::pressure_load(const State& s) const {
  Eigen::VectorXd b = Eigen::VectorXd::Zero(3 * mesh_.n_nodes());
  const int npf = mesh_.nodes_per_face();
  const auto& rule = tri_rule(mesh_.order == 2 ? 4 : 2);
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Eigen::MatrixXd x(npf, 3);
  for (const int f : load_faces_) {
    for (int a = 0; a < npf; ++a) x.row(a) = position(s, mesh_.faces(f, a)).transpose();
    for (const auto& qp : rule) {
      tri_shape(mesh_.order, qp.xi, N, dN);
      const Eigen::Vector3d xa = x.transpose() * dN.col(0), xb = x.transpose() * dN.col(1);
      const Eigen::Vector3d n = xa.cross(xb);
      for (int a = 0; a < npf; ++a) b.segment<3>(3 * mesh_.faces(f, a)) += qp.weight * N[a] * n;
    }
  }
  for (Eigen::Index i = 0; i < b.size(); ++i)
    if (fixed_[static_cast<size_t>(i)]) b[i] = 0.0;
  return b;
}

Summary Mechanics::solve(State& state, const Load& from, const Load& to, const ProgressCallback& progress) {
  Summary sum;
  const int nu = 3 * mesh_.n_nodes();
  SparseSolver solver(opt_.linear_solver, iterative_options_for(opt_));
  solver.set_saddle_point(nu);
  Eigen::VectorXd R;
  SparseMatrix K;
  auto load_at = [&](double lam) {
    return Load{from.pressure + lam * (to.pressure - from.pressure),
                from.active_tension + lam * (to.active_tension - from.active_tension)};
  };
  double lam = 0.0;
  double dlam = 1.0 / opt_.load_steps;
  int cuts = 0;
  State prev;
  double prev_lam = 0.0;
  bool have_prev = false;
  while (lam < 1.0 - 1e-14) {
    const double target = std::min(1.0, lam + dlam);
    const Load L = load_at(target);
    // tau of the stabilisation from the step's start point (a no-op without it).
    update_stabilization(state, load_at(lam));
    State trial = state;
    // Secant predictor: extrapolate the last converged increment to the new load fraction.
    if (have_prev && lam - prev_lam > 0) {
      const double r = (target - lam) / (lam - prev_lam);
      trial.u += r * (state.u - prev.u);
      trial.p += r * (state.p - prev.p);
      if (!assemble(trial, L, nullptr, nullptr)) trial = state;
    }
    NewtonRecord rec;
    rec.lambda = target;
    double r0 = -1.0;
    bool step_ok = false;
    for (int it = 0; it < opt_.max_newton_iterations; ++it) {
      auto t0 = Clock::now();
      const bool valid = assemble(trial, L, &R, &K);
      sum.assembly_seconds += seconds_since(t0);
      if (!valid) {
        rec.failure = "inverted element or non-finite residual";
        break;
      }
      const double ru = R.head(nu).norm();
      const double rp = R.tail(mesh_.n_vertices).norm();
      rec.residual = ru;
      rec.history.push_back(ru);
      if (r0 < 0) r0 = std::max(ru, 1e-300);
      if ((ru <= opt_.residual_tolerance * r0 || ru == 0.0) && rp <= opt_.volume_tolerance * ref_volume_ && it > 0) {
        step_ok = true;
        break;
      }
      if (ru == 0.0 && rp == 0.0) {
        step_ok = true;
        break;
      }
      t0 = Clock::now();
      if (!grad_div_gamma_.empty()) solver.set_schur_mass(schur_mass());
      const bool fact = solver.factorize(K);
      if (!fact) {
        sum.solve_seconds += seconds_since(t0);
        rec.failure = "singular tangent";
        break;
      }
      const Eigen::VectorXd dx = solver.solve(-R);
      sum.solve_seconds += seconds_since(t0);
      if (!dx.allFinite()) {
        rec.failure = "non-finite Newton update";
        break;
      }
      // Backtracking: halve the update while it inverts an element or blows the residual up
      // (the exponential laws make full Newton steps overshoot at large load increments).
      double alpha = 1.0;
      bool accepted = false;
      for (int ls = 0; ls < 12; ++ls, alpha *= 0.5) {
        State cand = trial;
        cand.u += alpha * dx.head(nu);
        cand.p += alpha * dx.tail(mesh_.n_vertices);
        Eigen::VectorXd Rc;
        t0 = Clock::now();
        const bool v = assemble(cand, L, &Rc, nullptr);
        sum.assembly_seconds += seconds_since(t0);
        if (v && Rc.head(nu).norm() <= 2.0 * ru + 1e-300) {
          trial = std::move(cand);
          accepted = true;
          break;
        }
      }
      if (!accepted) {
        rec.failure = "line search found no admissible step";
        break;
      }
      ++rec.iterations;
      ++sum.newton_iterations;
    }
    rec.converged = step_ok;
    sum.steps.push_back(rec);
    if (step_ok) {
      prev = state;
      prev_lam = lam;
      have_prev = true;
      state = trial;
      lam = target;
      if (progress) progress(lam, rec.iterations, rec.residual);
      // Grow the increment back after a cut once a step went through easily.
      if (cuts > 0 && rec.iterations <= 4) dlam = std::min(1.0 / opt_.load_steps, 2.0 * dlam);
    } else {
      if (++cuts > opt_.max_step_cuts) {
        sum.converged = false;
        std::ostringstream os;
        os << "Newton failed at load fraction " << target << " after " << opt_.max_step_cuts << " step cuts";
        sum.message = os.str();
        if (sum.newton_iterations > 0) sum.factor_nonzeros = solver.factor_nonzeros();
        return sum;
      }
      dlam *= 0.5;
    }
  }
  sum.converged = true;
  sum.message = "target load reached";
  if (sum.newton_iterations > 0) sum.factor_nonzeros = solver.factor_nonzeros();
  return sum;
}

}  // namespace sigmaheart::model::fem
