// `sigmaheart specificity CONFIG`: calibrate every case of a cohort with one calibration set-up,
// then ask which parameters separate two groups (ESTIMATION.md s.7; estimation/specificity).
//
//   cases:                              # or: cases: data/cohort.yaml (a file with a `cases:` list)
//     - {name: volunteer01, file: data/volunteer01.csv, group: healthy}
//     - {name: failing01, file: data/failing01.csv, group: failing,
//        truth: {sigma0: 4.5e4, c2: 300}}   # optional: known values (synthetic cohorts); those of
//                                             # estimated parameters are reported beside the estimates
//   observations: {indices: [EDV, ESV, EF, P_max], noise: {...}}   # as `calibrate`, without file:
//   estimate: {sigma0: {spread: 30 %}, ...}                          # as `calibrate`
//   calibration: {mode: iterate-keep-spread, max_iterations: 8}      # as `calibrate`
//   specificity:
//     groups: [healthy, failing]   # group a, group b; default: the two labels in order of appearance
//     lda_shrinkage: 0.2           # leave-one-out LDA, pooled covariance shrunk to its diagonal
//     parallel: auto               # cases | ensemble | auto
//     threads: 0                   # 0: all cores
//
// Paths in `cases` are relative to the file that lists them. Every case is parsed (its observation
// file read, its indices computed) before any calibration runs, so bad input is reported up front
// (exit 2, file:line:column).
//
// Parallelism: `cases` calibrates that many cases at once, each with a serial ensemble; `ensemble`
// calibrates the cases in order, each with a threaded ensemble; `auto` takes `cases` when the
// cohort has at least twice as many cases as threads. A UT iteration is p + 1 simplex members plus
// one serial centre run, so on 2 threads a threaded ensemble of a 5-parameter calibration keeps
// both threads busy only 6/7 of the time, while whole cases keep them busy until the last one.
// The numbers do not depend on the choice (each case runs on its own clones).
//
// Results: results/<config>-specificity.h5 (or -o), kind "specificity":
//   /parameters/{names, units}
//   /cases/{names, groups, files, status, termination}, /cases/{mean, std, truth} (case x
//     parameter, SI), /cases/{iterations, simulations}, /cases/relative_error [%],
//     /cases/observed, /cases/fitted (case x observation, clinical units, /cases/observation_units)
//   /statistics/{mean_a, sd_a, mean_b, sd_b, posterior_sd_a, posterior_sd_b} (SI),
//     {cohen_d, hedges_g, welch_t, welch_df, welch_p, mann_whitney_u, mann_whitney_p, auc, auc_se}
//     per parameter, /statistics/ranking (names, most separating first); attributes group_a, group_b
//   /classifier (attributes valid, accuracy, correct, total, shrinkage, message), /classifier/predicted
//   /failed/{names, messages}
// Exit codes: 0 done (cases whose calibration failed are dropped, listed and warned about);
// 2 bad input; 1 when the statistics cannot be computed (fewer than 2 calibrated cases in a group).
#include "app/calibration_setup.h"
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/results.h"
#include "app/progress.h"
#include "estimation/forward_model.h"
#include "estimation/specificity/specificity.h"
#include "estimation/ut_calibration.h"
#include "model/units.h"

#include <nlohmann/json.hpp>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

