// Specificity study (docs/estimation.md s.7): calibrate every case of a cohort with the same
// configuration, then ask which parameters separate two groups (e.g. volunteers and heart-failure
// patients). Per parameter, group B against group A: group means and spreads, effect sizes, Welch's
// t test on the posterior means and with each case's posterior variance carried in (the primary
// test), its p-value adjusted over the parameters (Holm or Benjamini-Hochberg), the Mann-Whitney U
// test and the AUC of "B > A" with its direction; jointly: the leave-one-out accuracy of a shrunk
// linear discriminant.
//
// Exclusion policy: a case enters the statistics only when its calibration returned an ok status
// (for the UT calibration UtSummary::ok()) with finite estimates of the right size; every other case
// is listed with its status (failed_cases, failure_status) and left out. When fewer than
// SpecificityOptions::min_cases_per_group remain in either compared group there are no statistics
// (status kNoStatistics, which the command turns into exit 1 with the per-case results written).
// run_specificity returns a SpecificitySummary: every case's calibration record in cohort order
// and the statistics, or the status kNoStatistics when the groups are too small (not an exception).
//
// Read only parameters that are both sensitive (a sensitivity study) and well identified (small
// posterior spread, reported here per group as the mean posterior standard deviation).
#pragma once

#include "estimation/checkpoint.h"
#include "estimation/parallel/communicator.h"
#include "estimation/specificity/statistics.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

namespace sigmaheart::estimation::specificity {

// One case of a cohort: an identifier, its group label, and an opaque reference the calibration
// callable understands (e.g. the path of its observation file; this library never opens it).
struct CohortCase {
  std::string id;
  std::string group;
  std::string source;
  // Known parameter values (synthetic cohorts), in the order of SpecificityOptions::parameters;
  // NaN where unknown, empty when none is known. Reported beside the estimates.
  Eigen::VectorXd truth;
  // The length of the case's observation vector (sizes the rows in which calibrations are
  // gathered from threads and ranks; at least the size of what calibrate returns).
  int observations = 0;
};

// What a calibration returns for one case: posterior mean and standard deviation of each studied
// parameter (physical units, the order of SpecificityOptions::parameters), or a failed Status.
struct CaseCalibration {
  model::Status status;
  Eigen::VectorXd mean;
  Eigen::VectorXd sd;
  // What the calibration did, for the per-case report (optional for the statistics).
  std::string termination = "not run";
  std::string message;
  int iterations = 0;
  int simulations = 0;
  double seconds = 0.0;
  Eigen::VectorXd observed, fitted;  // SI, one entry per observation; fitted NaN without a fit
  // 100 mean_j |fitted_j - observed_j| / |observed_j|; NaN without a fit. `scale` (one factor per
  // observation, e.g. to display units) is applied to both first: mathematically the same number,
  // but rounded as the shown values are.
  double relative_error_percent(const Eigen::VectorXd& scale = {}) const;
};
using CalibrateFn = std::function<CaseCalibration(const CohortCase&)>;

// A calibrated case, the input of the statistics.
struct CaseEstimate {
  std::string id;
  std::string group;
  Eigen::VectorXd mean;
  Eigen::VectorXd sd;
};

struct SpecificityOptions {
  std::vector<std::string> parameters;  // names, in the order of the calibration's vectors
  // The compared groups; both empty: the two labels of the cohort in order of first appearance
  // (the cohort must then have exactly two). Every difference, effect size, U and the AUC is of
  // group_b against group_a (B - A, P(B > A)); cases of other groups are ignored.
  std::string group_a, group_b;
  // Adjustment of the primary p-values over the parameters, and the adjusted level below which a
  // parameter is reported as different.
  PAdjust adjust = PAdjust::kHolm;
  double alpha = 0.05;
  // Fewest calibrated cases per compared group for statistics (>= 2: a sample variance).
  int min_cases_per_group = 2;
  // Linear discriminant (Fisher 1936) on the standardised posterior means with the pooled
  // within-group covariance shrunk towards its diagonal, S = (1 - lambda) S_pooled + lambda
  // diag(S_pooled) (Friedman 1989, J Am Stat Assoc 84:165, regularised discriminant analysis),
  // priors the training group fractions. lambda in [0, 1].
  double lda_shrinkage = 0.2;
  // run_specificity only: how many cases are calibrated at the same time (OpenMP threads, dynamic
  // schedule, one case per thread). 1: in order. With more than 1 the calibrate callable must be
  // safe to call concurrently (each call on its own simulator); results do not depend on it.
  int case_threads = 1;
  // The ranks to spread the cases over (not owned; null: this process) and the checkpoint that
  // records finished cases (estimation/checkpoint.h; scope "cases"). With several ranks each case
  // is calibrated on one rank (dynamic hand-out) and the results are gathered on every rank; the
  // calibrate callable must then build local ensembles (no communicator).
  parallel::Communicator* communicator = nullptr;
  MemberCheckpoint* checkpoint = nullptr;
  // Called after each calibrated case (run_specificity only; serialised, possibly from a worker
  // thread, so `done` counts finished cases, not a position in the cohort).
  std::function<void(int done, int total, const std::string& id)> progress;
  std::string validate() const;
};

struct ParameterSeparation {
  std::string name;
  GroupSummary a, b;              // posterior means across the cases of each group
  double posterior_sd_a = 0.0;    // mean posterior standard deviation over the cases of group a
  double posterior_sd_b = 0.0;
  EffectSize effect;              // b over a
  WelchResult welch;              // on the posterior means, b - a
  // The primary test: posterior_welch_test (each case's posterior variance added); b - a.
  WelchResult posterior_welch;
  double p_adjusted = 1.0;        // posterior_welch.p_value adjusted over the parameters
  bool different = false;         // p_adjusted < alpha
  MannWhitneyResult mann_whitney; // U, p, AUC = P(b > a) + P(b = a)/2, Hanley-McNeil SE
  std::string direction;          // auc_direction(AUC): b "higher", "lower" or "none"
};

struct ClassifierResult {
  // false when a group has fewer than 2 cases (message says why). With 2, each held-out case of
  // that group is classified from a single training case of its group: read with care.
  bool valid = false;
  std::string message;
  int correct = 0;
  int total = 0;
  double accuracy = 0.0;               // leave-one-out
  std::vector<int> predicted_label;    // per case: 0 = group a, 1 = group b
  std::vector<std::string> predicted;  // the same as group names (compare_groups fills it)
};

enum class SpecificityStatus {
  kOk,
  kNoStatistics,  // fewer than min_cases_per_group calibrated cases in a group: per-case results only
};
const char* to_string(SpecificityStatus status);

struct SpecificityResult {
  std::string group_a, group_b;
  std::vector<CaseEstimate> cases;                 // the cases that entered the statistics
  std::vector<std::string> failed_cases;           // ids of cases whose calibration failed
  std::vector<model::Status> failure_status;       // their Status, same order
  std::vector<ParameterSeparation> parameters;     // order of SpecificityOptions::parameters
  PAdjust adjust = PAdjust::kHolm;
  double alpha = 0.05;
  // Parameters by evidence: increasing primary (posterior Welch) p-value, ties by decreasing
  // |AUC - 0.5|.
  std::vector<int> ranking;
  ClassifierResult classifier;

