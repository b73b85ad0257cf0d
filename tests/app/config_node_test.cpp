// ConfigNode and ConfigFile: located errors, types, units, overrides (app/config_node.h).
#include "app/config_node.h"

#include "tests/app/test_support.h"

#include <gtest/gtest.h>

#include <string>

namespace sigmaheart::app {
namespace {

using sigmaheart::testing::error_of;

const char* kText =
    "solver:\n"                  // 1
    "  dt: 1 ms\n"               // 2
    "  steps: 12\n"              // 3
    "  tolerance: abc\n"         // 4
    "  pressure: \"8 mmHg\"\n"   // 5
    "  list: [1, 2.5, 3]\n";     // 6

TEST(ConfigNode, ReadsTypedValuesAndConvertsUnitStrings) {
  const ConfigNode s = ConfigFile::parse(kText, "a.yaml").root()["solver"];
  EXPECT_EQ(s.require<int>("steps"), 12);
  EXPECT_DOUBLE_EQ(s.require_quantity("dt", "s"), 1e-3);
  EXPECT_DOUBLE_EQ(s.require_quantity("pressure", "Pa"), 8 * 133.322);
  EXPECT_DOUBLE_EQ(s.require_quantity("steps", "Pa"), 12.0);  // a plain number is in the unit asked
  EXPECT_EQ(s.require<std::vector<double>>("list"), (std::vector<double>{1, 2.5, 3}));
  EXPECT_EQ(s.optional<int>("missing", 7), 7);
  EXPECT_EQ(s.path(), "solver");
}

TEST(ConfigNode, WrongTypeNamesLineColumnAndWhatWasExpected) {
  const ConfigNode s = ConfigFile::parse(kText, "a.yaml").root()["solver"];
  EXPECT_EQ(error_of([&] { s.require<double>("tolerance"); }),
            "a.yaml:4:14: solver.tolerance: expected a number, got 'abc'");
  EXPECT_EQ(error_of([&] { s.require<int>("tolerance"); }),
            "a.yaml:4:14: solver.tolerance: expected an integer, got 'abc'");
  EXPECT_EQ(error_of([&] { s.require<int>("list"); }),
            "a.yaml:6:9: solver.list: expected an integer, got a sequence");
}

TEST(ConfigNode, UnknownKeyIsReportedAtTheKeyWithDidYouMean) {
  const ConfigNode s = ConfigFile::parse(kText, "a.yaml").root()["solver"];
  EXPECT_EQ(error_of([&] { s.check_keys({"dt", "steps", "tolerances", "pressure", "list"}); }),
            "a.yaml:4:3: unknown key 'tolerance' in solver (did you mean 'tolerances'?)");
  EXPECT_EQ(error_of([&] { s.check_keys({"dt", "steps", "pressure", "list"}); }),
            "a.yaml:4:3: unknown key 'tolerance' in solver; expected one of: dt, steps, pressure, list");
}

TEST(ConfigNode, DuplicateKeyIsReportedAtItsSecondOccurrence) {
  // At parse time, in every map of the file (check_keys saw only the maps it was called on).
  EXPECT_EQ(error_of([] { ConfigFile::parse("a: 1\nb: 2\na: 3\n", "e.yaml"); }),
            "e.yaml:3:1: duplicate key 'a' (first at line 1): each key may appear once");
  EXPECT_EQ(error_of([] { ConfigFile::parse("s:\n  - {x: 1, x: 2}\n", "e.yaml"); }),
            "e.yaml:2:12: duplicate key 'x' (first at line 2): each key may appear once");
}

TEST(ConfigNode, MissingKeyIsReportedAtItsParent) {
  const ConfigNode s = ConfigFile::parse(kText, "a.yaml").root()["solver"];
  EXPECT_EQ(error_of([&] { s.require<double>("theta"); }),
            "a.yaml:2:3: missing required key 'theta' in solver");
}

TEST(ConfigNode, IncompatibleOrUnknownUnitsAreInputErrors) {
  const ConfigNode s = ConfigFile::parse(kText, "a.yaml").root()["solver"];
  EXPECT_EQ(error_of([&] { s.require_quantity("pressure", "m^3"); }),
            "a.yaml:5:13: solver.pressure: cannot convert 'mmHg' (Pa) to 'm^3' (m^3)");
  const ConfigNode t = ConfigFile::parse("v: 3 furlongs\n", "b.yaml").root();
  EXPECT_EQ(error_of([&] { t.require_quantity("v", "m"); }),
            "b.yaml:1:4: v: unknown unit 'furlongs' in '3 furlongs'");
}

TEST(ConfigNode, ChoiceSuggestsTheClosestAllowedValue) {
  const ConfigNode r = ConfigFile::parse("model: lumped-spere\n", "c.yaml").root();
  EXPECT_EQ(error_of([&] { r["model"].as_choice({"lumped-sphere", "fem"}); }),
            "c.yaml:1:8: model: unknown value 'lumped-spere' (did you mean 'lumped-sphere'?); "
            "expected one of: lumped-sphere, fem");
}

TEST(ConfigFile, YamlSyntaxErrorGivesLineAndColumn) {
  EXPECT_EQ(error_of([] { ConfigFile::parse("a: 1\nb: [1, 2}\n", "d.yaml"); }),
            "d.yaml:2:9: YAML syntax error: illegal flow end");
}

TEST(ConfigFile, MissingFileIsAnInputError) {
  EXPECT_EQ(error_of([] { ConfigFile::load("/nonexistent/x.yaml"); }),
            "/nonexistent/x.yaml: no such config file");
}

TEST(ConfigFile, SetReplacesValuesCreatesMapsAndErrorsNameTheOverride) {
  ConfigFile f = ConfigFile::parse(kText, "a.yaml");
  f.set("solver.steps", "20", "--set solver.steps=20");
  f.set("solver.extra.depth", "abc", "--set solver.extra.depth=abc");
  const ConfigNode s = f.root()["solver"];
  EXPECT_EQ(s.require<int>("steps"), 20);
  EXPECT_TRUE(s["steps"].overridden());
  EXPECT_FALSE(s["dt"].overridden());
  EXPECT_EQ(error_of([&] { s["extra"].require<int>("depth"); }),
            "--set solver.extra.depth=abc: solver.extra.depth: expected an integer, got 'abc'");
  EXPECT_EQ(f.overrides(),
            (std::vector<std::string>{"--set solver.steps=20", "--set solver.extra.depth=abc"}));
  EXPECT_EQ(error_of([&] { f.set("solver.dt.x", "1", "--set solver.dt.x=1"); }),
            "--set solver.dt.x=1: cannot set 'solver.dt.x': 'solver.dt' is not a map");
}

}  // namespace
}  // namespace sigmaheart::app
