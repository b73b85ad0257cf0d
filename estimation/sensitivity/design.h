// What every sensitivity study shares (ESTIMATION.md s.6): the range of each studied parameter,
// the map from the unit cube of a design to physical theta, the random streams, and the running of
// a design through an Ensemble.
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


// One studied parameter. The ForwardModel's inputs and the ranges correspond one to one, in order.
struct ParameterRange {
  std::string name;
  std::string unit;      // SI, for reports
  double nominal = 0.0;  // centre of one-at-a-time studies; must lie in [lower, upper]
  double lower = 0.0;    // physical bounds of the study
  double upper = 1.0;
  SamplingSpace space = SamplingSpace::kPhysical;
  Transform transform;   // used when space == kEta; lower and upper must map to finite eta

  // Empty when consistent, else a message naming the parameter.
  std::string validate() const;
  // u in [0, 1] -> theta (uniform in the chosen space).
  double from_unit(double u) const;
  // theta -> u in [0, 1] (inverse of from_unit).
  double to_unit(double theta) const;
};

// Empty when the ranges are valid and match the model's inputs (count and names), else a message.
std::string validate_ranges(const std::vector<ParameterRange>& ranges, const ForwardModel& model);

// Rows of U (runs x p, entries in [0, 1]) mapped to physical theta.
Eigen::MatrixXd unit_to_theta(const std::vector<ParameterRange>& ranges, const Eigen::MatrixXd& U);

std::vector<std::string> range_names(const std::vector<ParameterRange>& ranges);
std::vector<std::string> output_names(const ForwardModel& model);

// The seed of random stream `index` of a study seeded with `seed`: two rounds of SplitMix64
// (Steele, Lea & Flood 2014) over seed and index, so that streams are independent of the order
// in which they are drawn and of the thread count. Stream indices used by the studies are
// documented where they are drawn.
std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t index);
// A std::mt19937_64 seeded with stream_seed(seed, index).
std::mt19937_64 make_stream(std::uint64_t seed, std::uint64_t index);

// Runs every row of `thetas` (runs x inputs) through an Ensemble built on `model` with `options`.
// Rows of failed runs are NaN; status holds one entry per run.
EnsembleResult evaluate_design(const ForwardModel& model, const Eigen::MatrixXd& thetas,
                               const EnsembleOptions& options);

// A uniform integer in [0, n) from the top 32 bits of one draw (Lemire's multiply-shift; bias
// below n / 2^32). Written out rather than std::uniform_int_distribution, whose algorithm the
// standard leaves to the library, so that designs are the same with every standard library.
inline int uniform_index(std::mt19937_64& rng, int n) {
  return static_cast<int>(((rng() >> 32) * static_cast<std::uint64_t>(n)) >> 32);
}

// One failed run of a study design.
struct FailedRun {
  int run = 0;         // row of the study's design (its `thetas`)
  std::string block;   // which part of the design: "A", "AB_2 (x2)", "trajectory 3", "low x1" ...
  int design_row = 0;  // row within that block (the step within a Morris trajectory)
  Eigen::VectorXd theta;
  model::Status status;
};

// Percentile interval [q_low, q_high] of the finite values of `samples` (linear interpolation
// between order statistics, Hyndman-Fan type 7). NaN when no value is finite.
std::pair<double, double> percentile_interval(std::vector<double> samples, double confidence);

}  // namespace sigmaheart::estimation::sensitivity
