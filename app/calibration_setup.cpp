#include "app/calibration_setup.h"

#include "app/errors.h"
#include "app/io/observation_file.h"
#include "model/units.h"
#include "observers/composite.h"
#include "observers/curve_sampler.h"
#include "observers/global_indices.h"
#include "observers/observation_builder.h"
#include "observers/output_values.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace sigmaheart::app {

namespace {

observers::Noise parse_noise_node(const ConfigNode& node) {
  try {
    return observers::parse_noise(node.as<std::string>());
  } catch (const std::invalid_argument& e) {
    node.fail(std::string("noise: ") + e.what());
  }
}

observers::NoiseModel parse_noise_model(const ConfigNode& node) {
  observers::NoiseModel model;
  if (!node.defined()) return model;
  if (!node.is_map()) node.fail("expected a map of observation name -> noise (e.g. 'EDV: 3 mL')");
  for (const auto& key : node.keys()) {
    if (key == "default") {
      model.fallback = parse_noise_node(node[key]);
    } else {
      model.by_name[key] = parse_noise_node(node[key]);
    }
  }
  return model;
}

// Observations from a curve file: indices computed from the curves and/or the curves at frames.
void parse_file_observations(const Config& config, const ConfigNode& obs,
                             const std::vector<model::Channel>& sim_channels,
                             const std::filesystem::path& file_override, CalibrationProblem& out) {
  const ConfigNode file_node = file_override.empty() ? obs["file"] : obs;
  const std::filesystem::path path = input_file(
      file_node,
      file_override.empty() ? std::filesystem::path(file_node.as<std::string>()) : file_override,
      std::filesystem::path(config.file.file()).parent_path(), "observation file");
  io::ObservationCurves curves = io::read_observation_csv(path);
  // Missing frames (empty or NaN cells) are skipped; the others keep the full record's period.
  observers::BeatOptions measured_beat = observers::measured_frames();
  if (curves.missing > 0) {
    std::vector<std::string> used;  // every channel when indices are computed from the curves
    if (!obs.has("indices") && obs.has("curves")) {
      used = obs["curves"].as<std::vector<std::string>>();
      used.push_back("V_lv");  // end-diastole alignment
    }
    io::PresentFrames present = io::drop_missing_frames(curves, used, path.string());
    measured_beat.period = present.period;
    curves = std::move(present.curves);
  }
  out.observation_file = path;
  out.measured = curves.trajectory;
  out.measured_display_units = curves.display_units;

  const observers::NoiseModel noise = parse_noise_model(obs["noise"]);
  std::vector<observers::ObservationSet> sets;
  std::vector<std::unique_ptr<observers::Observer>> parts;

  if (obs.has("indices")) {
    observers::GlobalIndicesOptions gi;
    gi.indices = obs["indices"].as<std::vector<std::string>>();
    if (gi.indices.empty()) obs["indices"].fail("expected at least one index name");
    try {
      // The observer reads simulated beats; the measured curves only need the channels in use.
      parts.push_back(std::make_unique<observers::GlobalIndices>(gi, sim_channels));
    } catch (const std::invalid_argument& e) {
      obs["indices"].fail(e.what());
    }
    try {
      sets.push_back(observers::observations_from_indices(*out.measured, gi, noise,
                                                          curves.display_units, measured_beat));
    } catch (const std::invalid_argument& e) {
      file_node.fail(std::string("indices of the measured curves: ") + e.what());
    }
  }
  if (obs.has("curves")) {
    observers::MeasuredCurveOptions mc;
    mc.channels = obs["curves"].as<std::vector<std::string>>();
    // ecg: the file's times are times after the ECG trigger (the beat's electrical onset), as
    // gated cine MRI records them. end-diastole: both curves are aligned on their end-diastole
    // instead (for curves exported without trigger times; noisier, as ED is found from the data).
    const std::string align =
        obs.has("align") ? obs["align"].as_choice({"ecg", "end-diastole"}) : std::string("ecg");
    mc.alignment_channel = align == "ecg" ? std::string{} : std::string("V_lv");
    mc.beat = measured_beat;
    if (const auto period = config.simulator.parameters.index("period")) {
      io::check_frames_in_one_beat(curves, config.simulator.parameters[*period].nominal,
                                   path.string(), align == "ecg");
    }
    if (mc.channels.empty()) obs["curves"].fail("expected at least one channel name");
    observers::CurveObservations co;
    try {
      co = observers::observations_from_curves(*out.measured, mc, noise, curves.display_units);
    } catch (const std::invalid_argument& e) {
      file_node.fail(std::string("curves: ") + e.what());
    }
    try {
      parts.push_back(std::make_unique<observers::CurveSampler>(co.sampler, sim_channels));
    } catch (const std::invalid_argument& e) {
      obs["curves"].fail(e.what());
    }
    out.curve_sampling = co.sampler;
    out.frame_origin = co.frame_origin;
    sets.push_back(std::move(co.observations));
  }
  if (parts.empty()) {
    obs.fail("observations from a file need 'indices:' and/or 'curves:' (what to compare)");
  }
  try {
    out.observations = observers::concatenate(sets);
  } catch (const std::invalid_argument& e) {
    obs.fail(e.what());
  }
  if (parts.size() == 1) {
    out.observer = std::move(parts.front());
  } else {
    out.observer = std::make_unique<observers::CompositeObserver>(std::move(parts));
  }
}

// Typed-in values: `{EDV: {value: 142 mL, noise: 5 mL}}`, in file order.
std::vector<observers::ObservationEntry> read_entries(const ConfigNode& values, const std::string& what) {
  if (!values.is_map()) values.fail("expected a map of " + what + " name -> {value, noise}");
  std::vector<observers::ObservationEntry> entries;
  for (const auto& key : values.keys()) {
    const ConfigNode e = values[key];
    e.check_keys({"value", "noise"});
    observers::ObservationEntry entry;
    entry.name = key;
    std::tie(entry.value, entry.unit) = number_and_unit(e.require_child("value"));
    entry.noise = parse_noise_node(e.require_child("noise"));
    entries.push_back(entry);
  }
  return entries;
}

std::vector<std::string> names_of(const std::vector<observers::ObservationEntry>& entries) {
  std::vector<std::string> names;
  for (const auto& e : entries) names.push_back(e.name);
  return names;
}

// Typed-in indices: `values: {EDV: {value: 142 mL, noise: 5 mL}}`.
void parse_inline_observations(const ConfigNode& obs,
                               const std::vector<model::Channel>& sim_channels,
                               CalibrationProblem& out) {
  const ConfigNode values = obs["values"];
  const auto entries = read_entries(values, "index");
  const std::vector<std::string> names = names_of(entries);
  try {
    out.observations = observers::observations_from_entries(entries);
  } catch (const std::invalid_argument& e) {
    values.fail(e.what());
  }
  observers::GlobalIndicesOptions gi;
  gi.indices = names;
  try {
    out.observer = std::make_unique<observers::GlobalIndices>(gi, sim_channels);
  } catch (const std::invalid_argument& e) {
    values.fail(e.what());
  }
}

// Named outputs of a model that returns values (observers/output_values.h):
// `outputs: {"T[0]": {value: 0, noise: 1}, ...}` and an optional full noise `covariance:` (rows in
// the order of outputs:, entries in the product of the values' units), which replaces the noises.
void parse_output_observations(const ConfigNode& obs, const std::vector<model::Channel>& sim_channels,
                               CalibrationProblem& out) {
  const ConfigNode values = obs["outputs"];
  const auto entries = read_entries(values, "model output");
  const std::vector<std::string> names = names_of(entries);
  try {
    auto observer = std::make_unique<observers::OutputValues>(names, sim_channels);
    out.observations = observers::observations_from_entries(entries, observer->outputs());
    out.observer = std::move(observer);
  } catch (const std::invalid_argument& e) {
    values.fail(e.what());
  }
  if (!obs.has("covariance")) return;
  const ConfigNode rows = obs["covariance"];
  const auto m = static_cast<Eigen::Index>(names.size());
  Eigen::MatrixXd R(m, m);
  if (!rows.is_sequence() || static_cast<Eigen::Index>(rows.size()) != m) {
    rows.fail("expected " + std::to_string(m) + " rows of " + std::to_string(m) + " numbers");
  }
  for (Eigen::Index i = 0; i < m; ++i) {
    const auto row = rows[static_cast<size_t>(i)].as<std::vector<double>>();
    if (static_cast<Eigen::Index>(row.size()) != m) {
      rows[static_cast<size_t>(i)].fail("expected " + std::to_string(m) + " numbers in row " + std::to_string(i + 1));
    }
    for (Eigen::Index j = 0; j < m; ++j) R(i, j) = row[static_cast<size_t>(j)];
  }
  try {
    observers::set_covariance(out.observations, R, out.observations.display_units);
  } catch (const std::invalid_argument& e) {
    obs["covariance"].fail(e.what());
  }
}

estimation::PriorParameter parse_estimated(const Config& config, const std::string& name,
                                           const ConfigNode& node) {
  const auto& space = config.simulator.parameters;
  const auto index = space.index(name);
  if (!index) {
    std::string msg = "unknown parameter '" + name + "' for model " + config.simulator.model;
    const auto guess = model::closest_match(name, space.names());
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    throw InputError(node.location(), msg);
  }
  node.check_keys({"prior", "spread", "transform", "bounds"});
  try {
    estimation::PriorParameter c = bounded_by_the_model(parse_estimated_parameter(space[*index], node), space[*index]);
    c.range_lower = space[*index].range_lower;  // the physiological range, reported (prior_conflict.h)
    c.range_upper = space[*index].range_upper;
    c.range_source = space[*index].range_source;
    return c;
  } catch (const std::invalid_argument& e) {
    node.fail(std::string(e.what()) + " (bounds of '" + name + "': the prior must lie strictly inside)");
  }
}

estimation::UtGlobalStart parse_global_start(const ConfigNode& node) {
  estimation::UtGlobalStart g;
  if (!node.is_map()) node.fail("expected {samples: N, keep: k, width: 3, probe_iterations: 0}");
  node.check_keys({"samples", "keep", "width", "probe_iterations"});
  g.samples = node.require_child("samples").as<int>();
  if (g.samples < 1) node["samples"].fail("expected at least 1 screened point");
  g.keep = node.optional<int>("keep", g.keep);
  if (g.keep < 1 || g.keep > g.samples + 1) {
    node["keep"].fail("expected 1 <= keep <= samples + 1 (the screen includes the prior mean)");
  }
  g.width = node.optional<double>("width", g.width);
  if (!(g.width > 0)) node["width"].fail("expected a positive half-width in prior standard deviations");
  g.probe_iterations = node.optional<int>("probe_iterations", g.probe_iterations);
  if (g.probe_iterations < 0) {
    node["probe_iterations"].fail("expected 0 (every local run to the end) or a positive count");
  }
  return g;
}

// calibration.method / reference / least_squares (app/calibration_setup.h); the multi-start screen
// is the UT's global_start, so both estimators start from the same points.
void parse_least_squares(const ConfigNode& node, const estimation::UtOptions& ut,
                         std::optional<std::uint64_t> seed, CalibrationProblem& out) {
  if (node.has("method")) {
    out.least_squares_method = node["method"].as_choice({"unscented", "least-squares"}) == "least-squares";
  }
  if (node.has("reference")) {
    out.least_squares_reference = node["reference"].as_choice({"none", "least-squares"}) == "least-squares";
    if (out.least_squares_reference && out.least_squares_method) {
      node["reference"].fail("the reference run checks the unscented method; with method: least-squares "
                             "leave it out");
    }
  }
  estimation::LeastSquaresOptions& o = out.least_squares;
  const ConfigNode ls = node["least_squares"];
  if (ls.defined()) {
    ls.check_keys({"max_iterations", "difference", "relative_step"});
    o.max_iterations = ls.optional<int>("max_iterations", o.max_iterations);
    if (ls.has("difference")) {
      o.difference = *estimation::parse_finite_difference(ls["difference"].as_choice({"central", "forward"}));
    }
    o.relative_step = ls.optional<double>("relative_step", o.relative_step);
  }
  if (ut.global_start.samples > 0) {
    o.screen_points = ut.global_start.samples;
    o.starts = ut.global_start.keep;
    o.screen_width = ut.global_start.width;
  }
  o.seed = seed.value_or(0);
  if (const std::string problem = o.validate(); !problem.empty()) {
    (ls.defined() ? ls : node).fail("calibration.least_squares: " + problem);
  }
}

// observations.noise_model: {estimate_scale: true, prior_shape: 3, prior_scale: 4}: an unknown
// scale per channel with an inverse-gamma prior on its variance multiplier (noise_scale.h).
std::optional<estimation::NoiseScalePrior> parse_noise_scale(const ConfigNode& node) {
  if (!node.defined()) return std::nullopt;
  if (!node.is_map()) node.fail("expected {estimate_scale: true|false, prior_shape: 3, prior_scale: 4}");
  node.check_keys({"estimate_scale", "prior_shape", "prior_scale"});
  if (!node.require_child("estimate_scale").as<bool>()) return std::nullopt;
  estimation::NoiseScalePrior prior;
  prior.shape = node.optional<double>("prior_shape", prior.shape);
  if (!(prior.shape > 0)) node["prior_shape"].fail("expected a positive inverse-gamma shape a0");
  prior.scale = node.optional<double>("prior_scale", prior.shape + 1.0);
  if (!(prior.scale > 0)) node["prior_scale"].fail("expected a positive inverse-gamma scale b0");
  return prior;
}

estimation::UtOptions parse_ut_options(const ConfigNode& node) {
  estimation::UtOptions o;
  node.check_keys({"sigma_points", "kappa", "alpha", "beta", "mode", "max_iterations", "tolerance", "objective_tolerance",
                   "inflation", "sample_scale", "failure_policy", "shrink_factor", "max_retries",
                   "max_rejections", "secant_iterations", "geodesic_acceleration", "bound_margin", "global_start", "threads", "method", "reference",
                   "least_squares"});
  o.mode = estimation::UtMode::kMap;  // the default (docs/estimation.md s.3.2)
  if (node.has("sigma_points")) {
    o.sigma.rule = *estimation::parse_sigma_rule(
        node["sigma_points"].as_choice({"simplex", "canonical", "star", "scaled"}));
  }
  o.sigma.kappa = node.optional<double>("kappa", o.sigma.kappa);
  o.sigma.alpha = node.optional<double>("alpha", o.sigma.alpha);
  o.sigma.beta = node.optional<double>("beta", o.sigma.beta);
  if (node.has("mode")) {
    o.mode = *estimation::parse_ut_mode(
        node["mode"].as_choice({"map", "iterate-map", "one-shot", "iterate-keep-spread", "iterate-inflate"}));
  }
  o.max_iterations = node.optional<int>("max_iterations", o.mode == estimation::UtMode::kOneShot ? 1 : 20);
  o.tolerance = node.optional<double>("tolerance", o.tolerance);
  o.objective_tolerance = node.optional<double>("objective_tolerance", o.objective_tolerance);
  if (!(o.objective_tolerance >= 0)) node["objective_tolerance"].fail("expected >= 0 (0: stop on the step only)");
  o.inflation = node.optional<double>("inflation", o.inflation);
  o.sample_scale = node.optional<double>("sample_scale", o.sample_scale);
  if (node.has("failure_policy")) {
    o.failure_policy = *estimation::parse_ut_failure_policy(
        node["failure_policy"].as_choice({"abort", "shrink-and-retry"}));
  }
  o.shrink_factor = node.optional<double>("shrink_factor", o.shrink_factor);
  o.max_retries = node.optional<int>("max_retries", o.max_retries);
  o.max_rejections = node.optional<int>("max_rejections", o.max_rejections);
  o.secant_iterations = node.optional<int>("secant_iterations", o.secant_iterations);
  o.geodesic_acceleration = node.optional<bool>("geodesic_acceleration", o.geodesic_acceleration);
  if (o.secant_iterations < 0) node["secant_iterations"].fail("expected >= 0 (0: every iteration on sigma points)");
  o.bound_margin = node.optional<double>("bound_margin", o.bound_margin);
  if (node.has("global_start")) o.global_start = parse_global_start(node["global_start"]);
  o.ensemble.threads = node.optional<int>("threads", 0);
  return o;
}

}  // namespace

