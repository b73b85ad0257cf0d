#include "app/io/sensitivity_h5.h"

#include "app/io/display.h"
#include "app/io/results.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app::io {

namespace {

namespace sh = estimation::sensitivity;

const std::string kA = "/analysis";
const std::string kPerParameter = "see /analysis/parameters/units";
const std::string kPerOutput = "see /analysis/outputs/units";

// The outputs as shown: names, display and SI units, and the factor from SI.
struct OutputDisplay {
  std::vector<std::string> names, units, si_units;
  Eigen::VectorXd factor;  // shown = SI * factor
};

OutputDisplay output_display(const SensitivitySetup& setup) {
  const auto outs = setup.model->outputs();
  OutputDisplay d;
  d.factor.resize(static_cast<Eigen::Index>(outs.size()));
  for (size_t k = 0; k < outs.size(); ++k) {
    const DisplayUnit u = quantity_display_unit(outs[k].name, outs[k].unit);
    d.names.push_back(outs[k].name);
    d.units.push_back(u.unit);
    d.si_units.push_back(outs[k].unit);
    d.factor(static_cast<Eigen::Index>(k)) = u.from_si;
  }
  return d;
}

// Columns of a (rows x outputs) matrix in display units.
Eigen::MatrixXd shown(Eigen::MatrixXd m, const OutputDisplay& d) {
  if (m.cols() == d.factor.size()) m.array().rowwise() *= d.factor.transpose().array();
  return m;
}

std::string sampling(const estimation::PriorParameter& q) {
  std::string s = estimation::to_string(q.space);
  if (q.space == estimation::SamplingSpace::kEta) {
    s += std::string(" (") + estimation::to_string(q.transform.kind) + ")";
  }
  return s;
}

int top_count(const SensitivitySetup& setup) { return std::min(setup.prior.size(), 6); }

const std::string kParameterAxis = kA + "/parameters/names";
const std::string kOutputAxis = kA + "/outputs/names";

// Attaches the parameter and output name lists as HDF5 dimension scales of a dataset (empty: no
// scale on that dimension), so h5py's `dims` and xarray label the axes.
void axes(Hdf5Writer& h5, const std::string& dataset, const std::string& rows, const std::string& cols = "") {
  if (!rows.empty()) h5.attach_scale(dataset, 0, rows, rows == kParameterAxis ? "parameter" : "output");
  if (!cols.empty()) h5.attach_scale(dataset, 1, cols, cols == kParameterAxis ? "parameter" : "output");
}

// /analysis/parameters, /analysis/outputs, /analysis/design and /analysis/failed.
void write_common(Hdf5Writer& h5, const SensitivitySetup& setup, const sh::StudySummary& r,
                  const OutputDisplay& d) {
  const auto& prior = setup.prior;
  const std::vector<std::string> names = prior.names();
  h5.write_strings(kA + "/parameters/names", names);
  h5.write_strings(kA + "/parameters/units", prior.units());
  std::vector<std::string> spaces;
  for (const auto& q : prior.parameters) spaces.push_back(sampling(q));
  h5.write_strings(kA + "/parameters/sampling", spaces);
  h5.write_vector(kA + "/parameters/lower", prior.lower(), kPerParameter);
  h5.write_vector(kA + "/parameters/upper", prior.upper(), kPerParameter);
  h5.write_vector(kA + "/parameters/nominal", prior.nominal_theta(), kPerParameter);
  h5.write_strings(kA + "/outputs/names", d.names);
  h5.write_strings(kA + "/outputs/units", d.units);
  h5.write_strings(kA + "/outputs/si_units", d.si_units);
  h5.write_vector(kA + "/outputs/from_si", d.factor, "1");
  h5.set_attribute(kA, "method", to_string(setup.method));
  h5.set_attribute(kA, "model", setup.model_kind);
  for (const char* v : {"lower", "upper", "nominal"}) axes(h5, kA + "/parameters/" + v, kParameterAxis);
  axes(h5, kA + "/outputs/from_si", kOutputAxis);

  const std::string g = kA + "/design";
  h5.write_matrix(g + "/theta", r.thetas, kPerParameter, {}, names);
  h5.write_matrix(g + "/z", shown(r.Z, d), kPerOutput, {}, d.names);
  axes(h5, g + "/theta", "", kParameterAxis);
  axes(h5, g + "/z", "", kOutputAxis);
  std::vector<std::int64_t> codes(static_cast<size_t>(r.thetas.rows()), 0);
  for (const auto& f : r.failed_runs) codes[static_cast<size_t>(f.run)] = static_cast<std::int64_t>(f.status.code);
  h5.write_ints(g + "/status", codes);
  h5.set_attribute(g + "/status", "units", "1");
  h5.set_attribute(g + "/status", "description", "model::StatusCode per run, 0 = ok");
  if (r.layout.block.size() == static_cast<size_t>(r.thetas.rows())) {
    h5.write_strings(g + "/block", r.layout.block);
    h5.write_ints(g + "/row", std::vector<std::int64_t>(r.layout.row.begin(), r.layout.row.end()));
    h5.set_attribute(g + "/row", "units", "1");
  }
  h5.set_attribute(g, "layout", r.layout.description);
  h5.set_attribute(g, "runs", static_cast<int>(r.thetas.rows()));
  h5.set_attribute(g, "failed", static_cast<int>(r.failed_runs.size()));

  const std::string fg = kA + "/failed";
  h5.create_group(fg);
  h5.set_attribute(fg, "count", static_cast<int>(r.failed_runs.size()));
  if (r.failed_runs.empty()) return;
  std::vector<std::int64_t> runs, rows;
  std::vector<std::string> blocks, codes_text, messages;
  Eigen::MatrixXd thetas(static_cast<Eigen::Index>(r.failed_runs.size()), r.thetas.cols());
  for (size_t i = 0; i < r.failed_runs.size(); ++i) {
    const auto& f = r.failed_runs[i];
    runs.push_back(f.run);
    rows.push_back(f.design_row);
    blocks.push_back(f.block);
    codes_text.emplace_back(model::to_string(f.status.code));
    messages.push_back(f.status.message);
    if (f.theta.size() == r.thetas.cols()) thetas.row(static_cast<Eigen::Index>(i)) = f.theta.transpose();
  }
  h5.write_ints(fg + "/run", runs);
  h5.set_attribute(fg + "/run", "units", "1");
  h5.set_attribute(fg + "/run", "description", "row of /analysis/design");
  h5.write_strings(fg + "/block", blocks);
  h5.write_ints(fg + "/design_row", rows);
  h5.set_attribute(fg + "/design_row", "units", "1");
  h5.write_strings(fg + "/code", codes_text);
  h5.write_strings(fg + "/message", messages);
  h5.write_matrix(fg + "/theta", thetas, kPerParameter, {}, names);
  axes(h5, fg + "/theta", "", kParameterAxis);
}

// The method's tables, one overload per Summary: HDF5 group, JSON and report lines.
struct MethodWriter {
  Hdf5Writer* h5 = nullptr;                 // HDF5 when set
  nlohmann::ordered_json* js = nullptr;     // JSON when set
  std::ostringstream* report = nullptr;     // terminal when set
  const SensitivitySetup& setup;
  const OutputDisplay& d;

