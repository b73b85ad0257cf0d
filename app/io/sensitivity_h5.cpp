#include "app/io/sensitivity_h5.h"

#include "app/io/display.h"

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

  const std::string g = kA + "/design";
  h5.write_matrix(g + "/theta", r.thetas, kPerParameter, {}, names);
  h5.write_matrix(g + "/z", shown(r.Z, d), kPerOutput, {}, d.names);
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
}

// The method's tables, one overload per Summary: HDF5 group, JSON and report lines.
struct MethodWriter {
  Hdf5Writer* h5 = nullptr;                 // HDF5 when set
  nlohmann::ordered_json* js = nullptr;     // JSON when set
  std::ostringstream* report = nullptr;     // terminal when set
  const SensitivitySetup& setup;
  const OutputDisplay& d;

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
      h5->write_matrix(g + "/delta_low", dl, kPerOutput, names, d.names);
      h5->write_matrix(g + "/delta_high", dh, kPerOutput, names, d.names);
      h5->write_matrix(g + "/swing", swing, kPerOutput, names, d.names);
      h5->write_matrix(g + "/normalised", r.normalised, "1", names, d.names);
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
      h5->write_matrix(g + "/mu", mu, u, names, d.names);
      h5->write_matrix(g + "/mu_star", mus, u, names, d.names);
      h5->write_matrix(g + "/sigma", sg, u, names, d.names);
      h5->write_matrix(g + "/mu_low", shown(r.mu_low, d), u, names, d.names);
      h5->write_matrix(g + "/mu_high", shown(r.mu_high, d), u, names, d.names);
      h5->write_matrix(g + "/mu_star_low", shown(r.mu_star_low, d), u, names, d.names);
      h5->write_matrix(g + "/mu_star_high", shown(r.mu_star_high, d), u, names, d.names);
      h5->write_matrix(g + "/sigma_low", shown(r.sigma_low, d), u, names, d.names);
      h5->write_matrix(g + "/sigma_high", shown(r.sigma_high, d), u, names, d.names);
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

  void write_sobol_tables(const std::string& c, const sh::SobolEstimate& e) const {
    const std::vector<std::string> names = setup.prior.names();
    h5->write_matrix(c + "/S1", e.S1, "1", names, d.names);
    h5->write_matrix(c + "/ST", e.ST, "1", names, d.names);
    h5->write_matrix(c + "/S1_low", e.S1_low, "1", names, d.names);
    h5->write_matrix(c + "/S1_high", e.S1_high, "1", names, d.names);
    h5->write_matrix(c + "/ST_low", e.ST_low, "1", names, d.names);
    h5->write_matrix(c + "/ST_high", e.ST_high, "1", names, d.names);
    if (e.output_std.size() == d.factor.size()) {
      h5->write_vector(c + "/output_std", e.output_std.cwiseProduct(d.factor), kPerOutput);
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
      h5->set_attribute(g, "estimators",
                        "S1 Saltelli et al. 2010 (Table 2 b); ST Jansen 1999 (Saltelli 2010 Table 2 f); "
                        "percentile bootstrap over design rows");
      std::vector<std::int64_t> levels;
      for (const auto& e : r.convergence) {
        levels.push_back(e.n);
        if (e.n == r.N) write_sobol_tables(g, e);
        write_sobol_tables(g + "/convergence/n" + std::to_string(e.n), e);
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
        json_indices(k, order, extra, [&](int i) -> nlohmann::ordered_json {
          return {{"S1", e.S1(i, k)}, {"S1_low", e.S1_low(i, k)}, {"S1_high", e.S1_high(i, k)},
                  {"ST", e.ST(i, k)}, {"ST_low", e.ST_low(i, k)}, {"ST_high", e.ST_high(i, k)}};
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
  }
}

nlohmann::ordered_json sensitivity_json(const std::string& name, const SensitivitySetup& setup,
                                        const SensitivitySummary& summary,
                                        const std::string& results_file) {
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