namespace sigmaheart::app {

namespace {

namespace sp = estimation::specificity;

// One entry of `cases:`.
struct CaseEntry {
  std::string name;
  std::string group;
  std::filesystem::path file;             // absolute or relative to the working directory
  std::map<std::string, double> truth;    // parameter -> value (SI), when known
  Location where;
};

enum class Parallel { kAuto, kCases, kEnsemble };

struct SpecificitySection {
  std::string group_a, group_b;
  double lda_shrinkage = 0.2;
  Parallel parallel = Parallel::kAuto;
  int threads = 0;
};

CaseEntry parse_case(const Config& config, const ConfigNode& node, const std::filesystem::path& base) {
  if (!node.is_map()) node.fail("expected a case {name: ..., file: ..., group: ...}");
  node.check_keys({"name", "file", "group", "truth", "description"});
  CaseEntry c;
  c.where = node.location();
  c.name = node.require<std::string>("name");
  c.group = node.require<std::string>("group");
  if (c.name.empty()) node["name"].fail("expected a non-empty case name");
  if (c.group.empty()) node["group"].fail("expected a non-empty group label");
  c.file = node.require<std::string>("file");
  if (c.file.is_relative()) c.file = base / c.file;
  c.file = std::filesystem::absolute(c.file).lexically_normal();
  if (!std::filesystem::exists(c.file)) {
    node["file"].fail("observation file '" + c.file.string() +
                      "' does not exist (paths are relative to the file that lists the cases)");
  }
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
  ConfigNode list = root.require_child("cases");
  std::filesystem::path base = std::filesystem::path(config.file.file()).parent_path();
  std::optional<ConfigFile> listed;  // keeps the other file's tree alive while its nodes are read
  if (list.is_scalar()) {
    std::filesystem::path path = list.as<std::string>();
    if (path.is_relative()) path = base / path;
    if (!std::filesystem::exists(path)) list.fail("case list '" + path.string() + "' does not exist");
    listed = ConfigFile::load(path);
    base = path.parent_path();
    list = listed->root().require_child("cases");
  }
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

SpecificitySection parse_specificity_section(const Config& config) {
  SpecificitySection s;
  const ConfigNode node = config.file.root()["specificity"];
  node.check_keys({"groups", "lda_shrinkage", "parallel", "threads"});
  if (node.has("groups")) {
    const auto g = node["groups"].as<std::vector<std::string>>();
    if (g.size() != 2 || g[0] == g[1]) node["groups"].fail("expected two different group labels [a, b]");
    s.group_a = g[0];
    s.group_b = g[1];
  }
  s.lda_shrinkage = node.optional<double>("lda_shrinkage", s.lda_shrinkage);
  if (!(s.lda_shrinkage >= 0.0 && s.lda_shrinkage <= 1.0)) node["lda_shrinkage"].fail("expected a value in [0, 1]");
  if (node.has("parallel")) {
    const std::string p = node["parallel"].as_choice({"auto", "cases", "ensemble"});
    s.parallel = p == "cases" ? Parallel::kCases : p == "ensemble" ? Parallel::kEnsemble : Parallel::kAuto;
  }
  s.threads = node.optional<int>("threads", 0);
  if (s.threads < 0) node["threads"].fail("expected a thread count >= 0 (0: all cores)");
  return s;
}

// Everything the study needs, parsed and checked before any calibration runs.
struct SpecificitySetup {
  std::vector<CaseEntry> cases;
  std::vector<CalibrationProblem> problems;  // one per case
  SpecificitySection section;
  std::vector<std::string> names, units;     // estimated parameters
};

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
  for (const auto& c : s.cases) {
    s.problems.push_back(parse_calibration_problem(config, c.file));
    const auto& p = s.problems.back();
    if (s.names.empty()) {
      for (const auto& cp : p.parameters) s.names.push_back(cp.name);
      s.units = p.parameter_units;
    }
  }
  return s;
}

struct SpecificityCommandOptions {
  std::filesystem::path config;
  std::filesystem::path output;
  std::filesystem::path summary;
  int threads = 0;
  std::vector<std::string> overrides;
};

// Per-case record of what the calibration did (filled by the calibrate callable, one slot per case).
struct CaseRecord {
  std::string termination = "not run";
  std::string message;
  int iterations = 0;
  int simulations = 0;
  double seconds = 0.0;
  Eigen::VectorXd observed, fitted;  // display units
  double relative_error = NAN;       // mean |fitted - observed| / |observed| [%]
  bool ok = false;                   // the calibration ended usably (completed, converged, max iterations)
  Eigen::VectorXd mean, sd;          // posterior (SI) when ok
};

// Display unit and factor of each observation (clinical; EF in %, durations in ms).
std::pair<std::vector<std::string>, Eigen::VectorXd> observation_units(const observers::ObservationSet& obs) {
  std::vector<std::string> units;
  Eigen::VectorXd f(obs.size());
  for (int i = 0; i < obs.size(); ++i) {
    const auto& si = obs.units[static_cast<size_t>(i)];
    io::DisplayUnit u = io::display_unit(si);
    if (obs.names[static_cast<size_t>(i)] == "EF" && si == "1") u = {"%", 100.0};
    if (si == "s") u = {"ms", 1000.0};
    units.push_back(u.unit);
    f(i) = u.from_si;
  }
  return {units, f};
}

std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

int run_specificity_command(const SpecificityCommandOptions& o, CommandContext& ctx) {
  io::Provenance prov;
  prov.start_utc = io::utc_now();
  const auto wall_start = std::chrono::steady_clock::now();
  const Config config = load_config(o.config, o.overrides, *ctx.models);
  SpecificitySetup setup = parse_specificity_setup(config);
  const std::filesystem::path output =
      !o.output.empty() ? o.output : default_output_path(o.config, "specificity");
  const int n = static_cast<int>(setup.cases.size());
  const int p = static_cast<int>(setup.names.size());

  const int threads = o.threads > 0 ? o.threads : setup.section.threads > 0 ? setup.section.threads
                                                                             : omp_get_max_threads();
  bool by_case = setup.section.parallel == Parallel::kCases ||
                 (setup.section.parallel == Parallel::kAuto && n >= 2 * threads);
  if (threads == 1) by_case = false;

  std::vector<std::unique_ptr<model::Simulator>> simulators;
  std::vector<std::unique_ptr<estimation::SimulatorForwardModel>> forwards;
  for (int i = 0; i < n; ++i) {
    simulators.push_back(config.simulator.make());
    forwards.push_back(std::make_unique<estimation::SimulatorForwardModel>(
        *simulators.back(), *setup.problems[static_cast<size_t>(i)].observer, setup.names));
  }
  // Validate every calibration before running any.
  for (int i = 0; i < n; ++i) {
    auto& pr = setup.problems[static_cast<size_t>(i)];
    estimation::UtCalibration check(*forwards[static_cast<size_t>(i)], pr.parameters, pr.observations, pr.options);
    if (const std::string m = check.validate(); !m.empty()) {
      throw InputError(setup.cases[static_cast<size_t>(i)].where,
                       "case '" + setup.cases[static_cast<size_t>(i)].name + "': " + m);
    }
  }

  std::vector<sp::CohortCase> cohort;
  std::map<std::string, int> index_of;
  for (int i = 0; i < n; ++i) {
    const auto& c = setup.cases[static_cast<size_t>(i)];
    cohort.push_back({c.name, c.group, c.file.string()});
    index_of[c.name] = i;
  }
  std::vector<CaseRecord> records(static_cast<size_t>(n));

  spdlog::info("specificity study '{}': {} cases, {} parameters ({}), {} threads over {}",
               config.name, n, p, [&] {
                 std::string s;
                 for (const auto& x : setup.names) s += (s.empty() ? "" : ", ") + x;
                 return s;
               }(), threads, by_case ? "cases" : "each case's ensemble");

  ProgressLine line(ctx.err, "specificity");
  line.start("calibrating cases", n);
  std::mutex log_mutex;

  sp::CalibrateFn calibrate = [&](const sp::CohortCase& c) -> sp::CaseCalibration {
    const int i = index_of.at(c.id);
    CalibrationProblem& pr = setup.problems[static_cast<size_t>(i)];
    CaseRecord& rec = records[static_cast<size_t>(i)];
    const auto t0 = std::chrono::steady_clock::now();
    estimation::UtOptions options = pr.options;
    if (by_case) {
      options.ensemble.backend = estimation::Backend::kSerial;
      options.ensemble.threads = 1;
    } else {
      options.ensemble.threads = threads;
      if (threads == 1) options.ensemble.backend = estimation::Backend::kSerial;
    }
    estimation::UtCalibration cal(*forwards[static_cast<size_t>(i)], pr.parameters, pr.observations, options);
    const estimation::UtSummary s = cal.run();
    rec.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rec.termination = estimation::to_string(s.termination);
    rec.message = s.message;
    rec.iterations = static_cast<int>(s.iterations.size());
    rec.simulations = s.simulations;
    const auto [units, factor] = observation_units(pr.observations);
    (void)units;
    rec.observed = pr.observations.y.cwiseProduct(factor);
    rec.fitted = Eigen::VectorXd::Constant(pr.observations.size(), NAN);
    if (s.fit_after && s.fit_after->z.size() == pr.observations.size()) {
      rec.fitted = s.fit_after->z.cwiseProduct(factor);
      rec.relative_error = 100.0 * ((rec.fitted - rec.observed).cwiseAbs().array() /
                                    rec.observed.cwiseAbs().array().max(1e-300)).mean();
    }
    {
      std::lock_guard<std::mutex> lock(log_mutex);
      spdlog::debug("case {}: {} ({} iterations, {} runs, {:.1f} s)", c.id, rec.termination,
                    rec.iterations, rec.simulations, rec.seconds);
    }
    rec.ok = s.ok();
    if (rec.ok) {
      rec.mean = s.theta_of_eta_mean;
      rec.sd = s.theta_std;
    }
    sp::CaseCalibration out;
    if (!s.ok()) {
      out.status = model::Status::Error(model::StatusCode::kDiverged,
                                        "calibration ended early (" + rec.termination + "): " + s.message);
      return out;
    }
    out.status = model::Status::Ok();
    out.mean = s.theta_of_eta_mean;
    out.sd = s.theta_std;
    return out;
  };

  sp::SpecificityOptions so;
  so.parameters = setup.names;
  so.group_a = setup.section.group_a;
  so.group_b = setup.section.group_b;
  so.lda_shrinkage = setup.section.lda_shrinkage;
  so.case_threads = by_case ? threads : 1;
  so.progress = [&line](int done, int, const std::string&) { line.update(done); };

  sp::SpecificityResult result;
  std::string stats_failure;
  try {
    result = sp::run_specificity(cohort, calibrate, so);
  } catch (const std::invalid_argument& e) {
    stats_failure = e.what();
  }
  line.finish();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // Per-case tables in cohort order (failed cases have NaN rows).
  Eigen::MatrixXd mean = Eigen::MatrixXd::Constant(n, p, NAN), sd = mean, truth = mean;
  std::vector<std::string> status(static_cast<size_t>(n), "ok");
  // From the records, so that the estimates are reported even when the statistics cannot be made.
  std::vector<std::string> failed_names, failed_messages;
  for (int i = 0; i < n; ++i) {
    const auto& r = records[static_cast<size_t>(i)];
    if (r.ok && r.mean.size() == p) {
      mean.row(i) = r.mean.transpose();
      sd.row(i) = r.sd.transpose();
    } else {
      status[static_cast<size_t>(i)] = r.termination + ": " + r.message;
      failed_names.push_back(setup.cases[static_cast<size_t>(i)].name);
      failed_messages.push_back(status[static_cast<size_t>(i)]);
    }
  }
  bool any_truth = false;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < p; ++j) {
      const auto& t = setup.cases[static_cast<size_t>(i)].truth;
      const auto it = t.find(setup.names[static_cast<size_t>(j)]);
      if (it != t.end()) {
        truth(i, j) = it->second;
        any_truth = true;
      }
    }
  }
  if (stats_failure.empty() && result.cases.empty()) stats_failure = "no case was calibrated";
  const auto [obs_units, obs_factor] = observation_units(setup.problems.front().observations);
  (void)obs_factor;
  const auto& obs_names = setup.problems.front().observations.names;
  const int m = static_cast<int>(obs_names.size());

