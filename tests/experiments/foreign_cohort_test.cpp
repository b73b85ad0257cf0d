// The foreign cohort of the specificity study (experiments/foreign-data/foreign_cohort.h): the
// draws have the stated spread, the groups have the phenotypes they are named after, and the
// bundled files (configs/data/foreign-cohort) are what `foreign_lv --cohort` writes.
#include "foreign_cohort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace foreign {
namespace {

const std::filesystem::path kBundled =
    std::filesystem::path(SIGMAHEART_SOURCE_DIR) / "configs/data/foreign-cohort";

std::filesystem::path scratch(const std::string& what) {
  return std::filesystem::temp_directory_path() / ("foreign_cohort_test_" + what + "_" + std::to_string(::getpid()));
}

// The results of the bundled cohort, simulated once (files written to a scratch folder, removed).
const std::vector<CohortResult>& fresh() {
  static const std::vector<CohortResult> r = [] {
    const auto dir = scratch("results");
    auto results = write_cohort(dir);
    std::filesystem::remove_all(dir);
    return results;
  }();
  return r;
}

double drawn(const BenchCase& c, const std::string& name) {
  for (const auto& p : parameter_list(c)) {
    if (p.name == name) return p.value;
  }
  throw std::runtime_error("no parameter " + name);
}

// Whitespace-separated tokens; numbers compared to 1e-6 relative, everything else exactly.
bool same_text(const std::filesystem::path& a, const std::filesystem::path& b, std::string& where) {
  std::ifstream fa(a), fb(b);
  std::string la, lb;
  for (int line = 1;; ++line) {
    const bool ga = static_cast<bool>(std::getline(fa, la)), gb = static_cast<bool>(std::getline(fb, lb));
    if (ga != gb) return where = a.filename().string() + ": different line counts", false;
    if (!ga) return true;
    std::istringstream ta(la), tb(lb);
    std::string x, y;
    while (true) {
      const bool hx = static_cast<bool>(ta >> x), hy = static_cast<bool>(tb >> y);
      if (hx != hy) return where = a.filename().string() + ":" + std::to_string(line), false;
      if (!hx) break;
      if (x == y) continue;
      char* ex = nullptr;
      char* ey = nullptr;
      const double vx = std::strtod(x.c_str(), &ex), vy = std::strtod(y.c_str(), &ey);
      const bool numbers = ex != x.c_str() && ey != y.c_str() && std::string(ex) == std::string(ey);
      if (!numbers || std::abs(vx - vy) > 1e-6 * std::max(1.0, std::abs(vx))) {
        return where = a.filename().string() + ":" + std::to_string(line) + ": '" + x + "' vs '" + y + "'", false;
      }
    }
  }
}

TEST(ForeignCohort, BundledFilesEqualWhatTheProgramWrites) {
  const auto dir = scratch("files");
  std::filesystem::remove_all(dir);
  write_cohort(dir);
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names.size(), 26u);  // 24 subjects + cases.yaml + subjects.yaml
  size_t bundled = 0;
  for (const auto& e : std::filesystem::directory_iterator(kBundled)) bundled += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(bundled, names.size()) << "stale or missing files in " << kBundled;
  for (const auto& n : names) {
    std::string where;
    EXPECT_TRUE(same_text(kBundled / n, dir / n, where)) << where;
    EXPECT_LT(std::filesystem::file_size(kBundled / n), 20'000u) << n;
  }
  std::filesystem::remove_all(dir);
}

TEST(ForeignCohort, DrawsHaveTheStatedMeanAndSpread) {
  // 200 subjects per simulator and group: the drawn factors have mean 1 and cv 10 % (standard
  // errors 0.7 % and 0.5 %; tolerances 3 standard errors), and the draws repeat with the seed.
  CohortOptions o;
  o.per_model_and_group = 200;
  const auto subjects = cohort_subjects(o);
  ASSERT_EQ(subjects.size(), 1200u);
  const auto nominal = bench_cases();
  for (const char* group : {"healthy", "stiff"}) {
    for (const char* model : {"elastance", "one-fibre"}) {
      const auto base = std::find_if(nominal.begin(), nominal.end(), [&](const BenchCase& c) {
        return c.model == model && c.name == group;
      });
      ASSERT_NE(base, nominal.end());
      for (const auto& name : drawn_parameters(model)) {
        std::vector<double> f;
        for (const auto& s : subjects) {
          if (s.group == group && s.bench_case.model == model) f.push_back(drawn(s.bench_case, name) / drawn(*base, name));
        }
        ASSERT_EQ(f.size(), 200u);
        double mean = 0.0, var = 0.0;
        for (double v : f) mean += v / 200.0;
        for (double v : f) var += (v - mean) * (v - mean) / 199.0;
        EXPECT_NEAR(mean, 1.0, 0.021) << group << " " << model << " " << name;
        EXPECT_NEAR(std::sqrt(var) / mean, 0.10, 0.015) << group << " " << model << " " << name;
      }
    }
  }
  const auto again = cohort_subjects();
  const auto first = cohort_subjects();
  for (size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(drawn(first[i].bench_case, "P_pv"), drawn(again[i].bench_case, "P_pv"));
  }
}

TEST(ForeignCohort, GroupsHaveTheirPhenotypesAndOnlyTheIntendedLoad) {
  std::map<std::string, std::vector<const CohortResult*>> by_group;
  for (const auto& r : fresh()) by_group[r.subject.group].push_back(&r);
  ASSERT_EQ(by_group.size(), 3u);
  double healthy_ef_min = 100, healthy_edp_max = 0, healthy_peak_max = 0;
  for (const auto* r : by_group["healthy"]) {
    healthy_ef_min = std::min(healthy_ef_min, r->indices.EF);
    healthy_edp_max = std::max(healthy_edp_max, r->indices.EDP);
    healthy_peak_max = std::max(healthy_peak_max, r->indices.P_peak);
  }
  EXPECT_GT(healthy_ef_min, 50.0);
  for (const auto& [group, rs] : by_group) {
    EXPECT_EQ(rs.size(), 8u) << group;
    for (const auto* r : rs) {
      EXPECT_NEAR(r->indices.heart_rate, 70.0, 1e-9);
      EXPECT_EQ(r->beat.frames.size(), 30u);
      EXPECT_EQ(r->beat.frames.front().t, 0.0);
      if (group == "reduced") {
        EXPECT_LT(r->indices.EF, healthy_ef_min - 10.0) << r->subject.id;
        EXPECT_GT(r->indices.EDV, 180.0) << r->subject.id;
      }
      if (group == "stiff") {
        EXPECT_GT(r->indices.EDP, healthy_edp_max + 5.0) << r->subject.id;
        EXPECT_GT(r->indices.P_peak, healthy_peak_max + 10.0) << r->subject.id;
        EXPECT_LT(r->indices.EDV, 125.0) << r->subject.id;
      }
    }
  }
  // The reduced group keeps the healthy arterial load: Zc and P_ven exactly, R_sys and C_sys
  // drawn around the healthy nominal.
  const auto nominal = bench_cases();
  for (const auto* r : by_group["reduced"]) {
    const auto healthy = std::find_if(nominal.begin(), nominal.end(), [&](const BenchCase& c) {
      return c.model == r->subject.bench_case.model && c.name == "healthy";
    });
    EXPECT_EQ(drawn(r->subject.bench_case, "Zc"), drawn(*healthy, "Zc"));
    EXPECT_EQ(drawn(r->subject.bench_case, "P_ven"), drawn(*healthy, "P_ven"));
    EXPECT_NEAR(drawn(r->subject.bench_case, "R_sys") / drawn(*healthy, "R_sys"), 1.0, 0.35);
  }
}

}  // namespace
}  // namespace foreign
