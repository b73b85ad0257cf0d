#include "app/specificity_setup.h"

#include "estimation/enum_names.h"
#include "estimation/ut_calibration.h"

#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

namespace sigmaheart::app {

namespace {

namespace sp = estimation::specificity;

constexpr std::array<estimation::EnumName<SpecificityParallel>, 3> kParallelNames{{
    {SpecificityParallel::kAuto, "auto"},
    {SpecificityParallel::kCases, "cases"},
    {SpecificityParallel::kEnsemble, "ensemble"},
}};

constexpr std::array<estimation::EnumName<sp::PAdjust>, 2> kAdjustNames{{
    {sp::PAdjust::kHolm, "holm"},
    {sp::PAdjust::kBenjaminiHochberg, "benjamini-hochberg"},
}};

CaseEntry parse_case(const Config& config, const ConfigNode& node, const std::filesystem::path& base) {
  if (!node.is_map()) node.fail("expected a case {name: ..., file: ..., group: ...}");
  node.check_keys({"name", "file", "group", "truth", "description"});
  CaseEntry c;
  c.where = node.location();
  c.name = node.require<std::string>("name");
  c.group = node.require<std::string>("group");
  if (c.name.empty()) node["name"].fail("expected a non-empty case name");
  if (c.group.empty()) node["group"].fail("expected a non-empty group label");
  c.file = std::filesystem::absolute(input_file(node.require_child("file"),
                                                node.require<std::string>("file"), base,
                                                "observation file"))
               .lexically_normal();
  const ConfigNode truth = node["truth"];
  if (truth.defined()) {
    if (!truth.is_map()) truth.fail("expected a map of parameter name -> value");
    const auto& space = config.simulator.parameters;
    truth.check_keys(space.names(), "parameter", "for model " + config.simulator.model);
    for (const auto& key : truth.keys()) {
      c.truth[key] = truth[key].as_quantity(space[space.index_or_throw(key)].unit);
    }
  }
  return c;
}

// `cases:` as a list, or the path of a YAML file whose `cases:` is that list.
std::vector<CaseEntry> parse_cases(const Config& config) {
  const ConfigNode root = config.file.root();
  const ConfigNode given = root.require_child("cases");
  std::filesystem::path base = std::filesystem::path(config.file.file()).parent_path();
  // Never assign one ConfigNode to another: yaml-cpp's Node::operator= writes into the node it
  // refers to, so `list = <the other file's list>` replaced the config's `cases:` path by the list
  // itself and a second parse of the same config (validate runs two sections that read the cases)
  // resolved the files against the config's directory.
  std::optional<ConfigFile> listed;  // keeps the other file's tree alive while its nodes are read
  std::optional<ConfigNode> from_file;
  if (given.is_scalar()) {
    const std::filesystem::path path = input_file(given, given.as<std::string>(), base, "case list");
    listed = ConfigFile::load(path);
    base = path.parent_path();
    from_file.emplace(listed->root().require_child("cases"));
  }
  const ConfigNode& list = from_file ? *from_file : given;
  if (!list.is_sequence() || list.size() == 0) {
    list.fail("expected a list of cases [{name: ..., file: ..., group: ...}, ...] or the path of a "
              "YAML file with such a `cases:` list");
  }
  std::vector<CaseEntry> cases;
  std::set<std::string> seen;
  for (size_t i = 0; i < list.size(); ++i) {
    cases.push_back(parse_case(config, list[i], base));
    if (!seen.insert(cases.back().name).second) {
      list[i]["name"].fail("case name '" + cases.back().name + "' appears twice");
    }
  }
  return cases;
}

// The calibration problem's estimated parameters: names, SI units and prior means (the same for
// every case, one config).
void read_estimated_parameters(const CalibrationProblem& problem, SpecificitySetup& s) {
  s.prior_mean = problem.prior.nominal_theta();
  s.names = problem.prior.names();
  s.units = problem.prior.units();
}

// The one construction of a case's UtCalibration (see the header).
estimation::UtCalibration make_calibration(const CalibrationProblem& problem,
                                           estimation::ForwardModel& model,
                                           const estimation::UtOptions& options) {
  return estimation::UtCalibration(model, problem.prior, problem.observations, options);
}

}  // namespace

SpecificitySection parse_specificity_section(const Config& config) {
  SpecificitySection s;
  const ConfigNode node = config.file.root()["specificity"];
  node.check_keys({"groups", "lda_shrinkage", "adjust", "alpha", "min_cases_per_group",
                   "parallel", "threads"});
  if (node.has("groups")) {
    const auto g = node["groups"].as<std::vector<std::string>>();
    if (g.size() != 2 || g[0] == g[1]) node["groups"].fail("expected two different group labels [a, b]");
    s.group_a = g[0];
    s.group_b = g[1];
  }
  s.lda_shrinkage = node.optional<double>("lda_shrinkage", s.lda_shrinkage);
  if (!(s.lda_shrinkage >= 0.0 && s.lda_shrinkage <= 1.0)) node["lda_shrinkage"].fail("expected a value in [0, 1]");
  if (node.has("adjust")) {
    s.adjust = *estimation::enum_from_string(kAdjustNames,
                                             node["adjust"].as_choice({"holm", "benjamini-hochberg"}));
  }
  s.alpha = node.optional<double>("alpha", s.alpha);
  if (!(s.alpha > 0.0 && s.alpha < 1.0)) node["alpha"].fail("expected a level in (0, 1)");
  s.min_cases_per_group = node.optional<int>("min_cases_per_group", s.min_cases_per_group);
  if (s.min_cases_per_group < 2) node["min_cases_per_group"].fail("expected at least 2 (a sample variance)");
  if (node.has("parallel")) {
    s.parallel = *estimation::enum_from_string(
        kParallelNames, node["parallel"].as_choice({"auto", "cases", "ensemble"}));
  }
  s.threads = node.optional<int>("threads", 0);
  if (s.threads < 0) node["threads"].fail("expected a thread count >= 0 (0: all cores)");
  return s;
}

SpecificitySetup parse_specificity_setup(const Config& config) {
  SpecificitySetup s;
  s.cases = parse_cases(config);
  s.section = parse_specificity_section(config);
  const ConfigNode root = config.file.root();
  if (root["observations"].has("file")) {
    root["observations"]["file"].fail("a specificity study takes the observation files from `cases:`; "
                                      "remove observations.file");
  }
  std::set<std::string> groups;
  for (const auto& c : s.cases) groups.insert(c.group);
  if (s.section.group_a.empty() && groups.size() != 2) {
    root["cases"].fail("the cases have " + std::to_string(groups.size()) +
                       " group labels; name the two to compare in specificity.groups");
  }
  if (!s.section.group_a.empty()) {
    for (const auto& g : {s.section.group_a, s.section.group_b}) {
      if (!groups.count(g)) root["specificity"]["groups"].fail("no case has the group label '" + g + "'");
    }
  }
  for (const auto& c : s.cases) s.problems.push_back(parse_calibration_problem(config, c.file));
  const CalibrationProblem& first = s.problems.front();
  read_estimated_parameters(first, s);
  s.observation_names = first.observations.names;
  s.observation_si_units = first.observations.units;
  return s;
}

std::vector<sp::CohortCase> cohort_of(const SpecificitySetup& setup) {
  std::vector<sp::CohortCase> cohort;
  const auto p = static_cast<Eigen::Index>(setup.names.size());
  for (size_t i = 0; i < setup.cases.size(); ++i) {
    const auto& c = setup.cases[i];
    sp::CohortCase k{c.name, c.group, c.file.string(), {}};
    k.observations = static_cast<int>(setup.problems[i].observations.size());
    if (!c.truth.empty()) {
      k.truth = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::quiet_NaN());
      for (Eigen::Index j = 0; j < p; ++j) {
        const auto it = c.truth.find(setup.names[static_cast<size_t>(j)]);
        if (it != c.truth.end()) k.truth(j) = it->second;
      }
    }
    cohort.push_back(std::move(k));
  }
  return cohort;
}

