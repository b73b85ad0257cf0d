// The cases of the foreign-data bench and their export (measurement-like CSV, dense reference,
// cases.yaml). `foreign_lv --out DIR` is write_bench(DIR).
#pragma once

#include "elastance_lv.h"
#include "foreign_bench.h"
#include "one_fibre_lv.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace foreign {

struct BenchCase {
  std::string model;        ///< "elastance" or "one-fibre"
  std::string name;         ///< e.g. "healthy"
  std::string description;  ///< one line
  std::variant<ElastanceParameters, OneFibreParameters> parameters;
  std::uint64_t seed = 1;   ///< noise seed (mt19937_64 + Box-Muller: identical on every platform)
  double noise_V = 2.0;     ///< [mL] Gaussian noise std on the exported V_lv frames
  double noise_P = 2.0;     ///< [mmHg] Gaussian noise std on the exported P_lv frames
  std::string file_stem() const { return model + "-" + name; }
};

/// The bench: for each model healthy, healthy without atrial contraction, reduced
/// contractility, stiff wall with high afterload.
std::vector<BenchCase> bench_cases();

std::unique_ptr<LvCircuit> make_circuit(const BenchCase& c);

/// (name, value, unit) of every parameter of the case, in declaration order.
struct NamedValue {
  std::string name;
  double value;
  std::string unit;
};
std::vector<NamedValue> parameter_list(const BenchCase& c);

/// The 30 measurement-like frames: Beat::frames plus Gaussian noise (n_frames x 3: t, V, P).
std::vector<std::array<double, 3>> noisy_frames(const Beat& beat, const BenchCase& c);

struct BenchResult {
  BenchCase bench_case;
  Beat beat;
  Indices indices;
};

/// Simulates every case; then writes <stem>.csv, <stem>.dense.csv and cases.yaml into `out`
/// (created if needed). Deterministic. Returns the results (for printing and tests).
std::vector<BenchResult> write_bench(const std::filesystem::path& out);

}  // namespace foreign
