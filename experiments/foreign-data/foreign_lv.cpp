// foreign_lv: regenerates the foreign-data bench (experiments/foreign-data/README.md).
//
//   build/experiments/foreign-data/foreign_lv --out configs/data/foreign
//
// Writes <model>-<case>.csv (30 noisy frames), <model>-<case>.dense.csv (1 ms, noise-free) and
// cases.yaml, and prints one line of indices per case. Deterministic.
#include "foreign_cases.h"

#include <cstdio>
#include <exception>
#include <string>

int main(int argc, char** argv) {
  std::string out;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s --out DIR\n", argv[0]);
      return 2;
    }
  }
  if (out.empty()) {
    std::fprintf(stderr, "usage: %s --out DIR\n", argv[0]);
    return 2;
  }
  try {
    const auto results = foreign::write_bench(out);
    std::printf("%-30s %6s %7s %7s %6s %7s %6s %8s %6s %5s\n", "case", "HR", "EDV", "ESV", "EF",
                "Ppeak", "EDP", "dPdtmax", "Pao_d", "beats");
    for (const auto& r : results) {
      const auto& x = r.indices;
      std::printf("%-30s %6.1f %7.1f %7.1f %6.1f %7.1f %6.1f %8.0f %6.1f %5d\n",
                  r.bench_case.file_stem().c_str(), x.heart_rate, x.EDV, x.ESV, x.EF, x.P_peak,
                  x.EDP, x.dPdt_max, x.P_ao_dia, r.beat.beats_to_periodic);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "foreign_lv: %s\n", e.what());
    return 1;
  }
  return 0;
}
