#include "app/io/therapy_h5.h"

#include "app/io/atomic_file.h"
#include "app/io/display.h"
#include "app/io/hdf5_writer.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app::io {

namespace {

namespace th = estimation::therapy;

// Display unit and factor of a response column (see the header).
DisplayUnit shown(const std::string& name, const std::string& si) {
  if (si == "J") return {"mJ", 1e3};
  if (si == "%") return {"%", 1.0};
  if (name == "dEF") return {"%", 100.0};  // percentage points
  if (name == "dTAT") return {"ms", 1e3};
  return quantity_display_unit(name, si);
}

Eigen::VectorXd factors(const std::vector<std::string>& names, const std::vector<std::string>& units,
                        std::vector<std::string>* shown_units) {
  Eigen::VectorXd f(static_cast<Eigen::Index>(names.size()));
  for (size_t j = 0; j < names.size(); ++j) {
    const DisplayUnit d = shown(names[j], units[j]);
    f(static_cast<Eigen::Index>(j)) = d.from_si;
    if (shown_units) shown_units->push_back(d.unit);
  }
  return f;
}

// Rows of one group of therapies (the map or the sweep).
struct Table {
  Eigen::MatrixXd raw_mean, raw_std, raw_lower, raw_upper, change_mean, change_std, change_lower, change_upper;
  Eigen::VectorXd p_responder, ahr_std_posterior, av, vv;
  Eigen::MatrixXd activation;  // therapies x 17 segment activation times at the base parameters [ms]
  std::vector<std::int64_t> segment;
  std::vector<std::string> label, mode, surface, status, failure, note, captured;
};

Table table(const std::vector<th::TherapyOutcome>& group, const Eigen::VectorXd& fr, const Eigen::VectorXd& fc) {
  const auto n = static_cast<Eigen::Index>(group.size());
  Table t;
  const double nan = std::nan("");
  t.raw_mean = t.raw_std = t.raw_lower = t.raw_upper = Eigen::MatrixXd::Constant(n, fr.size(), nan);
  t.change_mean = t.change_std = t.change_lower = t.change_upper = Eigen::MatrixXd::Constant(n, fc.size(), nan);
  t.activation.resize(n, model::activation::kSegments);
  t.p_responder.resize(n);
  t.ahr_std_posterior.resize(n);
  t.av.resize(n);
  t.vv.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const th::TherapyOutcome& o = group[static_cast<size_t>(k)];
    if (o.raw_moments.mean.size() == fr.size()) {
      t.raw_mean.row(k) = o.raw_moments.mean.cwiseProduct(fr).transpose();
      t.raw_std.row(k) = o.raw_moments.std.cwiseProduct(fr).transpose();
      t.raw_lower.row(k) = o.raw_moments.lower.cwiseProduct(fr).transpose();
      t.raw_upper.row(k) = o.raw_moments.upper.cwiseProduct(fr).transpose();
    }
    if (o.change_moments.mean.size() == fc.size()) {
      t.change_mean.row(k) = o.change_moments.mean.cwiseProduct(fc).transpose();
      t.change_std.row(k) = o.change_moments.std.cwiseProduct(fc).transpose();
      t.change_lower.row(k) = o.change_moments.lower.cwiseProduct(fc).transpose();
      t.change_upper.row(k) = o.change_moments.upper.cwiseProduct(fc).transpose();
    }
    for (int j = 0; j < model::activation::kSegments; ++j) t.activation(k, j) = 1e3 * o.segment_times[static_cast<size_t>(j)];
    t.p_responder(k) = o.p_responder;
    t.ahr_std_posterior(k) = o.ahr_std_posterior * fc(th::TherapySummary::kAhr);
    t.av(k) = 1e3 * o.therapy.timing.av_delay;
    t.vv(k) = 1e3 * o.therapy.timing.vv_delay;
    t.label.push_back(o.therapy.label);
    t.mode.push_back(o.therapy.baseline ? "baseline" : th::to_string(o.therapy.mode));
    t.segment.push_back(0);
    t.surface.push_back("");
    t.status.push_back(o.ok() ? "ok" : "failed");
    t.failure.push_back(o.failure);
    t.note.push_back(o.note);
    std::string flags;
    for (bool c : o.captured) flags += std::string(flags.empty() ? "" : ",") + (c ? "captured" : "no-capture");
    t.captured.push_back(flags);
  }
  return t;
}

