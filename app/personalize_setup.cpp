#include "app/personalize_setup.h"

#include "app/personalize_start.h"

#include "app/calibration_setup.h"
#include "app/errors.h"
#include "app/io/display.h"
#include "app/io/observation_file.h"
#include "model/regional_volume_shares.h"
#include "model/time_shift.h"
#include "model/units.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>

namespace sigmaheart::app {

namespace {

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

// Segments of a per-segment family: `all` or a list of 1-based numbers among `available`.
std::vector<int> parse_segments(const ConfigNode& node, const std::vector<int>& available) {
  const int patches = available.empty() ? 0 : available.back();
  if (node.is_scalar()) {
    if (node.as<std::string>() != "all") node.fail("expected 'all' or a list of segment numbers");
    return available;
  }
  if (!node.is_sequence() || node.size() == 0) node.fail("expected 'all' or a list of segment numbers");
  std::vector<int> out;
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

// Names a config may use for the estimated parameters (for did-you-mean).
std::vector<std::string> estimable_names(const model::ParameterSpace& space) {
  std::vector<std::string> out;
  std::set<std::string> families;
  for (const auto& p : space.all()) {
    if (!p.regional()) {
      out.push_back(p.name);
    } else if (families.insert(p.family).second) {
      out.push_back(p.family);
      const std::string& n = p.name;  // its stem: the name up to the last '_'
      if (const auto cut = n.rfind('_'); cut != std::string::npos) out.push_back(n.substr(0, cut));
    }
  }
  return out;
}

void parse_observations(const Config& config, const ConfigNode& obs, PersonalizeProblem& out) {
  obs.check_keys({"file", "channels", "noise", "start_beats", "align", "period", "shares"});
  const auto sim = config.simulator.make();
  const auto sim_channels = sim->channels();
  const ConfigNode file_node = obs.require_child("file");
  const std::filesystem::path path =
      input_file(file_node, file_node.as<std::string>(),
                 std::filesystem::path(config.file.file()).parent_path(), "observation file");
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
      const auto found = tr.channel_index(names[i]);
      if (!found) obs["channels"][i].fail("the file has no column '" + names[i] + "'");
      columns.push_back(*found);
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
    const auto col = static_cast<size_t>(columns[static_cast<size_t>(j)]);
    const model::Channel& ch = tr.channels[col];
    bool in_model = false;
    for (const auto& s : sim_channels) in_model = in_model || s.name == ch.name;
    if (!in_model) {
      const auto guess = model::closest_match(ch.name, sim_names);
      file_node.fail("column '" + ch.name + "' is not a channel of model " + config.simulator.model +
                     (guess.empty() ? "" : " (did you mean '" + guess + "'?)"));
    }
    out.data.channels.push_back(ch.name);
    out.data.values.col(j) = tr.values.col(static_cast<Eigen::Index>(col));
    const std::string shown = curves.display_units[col];
    out.display_units.push_back(shown.empty() ? io::display_unit(ch.unit).unit : shown);
    out.display_factor(j) = model::units::convert(1.0, ch.unit, out.display_units.back());
    ConfigNode nj = noise;
    if (noise.is_map()) {
      nj = noise.has(ch.name) ? noise[ch.name] : noise["default"];
      if (!nj.defined()) noise.fail("no noise for '" + ch.name + "' (give it or 'default:')");
    }
    out.noise_si(j) = parse_noise_value(nj, ch.unit, out.data.values.col(j).mean());
  }
  out.start_beats = obs.optional<int>("start_beats", 0);
  if (out.start_beats < 0) obs["start_beats"].fail("expected an integer >= 0");
  out.align_end_diastole = obs.has("align") && obs["align"].as_choice({"ecg", "end-diastole"}) == "end-diastole";
  out.shares_from_data = obs.has("shares") && obs["shares"].as_choice({"model", "data"}) == "data";
  out.share_exponents =
      out.shares_from_data && model::RegionalVolumeShares::regional_channels(sim_channels).size() == 17;
  out.period_from_data = obs.has("period") && obs["period"].as_choice({"model", "data"}) == "data";
  if (out.period_from_data) {
    // One beat of evenly spaced frames: the period is the span plus one spacing (as
    // observers::measured_frames() infers it).
    const Eigen::Index n = tr.times.size();
    const double spacing = (tr.times(n - 1) - tr.times(0)) / static_cast<double>(n - 1);
    for (Eigen::Index k = 1; k < n; ++k) {
      if (std::abs(tr.times(k) - tr.times(k - 1) - spacing) > 0.05 * spacing) {
        obs["period"].fail("period: data needs evenly spaced frames over one beat; frames " + std::to_string(k - 1) +
                           " and " + std::to_string(k) + " (lines " + std::to_string(curves.lines[static_cast<size_t>(k - 1)]) +
                           ", " + std::to_string(curves.lines[static_cast<size_t>(k)]) + ") are not");
      }
    }
    out.period = spacing * static_cast<double>(n);
    out.notes.push_back("period from the data: " + std::to_string(n) + " frames every " +
                        std::to_string(1e3 * spacing) + " ms, " + std::to_string(1e3 * out.period) + " ms");
  }
  if (out.align_end_diastole && out.start_beats < 1) {
    obs["start_beats"].fail("align: end-diastole needs start_beats >= 1 (the data's first frame may fall before the "
                            "model's end-diastole)");
  }
  out.file_times = tr.times;
  out.file_curves = curves;
  out.data.times = tr.times.array() + out.start_beats * out.period;
  if (!out.align_end_diastole && !(tr.times(0) >= 0.0)) {
    file_node.fail("frame times must start at or after 0 (times after the ECG trigger; or align: end-diastole)");
  }
}

// The nominal values the set-up sets before the priors are read (a prior without `prior:` is
// centred there): the period from the data, a calibrate result's posterior means (held globals,
// and the centres of per-segment families) and a measured activation map.
void set_nominal_values(const Config& config, const ConfigNode& sec, PersonalizeProblem& out) {
  model::ParameterSpace& space = out.space;
  if (out.period_from_data) space.set_nominal(space[*space.find("period")].name, out.period);
  if (out.start) {
    for (const auto& q : out.start->globals.parameters) {
      if (space.index(q.name)) space.set_nominal(q.name, q.theta_nominal);
    }
    for (const auto& [stem, theta] : out.start->family_centres) {
      const std::vector<int> members = per_segment_family(config.simulator.parameters, stem);
      const std::string& family = config.simulator.parameters[members.front()].family;
      for (const auto& p : space.all()) {
        if (p.family == family) space.set_nominal(p.name, std::clamp(theta, p.lower, p.upper));
      }
    }
  }
  if (!out.activation_file.empty()) {
    const io::ActivationMap map = io::read_activation_map_csv(out.activation_file);
    for (size_t i = 0; i < map.segments.size(); ++i) {
      const auto idx = space.find("activation_time", map.segments[i]);
      if (!idx) {
        throw InputError(out.activation_file.string(), map.lines[i], 1,
                         "segment " + std::to_string(map.segments[i]) + " has no activation time Td of its own in model " +
                             config.simulator.model + " (outside its segments, or tied in a zone)");
      }
      const model::Parameter& p = space[*idx];
      if (!(map.times[i] >= p.lower && map.times[i] < std::min(p.upper, out.period))) {
        throw InputError(out.activation_file.string(), map.lines[i], 1,
                         "activation time of segment " + std::to_string(map.segments[i]) + " = " +
                             std::to_string(1e3 * map.times[i]) + " ms lies outside [0, period)");
      }
      space.set_nominal(p.name, map.times[i]);
    }
    out.notes.push_back("activation times of " + std::to_string(map.segments.size()) + " segments from " +
                        out.activation_file.string());
  }
}

// The parameters of the per-segment family that config key `key` names and their segment numbers;
// an InputError at the key when it names none.
std::pair<std::vector<int>, std::vector<int>> family_members(const Config& config, const ConfigNode& est,
                                                            const std::string& key,
                                                            const model::ParameterSpace& space) {
  std::vector<int> members = per_segment_family(space, key), segments;
  if (members.empty()) {
    throw InputError(est.key_location(key), "'" + key + "' is not a per-segment parameter family of " +
                                                config.simulator.model + " (e.g. sigma0, Td, stiff, scar)");
  }
  for (int i : members) segments.push_back(space[i].segment);
  return {members, segments};
}

// Zones (`<family>: {zones: {name: [segments]}}`) tie segments of a family to one parameter
// `<family>_<name>`; they change the parameter space the other keys are read against.
void parse_zones(const Config& config, const ConfigNode& est, PersonalizeProblem& out) {
  const model::ParameterSpace& inner = config.simulator.parameters;
  for (const auto& key : est.keys()) {
    const ConfigNode node = est[key];
    if (!node.is_map() || !node.has("zones")) continue;
    if (node.has("segments")) node.fail("give either segments: or zones:, not both");
    const auto [members, available] = family_members(config, est, key, inner);
    const ConfigNode zones = node["zones"];
    if (!zones.is_map() || zones.size() == 0) zones.fail("expected a map of zone name -> list of segments");
    std::vector<int> used;
    for (const auto& name : zones.keys()) {
      model::ParameterZone zone{key + "_" + name, {}};
      for (int s : parse_segments(zones[name], available)) {
        for (int u : used) {
          if (u == s) zones[name].fail("segment " + std::to_string(s) + " is already in another zone");
        }
        used.push_back(s);
        zone.members.push_back(*inner.find(inner[members.front()].family, s));
      }
      out.zones.push_back(std::move(zone));
    }
  }
  try {
    out.space = model::ZonedSimulator::zoned_space(inner, out.zones);
    // shares: data adds the volume share law's exponents per AHA level (17 segments).
    out.space = model::RegionalVolumeShares::shares_space(out.space, out.share_exponents);
    // align: end-diastole adds the time shift the filter may refine (model/time_shift.h).
    if (out.align_end_diastole) out.space = model::TimeShift::shifted_space(out.space);
  } catch (const std::invalid_argument& e) {
    est.fail(e.what());
  }
}

void parse_estimate(const Config& config, const ConfigNode& sec, PersonalizeProblem& out) {
  const ConfigNode est = sec.require_child("estimate");
  if (!est.is_map() || est.size() == 0) est.fail("expected a map of parameter -> {prior, spread, ...}");
  parse_zones(config, est, out);
  set_nominal_values(config, sec, out);
  const model::ParameterSpace& space = out.space;
  for (const auto& key : est.keys()) {
    const ConfigNode node = est[key];
    node.check_keys({"segments", "zones", "prior", "spread", "transform", "bounds"});
    if (node.has("zones")) {
      for (const auto& zone_name : node["zones"].keys()) {
        const int idx = *space.index(key + "_" + zone_name);
        out.prior.parameters.push_back(bounded_by_the_model(parse_estimated_parameter(space[idx], node), space[idx]));
        out.segments.push_back(0);
        out.families.push_back(key);
      }
    } else if (node.has("segments")) {
      const auto [members, available] = family_members(config, est, key, space);
      for (int s : parse_segments(node["segments"], available)) {
        const int idx = *space.find(space[members.front()].family, s);
        out.prior.parameters.push_back(bounded_by_the_model(parse_estimated_parameter(space[idx], node), space[idx]));
        out.segments.push_back(s);
        out.families.push_back(key);
      }
    } else {
      const auto idx = space.index(key);
      if (!idx) {
        const auto guess = model::closest_match(key, estimable_names(space));
        throw InputError(est.key_location(key),
                         "unknown parameter '" + key + "' for model " + config.simulator.model +
                             (guess.empty() ? "" : " (did you mean '" + guess + "'?)") +
                             "; per-segment families take 'segments:'");
      }
      out.prior.parameters.push_back(
          bounded_by_the_model(parse_estimated_parameter(space[*idx], node), space[*idx]));
      out.segments.push_back(0);
      out.families.push_back(key);
    }
  }
  if (out.start && out.start->estimate_globals && out.start->globals.size() > 0) {
    // The calibrated globals join the estimate with the calibration's posterior as their prior
    // (its correlations kept: the correlation matrix is block-diagonal, config block first).
    const estimation::Prior& g = out.start->globals;
    for (const auto& q : g.parameters) {
      for (size_t c = 0; c < out.prior.parameters.size(); ++c) {
        if (out.prior.parameters[c].name != q.name) continue;
        throw InputError(est.key_location(out.families[c]),
                         "'" + q.name + "' is co-estimated from the calibrate result (start: globals: estimate); "
                         "remove it here or hold the globals (globals: hold)");
      }
    }
    const int a = out.prior.size(), b = g.size();
    Eigen::MatrixXd C = Eigen::MatrixXd::Identity(a + b, a + b);
    if (out.prior.correlation.size() > 0) C.topLeftCorner(a, a) = out.prior.correlation;
    C.bottomRightCorner(b, b) = g.correlation;
    for (const auto& q : g.parameters) {
      out.prior.parameters.push_back(q);
      out.segments.push_back(0);
      out.families.push_back(q.name);
    }
    out.prior.correlation = C;
  }
  for (size_t a = 0; a < out.prior.parameters.size(); ++a) {
    for (size_t b = 0; b < a; ++b) {
      if (out.prior.parameters[a].name == out.prior.parameters[b].name) {
        est.fail("parameter '" + out.prior.parameters[a].name + "' is estimated twice");
      }
    }
  }
}

void parse_filter(const ConfigNode& f, PersonalizeProblem& out) {
  f.check_keys({"beats", "passes", "first_fraction", "pass_growth", "tempering", "sigma_scale",
                "forgetting", "r_inflation", "sigma_points", "kappa", "spin_up", "failure_policy",
                "max_retries", "shrink", "inflation", "threads", "map_iterations", "map_tolerance",
                "map_objective_tolerance", "noise_scale"});
  estimation::RoukfOptions& o = out.filter;
  o.beats = f.optional<int>("beats", 1);
  if (o.beats < 1) f["beats"].fail("expected an integer >= 1");
  o.period = out.period;
  if (f.has("passes")) {
    o.pass_mode = *estimation::parse_roukf_pass_mode(f["passes"].as_choice({"repeat", "split"}));
  }
  o.first_fraction = f.optional<double>("first_fraction", o.first_fraction);
  if (!(o.first_fraction > 0 && o.first_fraction <= 1)) f["first_fraction"].fail("expected a number in (0, 1]");
  o.pass_growth = f.optional<double>("pass_growth", o.pass_growth);
  if (!(o.pass_growth > 0)) f["pass_growth"].fail("expected a positive number");
  o.tempering = f.optional<double>("tempering", o.tempering);
  if (!(o.tempering >= 0)) f["tempering"].fail("expected a number >= 0 (0: off)");
  o.sigma_scale = f.optional<double>("sigma_scale", o.sigma_scale);
  if (!(o.sigma_scale > 0 && o.sigma_scale <= 1)) f["sigma_scale"].fail("expected a number in (0, 1]");
  o.forgetting = f.optional<double>("forgetting", o.forgetting);
  if (!(o.forgetting > 0 && o.forgetting <= 1)) f["forgetting"].fail("expected a number in (0, 1]");
  o.map_iterations = f.optional<int>("map_iterations", o.map_iterations);
  if (o.map_iterations < 0) f["map_iterations"].fail("expected an integer >= 0 (0: no MAP refinement)");
  o.map_tolerance = f.optional<double>("map_tolerance", o.map_tolerance);
  if (!(o.map_tolerance > 0)) f["map_tolerance"].fail("expected a positive number of posterior standard deviations");
  o.map_objective_tolerance = f.optional<double>("map_objective_tolerance", o.map_objective_tolerance);
  if (!(o.map_objective_tolerance >= 0)) {
    f["map_objective_tolerance"].fail("expected a number >= 0 (a fall of Phi per observation; 0: off)");
  }
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
  if (const ConfigNode ns = f["noise_scale"]; ns.defined()) {
    estimation::NoiseScalePrior prior;
    if (ns.is_scalar()) {
      ns.as_choice({"estimate"});
    } else {
      ns.check_keys({"shape", "scale"});
      prior.shape = ns.optional<double>("shape", prior.shape);
      prior.scale = ns.optional<double>("scale", prior.scale);
      if (const std::string e = prior.validate(); !e.empty()) ns.fail(e);
    }
    o.noise_scale = prior;
  }
  o.R = (out.r_inflation * out.noise_si).array().square().matrix().asDiagonal();
  o.refine = estimation::refine_by_time_step;
  if (const std::string e = o.validate(); !e.empty()) f.fail(e);
}

// truth: per family a list (one value per segment of the family) or one value; per global
// parameter one value.
void parse_truth(const model::ParameterSpace& space, const ConfigNode& truth, PersonalizeProblem& out) {
  if (!truth.is_map()) truth.fail("expected a map of parameter (or family) -> value(s)");
  const auto p = static_cast<Eigen::Index>(out.prior.size());
  Eigen::VectorXd t = Eigen::VectorXd::Constant(p, std::nan(""));
  for (const auto& key : truth.keys()) {
    const ConfigNode v = truth[key];
    bool used = false;
    for (Eigen::Index j = 0; j < p; ++j) {
      const auto k = static_cast<size_t>(j);
      const auto& q = out.prior.parameters[k];
      const bool in_family = out.families[k] == key && out.segments[k] > 0;
      if (v.is_sequence()) {
        if (!in_family) continue;
        const auto segments = per_segment_family(space, key).size();
        if (v.size() != segments) v.fail("expected " + std::to_string(segments) + " values, one per segment");
        t(j) = v[static_cast<size_t>(out.segments[k] - 1)].as_quantity(q.unit);
        used = true;
      } else if (q.name == key || in_family) {
        t(j) = v.as_quantity(q.unit);
        used = true;
      }
    }
    if (!used) throw InputError(truth.key_location(key), "'" + key + "' is not estimated");
  }
  if (!t.allFinite()) truth.fail("give the truth of every estimated parameter (or none)");
  out.filter.truth = t;
}

}  // namespace

PersonalizeProblem parse_personalize(const Config& config) {
  const ConfigNode root = config.file.root();
  const ConfigNode sec = root.require_child("personalize");
  sec.check_keys({"observations", "estimate", "filter", "truth", "start", "activation"});
  const model::ParameterSpace& space = config.simulator.parameters;
  PersonalizeProblem out;
  const auto period_index = space.find("period");
  if (!period_index) root["simulator"].fail("personalize needs a model with a parameter tagged 'period'");
  out.period = space.nominal()(*period_index);

  parse_observations(config, sec.require_child("observations"), out);
  const std::filesystem::path base = std::filesystem::path(config.file.file()).parent_path();
  if (const ConfigNode start = sec["start"]; start.defined()) {
    out.start = parse_calibrated_start(start, base, space, config.simulator.model);
    out.notes.push_back(std::string("start: ") + out.start->file.string() + " (calibrate, model " + out.start->model +
                        "), " + std::to_string(out.start->globals.size()) + " global parameter(s) " +
                        (out.start->estimate_globals ? "co-estimated" : "held") +
                        (out.start->family_centres.empty() ? "" : ", centring the per-segment " + out.start->family_centres.front().first));
  }
  if (const ConfigNode act = sec["activation"]; act.defined()) {
    if (!act.is_map()) act.fail("expected {file: ACTIVATION-MAP.csv}");
    act.check_keys({"file"});
    const ConfigNode f = act.require_child("file");
    out.activation_file = input_file(f, f.as<std::string>(), base, "activation map");
  }
  parse_estimate(config, sec, out);
  parse_filter(sec["filter"], out);
  out.filter.period = out.period;
  out.filter.base_theta = out.space.nominal();
  const ConfigNode file_node = sec["observations"]["file"];
  if (const std::string e = out.data.validate(); !e.empty()) file_node.fail(e);
  const auto& times = out.file_times;
  if (out.filter.beats > 1 && !(times(times.size() - 1) < times(0) + out.period)) {
    file_node.fail("the frames span more than one heart period (" + std::to_string(out.period) +
                   " s); repeated passes need one beat");
  }
  if (const ConfigNode truth = sec["truth"]; truth.defined()) parse_truth(out.space, truth, out);
  return out;
}

}  // namespace sigmaheart::app
