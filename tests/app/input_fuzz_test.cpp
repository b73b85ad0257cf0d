// Bad input never crashes or hangs (issue 12, item 6): every shipped config and a bundled data file
// are damaged in systematic ways (cut short at many places; each scalar value replaced by a
// wrong type, an empty value, a non-finite or an extreme number, a sequence, a map; each map
// entry removed) and fed to `sigmaheart validate` and to the command that reads the config. Each
// run must end with exit 0 or 2 (never 1, a signal or an exception escaping), every error line
// must name a file with line and column, and the command must refuse, located too, every config
// that `validate` refused. Deterministic: the damage is enumerated,
// not random.
#include "app/cli.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace sigmaheart {
namespace {

namespace fs = std::filesystem;
using testing::read_file;
using testing::scratch_dir;
using testing::write_file;

const fs::path kSource = SIGMAHEART_SOURCE_DIR;

struct Outcome {
  int code = -1;
  std::string out, err;
};

Outcome run(const std::vector<std::string>& args) {
  std::vector<const char*> argv = {"sigmaheart", "--log-level", "off"};
  for (const auto& a : args) argv.push_back(a.c_str());
  std::ostringstream out, err;
  Outcome o;
  o.code = app::run_cli(static_cast<int>(argv.size()), argv.data(), out, err);
  o.out = out.str();
  o.err = err.str();
  return o;
}

// The "error: " lines of a run.
std::vector<std::string> error_lines(const std::string& err) {
  std::vector<std::string> lines;
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("error: ", 0) == 0) lines.push_back(line);
  }
  return lines;
}

// Positions (line:column) of every scalar value in a YAML tree, in file order.
void scalar_marks(const YAML::Node& node, std::vector<YAML::Mark>& marks) {
  if (node.IsScalar()) {
    marks.push_back(node.Mark());
  } else if (node.IsMap()) {
    for (auto it = node.begin(); it != node.end(); ++it) scalar_marks(it->second, marks);
  } else if (node.IsSequence()) {
    for (const auto& item : node) scalar_marks(item, marks);
  }
}

// Offset of a 0-based line:column in `text`.
size_t offset_of(const std::string& text, const YAML::Mark& m) {
  size_t pos = 0;
  for (int line = 0; line < m.line; ++line) pos = text.find('\n', pos) + 1;
  return pos + static_cast<size_t>(m.column);
}

// The damaged variants of a config's text.
std::vector<std::string> damaged_configs(const std::string& text) {
  std::vector<std::string> out;
  // Cut short at 16 places spread over the file (mid-line cuts included).
  for (int k = 0; k < 16; ++k) out.push_back(text.substr(0, text.size() * k / 16));
  // Each scalar value replaced (plain scalars only: quoted ones end at the quote).
  const std::vector<std::string> replacements = {"abc", "\"\"", ".nan", "-.inf", "1e308", "-1e308",
                                                 "0", "-1", "[1, 2]", "{a: 1}", "1e-308"};
  std::vector<YAML::Mark> marks;
  scalar_marks(YAML::Load(text), marks);
  size_t r = 0;
  for (const auto& m : marks) {
    const size_t begin = offset_of(text, m);
    if (begin >= text.size() || text[begin] == '"' || text[begin] == '\'') continue;
    size_t end = begin;
    // A plain scalar in flow style ends at , ] }; in block style at the end of the line or " #".
    while (end < text.size() && text[end] != '\n' && text[end] != ',' && text[end] != ']' &&
           text[end] != '}' && text.compare(end, 2, " #") != 0) {
      ++end;
    }
    // Three replacements per value, cycling through the list, so that every kind is tried.
    for (int j = 0; j < 3; ++j, ++r) {
      std::string t = text;
      t.replace(begin, end - begin, replacements[r % replacements.size()]);
      out.push_back(t);
    }
  }
  // Each line removed in turn (a removed key, a removed list item, a broken indentation).
  std::vector<size_t> starts = {0};
  for (size_t p = text.find('\n'); p != std::string::npos && p + 1 < text.size();
       p = text.find('\n', p + 1)) {
    starts.push_back(p + 1);
  }
  for (size_t i = 0; i < starts.size(); ++i) {
    const size_t end = i + 1 < starts.size() ? starts[i + 1] : text.size();
    if (text.find_first_not_of(" \t\n", starts[i]) >= end) continue;  // blank line
    out.push_back(text.substr(0, starts[i]) + text.substr(end));
  }
  return out;
}

