// Checkpoint and resume (estimation/checkpoint.h, estimation/interrupt.h): records survive a cut
// tail, belong to one run, and an estimator interrupted at any ensemble call and resumed from its
// checkpoint ends with the bits of an uninterrupted run while running only the missing members.
#include "estimation/checkpoint.h"
#include "estimation/ensemble.h"
#include "estimation/interrupt.h"
#include "estimation/ut_calibration.h"
#include "tests/support/bitwise_equal.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;
using sigmaheart::testing::indexed;

std::filesystem::path scratch(const std::string& name) {
  const auto dir = std::filesystem::path(SIGMAHEART_BINARY_DIR) / "test_tmp" / "checkpoint";
  std::filesystem::create_directories(dir);
  const auto p = dir / name;
  std::filesystem::remove(p);
  return p;
}

CheckpointOptions opts(const std::filesystem::path& path, bool resume, std::uint64_t fp = 42) {
  CheckpointOptions o;
  o.path = path;
  o.fingerprint = fp;
  o.resume = resume;
  return o;
}

using sigmaheart::testing::bitwise_equal;

TEST(MemberCheckpoint, RecordsReadBackBitForBitAndACutTailIsDropped) {
  const auto path = scratch("records.ckpt");
  const Eigen::Vector3d row(1.0 / 3.0, -2.5e-7, 1e300);
  {
    MemberCheckpoint c(opts(path, false));
    c.add(MemberCheckpoint::key("", 0, 0, 0), model::Status::Ok(), row);
    c.add(MemberCheckpoint::key("", 0, 0, 1), model::Status::Error(model::StatusCode::kDiverged, "Newton"),
          Eigen::VectorXd::Constant(3, std::numeric_limits<double>::quiet_NaN()));
    c.add(MemberCheckpoint::key("case:b", 2, 7, 5), model::Status::Ok(), 2.0 * row);
    c.flush();
    EXPECT_EQ(c.written(), 3);
  }
  {
    MemberCheckpoint c(opts(path, true));
    ASSERT_EQ(c.loaded(), 3);
    const auto* r0 = c.find(MemberCheckpoint::key("", 0, 0, 0));
    ASSERT_NE(r0, nullptr);
    EXPECT_TRUE(bitwise_equal(r0->row, row));
    const auto* r1 = c.find(MemberCheckpoint::key("", 0, 0, 1));
    ASSERT_NE(r1, nullptr);
    EXPECT_EQ(r1->status.code, model::StatusCode::kDiverged);
    EXPECT_EQ(r1->status.message, "Newton");
    EXPECT_EQ(c.find(MemberCheckpoint::key("", 0, 0, 2)), nullptr);
  }
  // A kill in the middle of an append leaves a record cut short: it is dropped, the file is cut
  // back to the last whole record, and appending goes on after it.
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, size - 5);
  {
    MemberCheckpoint c(opts(path, true));
    EXPECT_EQ(c.loaded(), 2);
    EXPECT_EQ(c.find(MemberCheckpoint::key("case:b", 2, 7, 5)), nullptr);
    c.add(MemberCheckpoint::key("x", 0, 0, 0), model::Status::Ok(), row);
    c.flush();
  }
  MemberCheckpoint again(opts(path, true));
  EXPECT_EQ(again.loaded(), 3);
  EXPECT_NE(again.find(MemberCheckpoint::key("x", 0, 0, 0)), nullptr);
  // A corrupted byte inside a record stops the reading there (checksum).
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);
    f.put('\x7f');
  }
  MemberCheckpoint corrupt(opts(path, true));
  EXPECT_EQ(corrupt.loaded(), 0);
}

TEST(MemberCheckpoint, BelongsToOneRunAndAFreshStartForgetsIt) {
  const auto path = scratch("owner.ckpt");
  {
    MemberCheckpoint c(opts(path, false, 1));
    c.add("k", model::Status::Ok(), Eigen::Vector2d(1, 2));
    c.flush();
  }
  EXPECT_THROW(MemberCheckpoint(opts(path, true, 2)), CheckpointMismatch);
  { MemberCheckpoint fresh(opts(path, false, 1)); }
  EXPECT_EQ(MemberCheckpoint(opts(path, true, 1)).loaded(), 0);
  MemberCheckpoint c(opts(path, true, 1));
  c.remove();
  EXPECT_FALSE(std::filesystem::exists(path));
}

// theta -> z with a counter of evaluations and an optional interrupt after `interrupt_after` runs.
struct CountingMap {
  std::shared_ptr<std::atomic<int>> runs = std::make_shared<std::atomic<int>>(0);
  int interrupt_after = -1;
  FunctionModel model(int p, int m) const {
    auto counter = runs;
    const int after = interrupt_after;
    return FunctionModel(p, m, [counter, after, m](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
      if (++*counter == after) request_interrupt(SIGINT);
      for (int i = 0; i < m; ++i) z(i) = std::exp(0.3 * (i + 1) * t(i % t.size())) + t.sum() * (i + 1);
      if (t(0) > 5.0) return model::Status::Error(model::StatusCode::kDiverged, "too large");
      return model::Status::Ok();
    });
  }
};