  // A parameter x output table with its names and its two dimension scales.
  void table(const std::string& path, const Eigen::MatrixXd& values, const std::string& unit) const {
    h5->write_matrix(path, values, unit, setup.prior.names(), d.names);
    axes(*h5, path, kParameterAxis, kOutputAxis);
  }

  // JSON indices/<output k>: its unit, `extra` keys, the ranking and entry(i) per parameter i.
  template <class Entry>
  void json_indices(int k, const std::vector<int>& order, const nlohmann::ordered_json& extra,
                    Entry entry) const {
    auto& jo = (*js)["indices"][d.names[static_cast<size_t>(k)]];
    jo["unit"] = d.units[static_cast<size_t>(k)];
    for (const auto& [key, value] : extra.items()) jo[key] = value;
    for (int i : order) {
      const auto& n = setup.prior.parameters[static_cast<size_t>(i)].name;
      jo["ranking"].push_back(n);
      jo["parameters"][n] = entry(i);
    }
  }

  void operator()(const sh::OatSummary& r) const {
    const std::vector<std::string>& names = r.parameters;
    const Eigen::VectorXd z_nom = r.z_nominal.cwiseProduct(d.factor);
    const Eigen::MatrixXd dl = shown(r.delta_low, d), dh = shown(r.delta_high, d);
    const Eigen::MatrixXd swing = shown(r.swing, d);
    const int m = static_cast<int>(d.names.size());
    if (h5) {
      const std::string g = kA + "/oat";
      h5->write_vector(g + "/theta_low", r.theta_low, kPerParameter);
      h5->write_vector(g + "/theta_high", r.theta_high, kPerParameter);
      h5->write_vector(g + "/z_nominal", z_nom, kPerOutput);
      axes(*h5, g + "/theta_low", kParameterAxis);
      axes(*h5, g + "/theta_high", kParameterAxis);
      axes(*h5, g + "/z_nominal", kOutputAxis);
      table(g + "/delta_low", dl, kPerOutput);
      table(g + "/delta_high", dh, kPerOutput);
      table(g + "/swing", swing, kPerOutput);
      table(g + "/normalised", r.normalised, "1");
      h5->set_attribute(g + "/normalised", "description", "elasticity d ln z / d ln theta (central difference)");
      h5->set_attribute(g, "mode", sh::to_string(setup.oat.mode));
      h5->set_attribute(g, "relative_change", setup.oat.relative_change);
      h5->set_attribute(g, "valid", r.ok() ? 1 : 0);
      h5->set_attribute(g, "estimator", "one-at-a-time: z(low) - z(nominal), z(high) - z(nominal); elasticity");
    }
    if (report) {
      *report << "One-at-a-time study (" << sh::to_string(setup.oat.mode) << "), " << names.size()
              << " parameters, " << r.thetas.rows() << " runs, " << r.failed_runs.size() << " failed\n";
    }
    if (!r.ok()) return;
    for (int k = 0; k < m; ++k) {
      const auto& u = d.units[static_cast<size_t>(k)];
      const auto order = r.ranking(k);
      if (js) {
        json_indices(k, order, {{"nominal", z_nom(k)}}, [&](int i) -> nlohmann::ordered_json {
          return {{"delta_low", dl(i, k)}, {"delta_high", dh(i, k)}, {"swing", swing(i, k)},
                  {"elasticity", r.normalised(i, k)}};
        });
      }
      if (report) {
        *report << d.names[static_cast<size_t>(k)] << " (nominal " << format_number(z_nom(k), 4) << " " << u << "):";
        for (int t = 0; t < top_count(setup); ++t) {
          const int i = order[static_cast<size_t>(t)];
          *report << "  " << names[static_cast<size_t>(i)] << " " << format_number(dl(i, k), 3) << "/"
                  << format_number(dh(i, k), 3);
        }
        *report << " " << u << "\n";
      }
    }
  }