void write_table(Hdf5Writer& h5, const std::string& g, const Table& t, const std::vector<std::string>& raw_names,
                 const std::vector<std::string>& change_names) {
  h5.write_strings(g + "/label", t.label);
  h5.write_strings(g + "/mode", t.mode);
  h5.write_ints(g + "/lv_segment", t.segment);
  h5.write_strings(g + "/lv_surface", t.surface);
  h5.write_vector(g + "/av_delay", t.av, "ms");
  h5.write_vector(g + "/vv_delay", t.vv, "ms");
  h5.write_strings(g + "/status", t.status);
  h5.write_strings(g + "/failure", t.failure);
  h5.write_strings(g + "/note", t.note);
  h5.write_strings(g + "/captured", t.captured);
  const std::string raw_u = "see /responses/raw_units", change_u = "see /responses/change_units";
  for (const auto& [name, m] : {std::pair{"raw_mean", &t.raw_mean}, {"raw_std", &t.raw_std},
                                {"raw_lower", &t.raw_lower}, {"raw_upper", &t.raw_upper}})
    h5.write_matrix(g + "/" + name, *m, raw_u, t.label, raw_names);
  for (const auto& [name, m] : {std::pair{"change_mean", &t.change_mean}, {"change_std", &t.change_std},
                                {"change_lower", &t.change_lower}, {"change_upper", &t.change_upper}})
    h5.write_matrix(g + "/" + name, *m, change_u, t.label, change_names);
  h5.write_vector(g + "/p_responder", t.p_responder, "1");
  h5.write_vector(g + "/ahr_std_posterior", t.ahr_std_posterior, "%");
  h5.set_attribute(g + "/ahr_std_posterior", "description",
                   "AHR's standard deviation from the posterior alone; change_std adds the model error (/summary model_error_ahr)");
  h5.write_matrix(g + "/segment_activation", t.activation, "ms", t.label);
  h5.set_attribute(g + "/segment_activation", "description",
                   "mean activation time of each AHA segment under the therapy, at the base parameters, intrinsic clock");
}

Table site_table(const TherapyResults& r, const std::vector<th::TherapyOutcome>& group, const Eigen::VectorXd& fr,
                 const Eigen::VectorXd& fc) {
  Table t = table(group, fr, fc);
  const auto sites = r.problem->options.sites();
  for (size_t k = 0; k < group.size(); ++k) {
    const int j = group[k].therapy.lv_site;
    if (j < 0) continue;
    const auto& s = sites[static_cast<size_t>(j)];
    t.segment[k] = s.point ? 0 : s.segment;
    t.surface[k] = s.point ? "point" : model::activation::to_string(s.surface);
  }
  return t;
}

std::string personalization_text(const TherapyResults& r) {
  const auto& p = r.problem->personalization;
  if (!p) return "none (the config's parameters, no uncertainty)";
  std::string text = r.problem->personalization_file.string() + " (" + p->kind + ", " + p->status;
  if (p->volume_shares) text += "; its volume shares of the data";
  for (const auto& name : p->marginalised) text += "; " + name + " marginalised (observation clock only)";
  if (r.problem->inflation > 1.0) text += "; covariance inflated x" + format_number(r.problem->inflation, 3);
  return text + ")";
}

std::string model_error_text(const TherapyResults& r) {
  const auto& e = r.problem->options.model_error;
  if (!(e.ahr_sd > 0.0)) return "none (the intervals are the posterior's alone)";
  return "AHR +- " + format_number(e.ahr_sd, 3) + " % (1 std), " + format_number(100.0 * e.shared, 3) +
         " % of its variance shared by every site; added to the posterior's spread";
}

std::string scar_text(const TherapyResults& r) {
  std::string s;
  for (int k : r.problem->options.scar) s += (s.empty() ? "" : ", ") + std::to_string(k);
  return (s.empty() ? "none" : "segments " + s) + " (" + r.problem->scar_source + ")";
}

}  // namespace