TEST(EnsembleCheckpoint, AnInterruptedEnsembleKeepsItsFinishedMembersAndResumesToTheSameRows) {
  clear_interrupt();
  const auto path = scratch("ensemble.ckpt");
  Eigen::MatrixXd thetas(40, 2);
  for (int i = 0; i < 40; ++i) thetas.row(i) << 0.15 * i, std::sin(i);
  thetas(5, 0) = 6.0;  // a failed member is recorded as failed

  CountingMap plain;
  EnsembleOptions serial;
  serial.backend = Backend::kSerial;
  const EnsembleResult reference = Ensemble(plain.model(2, 3), serial).evaluate(thetas);

  CountingMap interrupted;
  interrupted.interrupt_after = 13;
  {
    MemberCheckpoint c(opts(path, false));
    EnsembleOptions o = serial;
    o.checkpoint = &c;
    o.checkpoint_batch = 8;
    Ensemble e(interrupted.model(2, 3), o);
    try {
      e.evaluate(thetas);
      FAIL() << "no Interrupted";
    } catch (const Interrupted& i) {
      EXPECT_EQ(i.signal, SIGINT);
    }
    EXPECT_EQ(c.written(), 13);  // batch 1 (8) and the 5 members of batch 2 that ran
  }
  clear_interrupt();
  EXPECT_EQ(interrupted.runs->load(), 13);

  for (int threads : {1, 2}) {
    CountingMap resumed;
    MemberCheckpoint c(opts(path, true));
    EnsembleOptions o = serial;
    if (threads > 1) {
      o.backend = Backend::kThreads;
      o.threads = threads;
    }
    o.checkpoint = &c;
    Ensemble e(resumed.model(2, 3), o);
    const EnsembleResult r = e.evaluate(thetas);
    EXPECT_EQ(resumed.runs->load(), threads == 1 ? 27 : 0) << "threads " << threads;
    EXPECT_EQ(e.reused_members(), threads == 1 ? 13 : 40);
    EXPECT_TRUE(bitwise_equal(r.Z.topRows(5), reference.Z.topRows(5)));
    EXPECT_TRUE(bitwise_equal(r.Z.bottomRows(34), reference.Z.bottomRows(34)));
    EXPECT_EQ(r.status[5].code, model::StatusCode::kDiverged);
    EXPECT_EQ(r.status[5].message, reference.status[5].message);
  }
}

observers::ObservationSet observations(const Eigen::VectorXd& y, double sd) {
  observers::ObservationSet obs;
  for (int i = 0; i < y.size(); ++i) {
    obs.names.push_back(indexed("o", i));
    obs.units.push_back("1");
  }
  obs.y = y;
  obs.R = Eigen::MatrixXd::Identity(y.size(), y.size()) * sd * sd;
  return obs;
}

// An iterated UT calibration interrupted in several places and resumed each time ends with the
// bits of the uninterrupted run, and together the runs evaluate each member once.
TEST(EnsembleCheckpoint, AnIteratedCalibrationInterruptedAnywhereResumesToTheUninterruptedBits) {
  clear_interrupt();
  Prior prior;
  for (int j = 0; j < 3; ++j) {
    prior.parameters.push_back(PriorParameter::gaussian(indexed("t", j), "1", 0.1, 0.5, SpreadKind::kEta, {}));
  }
  CountingMap truth_map;
  Eigen::VectorXd y(5);
  truth_map.model(3, 5).evaluate(Eigen::Vector3d(0.7, -0.4, 0.9), y);
  UtOptions uo;
  uo.mode = UtMode::kMap;
  uo.max_iterations = 40;
  uo.ensemble.backend = Backend::kSerial;

  CountingMap plain;
  const UtSummary reference = UtCalibration(plain.model(3, 5), prior, observations(y, 0.01), uo).run();
  ASSERT_EQ(reference.termination, UtTermination::kConverged) << reference.message;
  const int total = plain.runs->load();
  ASSERT_GT(total, 20);

  const auto path = scratch("ut.ckpt");
  std::filesystem::remove(path);
  int ran = 0;
  bool resume = false;
  // Interrupted after 5, then 4, then 6 further runs; the fourth run finishes.
  for (int after : {5, 4, 6, -1}) {
    CountingMap m;
    m.interrupt_after = after;
    MemberCheckpoint c(opts(path, resume));
    UtOptions o = uo;
    o.ensemble.checkpoint = &c;
    o.ensemble.checkpoint_batch = 4;
    const FunctionModel fm = m.model(3, 5);
    UtCalibration cal(fm, prior, observations(y, 0.01), o);
    if (after > 0) {
      EXPECT_THROW(cal.run(), Interrupted);
      clear_interrupt();
      ran += m.runs->load();
      resume = true;
      continue;
    }
    const UtSummary s = cal.run();
    ran += m.runs->load();
    EXPECT_EQ(s.termination, reference.termination);
    EXPECT_TRUE(bitwise_equal(s.eta_mean, reference.eta_mean));
    EXPECT_TRUE(bitwise_equal(s.eta_covariance, reference.eta_covariance));
    EXPECT_EQ(s.iterations.size(), reference.iterations.size());
  }
  // Members interrupted before they ran are run later; each member that ran is recorded, so the
  // four runs together evaluate no more than the uninterrupted one (plus the centre runs outside
  // ensembles, none in this mode) .
  EXPECT_EQ(ran, total);
}

}  // namespace
}  // namespace sigmaheart::estimation
