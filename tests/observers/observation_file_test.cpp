#include "app/io/observation_file.h"

#include "app/errors.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace sigmaheart::app::io {
namespace {

ObservationCurves parse(const std::string& text, const std::string& name = "cohort/p07.csv") {
  std::istringstream in(text);
  return parse_observation_csv(in, name);
}

// The message of the InputError the text raises; "" when it parses.
std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const char* kGood =
    "# patient 07, cine MRI\n"
    "time [ms], V_lv [mL], P_lv [mmHg]\n"
    "0, 140, 10   # end-diastole\n"
    "\n"
    "40, 120.5, 90\n"
    "80, 80, 115\n"
    "120, 70.25, 20\n";

TEST(ObservationFile, ReadsAGoodFileIntoSiUnits) {
  const auto c = parse(kGood);
  const auto& t = c.trajectory;
  ASSERT_EQ(t.samples(), 4);
  ASSERT_EQ(t.channels.size(), 2u);
  EXPECT_EQ(t.channels[0].name, "V_lv");
  EXPECT_EQ(t.channels[0].unit, "m^3");
  EXPECT_EQ(t.channels[1].unit, "Pa");
  EXPECT_EQ(c.time_unit, "ms");
  EXPECT_EQ(c.display_units, (std::vector<std::string>{"mL", "mmHg"}));
  EXPECT_NEAR(t.times(1), 0.04, 1e-15);
  EXPECT_NEAR(t.values(3, 0), 70.25e-6, 1e-18);
  EXPECT_NEAR(t.values(2, 1), 115 * 133.322, 1e-9);
}

TEST(ObservationFile, ConvertsLitresKilopascalsAndSecondsLikeTheirClinicalEquivalents) {
  const auto a = parse("time [ms], V_lv [mL], P_lv [mmHg]\n0, 150, 7.5\n500, 60, 120\n900, 140, 9\n");
  const auto b = parse("time [s], V_lv [L], P_lv [kPa]\n0, 0.150, 0.99991\n0.5, 0.060, 15.99864\n"
                       "0.9, 0.140, 1.199898\n");
  ASSERT_EQ(a.trajectory.samples(), b.trajectory.samples());
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a.trajectory.times(k), b.trajectory.times(k), 1e-15);
    EXPECT_NEAR(a.trajectory.values(k, 0), b.trajectory.values(k, 0), 1e-15);
    EXPECT_NEAR(a.trajectory.values(k, 1), b.trajectory.values(k, 1), 0.01);  // 0.01 Pa
  }
}

struct BadCase {
  const char* what;
  std::string text;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(ObservationFile, NamesFileLineAndWhatWasExpectedForEachMalformedInput) {
  const std::vector<BadCase> cases = {
      {"empty", "# nothing\n\n", {"cohort/p07.csv", "missing header"}},
      {"header missing", "0, 140, 10\n40, 120, 90\n",
       {"cohort/p07.csv:1:1:", "missing header", "'name [unit]'"}},
      {"unknown unit", "time [ms], V_lv [mL], P_lv [mmHG]\n",
       {"cohort/p07.csv:1:29:", "unknown unit 'mmHG'", "did you mean 'mmHg'", "known units:", "kPa"}},
      {"time not first", "V_lv [mL], time [ms]\n", {"cohort/p07.csv:1:1:", "'time [ms]' or 'time [s]'"}},
      {"volume in pressure unit", "time [ms], V_lv [mmHg]\n",
       {"cohort/p07.csv:1:", "expects a unit of m^3"}},
      {"non-numeric", "time [ms], V_lv [mL]\n0, 140\n40, abc\n80, 90\n",
       {"cohort/p07.csv:3:5:", "field 2 ('V_lv [mL]')", "expected a number, got 'abc'"}},
      {"ragged", "time [ms], V_lv [mL], P_lv [mmHg]\n0, 140, 10\n40, 120\n80, 90, 3\n",
       {"cohort/p07.csv:3:", "expected 3 fields", "got 2"}},
      {"non-increasing times", "time [ms], V_lv [mL]\n0, 140\n40, 120\n40, 100\n80, 90\n",
       {"cohort/p07.csv:4:1:", "expected times to increase strictly", "40 ms after 40 ms"}},
      {"too few rows", "time [ms], V_lv [mL]\n0, 140\n40, 120\n",
       {"cohort/p07.csv:3", "too few rows", "at least 3"}},
      {"nan", "time [ms], V_lv [mL]\n0, 140\n40, nan\n80, 90\n",
       {"cohort/p07.csv:3:5:", "expected a finite number, got 'nan'"}},
      {"empty cell", "time [ms], V_lv [mL]\n0, 140\n40,\n80, 90\n",
       {"cohort/p07.csv:3:", "got an empty field"}},
      {"duplicate column", "time [ms], V_lv [mL], V_lv [mL]\n",
       {"cohort/p07.csv:1:", "appears twice"}},
  };
  for (const auto& c : cases) {
    const std::string msg = error_of(c.text);
    ASSERT_FALSE(msg.empty()) << c.what << ": parsed without error";
    for (const auto& part : c.expected) {
      EXPECT_NE(msg.find(part), std::string::npos) << c.what << ": '" << part << "' not in: " << msg;
    }
  }
}

TEST(ObservationFile, ReportsAFileThatCannotBeOpened) {
  try {
    read_observation_csv("/nonexistent/dir/p01.csv");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/p01.csv"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
}

TEST(ObservationFile, WritesAFileThatReadsBackToTheSameSiValues) {
  const auto dir = std::filesystem::path(SIGMAHEART_BINARY_DIR) / "test_tmp" / "observation_file";
  std::filesystem::remove_all(dir);
  const auto path = dir / "case01.csv";
  const auto original = parse(kGood).trajectory;
  write_observation_csv(path, original, "ms", {"mL", "kPa"}, {"synthetic case 01", "30 frames"});
  EXPECT_TRUE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(dir / "case01.csv.tmp"));

  std::ifstream in(path);
  std::string first, second, header;
  std::getline(in, first);
  std::getline(in, second);
  std::getline(in, header);
  EXPECT_EQ(first, "# synthetic case 01");
  EXPECT_EQ(header, "time [ms], V_lv [mL], P_lv [kPa]");

  const auto back = read_observation_csv(path);
  EXPECT_EQ(back.display_units, (std::vector<std::string>{"mL", "kPa"}));
  ASSERT_EQ(back.trajectory.samples(), original.samples());
  for (int k = 0; k < original.samples(); ++k) {
    EXPECT_NEAR(back.trajectory.times(k), original.times(k), 1e-15);
    for (int c = 0; c < 2; ++c) {
      EXPECT_NEAR(back.trajectory.values(k, c), original.values(k, c),
                  1e-14 * std::abs(original.values(k, c)));
    }
  }
  EXPECT_THROW(write_observation_csv(path, original, "ms", {"mL", "mL"}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::app::io