void write_therapy_h5(const std::filesystem::path& path, const TherapyResults& r, Provenance prov) {
  const th::TherapySummary& s = *r.summary;
  std::vector<std::string> raw_units, change_units;
  const Eigen::VectorXd fr = factors(s.names.raw, s.names.raw_units, &raw_units);
  const Eigen::VectorXd fc = factors(s.names.change, s.names.change_units, &change_units);
  Hdf5Writer h5(path);
  write_parameters(h5, "/parameters", *r.space, r.mean_theta);
  h5.set_attribute("/parameters", "description", "every model parameter at the posterior mean (the point run for the beats)");
  h5.write_strings("/responses/raw_names", s.names.raw);
  h5.write_strings("/responses/raw_units", raw_units);
  h5.write_strings("/responses/change_names", s.names.change);
  h5.write_strings("/responses/change_units", change_units);
  if (r.problem->personalization) {
    h5.write_strings("/points/names", r.problem->personalization->posterior.names);
    h5.write_matrix("/points/eta", s.points.eta, "1");
    h5.write_matrix("/points/theta", s.points.theta, "SI, see /points/names");
  }
  h5.write_vector("/points/wm", s.points.wm, "1");
  h5.write_vector("/points/wc", s.points.wc, "1");

  Eigen::MatrixXd base = s.baseline.raw;
  for (Eigen::Index i = 0; i < base.rows(); ++i) base.row(i) = base.row(i).cwiseProduct(fr.transpose());
  h5.write_matrix("/baseline/raw", base, "see /responses/raw_units", {}, s.names.raw);
  const Table b = table({s.baseline}, fr, fc);
  h5.write_vector("/baseline/raw_mean", b.raw_mean.row(0).transpose(), "see /responses/raw_units");
  h5.write_vector("/baseline/raw_std", b.raw_std.row(0).transpose(), "see /responses/raw_units");
  h5.write_vector("/baseline/raw_lower", b.raw_lower.row(0).transpose(), "see /responses/raw_units");
  h5.write_vector("/baseline/raw_upper", b.raw_upper.row(0).transpose(), "see /responses/raw_units");
  h5.set_attribute("/baseline", "status", s.baseline.ok() ? "ok" : "failed: " + s.baseline.failure);
  h5.write_vector("/baseline/segment_activation", b.activation.row(0).transpose(), "ms");

  write_table(h5, "/map", site_table(r, s.map, fr, fc), s.names.raw, s.names.change);
  Eigen::MatrixXd ahr(static_cast<Eigen::Index>(s.map.size()), s.points.count());
  for (size_t k = 0; k < s.map.size(); ++k) ahr.row(static_cast<Eigen::Index>(k)) = s.map[k].change.col(th::TherapySummary::kAhr).transpose();
  h5.write_matrix("/map/ahr", ahr, "%");
  Eigen::VectorXd p_best = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(s.map.size()), std::nan(""));
  p_best.head(s.p_best.size()) = s.p_best;
  h5.write_vector("/map/p_best", p_best, "1");
  if (!s.sweep.empty()) write_table(h5, "/sweep", site_table(r, s.sweep, fr, fc), s.names.raw, s.names.change);
  h5.create_group("/best");
  h5.set_attribute("/best", "index", s.best);
  if (s.best >= 0) {
    h5.set_attribute("/best", "label", s.map[static_cast<size_t>(s.best)].therapy.label);
    h5.set_attribute("/best", "p_best", s.p_best(s.best));
  }
  if (r.baseline_beat) write_trajectory(h5, "/trajectories/baseline", *r.baseline_beat);
  if (r.best_beat) write_trajectory(h5, "/trajectories/best", *r.best_beat);

  h5.create_group("/summary");
  h5.set_attribute("/summary", "status", r.status);
  h5.set_attribute("/summary", "termination", th::to_string(s.termination));
  h5.set_attribute("/summary", "message", s.message);
  h5.set_attribute("/summary", "simulations", s.simulations);
  h5.set_attribute("/summary", "failures", s.failures);
  h5.set_attribute("/summary", "method", estimation::to_string(s.points.method));
  h5.set_attribute("/summary", "points", s.points.count());
  h5.set_attribute("/summary", "route", r.problem->route);
  h5.set_attribute("/summary", "scar", scar_text(r));
  if (s.conduction_velocity > 0.0) {
    h5.set_attribute("/summary", "conduction_velocity", s.conduction_velocity);
    h5.set_attribute("/summary", "conduction_source", s.conduction_source);
  }
  h5.set_attribute("/summary", "personalization", personalization_text(r));
  h5.set_attribute("/summary", "model_error", model_error_text(r));
  h5.set_attribute("/summary", "model_error_ahr", r.problem->options.model_error.ahr_sd);
  h5.set_attribute("/summary", "model_error_shared", r.problem->options.model_error.shared);
  h5.set_attribute("/summary", "responder_threshold", r.problem->options.responder_threshold);
  prov.end_utc = utc_now();
  write_provenance(h5, prov);
  h5.commit();
}

