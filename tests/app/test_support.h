// Shared helpers of the app tests: a scratch directory per test, files written from text, and a
// tiny stand-in simulator ("test-beat") registered beside the real ones (in a registry of the
// tests' own, handed to run_cli) so that command tests run in milliseconds and can fail on demand.
#pragma once

#include "app/cli.h"
#include "app/errors.h"
#include "model/registry.h"
#include "model/simulator.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

namespace sigmaheart::testing {

// A fresh directory named after the running test, under the build tree.
inline std::filesystem::path scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir = std::filesystem::path(SIGMAHEART_BINARY_DIR) / "tests-app-scratch" /
                                    (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Temporary files (io::AtomicFile's ".<name>.sigmaheart-<pid>-<n>.tmp", or any "*.tmp") in `dir`.
inline int temporaries_in(const std::filesystem::path& dir) {
  int n = 0;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".tmp") == 0) ++n;
  }
  return n;
}

inline std::filesystem::path write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// One beat of period 0.8 s: a cosine volume curve and a pressure pulse. Parameters: V_ed [m^3]
// (end-diastolic volume), EF [1] (ejection fraction), P_peak [Pa] and `fail` [1] (> 0.5: the run
// reports kDiverged without a trajectory, except in (0.8, 0.86): kNotPeriodic with its last beat, and
// in (0.86, 0.89): kDiverged at t = 0.3 s with the beat's samples up to there, the last one NaN).
// Channels V_lv [m^3], P_lv [Pa], phase [1].
class BeatStandIn final : public model::Simulator {
 public:
  explicit BeatStandIn(model::ParameterSpace p, int samples) : params_(std::move(p)), samples_(samples) {}

  static model::ParameterSpace defaults() {
    return model::ParameterSpace({
        {"V_ed", "m^3", 1.4e-4, 1e-5, 5e-4, "end-diastolic volume"},
        {"EF", "1", 0.6, 0.05, 0.9, "ejection fraction"},
        {"P_peak", "Pa", 16000.0, 1000.0, 40000.0, "peak LV pressure"},
        {"fail", "1", 0.0, 0.0, 1.0, "> 0.5 makes the run fail ((0.8, 0.86): not periodic; (0.86, 0.89): diverged mid-beat)"},
    });
  }

  std::string name() const override { return "test-beat"; }
  const model::ParameterSpace& parameters() const override { return params_; }
  std::vector<model::Channel> channels() const override {
    return {{"V_lv", "m^3", "volume"}, {"P_lv", "Pa", "pressure"}, {"phase", "1", "phase"}};
  }
  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override {
    model::RunResult r;
    const bool not_periodic = theta(3) > 0.8 && theta(3) < 0.86;
    const bool mid_beat = theta(3) > 0.86 && theta(3) < 0.89;
    if (theta(3) > 0.5 && !not_periodic && !mid_beat) {
      r.status = model::Status::Error(model::StatusCode::kDiverged, "Newton diverged at t = 0.3 s");
      return r;
    }
    const double period = 0.8;
    r.trajectory.channels = channels();
    r.trajectory.times = Eigen::VectorXd::LinSpaced(samples_, 0.0, period);
    r.trajectory.values.resize(samples_, 3);
    for (int k = 0; k < samples_; ++k) {
      const double phi = 2.0 * M_PI * r.trajectory.times(k) / period;
      const double s = 0.5 * (1.0 - std::cos(phi));  // 0 at ED, 1 at ES
      r.trajectory.values(k, 0) = theta(0) * (1.0 - theta(1) * s);
      r.trajectory.values(k, 1) = 1000.0 + (theta(2) - 1000.0) * std::pow(std::sin(phi / 2.0), 4);
      r.trajectory.values(k, 2) = phi < M_PI ? 2.0 : 0.0;
    }
    r.info.beats = 3;
    r.info.period = period;
    if (mid_beat) {
      // The samples up to t = 0.3 s, then one that went non-finite.
      int k = 0;
      while (r.trajectory.times(k) <= 0.3 + 1e-12) ++k;
      r.trajectory.times.conservativeResize(k + 1);
      r.trajectory.values.conservativeResize(k + 1, Eigen::NoChange);
      r.trajectory.values(k, 0) = std::numeric_limits<double>::quiet_NaN();
      r.status = model::Status::Error(model::StatusCode::kDiverged, "Newton diverged at t = 0.3 s");
      return r;
    }
    r.info.periodicity_change = 1e-4;
    if (not_periodic) {
      r.info.periodicity_change = 0.02;
      r.status = model::Status::Error(model::StatusCode::kNotPeriodic,
                                      "not periodic after 3 beats: beat-to-beat change 0.02 > periodic_tolerance 0.001");
    }
    return r;
  }
  std::unique_ptr<model::Simulator> clone() const override {
    return std::make_unique<BeatStandIn>(*this);
  }

 private:
  model::ParameterSpace params_;
  int samples_;
};

// Registers "test-beat" (numerics: {samples: int >= 10}).
inline void register_stand_in(model::ModelRegistry& registry) {
  registry.add(model::ModelSetup{
      "test-beat", "stand-in beat for tests", [](const model::OptionReader& numerics) {
        numerics.check_keys({"samples"});
        const int samples = numerics.integer("samples", 81);
        if (samples < 10) numerics.fail("samples", "numerics.samples: expected an integer >= 10");
        return model::ModelBuild(
            BeatStandIn::defaults(),
            [samples](const model::ParameterSpace& p) -> std::unique_ptr<model::Simulator> {
              return std::make_unique<BeatStandIn>(p, samples);
            });
      }});
}

// `base` with each registration of `add` applied: a test file's set of models, built once as
//   static const model::ModelRegistry registry = with_models(model::builtin_models(), {register_stand_in});
inline model::ModelRegistry with_models(model::ModelRegistry base,
                                        std::initializer_list<void (*)(model::ModelRegistry&)> add) {
  for (auto* registration : add) registration(base);
  return base;
}

// The built-in models plus "test-beat".
inline const model::ModelRegistry& stand_in_models() {
  static const model::ModelRegistry registry = with_models(model::builtin_models(), {register_stand_in});
  return registry;
}

// One in-process run of the command line with its exit code and captured streams, with
// stand_in_models(), so configs may name "test-beat".
struct CliRun {
  int code;
  std::string out;
  std::string err;
};

inline CliRun cli(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, stand_in_models());
  return {code, out.str(), err.str()};
}

// The message of the app::InputError that `f` throws ("" when it does not throw).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const app::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace sigmaheart::testing
