// `sigmaheart personalize CONFIG`: regional personalisation with the Reduced-Order Unscented
// Kalman Filter (Moireau & Chapelle 2011; ESTIMATION.md s.4): per-segment parameters (one
// contractility per AHA segment, as Marchesseau et al. 2013, Med Image Anal 17:816) and any global
// ones, from regional volume curves. The config's `personalize:` section, parsed in one place
// (parse_personalize below):
//
//   personalize:
//     observations:
//       file: data/regional-lad-infarct.csv   # time [ms], V_seg01 [mL], ..., V_seg17 [mL]
//       channels: all            # or [V_seg01, V_seg07]: columns of the file to assimilate
//       noise: 0.05 mL           # or {default: 0.05 mL, V_seg17: 0.1 mL}; "%" = of the column mean
//       start_beats: 8           # file time 0 = this many beats after the model's initial state
//     estimate:                  # per-segment families and global parameters
//       sigma0: {segments: all, prior: 5.3e4, spread: 50 %, transform: log}
//       R_p: {spread: 20 %}      # a global parameter (no segments:)
//     filter:
//       beats: 4                 # passes over the measured beat
//       forgetting: 0.9          # fading memory per frame, (0, 1]
//       r_inflation: 4           # the filter's R = (r_inflation x noise)^2
//       sigma_points: simplex    # simplex | canonical | star
//       spin_up: per-member      # per-member | common (initial state of the first prediction)
//       failure_policy: retry-then-skip   # retry-then-skip | skip | abort
//       max_retries: 2
//       shrink: 0.5
//       inflation: 0.1
//       threads: 2               # --threads overrides
//     truth:                     # optional (twin experiments): per family a list or one value
//       sigma0: [21.2 kPa, 21.2 kPa, 53 kPa, ...]
//
// Results: HDF5 of kind "personalize" (every filter step), optional JSON summary, a table on the
// terminal. Exit codes: 2 bad input (file:line:column), 1 when the filter aborts (results written).
#include "app/calibration_setup.h"
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/observation_file.h"
#include "app/io/results.h"
#include "app/progress.h"
#include "estimation/roukf/roukf.h"
#include "estimation/ut_calibration.h"
#include "model/lumped/regional.h"
#include "model/units.h"

#include <nlohmann/json.hpp>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app {

