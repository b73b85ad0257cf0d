// The fit report's writers (app/io/fit_report_io.h): JSON and an HDF5 group, in display units.
#include "app/io/fit_report_io.h"

#include "model/units.h"
#include "test_support.h"
#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace sigmaheart::app::io {
namespace {

using sigmaheart::testing::scratch_dir;

constexpr double kMl = 1e-6;
constexpr double kMmHg = model::units::kMmHg;

// A cosine beat of 20 frames: V in [50, 120] mL, P in [5, 120] mmHg; the fit misses P by 6 noise
// std on every frame (a discrepancy spread over the cycle) and V by 0.5 std.
struct Case {
  observers::ObservationSet obs;
  Eigen::VectorXd z;
  estimation::FitReport report;
  Case() {
    const int n = 20;
    obs.frame_times = Eigen::VectorXd::LinSpaced(n, 0.0, 0.8 * (n - 1) / n);
    obs.y.resize(2 * n);
    Eigen::VectorXd sd(2 * n);
    for (int k = 0; k < n; ++k) {
      const double c = 1 - std::cos(2 * std::numbers::pi * k / n);
      obs.names.push_back("V_lv@f" + std::to_string(100 + k).substr(1));
      obs.units.push_back("m^3");
      obs.y(k) = (120 - 35 * c) * kMl;
      sd(k) = 2 * kMl;
    }
    for (int k = 0; k < n; ++k) {
      const double c = 1 - std::cos(2 * std::numbers::pi * k / n);
      obs.names.push_back("P_lv@f" + std::to_string(100 + k).substr(1));
      obs.units.push_back("Pa");
      obs.y(n + k) = (5 + 57.5 * c) * kMmHg;
      sd(n + k) = 1 * kMmHg;
    }
    obs.R = sd.array().square().matrix().asDiagonal();
    z = obs.y;
    z.head(n).array() += 1 * kMl;
    z.tail(n).array() -= 6 * kMmHg;
    const Eigen::Matrix2d P = (Eigen::Matrix2d() << 0.04, 0.0396, 0.0396, 0.04).finished();
    report = estimation::make_fit_report(obs, z, estimation::PosteriorSpread{{"a", "b"}, P, Eigen::Vector2d(1.0, 0.21)});
  }
};

TEST(FitReportIo, WritesTheJsonInDisplayUnits) {
  const Case c;
  nlohmann::ordered_json j;
  add_fit_report_json(j, c.report);
  const auto& r = j.at("fit_report");
  EXPECT_EQ(r.at("summary"), c.report.summary);
  ASSERT_EQ(r.at("channels").size(), 2u);
  EXPECT_EQ(r.at("channels")[0].at("unit"), "mL");
  EXPECT_NEAR(r.at("channels")[0].at("rms_residual").get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(r.at("channels")[1].at("rms_noise_std").get<double>(), 6.0, 1e-9);
  EXPECT_EQ(r.at("channels")[1].at("unit"), "mmHg");
  const auto& idx = r.at("indices");
  ASSERT_EQ(idx.size(), 6u);
  EXPECT_EQ(idx[0].at("name"), "EDV");
  EXPECT_NEAR(idx[0].at("observed").get<double>(), 120.0, 1e-9);
  EXPECT_NEAR(idx[0].at("error").get<double>(), 1.0, 1e-9);
  EXPECT_EQ(idx[3].at("unit"), "%");
  EXPECT_NEAR(idx[3].at("observed").get<double>(), 100.0 * 70 / 120, 1e-9);
  EXPECT_NEAR(idx[4].at("error").get<double>(), -6.0, 1e-9);  // P_max in mmHg
  ASSERT_EQ(r.at("discrepancy").size(), 1u);
  EXPECT_EQ(r.at("discrepancy")[0].at("channel"), "P_lv");
  EXPECT_EQ(r.at("identifiability").at("uninformed"), std::vector<std::string>{"b"});
  EXPECT_NEAR(r.at("identifiability").at("correlated")[0].at("rho").get<double>(), 0.99, 1e-12);
}

TEST(FitReportIo, WritesAnHdf5GroupTheReaderReadsBack) {
  const Case c;
  const auto path = scratch_dir() / "report.h5";
  {
    Hdf5Writer h5(path);
    write_fit_report_h5(h5, "/fit_report", c.report);
    h5.commit();
  }
  Hdf5Reader r(path);
  EXPECT_EQ(r.string_attribute("/fit_report", "summary"), c.report.summary);
  EXPECT_EQ(r.read_strings("/fit_report/channels/names"), (std::vector<std::string>{"V_lv", "P_lv"}));
  EXPECT_NEAR(r.read_vector("/fit_report/channels/rms_normalised")(0), 0.5, 1e-12);
  EXPECT_EQ(r.string_attribute("/fit_report/channels/rms_normalised", "units"), "noise std");
  EXPECT_NEAR(r.read_vector("/fit_report/curves/P_lv/observed")(10), 120.0, 1e-9);
  EXPECT_EQ(r.string_attribute("/fit_report/curves/P_lv/observed", "units"), "mmHg");
  EXPECT_NEAR(r.read_vector("/fit_report/curves/P_lv/normalised_residual")(3), 6.0, 1e-9);
  EXPECT_EQ(r.read_vector("/fit_report/phases/time").size(), 20);
  EXPECT_EQ(r.read_strings("/fit_report/phases/names").size(), 4u);
  const Eigen::VectorXd share = r.read_vector("/fit_report/discrepancy/P_lv/share");
  EXPECT_NEAR(share.sum(), 1.0, 1e-12);
  EXPECT_NEAR(r.read_vector("/fit_report/indices/observed")(1), 50.0, 1e-9);
  EXPECT_NEAR(r.read_matrix("/fit_report/identifiability/correlation")(0, 1), 0.99, 1e-12);
  EXPECT_EQ(r.read_strings("/fit_report/identifiability/correlated_a"), std::vector<std::string>{"a"});
}

// A one-parameter linear problem z = (t, 2t) with a N(0, 1) prior: the MAP and the layout.
TEST(FitReportIo, WritesTheLeastSquaresSummary) {
  const sigmaheart::testing::FunctionModel fm(1, 2, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z << t(0), 2 * t(0);
    return model::Status::Ok();
  });
  estimation::Prior prior;
  prior.parameters.push_back(estimation::PriorParameter::gaussian("t0", "Pa", 0.0, 1.0, estimation::SpreadKind::kEta, {}));
  estimation::LeastSquaresOptions o;
  o.ensemble.backend = estimation::Backend::kSerial;
  const auto s = estimation::solve_map(
      fm, prior, sigmaheart::testing::observations_for(fm, Eigen::Vector2d(1.0, 2.0), Eigen::Matrix2d::Identity()), o);
  ASSERT_TRUE(s.ok()) << s.message;
  // Posterior precision 1 + 1 + 4 = 6, mean (1 + 4) / 6.
  const auto path = scratch_dir() / "map.h5";
  {
    Hdf5Writer h5(path);
    write_least_squares_h5(h5, "/map", s, prior.units());
    h5.commit();
  }
  Hdf5Reader r(path);
  EXPECT_EQ(r.string_attribute("/map", "termination"), "converged");
  EXPECT_NEAR(r.read_vector("/map/theta")(0), 5.0 / 6.0, 1e-9);
  EXPECT_NEAR(r.read_matrix("/map/eta_covariance")(0, 0), 1.0 / 6.0, 1e-9);
  EXPECT_EQ(r.read_strings("/map/units"), std::vector<std::string>{"Pa"});
  EXPECT_EQ(r.read_vector("/map/fit/estimate").size(), 2);
  nlohmann::ordered_json j;
  add_least_squares_json(j, s, prior.units());
  EXPECT_NEAR(j.at("map").at("parameters").at("t0").at("value").get<double>(), 5.0 / 6.0, 1e-9);
  EXPECT_EQ(j.at("map").at("termination"), "converged");
}

}  // namespace
}  // namespace sigmaheart::app::io