  void operator()(const sh::MorrisSummary& r) const {
    const std::vector<std::string>& names = r.parameters;
    const Eigen::MatrixXd mu = shown(r.mu, d), mus = shown(r.mu_star, d), sg = shown(r.sigma, d);
    const int m = static_cast<int>(d.names.size());
    if (h5) {
      const std::string g = kA + "/morris";
      const std::string u = kPerOutput + " (change over the whole range of the parameter)";
      table(g + "/mu", mu, u);
      table(g + "/mu_star", mus, u);
      table(g + "/sigma", sg, u);
      table(g + "/mu_low", shown(r.mu_low, d), u);
      table(g + "/mu_high", shown(r.mu_high, d), u);
      table(g + "/mu_star_low", shown(r.mu_star_low, d), u);
      table(g + "/mu_star_high", shown(r.mu_star_high, d), u);
      table(g + "/sigma_low", shown(r.sigma_low, d), u);
      table(g + "/sigma_high", shown(r.sigma_high, d), u);
      h5->write_ints(g + "/dropped_trajectories",
                     std::vector<std::int64_t>(r.dropped_trajectories.begin(), r.dropped_trajectories.end()));
      h5->set_attribute(g + "/dropped_trajectories", "units", "1");
      h5->set_attribute(g, "trajectories", setup.morris.trajectories);
      h5->set_attribute(g, "used_trajectories", static_cast<int>(r.used_trajectories.size()));
      h5->set_attribute(g, "levels", setup.morris.levels);
      h5->set_attribute(g, "confidence", setup.morris.confidence);
      h5->set_attribute(g, "bootstrap", setup.morris.bootstrap_samples);
      h5->set_attribute(g, "valid", r.ok() ? 1 : 0);
      h5->set_attribute(g, "estimator",
                        "Morris 1991 elementary effects in unit-cube coordinates; mu* Campolongo 2007; "
                        "percentile bootstrap over trajectories");
    }
    if (report) {
      *report << "Morris study: " << names.size() << " parameters, " << setup.morris.trajectories
              << " trajectories (" << r.used_trajectories.size() << " used, "
              << r.dropped_trajectories.size() << " dropped for failed runs), " << r.thetas.rows() << " runs\n";
    }
    if (js) {
      (*js)["trajectories_used"] = r.used_trajectories.size();
      (*js)["trajectories_dropped"] = r.dropped_trajectories;
    }
    if (!r.ok()) return;
    for (int k = 0; k < m; ++k) {
      const auto& un = d.units[static_cast<size_t>(k)];
      const auto order = r.ranking(k);
      if (js) {
        json_indices(k, order, nlohmann::ordered_json::object(), [&](int i) -> nlohmann::ordered_json {
          return {{"mu", mu(i, k)}, {"mu_star", mus(i, k)}, {"sigma", sg(i, k)},
                  {"mu_star_low", r.mu_star_low(i, k) * d.factor(k)},
                  {"mu_star_high", r.mu_star_high(i, k) * d.factor(k)}};
        });
      }
      if (report) {
        *report << d.names[static_cast<size_t>(k)] << " [" << un << "], mu* (sigma):";
        for (int t = 0; t < top_count(setup); ++t) {
          const int i = order[static_cast<size_t>(t)];
          *report << "  " << names[static_cast<size_t>(i)] << " " << format_number(mus(i, k), 3) << " ("
                  << format_number(sg(i, k), 2) << ")";
        }
        *report << "\n";
      }
    }
  }

