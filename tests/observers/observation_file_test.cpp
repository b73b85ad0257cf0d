#include "app/io/observation_file.h"

#include "app/errors.h"

#include <gtest/gtest.h>

#include <cmath>
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

// Each case fails to parse with a message holding every one of its expected parts.
void expect_errors(const std::vector<BadCase>& cases) {
  for (const auto& c : cases) {
    const std::string msg = error_of(c.text);
    ASSERT_FALSE(msg.empty()) << c.what << ": parsed without error";
    for (const auto& part : c.expected) {
      EXPECT_NE(msg.find(part), std::string::npos) << c.what << ": '" << part << "' not in: " << msg;
    }
  }
}

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
      // A NaN or empty data cell is a missing value now (MissingValuesAreKeptAsNaN); in the time
      // column both stay errors, and an infinite value stays one.
      {"nan time", "time [ms], V_lv [mL]\n0, 140\nnan, 120\n80, 90\n",
       {"cohort/p07.csv:3:1:", "field 1 ('time [ms]'): expected a time, got 'nan'"}},
      {"empty time cell", "time [ms], V_lv [mL]\n0, 140\n ,120\n80, 90\n",
       {"cohort/p07.csv:3:2:", "expected a time, got an empty field"}},
      {"inf", "time [ms], V_lv [mL]\n0, 140\n40, inf\n80, 90\n",
       {"cohort/p07.csv:3:5:", "expected a finite number, got 'inf'"}},
      {"duplicate column", "time [ms], V_lv [mL], V_lv [mL]\n",
       {"cohort/p07.csv:1:", "appears twice"}},
  };
  expect_errors(cases);
}

// Data as it comes: the time column as t/time in any case, units in brackets or parentheses (or a
// time suffix t_ms), clinical units; every variant gives the same SI values.
TEST(ObservationFile, AcceptsHeaderVariantsWithTheSameSiValues) {
  struct Variant {
    std::string header;
    double t_scale, v_scale, p_scale;  // file value = SI value / scale
  };
  const std::vector<Variant> variants = {
      {"time [s], V_lv [m^3], P_lv [Pa]", 1, 1, 1},
      {"t [s], V_lv [mL], P_lv [mmHg]", 1, 1e-6, 133.322},
      {"T [ms], V_lv (mL), P_lv (kPa)", 1e-3, 1e-6, 1e3},
      {"TIME (s), V_lv (L), P_lv (mmHg)", 1, 1e-3, 133.322},
      {"Time(ms),V_lv(ml),P_lv(mmHg)", 1e-3, 1e-6, 133.322},
      {"t_ms, V_lv [mL], P_lv [mmHg]", 1e-3, 1e-6, 133.322},
      {"time_s, V_lv [ mL ], P_lv ( kPa )", 1, 1e-6, 1e3},
  };
  const double t_si[3] = {0.0, 0.4, 0.8};
  const double v_si[3] = {150e-6, 60e-6, 140e-6};
  const double p_si[3] = {1000.0, 16000.0, 1200.0};
  for (const auto& v : variants) {
    std::ostringstream text;
    text.precision(17);
    text << v.header << "\n";
    for (int k = 0; k < 3; ++k) {
      text << t_si[k] / v.t_scale << ", " << v_si[k] / v.v_scale << ", " << p_si[k] / v.p_scale
           << "\n";
    }
    ObservationCurves c;
    ASSERT_NO_THROW(c = parse(text.str())) << v.header;
    ASSERT_EQ(c.trajectory.channels.size(), 2u) << v.header;
    EXPECT_EQ(c.trajectory.channels[0].name, "V_lv") << v.header;
    EXPECT_EQ(c.trajectory.channels[1].name, "P_lv") << v.header;
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(c.trajectory.times(k), t_si[k], 1e-14) << v.header;
      EXPECT_NEAR(c.trajectory.values(k, 0), v_si[k], 1e-18) << v.header;
      EXPECT_NEAR(c.trajectory.values(k, 1), p_si[k], 1e-9) << v.header;
    }
  }
  const auto ms = parse("Time (ms), V_lv (mL)\n0, 1\n1, 2\n2, 3\n");
  EXPECT_EQ(ms.time_unit, "ms");
  EXPECT_EQ(ms.display_units, (std::vector<std::string>{"mL"}));
}

TEST(ObservationFile, ReadsAHeartRateInBeatsPerMinuteAsPerSecond) {
  const auto c = parse("t [s], V_lv [mL], HR [bpm], HR2 [1/min]\n0, 100, 72, 60\n0.4, 90, 75, 90\n"
                       "0.8, 95, 72, 120\n");
  ASSERT_EQ(c.trajectory.channels.size(), 3u);
  EXPECT_EQ(c.trajectory.channels[1].unit, "1/s");
  EXPECT_NEAR(c.trajectory.values(0, 1), 1.2, 1e-15);
  EXPECT_NEAR(c.trajectory.values(2, 2), 2.0, 1e-15);
}