// The command that reads a config with these sections.
std::string command_for(const std::string& text) {
  for (const char* c : {"personalize", "sensitivity", "specificity"}) {
    if (text.find(std::string("\n") + c + ":") != std::string::npos) return c;
  }
  if (text.find("\nestimate:") != std::string::npos) return "calibrate";
  return "simulate";
}

// An error line names a file with line and column ("error: path:12:3: ...") or a --set.
const std::regex kLocated(R"(^error: ([^:]+:[0-9]+:[0-9]+|--set [^:]+): .+)");

// Runs validate on every damaged variant of `relative` (a config under the source tree, copied
// to the same relative place under `root`, where configs/data links to the bundled data), and the
// config's own command on those validate refused.
void check_config(const fs::path& root, const std::string& relative) {
  const std::string text = read_file(kSource / relative);
  const fs::path path = root / relative;
  fs::create_directories(path.parent_path());
  const fs::path out = root / "out.h5";
  const std::string command = command_for(text);
  int refused = 0, accepted = 0;
  const auto variants = damaged_configs(text);
  for (size_t v = 0; v < variants.size(); ++v) {
    write_file(path, variants[v]);
    const std::string what = relative + " variant " + std::to_string(v) + ":\n" + variants[v];
    const Outcome check = run({"validate", path.string()});
    ASSERT_TRUE(check.code == 0 || check.code == 2) << what << "\nexit " << check.code << "\n"
                                                    << check.err;
    if (check.code == 0) {
      ++accepted;
      // An accepted simulation config runs (a beat takes milliseconds): it ends with results
      // (0) or a failure in words (1), whatever the accepted values.
      if (command == "simulate") {
        const Outcome sim = run({command, path.string(), "-o", out.string()});
        EXPECT_TRUE(sim.code == 0 || sim.code == 1) << what << "\nexit " << sim.code << "\n"
                                                    << sim.err;
      }
      continue;
    }
    ++refused;
    const auto errors = error_lines(check.err);
    ASSERT_FALSE(errors.empty()) << what << "\n" << check.err;
    for (const auto& e : errors) EXPECT_TRUE(std::regex_match(e, kLocated)) << what << "\n" << e;
    // The command stops at its first error, which need not be validate's first (each reads its
    // sections in its own order), but it is located too.
    const Outcome cmd = run({command, path.string(), "-o", out.string()});
    ASSERT_EQ(cmd.code, 2) << what << "\n" << command << ": " << cmd.err;
    const auto cmd_errors = error_lines(cmd.err);
    ASSERT_EQ(cmd_errors.size(), 1u) << what << "\n" << cmd.err;
    EXPECT_TRUE(std::regex_match(cmd_errors[0], kLocated)) << what << "\n" << cmd_errors[0];
  }
  std::printf("%s: %zu damaged variants, %d refused, %d accepted\n", relative.c_str(),
              variants.size(), refused, accepted);
  // The damage is real: most variants are refused.
  EXPECT_GT(refused, accepted) << relative;
}

fs::path fuzz_root() {
  const fs::path root = scratch_dir();
  fs::create_directories(root / "configs");
  fs::create_directory_symlink(kSource / "configs" / "data", root / "configs" / "data");
  return root;
}

class ShippedConfig : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedConfig, EveryDamagedVariantIsRefusedCleanlyOrAccepted) {
  check_config(fuzz_root(), GetParam());
}

