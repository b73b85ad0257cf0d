#include "foreign_cohort.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace foreign {
namespace {

const char* const kGroups[] = {"healthy", "reduced", "stiff"};

// One standard normal deviate per call (the cosine branch of Box-Muller on two 53-bit uniforms),
// so the draws are the same with every standard library.
double standard_normal(std::mt19937_64& rng) {
  const double u = (static_cast<double>(rng() >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
  const double v = static_cast<double>(rng() >> 11) * 0x1.0p-53;          // [0, 1)
  return std::sqrt(-2.0 * std::log(u)) * std::cos(6.283185307179586 * v);
}

// A log-normal factor with mean 1 and coefficient of variation cv: exp(s z - s^2 / 2),
// s^2 = ln(1 + cv^2).
double lognormal_factor(std::mt19937_64& rng, double cv) {
  const double s = std::sqrt(std::log1p(cv * cv));
  return std::exp(s * standard_normal(rng) - 0.5 * s * s);
}

const BenchCase& nominal(const std::vector<BenchCase>& bench, const std::string& model,
                         const std::string& name) {
  for (const auto& c : bench) {
    if (c.model == model && c.name == name) return c;
  }
  throw std::logic_error("foreign cohort: no bench case " + model + "-" + name);
}

// The drawn parameters of one subject, in the order of drawn_parameters(model).
std::vector<double*> drawn_fields(BenchCase& c) {
  if (auto* e = std::get_if<ElastanceParameters>(&c.parameters)) {
    return {&e->Ees, &e->A_ed, &e->P_pv, &e->R_sys, &e->C_sys};
  }
  auto& f = std::get<OneFibreParameters>(c.parameters);
  return {&f.T0, &f.c_p, &f.P_pv, &f.R_sys, &f.C_sys};
}

// The arterial load (Zc, R_sys, C_sys, P_ven) of `from`, both cases of the same simulator.
void copy_arterial_load(BenchCase& c, const BenchCase& from) {
  if (auto* e = std::get_if<ElastanceParameters>(&c.parameters)) {
    const auto& h = std::get<ElastanceParameters>(from.parameters);
    std::tie(e->Zc, e->R_sys, e->C_sys, e->P_ven) = std::tie(h.Zc, h.R_sys, h.C_sys, h.P_ven);
  } else {
    auto& f = std::get<OneFibreParameters>(c.parameters);
    const auto& h = std::get<OneFibreParameters>(from.parameters);
    std::tie(f.Zc, f.R_sys, f.C_sys, f.P_ven) = std::tie(h.Zc, h.R_sys, h.C_sys, h.P_ven);
  }
}

void set_heart_rate(BenchCase& c, double heart_rate) {
  if (auto* e = std::get_if<ElastanceParameters>(&c.parameters)) {
    e->heart_rate = heart_rate;
  } else {
    std::get<OneFibreParameters>(c.parameters).heart_rate = heart_rate;
  }
}

std::string number(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("foreign cohort: cannot write " + path.string());
}

}  // namespace

std::vector<std::string> drawn_parameters(const std::string& model) {
  if (model == "elastance") return {"Ees", "A_ed", "P_pv", "R_sys", "C_sys"};
  return {"T0", "c_p", "P_pv", "R_sys", "C_sys"};
}

std::vector<CohortSubject> cohort_subjects(const CohortOptions& options) {
  if (!(options.cv >= 0.0 && options.cv < 1.0) || options.per_model_and_group < 1 ||
      !(options.heart_rate > 0.0)) {
    throw std::invalid_argument("foreign cohort: needs cv in [0, 1), >= 1 subject, heart rate > 0");
  }
  const std::vector<BenchCase> bench = bench_cases();
  std::mt19937_64 rng(options.seed);
  std::vector<CohortSubject> subjects;
  std::uint64_t noise_seed = 1000 * options.seed;
  for (const char* group : kGroups) {
    for (const auto& model : {std::pair{"elastance", "el"}, std::pair{"one-fibre", "of"}}) {
      for (int k = 1; k <= options.per_model_and_group; ++k) {
        CohortSubject s;
        s.id = std::string(group) + "-" + model.second + std::to_string(k);
        s.group = group;
        s.bench_case = nominal(bench, model.first, group);
        if (s.group == "reduced") copy_arterial_load(s.bench_case, nominal(bench, model.first, "healthy"));
        s.bench_case.name = s.id;
        s.bench_case.description = std::string(group) + " group subject, drawn around " + model.first +
                                   "-" + group + " (cv " + number("%g", 100.0 * options.cv) + " %)";
        s.bench_case.seed = ++noise_seed;
        set_heart_rate(s.bench_case, options.heart_rate);
        for (double* field : drawn_fields(s.bench_case)) *field *= lognormal_factor(rng, options.cv);
        subjects.push_back(std::move(s));
      }
    }
  }
  return subjects;
}

std::vector<CohortResult> write_cohort(const std::filesystem::path& out, const CohortOptions& options) {
  std::filesystem::create_directories(out);
  std::vector<CohortResult> results;
  for (auto& s : cohort_subjects(options)) {
    CohortResult r{std::move(s), {}, {}};
    r.beat = run_beat(*make_circuit(r.subject.bench_case));
    r.indices = indices_of(r.beat);
    results.push_back(std::move(r));
  }

  std::ostringstream cases, subjects;
  const std::string regenerate = "# Regenerate: build/experiments/foreign-data/foreign_lv --cohort " +
                                 std::string("configs/data/foreign-cohort\n");
  cases << "# Foreign cohort (experiments/foreign-data/foreign_cohort.h): the case list of\n"
        << "# configs/specificity-foreign.yaml. Curves from simulators that share no code with the BCS models.\n"
        << regenerate << "cases:\n";
  subjects << "# Foreign cohort: the parameters drawn for each subject (log-normal, mean = the bench case,\n"
           << "# cv " << number("%g", 100.0 * options.cv) << " %, seed " << options.seed
           << ") and the indices of its noise-free beat.\n"
           << regenerate << "heart_rate: " << number("%g", options.heart_rate) << "  # [bpm], every subject\n"
           << "subjects:\n";
  for (const auto& r : results) {
    const BenchCase& c = r.subject.bench_case;
    const Indices& x = r.indices;
    std::ostringstream csv;
    csv << "# foreign cohort (experiments/foreign-data/foreign_cohort.h): NOT made by a sigmaheart model\n"
        << "# subject " << r.subject.id << ", group " << r.subject.group << ", " << c.model << " simulator\n"
        << "# heart rate " << number("%.1f", x.heart_rate) << " bpm, period " << number("%.6f", r.beat.period)
        << " s; t = 0 at end-diastole (mitral closure, maximum volume)\n"
        << "# frames: " << r.beat.frames.size() << " per beat, t_k = k T / " << r.beat.frames.size() << "\n"
        << "# noise V_lv: Gaussian, std " << number("%g", c.noise_V) << " mL\n"
        << "# noise P_lv: Gaussian, std " << number("%g", c.noise_P) << " mmHg\n"
        << "# seed " << c.seed << " (mt19937_64, Box-Muller)\n"
        << "time [s], V_lv [mL], P_lv [mmHg]\n";
    for (const auto& f : noisy_frames(r.beat, c)) {
      csv << number("%.6f", f[0]) << ", " << number("%.3f", f[1]) << ", " << number("%.3f", f[2]) << "\n";
    }
    write_text(out / (r.subject.id + ".csv"), csv.str());

    cases << "  - {name: " << r.subject.id << ", file: " << r.subject.id << ".csv, group: " << r.subject.group
          << ", description: \"" << c.model << " simulator\"}\n";
    subjects << "  - name: " << r.subject.id << "\n"
             << "    group: " << r.subject.group << "\n"
             << "    model: " << c.model << "\n"
             << "    noise_seed: " << c.seed << "\n"
             << "    drawn:  # [units of the bench case, cases.yaml of configs/data/foreign]\n";
    const auto drawn = drawn_parameters(c.model);
    for (const auto& p : parameter_list(c)) {
      for (const auto& d : drawn) {
        if (p.name == d) subjects << "      " << p.name << ": " << number("%.6g", p.value) << "  # [" << p.unit << "]\n";
      }
    }
    subjects << "    indices: {EDV: " << number("%.1f", x.EDV) << ", ESV: " << number("%.1f", x.ESV)
             << ", EF: " << number("%.1f", x.EF) << ", P_peak: " << number("%.1f", x.P_peak)
             << ", EDP: " << number("%.1f", x.EDP) << "}  # [mL], [mL], [%], [mmHg], [mmHg]\n";
  }
  write_text(out / "cases.yaml", cases.str());
  write_text(out / "subjects.yaml", subjects.str());
  return results;
}

}  // namespace foreign
