#include "observers/composite.h"

#include "analytic_beat.h"
#include "observers/curve_sampler.h"
#include "observers/global_indices.h"

#include <gtest/gtest.h>

namespace sigmaheart::observers {
namespace {

using testing::CosineBeat;
using testing::sample_beat;

std::unique_ptr<Observer> volume_curve(const std::vector<model::Channel>& available) {
  CurveSamplerOptions o;
  o.frame_times = Eigen::VectorXd::LinSpaced(30, 0.0, 0.8 * 29 / 30);
  return std::make_unique<CurveSampler>(o, available);
}

TEST(CompositeObserver, ConcatenatesThePartsInOrder) {
  const CosineBeat b;
  const auto tr = sample_beat(b.channels(), b.period, 400, true);
  std::vector<std::unique_ptr<Observer>> parts;
  parts.push_back(std::make_unique<GlobalIndices>(GlobalIndicesOptions{}, tr.channels));
  parts.push_back(volume_curve(tr.channels));
  const CompositeObserver all(std::move(parts));
  ASSERT_EQ(all.size(), 14 + 30);
  EXPECT_EQ(all.outputs()[14].name, "V_lv@f00");

  Eigen::VectorXd z(all.size()), zi(14), zc(30);
  ASSERT_TRUE(all.observe(tr, z).ok());
  ASSERT_TRUE(all.part(0).observe(tr, zi).ok());
  ASSERT_TRUE(all.part(1).observe(tr, zc).ok());
  EXPECT_EQ(z.head(14), zi);
  EXPECT_EQ(z.tail(30), zc);

  const auto copy = all.clone();
  Eigen::VectorXd z2(all.size());
  ASSERT_TRUE(copy->observe(tr, z2).ok());
  EXPECT_EQ(z, z2);
}

TEST(CompositeObserver, RefusesTwoPartsWithTheSameOutputName) {
  const std::vector<model::Channel> available = {{"V_lv", "m^3", ""}};
  std::vector<std::unique_ptr<Observer>> parts;
  parts.push_back(volume_curve(available));
  parts.push_back(volume_curve(available));
  try {
    CompositeObserver c(std::move(parts));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'V_lv@f00'"), std::string::npos) << e.what();
  }
}

TEST(CompositeObserver, PrefixesAFailingPartsStatus) {
  const CosineBeat b;
  const auto tr = sample_beat(b.channels(), b.period, 400, true);
  std::vector<std::unique_ptr<Observer>> parts;
  parts.push_back(volume_curve(tr.channels));
  parts.push_back(std::make_unique<GlobalIndices>(GlobalIndicesOptions{}, tr.channels));
  const CompositeObserver all(std::move(parts));
  model::Trajectory flat = tr;
  flat.values.col(0).setConstant(1e-4);
  Eigen::VectorXd z(all.size());
  const auto s = all.observe(flat, z);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message.find("part 1"), std::string::npos) << s.message;
}

}  // namespace
}  // namespace sigmaheart::observers
