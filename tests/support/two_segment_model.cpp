#include "tests/support/two_segment_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace sigmaheart::testing {
namespace {

constexpr double kSystole = 0.3;     // T_s [s]
constexpr double kKappa = 2e4;       // elastance per active stress [1/m^3]
constexpr double kV0 = 1e-5;         // unloaded volume of a segment [m^3]
constexpr double kRmv = 1.33e6;      // mitral resistance [Pa s/m^3]
constexpr double kRao = 2.67e6;      // aortic resistance [Pa s/m^3]
constexpr double kCar = 1.125e-8;    // arterial compliance [m^3/Pa]

// theta in the order of default_parameters().
struct Theta {
  double s1, s2, e_min, r_d, p_ven, period;
  explicit Theta(const Eigen::Ref<const Eigen::VectorXd>& t)
      : s1(t(0)), s2(t(1)), e_min(t(2)), r_d(t(3)), p_ven(t(4)), period(t(5)) {}
};

double activation(double t, double period) {
  const double tau = t - period * std::floor(t / period);
  if (tau >= kSystole) return 0.0;
  const double s = std::sin(std::numbers::pi * tau / kSystole);
  return s * s;
}

struct Pressures {
  double e1, e2, p_lv;
};

Pressures pressures(const Theta& th, double t, double v_lv) {
  const double e = activation(t, th.period);
  const double e1 = th.e_min + kKappa * th.s1 * e;
  const double e2 = th.e_min + kKappa * th.s2 * e;
  return {e1, e2, (v_lv - 2.0 * kV0) / (1.0 / e1 + 1.0 / e2)};
}

Eigen::Vector2d rhs(const Theta& th, double t, const Eigen::Vector2d& x) {
  const double p_lv = pressures(th, t, x(0)).p_lv;
  const double q_in = std::max(th.p_ven - p_lv, 0.0) / kRmv;
  const double q_out = std::max(p_lv - x(1), 0.0) / kRao;
  return {q_in - q_out, (q_out - x(1) / th.r_d) / kCar};
}

// n RK4 steps of size h from (t0, x).
void rk4(const Theta& th, double t0, double h, int n, Eigen::Vector2d& x) {
  for (int k = 0; k < n; ++k) {
    const double t = t0 + k * h;
    const Eigen::Vector2d k1 = rhs(th, t, x);
    const Eigen::Vector2d k2 = rhs(th, t + 0.5 * h, x + 0.5 * h * k1);
    const Eigen::Vector2d k3 = rhs(th, t + 0.5 * h, x + 0.5 * h * k2);
    const Eigen::Vector2d k4 = rhs(th, t + h, x + h * k3);
    x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
}

Eigen::VectorXd channel_values(const Theta& th, double t, const Eigen::Vector2d& x) {
  const Pressures p = pressures(th, t, x(0));
  Eigen::VectorXd z(5);
  z << x(0), p.p_lv, x(1), kV0 + p.p_lv / p.e1, kV0 + p.p_lv / p.e2;
  return z;
}

}  // namespace

model::ParameterSpace TwoSegmentModel::default_parameters() {
  return model::ParameterSpace({
      {"sigma0_01", "Pa", 5e4, 5e3, 5e5, "contractility of segment 1", "contractility", 1},
      {"sigma0_02", "Pa", 5e4, 5e3, 5e5, "contractility of segment 2", "contractility", 2},
      {"E_min", "Pa/m^3", 2.1e7, 2e6, 2e8, "passive elastance of a segment", "elastance", 0},
      {"R_d", "Pa s/m^3", 1.33e8, 1e7, 1e9, "peripheral resistance", "afterload_resistance", 0},
      {"P_ven", "Pa", 1067.0, 100.0, 5000.0, "venous (filling) pressure", "preload_pressure", 0},
      {"period", "s", 0.8, 0.4, 1.5, "heart period (systole lasts 0.3 s)", "period", 0},
  });
}

std::vector<model::Channel> TwoSegmentModel::channels() const {
  return {{"V_lv", "m^3", "cavity volume", "", 0},
          {"P_lv", "Pa", "cavity pressure", "", 0},
          {"P_ar", "Pa", "arterial pressure", "", 0},
          {"V_seg01", "m^3", "volume of segment 1", "regional_volume", 1},
          {"V_seg02", "m^3", "volume of segment 2", "regional_volume", 2}};
}

std::vector<model::Channel> TwoSegmentModel::state_layout() const {
  return {{"V_lv", "m^3", "cavity volume", "", 0}, {"P_ar", "Pa", "arterial pressure", "", 0}};
}

model::Status TwoSegmentModel::check(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (theta.size() != parameters_.size()) {
    return model::Status::Error(model::StatusCode::kInvalidArgument,
                                "expected " + std::to_string(parameters_.size()) + " parameters");
  }
  if (!theta.allFinite()) return model::Status::Error(model::StatusCode::kNonFinite, "theta is not finite");
  if (std::string msg = parameters_.check(theta); !msg.empty()) {
    return model::Status::Error(model::StatusCode::kOutOfBounds, msg);
  }
  return model::Status::Ok();
}

model::State TwoSegmentModel::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  model::State s;
  s.x = Eigen::VectorXd::Constant(2, std::numeric_limits<double>::quiet_NaN());
  if (!check(theta).ok()) return s;
  const Theta th(theta);
  s.x << 2.0 * kV0 + 2.0 * th.p_ven / th.e_min, 1e4;  // relaxed and filled; arteries at 75 mmHg
  return s;
}