// Bounds are always respected (docs/estimation.md s.1.1): a `log` prior on a parameter whose
// bounds the log's range (0, inf) exceeds is given the bounded transform logit on
// [max(lower, 0), upper], which is a log transform of theta - lower well inside the bounds; the
// spread is converted again at the prior mean, so `30 %` keeps its meaning there.
estimation::PriorParameter bounded_by_the_model(estimation::PriorParameter c, const model::Parameter& p) {
  if (c.transform.kind != estimation::TransformKind::kLog) return c;
  const double lower = std::max(p.lower, 0.0);
  if (!std::isfinite(p.upper) && lower == 0.0) return c;
  if (!std::isfinite(p.upper)) return c;  // lower > 0 without an upper bound: Prior::validate reports it
  estimation::Transform t;
  t.kind = estimation::TransformKind::kLogit;
  t.lower = lower;
  t.upper = p.upper;
  const double theta0 = c.to_theta(c.mean_eta);
  // The std of theta at the prior mean, kept: std_eta' = std_eta T_log'(eta0) / T_logit'(eta0').
  const double theta_std = c.std_eta * c.transform.dtheta_deta(c.mean_eta);
  return estimation::PriorParameter::gaussian(c.name, c.unit, theta0, theta_std,
                                              estimation::SpreadKind::kAbsolute, t, t.lower, t.upper);
}

