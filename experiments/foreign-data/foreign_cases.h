// The cases of the foreign-data bench and their export (measurement-like CSV, dense reference,
// cases.yaml). `foreign_lv --out DIR` is write_bench(DIR).
#pragma once

#include "elastance_lv.h"
#include "foreign_bench.h"
#include "mooney_rivlin_lv.h"
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
  std::string model;        ///< "elastance", "one-fibre" or "mooney-rivlin"
  std::string name;         ///< e.g. "healthy"
  std::string description;  ///< one line
  std::variant<ElastanceParameters, OneFibreParameters, MooneyRivlinParameters> parameters;
  std::uint64_t seed = 1;   ///< noise seed (mt19937_64 + Box-Muller: identical on every platform)
  double noise_V = 2.0;     ///< [mL] Gaussian noise std on the exported V_lv frames
  double noise_P = 2.0;     ///< [mmHg] Gaussian noise std on the exported P_lv frames
  // Acquisition (the clinical conditions of README "Harder acquisitions"):
  int frames = 30;             ///< frames per beat
  double frame_offset = 0.0;   ///< [s] trigger delay: frame 0 this long after end-diastole
  std::vector<int> missing;    ///< frames written as empty cells (dropped out of the acquisition)
  std::string file_stem() const { return model + "-" + name; }
  bool clinical() const { return frames != 30 || frame_offset != 0.0 || !missing.empty(); }
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

/// The measurement-like frames: Beat::frames plus Gaussian noise (n_frames x 3: t, V, P); a missing
/// frame has NaN V and P (its noise is drawn all the same, so the others keep theirs).
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