model::Status TwoSegmentModel::advance(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                                       double t_end) {
  if (model::Status st = check(theta); !st.ok()) return st;
  if (state.x.size() != 2 || !(t_end >= state.time)) {
    return model::Status::Error(model::StatusCode::kInvalidArgument, "bad state or t_end < state.time");
  }
  if (t_end == state.time) return model::Status::Ok();
  const int n = std::max(1, static_cast<int>(std::ceil((t_end - state.time) / options_.dt - 1e-9)));
  Eigen::Vector2d x = state.x;
  rk4(Theta(theta), state.time, (t_end - state.time) / n, n, x);
  if (!x.allFinite()) {
    return model::Status::Error(model::StatusCode::kNonFinite,
                                "non-finite state before t = " + std::to_string(t_end) + " s");
  }
  state.x = x;
  state.time = t_end;
  return model::Status::Ok();
}

Eigen::VectorXd TwoSegmentModel::sample(const model::State& state,
                                        const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  return channel_values(Theta(theta), state.time, Eigen::Vector2d(state.x(0), state.x(1)));
}

model::RunResult TwoSegmentModel::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  model::RunResult r;
  if (r.status = check(theta); !r.status.ok()) return r;
  const Theta th(theta);
  const int steps = static_cast<int>(std::lround(th.period / options_.dt));
  const double h = th.period / steps;
  const int every = options_.output_every;
  const int samples = steps / every + 1;
  Eigen::Vector2d x = initial_state(theta).x;
  r.trajectory.channels = channels();
  r.trajectory.times.resize(samples);
  r.trajectory.values.resize(samples, 5);
  r.info.period = th.period;
  for (int beat = 0; beat < options_.max_beats; ++beat) {
    const Eigen::Vector2d start = x;
    for (int k = 0; k < samples; ++k) {
      if (k > 0) rk4(th, (k - 1) * every * h, h, every, x);  // beat-local time: e(t) is periodic
      r.trajectory.times(k) = k * every * h;
      r.trajectory.values.row(k) = channel_values(th, k * every * h, x).transpose();
    }
    if (steps % every != 0) rk4(th, (samples - 1) * every * h, h, steps % every, x);
    if (!x.allFinite()) {
      r.status = model::Status::Error(model::StatusCode::kNonFinite, "non-finite state in beat " +
                                                                         std::to_string(beat + 1));
      return r;
    }
    r.info.beats = beat + 1;
    r.info.periodicity_change = std::max(std::abs(x(0) - start(0)) / std::abs(start(0)),
                                         std::abs(x(1) - start(1)) / std::abs(start(1)));
    if (r.info.periodicity_change < options_.periodic_tolerance) return r;
  }
  r.status = model::Status::Error(model::StatusCode::kNotPeriodic,
                                  "no periodic beat after " + std::to_string(options_.max_beats) + " beats");
  return r;
}

void register_two_segment_model(model::ModelRegistry& registry) {
  registry.add(model::ModelSetup{
      "test-two-segment", "two-segment time-varying elastance ventricle (tests only)",
      [](const model::OptionReader& numerics) {
        numerics.check_keys({"dt", "output_every"});
        TwoSegmentOptions o;
        o.dt = numerics.quantity("dt", "s", o.dt);
        o.output_every = numerics.integer("output_every", o.output_every);
        if (!(o.dt > 0.0 && o.dt <= 2e-3)) numerics.fail("dt", numerics.path() + ".dt: must lie in (0, 2 ms]");
        if (o.output_every < 1) numerics.fail("output_every", numerics.path() + ".output_every: must be >= 1");
        return model::ModelBuild(
            TwoSegmentModel::default_parameters(),
            [o](const model::ParameterSpace& p) -> std::unique_ptr<model::Simulator> {
              return std::make_unique<TwoSegmentModel>(o, p);
            });
      }});
}

}  // namespace sigmaheart::testing
