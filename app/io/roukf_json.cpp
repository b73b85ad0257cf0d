// The JSON summary and the terminal table of `personalize` (declared in roukf_h5.h).
#include "app/io/atomic_file.h"
#include "app/io/display.h"
#include "app/io/roukf_h5.h"
#include "model/lumped/regional.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app::io {

namespace {

// "[lo, hi]", through a stream: GCC 12 warns falsely (-Wrestrict) on a chain of + here.
std::string interval(const std::string& lo, const std::string& hi) {
  std::ostringstream s;
  s << "[" << lo << ", " << hi << "]";
  return s.str();
}

// With a truth: how many parameters lie inside their +-2 std, against what a right spread gives
// (each with probability 0.954), and the joint check d2 = e^T P_eta^-1 e <= chi2_0.95(p)
// (RoukfSummary::truth_d2; docs/estimation.md s.4.5).
std::string truth_consistency_lines(const estimation::RoukfSummary& summary) {
  const Eigen::Index p = summary.truth_z.size();
  if (p == 0) return "";
  const double q = std::erf(2.0 / std::sqrt(2.0));  // P(|N(0,1)| <= 2) = 0.9545
  std::ostringstream t;
  t << "truth inside +-2 std: " << (summary.truth_z.array().abs() <= 2.0).count() << " of " << p
    << " (a right spread: " << format_number(p * q, 3) << " +- " << format_number(std::sqrt(p * q * (1 - q)), 2)
    << " expected; all " << p << " with probability " << format_number(std::pow(q, static_cast<double>(p)), 2)
    << ")";
  if (std::isfinite(summary.truth_d2)) {
    t << "\njoint: (eta - truth)^T P^-1 (eta - truth) = " << format_number(summary.truth_d2, 4)
      << (summary.truth_d2 <= summary.truth_d2_limit ? " <= " : " > ") << format_number(summary.truth_d2_limit, 4)
      << " = chi2_0.95(" << p << "): the truth is "
      << (summary.truth_d2 <= summary.truth_d2_limit ? "inside" : "OUTSIDE") << " the 95 % credible ellipsoid";
  }
  t << "\n";
  return t.str();
}

// Per channel at the estimate: chi-square per frame with the stated noise, its 95 % band and
// (with an estimated noise scale) the scale, as a std factor (docs/estimation.md s.4.8).
struct ChannelFit {
  double chi2_per_frame, lower, upper, scale;
  bool inside() const { return chi2_per_frame >= lower && chi2_per_frame <= upper; }
};
ChannelFit channel_fit(const estimation::RoukfSummary& summary, int c) {
  const int f = std::max(1, summary.channel_frames(c));
  return {summary.channel_chi2(c) / f, estimation::chi_square_quantile(f, 0.025) / f,
          estimation::chi_square_quantile(f, 0.975) / f,
          summary.noise_scale_mode.size() > c ? std::sqrt(summary.noise_scale_mode(c)) : std::nan("")};
}

bool informed(const estimation::RoukfSummary& summary, int j) {
  return !(summary.std_ratio.size() > j && summary.std_ratio(j) >= estimation::kUninformedStdRatio);
}

}  // namespace

