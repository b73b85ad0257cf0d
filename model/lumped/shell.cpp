#include "model/lumped/shell.h"

#include "model/periodic_shooting.h"

#include <algorithm>
#include <cmath>

namespace sigmaheart::model::lumped::shell {

const std::vector<std::string>& global_names() {
  static const std::vector<std::string> names = {
      "rho",  "R0",     "d0",   "c1",   "c2",   "eta",  "Es",  "mu",  "alpha", "k0",
      "k_ATP", "k_RS",  "APD",  "period", "K_at", "K_ar", "K_p", "R_p", "R_d", "C_p",
      "C_d",  "P_sv",   "P_at0", "P_at_kick", "C_cav", "n0_slope", "n0_e_max", "c_exp", "b_exp"};
  return names;
}

std::vector<int> global_indices(const ParameterSpace& space, bool atrial_chamber) {
  std::vector<int> idx;
  idx.reserve(global_names().size());
  for (const auto& n : global_names()) {
    const bool prescribed_atrium = n == "P_at0" || n == "P_at_kick";
    idx.push_back(atrial_chamber && prescribed_atrium ? -1 : space.index_or_throw(n));
  }
  return idx;
}

const std::vector<std::string>& atrium_names() {
  static const std::vector<std::string> names = {"E_at_min", "E_at_max", "V_at0", "P_pv", "R_pv"};
  return names;
}

std::vector<int> atrium_indices(const ParameterSpace& space) {
  std::vector<int> idx;
  for (const auto& n : atrium_names()) idx.push_back(space.index_or_throw(n));
  return idx;
}

Shell unpack(const Eigen::Ref<const Eigen::VectorXd>& theta, const std::vector<int>& global,
             const std::vector<int>* atrium, int atrium_entry) {
  auto at = [&](int k) {
    const int i = global[static_cast<size_t>(k)];
    return i < 0 ? 0.0 : theta(i);  // -1: P_at0, P_at_kick beside an atrial chamber (unused)
  };
  Shell m;
  m.rho = at(kRho);
  m.R0 = at(kR0);
  m.d0 = at(kD0);
  m.c1 = at(kC1);
  m.c2 = at(kC2);
  m.c_exp = at(kCexp);
  m.b_exp = at(kBexp);
  m.eta = at(kEta);
  m.period = at(kPeriod);
  m.act.Es = at(kEs);
  m.act.mu = at(kMu);
  m.act.alpha = at(kAlpha);
  m.act.k0 = at(kK0);
  m.act.sigma0 = 0.0;
  m.act.k_ATP = at(kKATP);
  m.act.k_RS = at(kKRS);
  m.act.APD = at(kAPD);
  m.act.n0_slope = at(kN0Slope);
  m.act.n0_e_max = at(kN0Emax);
  m.circ.K_at = at(kKat);
  m.circ.K_ar = at(kKar);
  m.circ.K_p = at(kKp);
  m.circ.R_p = at(kRp);
  m.circ.R_d = at(kRd);
  m.circ.C_p = at(kCp);
  m.circ.C_d = at(kCd);
  m.circ.P_sv = at(kPsv);
  m.circ.C_cav = at(kCcav);
  m.atrial.P_at0 = at(kPat0);
  m.atrial.P_at_kick = at(kPatKick);
  m.atrial.period = m.period;
  if (atrium != nullptr) {
    auto a = [&](int k) { return theta((*atrium)[static_cast<size_t>(k)]); };
    m.chamber = true;
    m.atrium_entry = atrium_entry;
    m.atrium.E_min = a(0);
    m.atrium.E_max = a(1);
    m.atrium.V0 = a(2);
    m.atrium.P_pv = a(3);
    m.atrium.R_pv = a(4);
    m.atrium.kick_duration = m.atrial.kick_duration;
    m.atrium.period = m.period;
  }
  return m;
}

double static_radius_offset(const Shell& m, double P) {
  auto f = [&](double y) {
    const double s = 1.0 + y / m.R0;
    double S = 0.0, dS = 0.0;
    passive_stress(m, s * s, S, dS);
    return m.d0 / m.R0 * s * S - P * s * s;
  };
  // f(0) = -P <= 0 and the passive stress grows with y: bracket the root in [0, hi].
  double lo = 0.0, hi = 0.5 * m.R0;
  while (f(hi) < 0.0 && hi < 10.0 * m.R0) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-15 * m.R0; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double next_time(double t, double t_end, double dt, double period) {
  const double tiny = 1e-6 * dt;  // grid points closer than this are one point
  const double b = std::floor(t / period + 1e-12);
  const double local = t - b * period;
  double next = b * period + (std::floor(local / dt + 1e-9) + 1.0) * dt;
  const double beat_end = (b + 1.0) * period;
  if (next > beat_end - tiny) next = beat_end;
  if (next > t_end - tiny) next = t_end;
  if (next - t < tiny && t_end - t >= tiny) {
    // Far into a run (t ~ 1e4 s, beat ~ 2e4 at dt = 50 ms) t carries rounding errors larger than
    // the 1e-12 and 1e-9 margins above: t = k T may be taken for the end of beat k - 1, and the
    // point found is t itself (a loop that never advances) or a rounding error after it. Round t
    // to the grid point it stands for and step from there. Earlier runs never reach this branch.
    const double b2 = std::floor((t + tiny) / period);
    const double local2 = std::max(t - b2 * period, 0.0);
    next = b2 * period + (std::floor(local2 / dt + 1e-6) + 1.0) * dt;
    if (next > (b2 + 1.0) * period - tiny) next = (b2 + 1.0) * period;
    if (next > t_end - tiny) next = t_end;
  }
  return next;
}

std::vector<Channel> state_head() {
  return {
      {"y", "m", "radial displacement of the mid-wall, R = R0 + y"},
      {"dy_dt", "m/s", "radial velocity"},
      {"P_v", "Pa", "ventricular pressure"},
      {"P_ar", "Pa", "proximal arterial pressure"},
      {"P_d", "Pa", "distal arterial pressure"},
  };
}

Channel last_open_valve_entry() {
  return {"last_open_valve", "1",
          "0 mitral or 2 aortic: the valve open last; only labels the closed phases (1 or 3)"};
}

std::vector<Channel> active_state_entries(const std::string& suffix) {
  return {
      {"e_c" + suffix, "1", "contractile-element strain"},
      {"k_c" + suffix, "Pa", "active stiffness"},
      {"tau_c" + suffix, "Pa", "contractile-element active stress"},
  };
}

std::vector<Channel> circulation_channels() {
  return {
      {"V_lv", "m^3", "left-ventricular cavity volume 4/3 pi R^3"},
      {"P_lv", "Pa", "left-ventricular pressure P_v"},
      {"P_ar", "Pa", "proximal arterial (aortic) pressure"},
      {"P_at", "Pa", "atrial pressure (prescribed, or the atrial chamber's)"},
      {"q_ar", "m^3/s", "aortic-valve flow, > 0 into the artery"},
      {"q_at", "m^3/s", "mitral-valve flow, > 0 into the ventricle"},
      {"phase", "1", "0 filling, 1 isovolumic contraction, 2 ejection, 3 isovolumic relaxation"},
      {"P_d", "Pa", "distal arterial pressure"},
  };
}

Eigen::Matrix<double, 8, 1> circulation_sample(const Shell& m, const State& state) {
  const auto& x = state.x;
  const double P_at = atrial_pressure(m, x, state.time);
  const auto q = circulation::valve_flow(x(kPv), x(kPar), P_at, m.circ);
  const auto last = x(x.size() - 1) > 1.0 ? circulation::ValveRegime::kEjection
                                          : circulation::ValveRegime::kFilling;
  Eigen::Matrix<double, 8, 1> out;
  out << cavity_volume(m, x(kY)), x(kPv), x(kPar), P_at, q.q_ar, q.q_at,
      static_cast<double>(circulation::phase(q.regime, last)), x(kPd);
  return out;
}

RunResult failed_run(std::vector<Channel> channels, Status status) {
  RunResult result;
  result.trajectory.channels = std::move(channels);
  result.status = std::move(status);
  return result;
}

double fill_relaxed_state(const Shell& m, Eigen::Ref<Eigen::VectorXd> x) {
  const double P0 = m.chamber ? m.atrium.P_pv : m.atrial(0.0);
  if (m.chamber) x(m.atrium_entry) = m.atrium.V0 + P0 / m.atrium.elastance(0.0);
  const double y = static_radius_offset(m, P0);
  const double s1 = 1.0 + y / m.R0;
  x(kY) = y;
  x(kPv) = P0;
  x(kPar) = std::max(P0, 75.0 * 133.322);
  x(kPd) = std::max(P0, 70.0 * 133.322);
  return 0.5 * (s1 * s1 - 1.0);
}

Status check_theta(const ParameterSpace& space, const SphereOptions& numerics,
                   const Eigen::Ref<const Eigen::VectorXd>& theta, double APD, double period) {
  if (theta.size() != space.size()) {
    std::ostringstream s;
    s << "theta has " << theta.size() << " entries, expected " << space.size();
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  if (const std::string msg = space.check(theta); !msg.empty()) {
    return Status::Error(StatusCode::kOutOfBounds, msg);
  }
  if (const std::string msg = numerics.validate(); !msg.empty()) {
    return Status::Error(StatusCode::kInvalidArgument, "SphereOptions: " + msg);
  }
  if (APD >= period) {
    return Status::Error(StatusCode::kOutOfBounds, "APD must be shorter than the period");
  }
  if (numerics.dt > period / SphereOptions::kMinStepsPerBeat) {
    std::ostringstream s;
    s << "dt = " << numerics.dt << " s must be <= period / " << SphereOptions::kMinStepsPerBeat
      << " = " << period / SphereOptions::kMinStepsPerBeat << " s (period " << period
      << " s): fewer steps per beat cannot resolve contraction and the valve events";
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  return Status::Ok();
}

Status check_advance(const State& state, Eigen::Index state_size, double t_end) {
  if (state.x.size() != state_size) {
    return Status::Error(StatusCode::kInvalidArgument, "state has the wrong size");
  }
  if (!state.x.allFinite()) return Status::Error(StatusCode::kNonFinite, "state is not finite");
  if (!(t_end >= state.time)) {
    return Status::Error(StatusCode::kInvalidArgument, "t_end lies before the state time");
  }
  return Status::Ok();
}

RunResult run_periodic(const Shell& m, const SphereOptions& o, std::vector<Channel> channels,
                       State state,
                       const std::function<Status(State&, double, int*, int*)>& step_to,
                       const std::function<Eigen::VectorXd(const State&)>& sample,
                       const Eigen::VectorXd* warm_from, Eigen::VectorXd* warm_out) {
  RunResult result;
  result.trajectory.channels = std::move(channels);
  const double T = m.period;
  result.info.period = T;
  const int steps_per_beat = static_cast<int>(std::ceil(T / o.dt - 1e-9));
  const int max_rows = steps_per_beat / o.output_every + 2;
  Eigen::VectorXd times(max_rows);
  Eigen::MatrixXd values(max_rows, static_cast<Eigen::Index>(result.trajectory.channels.size()));
  int rows = 0;  // of the last recorded beat

  // The beat map on the unknowns (the state without its last entry, the diagnostic valve flag,
  // which starts every beat as the last recorded beat ended). Every beat runs on t in [0, T], so
  // the map is the same function at every call.
  const Eigen::Index nu = state.x.size() - 1;
  double flag = state.x(nu);
  const BeatMap beat = [&](const Eigen::VectorXd& start, bool record) {
    BeatOutcome out;
    State s;
    s.time = 0.0;
    s.x.resize(nu + 1);
    s.x.head(nu) = start;
    s.x(nu) = flag;
    out.peak = start.cwiseAbs();
    int step = 0;
    if (record) {
      rows = 0;
      times(rows) = 0.0;
      values.row(rows++) = sample(s).transpose();
    }
    while (s.time < T) {
      const double t1 = next_time(s.time, T, o.dt, T);
      const double before = s.time;
      out.status = step_to(s, t1, &result.info.newton_iterations, &result.info.step_cuts);
      if (out.status.ok() && !(s.time > before)) {  // never loop without advancing
        std::ostringstream msg;
        msg << "no progress at t = " << before << " s (dt = " << o.dt << " s)";
        out.status = Status::Error(StatusCode::kInvalidArgument, msg.str());
      }
      if (!out.status.ok()) return out;
      out.peak = out.peak.cwiseMax(s.x.head(nu).cwiseAbs());
      ++step;
      if (record && (step % o.output_every == 0 || s.time >= T)) {
        if (rows == times.size()) {  // more steps than ceil(T / dt) (rounding): grow, never overflow
          times.conservativeResize(2 * rows);
          values.conservativeResize(2 * rows, Eigen::NoChange);
        }
        times(rows) = s.time >= T ? T : s.time;
        values.row(rows++) = sample(s).transpose();
      }
    }
    if (record) flag = s.x(nu);
    out.end = s.x.head(nu);
    return out;
  };

  ShootingOptions so;
  so.min_beats = o.min_beats;
  so.max_beats = o.max_beats;
  so.tolerance = o.periodic_tolerance;
  so.jacobian = warm_out != nullptr;
  const int n = static_cast<int>(nu);
  const std::optional<ShootingWarmStart> warm =
      warm_from ? ShootingWarmStart::unpack(*warm_from, n) : std::nullopt;
  const ShootingResult shot = find_periodic_state(state.x.head(nu), beat, so, warm ? &*warm : nullptr);
  if (warm_out) {
    *warm_out = shot.warm ? shot.warm->pack()
                          : Eigen::VectorXd(Eigen::VectorXd::Zero(ShootingWarmStart::packed_size(n)));
  }
  result.status = shot.status;
  result.info.beats = shot.beats;
  result.info.periodicity_change = shot.correction;
  result.trajectory.times = times.head(rows);
  result.trajectory.values = values.topRows(rows);
  return result;
}

}  // namespace sigmaheart::model::lumped::shell
