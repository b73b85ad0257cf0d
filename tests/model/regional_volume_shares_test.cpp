// Tests of model/regional_volume_shares.h on the regional lumped ventricle: the reference shares
// leave every channel unchanged, other shares move only the regional volumes (which still sum to
// the cavity volume, and equal V omega_p when every patch keeps its area share), bad shares are
// refused, and the simulator contract.
#include "model/regional_volume_shares.h"

#include "model/lumped/regional.h"
#include "tests/model/simulator_contract.h"

#include <gtest/gtest.h>

#include <memory>

namespace sigmaheart::model {
namespace {

std::unique_ptr<SteppableSimulator> five_patches(lumped::ActivationPattern pattern) {
  lumped::RegionalOptions o;
  o.area_shares = {0.3, 0.2, 0.2, 0.2, 0.1};
  o.activation = pattern;
  if (pattern == lumped::ActivationPattern::kExplicit) o.activation_times = {0.0, 0.03, 0.06, 0.09, 0.12};
  return std::make_unique<lumped::RegionalVentricle>(o);
}

Eigen::VectorXd other_shares() { return (Eigen::VectorXd(5) << 0.4, 0.3, 0.2, 0.1, 0.0).finished(); }

// The simulator of the contract tests below: five delayed patches reporting other_shares().
std::unique_ptr<Simulator> five_delayed_patches_other_shares() {
  auto inner = five_patches(lumped::ActivationPattern::kExplicit);
  const Eigen::VectorXd s = RegionalVolumeShares::reference_shares(*inner, inner->parameters().nominal());
  return std::make_unique<RegionalVolumeShares>(std::move(inner), other_shares(), s);
}

TEST(RegionalVolumeShares, TheReferenceSharesChangeNothing) {
  auto inner = five_patches(lumped::ActivationPattern::kExplicit);
  const Eigen::VectorXd theta = inner->parameters().nominal();
  const Eigen::VectorXd s = RegionalVolumeShares::reference_shares(*inner, theta);
  EXPECT_NEAR(s(0), 0.3, 1e-12);  // the area shares: every c_p = 1 in the relaxed initial state
  EXPECT_NEAR(s(4), 0.1, 1e-12);
  State a = inner->initial_state(theta);
  ASSERT_TRUE(inner->advance(a, theta, 0.2).ok());
  const Eigen::VectorXd z = inner->sample(a, theta);
  RegionalVolumeShares same(std::move(inner), s, s);
  const Eigen::VectorXd w = same.sample(a, theta);
  EXPECT_LE((w - z).cwiseAbs().maxCoeff(), 1e-14 * z.cwiseAbs().maxCoeff());
}

TEST(RegionalVolumeShares, OtherSharesMoveOnlyTheRegionalVolumesAndKeepTheirSum) {
  auto inner = five_patches(lumped::ActivationPattern::kExplicit);
  const Eigen::VectorXd theta = inner->parameters().nominal();
  const Eigen::VectorXd s = RegionalVolumeShares::reference_shares(*inner, theta);
  const RunResult plain = inner->clone()->run(theta);
  ASSERT_TRUE(plain.status.ok()) << plain.status.message;
  RegionalVolumeShares shared(std::move(inner), other_shares(), s);
  const RunResult r = shared.run(theta);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const std::vector<int> regional = RegionalVolumeShares::regional_channels(shared.channels());
  ASSERT_EQ(regional.size(), 5u);
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(r.trajectory.samples());
  for (int c : regional) sum += r.trajectory.values.col(c);
  const Eigen::VectorXd V = r.trajectory.channel("V_lv");
  EXPECT_LE((sum - V).cwiseAbs().maxCoeff(), 1e-13 * V.maxCoeff());
  EXPECT_LE((V - plain.trajectory.channel("V_lv")).cwiseAbs().maxCoeff(), 0.0);  // the mechanics unchanged
  EXPECT_EQ(r.trajectory.channel("V_seg05").cwiseAbs().maxCoeff(), 0.0);     // omega_5 = 0 holds nothing
  // With delays the patches trade area (c_p != 1), so V'_p differs from V omega_p during the beat.
  EXPECT_GT((r.trajectory.channel("V_seg01") - 0.4 * V).cwiseAbs().maxCoeff(), 1e-3 * V.maxCoeff());
}

TEST(RegionalVolumeShares, SynchronousPatchesReportTheCavityTimesTheirShare) {
  auto inner = five_patches(lumped::ActivationPattern::kSynchronous);
  const Eigen::VectorXd theta = inner->parameters().nominal();
  const Eigen::VectorXd s = RegionalVolumeShares::reference_shares(*inner, theta);
  RegionalVolumeShares shared(std::move(inner), other_shares(), s);
  State st = shared.initial_state(theta);
  ASSERT_TRUE(shared.advance(st, theta, 0.3).ok());
  const Eigen::VectorXd z = shared.sample(st, theta);
  for (int p = 0; p < 5; ++p) EXPECT_NEAR(z(8 + p), other_shares()(p) * z(0), 1e-12 * z(0)) << "patch " << p + 1;
}

TEST(RegionalVolumeShares, BadSharesAreRefused) {
  const Eigen::VectorXd s = Eigen::VectorXd::Constant(5, 0.2);
  auto make = [&](Eigen::VectorXd shares, Eigen::VectorXd reference) {
    RegionalVolumeShares r(five_patches(lumped::ActivationPattern::kSynchronous), std::move(shares), std::move(reference));
  };
  EXPECT_THROW(make(Eigen::VectorXd::Constant(4, 0.25), Eigen::VectorXd::Constant(4, 0.25)), std::invalid_argument);
  EXPECT_THROW(make((Eigen::VectorXd(5) << 0.5, 0.5, 0.2, 0.0, -0.2).finished(), s), std::invalid_argument);
  EXPECT_THROW(make(Eigen::VectorXd::Constant(5, 0.3), s), std::invalid_argument);
  EXPECT_THROW(make(s, Eigen::VectorXd::Zero(5)), std::invalid_argument);
  EXPECT_NO_THROW(make(other_shares(), s));
}

}  // namespace
}  // namespace sigmaheart::model

namespace sigmaheart::testing {
namespace {

INSTANTIATE_TEST_SUITE_P(RegionalVolumeShares, SimulatorContract,
                         ::testing::Values(ContractCase{"five_delayed_patches_other_shares",
                                                        model::five_delayed_patches_other_shares}),
                         contract_case_name);

}  // namespace
}  // namespace sigmaheart::testing
