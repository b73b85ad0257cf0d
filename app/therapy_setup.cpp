#include "app/therapy_setup.h"

#include "model/activation/paced_simulator.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sigmaheart::app {

namespace {

namespace act = model::activation;
namespace th = estimation::therapy;

act::LeadSite parse_site(const ConfigNode& n) {
  act::LeadSite s;
  if (n.is_scalar()) {
    s.segment = n.as<int>();
  } else {
    if (!n.is_map()) n.fail("expected a segment (1..17) or a map {segment, surface} or {point: [x, y, z]}");
    n.check_keys({"segment", "surface", "point"});
    if (n.has("point")) {
      const ConfigNode p = n["point"];
      if (!p.is_sequence() || p.size() != 3) p.fail("expected [x, y, z] (m, or with a unit such as \"10 mm\")");
      Eigen::Vector3d x;
      for (size_t i = 0; i < 3; ++i) x(static_cast<Eigen::Index>(i)) = p[i].as_quantity("m");
      s.point = x;
      if (n.has("segment")) n["segment"].fail("give a segment or a point, not both");
    } else {
      s.segment = n.require<int>("segment");
    }
    if (n.has("surface"))
      s.surface = n["surface"].as_choice({"endocardium", "epicardium"}) == "endocardium" ? act::Surface::kEndocardium
                                                                                        : act::Surface::kEpicardium;
  }
  if (!s.point && (s.segment < 1 || s.segment > act::kSegments))
    (n.is_map() ? n["segment"] : n).fail("expected an AHA segment 1..17, got " + std::to_string(s.segment));
  return s;
}

std::vector<double> durations(const ConfigNode& list) {
  if (!list.is_sequence()) list.fail("expected a list of durations, e.g. [80 ms, 120 ms]");
  std::vector<double> out;
  for (size_t i = 0; i < list.size(); ++i) out.push_back(list[i].as_quantity("s"));
  return out;
}

// A fraction written as "50 %" or 0.5.
double fraction(const ConfigNode& n) {
  if (n.as<std::string>().find('%') != std::string::npos) return n.as_quantity("%") / 100.0;
  return n.as<double>();
}

// Segments whose contractility (the parameters tagged contractility per segment) lies below
// `threshold` times their median, or whose scar fraction (scar_XX) is above one half.
std::vector<int> scar_from_contractility(const model::ParameterSpace& space, const Eigen::VectorXd& theta,
                                         double threshold) {
  std::vector<int> out;
  const std::vector<int> c = space.regional("contractility");
  if (!c.empty()) {
    std::vector<double> v;
    for (int i : c) v.push_back(theta(i));
    std::vector<double> sorted = v;
    std::sort(sorted.begin(), sorted.end());
    const size_t n = sorted.size();
    const double median = n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    for (size_t k = 0; k < c.size(); ++k)
      if (v[k] < threshold * median) out.push_back(space[c[k]].segment);
  }
  for (int i : space.regional("scar_fraction"))
    if (theta(i) > 0.5 && std::find(out.begin(), out.end(), space[i].segment) == out.end()) out.push_back(space[i].segment);
  std::sort(out.begin(), out.end());
  return out;
}

// The factor `inflate:` asks for. nis: the Birge ratio of the personalisation (its mean NIS over
// the NIS its stated noise predicts): when the innovations are c times larger in variance than the
// filter assumed, a linear-Gaussian posterior with the noise scaled by sqrt(c) has its covariance
// scaled by c (Birge 1932, Phys Rev 40:207; the reduced chi-square scaling of least squares). The
// model error it stands for is not Gaussian noise, so this widens the intervals without removing
// a bias.
double inflation_factor(const ConfigNode& n, const std::optional<io::PosteriorFile>& file) {
  if (n.is_scalar() && n.as<std::string>() == "none") return 1.0;
  if (n.is_scalar() && n.as<std::string>() == "nis") {
    if (!file) n.fail("inflate: nis needs therapy.personalization");
    if (!(std::isfinite(file->nis_mean) && file->nis_expected > 0.0))
      n.fail("inflate: nis needs a personalize result with its mean NIS (/summary nis_mean) and observations");
    return std::max(1.0, file->nis_mean / file->nis_expected);
  }
  const double f = n.as<double>();
  if (!(f >= 1.0 && std::isfinite(f))) n.fail("expected none, nis or a factor >= 1");
  return f;
}

void parse_uncertainty(const ConfigNode& u, estimation::PropagationOptions& o) {
  u.check_keys({"method", "sigma_points", "kappa", "alpha", "beta", "samples", "seed", "interval", "inflate",
                "model_error"});
  if (u.has("method"))
    o.method = *estimation::parse_propagation_method(u["method"].as_choice({"unscented", "monte-carlo", "point"}));
  if (u.has("sigma_points"))
    o.sigma.rule = *estimation::parse_sigma_rule(u["sigma_points"].as_choice({"star", "simplex", "scaled", "canonical"}));
  o.sigma.kappa = u.optional<double>("kappa", o.sigma.kappa);
  o.sigma.alpha = u.optional<double>("alpha", o.sigma.alpha);
  o.sigma.beta = u.optional<double>("beta", o.sigma.beta);
  o.samples = u.optional<int>("samples", o.samples);
  if (u.has("seed")) {
    const int seed = u["seed"].as<int>();
    if (seed < 0) u["seed"].fail("expected a non-negative integer");
    o.seed = static_cast<std::uint64_t>(seed);
  }
  if (u.has("interval")) o.interval = fraction(u["interval"]);
}

}  // namespace

