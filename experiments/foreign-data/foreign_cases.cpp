#include "foreign_cases.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace foreign {
namespace {

// Targets (README "Cases"): healthy adult SSFP-CMR volumes (Hudsmith et al. 2005, J Cardiovasc
// Magn Reson 7:775: EDV 160 +- 29 mL in men, 135 +- 26 mL in women; Maceira et al. 2006, J
// Cardiovasc Magn Reson 8:417), EF 55-65 %, EDP 6-12 mmHg; reduced contractility = dilated
// HFrEF, EF ~30 %; stiff wall + high afterload = hypertensive HFpEF, EF >= 55 %, high EDP,
// peak LV >= 160 mmHg.
ElastanceParameters elastance_healthy() {
  ElastanceParameters p;
  p.heart_rate = 65.0;
  return p;
}

OneFibreParameters one_fibre_healthy() {
  OneFibreParameters p;
  p.heart_rate = 72.0;
  return p;
}

MooneyRivlinParameters mooney_rivlin_healthy() { return MooneyRivlinParameters{}; }

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Standard normal deviates from mt19937_64 by Box-Muller, so the noise is the same with every
// standard library (std::normal_distribution is implementation-defined).
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : rng_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(rng_() >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
    const double u2 = static_cast<double>(rng_() >> 11) * 0x1.0p-53;          // [0, 1)
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * 3.141592653589793 * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * 3.141592653589793 * u2);
  }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

std::string model_line(const BenchCase& c) {
  if (c.model == "elastance") {
    return "time-varying elastance LV (double-Hill, Stergiopulos 1996) + exponential EDPVR, "
           "elastance atrium, diode valves, 3-element Windkessel";
  }
  if (c.model == "mooney-rivlin") {
    return "thin-walled sphere, Mooney-Rivlin wall (Adkins & Rivlin 1952) + active stress prescribed "
           "in time (Korakianitis & Shi 2006), elastance atrium, diode valves, 3-element Windkessel";
  }
  return "one-fibre LV (Arts 1991) + sarcomere active stress (Kerckhoffs 2003), elastance "
         "atrium, diode valves, 3-element Windkessel";
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("foreign_lv: cannot write " + path.string());
  f << text;
  if (!f) throw std::runtime_error("foreign_lv: write failed for " + path.string());
}

// Ventricular activation onset relative to end-diastole, in (-T/2, T/2].
double activation_after_ed(const Beat& b) {
  double d = -b.t_ed_cycle;
  while (d <= -0.5 * b.period) d += b.period;
  return d;
}

}  // namespace