  fill_provenance(prov, config, ctx, "specificity", threads, 1);

  const std::string per = "see /parameters/units";
  {
    io::Hdf5Writer h5(output);
    h5.write_strings("/parameters/names", setup.names);
    h5.write_strings("/parameters/units", setup.units);
    {
      Eigen::VectorXd prior(p);
      for (int j = 0; j < p; ++j) prior(j) = setup.problems.front().parameters[static_cast<size_t>(j)].prior_mean;
      h5.write_vector("/parameters/prior_mean", prior, per);
    }
    std::vector<std::string> names, groups, files, terminations;
    std::vector<std::int64_t> iterations, simulations;
    Eigen::VectorXd rel(n), seconds(n);
    Eigen::MatrixXd observed = Eigen::MatrixXd::Constant(n, m, NAN), fitted = observed;
    for (int i = 0; i < n; ++i) {
      const auto& c = setup.cases[static_cast<size_t>(i)];
      const auto& r = records[static_cast<size_t>(i)];
      names.push_back(c.name);
      groups.push_back(c.group);
      files.push_back(c.file.string());
      terminations.push_back(r.termination);
      iterations.push_back(r.iterations);
      simulations.push_back(r.simulations);
      rel(i) = r.relative_error;
      seconds(i) = r.seconds;
      if (r.observed.size() == m) observed.row(i) = r.observed.transpose();
      if (r.fitted.size() == m) fitted.row(i) = r.fitted.transpose();
    }
    h5.write_strings("/cases/names", names);
    h5.write_strings("/cases/groups", groups);
    h5.write_strings("/cases/files", files);
    h5.write_strings("/cases/status", status);
    h5.write_strings("/cases/termination", terminations);
    h5.write_ints("/cases/iterations", iterations);
    h5.set_attribute("/cases/iterations", "units", "1");
    h5.write_ints("/cases/simulations", simulations);
    h5.set_attribute("/cases/simulations", "units", "1");
    h5.write_vector("/cases/relative_error", rel, "%");
    h5.set_attribute("/cases/relative_error", "description", "mean |fitted - observed| / |observed| over the observations");
    h5.write_vector("/cases/seconds", seconds, "s");
    h5.write_matrix("/cases/mean", mean, per, names, setup.names);
    h5.set_attribute("/cases/mean", "description", "posterior point estimate T(eta mean); NaN for failed cases");
    h5.write_matrix("/cases/std", sd, per, names, setup.names);
    h5.set_attribute("/cases/std", "description", "posterior standard deviation (delta method)");
    if (any_truth) h5.write_matrix("/cases/truth", truth, per, names, setup.names);
    h5.write_strings("/cases/observation_names", obs_names);
    h5.write_strings("/cases/observation_units", obs_units);
    h5.write_matrix("/cases/observed", observed, "see /cases/observation_units", names, obs_names);
    h5.write_matrix("/cases/fitted", fitted, "see /cases/observation_units", names, obs_names);

    h5.create_group("/statistics");
    h5.set_attribute("/statistics", "valid", stats_failure.empty() ? 1 : 0);
    h5.set_attribute("/statistics", "message", stats_failure);
    if (stats_failure.empty()) {
      h5.set_attribute("/statistics", "group_a", result.group_a);
      h5.set_attribute("/statistics", "group_b", result.group_b);
      h5.set_attribute("/statistics", "tests",
                       "Welch t (two-sided); Mann-Whitney U (exact without ties for n <= 40, else normal "
                       "with tie correction); AUC = U / (n_a n_b) = P(a > b); effect sizes a over b");
      Eigen::VectorXd ma(p), sa(p), mb(p), sb(p), pa(p), pb(p), d(p), g(p), t(p), df(p), pw(p), u(p), pu(p),
          auc(p), auc_se(p);
      for (int j = 0; j < p; ++j) {
        const auto& q = result.parameters[static_cast<size_t>(j)];
        ma(j) = q.a.mean;
        sa(j) = q.a.sd;
        mb(j) = q.b.mean;
        sb(j) = q.b.sd;
        pa(j) = q.posterior_sd_a;
        pb(j) = q.posterior_sd_b;
        d(j) = q.effect.cohen_d;
        g(j) = q.effect.hedges_g;
        t(j) = q.welch.t;
        df(j) = q.welch.df;
        pw(j) = q.welch.p_value;
        u(j) = q.mann_whitney.U;
        pu(j) = q.mann_whitney.p_value;
        auc(j) = q.mann_whitney.auc;
        auc_se(j) = q.mann_whitney.auc_se;
      }
      const std::string s = "/statistics/";
      h5.write_vector(s + "mean_a", ma, per);
      h5.write_vector(s + "sd_a", sa, per);
      h5.write_vector(s + "mean_b", mb, per);
      h5.write_vector(s + "sd_b", sb, per);
      h5.write_vector(s + "posterior_sd_a", pa, per);
      h5.write_vector(s + "posterior_sd_b", pb, per);
      h5.write_vector(s + "cohen_d", d, "1");
      h5.write_vector(s + "hedges_g", g, "1");
      h5.write_vector(s + "welch_t", t, "1");
      h5.write_vector(s + "welch_df", df, "1");
      h5.write_vector(s + "welch_p", pw, "1");
      h5.write_vector(s + "mann_whitney_u", u, "1");
      h5.write_vector(s + "mann_whitney_p", pu, "1");
      h5.write_vector(s + "auc", auc, "1");
      h5.write_vector(s + "auc_se", auc_se, "1");
      std::vector<std::string> ranked;
      for (int j : result.ranking) ranked.push_back(setup.names[static_cast<size_t>(j)]);
      h5.write_strings(s + "ranking", ranked);
      h5.set_attribute(s + "ranking", "description", "by decreasing |AUC - 0.5|, ties by Welch p");

      h5.create_group("/classifier");
      h5.set_attribute("/classifier", "method",
                       "leave-one-out linear discriminant on standardised posterior means, pooled "
                       "covariance shrunk towards its diagonal (Friedman 1989)");
      h5.set_attribute("/classifier", "shrinkage", setup.section.lda_shrinkage);
      h5.set_attribute("/classifier", "valid", result.classifier.valid ? 1 : 0);
      h5.set_attribute("/classifier", "message", result.classifier.message);
      h5.set_attribute("/classifier", "correct", result.classifier.correct);
      h5.set_attribute("/classifier", "total", result.classifier.total);
      h5.set_attribute("/classifier", "accuracy", result.classifier.accuracy);
      if (result.classifier.valid) {
        std::vector<std::string> cn;
        for (const auto& c : result.cases) cn.push_back(c.id);
        h5.write_strings("/classifier/cases", cn);
        h5.write_strings("/classifier/predicted", result.classifier.predicted);
      }
    }
    h5.create_group("/failed");
    h5.set_attribute("/failed", "count", static_cast<int>(failed_names.size()));
    if (!failed_names.empty()) {
      h5.write_strings("/failed/names", failed_names);
      h5.write_strings("/failed/messages", failed_messages);
    }
    h5.create_group("/summary");
    h5.set_attribute("/summary", "wall_seconds", wall);
    h5.set_attribute("/summary", "parallel", by_case ? "cases" : "ensemble");
    prov.end_utc = io::utc_now();
    io::write_provenance(h5, prov);
    h5.commit();
  }