// An empty cell, NaN (any case), NA or N/A in a data column is a missing frame: NaN in the
// trajectory, the rest of the row kept.
TEST(ObservationFile, MissingValuesAreKeptAsNaN) {
  const auto c = parse(
      "time [ms], V_lv [mL], P_lv [mmHg]\n"
      "0, 140, 10\n"
      "40, , 90\n"          // line 3
      "80, NaN, nan\n"
      "120, NA, 20\n"
      "160, 75, N/A\n"
      "200, 80,\n");
  const auto& t = c.trajectory;
  ASSERT_EQ(t.samples(), 6);
  EXPECT_EQ(c.missing, 6);
  EXPECT_EQ(c.lines, (std::vector<int>{2, 3, 4, 5, 6, 7}));
  EXPECT_TRUE(std::isnan(t.values(1, 0)));
  EXPECT_NEAR(t.values(1, 1), 90 * 133.322, 1e-9);
  EXPECT_TRUE(std::isnan(t.values(2, 0)));
  EXPECT_TRUE(std::isnan(t.values(2, 1)));
  EXPECT_TRUE(std::isnan(t.values(3, 0)));
  EXPECT_NEAR(t.values(4, 0), 75e-6, 1e-18);
  EXPECT_TRUE(std::isnan(t.values(4, 1)));
  EXPECT_TRUE(std::isnan(t.values(5, 1)));
  EXPECT_NEAR(t.times(5), 0.2, 1e-15);
  EXPECT_EQ(parse(kGood).missing, 0);
}

// Missing frames are skipped: only rows where a used channel is missing go, and the period stays
// the full record's (the reduced record is no longer evenly spaced).
TEST(ObservationFile, DropsFramesWithAMissingValueAndKeepsTheFullRecordsPeriod) {
  const auto c = parse(
      "time [ms], V_lv [mL], P_lv [mmHg]\n"
      "0, 140, 10\n"
      "100, , 90\n"        // line 3: V_lv missing
      "200, 80, 115\n"
      "300, 70, NA\n"      // line 5: P_lv missing
      "400, 90, 20\n"
      "500, 120, 8\n");
  const auto both = drop_missing_frames(c, {"V_lv", "P_lv"}, "p.csv");
  EXPECT_EQ(both.dropped, (std::vector<int>{3, 5}));
  ASSERT_EQ(both.curves.trajectory.samples(), 4);
  EXPECT_EQ(both.curves.missing, 0);
  EXPECT_EQ(both.curves.lines, (std::vector<int>{2, 4, 6, 7}));
  EXPECT_NEAR(both.curves.trajectory.times(1), 0.2, 1e-15);
  EXPECT_NEAR(both.curves.trajectory.values(3, 0), 120e-6, 1e-18);
  EXPECT_NEAR(both.period, 0.6, 1e-15);  // 6 frames 100 ms apart
  const auto volume = drop_missing_frames(c, {"V_lv"}, "p.csv");
  EXPECT_EQ(volume.dropped, (std::vector<int>{3}));
  EXPECT_EQ(volume.curves.missing, 1);  // the P_lv cell of line 5, in a channel not asked for
  EXPECT_EQ(drop_missing_frames(c, {}, "p.csv").dropped, (std::vector<int>{3, 5}));
  const auto sparse = parse("t [s], V_lv [mL]\n0, 1\n0.1, nan\n0.2, 2\n0.3, NaN\n");
  EXPECT_THROW(drop_missing_frames(sparse, {"V_lv"}, "p.csv"), InputError);
}