std::vector<BenchCase> bench_cases() {
  std::vector<BenchCase> cases;
  {
    BenchCase c{"elastance", "healthy", "healthy adult, 65 bpm, with atrial contraction",
                elastance_healthy(), 101};
    cases.push_back(c);
    auto p = elastance_healthy();
    p.kick = 0.0;
    cases.push_back({"elastance", "healthy-no-atrial",
                     "healthy adult, 65 bpm, no atrial contraction (atrial kick off)", p, 102});
  }
  {
    ElastanceParameters p;  // dilated, hypocontractile (HFrEF-like)
    p.heart_rate = 85.0;
    p.tau1 = 0.20; p.tau2 = 0.36;                 // activation [s]
    p.Ees = 0.7; p.V0_es = 0.0;                   // weak ESPVR [mmHg/mL], [mL]
    p.A_ed = 0.4; p.B_ed = 0.02; p.V0_ed = 20.0;  // compliant, dilated EDPVR
    p.P_pv = 12.0; p.R_sys = 0.85; p.C_sys = 1.4;  // raised preload, circulation
    cases.push_back({"elastance", "reduced", "reduced contractility, dilated (EF ~30 %), 85 bpm", p,
                     103});
  }
  {
    ElastanceParameters p;  // hypertrophied, stiff, hypertensive (HFpEF-like)
    p.heart_rate = 75.0;
    p.tau1 = 0.22; p.tau2 = 0.37;  // activation [s]
    p.Ees = 4.5; p.V0_es = 10.0;   // steep ESPVR [mmHg/mL], [mL]
    p.A_ed = 0.5; p.B_ed = 0.04;   // stiff EDPVR [mmHg], [1/mL]
    p.P_pv = 15.0;                 // raised filling pressure [mmHg]
    p.R_sys = 1.6; p.C_sys = 0.7; p.Zc = 0.08;  // high, stiff afterload
    cases.push_back({"elastance", "stiff", "stiff wall, high afterload (HFpEF-like), 75 bpm", p, 104});
  }
  {
    cases.push_back({"one-fibre", "healthy", "healthy adult, 72 bpm, with atrial contraction",
                     one_fibre_healthy(), 201});
    auto p = one_fibre_healthy();
    p.atrial_contraction = false;
    cases.push_back({"one-fibre", "healthy-no-atrial",
                     "healthy adult, 72 bpm, no atrial contraction", p, 202});
  }
  {
    OneFibreParameters p;  // dilated, hypocontractile (HFrEF-like)
    p.heart_rate = 90.0;
    p.V_wall = 170.0; p.V_ref = 80.0;  // thin-walled, dilated [mL]
    p.c_p = 1.0; p.T0 = 80.0;          // passive scale, weak active stress
    p.P_pv = 15.0; p.R_sys = 0.85;     // raised preload, circulation
    cases.push_back({"one-fibre", "reduced", "reduced contractility, dilated (EF ~30 %), 90 bpm", p,
                     203});
  }
  {
    OneFibreParameters p;  // hypertrophied (thick wall), stiff, hypertensive (HFpEF-like)
    p.heart_rate = 60.0;
    p.V_wall = 220.0;                  // thick wall [mL]
    p.c_p = 2.0; p.k_p = 14.0;         // stiff passive fibre law
    p.T0 = 160.0;                      // preserved active stress
    p.P_pv = 15.0;                     // raised filling pressure [mmHg]
    p.R_sys = 1.6; p.C_sys = 0.8; p.Zc = 0.08;  // high, stiff afterload
    cases.push_back({"one-fibre", "stiff", "stiff wall, high afterload (HFpEF-like), 60 bpm", p, 204});
  }
  {
    cases.push_back({"mooney-rivlin", "healthy", "healthy adult, 68 bpm, with atrial contraction",
                     mooney_rivlin_healthy(), 301});
    MooneyRivlinParameters n = mooney_rivlin_healthy();
    n.kick = 0.0;
    cases.push_back({"mooney-rivlin", "healthy-no-atrial", "healthy adult, 68 bpm, no atrial contraction",
                     n, 304});
    MooneyRivlinParameters p;  // dilated, hypocontractile (HFrEF-like)
    p.heart_rate = 88.0;
    p.V0 = 130.0; p.V_wall = 170.0;    // dilated, thinner [mL]
    p.T_max = 16.0;                    // weak active stress for its size [kPa]
    p.C1 = 1.2; p.C2 = 0.6;            // fibrotic [kPa]
    p.P_pv = 14.0; p.R_sys = 0.85;     // raised preload, circulation
    cases.push_back({"mooney-rivlin", "reduced", "reduced contractility, dilated (EF ~30 %), 88 bpm", p,
                     302});
    MooneyRivlinParameters q;  // hypertrophied, stiff, hypertensive (HFpEF-like)
    q.heart_rate = 64.0;
    q.V_wall = 210.0; q.V0 = 55.0;      // thick wall [mL]
    q.C1 = 0.9; q.C2 = 0.45;            // stiff [kPa]
    q.T_max = 28.0;                     // preserved active stress [kPa]
    q.P_pv = 16.0;
    q.R_sys = 1.6; q.C_sys = 0.8; q.Zc = 0.08;
    cases.push_back({"mooney-rivlin", "stiff", "stiff wall, high afterload (HFpEF-like), 64 bpm", q, 303});
  }
  // Harder acquisitions (README "Harder acquisitions"): clinical frame counts, heart rates from 50
  // to 110 bpm, noise 1-4 mL / mmHg, missing frames and a trigger 30-60 ms after end-diastole.
  {
    BenchCase c{"one-fibre", "healthy-20f", "healthy, 20 frames, trigger +40 ms, noise 3 mL / 3 mmHg",
                one_fibre_healthy(), 211, 3.0, 3.0, 20, 0.040, {}};
    cases.push_back(c);
  }
  {
    ElastanceParameters p;  // the reduced case, at 25 frames with two dropped
    p = std::get<ElastanceParameters>(cases[2].parameters);
    cases.push_back({"elastance", "reduced-25f",
                     "reduced contractility, 25 frames, 2 missing, trigger +30 ms, noise 4 mL / 2 mmHg",
                     p, 113, 4.0, 2.0, 25, 0.030, {7, 16}});
  }
  {
    ElastanceParameters p = elastance_healthy();
    p.heart_rate = 110.0;  // tachycardia: the same ventricle, a short diastole
    cases.push_back({"elastance", "healthy-110bpm", "healthy ventricle at 110 bpm, 25 frames, trigger +50 ms, "
                     "noise 2 mL / 4 mmHg, 2 missing", p, 114, 2.0, 4.0, 25, 0.050, {3, 19}});
  }
  {
    MooneyRivlinParameters p = mooney_rivlin_healthy();
    p.heart_rate = 50.0;  // bradycardia: a long diastasis
    cases.push_back({"mooney-rivlin", "healthy-50f", "healthy at 50 bpm, 50 frames, trigger +60 ms, "
                     "noise 1 mL / 1 mmHg", p, 311, 1.0, 1.0, 50, 0.060, {}});
  }
  return cases;
}