  // SALib's names (Herman & Usher 2017, JOSS 2:97, sobol.analyze): S1, S1_conf, ST, ST_conf, and
  // with second order S2, S2_conf; the percentile bootstrap interval as *_percentile_low/high.
  void write_sobol_tables(const std::string& c, const sh::SobolEstimate& e) const {
    const std::string conf = "half-width of the " + format_number(100.0 * setup.sobol.confidence, 3) +
                             " % bootstrap interval: z x bootstrap std (as SALib's sobol.analyze)";
    const std::string pct = "percentile bootstrap interval at " +
                            format_number(100.0 * setup.sobol.confidence, 3) + " %";
    table(c + "/S1", e.S1, "1");
    table(c + "/S1_conf", e.S1_conf, "1");
    h5->set_attribute(c + "/S1_conf", "description", conf);
    table(c + "/ST", e.ST, "1");
    table(c + "/ST_conf", e.ST_conf, "1");
    h5->set_attribute(c + "/ST_conf", "description", conf);
    for (const char* name : {"S1_percentile_low", "S1_percentile_high", "ST_percentile_low", "ST_percentile_high"}) {
      const std::string n(name);
      const Eigen::MatrixXd& m = n == "S1_percentile_low"    ? e.S1_low
                                 : n == "S1_percentile_high" ? e.S1_high
                                 : n == "ST_percentile_low"  ? e.ST_low
                                                             : e.ST_high;
      table(c + "/" + n, m, "1");
      h5->set_attribute(c + "/" + n, "description", pct);
    }
    if (e.output_std.size() == d.factor.size()) {
      h5->write_vector(c + "/output_std", e.output_std.cwiseProduct(d.factor), kPerOutput);
      axes(*h5, c + "/output_std", kOutputAxis);
    }
    if (e.S2.empty()) return;
    // Second order: one p x p matrix per output (row i, column k: S2_ik for i < k; NaN on and
    // below the diagonal), named by the output.
    const std::vector<std::string> names = setup.prior.names();
    for (const char* group : {"S2", "S2_conf"}) {
      const std::string g = c + "/" + group;
      const auto& mats = std::string(group) == "S2" ? e.S2 : e.S2_conf;
      h5->create_group(g);
      h5->set_attribute(g, "outputs", d.names);
      h5->set_attribute(g, "description",
                        std::string(group) == "S2"
                            ? "second-order index S2(i, k), i < k, per output (Saltelli 2002; SALib S2); "
                              "NaN on and below the diagonal"
                            : conf);
      for (size_t k = 0; k < mats.size(); ++k) {
        const std::string path = g + "/" + d.names[k];
        h5->write_matrix(path, mats[k], "1", names, names);
        axes(*h5, path, kParameterAxis, kParameterAxis);
      }
    }
  }

