// The `sensitivity:` section of a config, parsed and validated in one place into typed options:
// the method, the model (the configured simulator's global indices or an analytic test function),
// the studied parameters as a uniform Prior, and the options of each method with the configured
// ensemble. Every problem is an InputError at the offending key (file:line:column).
//
//   sensitivity:
//     method: sobol                 # oat | morris | sobol
//     model: simulator              # simulator | ishigami | g-function
//     outputs: [EDV, ESV, EF, P_max]  # global indices (observers/global_indices.h); default: all
//     model_outputs: [log_density, "T[1]"]  # or: named outputs of a model that returns values
//                                   # (observers/output_values.h), e.g. a UM-Bridge benchmark
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
//             scrambling: lms, failure_policy: stop,   # failure_policy: stop | impute-mean
//             second_order: false}                     # true: S2 too, N (2p + 2) runs
//     ensemble: {backend: threads, threads: 0}         # serial | threads | mpi; 0 = all cores
#pragma once

#include "app/config.h"
#include "estimation/ensemble.h"
#include "estimation/prior.h"
#include "estimation/sensitivity/morris.h"
#include "estimation/sensitivity/oat.h"
#include "estimation/sensitivity/sobol_indices.h"
#include "estimation/sensitivity/test_functions.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <variant>

namespace sigmaheart::app {

enum class SensitivityMethod { kOat, kMorris, kSobol };
const char* to_string(SensitivityMethod method);  // "oat", "morris", "sobol"

struct SensitivitySetup {
  SensitivityMethod method = SensitivityMethod::kSobol;
  std::string model_kind = "simulator";  // simulator | ishigami | g-function
  std::unique_ptr<estimation::ForwardModel> model;
  estimation::Prior prior;  // uniform parameters, in the model's input order
  std::optional<estimation::sensitivity::ExactIndices> exact;  // the test functions
  estimation::sensitivity::OatOptions oat;
  estimation::sensitivity::MorrisOptions morris;
  estimation::sensitivity::SobolOptions sobol;

  int runs() const;             // the size of the chosen method's design
  std::uint64_t seed() const;   // the random seed of the chosen method (OAT: the Sobol' one)
  // The chosen method's ensemble options, and a setter that applies to every method.
  const estimation::EnsembleOptions& ensemble() const;
  void set_ensemble(const estimation::EnsembleOptions& options);
};

// What a study returns: the Summary of the method that ran.
using SensitivitySummary = std::variant<estimation::sensitivity::OatSummary,
                                        estimation::sensitivity::MorrisSummary,
                                        estimation::sensitivity::SobolSummary>;

SensitivitySetup parse_sensitivity(const Config& config);

// Runs the chosen method through the configured ensemble. Throws std::invalid_argument on options
// the parser could not check (none expected); failed runs are in the summary's status.
SensitivitySummary run_sensitivity_study(const SensitivitySetup& setup);

// The parts every summary shares.
const estimation::sensitivity::StudySummary& study_of(const SensitivitySummary& summary);

}  // namespace sigmaheart::app