std::unique_ptr<LvCircuit> make_circuit(const BenchCase& c) {
  if (const auto* e = std::get_if<ElastanceParameters>(&c.parameters)) {
    return std::make_unique<ElastanceLv>(*e);
  }
  if (const auto* m = std::get_if<MooneyRivlinParameters>(&c.parameters)) {
    return std::make_unique<MooneyRivlinLv>(*m);
  }
  return std::make_unique<OneFibreLv>(std::get<OneFibreParameters>(c.parameters));
}

namespace {

// The ventricle's own parameters, then those of the circuit both three-state simulators share
// (three_state_sample in foreign_bench.h), in declaration order.
template <class P>
std::vector<NamedValue> with_circuit(std::vector<NamedValue> own, const P& p) {
  own.insert(own.end(), {{"E_la_min", p.E_la_min, "mmHg/mL"}, {"E_la_max", p.E_la_max, "mmHg/mL"},
                         {"V0_la", p.V0_la, "mL"},            {"kick", p.kick, "1"},
                         {"t_la_onset", p.t_la_onset, "s"},   {"T_la", p.T_la, "s"},
                         {"P_pv", p.P_pv, "mmHg"},            {"R_pv", p.R_pv, "mmHg s/mL"},
                         {"R_mv", p.R_mv, "mmHg s/mL"},       {"R_av", p.R_av, "mmHg s/mL"},
                         {"Zc", p.Zc, "mmHg s/mL"},           {"R_sys", p.R_sys, "mmHg s/mL"},
                         {"C_sys", p.C_sys, "mL/mmHg"},       {"P_ven", p.P_ven, "mmHg"}});
  return own;
}

}  // namespace

std::vector<NamedValue> parameter_list(const BenchCase& c) {
  if (const auto* e = std::get_if<ElastanceParameters>(&c.parameters)) {
    const auto& p = *e;
    return with_circuit({{"heart_rate", p.heart_rate, "bpm"}, {"Ees", p.Ees, "mmHg/mL"},
            {"V0_es", p.V0_es, "mL"},            {"A_ed", p.A_ed, "mmHg"},
            {"B_ed", p.B_ed, "1/mL"},            {"V0_ed", p.V0_ed, "mL"},
            {"tau1", p.tau1, "s"},               {"tau2", p.tau2, "s"},
            {"m1", p.m1, "1"},                   {"m2", p.m2, "1"}},
           p);
  }
  if (const auto* m = std::get_if<MooneyRivlinParameters>(&c.parameters)) {
    const auto& p = *m;
    return with_circuit({{"heart_rate", p.heart_rate, "bpm"}, {"V_wall", p.V_wall, "mL"},
            {"V0", p.V0, "mL"},                  {"C1", p.C1, "kPa"},
            {"C2", p.C2, "kPa"},                 {"T_max", p.T_max, "kPa"},
            {"beta", p.beta, "1"},
            {"T1", p.T1, "s"},                   {"T2", p.T2, "s"}},
           p);
  }
  const auto& p = std::get<OneFibreParameters>(c.parameters);
  return {{"heart_rate", p.heart_rate, "bpm"},
          {"V_wall", p.V_wall, "mL"},
          {"V_ref", p.V_ref, "mL"},
          {"l_s_ref", p.l_s_ref, "um"},
          {"c_p", p.c_p, "kPa"},
          {"k_p", p.k_p, "1"},
          {"T0", p.T0, "kPa"},
          {"E_a", p.E_a, "1/um"},
          {"a_l", p.a_l, "1/um"},
          {"l_c0", p.l_c0, "um"},
          {"v0", p.v0, "um/s"},
          {"tau_r", p.tau_r, "s"},
          {"tau_d", p.tau_d, "s"},
          {"b", p.b, "s/um"},
          {"l_d", p.l_d, "um"},
          {"E_la_passive", p.E_la_passive, "mmHg/mL"},
          {"E_la_active", p.E_la_active, "mmHg/mL"},
          {"V0_la", p.V0_la, "mL"},
          {"atrial_contraction", p.atrial_contraction ? 1.0 : 0.0, "1"},
          {"t_la_lead", p.t_la_lead, "s"},
          {"T_la", p.T_la, "s"},
          {"P_pv", p.P_pv, "mmHg"},
          {"R_pv", p.R_pv, "mmHg s/mL"},
          {"R_mv", p.R_mv, "mmHg s/mL"},
          {"R_av", p.R_av, "mmHg s/mL"},
          {"Zc", p.Zc, "mmHg s/mL"},
          {"R_sys", p.R_sys, "mmHg s/mL"},
          {"C_sys", p.C_sys, "mL/mmHg"},
          {"P_ven", p.P_ven, "mmHg"}};
}