INSTANTIATE_TEST_SUITE_P(Fuzz, ShippedConfig,
                         ::testing::Values("configs/healthy.yaml", "configs/heart-failure.yaml",
                                           "configs/calibrate-volunteer.yaml",
                                           "configs/calibrate-failing.yaml",
                                           "configs/personalize-lad-infarct.yaml",
                                           "configs/sensitivity-healthy.yaml",
                                           "configs/sensitivity-ishigami.yaml",
                                           "configs/specificity-cohort.yaml",
                                           "configs/specificity-foreign.yaml",
                                           "experiments/foreign-data/calibrate-foreign.yaml",
                                           "experiments/foreign-data/calibrate-foreign-12.yaml",
                                           "experiments/sensitivity-bcs/sobol.yaml"),
                         [](const ::testing::TestParamInfo<std::string>& p) {
                           std::string n = fs::path(p.param).stem().string();
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

// The observation file of configs/calibrate-volunteer.yaml, damaged: cut short, each cell of the
// header and of three data rows replaced by text, nothing, NaN, an enormous or a negative
// number. validate and calibrate must refuse (exit 2, file:line:column of the CSV) or accept it.
TEST(Fuzz, DamagedObservationFiles) {
  const fs::path root = fuzz_root();
  const std::string csv = read_file(kSource / "configs/data/volunteer01.csv");
  std::vector<std::string> variants;
  for (int k = 0; k < 12; ++k) variants.push_back(csv.substr(0, csv.size() * k / 12));
  std::vector<size_t> line_starts = {0};
  for (size_t p = csv.find('\n'); p != std::string::npos && p + 1 < csv.size(); p = csv.find('\n', p + 1)) {
    line_starts.push_back(p + 1);
  }
  const std::vector<std::string> cells = {"abc", "", "nan", "1e400", "-5", "1,2"};
  int r = 0;
  // The first non-comment line (the header) and three data lines.
  std::vector<size_t> chosen;
  for (size_t i = 0; i < line_starts.size() && chosen.size() < 4; ++i) {
    if (csv[line_starts[i]] != '#') chosen.push_back(i);
  }
  for (size_t i : chosen) {
    const size_t begin = line_starts[i];
    const size_t end = csv.find('\n', begin);
    const std::string line = csv.substr(begin, end - begin);
    size_t cell_begin = 0;
    while (cell_begin <= line.size()) {
      size_t cell_end = line.find(',', cell_begin);
      if (cell_end == std::string::npos) cell_end = line.size();
      std::string damaged = line;
      damaged.replace(cell_begin, cell_end - cell_begin, cells[static_cast<size_t>(r++) % cells.size()]);
      variants.push_back(csv.substr(0, begin) + damaged + csv.substr(end));
      cell_begin = cell_end + 1;
    }
  }
  const fs::path data = root / "damaged.csv";
  const std::string set = "observations.file=" + data.string();
  const std::regex located(R"(^error: [^:]+:[0-9]+:[0-9]+: .+)");
  int refused = 0;
  for (size_t v = 0; v < variants.size(); ++v) {
    write_file(data, variants[v]);
    const std::string what = "variant " + std::to_string(v) + ":\n" + variants[v];
    const std::string config = (kSource / "configs/calibrate-volunteer.yaml").string();
    const Outcome check = run({"validate", config, "--set", set});
    ASSERT_TRUE(check.code == 0 || check.code == 2) << what << "\n" << check.err;
    if (check.code == 0) continue;
    ++refused;
    const auto errors = error_lines(check.err);
    ASSERT_EQ(errors.size(), 1u) << what << "\n" << check.err;  // one data file: one error
    EXPECT_NE(errors[0].find(data.string()), std::string::npos) << what << "\n" << errors[0];
    EXPECT_TRUE(std::regex_match(errors[0], located)) << what << "\n" << errors[0];
    const Outcome cmd = run({"calibrate", config, "--set", set, "-o", (root / "out.h5").string()});
    ASSERT_EQ(cmd.code, 2) << what << "\n" << cmd.err;
    EXPECT_EQ(error_lines(cmd.err), errors) << what;
  }
  EXPECT_GT(refused, static_cast<int>(variants.size()) / 2);
}

// Extreme flags: a count that would not fit in memory is refused at the flag (it ended in
// std::bad_alloc).
TEST(Fuzz, EnormousFrameCountIsRefusedAtTheFlag) {
  const fs::path dir = scratch_dir();
  const Outcome o = run({"synthesize", (kSource / "configs/healthy.yaml").string(), "--frames",
                         "2000000000", "-o", (dir / "x.csv").string()});
  EXPECT_EQ(o.code, 2);
  EXPECT_NE(o.err.find("error: --frames: expected 3 to 100000 frames"), std::string::npos) << o.err;
  EXPECT_FALSE(fs::exists(dir / "x.csv"));
}

// Outputs are checked before any work: an output that is an input, two outputs on one file, a
// directory, or a directory that cannot be written is refused at its option (exit 2) and the
// input is untouched.
TEST(Outputs, AreCheckedBeforeAnyWork) {
  const fs::path dir = scratch_dir();
  const fs::path config = dir / "healthy.yaml";
  fs::copy_file(kSource / "configs/healthy.yaml", config);
  const std::string text = read_file(config);
  const Outcome same = run({"simulate", config.string(), "-o", config.string()});
  EXPECT_EQ(same.code, 2);
  EXPECT_NE(same.err.find("error: -o " + config.string() + ": is the input file"), std::string::npos)
      << same.err;
  EXPECT_EQ(read_file(config), text);
  const fs::path h5 = dir / "r.h5";
  const Outcome twice = run({"simulate", config.string(), "-o", h5.string(), "--summary", h5.string()});
  EXPECT_EQ(twice.code, 2);
  EXPECT_NE(twice.err.find("is also the -o file"), std::string::npos) << twice.err;
  const Outcome directory = run({"calibrate", (kSource / "configs/calibrate-volunteer.yaml").string(),
                                 "-o", dir.string()});
  EXPECT_EQ(directory.code, 2);
  EXPECT_NE(directory.err.find("is a directory"), std::string::npos) << directory.err;
  // A directory without write permission (root may write anyway: then the run is not refused).
  const fs::path locked = dir / "locked";
  fs::create_directory(locked);
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  const bool root_writes = ::access(locked.c_str(), W_OK) == 0;
  if (!root_writes) {
    const Outcome denied = run({"calibrate", (kSource / "configs/calibrate-volunteer.yaml").string(),
                                "-o", (locked / "r.h5").string()});
    EXPECT_EQ(denied.code, 2);
    EXPECT_NE(denied.err.find("cannot write in"), std::string::npos) << denied.err;
  }
  fs::permissions(locked, fs::perms::owner_all);
  EXPECT_FALSE(fs::exists(h5));
}

// validate reports every error it finds, each at its place, and ends with the count.
TEST(Validate, ReportsEveryError) {
  const fs::path dir = scratch_dir();
  const fs::path path = write_file(dir / "three.yaml",
                                   "name: three\n"
                                   "simulator:\n"
                                   "  model: lumped-sphere\n"
                                   "  numerics: {dt: abc}\n"
                                   "  parameters:\n"
                                   "    sigma0: -5\n"
                                   "    k_ATPP: 8\n"
                                   "colour: blue\n");
  const Outcome o = run({"validate", path.string()});
  EXPECT_EQ(o.code, 2);
  const auto errors = error_lines(o.err);
  ASSERT_EQ(errors.size(), 4u) << o.err;
  const std::string f = path.string();
  EXPECT_EQ(errors[0].rfind("error: " + f + ":8:1: unknown section 'colour'", 0), 0u) << errors[0];
  EXPECT_EQ(errors[1].rfind("error: " + f + ":4:18: ", 0), 0u) << errors[1];
  EXPECT_EQ(errors[2].rfind("error: " + f + ":7:5: unknown parameter 'k_ATPP'", 0), 0u) << errors[2];
  EXPECT_EQ(errors[3].rfind("error: " + f + ":6:13: ", 0), 0u) << errors[3];
  EXPECT_NE(o.err.find(f + ": 4 errors"), std::string::npos) << o.err;
}

}  // namespace
}  // namespace sigmaheart