  void operator()(const sh::SobolSummary& r) const {
    const std::vector<std::string>& names = r.parameters;
    const int m = static_cast<int>(d.names.size());
    if (h5) {
      const std::string g = kA + "/sobol";
      h5->create_group(g);
      h5->set_attribute(g, "N", r.N);
      h5->set_attribute(g, "valid", r.ok() ? 1 : 0);
      h5->set_attribute(g, "imputed", r.imputed ? 1 : 0);
      h5->set_attribute(g, "failure_policy", sh::to_string(setup.sobol.failure_policy));
      h5->set_attribute(g, "message", r.message);
      h5->set_attribute(g, "confidence", setup.sobol.confidence);
      h5->set_attribute(g, "bootstrap", setup.sobol.bootstrap_samples);
      h5->set_attribute(g, "scrambling", sh::to_string(setup.sobol.scrambling));
      h5->set_attribute(g, "second_order", r.second_order ? 1 : 0);
      h5->set_attribute(g, "estimators",
                        std::string("S1 Saltelli et al. 2010 (Table 2 b); ST Jansen 1999 (Saltelli 2010 Table 2 f); ") +
                            (r.second_order ? "S2 Saltelli 2002 (as SALib); " : "") +
                            "bootstrap over design rows: *_conf = z x std (SALib), *_percentile_low/high");
      std::vector<std::int64_t> levels;
      for (const auto& e : r.convergence) {
        levels.push_back(e.n);
        if (e.n == r.N) write_sobol_tables(g, e);
        // Zero-padded to the width of N, so the groups sort by size ("n0128" < "n1024").
        write_sobol_tables(g + "/convergence/n" + padded_number(e.n, r.N), e);
      }
      if (!levels.empty()) {
        h5->write_ints(g + "/convergence/n", levels);
        h5->set_attribute(g + "/convergence/n", "units", "1");
      }
    }
    if (report) {
      *report << "Sobol' study: " << names.size() << " parameters, N = " << r.N << ", " << r.runs << " runs, "
              << r.failed_runs.size() << " failed (policy " << sh::to_string(setup.sobol.failure_policy) << ")\n";
      if (!r.message.empty()) *report << r.message << "\n";
    }
    if (js) {
      (*js)["N"] = r.N;
      (*js)["second_order"] = r.second_order;
      (*js)["confidence"] = setup.sobol.confidence;
      (*js)["conf"] = "S1_conf, ST_conf, S2_conf: half-width of the bootstrap interval at the confidence "
                      "level, z x bootstrap std (as SALib's sobol.analyze)";
      (*js)["imputed"] = r.imputed;
    }
    if (!r.ok()) return;
    const auto& e = r.estimate;
    const bool has_std = e.output_std.size() == m;
    for (int k = 0; k < m; ++k) {
      const auto order = r.ranking(k);
      if (js) {
        nlohmann::ordered_json extra = nlohmann::ordered_json::object();
        if (has_std) extra["std"] = e.output_std(k) * d.factor(k);
        if (!e.S2.empty()) {
          // {"x1": {"x3": S2_13, ...}, ...}: pairs i < k only.
          const auto kk = static_cast<size_t>(k);
          nlohmann::ordered_json s2 = nlohmann::ordered_json::object(), s2c = s2;
          for (size_t i = 0; i < names.size(); ++i) {
            for (size_t l = i + 1; l < names.size(); ++l) {
              const auto ii = static_cast<Eigen::Index>(i), ll = static_cast<Eigen::Index>(l);
              s2[names[i]][names[l]] = e.S2[kk](ii, ll);
              s2c[names[i]][names[l]] = e.S2_conf[kk](ii, ll);
            }
          }
          extra["S2"] = s2;
          extra["S2_conf"] = s2c;
        }
        json_indices(k, order, extra, [&](int i) -> nlohmann::ordered_json {
          return {{"S1", e.S1(i, k)}, {"S1_conf", e.S1_conf(i, k)}, {"ST", e.ST(i, k)},
                  {"ST_conf", e.ST_conf(i, k)},
                  {"S1_percentile_interval", {e.S1_low(i, k), e.S1_high(i, k)}},
                  {"ST_percentile_interval", {e.ST_low(i, k), e.ST_high(i, k)}}};
        });
      }
      if (report) {
        *report << d.names[static_cast<size_t>(k)];
        if (has_std) {
          *report << " (std " << format_number(e.output_std(k) * d.factor(k), 3) << " "
                  << d.units[static_cast<size_t>(k)] << ")";
        }
        *report << ", ST [S1]:";
        for (int t = 0; t < top_count(setup); ++t) {
          const int i = order[static_cast<size_t>(t)];
          *report << "  " << names[static_cast<size_t>(i)] << " " << std::fixed << std::setprecision(2)
                  << e.ST(i, k) << " [" << e.S1(i, k) << "]" << std::defaultfloat;
        }
        *report << "\n";
        if (!e.S2.empty()) {
          const Eigen::MatrixXd& s2 = e.S2[static_cast<size_t>(k)];
          int bi = -1, bl = -1;
          for (int i = 0; i < s2.rows(); ++i) {
            for (int l = i + 1; l < s2.cols(); ++l) {
              if (std::isfinite(s2(i, l)) && (bi < 0 || s2(i, l) > s2(bi, bl))) bi = i, bl = l;
            }
          }
          if (bi >= 0) {
            *report << "  largest interaction S2(" << names[static_cast<size_t>(bi)] << ", "
                    << names[static_cast<size_t>(bl)] << ") = " << std::fixed << std::setprecision(3)
                    << s2(bi, bl) << " +- " << e.S2_conf[static_cast<size_t>(k)](bi, bl) << std::defaultfloat
                    << "\n";
          }
        }
      }
    }
    if (report && setup.exact) *report << exact_table(r, *setup.exact);
  }