CalibrationProblem parse_calibration_problem(const Config& config,
                                             const std::filesystem::path& observation_file) {
  const ConfigNode root = config.file.root();
  CalibrationProblem out;
  const auto sim = config.simulator.make();
  const auto sim_channels = sim->channels();

  const ConfigNode obs = root.require_child("observations");
  obs.check_keys({"file", "indices", "curves", "align", "noise", "noise_model", "values", "outputs", "covariance"});
  const bool from_file = obs.has("file") || !observation_file.empty();
  if (static_cast<int>(from_file) + obs.has("values") + obs.has("outputs") != 1) {
    obs.fail("give one of 'file:' (measured curves), 'values:' (typed-in indices) or 'outputs:' "
             "(typed-in named outputs of the model)");
  }
  if (obs.has("covariance") && !obs.has("outputs")) obs["covariance"].fail("covariance: goes with outputs:");
  if (obs.has("outputs")) {
    parse_output_observations(obs, sim_channels, out);
  } else if (from_file) {
    parse_file_observations(config, obs, sim_channels, observation_file, out);
  } else {
    parse_inline_observations(obs, sim_channels, out);
  }
  const std::string consistent = observers::check_consistent(*out.observer, out.observations);
  if (!consistent.empty()) obs.fail(consistent);
  const std::string valid = out.observations.validate();
  if (!valid.empty()) obs.fail(valid);

  const ConfigNode est = root.require_child("estimate");
  if (!est.is_map() || est.size() == 0) {
    est.fail("expected a map of parameter name -> {prior, spread, transform}");
  }
  for (const auto& name : est.keys()) {
    out.prior.parameters.push_back(parse_estimated(config, name, est[name]));
  }

  const ConfigNode cal = root["calibration"];
  out.options = parse_ut_options(cal);
  out.options.noise_scale = parse_noise_scale(obs["noise_model"]);
  if (out.options.noise_scale && out.options.mode != estimation::UtMode::kMap) {
    obs["noise_model"].fail("an estimated noise scale needs calibration.mode: map");
  }
  const std::string problem = out.options.validate(out.prior.size());
  if (!problem.empty()) cal.fail(problem);
  parse_least_squares(cal, out.options, config.seed, out);
  return out;
}