std::string validate_case(const CalibrationProblem& problem, estimation::ForwardModel& model) {
  return make_calibration(problem, model, problem.options).validate();
}

sp::CaseCalibration calibrate_case(const CalibrationProblem& problem, estimation::ForwardModel& model,
                                   int threads, estimation::MemberCheckpoint* checkpoint,
                                   const std::string& scope) {
  const auto t0 = std::chrono::steady_clock::now();
  estimation::UtOptions options = problem.options;
  options.ensemble.threads = threads;
  options.ensemble.communicator = nullptr;  // a case runs on one rank (the cases are spread)
  options.ensemble.checkpoint = checkpoint;
  options.ensemble.checkpoint_scope = scope;
  if (threads == 1) options.ensemble.backend = estimation::Backend::kSerial;
  const estimation::UtSummary s = make_calibration(problem, model, options).run();
  sp::CaseCalibration out;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.termination = estimation::to_string(s.termination);
  out.message = s.message;
  out.iterations = static_cast<int>(s.iterations.size());
  out.simulations = s.simulations;
  out.observed = problem.observations.y;
  out.fitted = Eigen::VectorXd::Constant(problem.observations.size(), std::numeric_limits<double>::quiet_NaN());
  if (s.fit_after && s.fit_after->z.size() == problem.observations.size()) out.fitted = s.fit_after->z;
  if (!s.ok()) {
    out.status = model::Status::Error(model::StatusCode::kDiverged,
                                      "calibration ended early (" + out.termination + "): " + s.message);
    return out;
  }
  out.status = model::Status::Ok();
  out.mean = s.theta_of_eta_mean;
  out.sd = s.theta_std;
  return out;
}

}  // namespace sigmaheart::app