namespace {

struct PersonalizeOptions {
  std::filesystem::path config;
  std::filesystem::path output;
  std::filesystem::path summary;
  int threads = 0;
  std::vector<std::string> overrides;
};

// The parsed `personalize:` section.
struct PersonalizeProblem {
  estimation::RoukfData data;             // SI, times on the model's clock
  estimation::RoukfOptions filter;
  std::filesystem::path observation_file;
  Eigen::VectorXd file_times;             // [s] as in the file (beat-local)
  std::vector<std::string> display_units; // per channel ("mL")
  Eigen::VectorXd display_factor;         // display = SI * factor
  Eigen::VectorXd noise_si;               // per channel, the measurement noise std
  double r_inflation = 1.0;
  int start_beats = 0;
  double period = 0.0;
  std::string spin_up = "per-member";
  std::vector<std::string> units;         // per estimated parameter (SI)
  std::vector<int> segments;              // per estimated parameter: 1-based segment, 0 = global
  std::vector<std::string> families;      // per estimated parameter: "sigma0" or the global name
  std::vector<double> prior_theta;        // per estimated parameter
  std::optional<Eigen::VectorXd> truth;   // per estimated parameter (all or none)
};

std::string two_digits(int i) { return (i < 10 ? "0" : "") + std::to_string(i); }

// Noise std [SI] of one channel: "0.05 mL", "2 %" (of the column mean |y|), or a bare number (SI).
double parse_noise_value(const ConfigNode& node, const std::string& si_unit, double column_mean) {
  const auto [value, unit] = number_and_unit(node);
  if (!(value > 0)) node.fail("expected a positive noise standard deviation");
  if (unit == "%") return value / 100.0 * std::abs(column_mean);
  if (unit.empty()) return value;
  try {
    return model::units::convert(value, unit, si_unit);
  } catch (const std::invalid_argument& e) {
    node.fail(std::string("noise: ") + e.what() + " (channel unit: " + si_unit + ")");
  }
}

// Segments of a per-segment family: `all` or a list of 1-based numbers.
std::vector<int> parse_segments(const ConfigNode& node, int patches) {
  std::vector<int> out;
  if (node.is_scalar()) {
    if (node.as<std::string>() != "all") node.fail("expected 'all' or a list of segment numbers");
    for (int s = 1; s <= patches; ++s) out.push_back(s);
    return out;
  }
  if (!node.is_sequence() || node.size() == 0) node.fail("expected 'all' or a list of segment numbers");
  for (size_t i = 0; i < node.size(); ++i) {
    const int s = node[i].as<int>();
    if (s < 1 || s > patches) {
      node[i].fail("segment " + std::to_string(s) + " outside 1.." + std::to_string(patches));
    }
    for (int t : out) {
      if (t == s) node[i].fail("segment " + std::to_string(s) + " listed twice");
    }
    out.push_back(s);
  }
  return out;
}

// One estimated parameter from {prior, spread, transform}; `name` is a parameter of the space.
estimation::RoukfParameter parse_prior(const model::Parameter& p, const ConfigNode& node,
                                       double& prior) {
  // The same prior conventions as `calibrate` (app/calibration_setup.h).
  const estimation::CalibrationParameter c = parse_estimated_parameter(p, node);
  prior = c.prior_mean;
  estimation::RoukfParameter q;
  q.name = p.name;
  q.transform = c.transform;
  q.prior_eta = c.eta_mean();
  q.prior_std_eta = c.eta_std();
  return q;
}

PersonalizeProblem parse_personalize(const Config& config) {
  const ConfigNode root = config.file.root();
  const ConfigNode sec = root.require_child("personalize");
  sec.check_keys({"observations", "estimate", "filter", "truth"});
  const model::ParameterSpace& space = config.simulator.parameters;
  PersonalizeProblem out;
  const auto sim = config.simulator.make();
  const auto sim_channels = sim->channels();
  int patches = 0;
  while (space.index("sigma0_" + two_digits(patches + 1))) ++patches;
  const auto period_index = space.index("period");
  if (!period_index) root["simulator"].fail("personalize needs a model with a 'period' parameter");
  out.period = space.nominal()(*period_index);

  // ---- observations
  const ConfigNode obs = sec.require_child("observations");
  obs.check_keys({"file", "channels", "noise", "start_beats"});
  const ConfigNode file_node = obs.require_child("file");
  std::filesystem::path path = file_node.as<std::string>();
  if (path.is_relative()) path = std::filesystem::path(config.file.file()).parent_path() / path;
  if (!std::filesystem::exists(path)) {
    file_node.fail("observation file '" + path.string() +
                   "' does not exist (paths are relative to the config file)");
  }
  const io::ObservationCurves curves = io::read_observation_csv(path);
  out.observation_file = path;
  const model::Trajectory& tr = curves.trajectory;
  std::vector<int> columns;
  if (!obs.has("channels") || (obs["channels"].is_scalar() && obs["channels"].as<std::string>() == "all")) {
    for (size_t c = 0; c < tr.channels.size(); ++c) columns.push_back(static_cast<int>(c));
  } else {
    const auto names = obs["channels"].as<std::vector<std::string>>();
    if (names.empty()) obs["channels"].fail("expected 'all' or a list of column names");
    for (size_t i = 0; i < names.size(); ++i) {
      int found = -1;
      for (size_t c = 0; c < tr.channels.size(); ++c) {
        if (tr.channels[c].name == names[i]) found = static_cast<int>(c);
      }
      if (found < 0) obs["channels"][i].fail("the file has no column '" + names[i] + "'");
      columns.push_back(found);
    }
  }
  std::vector<std::string> sim_names;
  for (const auto& c : sim_channels) sim_names.push_back(c.name);
  const int m = static_cast<int>(columns.size());
  out.data.values.resize(tr.samples(), m);
  out.display_factor.resize(m);
  out.noise_si.resize(m);
  const ConfigNode noise = obs.require_child("noise");
  if (noise.is_map()) {
    for (const auto& key : noise.keys()) {
      bool known = key == "default";
      for (int c : columns) known = known || tr.channels[static_cast<size_t>(c)].name == key;
      if (!known) noise[key].fail("'" + key + "' is not an assimilated channel (nor 'default')");
    }
  }
  for (int j = 0; j < m; ++j) {
    const model::Channel& ch = tr.channels[static_cast<size_t>(columns[static_cast<size_t>(j)])];
    bool in_model = false;
    for (const auto& s : sim_channels) in_model = in_model || s.name == ch.name;
    if (!in_model) {
      const auto guess = model::closest_match(ch.name, sim_names);
      file_node.fail("column '" + ch.name + "' is not a channel of model " + config.simulator.model +
                     (guess.empty() ? "" : " (did you mean '" + guess + "'?)"));
    }
    out.data.channels.push_back(ch.name);
    out.data.values.col(j) = tr.values.col(columns[static_cast<size_t>(j)]);
    const std::string shown = curves.display_units[static_cast<size_t>(columns[static_cast<size_t>(j)])];
    out.display_units.push_back(shown.empty() ? io::display_unit(ch.unit).unit : shown);
    out.display_factor(j) = model::units::convert(1.0, ch.unit, out.display_units.back());
    const double mean = out.data.values.col(j).mean();
    ConfigNode nj = noise;
    if (noise.is_map()) {
      nj = noise.has(ch.name) ? noise[ch.name] : noise["default"];
      if (!nj.defined()) noise.fail("no noise for '" + ch.name + "' (give it or 'default:')");
    }
    out.noise_si(j) = parse_noise_value(nj, ch.unit, mean);
  }
  out.start_beats = obs.optional<int>("start_beats", 0);
  if (out.start_beats < 0) obs["start_beats"].fail("expected an integer >= 0");
  out.file_times = tr.times;
  out.data.times = tr.times.array() + out.start_beats * out.period;
  if (!(tr.times(0) >= 0.0)) file_node.fail("frame times must start at or after 0");

  // ---- estimate
  const ConfigNode est = sec.require_child("estimate");
  if (!est.is_map() || est.size() == 0) est.fail("expected a map of parameter -> {prior, spread, ...}");
  for (const auto& key : est.keys()) {
    const ConfigNode node = est[key];
    node.check_keys({"segments", "prior", "spread", "transform", "bounds"});
    if (node.has("segments")) {
      if (patches == 0 || !space.index(key + "_01")) {
        throw InputError(est.key_location(key), "'" + key + "' is not a per-segment parameter family of " +
                                                    config.simulator.model + " (e.g. sigma0, Td, stiff, scar)");
      }
      for (int s : parse_segments(node["segments"], patches)) {
        const model::Parameter& p = space[*space.index(key + "_" + two_digits(s))];
        double prior = 0.0;
        out.filter.parameters.push_back(parse_prior(p, node, prior));
        out.units.push_back(p.unit);
        out.segments.push_back(s);
        out.families.push_back(key);
        out.prior_theta.push_back(prior);
      }
    } else {
      const auto idx = space.index(key);
      if (!idx) {
        std::vector<std::string> candidates = space.names();
        for (const auto& n : space.names()) {  // the per-segment families: sigma0_01 -> sigma0
          if (n.size() > 3 && n.compare(n.size() - 3, 3, "_01") == 0) candidates.push_back(n.substr(0, n.size() - 3));
        }
        const auto guess = model::closest_match(key, candidates);
        throw InputError(est.key_location(key),
                         "unknown parameter '" + key + "' for model " + config.simulator.model +
                             (guess.empty() ? "" : " (did you mean '" + guess + "'?)") +
                             "; per-segment families take 'segments:'");
      }
      const model::Parameter& p = space[*idx];
      double prior = 0.0;
      out.filter.parameters.push_back(parse_prior(p, node, prior));
      out.units.push_back(p.unit);
      out.segments.push_back(0);
      out.families.push_back(key);
      out.prior_theta.push_back(prior);
    }
  }
  for (size_t a = 0; a < out.filter.parameters.size(); ++a) {
    for (size_t b = 0; b < a; ++b) {
      if (out.filter.parameters[a].name == out.filter.parameters[b].name) {
        est.fail("parameter '" + out.filter.parameters[a].name + "' is estimated twice");
      }
    }
  }

  // ---- filter
  const ConfigNode f = sec["filter"];
  f.check_keys({"beats", "forgetting", "r_inflation", "sigma_points", "kappa", "spin_up",
                "failure_policy", "max_retries", "shrink", "inflation", "threads"});
  estimation::RoukfOptions& o = out.filter;
  o.beats = f.optional<int>("beats", 1);
  if (o.beats < 1) f["beats"].fail("expected an integer >= 1");
  o.period = out.period;
  o.forgetting = f.optional<double>("forgetting", o.forgetting);
  if (!(o.forgetting > 0 && o.forgetting <= 1)) f["forgetting"].fail("expected a number in (0, 1]");
  out.r_inflation = f.optional<double>("r_inflation", 1.0);
  if (!(out.r_inflation > 0)) f["r_inflation"].fail("expected a positive factor");
  if (f.has("sigma_points")) {
    o.sigma_rule = *estimation::parse_sigma_rule(f["sigma_points"].as_choice({"simplex", "canonical", "star"}));
  }
  o.star_kappa = f.optional<double>("kappa", o.star_kappa);
  out.spin_up = f.has("spin_up") ? f["spin_up"].as_choice({"per-member", "common"}) : "per-member";
  o.initial_state_per_member = out.spin_up == "per-member";
  if (f.has("failure_policy")) {
    o.failure_policy = *estimation::parse_roukf_failure_policy(
        f["failure_policy"].as_choice({"retry-then-skip", "skip", "abort"}));
  }
  o.max_retries = f.optional<int>("max_retries", o.max_retries);
  o.shrink = f.optional<double>("shrink", o.shrink);
  o.inflation = f.optional<double>("inflation", o.inflation);
  o.ensemble.threads = f.optional<int>("threads", 0);
  if (o.ensemble.threads < 0) f["threads"].fail("expected an integer >= 0 (0: all cores)");
  o.R = (out.r_inflation * out.noise_si).array().square().matrix().asDiagonal();
  o.base_theta = space.nominal();
  o.refine = [](const model::SteppableSimulator& s, int level) -> std::unique_ptr<model::SteppableSimulator> {
    const auto* r = dynamic_cast<const model::lumped::RegionalVentricle*>(&s);
    if (r == nullptr) return nullptr;
    return r->with_time_step(r->options().numerics.dt / std::pow(2.0, level));
  };
  if (const std::string e = o.validate(); !e.empty()) f.fail(e);
  if (const std::string e = out.data.validate(); !e.empty()) file_node.fail(e);
  if (o.beats > 1 && !(tr.times(tr.samples() - 1) < tr.times(0) + out.period)) {
    file_node.fail("the frames span more than one heart period (" + std::to_string(out.period) +
                   " s); repeated passes need one beat");
  }

  // ---- truth (optional)
  const ConfigNode truth = sec["truth"];
  if (truth.defined()) {
    if (!truth.is_map()) truth.fail("expected a map of parameter (or family) -> value(s)");
    Eigen::VectorXd t = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(out.units.size()), std::nan(""));
    for (const auto& key : truth.keys()) {
      const ConfigNode v = truth[key];
      bool used = false;
      if (v.is_sequence()) {
        if (static_cast<int>(v.size()) != patches) {
          v.fail("expected " + std::to_string(patches) + " values, one per segment");
        }
        for (size_t j = 0; j < out.units.size(); ++j) {
          if (out.families[j] == key && out.segments[j] > 0) {
            t(static_cast<Eigen::Index>(j)) = v[static_cast<size_t>(out.segments[j] - 1)].as_quantity(out.units[j]);
            used = true;
          }
        }
      } else {
        for (size_t j = 0; j < out.units.size(); ++j) {
          if (out.filter.parameters[j].name == key || (out.families[j] == key && out.segments[j] > 0)) {
            t(static_cast<Eigen::Index>(j)) = v.as_quantity(out.units[j]);
            used = true;
          }
        }
      }
      if (!used) throw InputError(truth.key_location(key), "'" + key + "' is not estimated");
    }
    if (!t.allFinite()) truth.fail("give the truth of every estimated parameter (or none)");
    out.truth = t;
  }
  return out;
}

