#include "estimation/forward_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace sigmaheart::estimation {
namespace {

// x(t) = a + b t + c t^2 on t in [0, 1]; diverges when a > 5.
class LineSimulator final : public model::Simulator {
 public:
  LineSimulator()
      : space_({{"a", "1", 1.0, -10.0, 10.0, ""},
                {"b", "1", 2.0, -10.0, 10.0, ""},
                {"c", "1", 3.0, 0.0, 10.0, ""}}) {}
  std::string name() const override { return "line"; }
  const model::ParameterSpace& parameters() const override { return space_; }
  std::vector<model::Channel> channels() const override { return {{"x", "1", ""}}; }
  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override {
    ++runs;
    model::RunResult out;
    if (theta(0) > 5) {
      out.status = model::Status::Error(model::StatusCode::kDiverged, "a too large at t = 0.5 s");
      return out;
    }
    out.trajectory.times = Eigen::VectorXd::LinSpaced(11, 0.0, 1.0);
    out.trajectory.channels = channels();
    const auto& t = out.trajectory.times.array();
    out.trajectory.values = (theta(0) + theta(1) * t + theta(2) * t.square()).matrix();
    return out;
  }
  std::unique_ptr<model::Simulator> clone() const override {
    return std::make_unique<LineSimulator>(*this);
  }
  int runs = 0;

 private:
  model::ParameterSpace space_;
};

class EndsObserver final : public observers::Observer {
 public:
  std::vector<model::Channel> outputs() const override {
    return {{"x_start", "1", ""}, {"x_end", "1", ""}};
  }
  model::Status observe(const model::Trajectory& tr, Eigen::Ref<Eigen::VectorXd> z) const override {
    if (!tr.has_channel("x")) return model::Status::Error(model::StatusCode::kBadOutput, "no x");
    const Eigen::VectorXd x = tr.channel("x");
    z << x(0), x(x.size() - 1);
    return model::Status::Ok();
  }
  std::unique_ptr<observers::Observer> clone() const override {
    return std::make_unique<EndsObserver>();
  }
};

TEST(SimulatorForwardModel, EmbedsEstimatedParametersIntoTheBaseVector) {
  const LineSimulator sim;
  const EndsObserver obs;
  SimulatorForwardModel fm(sim, obs, std::vector<std::string>{"c", "a"});
  EXPECT_EQ(fm.input_size(), 2);
  EXPECT_EQ(fm.input_names(), (std::vector<std::string>{"c", "a"}));
  const Eigen::Vector2d theta(0.5, -1.0);  // c = 0.5, a = -1, b stays 2
  EXPECT_NEAR(fm.full_theta(theta)(1), 2.0, 0.0);
  Eigen::VectorXd z(2);
  ASSERT_TRUE(fm.evaluate(theta, z).ok());
  EXPECT_NEAR(z(0), -1.0, 1e-15);
  EXPECT_NEAR(z(1), -1.0 + 2.0 + 0.5, 1e-14);
}

TEST(SimulatorForwardModel, OutOfBoundsAndSimulatorFailuresAreStatuses) {
  const LineSimulator sim;
  const EndsObserver obs;
  SimulatorForwardModel fm(sim, obs, {0, 2}, sim.parameters().nominal());
  Eigen::VectorXd z(2);
  const model::Status bounds = fm.evaluate(Eigen::Vector2d(1.0, -0.1), z);  // c < 0
  EXPECT_EQ(bounds.code, model::StatusCode::kOutOfBounds);
  const model::Status diverged = fm.evaluate(Eigen::Vector2d(6.0, 1.0), z);
  EXPECT_EQ(diverged.code, model::StatusCode::kDiverged);
  EXPECT_NE(diverged.message.find("a too large"), std::string::npos);
  const model::Status wrong = fm.evaluate(Eigen::Vector3d(1.0, 1.0, 1.0), z);
  EXPECT_EQ(wrong.code, model::StatusCode::kInvalidArgument);
  EXPECT_THROW(SimulatorForwardModel(sim, obs, {0, 0}, sim.parameters().nominal()),
               std::invalid_argument);
  EXPECT_THROW(SimulatorForwardModel(sim, obs, std::vector<std::string>{"bb"}),
               std::invalid_argument);
}

TEST(SimulatorForwardModel, ClonesGiveTheSameNumbers) {
  const LineSimulator sim;
  const EndsObserver obs;
  SimulatorForwardModel fm(sim, obs, std::vector<std::string>{"b"});
  auto copy = fm.clone();
  Eigen::VectorXd z1(2), z2(2);
  ASSERT_TRUE(fm.evaluate(Eigen::VectorXd::Constant(1, 0.25), z1).ok());
  ASSERT_TRUE(copy->evaluate(Eigen::VectorXd::Constant(1, 0.25), z2).ok());
  EXPECT_NEAR((z1 - z2).norm(), 0.0, 0.0);
  EXPECT_NEAR(z1(1), 1.0 + 0.25 + 3.0, 1e-14);
  EXPECT_EQ(fm.last_run().trajectory.samples(), 11);
}

}  // namespace
}  // namespace sigmaheart::estimation