void write_therapy_json(const std::filesystem::path& path, const std::string& name, const TherapyResults& r,
                        const Provenance& prov) {
  const th::TherapySummary& s = *r.summary;
  const Eigen::VectorXd fr = factors(s.names.raw, s.names.raw_units, nullptr);
  const Eigen::VectorXd fc = factors(s.names.change, s.names.change_units, nullptr);
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr); };
  auto rows = [&](const std::vector<th::TherapyOutcome>& group, bool with_best) {
    nlohmann::ordered_json out = nlohmann::ordered_json::array();
    const Table t = site_table(r, group, fr, fc);
    for (size_t k = 0; k < group.size(); ++k) {
      const auto K = static_cast<Eigen::Index>(k);
      nlohmann::ordered_json e = {{"label", t.label[k]}, {"mode", t.mode[k]}, {"lv_segment", t.segment[k]},
                                  {"av_delay_ms", t.av(K)}, {"vv_delay_ms", t.vv(K)}, {"status", t.status[k]}};
      for (size_t c = 0; c < s.names.change.size(); ++c) {
        const auto C = static_cast<Eigen::Index>(c);
        e[s.names.change[c]] = {{"mean", number(t.change_mean(K, C))}, {"std", number(t.change_std(K, C))},
                                {"lower", number(t.change_lower(K, C))}, {"upper", number(t.change_upper(K, C))}};
        if (static_cast<int>(c) == th::TherapySummary::kAhr)
          e[s.names.change[c]]["std_posterior"] = number(t.ahr_std_posterior(K));
      }
      e["p_responder"] = number(t.p_responder(K));
      if (with_best && K < s.p_best.size()) e["p_best"] = number(s.p_best(K));
      if (!t.failure[k].empty()) e["failure"] = t.failure[k];
      if (!t.note[k].empty()) e["note"] = t.note[k];
      out.push_back(e);
    }
    return out;
  };
  const Table b = table({s.baseline}, fr, fc);
  nlohmann::ordered_json baseline;
  for (size_t c = 0; c < s.names.raw.size(); ++c) baseline[s.names.raw[c]] = number(b.raw_mean(0, static_cast<Eigen::Index>(c)));
  baseline["segment_activation_ms"] = nlohmann::ordered_json::array();
  for (int j = 0; j < model::activation::kSegments; ++j) baseline["segment_activation_ms"].push_back(number(b.activation(0, j)));
  nlohmann::ordered_json j = {{"kind", "therapy"},
                              {"name", name},
                              {"status", r.status},
                              {"termination", th::to_string(s.termination)},
                              {"message", s.message},
                              {"method", estimation::to_string(s.points.method)},
                              {"points", s.points.count()},
                              {"personalization", personalization_text(r)},
                              {"model_error", {{"ahr_std_percent", r.problem->options.model_error.ahr_sd},
                                               {"shared", r.problem->options.model_error.shared}}},
                              {"scar", scar_text(r)},
                              {"conduction_velocity_m_per_s", s.conduction_velocity > 0.0 ? nlohmann::ordered_json(s.conduction_velocity)
                                                                                        : nlohmann::ordered_json(nullptr)},
                              {"conduction_source", s.conduction_source},
                              {"responder_threshold_percent", r.problem->options.responder_threshold},
                              {"baseline", baseline},
                              {"map", rows(s.map, true)},
                              {"best", s.best >= 0 ? nlohmann::ordered_json(s.map[static_cast<size_t>(s.best)].therapy.label)
                                                   : nlohmann::ordered_json(nullptr)},
                              {"sweep", rows(s.sweep, false)},
                              {"simulations", s.simulations},
                              {"failures", s.failures},
                              {"provenance", provenance_json(prov)}};
  write_text_file(path, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
}

