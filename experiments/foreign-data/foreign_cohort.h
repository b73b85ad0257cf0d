// A foreign cohort for the specificity study (experiments/specificity/README.md): three groups of
// subjects made by the bench's two simulators, each subject's parameters drawn around the nominal
// of a bench case (foreign_cases.h) with a stated coefficient of variation.
//
//   group     bench case   what differs from `healthy` (foreign_cases.cpp, README "Cases")
//   healthy   healthy      -
//   reduced   reduced      contractility (Ees / T0) lower, dilated, higher filling pressure; the
//                          arterial load (Zc, R_sys, C_sys, P_ven) is set to the healthy case's,
//                          so afterload is a parameter that does NOT differ (a negative control)
//   stiff     stiff        stiffer / thicker wall, higher afterload (R_sys up, C_sys down)
//
// Every subject has the same heart rate (CohortOptions::heart_rate): the specificity config has one
// heart period for every case, so the groups differ only in the parameters above. Half the
// subjects of each group come from each simulator, so model form is balanced across the groups.
// `foreign_lv --cohort DIR` is write_cohort(DIR).
#pragma once

#include "foreign_cases.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace foreign {

struct CohortOptions {
  std::uint64_t seed = 2026;    ///< parameter draws (mt19937_64 + Box-Muller)
  int per_model_and_group = 4;  ///< subjects per (simulator, group): 8 per group
  /// Between-subject coefficient of variation of each drawn parameter (log-normal, mean = the bench
  /// nominal). A choice, not a measurement: large enough that subjects of a group differ visibly,
  /// smaller than the group differences of the bench (30-80 % on the changed parameters).
  double cv = 0.10;
  double heart_rate = 70.0;  ///< [bpm] for every subject
};

/// Which parameters vary between subjects (every other parameter is the bench case's).
///   elastance: Ees, A_ed, P_pv, R_sys, C_sys;   one-fibre: T0, c_p, P_pv, R_sys, C_sys.
std::vector<std::string> drawn_parameters(const std::string& model);

struct CohortSubject {
  std::string id;     ///< e.g. "healthy-el1" (el: elastance, of: one-fibre)
  std::string group;  ///< healthy, reduced or stiff
  BenchCase bench_case;  ///< the drawn parameters; seed = the subject's noise seed
};

/// The subjects in file order: group by group, elastance then one-fibre. Deterministic.
std::vector<CohortSubject> cohort_subjects(const CohortOptions& options = {});

struct CohortResult {
  CohortSubject subject;
  Beat beat;
  Indices indices;
};

/// Simulates every subject and writes <id>.csv (30 noisy frames, t = 0 at end-diastole, the bench's
/// format and noise), cases.yaml (the `cases:` list a specificity config reads) and subjects.yaml
/// (drawn parameters with units, indices) into `out` (created if needed). Deterministic.
std::vector<CohortResult> write_cohort(const std::filesystem::path& out, const CohortOptions& options = {});

}  // namespace foreign
