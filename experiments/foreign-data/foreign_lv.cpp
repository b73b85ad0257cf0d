// foreign_lv: regenerates the foreign-data bench (experiments/foreign-data/README.md) or the
// foreign cohort of the specificity study (foreign_cohort.h).
//
//   build/experiments/foreign-data/foreign_lv --out configs/data/foreign
//   build/experiments/foreign-data/foreign_lv --cohort configs/data/foreign-cohort
//
// --out writes <model>-<case>.csv (30 noisy frames), <model>-<case>.dense.csv (1 ms, noise-free)
// and cases.yaml; --cohort writes <subject>.csv, cases.yaml and subjects.yaml. Each prints one
// line of indices per case. Deterministic.
#include "foreign_cases.h"
#include "foreign_cohort.h"

#include <cstdio>
#include <exception>
#include <string>

namespace {

void print_header() {
  std::printf("%-30s %6s %7s %7s %6s %7s %6s %8s %6s %5s\n", "case", "HR", "EDV", "ESV", "EF",
              "Ppeak", "EDP", "dPdtmax", "Pao_d", "beats");
}

void print_row(const std::string& name, const foreign::Indices& x, int beats) {
  std::printf("%-30s %6.1f %7.1f %7.1f %6.1f %7.1f %6.1f %8.0f %6.1f %5d\n", name.c_str(),
              x.heart_rate, x.EDV, x.ESV, x.EF, x.P_peak, x.EDP, x.dPdt_max, x.P_ao_dia, beats);
}

int usage(const char* program) {
  std::fprintf(stderr, "usage: %s --out DIR | --cohort DIR\n", program);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out, cohort;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--cohort" && i + 1 < argc) {
      cohort = argv[++i];
    } else {
      return usage(argv[0]);
    }
  }
  if (out.empty() == cohort.empty()) return usage(argv[0]);
  try {
    print_header();
    if (!out.empty()) {
      for (const auto& r : foreign::write_bench(out)) {
        print_row(r.bench_case.file_stem(), r.indices, r.beat.beats_to_periodic);
      }
    } else {
      for (const auto& r : foreign::write_cohort(cohort)) {
        print_row(r.subject.id, r.indices, r.beat.beats_to_periodic);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "foreign_lv: %s\n", e.what());
    return 1;
  }
  return 0;
}