estimation::PriorParameter parse_estimated_parameter(const model::Parameter& p,
                                                     const ConfigNode& node) {
  const double prior_mean = node.optional_quantity("prior", p.unit, p.nominal);
  if (prior_mean < p.lower || prior_mean > p.upper) {
    std::ostringstream s;
    s << "prior of '" << p.name << "' = " << prior_mean << " " << p.unit
      << " lies outside the parameter's bounds [" << p.lower << ", " << p.upper << "]";
    node["prior"].fail(s.str());
  }

  const ConfigNode spread = node.require_child("spread");
  const auto [value, spread_unit] = number_and_unit(spread);
  if (!(value > 0)) spread.fail("expected a positive spread");
  estimation::SpreadKind spread_kind = estimation::SpreadKind::kAbsolute;
  double prior_spread = value;
  if (spread_unit == "%") {
    spread_kind = estimation::SpreadKind::kRelative;
    prior_spread = value / 100.0;
  } else if (spread_unit == "eta") {
    spread_kind = estimation::SpreadKind::kEta;
  } else if (spread_unit.empty()) {
    spread.fail("write the spread as a percentage of the prior ('30 %'), in the parameter's unit "
                "('2e4 " + p.unit + "'), or in the transformed coordinate ('0.3 eta')");
  } else if (spread_unit != p.unit) {
    try {
      prior_spread = model::units::convert(value, spread_unit, p.unit);
    } catch (const std::invalid_argument& e) {
      spread.fail(std::string("spread: ") + e.what() + " (parameter unit: " + p.unit + ")");
    }
  }

  const std::string kind_text =
      node.has("transform") ? node["transform"].as_choice({"identity", "log", "logit"}) : "log";
  estimation::Transform transform;
  transform.kind = *estimation::parse_transform_kind(kind_text);
  // The prior's bounds: the transform's range, which every sigma point respects.
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  if (transform.kind == estimation::TransformKind::kLog) {
    if (!(prior_mean > 0)) node.fail("a log transform needs a positive prior");
    transform.reference = prior_mean;
    lower = 0.0;
  } else if (transform.kind == estimation::TransformKind::kLogit) {
    std::vector<double> b = {p.lower, p.upper};
    if (node.has("bounds")) {
      b = node["bounds"].as<std::vector<double>>();
      if (b.size() != 2) node["bounds"].fail("expected [lower, upper]");
    }
    if (!std::isfinite(b[0]) || !std::isfinite(b[1]) || b[0] >= b[1]) {
      node.fail("a logit transform needs finite bounds lower < upper (give 'bounds: [lo, hi]')");
    }
    if (b[0] < p.lower || b[1] > p.upper) {
      node["bounds"].fail("bounds must lie inside the parameter's own bounds");
    }
    transform.lower = lower = b[0];
    transform.upper = upper = b[1];
    if (!(prior_mean > b[0] && prior_mean < b[1])) {
      node.fail("the prior must lie strictly inside the logit bounds");
    }
  }
  if (const std::string t = transform.validate(); !t.empty()) node.fail("parameter '" + p.name + "': " + t);
  estimation::PriorParameter c;
  try {
    c = estimation::PriorParameter::gaussian(p.name, p.unit, prior_mean, prior_spread, spread_kind,
                                             transform, lower, upper);
  } catch (const std::invalid_argument& e) {
    node.fail(e.what());
  }
  if (const std::string problem = c.validate(); !problem.empty()) node.fail(problem);
  return c;
}

std::pair<double, std::string> number_and_unit(const ConfigNode& node) {
  const std::string text = node.as<std::string>();
  std::istringstream in(text);
  double value = 0.0;
  if (!(in >> value)) node.fail("expected a number with a unit, got '" + text + "'");
  std::string unit;
  std::getline(in, unit);
  const auto b = unit.find_first_not_of(" \t");
  unit = b == std::string::npos ? std::string{} : unit.substr(b);
  return {value, unit};
}

}  // namespace sigmaheart::app
