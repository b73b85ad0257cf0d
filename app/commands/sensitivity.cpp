// `sigmaheart sensitivity CONFIG`: a one-at-a-time, Morris or Sobol' study of the configured
// simulator's observer outputs (ESTIMATION.md s.6), or of an analytic test function with exact
// indices, so a study set-up can be checked with the same command.
//
//   sensitivity:
//     method: sobol                 # oat | morris | sobol
//     model: simulator              # simulator | ishigami | g-function
//     outputs: [EDV, ESV, EF, P_max]  # global indices (observers/global_indices.h); default: all
//     seed: 7                       # default: the config's seed, else 1
//     parameters:                   # simulator only; nominal = the config's value
//       sigma0: {lower: 8.0e4, upper: 2.0e5}        # bounds in the parameter's SI unit (or "80 kPa")
//       R_p:    {relative: 0.3}                     # nominal (1 -+ 0.3)
//       K_p:    {relative: 0.5, space: eta, transform: log}   # log-uniform
//       K_ar:   {lower: 1e6, upper: 1e8, space: eta, transform: logit, bounds: [0, 1e9]}
//     ishigami: {a: 7, b: 0.1}      # model: ishigami
//     g_function: {a: [0, 1, 4.5, 9, 99, 99, 99, 99]}   # model: g-function
//     oat: {mode: relative, relative_change: 0.1}      # mode: relative | range
//     morris: {trajectories: 20, levels: 4, bootstrap: 1000, confidence: 0.95}
//     sobol: {N: 1024, bootstrap: 1000, confidence: 0.95, convergence_levels: 4,
//             scrambling: lms, failure_policy: stop}   # failure_policy: stop | impute-mean
//     ensemble: {backend: threads, threads: 0}         # serial | threads | mpi; 0 = all cores
//
// Usage: sigmaheart sensitivity CONFIG [-o OUT.h5] [--summary OUT.json] [--threads N] [--set k=v]
//
// Results: results/<config>-sensitivity.h5 (or -o), kind "sensitivity". Outputs are in clinical
// units (mL, mmHg, mL/s, mmHg/s, durations in ms, EF in %); parameters in SI.
//   /analysis/parameters/{names, units, sampling, lower, upper, nominal}
//   /analysis/outputs/{names, units, si_units, from_si}
//   /analysis/design/{theta, z, status, block, row}   every run; `layout` attribute
//   /analysis/failed/{run, block, design_row, code, message, theta}   (attribute count)
//   /analysis/oat/{theta_low, theta_high, z_nominal, delta_low, delta_high, swing, normalised}
//   /analysis/morris/{mu, mu_star, sigma, *_low, *_high, dropped_trajectories}
//   /analysis/sobol/{S1, ST, S1_low, S1_high, ST_low, ST_high, output_std}, attribute `estimators`,
//   /analysis/sobol/convergence/n (sizes) and .../n<size>/... the same tables per prefix size
//   /analysis/exact/{S1, ST} for the test functions
// Tables are parameter x output (row_names, column_names attributes).
// Exit codes: 0 done; 2 bad config (file:line:column); 1 the study could not be completed (e.g. a
// Sobol' design with failed runs under failure_policy: stop, or a failed nominal run of OAT): the
// results file and the JSON summary are still written and list the failed runs.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/results.h"
#include "app/progress.h"
#include "estimation/forward_model.h"
#include "estimation/sensitivity/morris.h"
#include "estimation/sensitivity/oat.h"
#include "estimation/sensitivity/sobol_indices.h"
#include "estimation/sensitivity/test_functions.h"
#include "observers/global_indices.h"

#include <nlohmann/json.hpp>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <iomanip>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>