std::string therapy_report(const TherapyResults& r) {
  const th::TherapySummary& s = *r.summary;
  const Eigen::VectorXd fr = factors(s.names.raw, s.names.raw_units, nullptr);
  const Eigen::VectorXd fc = factors(s.names.change, s.names.change_units, nullptr);
  std::ostringstream o;
  o << "therapy (" << r.space->size() << " parameters, " << s.points.count() << " point(s), "
    << estimation::to_string(s.points.method) << "): " << s.simulations << " runs, " << s.failures << " failed; "
    << r.status << "\n";
  o << "personalisation: " << personalization_text(r) << "\nscar: " << scar_text(r) << "\n";
  if (r.problem->options.model_error.ahr_sd > 0.0) o << "model error: " << model_error_text(r) << "\n";
  if (s.conduction_velocity > 0.0)
    o << "paced wave on the segment graph: " << s.conduction_velocity << " m/s (" << s.conduction_source << ")\n";
  const Table b = table({s.baseline}, fr, fc);
  o << "baseline: dP/dt max " << format_number(b.raw_mean(0, 0)) << " mmHg/s, SV " << format_number(b.raw_mean(0, 1))
    << " mL, EF " << format_number(b.raw_mean(0, 2)) << " %, EDV " << format_number(b.raw_mean(0, 3)) << " mL, TAT "
    << format_number(b.raw_mean(0, 6)) << " ms" << (s.baseline.ok() ? "" : "  FAILED: " + s.baseline.failure) << "\n";
  auto lines = [&](const std::vector<th::TherapyOutcome>& group, bool with_best) {
    const Table t = site_table(r, group, fr, fc);
    o << std::left << std::setw(34) << "therapy" << std::right << std::setw(8) << "AHR %" << std::setw(20)
      << "90 % interval" << std::setw(10) << "P(resp)" << (with_best ? "    P(best)" : "") << std::setw(9) << "dSV mL"
      << std::setw(9) << "dEF %" << std::setw(9) << "TAT ms" << "\n";
    for (size_t k = 0; k < group.size(); ++k) {
      const auto K = static_cast<Eigen::Index>(k);
      o << std::left << std::setw(34) << t.label[k].substr(0, 33) << std::right << std::setw(8)
        << format_number(t.change_mean(K, 0), 3) << std::setw(20)
        << ("[" + format_number(t.change_lower(K, 0), 3) + ", " + format_number(t.change_upper(K, 0), 3) + "]")
        << std::setw(10) << format_number(t.p_responder(K), 2);
      if (with_best) o << std::setw(11) << format_number(K < s.p_best.size() ? s.p_best(K) : std::nan(""), 2);
      o << std::setw(9) << format_number(t.change_mean(K, 1), 3) << std::setw(9) << format_number(t.change_mean(K, 2), 3)
        << std::setw(9) << format_number(t.raw_mean(K, 6), 3);
      if (!t.failure[k].empty()) o << "  FAILED: " << t.failure[k];
      if (!t.note[k].empty()) o << "  (" << t.note[k] << ")";
      o << (with_best && static_cast<int>(k) == s.best ? "  <- best" : "") << "\n";
    }
  };
  lines(s.map, true);
  if (!s.sweep.empty()) {
    o << "AV/VV sweep at the best site:\n";
    lines(s.sweep, false);
  }
  return o.str();
}

}  // namespace sigmaheart::app::io