// The config's column mapping (file column -> channel): applied before the unit checks.
TEST(ObservationFile, RenamesColumnsByTheGivenMapping) {
  std::istringstream in("Zeit [ms], LVV (mL), LVP (mmHg), V_seg07 [mL]\n0, 140, 10, 8\n"
                        "40, 120, 90, 7\n80, 80, 115, 6\n");
  const auto c = parse_observation_csv(in, "p.csv",
                                       {{"LVV", "V_lv"}, {"LVP", "P_lv"}, {"Zeit", "time"}});
  ASSERT_EQ(c.trajectory.channels.size(), 3u);
  EXPECT_EQ(c.trajectory.channels[0].name, "V_lv");
  EXPECT_EQ(c.trajectory.channels[1].name, "P_lv");
  EXPECT_EQ(c.trajectory.channels[2].name, "V_seg07");
  EXPECT_EQ(c.trajectory.channels[1].unit, "Pa");
  EXPECT_NEAR(c.trajectory.times(2), 0.08, 1e-15);
  EXPECT_NEAR(c.trajectory.values(1, 0), 120e-6, 1e-18);

  auto error = [](const std::string& text, const ColumnMapping& rename) {
    std::istringstream s(text);
    try {
      parse_observation_csv(s, "p.csv", rename);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  // The renamed channel's unit is checked under its new name (V_* takes a volume).
  EXPECT_NE(error("t [s], LVV [mmHg]\n0, 1\n1, 2\n2, 3\n", {{"LVV", "V_lv"}})
                .find("p.csv:1:13: column 'V_lv' expects a unit of m^3"),
            std::string::npos);
  EXPECT_NE(error("t [s], V_lv [mL]\n0, 1\n1, 2\n2, 3\n", {{"LVV", "V_lv"}})
                .find("p.csv:1:1: column mapping 'LVV' -> 'V_lv': the header has no column 'LVV'"),
            std::string::npos);
  EXPECT_NE(error("t [s], LVV [mL], V_lv [mL]\n0, 1, 1\n1, 2, 2\n2, 3, 3\n", {{"LVV", "V_lv"}})
                .find("column 'V_lv' appears twice"),
            std::string::npos);
}

// Bad input in the variants names the line and the column.
TEST(ObservationFile, RejectsBadVariantsWithLineAndColumn) {
  const std::vector<BadCase> cases = {
      {"unknown unit in parentheses", "t (ms), V_lv (mLL)\n",
       {"cohort/p07.csv:1:15:", "unknown unit 'mLL'", "did you mean 'mL'"}},
      {"time in a volume unit", "t [mL], V_lv [mL]\n", {"cohort/p07.csv:1:1:", "'time [ms]'"}},
      {"no unit", "t [s], V_lv\n", {"cohort/p07.csv:1:8:", "'name [unit]' or 'name (unit)'"}},
      {"time without unit", "time, V_lv [mL]\n",
       {"cohort/p07.csv:1:1:", "'name [unit]' or 'name (unit)'"}},
      {"second time column", "t [s], time [ms]\n", {"cohort/p07.csv:1:8:", "only the first"}},
      {"non-numeric", "Time (ms), V_lv (mL)\n0, 140\n40, 12O\n80, 90\n",
       {"cohort/p07.csv:3:5:", "field 2 ('V_lv (mL)'): expected a number, got '12O'"}},
      {"decreasing time", "t [s], V_lv [mL]\n0, 140\n0.4, 120\n0.3, 100\n",
       {"cohort/p07.csv:4:1:", "expected times to increase strictly", "0.3 s after 0.4 s"}},
      {"missing time cell", "t [s], V_lv [mL]\n0, 140\nNA, 120\n0.3, 100\n",
       {"cohort/p07.csv:3:1:", "expected a time, got 'NA'"}},
  };
  expect_errors(cases);
}

// Frames later than one simulated beat would be compared with the simulated beat wrapped into its
// first period: refused with the file, the frame's line and the period.
TEST(ObservationFile, FramesBeyondOneBeatAreAnInputErrorNamingLineAndPeriod) {
  std::string text = "# two beats\ntime [ms], V_lv [mL]\n";
  for (int k = 0; k < 12; ++k) text += std::to_string(k * 170) + ", " + std::to_string(100 + k) + "\n";
  const auto c = parse(text);  // frames 0 ... 1870 ms
  try {
    check_frames_in_one_beat(c, 0.85, "cohort/p07.csv", true);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    // Frame 5 (850 ms) is the closed beat's end, within half a frame; frame 6 (1020 ms) is not.
    EXPECT_EQ(e.line(), 9);
    EXPECT_NE(std::string(e.what()).find("cohort/p07.csv:9:1: frame 6 at t = 1020 ms lies beyond "
                                         "one beat: the simulated period is 850 ms"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(check_frames_in_one_beat(c, 2.0, "cohort/p07.csv", true));
  // One beat of frames starting mid-record is fine when aligned on end-diastole, not after the
  // trigger (times from 0).
  const auto late = parse("t [s], V_lv [mL]\n0.5, 1\n0.8, 2\n1.1, 3\n");
  EXPECT_NO_THROW(check_frames_in_one_beat(late, 0.85, "x.csv", false));
  EXPECT_THROW(check_frames_in_one_beat(late, 0.85, "x.csv", true), InputError);
  EXPECT_NO_THROW(check_frames_in_one_beat(parse(kGood), 0.85, "x.csv", true));
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
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    EXPECT_NE(e.path().extension(), ".tmp") << e.path();  // the temporary was renamed
  }

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