  // Terminal report.
  std::ostringstream t;
  t << "Specificity study '" << config.name << "': " << n << " cases, " << p << " parameters, "
    << fmt(wall, 3) << " s wall (" << threads << " threads over " << (by_case ? "cases" : "ensembles") << ")\n";
  t << std::left << std::setw(14) << "case" << std::setw(10) << "group";
  for (const auto& nm : setup.names) t << std::right << std::setw(22) << nm;
  t << std::setw(11) << "fit err" << "  calibration\n";
  for (int i = 0; i < n; ++i) {
    const auto& c = setup.cases[static_cast<size_t>(i)];
    const auto& r = records[static_cast<size_t>(i)];
    t << std::left << std::setw(14) << c.name << std::setw(10) << c.group << std::right;
    for (int j = 0; j < p; ++j) {
      t << std::setw(22) << (fmt(mean(i, j), 3) + " +- " + fmt(sd(i, j), 2));
    }
    t << std::setw(9) << fmt(r.relative_error, 2) << " %  " << r.termination << " (" << r.iterations
      << " it, " << r.simulations << " runs)\n";
  }
  t << "units:";
  for (int j = 0; j < p; ++j) t << " " << setup.names[static_cast<size_t>(j)] << " [" << setup.units[static_cast<size_t>(j)] << "]";
  t << "\n";
  for (size_t k = 0; k < failed_names.size(); ++k) {
    t << "FAILED " << failed_names[k] << ": " << failed_messages[k] << "\n";
  }
  if (stats_failure.empty()) {
    t << "\n" << result.group_a << " vs " << result.group_b << ", parameters by separation:\n";
    t << std::left << std::setw(10) << "parameter" << std::right << std::setw(24) << result.group_a
      << std::setw(24) << result.group_b << std::setw(9) << "g" << std::setw(11) << "Welch p"
      << std::setw(11) << "U p" << std::setw(7) << "AUC" << std::setw(20) << "posterior sd a/b" << "\n";
    for (int j : result.ranking) {
      const auto& q = result.parameters[static_cast<size_t>(j)];
      t << std::left << std::setw(10) << q.name << std::right << std::setw(24)
        << (fmt(q.a.mean) + " +- " + fmt(q.a.sd, 2)) << std::setw(24) << (fmt(q.b.mean) + " +- " + fmt(q.b.sd, 2))
        << std::setw(9) << fmt(q.effect.hedges_g, 3) << std::setw(11) << fmt(q.welch.p_value, 2)
        << std::setw(11) << fmt(q.mann_whitney.p_value, 2) << std::setw(7) << fmt(q.mann_whitney.auc, 2)
        << std::setw(20) << (fmt(q.posterior_sd_a, 2) + " / " + fmt(q.posterior_sd_b, 2)) << "\n";
    }
    if (result.classifier.valid) {
      t << "leave-one-out LDA accuracy " << fmt(100.0 * result.classifier.accuracy, 3) << " % ("
        << result.classifier.correct << "/" << result.classifier.total << ")\n";
    } else {
      t << "classifier: " << result.classifier.message << "\n";
    }
  } else {
    t << "no statistics: " << stats_failure << "\n";
  }
  ctx.out << t.str() << "wrote " << output.string() << "\n";