std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

int run_personalize(const PersonalizeOptions& o, CommandContext& ctx) {
  io::Provenance prov;
  prov.start_utc = io::utc_now();
  const Config config = load_config(o.config, o.overrides);
  PersonalizeProblem problem = parse_personalize(config);
  const std::filesystem::path output =
      !o.output.empty() ? o.output : default_output_path(o.config, "personalize");

  std::unique_ptr<model::Simulator> simulator = config.simulator.make();
  const auto* steppable = dynamic_cast<const model::SteppableSimulator*>(simulator.get());
  if (steppable == nullptr) {
    config.file.root()["simulator"]["model"].fail(
        "model " + config.simulator.model + " cannot be advanced step by step; personalize needs a "
        "steppable simulator (lumped-regional, lumped-sphere)");
  }
  estimation::RoukfOptions& filter = problem.filter;
  if (o.threads > 0) filter.ensemble.threads = o.threads;
  filter.ensemble.communicator = ctx.comm;  // members spread over the ranks, if several
  if (filter.ensemble.threads == 1) filter.ensemble.backend = estimation::Backend::kSerial;
  const int threads = filter.ensemble.threads > 0 ? filter.ensemble.threads : omp_get_max_threads();
  const int p = static_cast<int>(filter.parameters.size());
  const int m = static_cast<int>(problem.data.channels.size());
  const int frames = static_cast<int>(problem.data.times.size());

  ProgressLine progress(ctx.err, "personalize");
  int stage_beat = -1;
  filter.on_step = [&](const estimation::RoukfStep& s) {
    if (s.beat != stage_beat) {
      if (stage_beat >= 0) progress.finish();
      stage_beat = s.beat;
      progress.start("pass " + std::to_string(s.beat + 1) + "/" + std::to_string(filter.beats) +
                         " over " + std::to_string(frames) + " frames",
                     frames);
    }
    progress.update(s.frame + 1);
    return true;
  };
  spdlog::info("personalize: {} parameter(s) of {} from {} channel(s) x {} frames, {} pass(es), "
               "{} threads",
               p, simulator->name(), m, frames, filter.beats, threads);
  const estimation::RoukfSummary summary = estimation::run_roukf(*steppable, problem.data, filter);
  progress.finish();
  if (summary.termination == estimation::RoukfTermination::kInvalidInput) {
    throw InputError(config.file.root()["personalize"].location(), summary.message);
  }

  // ---- Derived numbers.
  const int steps = static_cast<int>(summary.steps.size());
  std::vector<std::string> names = summary.parameter_names;
  Eigen::VectorXd prior_theta(p), prior_std(p), theta_std(p);
  for (int j = 0; j < p; ++j) {
    const auto& q = filter.parameters[static_cast<size_t>(j)];
    prior_theta(j) = problem.prior_theta[static_cast<size_t>(j)];
    prior_std(j) = std::abs(q.transform.dtheta_deta(q.prior_eta)) * q.prior_std_eta;
  }
  const bool have_estimate = summary.theta.size() == p;
  Eigen::VectorXd final_theta = have_estimate ? summary.theta : prior_theta;
  for (int j = 0; j < p; ++j) {
    const auto& q = filter.parameters[static_cast<size_t>(j)];
    theta_std(j) = have_estimate ? std::abs(q.transform.dtheta_deta(summary.eta(j))) *
                                       std::sqrt(std::max(0.0, summary.eta_covariance(j, j)))
                                 : prior_std(j);
  }
  // Per-pass relative error [%] of the last step of each pass (twin experiments).
  Eigen::MatrixXd pass_error;
  int passes_needed = -1;
  if (problem.truth) {
    pass_error = Eigen::MatrixXd::Constant(filter.beats, p, std::nan(""));
    for (const auto& s : summary.steps) {
      if (s.theta.size() != p) continue;
      pass_error.row(s.beat) =
          (100.0 * (s.theta - *problem.truth).array().abs() / problem.truth->array().abs()).matrix().transpose();
    }
    for (int b = 0; b < pass_error.rows() && passes_needed < 0; ++b) {
      if (pass_error.row(b).allFinite() && pass_error.row(b).maxCoeff() <= 10.0) passes_needed = b + 1;
    }
  }
  Eigen::VectorXd full = filter.base_theta;
  for (int j = 0; j < p; ++j) full(*config.simulator.parameters.index(names[static_cast<size_t>(j)])) = final_theta(j);

  // ---- Results file.
  fill_provenance(prov, config, ctx, "personalize", threads, 1);
  {
    io::Hdf5Writer h5(output);
    io::write_parameters(h5, "/parameters", config.simulator.parameters, full);
    h5.set_attribute("/parameters", "description", "every simulator parameter; estimated ones at the final estimate");

    const std::string per = "per parameter, see /estimate/units";
    h5.write_strings("/estimate/names", names);
    h5.write_strings("/estimate/units", problem.units);
    h5.write_strings("/estimate/family", problem.families);
    std::vector<std::int64_t> segs(problem.segments.begin(), problem.segments.end());
    h5.write_ints("/estimate/segment", segs);
    h5.set_attribute("/estimate/segment", "units", "1-based AHA segment; 0 = global parameter");
    std::vector<std::string> transforms;
    for (const auto& q : filter.parameters) transforms.emplace_back(estimation::to_string(q.transform.kind));
    h5.write_strings("/estimate/transform", transforms);
    h5.write_vector("/estimate/prior", prior_theta, per);
    h5.write_vector("/estimate/prior_std", prior_std, per);
    h5.write_vector("/estimate/value", final_theta, per);
    h5.set_attribute("/estimate/value", "description", "T(eta mean) after the last step");
    h5.write_vector("/estimate/std", theta_std, per);
    h5.set_attribute("/estimate/std", "description", "|dtheta/deta| sqrt(P_eta) (delta method)");
    if (have_estimate) {
      h5.write_vector("/estimate/lower", summary.theta_lower, per);
      h5.write_vector("/estimate/upper", summary.theta_upper, per);
      h5.write_vector("/estimate/eta", summary.eta, "1");
      h5.write_matrix("/estimate/eta_covariance", summary.eta_covariance, "1", names, names);
    }

    // Observations in display units (mL).
    Eigen::MatrixXd y = problem.data.values;
    for (int j = 0; j < m; ++j) y.col(j) *= problem.display_factor(j);
    h5.write_strings("/observations/names", problem.data.channels);
    h5.write_strings("/observations/units", problem.display_units);
    h5.write_vector("/observations/time", problem.file_times, "s");
    h5.set_attribute("/observations/time", "description", "frame times as in the file (beat-local)");
    h5.write_matrix("/observations/values", y, "see /observations/units", {}, problem.data.channels);
    h5.write_vector("/observations/noise_std", problem.noise_si.cwiseProduct(problem.display_factor),
                    "see /observations/units");
    h5.write_vector("/observations/filter_noise_std",
                    problem.r_inflation * problem.noise_si.cwiseProduct(problem.display_factor),
                    "see /observations/units");
    h5.set_attribute("/observations", "file", problem.observation_file.string());
    h5.set_attribute("/observations", "start_beats", problem.start_beats);

    // Every filter step.
    Eigen::VectorXd time(steps), nis(steps), loglik(steps);
    std::vector<std::int64_t> beat(steps), frame(steps), observed(steps), skipped(steps);
    Eigen::MatrixXd th = Eigen::MatrixXd::Constant(steps, p, std::nan("")), lo = th, hi = th, eta = th, eta_std = th;
    Eigen::MatrixXd innov = Eigen::MatrixXd::Constant(steps, m, std::nan("")), fc = innov, fit = innov;
    std::vector<std::string> actions;
    for (int k = 0; k < steps; ++k) {
      const auto& s = summary.steps[static_cast<size_t>(k)];
      time(k) = s.time;
      nis(k) = s.nis;
      loglik(k) = s.log_likelihood;
      beat[k] = s.beat;
      frame[k] = s.frame;
      observed[k] = s.observed;
      skipped[k] = s.analysis_skipped ? 1 : 0;
      if (s.theta.size() == p) {
        th.row(k) = s.theta.transpose();
        lo.row(k) = s.theta_lower.transpose();
        hi.row(k) = s.theta_upper.transpose();
        eta.row(k) = s.eta.transpose();
        eta_std.row(k) = s.eta_std.transpose();
      }
      if (s.innovation.size() == m) {
        innov.row(k) = s.innovation.cwiseProduct(problem.display_factor).transpose();
        fc.row(k) = s.forecast.cwiseProduct(problem.display_factor).transpose();
        fit.row(k) = s.fitted.cwiseProduct(problem.display_factor).transpose();
      }
      for (const auto& a : s.actions) {
        actions.push_back("step " + std::to_string(k) + (a.member >= 0 ? " member " + std::to_string(a.member) : "") +
                          ": " + a.what + (a.status.ok() ? "" : " (" + a.status.message + ")"));
      }
    }
    h5.write_vector("/steps/time", time, "s");
    h5.set_attribute("/steps/time", "description", "model time of the frame (start_beats + pass) x period + frame time");
    h5.write_ints("/steps/beat", beat);
    h5.write_ints("/steps/frame", frame);
    h5.write_ints("/steps/observed", observed);
    h5.write_ints("/steps/analysis_skipped", skipped);
    for (const char* n : {"/steps/beat", "/steps/frame", "/steps/observed", "/steps/analysis_skipped"}) {
      h5.set_attribute(n, "units", "1");
    }
    h5.write_matrix("/steps/theta", th, per, {}, names);
    h5.write_matrix("/steps/theta_lower", lo, per, {}, names);
    h5.set_attribute("/steps/theta_lower", "description", "T(eta - 2 std)");
    h5.write_matrix("/steps/theta_upper", hi, per, {}, names);
    h5.set_attribute("/steps/theta_upper", "description", "T(eta + 2 std)");
    h5.write_matrix("/steps/eta", eta, "1", {}, names);
    h5.write_matrix("/steps/eta_std", eta_std, "1", {}, names);
    h5.write_matrix("/steps/innovation", innov, "see /observations/units", {}, problem.data.channels);
    h5.write_matrix("/steps/forecast", fc, "see /observations/units", {}, problem.data.channels);
    h5.write_matrix("/steps/fitted", fit, "see /observations/units", {}, problem.data.channels);
    h5.set_attribute("/steps/fitted", "description", "linearised posterior fit of the observations");
    h5.write_vector("/steps/nis", nis, "1");
    h5.write_vector("/steps/log_likelihood", loglik, "1");
    h5.write_strings("/failures/actions", actions);

    if (problem.truth) {
      h5.write_vector("/truth/values", *problem.truth, per);
      h5.write_matrix("/truth/pass_error", pass_error, "%", {}, names);
      h5.set_attribute("/truth/pass_error", "description", "|estimate - truth| / truth after each pass");
      h5.set_attribute("/truth", "passes_to_within_10_percent", passes_needed);
    }

    h5.create_group("/summary");
    h5.set_attribute("/summary", "termination", estimation::to_string(summary.termination));
    h5.set_attribute("/summary", "message", summary.message);
    h5.set_attribute("/summary", "report", summary.brief_report());
    h5.set_attribute("/summary", "members", summary.members);
    h5.set_attribute("/summary", "member_runs", summary.member_runs);
    h5.set_attribute("/summary", "retries", summary.retries);
    h5.set_attribute("/summary", "skipped_analyses", summary.skipped_analyses);
    h5.set_attribute("/summary", "wall_seconds", summary.wall_seconds);
    h5.set_attribute("/summary", "passes", filter.beats);
    h5.set_attribute("/summary", "forgetting", filter.forgetting);
    h5.set_attribute("/summary", "r_inflation", problem.r_inflation);
    h5.set_attribute("/summary", "spin_up", problem.spin_up);
    h5.set_attribute("/summary", "failure_policy", estimation::to_string(filter.failure_policy));
    prov.end_utc = io::utc_now();
    io::write_provenance(h5, prov);
    h5.commit();
  }

  // ---- Terminal table (Pa shown as kPa).
  auto shown = [&](int j, double v) {
    return problem.units[static_cast<size_t>(j)] == "Pa" ? v / 1e3 : v;
  };
  auto shown_unit = [&](int j) {
    return problem.units[static_cast<size_t>(j)] == "Pa" ? std::string("kPa") : problem.units[static_cast<size_t>(j)];
  };
  const bool aha = problem.segments.size() == static_cast<size_t>(p) && p > 0;
  std::ostringstream t;
  t << summary.brief_report() << "\n\n"
    << std::left << std::setw(12) << "parameter" << std::setw(21) << "segment" << std::right
    << std::setw(9) << "prior" << std::setw(10) << "estimate" << std::setw(20) << "+-2 sigma";
  if (problem.truth) t << std::setw(9) << "truth" << std::setw(8) << "error";
  t << "  unit\n";
  for (int j = 0; j < p; ++j) {
    const int seg = problem.segments[static_cast<size_t>(j)];
    const std::string where = seg == 0 ? "(global)"
                              : seg <= 17 && aha ? model::lumped::aha17_segment_names()[static_cast<size_t>(seg - 1)]
                                                 : "patch " + std::to_string(seg);
    const double lo = have_estimate ? summary.theta_lower(j) : std::nan("");
    const double hi = have_estimate ? summary.theta_upper(j) : std::nan("");
    t << std::left << std::setw(12) << names[static_cast<size_t>(j)] << std::setw(21) << where << std::right
      << std::setw(9) << fmt(shown(j, prior_theta(j))) << std::setw(10) << fmt(shown(j, final_theta(j)))
      << std::setw(20) << ("[" + fmt(shown(j, lo), 3) + ", " + fmt(shown(j, hi), 3) + "]");
    if (problem.truth) {
      t << std::setw(9) << fmt(shown(j, (*problem.truth)(j))) << std::setw(7)
        << fmt(pass_error(pass_error.rows() - 1, j), 2) << "%";
    }
    t << "  " << shown_unit(j) << "\n";
  }
  if (problem.truth) {
    t << "\nmax | mean error over the parameters after each pass:";
    for (int b = 0; b < pass_error.rows(); ++b) {
      t << "  " << b + 1 << ": " << fmt(pass_error.row(b).maxCoeff(), 3) << " | "
        << fmt(pass_error.row(b).mean(), 3) << " %";
    }
    t << "\npasses until every parameter is within 10 % of the truth: "
      << (passes_needed > 0 ? std::to_string(passes_needed) : std::string("not reached")) << "\n";
  }
  ctx.out << t.str() << "wrote " << output.string() << "\n";

  if (!o.summary.empty()) {
    nlohmann::ordered_json j;
    j["kind"] = "personalize";
    j["name"] = config.name;
    j["termination"] = estimation::to_string(summary.termination);
    j["message"] = summary.message;
    j["steps"] = steps;
    j["passes"] = filter.beats;
    j["members"] = summary.members;
    j["member_runs"] = summary.member_runs;
    j["retries"] = summary.retries;
    j["skipped_analyses"] = summary.skipped_analyses;
    j["threads"] = threads;
    j["wall_seconds"] = summary.wall_seconds;
    for (int k = 0; k < p; ++k) {
      nlohmann::ordered_json e = {{"value", final_theta(k)},
                                  {"std", theta_std(k)},
                                  {"unit", problem.units[static_cast<size_t>(k)]},
                                  {"segment", problem.segments[static_cast<size_t>(k)]},
                                  {"prior", prior_theta(k)},
                                  {"prior_std", prior_std(k)}};
      if (have_estimate) {
        e["lower_2sigma"] = summary.theta_lower(k);
        e["upper_2sigma"] = summary.theta_upper(k);
      }
      if (problem.truth) {
        e["truth"] = (*problem.truth)(k);
        e["error_percent"] = pass_error(pass_error.rows() - 1, k);
      }
      j["parameters"][names[static_cast<size_t>(k)]] = e;
    }
    if (problem.truth) {
      for (int b = 0; b < pass_error.rows(); ++b) {
        j["max_error_percent_per_pass"].push_back(pass_error.row(b).maxCoeff());
      }
      j["passes_to_within_10_percent"] = passes_needed > 0 ? nlohmann::ordered_json(passes_needed) : nullptr;
    }
    io::write_text_file(o.summary, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
    ctx.out << "wrote " << o.summary.string() << "\n";
  }

  if (!summary.ok()) {
    throw RunFailure("the filter stopped (" + std::string(estimation::to_string(summary.termination)) +
                     "): " + summary.message + "; the steps done are in " + output.string());
  }
  return kExitOk;
}

}  // namespace

void register_personalize(CLI::App& app, CommandContext& ctx) {
  register_config_section({"personalize", [](const Config& c) { parse_personalize(c); }});
  auto opts = std::make_shared<PersonalizeOptions>();
  CLI::App* sub = app.add_subcommand(
      "personalize", "Estimate per-segment parameters from regional volume curves (ROUKF)");
  sub->add_option("config", opts->config, "Config file (YAML) with a personalize: section")->required();
  sub->add_option("-o,--output", opts->output, "Results file (HDF5); default results/<config>-personalize.h5");
  sub->add_option("--summary", opts->summary, "Also write the final estimates and their std as JSON");
  sub->add_option("--threads", opts->threads, "Threads for the ensemble (default: the config's, else all cores)")
      ->check(CLI::PositiveNumber);
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx] { ctx.run = [opts, &ctx] { return run_personalize(*opts, ctx); }; });
}

}  // namespace sigmaheart::app
