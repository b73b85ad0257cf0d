// Writers of a specificity study (app/commands/specificity.cpp): the results file, the JSON
// summary and the terminal report, from the setup and the Summary the estimator returned.
// Layout (kind "specificity"):
//   /parameters/{names, units, prior_mean}
//   /cases/{names, groups, files, status, termination}, /cases/{mean, std, truth} (case x
//     parameter, SI), /cases/{iterations, simulations, seconds}, /cases/relative_error [%],
//     /cases/observed, /cases/fitted (case x observation, clinical units, /cases/observation_units)
//   /statistics/{mean_a, sd_a, mean_b, sd_b, posterior_sd_a, posterior_sd_b} (SI),
//     {cohen_d, hedges_g, welch_t, welch_df, welch_p, posterior_welch_t, posterior_welch_df,
//     posterior_welch_p, p_adjusted, different, mann_whitney_u, mann_whitney_p, auc, auc_se} per
//     parameter (every difference b - a, AUC = P(b > a)), /statistics/direction (b higher, lower,
//     none), /statistics/ranking (names, strongest evidence first); attributes group_a, group_b,
//     adjust, alpha
//   /classifier (attributes valid, accuracy, correct, total, shrinkage, message), /classifier/predicted
//   /failed/{names, messages}, /summary (attributes wall_seconds, parallel, status, message)
#pragma once

#include "app/io/hdf5_writer.h"
#include "app/io/results.h"
#include "app/specificity_setup.h"
#include "estimation/specificity/specificity.h"

#include <nlohmann/json.hpp>

#include <string>

namespace sigmaheart::app::io {

// How the study ran (not a result of the estimator).
struct SpecificityRun {
  double wall_seconds = 0.0;
  int threads = 1;
  bool by_case = false;  // threads over cases (true) or over each case's ensemble
};

// Writes every group but the provenance.
void write_specificity_h5(Hdf5Writer& h5, const SpecificitySetup& setup,
                          const estimation::specificity::SpecificitySummary& summary,
                          const SpecificityRun& run);

nlohmann::ordered_json specificity_json(const std::string& name, const SpecificitySetup& setup,
                                        const estimation::specificity::SpecificitySummary& summary,
                                        const SpecificityRun& run, const std::string& results_file,
                                        const Provenance& provenance);

// Per-case table, failed cases, and the parameters by separation.
std::string specificity_report(const std::string& name, const SpecificitySetup& setup,
                               const estimation::specificity::SpecificitySummary& summary,
                               const SpecificityRun& run);

}  // namespace sigmaheart::app::io
