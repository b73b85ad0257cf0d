// Tests of model/zoned_simulator.h on the regional lumped ventricle: the zoned space, expand(),
// runs and steps identical to the inner model with every zone member at the zone's value, the
// errors, and the simulator contract.
#include "model/zoned_simulator.h"

#include "model/lumped/regional.h"
#include "tests/model/simulator_contract.h"

#include <gtest/gtest.h>

#include <memory>

namespace sigmaheart::model {
namespace {

std::unique_ptr<SteppableSimulator> five_patches() {
  lumped::RegionalOptions o;
  o.area_shares = {0.3, 0.2, 0.2, 0.2, 0.1};
  return std::make_unique<lumped::RegionalVentricle>(o);
}

// Zones {1, 2} and {4, 5} of sigma0; sigma0_03 stays its own parameter.
std::vector<ParameterZone> two_zones(const ParameterSpace& s) {
  return {{"sigma0_front", {s.index_or_throw("sigma0_01"), s.index_or_throw("sigma0_02")}},
          {"sigma0_back", {s.index_or_throw("sigma0_04"), s.index_or_throw("sigma0_05")}}};
}

// The simulator of the contract tests below: two zones over the five patches.
std::unique_ptr<Simulator> two_zones_of_five_patches() {
  auto inner = five_patches();
  const ParameterSpace in = inner->parameters();
  return std::make_unique<ZonedSimulator>(std::move(inner), two_zones(in));
}

TEST(ZonedSimulator, SpaceDropsTheMembersAndAppendsOneParameterPerZone) {
  auto inner = five_patches();
  const ParameterSpace in = inner->parameters();
  ZonedSimulator z(std::move(inner), two_zones(in));
  const ParameterSpace& s = z.parameters();
  EXPECT_EQ(s.size(), in.size() - 2);
  EXPECT_FALSE(s.index("sigma0_01"));
  EXPECT_FALSE(s.index("sigma0_05"));
  ASSERT_TRUE(s.index("sigma0_03"));
  const Parameter& front = s[s.index_or_throw("sigma0_front")];
  const Parameter& m1 = in[in.index_or_throw("sigma0_01")];
  EXPECT_EQ(front.unit, m1.unit);
  EXPECT_EQ(front.family, m1.family);
  EXPECT_EQ(front.segment, 0);
  EXPECT_EQ(front.lower, m1.lower);
  EXPECT_EQ(front.upper, m1.upper);
  EXPECT_DOUBLE_EQ(front.nominal, m1.nominal);
  EXPECT_EQ(s.index_or_throw("sigma0_back"), s.size() - 1);

  // expand(): members take their zone's value, every other parameter keeps its own.
  Eigen::VectorXd theta = s.nominal();
  theta(s.index_or_throw("sigma0_front")) = 2.0e4;
  theta(s.index_or_throw("sigma0_back")) = 7.0e4;
  theta(s.index_or_throw("sigma0_03")) = 4.0e4;
  const Eigen::VectorXd full = z.expand(theta);
  ASSERT_EQ(full.size(), in.size());
  EXPECT_EQ(full(in.index_or_throw("sigma0_01")), 2.0e4);
  EXPECT_EQ(full(in.index_or_throw("sigma0_02")), 2.0e4);
  EXPECT_EQ(full(in.index_or_throw("sigma0_03")), 4.0e4);
  EXPECT_EQ(full(in.index_or_throw("sigma0_04")), 7.0e4);
  EXPECT_EQ(full(in.index_or_throw("sigma0_05")), 7.0e4);
  for (int i = 0; i < in.size(); ++i) {
    if (in[i].family == m1.family) continue;
    EXPECT_EQ(full(i), theta(s.index_or_throw(in[i].name))) << in[i].name;
  }
}

TEST(ZonedSimulator, RunsAndStepsAreTheInnerModelsWithTheExpandedTheta) {
  auto inner = five_patches();
  auto reference = five_patches();
  const ParameterSpace in = inner->parameters();
  ZonedSimulator z(std::move(inner), two_zones(in));
  Eigen::VectorXd theta = z.parameters().nominal();
  theta(z.parameters().index_or_throw("sigma0_front")) = 3.0e4;
  const Eigen::VectorXd full = z.expand(theta);

  const RunResult a = z.run(theta), b = reference->run(full);
  ASSERT_TRUE(a.status.ok()) << a.status.message;
  ASSERT_TRUE(b.status.ok()) << b.status.message;
  EXPECT_EQ((a.trajectory.values - b.trajectory.values).cwiseAbs().maxCoeff(), 0.0);
  // The reduced front zone ejects less from patches 1 and 2 than the back zone from 4 and 5
  // per unit area: the zone value reached the segments.
  State sa = z.initial_state(theta), sb = reference->initial_state(full);
  ASSERT_TRUE(z.advance(sa, theta, 0.4).ok());
  ASSERT_TRUE(reference->advance(sb, full, 0.4).ok());
  EXPECT_EQ((sa.x - sb.x).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((z.sample(sa, theta) - reference->sample(sb, full)).cwiseAbs().maxCoeff(), 0.0);

  const RunResult wrong = z.run(Eigen::VectorXd::Zero(3));
  EXPECT_EQ(wrong.status.code, StatusCode::kInvalidArgument);
}

TEST(ZonedSimulator, RefusesOverlappingEmptyOrMixedZones) {
  const ParameterSpace in = five_patches()->parameters();
  const int s1 = in.index_or_throw("sigma0_01"), s2 = in.index_or_throw("sigma0_02");
  EXPECT_THROW(ZonedSimulator(five_patches(), {{"a", {s1, s2}}, {"b", {s2}}}), std::invalid_argument);
  EXPECT_THROW(ZonedSimulator(five_patches(), {{"a", {}}}), std::invalid_argument);
  EXPECT_THROW(ZonedSimulator(five_patches(), {{"a", {s1, in.index_or_throw("period")}}}), std::invalid_argument);
  EXPECT_THROW(ZonedSimulator(five_patches(), {{"sigma0_03", {s1}}}), std::invalid_argument);
  EXPECT_THROW(ZonedSimulator(five_patches(), {{"a", {s1}}, {"a", {s2}}}), std::invalid_argument);
  EXPECT_THROW(ZonedSimulator(five_patches(), {{"a", {in.size()}}}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model

namespace sigmaheart::testing {
namespace {

INSTANTIATE_TEST_SUITE_P(ZonedSimulator, SimulatorContract,
                         ::testing::Values(ContractCase{"two_zones_of_five_patches", model::two_zones_of_five_patches}),
                         contract_case_name);

}  // namespace
}  // namespace sigmaheart::testing
