#pragma once

// Used by forward_robustness_test.cpp, built at two sizes (256/64 points, and 4096).
//
// The forward map does not break: over a Sobol' sample of the WHOLE parameter box (every parameter
// uniform between its bounds) the lumped sphere and the regional model return a periodic beat.
// A physiological outcome (no ejection, a tiny or huge ventricle) is a valid beat; a numerical
// failure (Newton, NaN, not periodic) is not. Points that break a documented cross-parameter
// constraint (APD < period) are bad input and are counted apart: run() must refuse them with
// kOutOfBounds, which is not a numerical failure.
//
// Regional: 5 patches (30 global parameters + 4 per patch = 50 dimensions; the 17-segment model's
// 98 would also fit since the direction numbers come from Boost.Random's 3667-dimension table, but
// 5 patches keep the census affordable and the points unchanged). The per-patch equations are the
// same for 5 or 17 patches.
#include "model/lumped/regional.h"
#include "model/lumped/sphere.h"

#include "estimation/sensitivity/sobol_sequence.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

namespace sigmaheart::model::lumped {

using estimation::sensitivity::Scrambling;
using estimation::sensitivity::SobolSequence;
using estimation::sensitivity::SobolSequenceOptions;

struct Census {
  int points = 0, ok = 0, refused = 0, failed = 0;
  std::map<std::string, int> by_code;
  std::string first_failure;
};

// Runs `sim` at `n` Sobol' points mapped onto the parameter bounds (SIGMAHEART_CENSUS_POINTS=m
// runs the first m points instead, for measuring; the test's assertion is unchanged).
// SIGMAHEART_CENSUS_DUMP=file writes, for each periodic point, its beats, step cuts and every
// channel at 20 evenly spaced samples of the returned beat (%.17g), to compare two builds.
// `only_points`: when not empty, only these indices of the n-point sample run (regression tests of
// points that once failed).
inline Census census(Simulator& sim, int n, const std::vector<int>& only_points = {}) {
  if (const char* points = std::getenv("SIGMAHEART_CENSUS_POINTS")) n = std::atoi(points);
  const ParameterSpace& space = sim.parameters();
  SobolSequenceOptions so;
  so.dimension = space.size();
  so.scrambling = Scrambling::kLinearMatrixAndShift;
  so.seed = 20261123;
  const SobolSequence sobol(so);
  const Eigen::MatrixXd u = sobol.points(0, static_cast<std::uint64_t>(n));
  Census c;
  std::ofstream dump;
  if (const char* file = std::getenv("SIGMAHEART_CENSUS_DUMP")) dump.open(file);
  dump.precision(17);
  const char* only = std::getenv("SIGMAHEART_POINT");
  // SIGMAHEART_CENSUS_SHARD=k/K runs only the points i with i mod K == k (for measuring in
  // parallel processes; the assertion then holds for that shard).
  int shard = 0, shards = 1;
  if (const char* sh = std::getenv("SIGMAHEART_CENSUS_SHARD")) {
    if (std::sscanf(sh, "%d/%d", &shard, &shards) != 2 || shards < 1 || shard < 0 || shard >= shards) {
      shard = 0;
      shards = 1;
    }
  }
  for (int i = only ? std::atoi(only) : 0; i < (only ? std::atoi(only) + 1 : n); ++i) {
    if (!only && i % shards != shard) continue;
    if (!only_points.empty() &&
        std::find(only_points.begin(), only_points.end(), i) == only_points.end()) {
      continue;
    }
    Eigen::VectorXd theta(space.size());
    for (int k = 0; k < space.size(); ++k) {
      theta(k) = space[k].lower + u(i, k) * (space[k].upper - space[k].lower);
    }
    if (only) std::cout << "theta " << theta.transpose() << std::endl;
    const auto start = std::chrono::steady_clock::now();
    const RunResult r = sim.run(theta);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (std::getenv("SIGMAHEART_PRINT_FAILURES") != nullptr && seconds > 0.5) {
      std::cout << "point " << i << " took " << seconds << " s, " << r.info.beats << " beats, "
                << r.info.step_cuts << " cuts, " << r.info.newton_iterations << " Newton, "
                << to_string(r.status.code) << "\n" << std::flush;
    }
    ++c.points;
    if (only) std::cout << "point " << i << ": " << to_string(r.status.code) << " " << r.status.message << " beats " << r.info.beats << " cuts " << r.info.step_cuts << " newton " << r.info.newton_iterations << " change " << r.info.periodicity_change << "\n" << theta.transpose() << "\n";
    if (r.status.ok()) {
      ++c.ok;
      EXPECT_TRUE(r.trajectory.values.allFinite()) << "point " << i;
      if (dump.is_open()) {
        const Eigen::Index rows = r.trajectory.values.rows();
        dump << i << " " << r.info.beats << " " << r.info.step_cuts;
        for (int k = 0; k < 20; ++k) dump << " " << r.trajectory.values.row(k * (rows - 1) / 19);
        dump << "\n";
      }
    } else if (r.status.code == StatusCode::kOutOfBounds) {
      ++c.refused;
    } else {
      ++c.failed;
      ++c.by_code[to_string(r.status.code)];
      if (c.first_failure.empty()) {
        c.first_failure = "point " + std::to_string(i) + ": " + r.status.message;
      }
      if (std::getenv("SIGMAHEART_PRINT_FAILURES") != nullptr) {
        std::cout << "point " << i << " " << to_string(r.status.code) << ": " << r.status.message
                  << "\n";
      }
    }
  }
  return c;
}

inline void expect_no_failure(const Census& c, const std::string& what) {
  std::string codes;
  for (const auto& [code, count] : c.by_code) codes += " " + code + ":" + std::to_string(count);
  std::cout << what << ": " << c.points << " points, " << c.ok << " periodic beats, " << c.refused
            << " refused (APD >= period), " << c.failed << " numerical failures" << codes << "\n";
  EXPECT_EQ(c.failed, 0) << c.first_failure;
  EXPECT_EQ(c.ok + c.refused, c.points);
}

inline RegionalOptions five_patches() {
  RegionalOptions o;
  o.area_shares = {0.2, 0.2, 0.2, 0.2, 0.2};
  o.activation = ActivationPattern::kExplicit;
  o.activation_times = {0.0, 0.02, 0.04, 0.06, 0.08};
  return o;
}

}  // namespace sigmaheart::model::lumped