  std::string report() const;
};

// The statistics on already-calibrated cases. Throws std::invalid_argument on bad options, when a
// case's vectors do not match the parameters, or when a group has fewer than min_cases_per_group.
SpecificityResult compare_groups(const std::vector<CaseEstimate>& cases,
                                 const SpecificityOptions& options);

// Everything a specificity study reports: the statistics (when they could be made) and every
// case of the cohort with its calibration, in cohort order.
struct SpecificitySummary : SpecificityResult {
  SpecificityStatus status = SpecificityStatus::kOk;
  std::string message;  // why there are no statistics
  std::vector<std::string> parameter_names;      // SpecificityOptions::parameters
  std::vector<CohortCase> cohort;                // every case
  std::vector<CaseCalibration> calibrations;     // one per cohort case
  bool ok() const { return status == SpecificityStatus::kOk; }
  bool case_ok(int i) const;  // the calibration of cohort case i succeeded
  // "ok", or "<termination>: <message>" of a failed calibration.
  std::string case_status(int i) const;
  // cases x parameters in cohort order: posterior means and standard deviations (NaN rows for
  // failed cases), known values (NaN where unknown).
  Eigen::MatrixXd means() const;
  Eigen::MatrixXd sds() const;
  Eigen::MatrixXd truths() const;
  bool any_truth() const;
};

// Calibrates each case with `calibrate` (in order, or options.case_threads at a time; a calibration
// may itself run in parallel), drops and lists the failed cases (a failed Status or an exception;
// listed in cohort order), then compare_groups. Throws std::invalid_argument on bad options only;
// when the groups are too small the summary's status is kNoStatistics.
SpecificitySummary run_specificity(const std::vector<CohortCase>& cases, const CalibrateFn& calibrate,
                                   const SpecificityOptions& options);

// Leave-one-out accuracy of the shrunk LDA on rows of X (cases x features) with labels in {0, 1}.
ClassifierResult loo_lda(const Eigen::MatrixXd& X, const std::vector<int>& label, double shrinkage);

}  // namespace sigmaheart::estimation::specificity
