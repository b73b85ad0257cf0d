// What every sensitivity study shares (docs/estimation.md s.6): the studied parameters are a Prior of
// uniform parameters (estimation/prior.h: range, nominal, physical or eta space, and the map from
// the unit cube of a design to theta), the random streams, the Summary fields every study fills,
// and the running of a design through an Ensemble.
#pragma once

#include "estimation/ensemble.h"
#include "estimation/prior.h"
#include "estimation/transform.h"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace sigmaheart::estimation::sensitivity {

using estimation::SamplingSpace;

// How a study ended. Failed runs are never an exception: the summary says what was done.
enum class StudyStatus {
  kOk,              // every statistic computed (some runs may have failed and be listed)
  kFailedRuns,      // failed runs the failure policy cannot absorb (Sobol' policy stop, Morris
                    // with no complete trajectory): no statistics
  kFailedNominal,   // one-at-a-time: the nominal run failed, no deltas
};
const char* to_string(StudyStatus status);

// The block label and the row within its block of every run of a design.
struct DesignLayout {
  std::string description;
  std::vector<std::string> block;
  std::vector<int> row;
};

// One failed run of a study design.
struct FailedRun {
  int run = 0;         // row of the study's design (its `thetas`)
  std::string block;   // which part of the design: "A", "AB_2 (x2)", "trajectory 3", "low x1" ...
  int design_row = 0;  // row within that block (the step within a Morris trajectory)
  Eigen::VectorXd theta;
  model::Status status;
};

// What every study's Summary carries: how it ended, the design and its outputs, the failed runs.
struct StudySummary {
  StudyStatus status = StudyStatus::kOk;
  std::string message;  // why not ok, or what was done about failed runs; empty on a clean run
  std::vector<std::string> parameters, outputs;
  Eigen::MatrixXd thetas;  // runs x p, the design in physical units
  Eigen::MatrixXd Z;       // runs x m, model outputs (NaN rows for failed runs)
  DesignLayout layout;     // one block label and row per run
  std::vector<FailedRun> failed_runs;
  bool ok() const { return status == StudyStatus::kOk; }
};

// Empty when the prior's parameters are uniform, valid and match the model's inputs (count and
// names), else a message.
std::string validate_prior(const Prior& prior, const ForwardModel& model);
// The input checks every study starts with: throws std::invalid_argument with `study` + ": " +
// the validate_prior() message, else with `options_message` (the options' validate()) if not empty.
void check_study_inputs(const std::string& study, const Prior& prior, const ForwardModel& model,
                        const std::string& options_message);

std::vector<std::string> output_names(const ForwardModel& model);

// The seed of random stream `index` of a study seeded with `seed`: two rounds of SplitMix64
// (Steele, Lea & Flood 2014) over seed and index, so that streams are independent of the order
// in which they are drawn and of the thread count. Stream indices used by the studies are
// documented where they are drawn.
std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t index);
// A std::mt19937_64 seeded with stream_seed(seed, index).
std::mt19937_64 make_stream(std::uint64_t seed, std::uint64_t index);

// Runs every row of summary.thetas through an Ensemble built on `model` with `options` (under MPI,
// collectively: every rank gets the same outputs). Fills summary.Z (NaN rows for failed runs),
// summary.failed_runs (block and row from summary.layout) and returns whether each run succeeded.
std::vector<bool> evaluate_design(const ForwardModel& model, const EnsembleOptions& options,
                                  StudySummary& summary);

// Parameters of output `column` by decreasing |score(i, column)|, NaN last, ties in order.
std::vector<int> rank_by(const Eigen::MatrixXd& score, int column);

// A uniform integer in [0, n) from the top 32 bits of one draw (Lemire's multiply-shift; bias
// below n / 2^32). Written out rather than std::uniform_int_distribution, whose algorithm the
// standard leaves to the library, so that designs are the same with every standard library.
inline int uniform_index(std::mt19937_64& rng, int n) {
  return static_cast<int>(((rng() >> 32) * static_cast<std::uint64_t>(n)) >> 32);
}

// The standard normal quantile z with Phi(z) = prob, prob in (0, 1): Newton's method on the
// upper tail erfc(x / sqrt 2) / 2 (Abramowitz & Stegun 1964, 26.2.29) from x = 0, to the last few
// bits. normal_quantile(0.975) = 1.959964. Throws std::invalid_argument outside (0, 1).
double normal_quantile(double prob);

// Sample standard deviation (divisor count - 1) of the finite values of `samples`; NaN with fewer
// than two finite values.
double finite_std(const std::vector<double>& samples);

// Percentile interval [q_low, q_high] of the finite values of `samples` (linear interpolation
// between order statistics, Hyndman-Fan type 7). NaN when no value is finite.
std::pair<double, double> percentile_interval(std::vector<double> samples, double confidence);

}  // namespace sigmaheart::estimation::sensitivity
