#include "app/io/fit_report_io.h"

#include "app/io/display.h"

#include <cstdint>
#include <limits>
#include <vector>

namespace sigmaheart::app::io {

namespace {

using estimation::CyclePhase;
using estimation::FitReport;
using estimation::kCyclePhases;

std::vector<std::string> phase_names() {
  std::vector<std::string> out;
  for (int k = 0; k < kCyclePhases; ++k) out.emplace_back(estimation::to_string(static_cast<CyclePhase>(k)));
  return out;
}

// The fit report in display units: one place converts, both writers read it.
struct Shown {
  struct Channel {
    std::string unit;
    double from_si = 1.0;
  };
  std::vector<Channel> channels;  // parallel to report.channels
  std::vector<DisplayUnit> indices;
};

Shown shown(const FitReport& r) {
  Shown s;
  for (const auto& c : r.channels) {
    const DisplayUnit d = quantity_display_unit(c.channel, c.unit);
    s.channels.push_back({d.unit, d.from_si});
  }
  for (const auto& i : r.indices) s.indices.push_back(quantity_display_unit(i.name, i.unit));
  return s;
}

double channel_factor(const FitReport& r, const Shown& s, const std::string& channel, std::string& unit) {
  for (size_t k = 0; k < r.channels.size(); ++k) {
    if (r.channels[k].channel == channel) {
      unit = s.channels[k].unit;
      return s.channels[k].from_si;
    }
  }
  unit = "";
  return 1.0;
}

}  // namespace

void add_fit_report_json(nlohmann::ordered_json& parent, const FitReport& r,
                         const estimation::FitReportOptions& options) {
  const Shown s = shown(r);
  nlohmann::ordered_json j;
  j["summary"] = r.summary;
  if (!r.prior_conflict.empty()) j["prior_conflict"] = r.prior_conflict;
  j["channels"] = nlohmann::ordered_json::array();
  for (size_t k = 0; k < r.channels.size(); ++k) {
    const auto& c = r.channels[k];
    j["channels"].push_back({{"channel", c.channel},
                             {"count", c.count},
                             {"rms_noise_std", c.rms_normalised},
                             {"max_abs_noise_std", c.max_abs_normalised},
                             {"rms_residual", c.rms_residual * s.channels[k].from_si},
                             {"unit", s.channels[k].unit}});
  }
  j["indices"] = nlohmann::ordered_json::array();
  for (size_t k = 0; k < r.indices.size(); ++k) {
    const auto& i = r.indices[k];
    const double f = s.indices[k].from_si;
    j["indices"].push_back({{"name", i.name},
                            {"observed", i.observed * f},
                            {"fitted", i.fitted * f},
                            {"error", i.error * f},
                            {"unit", s.indices[k].unit}});
  }
  j["discrepancy_threshold_noise_std"] = options.discrepancy_rms;
  j["discrepancy"] = nlohmann::ordered_json::array();
  for (const auto& d : r.discrepancies) {
    nlohmann::ordered_json phases = nlohmann::ordered_json::array();
    for (const auto& ph : d.phases) {
      phases.push_back({{"phase", estimation::to_string(ph.phase)},
                        {"frames", ph.frames},
                        {"rms_noise_std", ph.rms_normalised},
                        {"share_percent", 100 * ph.share}});
    }
    j["discrepancy"].push_back({{"channel", d.channel},
                                {"rms_noise_std", d.rms_normalised},
                                {"dominant_phase", estimation::to_string(d.dominant)},
                                {"phases", phases}});
  }
  if (r.identifiability) {
    const auto& id = *r.identifiability;
    nlohmann::ordered_json pairs = nlohmann::ordered_json::array();
    for (const auto& p : id.correlated) pairs.push_back({{"a", p.a}, {"b", p.b}, {"rho", p.rho}});
    nlohmann::ordered_json ratio = nlohmann::ordered_json::object();
    for (size_t k = 0; k < id.names.size(); ++k) ratio[id.names[k]] = id.std_ratio(static_cast<Eigen::Index>(k));
    j["identifiability"] = {{"posterior_over_prior_std", ratio},
                            {"uninformed", id.uninformed},
                            {"uninformed_ratio", options.uninformed_ratio},
                            {"correlated", pairs},
                            {"correlation_threshold", options.correlation_threshold}};
  }
  j["notes"] = r.notes;
  parent["fit_report"] = j;
}

void write_fit_report_h5(Hdf5Writer& h5, const std::string& group, const FitReport& r,
                         const estimation::FitReportOptions& options) {
  const Shown s = shown(r);
  const std::string g = group;
  h5.create_group(g);
  h5.set_attribute(g, "summary", r.summary);
  h5.set_attribute(g, "prior_conflict", r.prior_conflict);
  h5.set_attribute(g, "discrepancy_rms", options.discrepancy_rms);
  h5.write_strings(g + "/notes", r.notes);

  // Channels.
  {
    std::vector<std::string> names, units;
    std::vector<std::int64_t> count;
    const auto n = static_cast<Eigen::Index>(r.channels.size());
    Eigen::VectorXd rms(n), rms_res(n), max_abs(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto& c = r.channels[static_cast<size_t>(k)];
      names.push_back(c.channel);
      units.push_back(s.channels[static_cast<size_t>(k)].unit);
      count.push_back(c.count);
      rms(k) = c.rms_normalised;
      rms_res(k) = c.rms_residual * s.channels[static_cast<size_t>(k)].from_si;
      max_abs(k) = c.max_abs_normalised;
    }
    h5.write_strings(g + "/channels/names", names);
    h5.write_strings(g + "/channels/units", units);
    h5.write_ints(g + "/channels/count", count);
    h5.write_vector(g + "/channels/rms_normalised", rms, "noise std");
    h5.write_vector(g + "/channels/rms_residual", rms_res, "see " + g + "/channels/units");
    h5.write_vector(g + "/channels/max_abs_normalised", max_abs, "noise std");
  }

  // Clinical indices.
  if (!r.indices.empty()) {
    std::vector<std::string> names, units;
    const auto n = static_cast<Eigen::Index>(r.indices.size());
    Eigen::VectorXd obs(n), fit(n), err(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto& i = r.indices[static_cast<size_t>(k)];
      const double f = s.indices[static_cast<size_t>(k)].from_si;
      names.push_back(i.name);
      units.push_back(s.indices[static_cast<size_t>(k)].unit);
      obs(k) = i.observed * f;
      fit(k) = i.fitted * f;
      err(k) = i.error * f;
    }
    const std::string per = "see " + g + "/indices/units";
    h5.write_strings(g + "/indices/names", names);
    h5.write_strings(g + "/indices/units", units);
    h5.write_vector(g + "/indices/observed", obs, per);
    h5.write_vector(g + "/indices/fitted", fit, per);
    h5.write_vector(g + "/indices/error", err, per);
  }

  // Phases of the frames.
  if (!r.frame_phases.empty()) {
    std::vector<std::int64_t> code;
    std::vector<std::string> name;
    for (CyclePhase ph : r.frame_phases) {
      code.push_back(static_cast<std::int64_t>(ph));
      name.emplace_back(estimation::to_string(ph));
    }
    h5.write_vector(g + "/phases/time", r.frame_times, "s");
    h5.write_ints(g + "/phases/phase", code);
    h5.write_strings(g + "/phases/phase_name", name);
    h5.write_strings(g + "/phases/names", phase_names());
  }

  // Curves at frames.
  for (const auto& c : r.curves) {
    std::string unit;
    const double f = channel_factor(r, s, c.channel, unit);
    const std::string cg = g + "/curves/" + c.channel;
    h5.write_vector(cg + "/time", c.times, "s");
    h5.write_vector(cg + "/observed", c.observed * f, unit);
    h5.write_vector(cg + "/fitted", c.fitted * f, unit);
    h5.write_vector(cg + "/noise_std", c.noise_std * f, unit);
    h5.write_vector(cg + "/normalised_residual", (c.observed - c.fitted).cwiseQuotient(c.noise_std), "noise std");
  }

  // Discrepancy per phase.
  for (const auto& d : r.discrepancies) {
    const std::string dg = g + "/discrepancy/" + d.channel;
    std::vector<std::int64_t> frames;
    Eigen::VectorXd rms(kCyclePhases), share(kCyclePhases);
    for (int k = 0; k < kCyclePhases; ++k) {
      const auto& ph = d.phases[static_cast<size_t>(k)];
      frames.push_back(ph.frames);
      rms(k) = ph.rms_normalised;
      share(k) = ph.share;
    }
    h5.write_strings(dg + "/phase_names", phase_names());
    h5.write_ints(dg + "/frames", frames);
    h5.write_vector(dg + "/rms_normalised", rms, "noise std");
    h5.write_vector(dg + "/share", share, "1");
    h5.set_attribute(dg, "rms_normalised", d.rms_normalised);
    h5.set_attribute(dg, "dominant", estimation::to_string(d.dominant));
  }

  // Identifiability.
  if (r.identifiability) {
    const auto& id = *r.identifiability;
    const std::string ig = g + "/identifiability";
    h5.write_strings(ig + "/names", id.names);
    h5.write_matrix(ig + "/correlation", id.correlation, "1", id.names, id.names);
    h5.write_vector(ig + "/std_ratio", id.std_ratio, "1");
    h5.write_strings(ig + "/uninformed", id.uninformed);
    std::vector<std::string> a, b;
    Eigen::VectorXd rho(static_cast<Eigen::Index>(id.correlated.size()));
    for (size_t k = 0; k < id.correlated.size(); ++k) {
      a.push_back(id.correlated[k].a);
      b.push_back(id.correlated[k].b);
      rho(static_cast<Eigen::Index>(k)) = id.correlated[k].rho;
    }
    h5.write_strings(ig + "/correlated_a", a);
    h5.write_strings(ig + "/correlated_b", b);
    h5.write_vector(ig + "/correlated_rho", rho, "1");
    h5.set_attribute(ig, "uninformed_ratio", options.uninformed_ratio);
    h5.set_attribute(ig, "correlation_threshold", options.correlation_threshold);
  }
}

void write_least_squares_h5(Hdf5Writer& h5, const std::string& group,
                            const estimation::LeastSquaresSummary& s,
                            const std::vector<std::string>& units) {
  const std::string g = group;
  const std::string per = "per parameter, see " + g + "/units";
  h5.create_group(g);
  h5.set_attribute(g, "termination", estimation::to_string(s.termination));
  h5.set_attribute(g, "message", s.message);
  h5.set_attribute(g, "report", s.brief_report());
  h5.set_attribute(g, "simulations", s.simulations);
  h5.set_attribute(g, "failures", s.failures);
  h5.set_attribute(g, "best_start", s.best_start);
  h5.set_attribute(g, "polished", s.polished ? 1 : 0);
  h5.set_attribute(g, "cost", s.cost);
  h5.set_attribute(g, "prior_cost", s.prior_cost);
  h5.write_strings(g + "/names", s.names);
  h5.write_strings(g + "/units", units);
  h5.write_vector(g + "/theta", s.theta, per);
  h5.write_vector(g + "/theta_std", s.theta_std, per);
  h5.write_vector(g + "/theta_prior", s.theta_prior, per);
  h5.write_vector(g + "/eta", s.eta, "1");
  h5.write_vector(g + "/eta_std", s.eta_std, "1");
  h5.write_vector(g + "/eta_prior_mean", s.eta_prior_mean, "1");
  h5.write_vector(g + "/eta_prior_std", s.eta_prior_std, "1");
  h5.write_matrix(g + "/eta_covariance", s.eta_covariance, "1", s.names, s.names);
  h5.write_matrix(g + "/jacobian", s.jacobian, "1", s.observation_names, s.names);
  const auto nan = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(s.observation_names.size()),
                                             std::numeric_limits<double>::quiet_NaN());
  h5.write_vector(g + "/fit/estimate", s.fit_estimate ? s.fit_estimate->z : Eigen::VectorXd(nan), "SI");
  h5.write_vector(g + "/fit/prior", s.fit_prior ? s.fit_prior->z : Eigen::VectorXd(nan), "SI");
  const auto n = static_cast<Eigen::Index>(s.iterations.size());
  std::vector<std::int64_t> start, iteration, ok;
  Eigen::VectorXd cost(n), gradient(n), step(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto& it = s.iterations[static_cast<size_t>(k)];
    start.push_back(it.start);
    iteration.push_back(it.iteration);
    ok.push_back(it.step_is_successful ? 1 : 0);
    cost(k) = it.cost;
    gradient(k) = it.gradient_max_norm;
    step(k) = it.step_norm;
  }
  h5.write_ints(g + "/iterations/start", start);
  h5.write_ints(g + "/iterations/iteration", iteration);
  h5.write_vector(g + "/iterations/cost", cost, "1");
  h5.write_vector(g + "/iterations/gradient_max_norm", gradient, "1");
  h5.write_vector(g + "/iterations/step_norm", step, "1");
  h5.write_ints(g + "/iterations/successful", ok);
  std::vector<std::int64_t> its;
  std::vector<std::string> terms;
  Eigen::VectorXd final_cost(static_cast<Eigen::Index>(s.starts.size()));
  for (size_t k = 0; k < s.starts.size(); ++k) {
    its.push_back(s.starts[k].iterations);
    terms.push_back(s.starts[k].ceres_termination);
    final_cost(static_cast<Eigen::Index>(k)) = s.starts[k].final_cost;
  }
  h5.write_vector(g + "/starts/final_cost", final_cost, "1");
  h5.write_ints(g + "/starts/iterations", its);
  h5.write_strings(g + "/starts/termination", terms);
  h5.write_strings(g + "/failures", s.failure_messages);
}

void add_least_squares_json(nlohmann::ordered_json& parent,
                            const estimation::LeastSquaresSummary& s,
                            const std::vector<std::string>& units) {
  nlohmann::ordered_json j;
  j["termination"] = estimation::to_string(s.termination);
  j["message"] = s.message;
  nlohmann::ordered_json params = nlohmann::ordered_json::object();
  for (size_t k = 0; k < s.names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    params[s.names[k]] = {{"value", s.theta(i)},
                          {"std", s.theta_std(i)},
                          {"prior", s.theta_prior(i)},
                          {"unit", k < units.size() ? units[k] : std::string()}};
  }
  j["parameters"] = params;
  j["simulations"] = s.simulations;
  j["failures"] = s.failures;
  j["cost"] = s.cost;
  j["prior_cost"] = s.prior_cost;
  j["rms_noise_std_before"] = s.metrics_prior.rms_normalised_residual;
  j["rms_noise_std_after"] = s.metrics_estimate.rms_normalised_residual;
  parent["map"] = j;
}

}  // namespace sigmaheart::app::io