namespace sigmaheart::app {

namespace {

namespace sh = estimation::sensitivity;

enum class Method { kOat, kMorris, kSobol };

struct SensitivitySetup {
  Method method = Method::kSobol;
  std::string model_kind = "simulator";
  std::unique_ptr<estimation::ForwardModel> model;
  std::vector<sh::ParameterRange> ranges;
  std::optional<sh::ExactIndices> exact;
  sh::OatOptions oat;
  sh::MorrisOptions morris;
  sh::SobolOptions sobol;
};

estimation::EnsembleOptions parse_ensemble(const ConfigNode& node) {
  estimation::EnsembleOptions e;
  if (!node.defined()) return e;
  node.check_keys({"backend", "threads"});
  if (node.has("backend")) {
    e.backend = *estimation::parse_backend(node["backend"].as_choice({"serial", "threads", "mpi"}));
  }
  e.threads = node.optional<int>("threads", e.threads);
  if (const std::string m = e.validate(); !m.empty()) node.fail(m);
  return e;
}

sh::ParameterRange parse_range(const ConfigNode& node, const model::Parameter& p) {
  node.check_keys({"lower", "upper", "relative", "space", "transform", "bounds"});
  sh::ParameterRange r;
  r.name = p.name;
  r.unit = p.unit;
  r.nominal = p.nominal;
  const bool bounds = node.has("lower") || node.has("upper");
  if (bounds == node.has("relative")) {
    node.fail("give either lower and upper, or relative, for parameter '" + p.name + "'");
  }
  if (bounds) {
    r.lower = node.require_quantity("lower", p.unit);
    r.upper = node.require_quantity("upper", p.unit);
  } else {
    const double f = node["relative"].as_quantity("1");
    if (!(f > 0.0 && f < 1.0)) node["relative"].fail("expected a fraction in (0, 1)");
    r.lower = p.nominal * (1.0 - f);
    r.upper = p.nominal * (1.0 + f);
    if (r.lower > r.upper) std::swap(r.lower, r.upper);
  }
  if (node.has("space")) r.space = *estimation::parse_sampling_space(node["space"].as_choice({"physical", "eta"}));
  if (node.has("transform")) {
    r.transform.kind =
        *estimation::parse_transform_kind(node["transform"].as_choice({"identity", "log", "logit"}));
  } else if (r.space == sh::SamplingSpace::kEta) {
    node.fail("space: eta needs a transform (log or logit)");
  }
  r.transform.reference = p.nominal > 0 ? p.nominal : 1.0;
  if (r.transform.kind == estimation::TransformKind::kLogit) {
    if (node.has("bounds")) {
      const auto b = node["bounds"].as<std::vector<double>>();
      if (b.size() != 2) node["bounds"].fail("expected [lower, upper]");
      r.transform.lower = b[0];
      r.transform.upper = b[1];
    } else {
      r.transform.lower = p.lower;
      r.transform.upper = p.upper;
    }
  }
  if (!(r.lower >= p.lower && r.upper <= p.upper)) {
    std::ostringstream s;
    s << "range [" << r.lower << ", " << r.upper << "] " << p.unit << " of '" << p.name
      << "' leaves the model's bounds [" << p.lower << ", " << p.upper << "]";
    node.fail(s.str());
  }
  if (const std::string m = r.validate(); !m.empty()) node.fail(m);
  return r;
}

SensitivitySetup parse_sensitivity(const Config& config) {
  const ConfigNode node = config.file.root().require_child("sensitivity");
  node.check_keys({"method", "model", "outputs", "seed", "parameters", "ishigami", "g_function",
                   "oat", "morris", "sobol", "ensemble"});
  SensitivitySetup s;
  const std::string method = node.require_child("method").as_choice({"oat", "morris", "sobol"});
  s.method = method == "oat" ? Method::kOat : method == "morris" ? Method::kMorris : Method::kSobol;
  if (node.has("model")) s.model_kind = node["model"].as_choice({"simulator", "ishigami", "g-function"});
  std::uint64_t seed = config.seed.value_or(1);
  if (node.has("seed")) {
    const int v = node["seed"].as<int>();
    if (v < 0) node["seed"].fail("expected a seed >= 0");
    seed = static_cast<std::uint64_t>(v);
  }

  if (s.model_kind == "ishigami") {
    const ConfigNode n = node["ishigami"];
    n.check_keys({"a", "b"});
    const double a = n.optional<double>("a", 7.0), b = n.optional<double>("b", 0.1);
    s.model = std::make_unique<sh::IshigamiModel>(a, b);
    s.ranges = sh::ishigami_ranges();
    s.exact = sh::ishigami_exact(a, b);
  } else if (s.model_kind == "g-function") {
    const ConfigNode n = node["g_function"];
    n.check_keys({"a"});
    Eigen::VectorXd a = sh::g_function_default_a();
    if (n.has("a")) {
      const auto v = n["a"].as<std::vector<double>>();
      a = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
      if (a.size() == 0 || (a.array() < 0).any()) n["a"].fail("expected a list of a_i >= 0");
    }
    s.model = std::make_unique<sh::GFunctionModel>(a);
    s.ranges = sh::g_function_ranges(static_cast<int>(a.size()));
    s.exact = sh::g_function_exact(a);
  } else {
    const ConfigNode params = node.require_child("parameters");
    const model::ParameterSpace& space = config.simulator.parameters;
    params.check_keys(space.names(), "parameter", "for model " + config.simulator.model);
    std::vector<std::string> names;
    for (const auto& key : params.keys()) {
      s.ranges.push_back(parse_range(params[key], space[space.index_or_throw(key)]));
      names.push_back(key);
    }
    if (names.empty()) params.fail("no parameters to study");
    observers::GlobalIndicesOptions go;
    if (node.has("outputs")) go.indices = node["outputs"].as<std::vector<std::string>>();
    try {
      auto simulator = config.simulator.make();
      const observers::GlobalIndices observer(go, simulator->channels());
      s.model = std::make_unique<estimation::SimulatorForwardModel>(*simulator, observer, names);
    } catch (const std::invalid_argument& e) {
      node[node.has("outputs") ? "outputs" : "parameters"].fail(e.what());
    }
  }
  if (s.model_kind != "simulator" && (node.has("parameters") || node.has("outputs"))) {
    node.fail("parameters and outputs are fixed for the test function '" + s.model_kind + "'");
  }

  const estimation::EnsembleOptions ensemble = parse_ensemble(node["ensemble"]);
  const int p = static_cast<int>(s.ranges.size());
  {
    const ConfigNode n = node["oat"];
    n.check_keys({"mode", "relative_change"});
    s.oat.ensemble = ensemble;
    if (n.has("mode")) s.oat.mode = *sh::parse_oat_mode(n["mode"].as_choice({"relative", "range"}));
    s.oat.relative_change = n.optional_quantity("relative_change", "1", s.oat.relative_change);
    if (const std::string m = s.oat.validate(); !m.empty()) n.fail(m);
  }
  {
    const ConfigNode n = node["morris"];
    n.check_keys({"trajectories", "levels", "bootstrap", "confidence"});
    s.morris.ensemble = ensemble;
    s.morris.seed = seed;
    s.morris.trajectories = n.optional<int>("trajectories", s.morris.trajectories);
    s.morris.levels = n.optional<int>("levels", s.morris.levels);
    s.morris.bootstrap_samples = n.optional<int>("bootstrap", s.morris.bootstrap_samples);
    s.morris.confidence = n.optional<double>("confidence", s.morris.confidence);
    if (const std::string m = s.morris.validate(); !m.empty()) n.fail(m);
  }
  {
    const ConfigNode n = node["sobol"];
    n.check_keys({"N", "bootstrap", "confidence", "convergence_levels", "scrambling", "failure_policy"});
    s.sobol.ensemble = ensemble;
    s.sobol.seed = seed;
    s.sobol.base_samples = n.optional<int>("N", s.sobol.base_samples);
    if (n.has("N") && (s.sobol.base_samples < 16 ||
                       !sh::is_power_of_two(static_cast<std::uint64_t>(s.sobol.base_samples)))) {
      n["N"].fail("expected a power of two >= 16 (the design runs N (p + 2) simulations)");
    }
    s.sobol.bootstrap_samples = n.optional<int>("bootstrap", s.sobol.bootstrap_samples);
    s.sobol.confidence = n.optional<double>("confidence", s.sobol.confidence);
    s.sobol.convergence_levels = n.optional<int>("convergence_levels", s.sobol.convergence_levels);
    if (n.has("scrambling")) {
      s.sobol.scrambling = *sh::parse_scrambling(n["scrambling"].as_choice({"lms", "none"}));
    }
    if (n.has("failure_policy")) {
      s.sobol.failure_policy = *sh::parse_sobol_failure_policy(
          n["failure_policy"].as_choice({"stop", "impute-mean"}));
    }
    if (const std::string m = s.sobol.validate(p); !m.empty()) n.fail(m);
  }
  return s;
}

std::string exact_table(const sh::SobolResult& r, const sh::ExactIndices& e) {
  std::ostringstream s;
  s << "exact indices of the test function (estimate - exact):\n" << std::fixed << std::setprecision(4);
  for (size_t i = 0; i < r.parameters.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    s << "  " << std::setw(6) << std::left << r.parameters[i] << std::right << " S1 " << e.S1(ii)
      << " (" << std::showpos << r.estimate.S1(ii, 0) - e.S1(ii) << std::noshowpos << ")  ST "
      << e.ST(ii) << " (" << std::showpos << r.estimate.ST(ii, 0) - e.ST(ii) << std::noshowpos
      << ")\n";
  }
  return s.str();
}

struct SensitivityCommandOptions {
  std::filesystem::path config;
  std::filesystem::path output;   // empty: default_output_path(config, "sensitivity")
  std::filesystem::path summary;  // empty: no JSON summary
  int threads = 0;                // > 0: overrides sensitivity.ensemble.threads
  std::vector<std::string> overrides;
};

// How the outputs are shown (terminal, HDF5, JSON): clinical units (io::display_unit: mL, mmHg,
// mL/s, mmHg/s), durations in ms and the ejection fraction in %. Sobol' indices are ratios and need no factor.
struct OutputDisplay {
  std::vector<std::string> names, units, si_units;
  Eigen::VectorXd factor;  // shown = SI * factor
};

OutputDisplay output_display(const std::vector<model::Channel>& outs) {
  OutputDisplay d;
  d.factor.resize(static_cast<Eigen::Index>(outs.size()));
  for (size_t k = 0; k < outs.size(); ++k) {
    io::DisplayUnit u = io::display_unit(outs[k].unit);
    if (outs[k].name == "EF" && outs[k].unit == "1") u = {"%", 100.0};
    if (outs[k].unit == "s") u = {"ms", 1000.0};  // durations within a beat (t_ES, ejection)
    d.names.push_back(outs[k].name);
    d.units.push_back(u.unit);
    d.si_units.push_back(outs[k].unit);
    d.factor(static_cast<Eigen::Index>(k)) = u.from_si;
  }
  return d;
}

// Columns of a (rows x outputs) matrix in display units.
Eigen::MatrixXd shown(Eigen::MatrixXd m, const OutputDisplay& d) {
  if (m.cols() == d.factor.size()) m.array().rowwise() *= d.factor.transpose().array();
  return m;
}

std::string fmt(double v, int precision = 3) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

// The block label and the row within the block of every run of a design (its layout).
struct DesignLayout {
  std::vector<std::string> block;
  std::vector<std::int64_t> row;
  std::string description;
};

DesignLayout oat_layout(const std::vector<std::string>& names) {
  DesignLayout l;
  l.description = "2p + 1 runs: nominal, then low and high of each parameter in order";
  l.block.push_back("nominal");
  l.row.push_back(0);
  for (const auto& n : names) {
    l.block.push_back("low " + n);
    l.row.push_back(0);
    l.block.push_back("high " + n);
    l.row.push_back(0);
  }
  return l;
}

DesignLayout morris_layout(int trajectories, int p) {
  DesignLayout l;
  l.description = "r (p + 1) runs, trajectory-major; row = step within the trajectory";
  for (int t = 0; t < trajectories; ++t) {
    for (int s = 0; s <= p; ++s) {
      l.block.push_back("trajectory " + std::to_string(t));
      l.row.push_back(s);
    }
  }
  return l;
}

DesignLayout sobol_layout(int N, const std::vector<std::string>& names) {
  DesignLayout l;
  l.description = "N (p + 2) runs in blocks A, B, AB_1..AB_p (AB_i: A with column i from B); "
                  "row = design row j in 0..N-1";
  auto add = [&](const std::string& b) {
    for (int j = 0; j < N; ++j) {
      l.block.push_back(b);
      l.row.push_back(j);
    }
  };
  add("A");
  add("B");
  for (size_t i = 0; i < names.size(); ++i) add("AB_" + std::to_string(i + 1) + " (" + names[i] + ")");
  return l;
}

void write_design(io::Hdf5Writer& h5, const std::string& a, const DesignLayout& layout,
                  const std::vector<std::string>& names, const OutputDisplay& d,
                  const Eigen::MatrixXd& theta, const Eigen::MatrixXd& Z,
                  const std::vector<sh::FailedRun>& failed) {
  const std::string g = a + "/design";
  h5.write_matrix(g + "/theta", theta, "see /analysis/parameters/units", {}, names);
  h5.write_matrix(g + "/z", shown(Z, d), "see /analysis/outputs/units", {}, d.names);
  std::vector<std::int64_t> codes(static_cast<size_t>(theta.rows()), 0);
  for (const auto& f : failed) codes[static_cast<size_t>(f.run)] = static_cast<std::int64_t>(f.status.code);
  h5.write_ints(g + "/status", codes);
  h5.set_attribute(g + "/status", "units", "1");
  h5.set_attribute(g + "/status", "description", "model::StatusCode per run, 0 = ok");
  if (layout.block.size() == static_cast<size_t>(theta.rows())) {
    h5.write_strings(g + "/block", layout.block);
    h5.write_ints(g + "/row", layout.row);
    h5.set_attribute(g + "/row", "units", "1");
  }
  h5.set_attribute(g, "layout", layout.description);
  h5.set_attribute(g, "runs", static_cast<int>(theta.rows()));
  h5.set_attribute(g, "failed", static_cast<int>(failed.size()));

  const std::string fg = a + "/failed";
  h5.create_group(fg);
  h5.set_attribute(fg, "count", static_cast<int>(failed.size()));
  if (failed.empty()) return;
  std::vector<std::int64_t> runs, rows;
  std::vector<std::string> blocks, codes_text, messages;
  Eigen::MatrixXd thetas(static_cast<Eigen::Index>(failed.size()), theta.cols());
  for (size_t i = 0; i < failed.size(); ++i) {
    const auto& f = failed[i];
    runs.push_back(f.run);
    rows.push_back(f.design_row);
    blocks.push_back(f.block);
    codes_text.emplace_back(model::to_string(f.status.code));
    messages.push_back(f.status.message);
    if (f.theta.size() == theta.cols()) thetas.row(static_cast<Eigen::Index>(i)) = f.theta.transpose();
  }
  h5.write_ints(fg + "/run", runs);
  h5.set_attribute(fg + "/run", "units", "1");
  h5.set_attribute(fg + "/run", "description", "row of /analysis/design");
  h5.write_strings(fg + "/block", blocks);
  h5.write_ints(fg + "/design_row", rows);
  h5.set_attribute(fg + "/design_row", "units", "1");
  h5.write_strings(fg + "/code", codes_text);
  h5.write_strings(fg + "/message", messages);
  h5.write_matrix(fg + "/theta", thetas, "see /analysis/parameters/units", {}, names);
}

std::string failures_text(const std::vector<sh::FailedRun>& failed) {
  std::ostringstream s;
  const size_t shown_runs = std::min<size_t>(failed.size(), 10);
  for (size_t i = 0; i < shown_runs; ++i) {
    const auto& f = failed[i];
    s << "  failed run " << f.run << " (" << f.block << ", row " << f.design_row << "): "
      << model::to_string(f.status.code) << ": " << f.status.message << "\n";
  }
  if (shown_runs < failed.size()) s << "  ... " << failed.size() - shown_runs << " more (in the results file)\n";
  return s.str();
}

// Parameters of output k by decreasing `score` (NaN last).
std::vector<int> rank_by(const Eigen::MatrixXd& score, int k) {
  std::vector<int> order(static_cast<size_t>(score.rows()));
  std::iota(order.begin(), order.end(), 0);
  auto key = [&](int i) {
    const double v = std::abs(score(i, k));
    return std::isnan(v) ? -1.0 : v;
  };
  std::stable_sort(order.begin(), order.end(), [&](int i, int j) { return key(i) > key(j); });
  return order;
}

int run_sensitivity(const SensitivityCommandOptions& o, CommandContext& ctx) {
  io::Provenance prov;
  prov.start_utc = io::utc_now();
  const Config config = load_config(o.config, o.overrides);
  SensitivitySetup setup = parse_sensitivity(config);
  const std::filesystem::path output =
      !o.output.empty() ? o.output : default_output_path(o.config, "sensitivity");
  for (estimation::EnsembleOptions* e : {&setup.oat.ensemble, &setup.morris.ensemble, &setup.sobol.ensemble}) {
    if (o.threads > 0) e->threads = o.threads;
    e->communicator = ctx.comm;  // design runs spread over the ranks, if several
    if (e->threads == 1 && e->backend == estimation::Backend::kThreads) e->backend = estimation::Backend::kSerial;
  }
  const std::vector<std::string> names = sh::range_names(setup.ranges);
  const OutputDisplay disp = output_display(setup.model->outputs());
  const int p = static_cast<int>(names.size());
  const int m = static_cast<int>(disp.names.size());
  const char* method_name = setup.method == Method::kOat      ? "oat"
                            : setup.method == Method::kMorris ? "morris"
                                                              : "sobol";
  const int total_runs = setup.method == Method::kOat      ? 2 * p + 1
                         : setup.method == Method::kMorris ? setup.morris.trajectories * (p + 1)
                                                           : setup.sobol.base_samples * (p + 2);
  const int threads = setup.sobol.ensemble.backend == estimation::Backend::kSerial ? 1
                      : setup.sobol.ensemble.threads > 0 ? setup.sobol.ensemble.threads
                                                         : omp_get_max_threads();
  spdlog::info("sensitivity study '{}': {} of {} ({} parameters, {} outputs, {} runs, {} threads)",
               config.name, method_name, setup.model_kind, p, m, total_runs, threads);
  ProgressLine progress(ctx.err, "sensitivity");
  auto on_run = [&progress](int done, int) { progress.update(done); };
  setup.oat.ensemble.progress = setup.morris.ensemble.progress = setup.sobol.ensemble.progress = on_run;

  fill_provenance(prov, config, ctx, "sensitivity", threads, 1);
  prov.seed = setup.method == Method::kMorris ? setup.morris.seed : setup.sobol.seed;

  nlohmann::ordered_json js;
  js["kind"] = "sensitivity";
  js["name"] = config.name;
  js["method"] = method_name;
  js["model"] = setup.model_kind;
  js["runs"] = total_runs;

  io::Hdf5Writer h5(output);
  const std::string a = "/analysis";
  h5.write_strings(a + "/parameters/names", names);
  {
    Eigen::VectorXd lo(p), hi(p), nom(p);
    std::vector<std::string> units, spaces;
    for (int i = 0; i < p; ++i) {
      const auto& r = setup.ranges[static_cast<size_t>(i)];
      lo(i) = r.lower;
      hi(i) = r.upper;
      nom(i) = r.nominal;
      units.push_back(r.unit);
      spaces.push_back(std::string(estimation::to_string(r.space)) +
                       (r.space == sh::SamplingSpace::kEta
                            ? std::string(" (") + estimation::to_string(r.transform.kind) + ")"
                            : std::string()));
      js["parameters"].push_back({{"name", r.name}, {"unit", r.unit}, {"nominal", r.nominal},
                                  {"lower", r.lower}, {"upper", r.upper}, {"sampling", spaces.back()}});
    }
    h5.write_strings(a + "/parameters/units", units);
    h5.write_strings(a + "/parameters/sampling", spaces);
    h5.write_vector(a + "/parameters/lower", lo, "see /analysis/parameters/units");
    h5.write_vector(a + "/parameters/upper", hi, "see /analysis/parameters/units");
    h5.write_vector(a + "/parameters/nominal", nom, "see /analysis/parameters/units");
  }
  h5.write_strings(a + "/outputs/names", disp.names);
  h5.write_strings(a + "/outputs/units", disp.units);
  h5.write_strings(a + "/outputs/si_units", disp.si_units);
  h5.write_vector(a + "/outputs/from_si", disp.factor, "1");
  for (int k = 0; k < m; ++k) js["outputs"].push_back({{"name", disp.names[static_cast<size_t>(k)]}, {"unit", disp.units[static_cast<size_t>(k)]}});
  h5.set_attribute(a, "method", method_name);
  h5.set_attribute(a, "model", setup.model_kind);
  const std::string per_output = "see /analysis/outputs/units";

  std::ostringstream report;
  std::string failure;
  std::vector<sh::FailedRun> failed;
  const int top = std::min(p, 6);
  progress.start(std::string(method_name) + " design", total_runs);
  try {
    if (setup.method == Method::kOat) {
      const auto r = sh::run_oat(*setup.model, setup.ranges, setup.oat);
      progress.finish();
      failed = r.failed_runs;
      write_design(h5, a, oat_layout(names), names, disp, r.thetas, r.Z, r.failed_runs);
      const std::string g = a + "/oat";
      h5.write_vector(g + "/theta_low", r.theta_low, "see /analysis/parameters/units");
      h5.write_vector(g + "/theta_high", r.theta_high, "see /analysis/parameters/units");
      const Eigen::VectorXd z_nom = r.z_nominal.size() == m ? Eigen::VectorXd(r.z_nominal.cwiseProduct(disp.factor))
                                                            : Eigen::VectorXd::Constant(m, NAN);
      h5.write_vector(g + "/z_nominal", z_nom, per_output);
      const Eigen::MatrixXd dl = shown(r.delta_low, disp), dh = shown(r.delta_high, disp);
      const Eigen::MatrixXd swing = (dh - dl).cwiseAbs();
      h5.write_matrix(g + "/delta_low", dl, per_output, names, disp.names);
      h5.write_matrix(g + "/delta_high", dh, per_output, names, disp.names);
      h5.write_matrix(g + "/swing", swing, per_output, names, disp.names);
      h5.write_matrix(g + "/normalised", r.normalised, "1", names, disp.names);
      h5.set_attribute(g + "/normalised", "description", "elasticity d ln z / d ln theta (central difference)");
      h5.set_attribute(g, "mode", sh::to_string(setup.oat.mode));
      h5.set_attribute(g, "relative_change", setup.oat.relative_change);
      h5.set_attribute(g, "valid", r.valid ? 1 : 0);
      h5.set_attribute(g, "estimator", "one-at-a-time: z(low) - z(nominal), z(high) - z(nominal); elasticity");
      if (!r.valid) failure = r.message;
      report << "One-at-a-time study (" << sh::to_string(setup.oat.mode) << "), " << p << " parameters, "
             << total_runs << " runs, " << r.failed_runs.size() << " failed\n";
      if (r.valid) {
        for (int k = 0; k < m; ++k) {
          const auto& u = disp.units[static_cast<size_t>(k)];
          report << disp.names[static_cast<size_t>(k)] << " (nominal " << fmt(z_nom(k), 4) << " " << u << "):";
          auto& jo = js["indices"][disp.names[static_cast<size_t>(k)]];
          jo["unit"] = u;
          jo["nominal"] = z_nom(k);
          const auto order = rank_by(swing, k);
          for (int i : order) {
            const auto& n = names[static_cast<size_t>(i)];
            jo["ranking"].push_back(n);
            jo["parameters"][n] = {{"delta_low", dl(i, k)}, {"delta_high", dh(i, k)},
                                   {"swing", swing(i, k)}, {"elasticity", r.normalised(i, k)}};
          }
          for (int t = 0; t < top; ++t) {
            const int i = order[static_cast<size_t>(t)];
            report << "  " << names[static_cast<size_t>(i)] << " " << std::showpos << fmt(dl(i, k)) << "/"
                   << fmt(dh(i, k)) << std::noshowpos;
          }
          report << " " << u << "\n";
        }
      }
    } else if (setup.method == Method::kMorris) {
      const auto r = sh::run_morris(*setup.model, setup.ranges, setup.morris);
      progress.finish();
      failed = r.failed_runs;
      write_design(h5, a, morris_layout(setup.morris.trajectories, p), names, disp, r.thetas, r.Z, r.failed_runs);
      const std::string g = a + "/morris";
      const std::string u = "see /analysis/outputs/units (change over the whole range of the parameter)";
      const Eigen::MatrixXd mu = shown(r.mu, disp), mus = shown(r.mu_star, disp), sg = shown(r.sigma, disp);
      h5.write_matrix(g + "/mu", mu, u, names, disp.names);
      h5.write_matrix(g + "/mu_star", mus, u, names, disp.names);
      h5.write_matrix(g + "/sigma", sg, u, names, disp.names);
      h5.write_matrix(g + "/mu_low", shown(r.mu_low, disp), u, names, disp.names);
      h5.write_matrix(g + "/mu_high", shown(r.mu_high, disp), u, names, disp.names);
      h5.write_matrix(g + "/mu_star_low", shown(r.mu_star_low, disp), u, names, disp.names);
      h5.write_matrix(g + "/mu_star_high", shown(r.mu_star_high, disp), u, names, disp.names);
      h5.write_matrix(g + "/sigma_low", shown(r.sigma_low, disp), u, names, disp.names);
      h5.write_matrix(g + "/sigma_high", shown(r.sigma_high, disp), u, names, disp.names);
      std::vector<std::int64_t> dropped(r.dropped_trajectories.begin(), r.dropped_trajectories.end());
      h5.write_ints(g + "/dropped_trajectories", dropped);
      h5.set_attribute(g + "/dropped_trajectories", "units", "1");
      h5.set_attribute(g, "trajectories", setup.morris.trajectories);
      h5.set_attribute(g, "used_trajectories", static_cast<int>(r.used_trajectories.size()));
      h5.set_attribute(g, "levels", setup.morris.levels);
      h5.set_attribute(g, "confidence", setup.morris.confidence);
      h5.set_attribute(g, "bootstrap", setup.morris.bootstrap_samples);
      h5.set_attribute(g, "valid", r.valid ? 1 : 0);
      h5.set_attribute(g, "estimator",
                       "Morris 1991 elementary effects in unit-cube coordinates; mu* Campolongo 2007; "
                       "percentile bootstrap over trajectories");
      if (!r.valid) failure = r.message;
      report << "Morris study: " << p << " parameters, " << setup.morris.trajectories << " trajectories ("
             << r.used_trajectories.size() << " used, " << r.dropped_trajectories.size()
             << " dropped for failed runs), " << total_runs << " runs\n";
      js["trajectories_used"] = r.used_trajectories.size();
      js["trajectories_dropped"] = r.dropped_trajectories;
      if (r.valid) {
        for (int k = 0; k < m; ++k) {
          const auto& un = disp.units[static_cast<size_t>(k)];
          auto& jo = js["indices"][disp.names[static_cast<size_t>(k)]];
          jo["unit"] = un;
          const auto order = rank_by(mus, k);
          for (int i : order) {
            const auto& n = names[static_cast<size_t>(i)];
            jo["ranking"].push_back(n);
            jo["parameters"][n] = {{"mu", mu(i, k)}, {"mu_star", mus(i, k)}, {"sigma", sg(i, k)},
                                   {"mu_star_low", r.mu_star_low(i, k) * disp.factor(k)},
                                   {"mu_star_high", r.mu_star_high(i, k) * disp.factor(k)}};
          }
          report << disp.names[static_cast<size_t>(k)] << " [" << un << "], mu* (sigma):";
          for (int t = 0; t < top; ++t) {
            const int i = order[static_cast<size_t>(t)];
            report << "  " << names[static_cast<size_t>(i)] << " " << fmt(mus(i, k)) << " (" << fmt(sg(i, k), 2) << ")";
          }
          report << "\n";
        }
      }
    } else {
      const auto r = sh::run_sobol(*setup.model, setup.ranges, setup.sobol);
      progress.finish();
      failed = r.failed_runs;
      write_design(h5, a, sobol_layout(r.N, names), names, disp, r.thetas, r.Z, r.failed_runs);
      const std::string g = a + "/sobol";
      h5.create_group(g);
      h5.set_attribute(g, "N", r.N);
      h5.set_attribute(g, "valid", r.valid ? 1 : 0);
      h5.set_attribute(g, "imputed", r.imputed ? 1 : 0);
      h5.set_attribute(g, "failure_policy", sh::to_string(setup.sobol.failure_policy));
      h5.set_attribute(g, "message", r.message);
      h5.set_attribute(g, "confidence", setup.sobol.confidence);
      h5.set_attribute(g, "bootstrap", setup.sobol.bootstrap_samples);
      h5.set_attribute(g, "scrambling", sh::to_string(setup.sobol.scrambling));
      h5.set_attribute(g, "estimators",
                       "S1 Saltelli et al. 2010 (Table 2 b); ST Jansen 1999 (Saltelli 2010 Table 2 f); "
                       "percentile bootstrap over design rows");
      std::vector<std::int64_t> levels;
      for (const auto& e : r.convergence) {
        levels.push_back(e.n);
        for (const std::string& c : {e.n == r.N ? g : std::string(), g + "/convergence/n" + std::to_string(e.n)}) {
          if (c.empty()) continue;
          h5.write_matrix(c + "/S1", e.S1, "1", names, disp.names);
          h5.write_matrix(c + "/ST", e.ST, "1", names, disp.names);
          h5.write_matrix(c + "/S1_low", e.S1_low, "1", names, disp.names);
          h5.write_matrix(c + "/S1_high", e.S1_high, "1", names, disp.names);
          h5.write_matrix(c + "/ST_low", e.ST_low, "1", names, disp.names);
          h5.write_matrix(c + "/ST_high", e.ST_high, "1", names, disp.names);
          if (e.variance.size() == m) {
            Eigen::VectorXd sd = e.variance.cwiseMax(0.0).cwiseSqrt().cwiseProduct(disp.factor);
            h5.write_vector(c + "/output_std", sd, per_output);
          }
        }
      }
      if (!levels.empty()) {
        h5.write_ints(g + "/convergence/n", levels);
        h5.set_attribute(g + "/convergence/n", "units", "1");
      }
      if (!r.valid) failure = r.message;
      report << "Sobol' study: " << p << " parameters, N = " << r.N << ", " << r.runs << " runs, "
             << r.failed_runs.size() << " failed (policy " << sh::to_string(setup.sobol.failure_policy)
             << ")\n";
      if (!r.message.empty()) report << r.message << "\n";
      js["N"] = r.N;
      js["imputed"] = r.imputed;
      if (r.valid) {
        const auto& e = r.estimate;
        for (int k = 0; k < m; ++k) {
          auto& jo = js["indices"][disp.names[static_cast<size_t>(k)]];
          jo["unit"] = disp.units[static_cast<size_t>(k)];
          if (e.variance.size() == m) jo["std"] = std::sqrt(std::max(0.0, e.variance(k))) * disp.factor(k);
          const auto order = rank_by(e.ST, k);
          for (int i : order) {
            const auto& n = names[static_cast<size_t>(i)];
            jo["ranking"].push_back(n);
            jo["parameters"][n] = {{"S1", e.S1(i, k)}, {"S1_low", e.S1_low(i, k)}, {"S1_high", e.S1_high(i, k)},
                                   {"ST", e.ST(i, k)}, {"ST_low", e.ST_low(i, k)}, {"ST_high", e.ST_high(i, k)}};
          }
          report << disp.names[static_cast<size_t>(k)];
          if (e.variance.size() == m) {
            report << " (std " << fmt(std::sqrt(std::max(0.0, e.variance(k))) * disp.factor(k)) << " "
                   << disp.units[static_cast<size_t>(k)] << ")";
          }
          report << ", ST [S1]:";
          for (int t = 0; t < top; ++t) {
            const int i = order[static_cast<size_t>(t)];
            report << "  " << names[static_cast<size_t>(i)] << " " << std::fixed << std::setprecision(2)
                   << e.ST(i, k) << " [" << e.S1(i, k) << "]" << std::defaultfloat;
          }
          report << "\n";
        }
        if (setup.exact) report << exact_table(r, *setup.exact);
      }
    }
  } catch (const std::invalid_argument& e) {
    throw InputError(config.file.root()["sensitivity"].location(), e.what());
  }
  if (!failed.empty()) report << failures_text(failed);
  if (setup.exact) {
    h5.write_vector(a + "/exact/S1", setup.exact->S1, "1");
    h5.write_vector(a + "/exact/ST", setup.exact->ST, "1");
    js["exact"] = {{"S1", std::vector<double>(setup.exact->S1.data(), setup.exact->S1.data() + setup.exact->S1.size())},
                   {"ST", std::vector<double>(setup.exact->ST.data(), setup.exact->ST.data() + setup.exact->ST.size())}};
  }
  prov.end_utc = io::utc_now();
  io::write_provenance(h5, prov);
  h5.commit();

  js["valid"] = failure.empty();
  js["message"] = failure;
  for (const auto& f : failed) {
    js["failed_runs"].push_back({{"run", f.run}, {"block", f.block}, {"design_row", f.design_row},
                                 {"code", model::to_string(f.status.code)}, {"message", f.status.message}});
  }
  if (failed.empty()) js["failed_runs"] = nlohmann::json::array();
  js["results_file"] = output.string();

  ctx.out << report.str() << "wrote " << output.string() << "\n";
  if (!o.summary.empty()) {
    io::write_text_file(o.summary, [&](std::ostream& f) { f << js.dump(2) << "\n"; });
    ctx.out << "wrote " << o.summary.string() << "\n";
  }
  if (!failure.empty()) {
    throw RunFailure("sensitivity study '" + config.name + "': " + failure + " (failed runs listed in " +
                     output.string() + ", /analysis/failed)");
  }
  return kExitOk;
}

}  // namespace

void register_sensitivity(CLI::App& app, CommandContext& ctx) {
  register_config_section({"sensitivity", [](const Config& c) { parse_sensitivity(c); }});
  auto opts = std::make_shared<SensitivityCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "sensitivity", "One-at-a-time, Morris or Sobol' study of the model outputs (section sensitivity:)");
  sub->add_option("config", opts->config, "Config file (YAML) with a sensitivity: section")->required();
  sub->add_option("-o,--output", opts->output,
                  "Results file (HDF5); default results/<config>-sensitivity.h5");
  sub->add_option("--summary", opts->summary, "Also write the indices (clinical units) as JSON");
  sub->add_option("--threads", opts->threads, "Threads for the design runs (default: the config's, else all cores)")
      ->check(CLI::PositiveNumber);
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx] { ctx.run = [opts, &ctx] { return run_sensitivity(*opts, ctx); }; });
}

}  // namespace sigmaheart::app
