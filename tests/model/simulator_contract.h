// Contract tests written once and run on every simulator (STYLE.md practice 7):
// determinism, clone independence, dimensions, failure as a Status, warm starts, and for steppable
// simulators replay from a saved state. Every model of a registry runs them with its default numerics:
//   INSTANTIATE_TEST_SUITE_P(Builtin, SimulatorContract,
//                            ::testing::ValuesIn(contract_cases(model::builtin_models())),
//                            contract_case_name);
// (tests/model/registry_test.cpp does this for the built-in models, so a newly registered model is
// covered without a line of test code); a test file may add cases for other numerics with
// ::testing::Values(ContractCase{...}).
#pragma once

#include "model/registry.h"
#include "model/simulator.h"

#include <gtest/gtest.h>

#include <cctype>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace sigmaheart::testing {

struct ContractCase {
  std::string name;
  std::function<std::unique_ptr<model::Simulator>()> make;
  // Two replay split times [s] on the simulator's time grid (steppable simulators only).
  double replay_t1 = 0.1;
  double replay_t2 = 0.3;
  // Relative perturbation applied to every parameter for the "another theta" runs.
  double perturbation = 0.05;
};

inline void PrintTo(const ContractCase& c, std::ostream* os) { *os << c.name; }

// One case per model of `registry`, built with its default numerics (an absent `numerics:`).
// The registry must outlive the tests (builtin_models() or a static).
inline std::vector<ContractCase> contract_cases(const model::ModelRegistry& registry) {
  std::vector<ContractCase> cases;
  for (const auto& setup : registry.all()) {
    const model::ModelSetup* s = &setup;
    cases.push_back({setup.name, [s] { return s->configure_defaults().make(); }});
  }
  return cases;
}

// gtest parameter names allow letters, digits and '_' only: "lumped-sphere" -> "lumped_sphere".
inline std::string contract_case_name(const ::testing::TestParamInfo<ContractCase>& info) {
  std::string name = info.param.name;
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return name;
}

class SimulatorContract : public ::testing::TestWithParam<ContractCase> {
 protected:
  static Eigen::VectorXd perturbed(const model::ParameterSpace& space, double rel) {
    Eigen::VectorXd theta = space.nominal();
    for (int i = 0; i < space.size(); ++i) {
      const double v = theta(i) * (1.0 + rel * ((i % 2 == 0) ? 1.0 : -1.0));
      if (v >= space[i].lower && v <= space[i].upper) theta(i) = v;
    }
    return theta;
  }
};

TEST_P(SimulatorContract, SameThetaGivesIdenticalBits) {
  auto sim = GetParam().make();
  const Eigen::VectorXd theta = sim->parameters().nominal();
  const auto a = sim->run(theta);
  const auto b = sim->run(theta);
  ASSERT_TRUE(a.status.ok()) << a.status.message;
  ASSERT_TRUE(b.status.ok()) << b.status.message;
  ASSERT_EQ(a.trajectory.values.rows(), b.trajectory.values.rows());
  EXPECT_EQ((a.trajectory.values - b.trajectory.values).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.trajectory.times - b.trajectory.times).cwiseAbs().maxCoeff(), 0.0);
}