  static std::string exact_table(const sh::SobolSummary& r, const sh::ExactIndices& e) {
    std::ostringstream s;
    s << "exact indices of the test function (estimate - exact):\n" << std::fixed << std::setprecision(4);
    for (size_t i = 0; i < r.parameters.size(); ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      s << "  " << std::setw(6) << std::left << r.parameters[i] << std::right << " S1 " << e.S1(ii)
        << " (" << std::showpos << r.estimate.S1(ii, 0) - e.S1(ii) << std::noshowpos << ")  ST "
        << e.ST(ii) << " (" << std::showpos << r.estimate.ST(ii, 0) - e.ST(ii) << std::noshowpos
        << ")\n";
    }
    if (!r.estimate.S2.empty() && e.S2.rows() == static_cast<Eigen::Index>(r.parameters.size())) {
      for (Eigen::Index i = 0; i < e.S2.rows(); ++i) {
        for (Eigen::Index k = i + 1; k < e.S2.cols(); ++k) {
          s << "  S2(" << r.parameters[static_cast<size_t>(i)] << ", " << r.parameters[static_cast<size_t>(k)]
            << ") " << e.S2(i, k) << " (" << std::showpos << r.estimate.S2[0](i, k) - e.S2(i, k)
            << std::noshowpos << ")\n";
        }
      }
    }
    return s.str();
  }
};

std::vector<double> to_std_vector(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

}  // namespace

void write_sensitivity_h5(Hdf5Writer& h5, const SensitivitySetup& setup,
                          const SensitivitySummary& summary) {
  const OutputDisplay d = output_display(setup);
  write_common(h5, setup, study_of(summary), d);
  std::visit(MethodWriter{&h5, nullptr, nullptr, setup, d}, summary);
  if (setup.exact) {
    h5.write_vector(kA + "/exact/S1", setup.exact->S1, "1");
    h5.write_vector(kA + "/exact/ST", setup.exact->ST, "1");
    axes(h5, kA + "/exact/S1", kParameterAxis);
    axes(h5, kA + "/exact/ST", kParameterAxis);
    if (setup.exact->S2.size() > 0) {
      const auto names = setup.prior.names();
      h5.write_matrix(kA + "/exact/S2", setup.exact->S2, "1", names, names);
      axes(h5, kA + "/exact/S2", kParameterAxis, kParameterAxis);
    }
  }
}

nlohmann::ordered_json sensitivity_json(const std::string& name, const SensitivitySetup& setup,
                                        const SensitivitySummary& summary,
                                        const std::string& results_file, const Provenance& provenance) {
  const OutputDisplay d = output_display(setup);
  const sh::StudySummary& r = study_of(summary);
  nlohmann::ordered_json js;
  js["kind"] = "sensitivity";
  js["name"] = name;
  js["method"] = to_string(setup.method);
  js["model"] = setup.model_kind;
  js["runs"] = setup.runs();
  for (const auto& q : setup.prior.parameters) {
    js["parameters"].push_back({{"name", q.name}, {"unit", q.unit}, {"nominal", q.theta_nominal},
                                {"lower", q.lower}, {"upper", q.upper}, {"sampling", sampling(q)}});
  }
  for (size_t k = 0; k < d.names.size(); ++k) {
    js["outputs"].push_back({{"name", d.names[k]}, {"unit", d.units[k]}});
  }
  std::visit(MethodWriter{nullptr, &js, nullptr, setup, d}, summary);
  if (setup.exact) {
    js["exact"] = {{"S1", to_std_vector(setup.exact->S1)}, {"ST", to_std_vector(setup.exact->ST)}};
    if (setup.method == SensitivityMethod::kSobol && setup.sobol.second_order && setup.exact->S2.size() > 0) {
      const auto names = setup.prior.names();
      for (size_t i = 0; i < names.size(); ++i) {
        for (size_t l = i + 1; l < names.size(); ++l) {
          js["exact"]["S2"][names[i]][names[l]] =
              setup.exact->S2(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(l));
        }
      }
    }
  }
  js["valid"] = r.ok();
  js["status"] = sh::to_string(r.status);
  js["message"] = r.ok() ? std::string() : r.message;
  js["failed_runs"] = nlohmann::json::array();
  for (const auto& f : r.failed_runs) {
    js["failed_runs"].push_back({{"run", f.run}, {"block", f.block}, {"design_row", f.design_row},
                                 {"code", model::to_string(f.status.code)}, {"message", f.status.message}});
  }
  js["results_file"] = results_file;
  js["provenance"] = provenance_json(provenance);
  return js;
}

std::string sensitivity_report(const SensitivitySetup& setup, const SensitivitySummary& summary) {
  const OutputDisplay d = output_display(setup);
  std::ostringstream report;
  std::visit(MethodWriter{nullptr, nullptr, &report, setup, d}, summary);
  const auto& failed = study_of(summary).failed_runs;
  const size_t listed = std::min<size_t>(failed.size(), 10);
  for (size_t i = 0; i < listed; ++i) {
    const auto& f = failed[i];
    report << "  failed run " << f.run << " (" << f.block << ", row " << f.design_row << "): "
           << model::to_string(f.status.code) << ": " << f.status.message << "\n";
  }
  if (listed < failed.size()) report << "  ... " << failed.size() - listed << " more (in the results file)\n";
  return report.str();
}

}  // namespace sigmaheart::app::io
