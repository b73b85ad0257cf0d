// The cases of the foreign regional bench (experiments/regional-foreign/README.md) and the
// statistics its targets are stated in, for the benchmark (bench/regional_foreign_bench.cpp);
// summarize.py computes the same from the JSON summaries. Header-only, no sigmaheart dependency.
#pragma once

#include <algorithm>
#include <map>
#include <string>
#include <vector>

namespace sigmaheart::regional_foreign {

struct ForeignCase {
  std::string name;            // configs/data/regional-foreign/<name>.csv
  std::vector<int> infarct;    // segments at 40 % contractility in the 3D heart (make-data)
};

// The eight 3D hearts (make-data): healthy, LBBB, LBBB with an LAD / LCx / RCA infarct, large (the
// territory, Cerqueira et al. 2002) and small (three segments).
inline const std::vector<ForeignCase>& cases() {
  static const std::vector<ForeignCase> c = {
      {"healthy", {}},
      {"lbbb", {}},
      {"lbbb-lad-large", {1, 2, 7, 8, 13, 14, 17}},
      {"lbbb-lad-small", {7, 13, 14}},
      {"lbbb-lcx-large", {5, 6, 11, 12, 16}},
      {"lbbb-lcx-small", {5, 6, 11}},
      {"lbbb-rca-large", {3, 4, 9, 10, 15}},
      {"lbbb-rca-small", {4, 10, 15}},
  };
  return c;
}

// The latest-activated segments of lv-3d's LBBB (docs/models.md s.4.6: the lateral wall).
inline const std::vector<int>& late_segments() {
  static const std::vector<int> s = {5, 6, 11, 12, 16};
  return s;
}

// Estimated scar: contractility below this fraction of the median of segments 1-16 (segment 17
// holds no cavity volume in lv-3d, docs/models.md s.5, and is left out of every statistic).
inline constexpr double kScarFraction = 0.6;

inline bool contains(const std::vector<int>& v, int s) { return std::find(v.begin(), v.end(), s) != v.end(); }

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The statistics of one case from the estimated contractility of segments 1-16.
struct CaseStatistics {
  double median = 0.0;                     // [Pa]
  double auc = -1.0;                       // P(infarct segment < other segment), ties 1/2; -1: no infarct
  double min_relative = 0.0;               // lowest segment / median
  std::vector<int> scar;                   // below kScarFraction x median
  std::vector<int> late_healthy_in_scar;   // late-activated segments outside the infarct among them
};
inline CaseStatistics statistics(const std::map<int, double>& sigma0, const std::vector<int>& infarct) {
  CaseStatistics s;
  std::vector<double> v;
  for (const auto& [seg, value] : sigma0) v.push_back(value);
  s.median = regional_foreign::median(v);
  s.min_relative = *std::min_element(v.begin(), v.end()) / s.median;
  for (const auto& [seg, value] : sigma0) {
    if (value >= kScarFraction * s.median) continue;
    s.scar.push_back(seg);
    if (contains(late_segments(), seg) && !contains(infarct, seg)) s.late_healthy_in_scar.push_back(seg);
  }
  double wins = 0.0, pairs = 0.0;
  for (const auto& [a, va] : sigma0) {
    if (!contains(infarct, a)) continue;
    for (const auto& [b, vb] : sigma0) {
      if (contains(infarct, b)) continue;
      wins += va < vb ? 1.0 : va == vb ? 0.5 : 0.0;
      pairs += 1.0;
    }
  }
  if (pairs > 0) s.auc = wins / pairs;
  return s;
}

}  // namespace sigmaheart::regional_foreign