  if (!o.summary.empty()) {
    nlohmann::ordered_json j;
    j["kind"] = "specificity";
    j["name"] = config.name;
    j["wall_seconds"] = wall;
    j["threads"] = threads;
    j["parallel"] = by_case ? "cases" : "ensemble";
    j["parameters"] = setup.names;
    j["units"] = setup.units;
    for (int i = 0; i < n; ++i) {
      const auto& c = setup.cases[static_cast<size_t>(i)];
      const auto& r = records[static_cast<size_t>(i)];
      nlohmann::ordered_json jc;
      jc["name"] = c.name;
      jc["group"] = c.group;
      jc["file"] = c.file.string();
      jc["status"] = status[static_cast<size_t>(i)];
      jc["termination"] = r.termination;
      jc["iterations"] = r.iterations;
      jc["simulations"] = r.simulations;
      jc["relative_error_percent"] = r.relative_error;
      for (int k = 0; k < p; ++k) {
        jc["estimate"][setup.names[static_cast<size_t>(k)]] = {{"value", mean(i, k)}, {"std", sd(i, k)}};
        if (!std::isnan(truth(i, k))) jc["estimate"][setup.names[static_cast<size_t>(k)]]["truth"] = truth(i, k);
      }
      j["cases"].push_back(jc);
    }
    j["failed_cases"] = failed_names;
    j["valid"] = stats_failure.empty();
    j["message"] = stats_failure;
    if (stats_failure.empty()) {
      j["group_a"] = result.group_a;
      j["group_b"] = result.group_b;
      for (int k : result.ranking) {
        const auto& q = result.parameters[static_cast<size_t>(k)];
        j["ranking"].push_back(q.name);
        j["statistics"][q.name] = {{"unit", setup.units[static_cast<size_t>(k)]},
                                   {"mean_a", q.a.mean}, {"sd_a", q.a.sd}, {"n_a", q.a.n},
                                   {"mean_b", q.b.mean}, {"sd_b", q.b.sd}, {"n_b", q.b.n},
                                   {"posterior_sd_a", q.posterior_sd_a}, {"posterior_sd_b", q.posterior_sd_b},
                                   {"cohen_d", q.effect.cohen_d}, {"hedges_g", q.effect.hedges_g},
                                   {"welch_t", q.welch.t}, {"welch_df", q.welch.df}, {"welch_p", q.welch.p_value},
                                   {"mann_whitney_u", q.mann_whitney.U}, {"mann_whitney_p", q.mann_whitney.p_value},
                                   {"mann_whitney_exact", q.mann_whitney.exact},
                                   {"auc", q.mann_whitney.auc}, {"auc_se", q.mann_whitney.auc_se}};
      }
      j["classifier"] = {{"valid", result.classifier.valid}, {"accuracy", result.classifier.accuracy},
                         {"correct", result.classifier.correct}, {"total", result.classifier.total},
                         {"message", result.classifier.message}};
    }
    j["results_file"] = output.string();
    io::write_text_file(o.summary, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
    ctx.out << "wrote " << o.summary.string() << "\n";
  }
  if (!failed_names.empty() && stats_failure.empty()) {
    spdlog::warn("{} of {} calibrations failed and were left out of the statistics (listed above and "
                 "in /failed)", failed_names.size(), n);
  }
  if (!stats_failure.empty()) {
    throw RunFailure("specificity study '" + config.name + "': " + stats_failure + "; per-case results in " +
                     output.string());
  }
  return kExitOk;
}

}  // namespace