std::vector<std::array<double, 3>> noisy_frames(const Beat& beat, const BenchCase& c) {
  Gaussian g(c.seed);
  std::vector<std::array<double, 3>> out;
  for (const auto& s : beat.frames) {
    const double nv = g();
    const double np = g();
    out.push_back({s.t, s.V_lv + c.noise_V * nv, s.P_lv + c.noise_P * np});
    const int k = static_cast<int>(out.size()) - 1;
    if (std::find(c.missing.begin(), c.missing.end(), k) != c.missing.end()) {
      out.back()[1] = out.back()[2] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  return out;
}

std::vector<BenchResult> write_bench(const std::filesystem::path& out) {
  std::filesystem::create_directories(out);
  std::vector<BenchResult> results;
  for (const auto& c : bench_cases()) {
    const auto sim = make_circuit(c);
    BenchResult r{c, run_beat(*sim, 1e-3, c.frames, {}, c.frame_offset), {}};
    r.indices = indices_of(r.beat);
    results.push_back(r);
  }

  for (const auto& r : results) {
    const auto& c = r.bench_case;
    const auto& x = r.indices;
    std::ostringstream head;
    head << "# foreign-data bench (experiments/foreign-data): LV curves NOT made by a sigmaheart model\n"
         << "# model: " << model_line(c) << "\n"
         << "# case: " << c.name << " - " << c.description << "\n"
         << "# heart rate " << fmt("%.1f", x.heart_rate) << " bpm, period " << fmt("%.6f", r.beat.period)
         << " s; t = 0 at end-diastole (mitral closure, maximum volume)"
         << (c.frame_offset != 0.0 ? " in the dense reference" : "") << "\n";
    std::ostringstream csv;
    csv << head.str() << "# frames: " << r.beat.frames.size() << " per beat, t_k = k T / "
        << r.beat.frames.size() << "\n";
    if (c.frame_offset != 0.0) {
      csv << "# trigger " << fmt("%.0f", 1e3 * c.frame_offset)
          << " ms after end-diastole: frame k at end-diastole + " << fmt("%.3f", c.frame_offset)
          << " s + t_k (t = 0 is the trigger here)\n";
    }
    if (!c.missing.empty()) csv << "# missing frames (empty cells): " << c.missing.size() << "\n";
    csv
        << "# noise V_lv: Gaussian, std " << fmt("%g", c.noise_V) << " mL\n"
        << "# noise P_lv: Gaussian, std " << fmt("%g", c.noise_P) << " mmHg\n"
        << "# seed " << c.seed << " (mt19937_64, Box-Muller)\n"
        << "# noise-free reference: " << c.file_stem() << ".dense.csv\n"
        << "time [s], V_lv [mL], P_lv [mmHg]\n";
    for (const auto& f : noisy_frames(r.beat, c)) {
      if (std::isnan(f[1])) {
        csv << fmt("%.6f", f[0]) << ", , \n";
      } else {
        csv << fmt("%.6f", f[0]) << ", " << fmt("%.3f", f[1]) << ", " << fmt("%.3f", f[2]) << "\n";
      }
    }
    write_file(out / (c.file_stem() + ".csv"), csv.str());

    std::ostringstream dense;
    dense << head.str() << "# dense noise-free reference, every 1 ms over one beat\n"
          << "time [s], V_lv [mL], P_lv [mmHg], P_la [mmHg], P_ao [mmHg], Q_mv [mL/s], Q_av [mL/s]\n";
    for (const auto& s : r.beat.dense) {
      dense << fmt("%.3f", s.t) << ", " << fmt("%.4f", s.V_lv) << ", " << fmt("%.4f", s.P_lv) << ", "
            << fmt("%.4f", s.P_la) << ", " << fmt("%.4f", s.P_ao) << ", " << fmt("%.3f", s.Q_mv)
            << ", " << fmt("%.3f", s.Q_av) << "\n";
    }
    write_file(out / (c.file_stem() + ".dense.csv"), dense.str());
  }

  std::ostringstream y;
  y << "# Foreign-data bench: LV curves from simulators that share no code with the BCS models.\n"
    << "# Regenerate: build/experiments/foreign-data/foreign_lv --out configs/data/foreign\n"
    << "# Indices from the noise-free dense beat (1 ms): EDV = V at t = 0 (end-diastole), ESV = min V,\n"
    << "# peak = max P_lv, EDP = P_lv at t = 0, dP/dt max by central differences.\n"
    << "cases:\n";
  for (const auto& r : results) {
    const auto& c = r.bench_case;
    const auto& x = r.indices;
    y << "  - name: " << c.file_stem() << "\n"
      << "    model: " << c.model << "\n"
      << "    case: " << c.name << "\n"
      << "    description: \"" << c.description << "\"\n"
      << "    observations: " << c.file_stem() << ".csv\n"
      << "    dense_reference: " << c.file_stem() << ".dense.csv\n"
      << "    heart_rate: " << fmt("%.1f", x.heart_rate) << "    # [bpm]\n"
      << "    period: " << fmt("%.6f", r.beat.period) << "      # [s]\n"
      << "    activation_onset: " << fmt("%.4f", activation_after_ed(r.beat))
      << "  # [s] ventricular activation onset after end-diastole (< 0: before)\n"
      << "    noise: {V_lv: " << fmt("%g", c.noise_V) << ", P_lv: " << fmt("%g", c.noise_P)
      << ", seed: " << c.seed << "}  # [mL], [mmHg] Gaussian std\n";
    if (c.clinical()) {
      y << "    acquisition: {frames: " << c.frames << ", trigger_after_ed: " << fmt("%.3f", c.frame_offset)
        << ", missing_frames: [";
      for (size_t k = 0; k < c.missing.size(); ++k) y << (k ? ", " : "") << c.missing[k];
      y << "]}  # [1], [s], frame indices\n";
    }
    y
      << "    indices:\n"
      << "      EDV: " << fmt("%.1f", x.EDV) << "       # [mL]\n"
      << "      ESV: " << fmt("%.1f", x.ESV) << "       # [mL]\n"
      << "      SV: " << fmt("%.1f", x.SV) << "        # [mL]\n"
      << "      EF: " << fmt("%.1f", x.EF) << "        # [%]\n"
      << "      P_peak: " << fmt("%.1f", x.P_peak) << "    # [mmHg]\n"
      << "      EDP: " << fmt("%.1f", x.EDP) << "       # [mmHg]\n"
      << "      dPdt_max: " << fmt("%.0f", x.dPdt_max) << "  # [mmHg/s]\n"
      << "      P_ao: [" << fmt("%.1f", x.P_ao_dia) << ", " << fmt("%.1f", x.P_ao_sys)
      << "]  # [mmHg] min, max\n"
      << "      CO: " << fmt("%.2f", x.CO) << "        # [L/min]\n"
      << "    periodic: {beats: " << r.beat.beats_to_periodic << ", change: "
      << fmt("%.1e", r.beat.periodic_change) << "}\n"
      << "    parameters:\n";
    for (const auto& p : parameter_list(c)) {
      y << "      " << p.name << ": " << fmt("%g", p.value) << "  # [" << p.unit << "]\n";
    }
  }
  write_file(out / "cases.yaml", y.str());
  return results;
}

}  // namespace foreign
