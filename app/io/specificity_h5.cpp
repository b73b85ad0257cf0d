#include "app/io/specificity_h5.h"

#include "app/io/display.h"

#include <functional>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app::io {

namespace {

namespace sp = estimation::specificity;

const std::string kPerParameter = "see /parameters/units";

// The observations as shown: clinical units and the factor from SI.
struct ObservationDisplay {
  std::vector<std::string> units;
  Eigen::VectorXd factor;
};

ObservationDisplay observation_display(const SpecificitySetup& setup) {
  ObservationDisplay d;
  const size_t m = setup.observation_names.size();
  d.factor.resize(static_cast<Eigen::Index>(m));
  for (size_t k = 0; k < m; ++k) {
    const DisplayUnit u = quantity_display_unit(setup.observation_names[k], setup.observation_si_units[k]);
    d.units.push_back(u.unit);
    d.factor(static_cast<Eigen::Index>(k)) = u.from_si;
  }
  return d;
}

// The per-parameter statistics written as /statistics/<name>, with their unit.
struct StatisticColumn {
  const char* name;
  bool per_parameter_unit;  // SI unit of the parameter, else "1"
  std::function<double(const sp::ParameterSeparation&)> value;
};

const std::vector<StatisticColumn>& statistic_columns() {
  using S = sp::ParameterSeparation;
  static const std::vector<StatisticColumn> columns = {
      {"mean_a", true, [](const S& q) { return q.a.mean; }},
      {"sd_a", true, [](const S& q) { return q.a.sd; }},
      {"mean_b", true, [](const S& q) { return q.b.mean; }},
      {"sd_b", true, [](const S& q) { return q.b.sd; }},
      {"posterior_sd_a", true, [](const S& q) { return q.posterior_sd_a; }},
      {"posterior_sd_b", true, [](const S& q) { return q.posterior_sd_b; }},
      {"cohen_d", false, [](const S& q) { return q.effect.cohen_d; }},
      {"hedges_g", false, [](const S& q) { return q.effect.hedges_g; }},
      {"welch_t", false, [](const S& q) { return q.welch.t; }},
      {"welch_df", false, [](const S& q) { return q.welch.df; }},
      {"welch_p", false, [](const S& q) { return q.welch.p_value; }},
      {"posterior_welch_t", false, [](const S& q) { return q.posterior_welch.t; }},
      {"posterior_welch_df", false, [](const S& q) { return q.posterior_welch.df; }},
      {"posterior_welch_p", false, [](const S& q) { return q.posterior_welch.p_value; }},
      {"p_adjusted", false, [](const S& q) { return q.p_adjusted; }},
      {"different", false, [](const S& q) { return q.different ? 1.0 : 0.0; }},
      {"mann_whitney_u", false, [](const S& q) { return q.mann_whitney.U; }},
      {"mann_whitney_p", false, [](const S& q) { return q.mann_whitney.p_value; }},
      {"auc", false, [](const S& q) { return q.mann_whitney.auc; }},
      {"auc_se", false, [](const S& q) { return q.mann_whitney.auc_se; }},
  };
  return columns;
}

void write_cases(Hdf5Writer& h5, const SpecificitySetup& setup, const sp::SpecificitySummary& s) {
  const int n = static_cast<int>(s.cohort.size());
  const int m = static_cast<int>(setup.observation_names.size());
  const ObservationDisplay od = observation_display(setup);
  std::vector<std::string> names, groups, files, status, terminations;
  std::vector<std::int64_t> iterations, simulations;
  Eigen::VectorXd rel(n), seconds(n);
  Eigen::MatrixXd observed = Eigen::MatrixXd::Constant(n, m, NAN), fitted = observed;
  for (int i = 0; i < n; ++i) {
    const auto& c = s.cohort[static_cast<size_t>(i)];
    const auto& r = s.calibrations[static_cast<size_t>(i)];
    names.push_back(c.id);
    groups.push_back(c.group);
    files.push_back(c.source);
    status.push_back(s.case_status(i));
    terminations.push_back(r.termination);
    iterations.push_back(r.iterations);
    simulations.push_back(r.simulations);
    rel(i) = r.relative_error_percent(od.factor);
    seconds(i) = r.seconds;
    if (r.observed.size() == m) observed.row(i) = r.observed.cwiseProduct(od.factor).transpose();
    if (r.fitted.size() == m) fitted.row(i) = r.fitted.cwiseProduct(od.factor).transpose();
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
  h5.write_matrix("/cases/mean", s.means(), kPerParameter, names, setup.names);
  h5.set_attribute("/cases/mean", "description", "posterior point estimate T(eta mean); NaN for failed cases");
  h5.write_matrix("/cases/std", s.sds(), kPerParameter, names, setup.names);
  h5.set_attribute("/cases/std", "description", "posterior standard deviation (delta method)");
  if (s.any_truth()) h5.write_matrix("/cases/truth", s.truths(), kPerParameter, names, setup.names);
  h5.write_strings("/cases/observation_names", setup.observation_names);
  h5.write_strings("/cases/observation_units", od.units);
  h5.write_matrix("/cases/observed", observed, "see /cases/observation_units", names, setup.observation_names);
  h5.write_matrix("/cases/fitted", fitted, "see /cases/observation_units", names, setup.observation_names);
}

void write_statistics(Hdf5Writer& h5, const SpecificitySetup& setup, const sp::SpecificitySummary& s) {
  h5.create_group("/statistics");
  h5.set_attribute("/statistics", "valid", s.ok() ? 1 : 0);
  h5.set_attribute("/statistics", "message", s.message);
  if (!s.ok()) return;
  h5.set_attribute("/statistics", "group_a", s.group_a);
  h5.set_attribute("/statistics", "group_b", s.group_b);
  h5.set_attribute("/statistics", "tests",
                   "every difference b - a; Welch t (two-sided) on the posterior means; posterior Welch: "
                   "each case's posterior variance added to the between-case variance (the primary test), "
                   "p_adjusted its p over the parameters; Mann-Whitney U (exact without ties for n <= 40, "
                   "else normal with tie correction); AUC = U / (n_a n_b) = P(b > a)");
  h5.set_attribute("/statistics", "adjust", sp::to_string(s.adjust));
  h5.set_attribute("/statistics", "alpha", s.alpha);
  std::vector<std::string> directions;
  for (const auto& q : s.parameters) directions.push_back(q.direction);
  h5.write_strings("/statistics/direction", directions);
  h5.set_attribute("/statistics/direction", "description", "group b higher, lower or none against group a (AUC vs 0.5)");
  const auto p = static_cast<Eigen::Index>(s.parameters.size());
  for (const StatisticColumn& c : statistic_columns()) {
    Eigen::VectorXd v(p);
    for (Eigen::Index j = 0; j < p; ++j) v(j) = c.value(s.parameters[static_cast<size_t>(j)]);
    h5.write_vector(std::string("/statistics/") + c.name, v, c.per_parameter_unit ? kPerParameter : "1");
  }
  std::vector<std::string> ranked;
  for (int j : s.ranking) ranked.push_back(setup.names[static_cast<size_t>(j)]);
  h5.write_strings("/statistics/ranking", ranked);
  h5.set_attribute("/statistics/ranking", "description", "by increasing posterior Welch p, ties by decreasing |AUC - 0.5|");

  const auto& cl = s.classifier;
  h5.create_group("/classifier");
  h5.set_attribute("/classifier", "method",
                   "leave-one-out linear discriminant on standardised posterior means, pooled "
                   "covariance shrunk towards its diagonal (Friedman 1989)");
  h5.set_attribute("/classifier", "shrinkage", setup.section.lda_shrinkage);
  h5.set_attribute("/classifier", "valid", cl.valid ? 1 : 0);
  h5.set_attribute("/classifier", "message", cl.message);
  h5.set_attribute("/classifier", "correct", cl.correct);
  h5.set_attribute("/classifier", "total", cl.total);
  h5.set_attribute("/classifier", "accuracy", cl.accuracy);
  if (cl.valid) {
    std::vector<std::string> cn;
    for (const auto& c : s.cases) cn.push_back(c.id);
    h5.write_strings("/classifier/cases", cn);
    h5.write_strings("/classifier/predicted", cl.predicted);
  }
}

// Names and status texts of the cases whose calibration failed, in cohort order.
std::pair<std::vector<std::string>, std::vector<std::string>> failed_cases(const sp::SpecificitySummary& s) {
  std::vector<std::string> names, messages;
  for (int i = 0; i < static_cast<int>(s.cohort.size()); ++i) {
    if (s.case_ok(i)) continue;
    names.push_back(s.cohort[static_cast<size_t>(i)].id);
    messages.push_back(s.case_status(i));
  }
  return {names, messages};
}

const char* parallel_name(const SpecificityRun& run) { return run.by_case ? "cases" : "ensemble"; }

}  // namespace

void write_specificity_h5(Hdf5Writer& h5, const SpecificitySetup& setup,
                          const sp::SpecificitySummary& summary, const SpecificityRun& run) {
  h5.write_strings("/parameters/names", setup.names);
  h5.write_strings("/parameters/units", setup.units);
  h5.write_vector("/parameters/prior_mean", setup.prior_mean, kPerParameter);
  write_cases(h5, setup, summary);
  write_statistics(h5, setup, summary);
  const auto [names, messages] = failed_cases(summary);
  h5.create_group("/failed");
  h5.set_attribute("/failed", "count", static_cast<int>(names.size()));
  if (!names.empty()) {
    h5.write_strings("/failed/names", names);
    h5.write_strings("/failed/messages", messages);
  }
  h5.create_group("/summary");
  h5.set_attribute("/summary", "wall_seconds", run.wall_seconds);
  h5.set_attribute("/summary", "parallel", parallel_name(run));
  h5.set_attribute("/summary", "status", sp::to_string(summary.status));
  h5.set_attribute("/summary", "message", summary.message);
}

nlohmann::ordered_json specificity_json(const std::string& name, const SpecificitySetup& setup,
                                        const sp::SpecificitySummary& s, const SpecificityRun& run,
                                        const std::string& results_file, const Provenance& provenance) {
  nlohmann::ordered_json j;
  j["kind"] = "specificity";
  j["name"] = name;
  j["wall_seconds"] = run.wall_seconds;
  j["threads"] = run.threads;
  j["parallel"] = parallel_name(run);
  j["parameters"] = setup.names;
  j["units"] = setup.units;
  const Eigen::MatrixXd mean = s.means(), sd = s.sds(), truth = s.truths();
  const ObservationDisplay od = observation_display(setup);
  const int p = static_cast<int>(setup.names.size());
  for (int i = 0; i < static_cast<int>(s.cohort.size()); ++i) {
    const auto& c = s.cohort[static_cast<size_t>(i)];
    const auto& r = s.calibrations[static_cast<size_t>(i)];
    nlohmann::ordered_json jc;
    jc["name"] = c.id;
    jc["group"] = c.group;
    jc["file"] = c.source;
    jc["status"] = s.case_status(i);
    jc["termination"] = r.termination;
    jc["iterations"] = r.iterations;
    jc["simulations"] = r.simulations;
    jc["relative_error_percent"] = r.relative_error_percent(od.factor);
    for (int k = 0; k < p; ++k) {
      auto& je = jc["estimate"][setup.names[static_cast<size_t>(k)]];
      je = {{"value", mean(i, k)}, {"std", sd(i, k)}};
      if (!std::isnan(truth(i, k))) je["truth"] = truth(i, k);
    }
    j["cases"].push_back(jc);
  }
  j["failed_cases"] = failed_cases(s).first;
  j["valid"] = s.ok();
  j["status"] = sp::to_string(s.status);
  j["message"] = s.message;
  if (s.ok()) {
    j["group_a"] = s.group_a;
    j["group_b"] = s.group_b;
    j["adjust"] = sp::to_string(s.adjust);
    j["alpha"] = s.alpha;
    for (int k : s.ranking) {
      const auto& q = s.parameters[static_cast<size_t>(k)];
      j["ranking"].push_back(q.name);
      j["statistics"][q.name] = {{"unit", setup.units[static_cast<size_t>(k)]},
                                 {"mean_a", q.a.mean}, {"sd_a", q.a.sd}, {"n_a", q.a.n},
                                 {"mean_b", q.b.mean}, {"sd_b", q.b.sd}, {"n_b", q.b.n},
                                 {"posterior_sd_a", q.posterior_sd_a}, {"posterior_sd_b", q.posterior_sd_b},
                                 {"cohen_d", q.effect.cohen_d}, {"hedges_g", q.effect.hedges_g},
                                 {"welch_t", q.welch.t}, {"welch_df", q.welch.df}, {"welch_p", q.welch.p_value},
                                 {"posterior_welch_t", q.posterior_welch.t},
                                 {"posterior_welch_df", q.posterior_welch.df},
                                 {"posterior_welch_p", q.posterior_welch.p_value},
                                 {"p_adjusted", q.p_adjusted}, {"different", q.different},
                                 {"direction", q.direction},
                                 {"mann_whitney_u", q.mann_whitney.U}, {"mann_whitney_p", q.mann_whitney.p_value},
                                 {"mann_whitney_exact", q.mann_whitney.exact},
                                 {"auc", q.mann_whitney.auc}, {"auc_se", q.mann_whitney.auc_se}};
    }
    j["classifier"] = {{"valid", s.classifier.valid}, {"accuracy", s.classifier.accuracy},
                       {"correct", s.classifier.correct}, {"total", s.classifier.total},
                       {"message", s.classifier.message}};
  }
  j["results_file"] = results_file;
  j["provenance"] = provenance_json(provenance);
  return j;
}

std::string specificity_report(const std::string& name, const SpecificitySetup& setup,
                               const sp::SpecificitySummary& s, const SpecificityRun& run) {
  auto fmt = [](double v, int significant = 4) { return format_number(v, significant); };
  const int n = static_cast<int>(s.cohort.size());
  const int p = static_cast<int>(setup.names.size());
  const Eigen::MatrixXd mean = s.means(), sd = s.sds();
  const ObservationDisplay od = observation_display(setup);
  std::ostringstream t;
  t << "Specificity study '" << name << "': " << n << " cases, " << p << " parameters, "
    << fmt(run.wall_seconds, 3) << " s wall (" << run.threads << " threads over "
    << (run.by_case ? "cases" : "ensembles") << ")\n";
  t << std::left << std::setw(14) << "case" << std::setw(10) << "group";
  for (const auto& nm : setup.names) t << std::right << std::setw(22) << nm;
  t << std::setw(11) << "fit err" << "  calibration\n";
  for (int i = 0; i < n; ++i) {
    const auto& c = s.cohort[static_cast<size_t>(i)];
    const auto& r = s.calibrations[static_cast<size_t>(i)];
    t << std::left << std::setw(14) << c.id << std::setw(10) << c.group << std::right;
    for (int j = 0; j < p; ++j) t << std::setw(22) << (fmt(mean(i, j), 3) + " +- " + fmt(sd(i, j), 2));
    t << std::setw(9) << fmt(r.relative_error_percent(od.factor), 2) << " %  " << r.termination << " ("
      << r.iterations << " it, " << r.simulations << " runs)\n";
  }
  t << "units:";
  for (int j = 0; j < p; ++j) t << " " << setup.names[static_cast<size_t>(j)] << " [" << setup.units[static_cast<size_t>(j)] << "]";
  t << "\n";
  const auto [failed_names, failed_messages] = failed_cases(s);
  for (size_t k = 0; k < failed_names.size(); ++k) t << "FAILED " << failed_names[k] << ": " << failed_messages[k] << "\n";
  if (!s.ok()) {
    t << "no statistics: " << s.message << "\n";
    return t.str();
  }
  t << "\n" << s.group_b << " against " << s.group_a << " (B - A), parameters by evidence; p of the Welch test "
    << "with each case's posterior variance, adjusted by " << sp::to_string(s.adjust) << ", different at "
    << fmt(s.alpha, 3) << ":\n";
  t << std::left << std::setw(10) << "parameter" << std::right << std::setw(24) << ("A: " + s.group_a)
    << std::setw(24) << ("B: " + s.group_b) << std::setw(9) << "g" << std::setw(11) << "Welch p" << std::setw(11)
    << "post. p" << std::setw(11) << "adj. p" << std::setw(11) << "U p" << std::setw(11) << "AUC(B>A)"
    << std::setw(20) << "posterior sd A/B" << "  B vs A\n";
  for (int j : s.ranking) {
    const auto& q = s.parameters[static_cast<size_t>(j)];
    t << std::left << std::setw(10) << q.name << std::right << std::setw(24)
      << (fmt(q.a.mean) + " +- " + fmt(q.a.sd, 2)) << std::setw(24) << (fmt(q.b.mean) + " +- " + fmt(q.b.sd, 2))
      << std::setw(9) << fmt(q.effect.hedges_g, 3) << std::setw(11) << fmt(q.welch.p_value, 2)
      << std::setw(11) << fmt(q.posterior_welch.p_value, 2) << std::setw(11) << fmt(q.p_adjusted, 2)
      << std::setw(11) << fmt(q.mann_whitney.p_value, 2) << std::setw(11) << fmt(q.mann_whitney.auc, 2)
      << std::setw(20) << (fmt(q.posterior_sd_a, 2) + " / " + fmt(q.posterior_sd_b, 2)) << "  "
      << (q.different ? q.direction + " (different)" : "not different") << " [" << setup.units[static_cast<size_t>(j)]
      << "]\n";
  }
  if (s.classifier.valid) {
    t << "leave-one-out LDA accuracy " << fmt(100.0 * s.classifier.accuracy, 3) << " % ("
      << s.classifier.correct << "/" << s.classifier.total << ")\n";
  } else {
    t << "classifier: " << s.classifier.message << "\n";
  }
  return t.str();
}

}  // namespace sigmaheart::app::io