TEST_P(SimulatorContract, TrajectoryMatchesDeclaredChannels) {
  auto sim = GetParam().make();
  const auto r = sim->run(sim->parameters().nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto declared = sim->channels();
  ASSERT_EQ(r.trajectory.channels.size(), declared.size());
  for (size_t i = 0; i < declared.size(); ++i) {
    EXPECT_EQ(r.trajectory.channels[i].name, declared[i].name);
    EXPECT_EQ(r.trajectory.channels[i].unit, declared[i].unit);
  }
  EXPECT_EQ(r.trajectory.values.cols(), static_cast<Eigen::Index>(declared.size()));
  EXPECT_EQ(r.trajectory.values.rows(), r.trajectory.times.size());
  EXPECT_GT(r.trajectory.samples(), 10);
  EXPECT_TRUE(r.trajectory.values.allFinite());
  for (int k = 1; k < r.trajectory.samples(); ++k) {
    ASSERT_GT(r.trajectory.times(k), r.trajectory.times(k - 1)) << "times not increasing at " << k;
  }
}

TEST_P(SimulatorContract, ClonesAreIndependent) {
  auto sim = GetParam().make();
  const Eigen::VectorXd nominal = sim->parameters().nominal();
  const Eigen::VectorXd other = perturbed(sim->parameters(), GetParam().perturbation);
  const auto reference = sim->run(nominal);
  ASSERT_TRUE(reference.status.ok()) << reference.status.message;

  // Two clones run different thetas at the same time on two threads; then the original again.
  auto c1 = sim->clone();
  auto c2 = sim->clone();
  model::RunResult r1, r2;
  std::thread t1([&] { r1 = c1->run(nominal); });
  std::thread t2([&] { r2 = c2->run(other); });
  t1.join();
  t2.join();
  ASSERT_TRUE(r1.status.ok()) << r1.status.message;
  ASSERT_TRUE(r2.status.ok()) << r2.status.message;
  EXPECT_EQ((r1.trajectory.values - reference.trajectory.values).cwiseAbs().maxCoeff(), 0.0);
  const auto again = sim->run(nominal);
  EXPECT_EQ((again.trajectory.values - reference.trajectory.values).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(c1->parameters().names(), sim->parameters().names());
}

// Warm starts (model/simulator.h): without one, run_warm() is run() bit for bit and hands on
// warm_start_size() entries; a run from that warm start at another theta is deterministic.
TEST_P(SimulatorContract, RunWarmWithoutAWarmStartIsRunAndFromOneIsDeterministic) {
  auto sim = GetParam().make();
  const Eigen::VectorXd theta = sim->parameters().nominal();
  const auto cold = sim->run(theta);
  Eigen::VectorXd warm;
  const auto a = sim->run_warm(theta, Eigen::VectorXd(), &warm);
  ASSERT_TRUE(a.status.ok()) << a.status.message;
  ASSERT_EQ(a.trajectory.values.rows(), cold.trajectory.values.rows());
  EXPECT_EQ((a.trajectory.values - cold.trajectory.values).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(warm.size(), sim->warm_start_size());
  const Eigen::VectorXd other = perturbed(sim->parameters(), GetParam().perturbation);
  const auto b1 = sim->run_warm(other, warm, nullptr);
  const auto b2 = sim->clone()->run_warm(other, warm, nullptr);
  ASSERT_TRUE(b1.status.ok()) << b1.status.message;
  ASSERT_TRUE(b2.status.ok()) << b2.status.message;
  ASSERT_EQ(b1.trajectory.values.rows(), b2.trajectory.values.rows());
  EXPECT_EQ((b1.trajectory.values - b2.trajectory.values).cwiseAbs().maxCoeff(), 0.0);
}

TEST_P(SimulatorContract, FailureIsReportedAsStatus) {
  auto sim = GetParam().make();
  const auto& space = sim->parameters();
  Eigen::VectorXd theta = space.nominal();
  theta(0) = std::numeric_limits<double>::quiet_NaN();
  model::RunResult r;
  EXPECT_NO_THROW(r = sim->run(theta));
  EXPECT_FALSE(r.status.ok());
  EXPECT_FALSE(r.status.message.empty());

  // Out of bounds on the first bounded parameter.
  for (int i = 0; i < space.size(); ++i) {
    if (std::isfinite(space[i].upper)) {
      theta = space.nominal();
      theta(i) = space[i].upper * 2.0 + 1.0;
      EXPECT_NO_THROW(r = sim->run(theta));
      EXPECT_EQ(r.status.code, model::StatusCode::kOutOfBounds) << r.status.message;
      EXPECT_NE(r.status.message.find(space[i].name), std::string::npos) << r.status.message;
      break;
    }
  }
  // Wrong size.
  EXPECT_NO_THROW(r = sim->run(Eigen::VectorXd::Ones(space.size() + 1)));
  EXPECT_FALSE(r.status.ok());
}

TEST_P(SimulatorContract, ReplayFromSavedStateEqualsUninterruptedRun) {
  auto sim = GetParam().make();
  auto* steppable = dynamic_cast<model::SteppableSimulator*>(sim.get());
  if (steppable == nullptr) GTEST_SKIP() << "not a steppable simulator";
  const Eigen::VectorXd theta = sim->parameters().nominal();
  const double t1 = GetParam().replay_t1;
  const double t2 = GetParam().replay_t2;

  model::State straight = steppable->initial_state(theta);
  ASSERT_EQ(straight.x.size(), static_cast<Eigen::Index>(steppable->state_layout().size()));
  ASSERT_TRUE(steppable->advance(straight, theta, t2).ok());

  model::State split = steppable->initial_state(theta);
  ASSERT_TRUE(steppable->advance(split, theta, t1).ok());
  const model::State saved = split;  // a checkpoint, as the ROUKF keeps one per member
  ASSERT_TRUE(steppable->advance(split, theta, t2).ok());

  // Resume the checkpoint on a clone: must land on the same bits as the original continuation.
  auto other = sim->clone();
  auto* other_steppable = dynamic_cast<model::SteppableSimulator*>(other.get());
  model::State resumed = saved;
  ASSERT_TRUE(other_steppable->advance(resumed, theta, t2).ok());

  EXPECT_DOUBLE_EQ(straight.time, t2);
  EXPECT_DOUBLE_EQ(split.time, t2);
  const double scale = 1.0 + straight.x.cwiseAbs().maxCoeff();
  EXPECT_LE((split.x - straight.x).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_EQ((resumed.x - split.x).cwiseAbs().maxCoeff(), 0.0);

  const Eigen::VectorXd s = steppable->sample(split, theta);
  EXPECT_EQ(s.size(), static_cast<Eigen::Index>(sim->channels().size()));
  EXPECT_TRUE(s.allFinite());
}

}  // namespace sigmaheart::testing
