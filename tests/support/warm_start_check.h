// A warm start against the cold run (model/simulator.h, run_warm; docs/models.md s.2.1), the same
// checks for every model that offers one (the sphere, the 17-patch regional model): the run that
// produces the warm start is run()'s beat; a nearby theta started warm gives the cold beat within
// the periodicity tolerance in at most `max_warm_beats`; an all-zero warm start (what a failed run
// hands on) is a cold run, bit for bit.
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>
#include <gtest/gtest.h>

#include <initializer_list>

namespace sigmaheart::testing {

inline void expect_warm_start_gives_the_cold_beat(model::Simulator& sim, const Eigen::VectorXd& theta0,
                                                  const Eigen::VectorXd& theta,
                                                  std::initializer_list<const char*> channels,
                                                  int max_warm_beats) {
  Eigen::VectorXd warm;
  const model::RunResult centre = sim.run_warm(theta0, Eigen::VectorXd(), &warm);
  ASSERT_TRUE(centre.status.ok()) << centre.status.message;
  ASSERT_EQ(warm.size(), sim.warm_start_size());
  // Producing a warm start adds unrecorded beats after the periodic one: the beat is run()'s.
  EXPECT_EQ(centre.trajectory.values, sim.run(theta0).trajectory.values);
  const model::RunResult cold = sim.run(theta);
  const model::RunResult hot = sim.run_warm(theta, warm, nullptr);
  ASSERT_TRUE(cold.status.ok()) << cold.status.message;
  ASSERT_TRUE(hot.status.ok()) << hot.status.message;
  for (const char* channel : channels) {
    const Eigen::VectorXd c = cold.trajectory.channel(channel);
    const Eigen::VectorXd h = hot.trajectory.channel(channel);
    const double range = c.maxCoeff() - c.minCoeff();
    // Both within periodic_tolerance (1e-6 of the state's scales) of the periodic state.
    EXPECT_LT((h - c).cwiseAbs().maxCoeff(), 1e-6 * range) << channel;
  }
  EXPECT_LE(hot.info.beats, max_warm_beats);
  EXPECT_GE(cold.info.beats, 10);
  const model::RunResult zeros = sim.run_warm(theta, Eigen::VectorXd::Zero(warm.size()), nullptr);
  EXPECT_EQ(zeros.trajectory.values, cold.trajectory.values);
  EXPECT_EQ(zeros.info.beats, cold.info.beats);
}

}  // namespace sigmaheart::testing
