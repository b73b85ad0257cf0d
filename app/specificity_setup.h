// The sections of a specificity config, parsed and checked in one place before any calibration
// runs: `cases:` (the cohort), `specificity:` (the compared groups, the classifier, parallelism)
// and, per case, the calibration problem of `observations:`, `estimate:`, `calibration:`
// (app/calibration_setup.h) with the case's observation file.
//
//   cases:                              # or: cases: data/cohort.yaml (a file with a `cases:` list)
//     - {name: volunteer01, file: data/volunteer01.csv, group: healthy}
//     - {name: failing01, file: data/failing01.csv, group: failing,
//        truth: {sigma0: 4.5e4, c2: 300}}   # optional: known values (synthetic cohorts); those of
//                                             # estimated parameters are reported beside the estimates
//   specificity:
//     groups: [healthy, failing]   # group a, group b; default: the two labels in order of appearance
//     lda_shrinkage: 0.2           # leave-one-out LDA, pooled covariance shrunk to its diagonal
//     adjust: holm                 # holm | benjamini-hochberg: p-values adjusted over the parameters
//     alpha: 0.05                  # adjusted level below which a parameter is reported as different
//     min_cases_per_group: 2       # fewer calibrated cases in a compared group: no statistics, exit 1
//     parallel: auto               # cases | ensemble | auto
//     threads: 0                   # 0: all cores
//
// Paths in `cases` are relative to the file that lists them.
#pragma once

#include "app/calibration_setup.h"
#include "app/config.h"
#include "estimation/specificity/specificity.h"

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app {

// One entry of `cases:`.
struct CaseEntry {
  std::string name;
  std::string group;
  std::filesystem::path file;           // absolute
  std::map<std::string, double> truth;  // parameter -> value (SI), when known
  Location where;
};

// How the cohort uses the threads: `cases` calibrates that many cases at once, each with a serial
// ensemble; `ensemble` calibrates the cases in order, each with a threaded ensemble; `auto` takes
// `cases` when the cohort has at least twice as many cases as threads. The numbers do not depend
// on the choice (each case runs on its own clones).
enum class SpecificityParallel { kAuto, kCases, kEnsemble };

struct SpecificitySection {
  std::string group_a, group_b;
  double lda_shrinkage = 0.2;
  estimation::specificity::PAdjust adjust = estimation::specificity::PAdjust::kHolm;
  double alpha = 0.05;
  int min_cases_per_group = 2;
  SpecificityParallel parallel = SpecificityParallel::kAuto;
  int threads = 0;
};

// Everything the study needs, parsed and checked before any calibration runs.
struct SpecificitySetup {
  std::vector<CaseEntry> cases;
  std::vector<CalibrationProblem> problems;  // one per case
  SpecificitySection section;
  std::vector<std::string> names, units;     // estimated parameters
  Eigen::VectorXd prior_mean;                // theta, SI
  std::vector<std::string> observation_names, observation_si_units;
};

SpecificitySection parse_specificity_section(const Config& config);
SpecificitySetup parse_specificity_setup(const Config& config);

// The cohort as the estimator sees it (ids, groups, files, known values in parameter order).
std::vector<estimation::specificity::CohortCase> cohort_of(const SpecificitySetup& setup);

// The per-case UT calibration: the one place that builds a UtCalibration from a case's problem.
// validate_case returns an empty string when the case's calibration can run; calibrate_case runs
// it on `model` (a forward model of the case's observer) with the configured ensemble on `threads`
// threads (1: serial), recording its members in `checkpoint` (if any) under `scope` (the case's
// name). The case fails when !UtSummary::ok() (anything but converged, e.g. the
// iteration limit, is a failed case: listed and left out of the statistics).
std::string validate_case(const CalibrationProblem& problem, estimation::ForwardModel& model);
estimation::specificity::CaseCalibration calibrate_case(const CalibrationProblem& problem,
                                                        estimation::ForwardModel& model, int threads,
                                                        estimation::MemberCheckpoint* checkpoint = nullptr,
                                                        const std::string& scope = "");

}  // namespace sigmaheart::app