TherapyProblem parse_therapy(const Config& config) {
  const ConfigNode root = config.file.root();
  const ConfigNode t = root.require_child("therapy");
  if (!t.is_map()) t.fail("expected a map: the therapy: section (personalization, leads, timing, ...)");
  t.check_keys({"personalization", "uncertainty", "responder_threshold", "scar", "scar_threshold",
                "intrinsic_conduction", "conduction_velocity", "timing", "rv_lead", "lv_leads", "modes", "sweep",
                "threads", "pv_loops"});
  TherapyProblem p;
  th::TherapyOptions& o = p.options;
  const auto simulator = config.simulator.make();
  p.route = act::PacedSimulator::route(*simulator);
  if (p.route.empty())
    root["simulator"]["model"].fail("model " + config.simulator.model +
                                    " has no activation a therapy can set: therapy needs the pacing capability (lv-3d) "
                                    "or an activation time per AHA segment (lumped-regional)");

  // The parameters: the personalisation result's, or the config's.
  if (t.has("personalization")) {
    const ConfigNode f = t["personalization"];
    p.personalization_file = input_file(f, f.as<std::string>(), std::filesystem::path(config.file.file()).parent_path(),
                                        "personalisation result");
    if (root["simulator"].has("parameters"))
      root["simulator"]["parameters"].fail("with therapy.personalization every parameter comes from the result file; "
                                           "remove simulator.parameters");
    const std::unique_ptr<model::SteppableSimulator> inner = model::into_steppable(config.simulator.make());
    p.personalization =
        io::read_posterior(p.personalization_file, config.simulator.parameters, config.simulator.model, f, inner.get());
    p.space = p.personalization->space;
    p.base_theta = p.personalization->theta;
    if (p.personalization->volume_shares) {
      try {
        (void)make_therapy_model(config, p);
      } catch (const std::invalid_argument& e) {
        f.fail("personalisation result '" + p.personalization_file.string() + "': " + e.what());
      }
    }
  } else {
    p.space = config.simulator.parameters;
    p.base_theta = config.simulator.parameters.nominal();
  }

  if (t.has("uncertainty")) {
    parse_uncertainty(t["uncertainty"], o.propagation);
    if (t["uncertainty"].has("inflate")) {
      p.inflation = inflation_factor(t["uncertainty"]["inflate"], p.personalization);
      if (p.personalization) p.personalization->posterior.eta_covariance *= p.inflation;
    }
  }
  if (t.has("uncertainty") && t["uncertainty"].has("model_error")) {
    // model_error: {ahr: 9 %, shared: 50 %} (or none): the model's AHR error against a reference.
    const ConfigNode n = t["uncertainty"]["model_error"];
    if (!(n.is_scalar() && n.as<std::string>() == "none")) {
      if (!n.is_map()) n.fail("expected none or {ahr: <standard deviation in %>, shared: <fraction of it common to every site>}");
      n.check_keys({"ahr", "shared"});
      o.model_error.ahr_sd = n.require_quantity("ahr", "%");
      if (!(o.model_error.ahr_sd >= 0.0 && o.model_error.ahr_sd <= 100.0))
        n["ahr"].fail("expected the standard deviation of the model's AHR error, 0-100 % (AHR points)");
      if (n.has("shared")) o.model_error.shared = fraction(n["shared"]);
      if (!(o.model_error.shared >= 0.0 && o.model_error.shared <= 1.0))
        n["shared"].fail("expected the fraction of the error's variance common to every site, 0-100 %");
    }
  }
  if (const int np = p.personalization ? p.personalization->posterior.size() : 1;
      !o.propagation.validate(np).empty())
    t["uncertainty"].fail(o.propagation.validate(np));
  if (t.has("responder_threshold")) o.responder_threshold = t["responder_threshold"].as_quantity("%");
  if (t.has("intrinsic_conduction")) o.intrinsic_conduction = t["intrinsic_conduction"].as<bool>();
  // conduction_velocity: a speed, or `intrinsic` (the intrinsic sequence's, estimation/therapy/therapy.h).
  if (t.has("conduction_velocity") && t["conduction_velocity"].is_scalar() &&
      t["conduction_velocity"].as<std::string>() == "intrinsic") {
    o.velocity_from_sequence = true;
  } else {
    o.graph.conduction_velocity = t.optional_quantity("conduction_velocity", "m/s", o.graph.conduction_velocity);
    if (!o.graph.validate().empty()) t["conduction_velocity"].fail(o.graph.validate());
  }

  if (t.has("timing")) {
    const ConfigNode n = t["timing"];
    n.check_keys({"pr_interval", "av_delay", "vv_delay"});
    o.timing.pr_interval = n.optional_quantity("pr_interval", "s", o.timing.pr_interval);
    o.timing.av_delay = n.optional_quantity("av_delay", "s", o.timing.av_delay);
    o.timing.vv_delay = n.optional_quantity("vv_delay", "s", o.timing.vv_delay);
    if (const std::string m = o.timing.validate(); !m.empty()) n[m.substr(0, m.find(' '))].fail(m);
  }
  const ConfigNode sweep = t["sweep"];
  if (!sweep.defined()) {
    o.av_sweep = {0.06, 0.09, 0.12, 0.15, 0.18};
    o.vv_sweep = {-0.04, -0.02, 0.0, 0.02, 0.04};
  } else if (!(sweep.is_scalar() && sweep.as_choice({"none"}) == "none")) {
    sweep.check_keys({"av_delay", "vv_delay"});
    if (sweep.has("av_delay")) o.av_sweep = durations(sweep["av_delay"]);
    if (sweep.has("vv_delay")) o.vv_sweep = durations(sweep["vv_delay"]);
    for (const char* key : {"av_delay", "vv_delay"}) {
      const auto& list = std::string(key) == "av_delay" ? o.av_sweep : o.vv_sweep;
      for (size_t i = 0; i < list.size(); ++i) {
        th::Timing probe = o.timing;
        (std::string(key) == "av_delay" ? probe.av_delay : probe.vv_delay) = list[i];
        if (const std::string m = probe.validate(); !m.empty()) sweep[key][i].fail(m);
      }
    }
  }
  if (t.has("modes")) {
    const ConfigNode m = t["modes"];
    if (!m.is_sequence() || m.size() == 0) m.fail("expected a list of pacing modes: [biv], [lv-only] or both");
    o.modes.clear();
    for (size_t i = 0; i < m.size(); ++i) o.modes.push_back(*th::parse_mode(m[i].as_choice({"biv", "lv-only"})));
  }

  // Scar: given, none, or from the contractility at the estimate.
  const ConfigNode scar = t["scar"];
  const double threshold = t.has("scar_threshold") ? fraction(t["scar_threshold"]) : 0.5;
  if (!(threshold > 0.0 && threshold < 1.0)) t["scar_threshold"].fail("expected a fraction of the median in (0, 1)");
  if (scar.is_sequence()) {
    for (size_t i = 0; i < scar.size(); ++i) {
      const int s = scar[i].as<int>();
      if (s < 1 || s > act::kSegments) scar[i].fail("expected an AHA segment 1..17");
      o.scar.push_back(s);
    }
    p.scar_source = "config";
  } else if (scar.defined() && scar.as_choice({"auto", "none"}) == "none") {
    p.scar_source = "none";
  } else {
    o.scar = scar_from_contractility(p.space, p.base_theta, threshold);
    p.scar_source = "auto: contractility below " + std::to_string(std::lround(100 * threshold)) + " % of the median";
  }

  // Leads, each checked on the model (a point outside the mesh, in no segment, or on the graph).
  auto check_site = [&](const ConfigNode& at, const act::LeadSite& site) {
    act::PacingPlan plan;
    plan.scar = o.scar;
    plan.stimuli.push_back({"lead", site, 0.0});
    try {
      const act::PacedSimulator probe(*simulator, plan, o.graph);
    } catch (const std::invalid_argument& e) {
      at.fail(e.what());
    }
  };
  if (t.has("rv_lead")) o.rv_site = parse_site(t["rv_lead"]);
  check_site(t.has("rv_lead") ? t["rv_lead"] : t, o.rv_site);
  const ConfigNode lv = t["lv_leads"];
  if (lv.is_sequence()) {
    if (lv.size() == 0) lv.fail("expected at least one LV lead site (or `all`)");
    for (size_t i = 0; i < lv.size(); ++i) {
      o.lv_sites.push_back(parse_site(lv[i]));
      check_site(lv[i], o.lv_sites.back());
    }
  } else if (lv.defined()) {
    lv.as_choice({"all"});
  }
  if (!lv.is_sequence())
    for (const auto& s : o.sites()) check_site(lv.defined() ? lv : t, s);

  p.pv_loops = t.optional<bool>("pv_loops", true);
  p.threads = t.optional<int>("threads", 0);
  if (p.threads < 0) t["threads"].fail("expected an integer >= 0 (0: all cores)");
  if (const std::string m = o.validate(); !m.empty()) t.fail(m);
  return p;
}

std::unique_ptr<model::Simulator> make_therapy_model(const Config& config, const TherapyProblem& problem) {
  std::unique_ptr<model::Simulator> simulator = config.simulator.make();
  if (!problem.personalization || !problem.personalization->volume_shares) return simulator;
  std::unique_ptr<model::SteppableSimulator> inner = model::into_steppable(std::move(simulator));
  if (!inner) throw std::invalid_argument("model " + config.simulator.model + " cannot be stepped: no volume shares");
  return io::wrap_as_fitted(*problem.personalization, std::move(inner));
}

}  // namespace sigmaheart::app
