// Variance-based (Sobol') sensitivity indices from a Saltelli design (docs/estimation.md s.6).
//
// Design (Saltelli et al. 2010, Comput Phys Commun 181:259, s.3): a scrambled Sobol' sequence of
// dimension 2p gives N points; A is its first p columns, B its last p, and AB_i is A with column i
// taken from B. The N (p + 2) runs are ordered by block: A (rows 0..N-1), B (N..2N-1), then
// AB_1, ..., AB_p. With second-order indices (Saltelli 2002, Comput Phys Commun 145:280, s.3) the
// blocks BA_1, ..., BA_p follow (BA_i: B with column i taken from A): N (2p + 2) runs.
// Every output of the model is analysed from the same runs.
//
// Estimators, per output, with f_A, f_B, f_ABi, f_BAi the outputs of the blocks and V the variance
// of the 2N outputs of A and B together:
//   first order  S1_i = (1/N) sum_j f_B(j) (f_ABi(j) - f_A(j)) / V     (Saltelli 2010, Table 2 (b))
//   total order  ST_i = (1/2N) sum_j (f_A(j) - f_ABi(j))^2 / V         (Jansen 1999; Saltelli 2010,
//                                                                       Table 2 (f))
//   second order S2_ik = V_ik^c / V - S1_i - S1_k, i < k, with the closed index
//                V_ik^c / V = (1/N) sum_j (f_BAi(j) f_ABk(j) - f_A(j) f_B(j)) / V
//                (Saltelli 2002, eq. 8 and s.3; the estimator of SALib's sobol.analyze, Herman &
//                Usher 2017, JOSS 2:97): BA_i and AB_k share x_i (from A) and x_k (from B).
// Outputs are centred by the mean of the A and B outputs in the first- and second-order sums,
// e.g. sum_j (f_B(j) - mean) (f_ABi(j) - f_A(j)): the same expectation (E[f_ABi - f_A] = 0), but
// without centring the estimator's variance grows with mean^2 / V, which for outputs far from zero
// (P_max 124 +- 14 mmHg) made the 95 % interval of S1 as wide as [0, 1] at N = 2048 (the ST
// estimator is a difference and was unaffected).
// Confidence: B bootstrap replicates over the N design rows (the same resampled rows in every
// block), replicate b drawn from make_stream(seed, kBootstrapStream + b). Reported as SALib does:
// S1_conf, ST_conf, S2_conf = z_{(1+c)/2} x the bootstrap standard deviation, the half-width of the
// normal-approximation interval at confidence c; the percentile interval of S1 and ST is kept
// beside it (S1_low, S1_high, ST_low, ST_high).
// Convergence: the same estimators on the prefixes of n = N, N/2, N/4, ... rows (each prefix of a
// Sobol' sequence of length 2^k is itself a net, so these are proper smaller designs).
//
// Failed runs: a Saltelli design cannot drop rows (each estimator pairs rows across blocks).
// The policy is an explicit option (SobolFailurePolicy) and the result says what was done.
#pragma once

#include "estimation/ensemble.h"
#include "estimation/sensitivity/design.h"
#include "estimation/sensitivity/sobol_sequence.h"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation::sensitivity {

enum class SobolFailurePolicy {
  // Default: no indices are computed; the summary has status kFailedRuns and lists the failed runs
  // (design row, block, parameters, message) so they can be investigated or the ranges narrowed.
  kStop,
  // Each failed run's outputs are replaced by the mean of that output over the successful runs of
  // the whole design; the indices are computed and the result is flagged `imputed` with the list
  // of imputed runs. Imputation pulls the affected estimates towards zero; use only for a few
  // failures.
  kImputeMean,
};
const char* to_string(SobolFailurePolicy policy);
std::optional<SobolFailurePolicy> parse_sobol_failure_policy(const std::string& text);  // "stop", "impute-mean"

struct SobolOptions {
  int base_samples = 1024;  // N, a power of two >= 16; runs = N (p + 2)
  Scrambling scrambling = Scrambling::kLinearMatrixAndShift;
  std::uint64_t seed = 1;   // scramble and bootstrap streams
  int bootstrap_samples = 1000;  // 0: no intervals
  double confidence = 0.95;
  int convergence_levels = 4;    // estimates at N, N/2, ..., N/2^(levels-1) (prefixes >= 16 rows)
  bool second_order = false;     // S2 too: the BA_i blocks are added, runs = N (2p + 2)
  SobolFailurePolicy failure_policy = SobolFailurePolicy::kStop;
  EnsembleOptions ensemble;
  std::string validate(int p) const;
};

// Indices of one prefix size: p x m tables (parameter x output).
struct SobolEstimate {
  int n = 0;                              // design rows used
  Eigen::MatrixXd S1, ST;
  // Half-width of the bootstrap interval at the configured confidence, z x bootstrap std (SALib's
  // S1_conf / ST_conf); NaN without bootstrap.
  Eigen::MatrixXd S1_conf, ST_conf;
  Eigen::MatrixXd S1_low, S1_high, ST_low, ST_high;  // percentile bootstrap interval (NaN without)
  // Second order (empty unless options.second_order): per output a p x p matrix, S2(i, k) for
  // i < k, NaN on and below the diagonal; S2_conf likewise.
  std::vector<Eigen::MatrixXd> S2, S2_conf;
  Eigen::VectorXd variance;               // m, output variance estimate
  Eigen::VectorXd output_std;             // m, sqrt(max(variance, 0))
};

struct SobolSummary : StudySummary {
  // status kFailedRuns: indices not computed (failure_policy stop, or every run failed; see
  // message and failed_runs). Layout: "A", "B", "AB_<i> (<name>)", row = design row j.
  bool imputed = false; // true: some outputs were imputed (see failed_runs)
  int N = 0;
  int runs = 0;
  bool second_order = false;

  SobolEstimate estimate;                // the full design (n = N)
  std::vector<SobolEstimate> convergence;  // n = N, N/2, ... (first entry equals `estimate`)

  // Outputs whose variance is zero (indices NaN for them).
  std::vector<std::string> constant_outputs;

  // Parameters of one output by decreasing ST (NaN last).
  std::vector<int> ranking(int output) const { return rank_by(estimate.ST, output); }
  // A few lines: design size, failures and policy, and per output the S1/ST table.
  std::string report() const;
};

// Runs of a Saltelli design: N (p + 2), or N (2p + 2) with second-order indices.
std::int64_t sobol_runs(int p, std::int64_t N, bool second_order);

// The unit-cube Saltelli design: sobol_runs(p, N, second_order) rows, block order A, B,
// AB_1..AB_p (then BA_1..BA_p with second order).
Eigen::MatrixXd saltelli_design(int p, int N, Scrambling scrambling, std::uint64_t seed,
                                bool second_order = false);

// Block labels of the runs.
DesignLayout sobol_layout(int N, const std::vector<std::string>& names, bool second_order = false);

// Runs the design through an Ensemble (options.ensemble) and estimates the indices. Throws
// std::invalid_argument on invalid options or prior (before any run); run failures are handled by
// the policy and reported in the summary's status.
SobolSummary run_sobol(const ForwardModel& model, const Prior& prior, const SobolOptions& options);

// The estimators alone, from the outputs of an already-run design (runs x m, block order above,
// all finite; N (2p + 2) rows when options.second_order). Exposed for tests and for designs run
// elsewhere.
SobolEstimate sobol_estimate(const Eigen::MatrixXd& Z, int p, int N, int n_used,
                             const SobolOptions& options);

}  // namespace sigmaheart::estimation::sensitivity
