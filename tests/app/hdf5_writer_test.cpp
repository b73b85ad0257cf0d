// Results files: atomic HDF5 writing and readback (app/io/hdf5_writer.h), CSV and JSON
// (app/io/results.h).
#include "app/io/hdf5_writer.h"
#include "app/io/results.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace sigmaheart::app::io {
namespace {

using sigmaheart::testing::read_file;
using sigmaheart::testing::scratch_dir;
using sigmaheart::testing::temporaries_in;
using sigmaheart::testing::write_file;

model::Trajectory small_trajectory() {
  model::Trajectory t;
  t.times = Eigen::Vector3d(0.0, 0.5, 1.0);
  t.channels = {{"V_lv", "m^3", "volume"}, {"P_lv", "Pa", "pressure"}, {"phase", "1", ""}};
  t.values.resize(3, 3);
  t.values << 1.2e-4, 1000.0, 0, 1.0e-4, 13332.2, 2, 0.6e-4, 133.322, 0;
  return t;
}

TEST(Hdf5Writer, WritesAtomicallyAndReadsBackDatasetsWithUnits) {
  const auto dir = scratch_dir();
  const auto path = dir / "out" / "r.h5";  // the directory is created
  {
    Hdf5Writer w(path);
    EXPECT_EQ(temporaries_in(dir / "out"), 1);  // the unique hidden temporary
    EXPECT_FALSE(std::filesystem::exists(path));
    w.write_vector("/a/b/x", Eigen::Vector3d(1.0, 2.0, 3.5), "mL");
    w.write_text("/config", "name: x\n");
    w.write_strings("/names", {"alpha", "beta"});
    Eigen::MatrixXd m(2, 3);
    m << 1, 2, 3, 4, 5, 6;
    w.write_matrix("/m", m, "Pa", {"r0", "r1"}, {"c0", "c1", "c2"});
    w.set_attribute("/", "kind", "simulate");
    w.set_attribute("/", "threads", 4);
    w.set_attribute("/", "empty", std::vector<std::string>{});
    w.commit();
  }
  EXPECT_TRUE(std::filesystem::exists(path));
  EXPECT_EQ(temporaries_in(dir / "out"), 0);

  Hdf5Reader r(path);
  EXPECT_EQ(r.read_vector("/a/b/x"), Eigen::Vector3d(1.0, 2.0, 3.5));
  EXPECT_EQ(r.string_attribute("/a/b/x", "units"), "mL");
  EXPECT_EQ(r.read_text("/config"), "name: x\n");
  EXPECT_EQ(r.read_strings("/names"), (std::vector<std::string>{"alpha", "beta"}));
  const Eigen::MatrixXd m = r.read_matrix("/m");
  ASSERT_EQ(m.rows(), 2);
  EXPECT_EQ(m(0, 2), 3.0);  // row-major as written
  EXPECT_EQ(m(1, 0), 4.0);
  EXPECT_EQ(r.strings_attribute("/m", "column_names"), (std::vector<std::string>{"c0", "c1", "c2"}));
  EXPECT_EQ(r.string_attribute("/", "kind"), "simulate");
  EXPECT_EQ(r.double_attribute("/", "threads"), 4.0);
  EXPECT_TRUE(r.strings_attribute("/", "empty").empty());
  EXPECT_EQ(r.members("/"), (std::vector<std::string>{"a", "config", "names", "m"}));  // creation order
}

TEST(Hdf5Writer, AnExistingFileIsReplacedOnlyOnCommit) {
  const auto dir = scratch_dir();
  const auto path = write_file(dir / "r.h5", "previous result");
  {
    Hdf5Writer w(path);
    w.write_vector("/x", Eigen::Vector2d(1.0, 2.0), "s");
    // no commit: an error before the end of the work
  }
  EXPECT_EQ(read_file(path), "previous result");
  EXPECT_EQ(temporaries_in(dir), 0);
}

TEST(Results, TrajectoryIsStoredInClinicalUnitsWithUnitsAttributes) {
  const auto dir = scratch_dir();
  {
    Hdf5Writer w(dir / "t.h5");
    write_trajectory(w, "/trajectories/simulated", small_trajectory());
    w.commit();
  }
  Hdf5Reader r(dir / "t.h5");
  const Eigen::VectorXd v = r.read_vector("/trajectories/simulated/V_lv");
  EXPECT_NEAR(v(0), 120.0, 1e-9);
  EXPECT_EQ(r.string_attribute("/trajectories/simulated/V_lv", "units"), "mL");
  EXPECT_NEAR(r.read_vector("/trajectories/simulated/P_lv")(1), 100.0, 1e-9);
  EXPECT_EQ(r.string_attribute("/trajectories/simulated/P_lv", "units"), "mmHg");
  EXPECT_EQ(r.string_attribute("/trajectories/simulated/time", "units"), "s");
  EXPECT_EQ(r.strings_attribute("/trajectories/simulated", "channels"),
            (std::vector<std::string>{"V_lv", "P_lv", "phase"}));
}

TEST(Results, CsvHasANameAndUnitHeaderAndClinicalValues) {
  const auto dir = scratch_dir();
  write_trajectory_csv(dir / "t.csv", small_trajectory());
  EXPECT_EQ(temporaries_in(dir), 0);
  EXPECT_EQ(read_file(dir / "t.csv"),
            "time [s],V_lv [mL],P_lv [mmHg],phase [1]\n"
            "0,120,7.500637554,0\n"
            "0.5,100,100,2\n"
            "1,60,1,0\n");
}

TEST(Results, JsonSummaryGivesEachValueWithItsUnit) {
  const auto dir = scratch_dir();
  write_indicators_json(dir / "s.json", {{"EDV", 142.5, "mL", ""}, {"EF", 60.0, "%", ""}});
  const auto j = nlohmann::json::parse(read_file(dir / "s.json"));
  EXPECT_EQ(j["EDV"]["value"], 142.5);
  EXPECT_EQ(j["EDV"]["unit"], "mL");
  EXPECT_EQ(j["EF"]["unit"], "%");
  EXPECT_EQ(j.size(), 2u);
}

TEST(Results, DisplayUnitsAreClinical) {
  EXPECT_EQ(display_unit("m^3").unit, "mL");
  EXPECT_DOUBLE_EQ(display_unit("m^3").from_si, 1e6);
  EXPECT_EQ(display_unit("Pa/s").unit, "mmHg/s");
  EXPECT_DOUBLE_EQ(display_unit("Pa").from_si, 1.0 / 133.322);
  EXPECT_EQ(display_unit("1/s").unit, "1/s");
}

}  // namespace
}  // namespace sigmaheart::app::io