void register_specificity(CLI::App& app, CommandContext& ctx) {
  register_calibration_sections();
  register_config_section({"cases", [](const Config& c) { parse_specificity_setup(c); }});
  register_config_section({"specificity", [](const Config& c) { parse_specificity_section(c); }});
  // A specificity config has observations: without file: (the cases give the files); check the
  // calibration sections with the first case's file then, as `calibrate` would for one case.
  register_config_section({"observations", [](const Config& c) {
                             if (c.file.root().has("cases")) {
                               parse_specificity_setup(c);
                             } else {
                               parse_calibration_problem(c);
                             }
                           }});
  auto opts = std::make_shared<SpecificityCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "specificity", "Calibrate a cohort and find the parameters that separate two groups");
  sub->add_option("config", opts->config,
                  "Config file (YAML) with cases:, observations:, estimate:, calibration: "
                  "(and optionally specificity:)")
      ->required();
  sub->add_option("-o,--output", opts->output, "Results file (HDF5); default results/<config>-specificity.h5");
  sub->add_option("--summary", opts->summary, "Also write the per-case estimates and the statistics as JSON");
  sub->add_option("--threads", opts->threads, "Threads (default: specificity.threads, else all cores)")
      ->check(CLI::PositiveNumber);
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx] { ctx.run = [opts, &ctx] { return run_specificity_command(*opts, ctx); }; });
}

}  // namespace sigmaheart::app