void write_roukf_json(const std::filesystem::path& path, const std::string& name,
                      const RoukfResults& results, const Provenance& provenance) {
  const PersonalizeProblem& problem = *results.problem;
  const estimation::RoukfSummary& summary = *results.summary;
  const Eigen::VectorXd value = results.value(), std = results.std();
  const std::vector<std::string> units = problem.prior.units();
  const Eigen::MatrixXd& pass_error = summary.pass_error_percent;

  nlohmann::ordered_json j;
  j["kind"] = "personalize";
  j["name"] = name;
  j["termination"] = estimation::to_string(summary.termination);
  j["message"] = summary.message;
  j["steps"] = summary.steps.size();
  j["passes"] = summary.pass_fractions.empty() ? problem.filter.beats
                                               : static_cast<int>(summary.pass_fractions.size());
  j["pass_mode"] = estimation::to_string(problem.filter.pass_mode);
  if (!summary.pass_fractions.empty()) j["pass_fractions"] = summary.pass_fractions;
  j["members"] = summary.members;
  j["member_runs"] = summary.member_runs;
  j["retries"] = summary.retries;
  j["skipped_analyses"] = summary.skipped_analyses;
  // Filter consistency (RoukfSummary): time-averaged NIS [1] and its chi-square 95 % band.
  j["nis_mean"] = summary.nis_mean;
  j["nis_band_95"] = {summary.nis_band_lower, summary.nis_band_upper};
  j["nis_frames"] = summary.nis_frames;
  j["nis_source"] = summary.nis_source;
  j["nis_inside_band"] = summary.nis_mean >= summary.nis_band_lower && summary.nis_mean <= summary.nis_band_upper;
  if (summary.map_runs > 0) {
    // Gauss-Newton on the whole-data MAP objective after the split passes (docs/estimation.md s.4.7).
    j["map_refinement"] = {{"steps", summary.map_steps},
                           {"converged", summary.map_converged},
                           {"note", summary.map_note},
                           {"shift_filter_std", summary.map_shift_std},
                           {"last_step_std", summary.map_last_step_std},
                           {"objective_at_filter_estimate", summary.map_statistic_filter},
                           {"objective_at_estimate", summary.map_objective},
                           {"runs", summary.map_runs}};
    nlohmann::ordered_json history = nlohmann::ordered_json::array();
    for (const estimation::RoukfMapStep& r : summary.map_history) {
      history.push_back({{"objective", r.objective}, {"gauss_newton_std", r.gauss_newton_std},
                         {"step_std", r.step_std}, {"predicted", r.predicted}, {"actual", r.actual},
                         {"gain", r.gain}, {"damping", r.damping}, {"cos_previous", r.cos_previous},
                         {"rejected", r.rejected}, {"out_of_bounds", r.out_of_bounds},
                         {"accepted", r.accepted}, {"extrapolated", r.extrapolated}});
    }
    j["map_refinement"]["history"] = history;
  }
  if (summary.channel_chi2.size() == static_cast<Eigen::Index>(problem.data.channels.size())) {
    for (size_t c = 0; c < problem.data.channels.size(); ++c) {
      const ChannelFit f = channel_fit(summary, static_cast<int>(c));
      nlohmann::ordered_json e = {{"chi2_per_frame", f.chi2_per_frame},
                                  {"band_95", {f.lower, f.upper}},
                                  {"inside_band", f.inside()},
                                  {"frames", summary.channel_frames(static_cast<Eigen::Index>(c))}};
      if (std::isfinite(f.scale)) e["noise_scale"] = f.scale;
      j["channels"][problem.data.channels[c]] = e;
    }
  }
  j["setup"] = {{"align", problem.align_end_diastole ? "end-diastole" : "ecg"},
                {"period", problem.period},
                {"notes", problem.notes}};
  if (std::isfinite(problem.data_ed_time)) {
    j["setup"]["data_ed_time"] = problem.data_ed_time;
    j["setup"]["model_ed_time"] = problem.model_ed_time;
  }
  if (problem.volume_shares.size() > 0) {
    j["setup"]["volume_shares"] = std::vector<double>(problem.volume_shares.data(),
                                                     problem.volume_shares.data() + problem.volume_shares.size());
  }
  j["threads"] = results.threads;
  j["wall_seconds"] = summary.wall_seconds;
  for (size_t k = 0; k < summary.parameter_names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    nlohmann::ordered_json e = {{"value", value(i)},
                                {"std", std(i)},
                                {"unit", units[k]},
                                {"segment", problem.segments[k]},
                                {"prior", summary.theta_prior(i)},
                                {"prior_std", summary.theta_prior_std(i)}};
    if (summary.has_estimate()) {
      e["lower_2sigma"] = summary.theta_lower(i);
      e["upper_2sigma"] = summary.theta_upper(i);
    }
    if (summary.std_ratio.size() > i) {
      e["std_ratio"] = summary.std_ratio(i);
      e["informed"] = informed(summary, static_cast<int>(i));
    }
    if (problem.filter.truth) {
      e["truth"] = (*problem.filter.truth)(i);
      if (summary.error_percent.size() > i) e["error_percent"] = summary.error_percent(i);
      if (summary.truth_z.size() > i) e["truth_standardised_error"] = summary.truth_z(i);
    }
    j["parameters"][summary.parameter_names[k]] = e;
  }
  if (problem.filter.truth) {
    for (Eigen::Index b = 0; b < pass_error.rows(); ++b) {
      j["max_error_percent_per_pass"].push_back(pass_error.row(b).maxCoeff());
    }
    const int passes = summary.passes_to_within_10_percent;
    j["passes_to_within_10_percent"] = passes > 0 ? nlohmann::ordered_json(passes) : nullptr;
    if (summary.truth_z.size() > 0) {
      j["truth_inside_2std"] = (summary.truth_z.array().abs() <= 2.0).count();
      j["truth_mahalanobis_squared"] = summary.truth_d2;  // NaN is written as null
      j["truth_mahalanobis_squared_limit_95"] = summary.truth_d2_limit;
    }
  }
  j["provenance"] = provenance_json(provenance);
  write_text_file(path, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
}

std::string roukf_report(const RoukfResults& results) {
  const PersonalizeProblem& problem = *results.problem;
  const estimation::RoukfSummary& summary = *results.summary;
  const Eigen::VectorXd value = results.value();
  const Eigen::MatrixXd& pass_error = summary.pass_error_percent;
  const auto& truth = problem.filter.truth;
  const int p = static_cast<int>(summary.parameter_names.size());
  // Pa is shown as kPa in this table (contractilities read better so).
  auto shown = [&](int j, double v) { return problem.prior[j].unit == "Pa" ? v / 1e3 : v; };
  auto shown_unit = [&](int j) { return problem.prior[j].unit == "Pa" ? std::string("kPa") : problem.prior[j].unit; };
  const bool aha = problem.segments.size() == static_cast<size_t>(p) && p > 0;

  std::ostringstream t;
  t << summary.brief_report() << "\n\n"
    << std::left << std::setw(12) << "parameter" << std::setw(21) << "segment" << std::right
    << std::setw(9) << "prior" << std::setw(10) << "estimate" << std::setw(20) << "+-2 sigma";
  if (truth) t << std::setw(9) << "truth" << std::setw(8) << "error";
  t << "  unit\n";
  for (int j = 0; j < p; ++j) {
    const int seg = problem.segments[static_cast<size_t>(j)];
    const std::string where = seg == 0 ? "(global)"
                              : seg <= 17 && aha ? model::lumped::aha17_segment_names()[static_cast<size_t>(seg - 1)]
                                                 : "patch " + std::to_string(seg);
    const double lo = summary.has_estimate() ? summary.theta_lower(j) : std::nan("");
    const double hi = summary.has_estimate() ? summary.theta_upper(j) : std::nan("");
    t << std::left << std::setw(12) << summary.parameter_names[static_cast<size_t>(j)] << std::setw(21)
      << where << std::right << std::setw(9) << format_number(shown(j, summary.theta_prior(j)))
      << std::setw(10) << format_number(shown(j, value(j))) << std::setw(20)
      << interval(format_number(shown(j, lo), 3), format_number(shown(j, hi), 3));
    if (truth) {
      t << std::setw(9) << format_number(shown(j, (*truth)(j))) << std::setw(7)
        << (summary.error_percent.size() > j ? format_number(summary.error_percent(j), 2) : std::string("-")) << "%";
    }
    t << "  " << shown_unit(j) << (informed(summary, j) ? "" : "  (not informed by the data)") << "\n";
  }
  for (const std::string& note : problem.notes) t << "set-up: " << note << "\n";
  if (summary.channel_chi2.size() == static_cast<Eigen::Index>(problem.data.channels.size())) {
    // Which curves the model fits within the stated noise (docs/estimation.md s.4.8).
    t << "\nfit per channel at the estimate: chi2 per frame with the stated noise (95 % band)";
    if (summary.noise_scale_mode.size() > 0) t << ", estimated noise scale";
    t << "\n";
    for (size_t c = 0; c < problem.data.channels.size(); ++c) {
      const ChannelFit f = channel_fit(summary, static_cast<int>(c));
      t << "  " << std::left << std::setw(10) << problem.data.channels[c] << std::right << std::setw(10)
        << format_number(f.chi2_per_frame, 3) << "  " << interval(format_number(f.lower, 3), format_number(f.upper, 3))
        << (f.inside() ? "          " : (f.chi2_per_frame > f.upper ? "  misfit  " : "  below   "));
      if (std::isfinite(f.scale)) t << "  noise x " << format_number(f.scale, 3);
      t << "\n";
    }
  }
  // What a NIS outside its band means for the numbers above (docs/estimation.md s.4.5).
  if (std::isfinite(summary.nis_mean) && summary.nis_mean > summary.nis_band_upper) {
    t << "\nWARNING: the mean NIS " << format_number(summary.nis_mean, 4) << " is above its 95 % band "
      << format_number(summary.nis_band_lower, 4) << "-" << format_number(summary.nis_band_upper, 4)
      << ": the model does not explain the data within the stated noise (model-form error, or the noise is "
         "underestimated), so the +-2 sigma intervals are too narrow to be credible.\n";
  } else if (std::isfinite(summary.nis_mean) && summary.nis_mean < summary.nis_band_lower) {
    t << "\nnote: the mean NIS " << format_number(summary.nis_mean, 4) << " is below its 95 % band "
      << format_number(summary.nis_band_lower, 4) << "-" << format_number(summary.nis_band_upper, 4)
      << ": the residuals are smaller than the stated noise (the intervals are conservative).\n";
  }
  if (truth) {
    t << "\nmax | mean error over the parameters after each pass:";
    for (Eigen::Index b = 0; b < pass_error.rows(); ++b) {
      t << "  " << b + 1 << ": " << format_number(pass_error.row(b).maxCoeff(), 3) << " | "
        << format_number(pass_error.row(b).mean(), 3) << " %";
    }
    const int passes = summary.passes_to_within_10_percent;
    t << "\npasses until every parameter is within 10 % of the truth: "
      << (passes > 0 ? std::to_string(passes) : std::string("not reached")) << "\n";
    if (summary.map_runs > 0 && summary.error_percent.size() == p) {
      t << "after the MAP refinement: " << format_number(summary.error_percent.maxCoeff(), 3) << " | "
        << format_number(summary.error_percent.mean(), 3) << " %\n";
    }
    t << truth_consistency_lines(summary);
  }
  return t.str();
}

}  // namespace sigmaheart::app::io
