// The rank context of run_cli (app/cli.h) without mpirun: a fake communicator plays rank 1 of 2
// and the exit code of the (absent) rank 0, so the contract of a non-root rank is checked
// in-process: it prints nothing, writes no file, and exits with the code all ranks agree on.
#include "app/cli.h"
#include "app/errors.h"
#include "estimation/parallel/communicator.h"

#include "../test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

namespace sigmaheart::app {
namespace {

using estimation::parallel::Communicator;
using estimation::parallel::SerialCommunicator;
using estimation::parallel::SharedCounter;
using namespace sigmaheart::testing;

// Rank 1 of 2 whose partner, rank 0, returns `root_code`. No collective but the exit-code
// agreement may be reached (the commands used here have no ensemble).
class SecondRank final : public Communicator {
 public:
  explicit SecondRank(int root_code) : root_code_(root_code) {}
  int rank() const override { return 1; }
  int size() const override { return 2; }
  void barrier() override {}
  using Communicator::broadcast;
  void broadcast(std::span<std::byte> data, int root) override {
    ASSERT_EQ(root, 0);
    ASSERT_EQ(data.size(), sizeof(int));  // only the root's exit code is broadcast
    std::memcpy(data.data(), &root_code_, sizeof(int));
  }
  std::vector<std::vector<std::byte>> all_gather(std::span<const std::byte>) override {
    ADD_FAILURE() << "unexpected all_gather";
    return {};
  }
  int all_reduce_max(int value) override { return std::max(value, root_code_); }
  std::unique_ptr<SharedCounter> make_counter() override { return SerialCommunicator().make_counter(); }
  bool counter_from_threads() const override { return true; }

 private:
  int root_code_;
};

std::string healthy() { return std::string(SIGMAHEART_SOURCE_DIR) + "/configs/healthy.yaml"; }

int run(const std::vector<std::string>& args, Communicator& comm, std::string& out, std::string& err) {
  std::vector<const char*> argv = {"sigmaheart"};
  for (const auto& a : args) argv.push_back(a.c_str());
  std::ostringstream o, e;
  const int code = run_cli(static_cast<int>(argv.size()), argv.data(), o, e, comm);
  out = o.str();
  err = e.str();
  return code;
}

TEST(CliRanks, ANonRootRankPrintsNothingWritesNothingAndFollowsTheRootsFailure) {
  const auto dir = scratch_dir();
  SecondRank rank1(kExitRuntimeFailure);
  std::string out, err;
  const int code = run({"simulate", healthy(), "-o", (dir / "r.h5").string(), "--summary",
                        (dir / "r.json").string()},
                       rank1, out, err);
  EXPECT_EQ(code, kExitRuntimeFailure);
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");  // its own run succeeded: rank 0 reports the failure
  EXPECT_FALSE(std::filesystem::exists(dir / "r.h5"));
  EXPECT_FALSE(std::filesystem::exists(dir / "r.json"));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

TEST(CliRanks, ARankThatFailsAloneReportsItsErrorWithItsRank) {
  const auto dir = scratch_dir();
  SecondRank rank1(kExitOk);
  std::string out, err;
  const int code =
      run({"simulate", healthy(), "-o", (dir / "r.h5").string(), "--set", "sigma0=-1"}, rank1, out, err);
  EXPECT_EQ(code, kExitBadInput);
  EXPECT_EQ(out, "");
  EXPECT_EQ(err.rfind("rank 1: error: ", 0), 0u) << err;
  EXPECT_NE(err.find("sigma0"), std::string::npos) << err;
}

TEST(CliRanks, OneRankRunsAsWithoutCommunicator) {
  const auto dir = scratch_dir();
  SerialCommunicator one;
  std::string out, err;
  EXPECT_EQ(run({"--log-level", "off", "simulate", healthy(), "-o", (dir / "r.h5").string()}, one, out, err),
            kExitOk)
      << err;
  EXPECT_TRUE(std::filesystem::exists(dir / "r.h5"));
}

}  // namespace
}  // namespace sigmaheart::app
