#include "app/sensitivity_setup.h"

#include "estimation/enum_names.h"
#include "estimation/forward_model.h"
#include "observers/global_indices.h"
#include "observers/output_values.h"

#include <array>
#include <cstdint>
#include <sstream>
#include <utility>

namespace sigmaheart::app {

namespace {

namespace sh = estimation::sensitivity;
using estimation::PriorParameter;

constexpr std::array<estimation::EnumName<SensitivityMethod>, 3> kMethodNames{{
    {SensitivityMethod::kOat, "oat"},
    {SensitivityMethod::kMorris, "morris"},
    {SensitivityMethod::kSobol, "sobol"},
}};

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

// One studied parameter of the simulator: {lower, upper} or {relative}, and where it is uniform.
PriorParameter parse_range(const ConfigNode& node, const model::Parameter& p) {
  node.check_keys({"lower", "upper", "relative", "space", "transform", "bounds"});
  const bool bounds = node.has("lower") || node.has("upper");
  if (bounds == node.has("relative")) {
    node.fail("give either lower and upper, or relative, for parameter '" + p.name + "'");
  }
  double lower = 0.0, upper = 0.0;
  if (bounds) {
    lower = node.require_quantity("lower", p.unit);
    upper = node.require_quantity("upper", p.unit);
  } else {
    const double f = node["relative"].as_quantity("1");
    if (!(f > 0.0 && f < 1.0)) node["relative"].fail("expected a fraction in (0, 1)");
    lower = p.nominal * (1.0 - f);
    upper = p.nominal * (1.0 + f);
    if (lower > upper) std::swap(lower, upper);
  }
  PriorParameter r = PriorParameter::uniform(p.name, p.unit, lower, upper, p.nominal);
  if (node.has("space")) {
    r.space = *estimation::parse_sampling_space(node["space"].as_choice({"physical", "eta"}));
  }
  if (node.has("transform")) {
    r.transform.kind =
        *estimation::parse_transform_kind(node["transform"].as_choice({"identity", "log", "logit"}));
  } else if (r.space == estimation::SamplingSpace::kEta) {
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

// model: ishigami | g-function: the model, its fixed prior and its exact indices.
void parse_test_function(const ConfigNode& node, SensitivitySetup& s) {
  if (s.model_kind == "ishigami") {
    const ConfigNode n = node["ishigami"];
    n.check_keys({"a", "b"});
    const double a = n.optional<double>("a", 7.0), b = n.optional<double>("b", 0.1);
    s.model = std::make_unique<sh::IshigamiModel>(a, b);
    s.prior = sh::ishigami_prior();
    s.exact = sh::ishigami_exact(a, b);
    return;
  }
  const ConfigNode n = node["g_function"];
  n.check_keys({"a"});
  Eigen::VectorXd a = sh::g_function_default_a();
  if (n.has("a")) {
    const auto v = n["a"].as<std::vector<double>>();
    a = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
    if (a.size() == 0 || (a.array() < 0).any()) n["a"].fail("expected a list of a_i >= 0");
  }
  s.model = std::make_unique<sh::GFunctionModel>(a);
  s.prior = sh::g_function_prior(static_cast<int>(a.size()));
  s.exact = sh::g_function_exact(a);
}

// model: simulator: the studied parameters and the global indices observed.
void parse_simulator_study(const Config& config, const ConfigNode& node, SensitivitySetup& s) {
  const ConfigNode params = node.require_child("parameters");
  const model::ParameterSpace& space = config.simulator.parameters;
  params.check_keys(space.names(), "parameter", "for model " + config.simulator.model);
  for (const auto& key : params.keys()) {
    s.prior.parameters.push_back(parse_range(params[key], space[space.index_or_throw(key)]));
  }
  if (s.prior.parameters.empty()) params.fail("no parameters to study");
  if (node.has("outputs") && node.has("model_outputs")) {
    node["model_outputs"].fail("give either outputs: (heart indices) or model_outputs: (named outputs of the model)");
  }
  const std::string key = node.has("model_outputs") ? "model_outputs" : node.has("outputs") ? "outputs" : "parameters";
  try {
    auto simulator = config.simulator.make();
    std::unique_ptr<observers::Observer> observer;
    if (node.has("model_outputs")) {  // any named output vector or element (observers/output_values.h)
      observer = std::make_unique<observers::OutputValues>(node["model_outputs"].as<std::vector<std::string>>(),
                                                           simulator->channels());
    } else {
      observers::GlobalIndicesOptions go;
      if (node.has("outputs")) go.indices = node["outputs"].as<std::vector<std::string>>();
      observer = std::make_unique<observers::GlobalIndices>(go, simulator->channels());
    }
    s.model = std::make_unique<estimation::SimulatorForwardModel>(*simulator, *observer, s.prior.names());
  } catch (const std::invalid_argument& e) {
    node[key].fail(e.what());
  }
}

void parse_methods(const ConfigNode& node, std::uint64_t seed, SensitivitySetup& s) {
  {
    const ConfigNode n = node["oat"];
    n.check_keys({"mode", "relative_change"});
    if (n.has("mode")) s.oat.mode = *sh::parse_oat_mode(n["mode"].as_choice({"relative", "range"}));
    s.oat.relative_change = n.optional_quantity("relative_change", "1", s.oat.relative_change);
    if (const std::string m = s.oat.validate(); !m.empty()) n.fail(m);
  }
  {
    const ConfigNode n = node["morris"];
    n.check_keys({"trajectories", "levels", "bootstrap", "confidence"});
    s.morris.seed = seed;
    s.morris.trajectories = n.optional<int>("trajectories", s.morris.trajectories);
    s.morris.levels = n.optional<int>("levels", s.morris.levels);
    s.morris.bootstrap_samples = n.optional<int>("bootstrap", s.morris.bootstrap_samples);
    s.morris.confidence = n.optional<double>("confidence", s.morris.confidence);
    if (const std::string m = s.morris.validate(); !m.empty()) n.fail(m);
  }
  const ConfigNode n = node["sobol"];
  n.check_keys({"N", "bootstrap", "confidence", "convergence_levels", "scrambling", "failure_policy",
                "second_order"});
  s.sobol.seed = seed;
  s.sobol.base_samples = n.optional<int>("N", s.sobol.base_samples);
  if (n.has("N") && (s.sobol.base_samples < 16 ||
                     !sh::is_power_of_two(static_cast<std::uint64_t>(s.sobol.base_samples)))) {
    n["N"].fail("expected a power of two >= 16 (the design runs N (p + 2) simulations)");
  }
  s.sobol.second_order = n.optional<bool>("second_order", s.sobol.second_order);
  s.sobol.bootstrap_samples = n.optional<int>("bootstrap", s.sobol.bootstrap_samples);
  s.sobol.confidence = n.optional<double>("confidence", s.sobol.confidence);
  s.sobol.convergence_levels = n.optional<int>("convergence_levels", s.sobol.convergence_levels);
  if (n.has("scrambling")) {
    s.sobol.scrambling = *sh::parse_scrambling(n["scrambling"].as_choice({"lms", "none"}));
  }
  if (n.has("failure_policy")) {
    s.sobol.failure_policy =
        *sh::parse_sobol_failure_policy(n["failure_policy"].as_choice({"stop", "impute-mean"}));
  }
  if (const std::string m = s.sobol.validate(s.prior.size()); !m.empty()) n.fail(m);
}

}  // namespace

const char* to_string(SensitivityMethod method) {
  return estimation::enum_to_string(kMethodNames, method);
}

int SensitivitySetup::runs() const {
  const int p = prior.size();
  switch (method) {
    case SensitivityMethod::kOat: return 2 * p + 1;
    case SensitivityMethod::kMorris: return morris.trajectories * (p + 1);
    case SensitivityMethod::kSobol:
      return static_cast<int>(sh::sobol_runs(p, sobol.base_samples, sobol.second_order));
  }
  return 0;
}

std::uint64_t SensitivitySetup::seed() const {
  return method == SensitivityMethod::kMorris ? morris.seed : sobol.seed;
}

const estimation::EnsembleOptions& SensitivitySetup::ensemble() const {
  switch (method) {
    case SensitivityMethod::kOat: return oat.ensemble;
    case SensitivityMethod::kMorris: return morris.ensemble;
    case SensitivityMethod::kSobol: break;
  }
  return sobol.ensemble;
}

void SensitivitySetup::set_ensemble(const estimation::EnsembleOptions& options) {
  oat.ensemble = morris.ensemble = sobol.ensemble = options;
}

SensitivitySetup parse_sensitivity(const Config& config) {
  const ConfigNode node = config.file.root().require_child("sensitivity");
  node.check_keys({"method", "model", "outputs", "model_outputs", "seed", "parameters", "ishigami", "g_function",
                   "oat", "morris", "sobol", "ensemble"});
  SensitivitySetup s;
  s.method = *estimation::enum_from_string(
      kMethodNames, node.require_child("method").as_choice({"oat", "morris", "sobol"}));
  if (node.has("model")) s.model_kind = node["model"].as_choice({"simulator", "ishigami", "g-function"});
  std::uint64_t seed = config.seed.value_or(1);
  if (node.has("seed")) {
    const int v = node["seed"].as<int>();
    if (v < 0) node["seed"].fail("expected a seed >= 0");
    seed = static_cast<std::uint64_t>(v);
  }
  if (s.model_kind == "simulator") {
    parse_simulator_study(config, node, s);
  } else {
    parse_test_function(node, s);
    if (node.has("parameters") || node.has("outputs") || node.has("model_outputs")) {
      node.fail("parameters and outputs are fixed for the test function '" + s.model_kind + "'");
    }
  }
  s.set_ensemble(parse_ensemble(node["ensemble"]));
  parse_methods(node, seed, s);
  // The design's size in 64 bits: a Sobol' N of 2^30 with 12 parameters is 1.5e10 runs, which
  // overflowed the int run count (issue: a Sobol' N so large that the sample count overflows).
  const std::int64_t p = s.prior.size();
  std::int64_t runs = 2 * p + 1;
  const char* key = nullptr;
  if (s.method == SensitivityMethod::kMorris) {
    runs = static_cast<std::int64_t>(s.morris.trajectories) * (p + 1);
    key = "trajectories";
  } else if (s.method == SensitivityMethod::kSobol) {
    runs = sh::sobol_runs(static_cast<int>(p), s.sobol.base_samples, s.sobol.second_order);
    key = "N";
  }
  constexpr std::int64_t kMaxRuns = 100'000'000;  // ~10 days of 1 s simulations on 100 cores
  if (runs > kMaxRuns) {
    const ConfigNode where = key ? node[to_string(s.method)][key] : node["method"];
    where.fail("the design would run " + std::to_string(runs) + " simulations, more than " +
               std::to_string(kMaxRuns) + "; choose a smaller " + (key ? key : "design"));
  }
  return s;
}

SensitivitySummary run_sensitivity_study(const SensitivitySetup& s) {
  switch (s.method) {
    case SensitivityMethod::kOat: return sh::run_oat(*s.model, s.prior, s.oat);
    case SensitivityMethod::kMorris: return sh::run_morris(*s.model, s.prior, s.morris);
    case SensitivityMethod::kSobol: break;
  }
  return sh::run_sobol(*s.model, s.prior, s.sobol);
}

const estimation::sensitivity::StudySummary& study_of(const SensitivitySummary& summary) {
  return std::visit([](const auto& s) -> const sh::StudySummary& { return s; }, summary);
}

}  // namespace sigmaheart::app
