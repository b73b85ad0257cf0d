// The foreign-data bench (experiments/foreign-data) checked against expectations that do not come
// from its own code: conservation of mass, isovolumic phases, the Frank-Starling response,
// literature ranges of the targeted phenotypes, and that the bundled files are what the program
// writes.
#include "foreign_cases.h"
#include "foreign_ode.h"
#include "tests/support/expect_between.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace foreign {
namespace {

using sigmaheart::testing::expect_between;

const std::vector<BenchCase>& cases() {
  static const auto c = bench_cases();
  return c;
}

const BenchCase& find_case(const std::string& stem) {
  for (const auto& c : cases()) {
    if (c.file_stem() == stem) return c;
  }
  throw std::runtime_error("no case " + stem);
}

// Dense beats at 0.1 ms, computed once per case.
const Beat& fine_beat(const std::string& stem) {
  static std::vector<std::pair<std::string, Beat>> memo;
  for (const auto& [s, b] : memo) {
    if (s == stem) return b;
  }
  memo.emplace_back(stem, run_beat(*make_circuit(find_case(stem)), 1e-4));
  return memo.back().second;
}

// Trapezoidal integral of a flow over the dense beat [mL].
template <class Get>
double integral(const Beat& b, Get get) {
  double v = 0.0;
  for (size_t k = 1; k < b.dense.size(); ++k) {
    v += 0.5 * (get(b.dense[k]) + get(b.dense[k - 1])) * (b.dense[k].t - b.dense[k - 1].t);
  }
  return v;
}

TEST(ForeignBench, DormandPrinceMatchesExponentialDecay) {
  Eigen::VectorXd y(2);
  y << 1.0, 2.0;
  double h = 0.0;
  Dopri5Options o;
  o.rtol = 1e-10;
  o.atol = 1e-12;
  dopri5([](double, const Eigen::VectorXd& x, Eigen::VectorXd& dx) { dx = -3.0 * x; }, 0.0, 1.0,
         y, h, o);
  EXPECT_NEAR(y(0), std::exp(-3.0), 1e-9);
  EXPECT_NEAR(y(1), 2.0 * std::exp(-3.0), 1e-9);
}

class EveryCase : public ::testing::TestWithParam<std::string> {};

// Over a periodic beat the LV volume returns, mitral inflow equals aortic outflow, the atrium
// and the Windkessel pass on what they receive, and the ejected volume is EDV - ESV.
TEST_P(EveryCase, ConservesMassOverAPeriodicBeat) {
  const Beat& b = fine_beat(GetParam());
  const double EDV = b.dense.front().V_lv;
  double ESV = EDV;
  for (const auto& s : b.dense) ESV = std::min(ESV, s.V_lv);
  const double in_mv = integral(b, [](const Sample& s) { return s.Q_mv; });
  const double out_av = integral(b, [](const Sample& s) { return s.Q_av; });
  const double in_pv = integral(b, [](const Sample& s) { return s.Q_pv; });
  const double out_per = integral(b, [](const Sample& s) { return s.Q_per; });
  // Tolerances: the periodic state is met to 1e-6 relative (~1e-4 mL, ~1e-4 mmHg x C) and the
  // trapezoidal rule at 0.1 ms is accurate to ~1e-5 mL; observed errors are 1e-6 to 4e-3 mL.
  EXPECT_NEAR(b.dense.back().V_lv, EDV, 1e-4);
  EXPECT_NEAR(in_mv - out_av, 0.0, 1e-3) << "mitral " << in_mv << " mL, aortic " << out_av << " mL";
  EXPECT_NEAR(in_pv, in_mv, 1e-2);
  EXPECT_NEAR(out_per, out_av, 1e-2);
  EXPECT_NEAR(out_av, EDV - ESV, 1e-3) << "no regurgitation: all that leaves is EDV - ESV";
}

// Both valves closed: the volume holds (isovolumic contraction from end-diastole to aortic
// opening, isovolumic relaxation from aortic closure to mitral opening), the pressure rises in
// the first and falls in the second, and both last a physiological time (tens of ms).
TEST_P(EveryCase, IsovolumicPhasesHoldVolume) {
  const Beat& b = fine_beat(GetParam());
  // The Mooney-Rivlin sphere's activation is prescribed and decays 0.16 s after its peak: it
  // ejects in 0.15-0.19 s, and its stiff case opens the aortic valve 36 mmHg above its EDP of
  // 26 mmHg (README "Known departures"); the other families hold the physiological windows.
  const bool prescribed = GetParam().rfind("mooney-rivlin", 0) == 0;
  const auto& d = b.dense;
  auto closed = [](const Sample& s) { return s.Q_mv == 0.0 && s.Q_av == 0.0; };
  ASSERT_TRUE(closed(d.front())) << "t = 0 is end-diastole: mitral just closed";
  size_t k_open = 0;
  while (k_open < d.size() && closed(d[k_open])) ++k_open;
  ASSERT_LT(k_open, d.size());
  EXPECT_GT(d[k_open].Q_av, 0.0) << "the first valve to open after end-diastole is the aortic";
  const double ivc = d[k_open].t;
  for (size_t k = 0; k < k_open; ++k) EXPECT_NEAR(d[k].V_lv, d.front().V_lv, 1e-9);
  EXPECT_GT(d[k_open - 1].P_lv, d.front().P_lv + (prescribed ? 30.0 : 40.0));
  expect_between(ivc, 0.015, 0.150, "isovolumic contraction");

  size_t k_ac = k_open;  // aortic closure
  while (k_ac < d.size() && d[k_ac].Q_av > 0.0) ++k_ac;
  size_t k_mo = k_ac;  // mitral opening
  while (k_mo < d.size() && d[k_mo].Q_mv == 0.0) ++k_mo;
  ASSERT_LT(k_mo, d.size());
  for (size_t k = k_ac; k < k_mo; ++k) {
    EXPECT_TRUE(closed(d[k]));
    EXPECT_NEAR(d[k].V_lv, d[k_ac].V_lv, 1e-9);
  }
  EXPECT_LT(d[k_mo - 1].P_lv, d[k_ac].P_lv - 40.0);
  const double ivr = d[k_mo].t - d[k_ac].t;
  expect_between(ivr, 0.030, 0.200, "isovolumic relaxation");
  const double ejection = d[k_ac].t - d[k_open].t;
  // LV ejection time ~0.25-0.33 s at 60-90 bpm
  expect_between(ejection, prescribed ? 0.14 : 0.20, 0.36, "ejection");
}

// The exported frames start at end-diastole, are evenly spread over one beat, and differ from
// the noise-free frames by noise of the stated size.
TEST_P(EveryCase, FramesAreOneBeatFromEndDiastoleWithStatedNoise) {
  const auto& c = find_case(GetParam());
  const Beat b = run_beat(*make_circuit(c));
  ASSERT_EQ(b.frames.size(), 30u);
  EXPECT_EQ(b.frames.front().t, 0.0);
  EXPECT_NEAR(b.frames.back().t, b.period * 29.0 / 30.0, 1e-12);
  double vmax = 0.0;
  for (const auto& s : b.frames) vmax = std::max(vmax, s.V_lv);
  EXPECT_NEAR(b.frames.front().V_lv, vmax, 1e-9) << "frame 0 holds the largest volume";
  const auto noisy = noisy_frames(b, c);
  double sv = 0.0, sp = 0.0;
  for (size_t k = 0; k < noisy.size(); ++k) {
    sv += std::pow(noisy[k][1] - b.frames[k].V_lv, 2);
    sp += std::pow(noisy[k][2] - b.frames[k].P_lv, 2);
  }
  // sample std of 30 Gaussian deviates lies within [0.6, 1.4] x std with probability > 0.99
  expect_between(std::sqrt(sv / 30.0), 0.6 * c.noise_V, 1.4 * c.noise_V, "volume noise");
  expect_between(std::sqrt(sp / 30.0), 0.6 * c.noise_P, 1.4 * c.noise_P, "pressure noise");
}

INSTANTIATE_TEST_SUITE_P(ForeignBench, EveryCase,
                         ::testing::Values("elastance-healthy", "elastance-healthy-no-atrial",
                                           "elastance-reduced", "elastance-stiff",
                                           "one-fibre-healthy", "one-fibre-healthy-no-atrial",
                                           "one-fibre-reduced", "one-fibre-stiff",
                                           "mooney-rivlin-healthy", "mooney-rivlin-healthy-no-atrial",
                                           "mooney-rivlin-reduced", "mooney-rivlin-stiff"),
                         [](const auto& param_info) {
                           std::string n = param_info.param;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

// Frank-Starling: raising the filling pressure raises EDV and stroke volume, in both models with
// a length-dependent ventricle over 6-14 mmHg. (The Mooney-Rivlin sphere has a descending limb:
// beyond an end-diastolic stretch of 1.17 its end-systolic pressure falls with volume and at
// P_pv 14 mmHg it finds no periodic state; README "Known departures".)
TEST(ForeignBench, HigherPreloadRaisesStrokeVolume) {
  for (const std::string stem : {"elastance-healthy", "one-fibre-healthy"}) {
    double last_edv = 0.0, last_sv = 0.0;
    for (double P_pv : {6.0, 8.5, 11.0, 14.0}) {
      BenchCase c = find_case(stem);
      std::visit([&](auto& p) { p.P_pv = P_pv; }, c.parameters);
      const Indices x = indices_of(run_beat(*make_circuit(c)));
      EXPECT_GT(x.EDV, last_edv + 3.0) << stem << " P_pv " << P_pv;
      EXPECT_GT(x.SV, last_sv + 2.0) << stem << " P_pv " << P_pv;
      last_edv = x.EDV;
      last_sv = x.SV;
    }
  }
}

// The one-fibre model has a cellular length dependence of its own: at the same fibre stretch
// history, a longer sarcomere gives a longer twitch and a larger active stress.
TEST(ForeignBench, OneFibreActiveStressGrowsWithSarcomereLength) {
  OneFibreParameters p;
  const OneFibreLv lv(p);
  const double t = 0.15;  // mid-systole of the twitch
  double last = -1.0;
  for (double V : {80.0, 110.0, 140.0}) {
    const double l_s = p.l_s_ref * lv.fibre_stretch(V);
    const double l_c = l_s - 1.0 / p.E_a;  // series element at its isometric extension
    const double passive = lv.fibre_stress(lv.period() - 1e-3, V, l_c);  // twitch over
    const double active = lv.fibre_stress(t, V, l_c) - passive;
    EXPECT_GT(active, 1.1 * last) << "V " << V;
    last = active;
  }
}

// The cases land in the literature ranges they were built for (README "Cases").
TEST(ForeignBench, CasesMatchTheirTargetPhenotypes) {
  for (const std::string model : {"elastance", "one-fibre", "mooney-rivlin"}) {
    const Indices healthy = indices_of(run_beat(*make_circuit(find_case(model + "-healthy"))));
    const Indices no_atrial =
        indices_of(run_beat(*make_circuit(find_case(model + "-healthy-no-atrial"))));
    const Indices reduced = indices_of(run_beat(*make_circuit(find_case(model + "-reduced"))));
    const Indices stiff = indices_of(run_beat(*make_circuit(find_case(model + "-stiff"))));
    SCOPED_TRACE(model);
    // healthy: Maceira 2006 CMR volumes; brachial-like peak pressure; normal EDP
    expect_between(healthy.EDV, 120.0, 150.0, "healthy EDV");
    expect_between(healthy.EF, 55.0, 65.0, "healthy EF");
    expect_between(healthy.P_peak, 115.0, 135.0, "healthy P_peak");
    expect_between(healthy.EDP, 5.0, 12.0, "healthy EDP");
    EXPECT_GE(healthy.heart_rate, 60.0);
    EXPECT_LE(healthy.heart_rate, 75.0);
    // atrial contraction adds late filling
    EXPECT_GT(healthy.EDV, no_atrial.EDV + 5.0);
    // reduced contractility: dilated, EF ~30 %
    EXPECT_GT(healthy.EF, reduced.EF + 20.0);
    expect_between(reduced.EF, 25.0, 35.0, "reduced EF");
    EXPECT_GT(reduced.EDV, 180.0);
    EXPECT_GT(reduced.EDP, 12.0);
    // stiff wall + high afterload: preserved EF, high EDP, high peak pressure
    EXPECT_GT(stiff.EF, 55.0);
    EXPECT_GT(stiff.EDP, 15.0);
    EXPECT_GT(stiff.P_peak, 160.0);
    EXPECT_LT(stiff.EDV, healthy.EDV);
  }
  // The phenotype cases span 60-90 bpm; the harder acquisitions 50-110 bpm.
  double hr_min = 1e9, hr_max = 0.0, clinical_min = 1e9, clinical_max = 0.0;
  for (const auto& c : cases()) {
    const double hr = std::visit([](const auto& p) { return p.heart_rate; }, c.parameters);
    (c.clinical() ? clinical_min : hr_min) = std::min(c.clinical() ? clinical_min : hr_min, hr);
    (c.clinical() ? clinical_max : hr_max) = std::max(c.clinical() ? clinical_max : hr_max, hr);
  }
  EXPECT_EQ(hr_min, 60.0);
  EXPECT_EQ(hr_max, 90.0);
  EXPECT_EQ(clinical_min, 50.0);
  EXPECT_EQ(clinical_max, 110.0);
}

std::vector<std::string> lines_of(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

// Lines agree when their text outside numbers is equal and their numbers agree to 1e-6 relative
// (a last printed digit may differ with another compiler's rounding).
bool same_line(const std::string& a, const std::string& b) {
  if (a == b) return true;
  static const std::regex num(R"([-+]?[0-9]*\.?[0-9]+([eE][-+]?[0-9]+)?)");
  if (std::regex_replace(a, num, "#") != std::regex_replace(b, num, "#")) return false;
  std::vector<double> x, y;
  for (std::sregex_iterator i(a.begin(), a.end(), num), e; i != e; ++i) x.push_back(std::stod(i->str()));
  for (std::sregex_iterator i(b.begin(), b.end(), num), e; i != e; ++i) y.push_back(std::stod(i->str()));
  if (x.size() != y.size()) return false;
  for (size_t k = 0; k < x.size(); ++k) {
    if (std::abs(x[k] - y[k]) > 1e-6 * std::max(1.0, std::abs(x[k])) + 2e-3) return false;
  }
  return true;
}

// The bench must stay foreign: no source of experiments/foreign-data includes sigmaheart code.
TEST(ForeignBench, SharesNoCodeWithSigmaheart) {
  const std::filesystem::path dir = std::filesystem::path(SIGMAHEART_SOURCE_DIR) / "experiments/foreign-data";
  int sources = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const auto ext = e.path().extension();
    if (ext != ".h" && ext != ".cpp" && e.path().filename() != "CMakeLists.txt") continue;
    ++sources;
    for (const auto& line : lines_of(e.path())) {
      for (const char* banned : {"\"model/", "\"observers/", "\"estimation/", "\"app/", "sigmaheart::",
                                 "sigmaheart_"}) {
        EXPECT_EQ(line.find(banned), std::string::npos) << e.path().filename() << ": " << line;
      }
    }
  }
  EXPECT_GE(sources, 10);
}

// The measurement-like files are in the format app/io/observation_file.cpp reads: comment lines,
// the header 'time [s], V_lv [mL], P_lv [mmHg]', then 30 rows of three numbers from t = 0.
TEST(ForeignBench, ExportedFramesHaveTheObservationFileFormat) {
  const std::filesystem::path dir = std::filesystem::path(SIGMAHEART_SOURCE_DIR) / "configs/data/foreign";
  for (const auto& c : cases()) {
    const auto lines = lines_of(dir / (c.file_stem() + ".csv"));
    size_t k = 0;
    while (k < lines.size() && lines[k].rfind("#", 0) == 0) ++k;
    ASSERT_LT(k, lines.size());
    EXPECT_EQ(lines[k], "time [s], V_lv [mL], P_lv [mmHg]") << c.file_stem();
    EXPECT_EQ(lines.size() - k - 1, static_cast<size_t>(c.frames)) << c.file_stem();
    double last_t = -1.0;
    size_t missing = 0;
    for (size_t r = k + 1; r < lines.size(); ++r) {
      double t = 0, v = 0, p = 0;
      const int read = std::sscanf(lines[r].c_str(), "%lf, %lf, %lf", &t, &v, &p);
      missing += read == 1;
      ASSERT_TRUE(read == 3 || (read == 1 && lines[r].find(", , ") != std::string::npos)) << lines[r];
      EXPECT_GT(t, last_t);
      if (r == k + 1) {
        EXPECT_EQ(t, 0.0);
      }
      last_t = t;
    }
    EXPECT_EQ(missing, c.missing.size()) << c.file_stem();
    bool noise_line = false;
    const std::string stated = "noise V_lv: Gaussian, std " + std::to_string(static_cast<int>(c.noise_V)) + " mL";
    for (size_t r = 0; r < k; ++r) noise_line |= lines[r].find(stated) != std::string::npos;
    EXPECT_TRUE(noise_line) << c.file_stem();
  }
}

TEST(ForeignBench, BundledFilesEqualWhatTheProgramWrites) {
  const std::filesystem::path bundled = std::filesystem::path(SIGMAHEART_SOURCE_DIR) / "configs/data/foreign";
  const std::filesystem::path fresh =
      std::filesystem::temp_directory_path() / ("foreign_bench_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(fresh);
  write_bench(fresh);
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(fresh)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names.size(), 2 * cases().size() + 1);  // cases x (frames + dense) + cases.yaml
  size_t bundled_count = 0;
  for (const auto& e : std::filesystem::directory_iterator(bundled)) {
    (void)e;
    ++bundled_count;
  }
  EXPECT_EQ(bundled_count, names.size()) << "stale or missing files in " << bundled;
  for (const auto& n : names) {
    const auto a = lines_of(bundled / n);
    const auto b = lines_of(fresh / n);
    ASSERT_EQ(a.size(), b.size()) << n;
    for (size_t k = 0; k < a.size(); ++k) {
      ASSERT_TRUE(same_line(a[k], b[k])) << n << ":" << k + 1 << "\n  bundled: " << a[k]
                                         << "\n  fresh:   " << b[k];
    }
    EXPECT_LT(std::filesystem::file_size(bundled / n), 100'000u) << n;
  }
  std::filesystem::remove_all(fresh);
}

}  // namespace
}  // namespace foreign
