#include "estimation/therapy/therapy.h"

#include "estimation/enum_names.h"
#include "model/activation/paced_simulator.h"
#include "observers/global_indices.h"
#include "observers/pump_work.h"

#include <cmath>
#include <iomanip>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation::therapy {

namespace act = model::activation;

SIGMAHEART_ENUM_TEXT(Mode, parse_mode, {Mode::kBiventricular, "biv"}, {Mode::kLvOnly, "lv-only"})

const char* to_string(Termination t) {
  return t == Termination::kOk ? "ok" : t == Termination::kSomeFailed ? "some-therapies-failed" : "baseline-failed";
}

std::string Timing::validate() const {
  std::ostringstream s;
  if (!(pr_interval >= 0.08 && pr_interval <= 0.4)) s << "pr_interval = " << 1e3 * pr_interval << " ms must lie in [80, 400] ms";
  else if (!(av_delay >= 0.04 && av_delay <= 0.35)) s << "av_delay = " << 1e3 * av_delay << " ms must lie in [40, 350] ms";
  else if (!(vv_delay >= -0.08 && vv_delay <= 0.08)) s << "vv_delay = " << 1e3 * vv_delay << " ms must lie in [-80, 80] ms";
  return s.str();
}

std::vector<act::LeadSite> TherapyOptions::sites() const {
  if (!lv_sites.empty()) return lv_sites;
  std::vector<act::LeadSite> all;
  for (int s = 1; s <= act::kSegments; ++s) all.push_back({s, act::Surface::kEpicardium, std::nullopt});
  return all;
}

std::string TherapyOptions::validate() const {
  if (const std::string m = timing.validate(); !m.empty()) return "timing: " + m;
  for (double av : av_sweep) {
    Timing t = timing;
    t.av_delay = av;
    if (const std::string m = t.validate(); !m.empty()) return "av_sweep: " + m;
  }
  for (double vv : vv_sweep) {
    Timing t = timing;
    t.vv_delay = vv;
    if (const std::string m = t.validate(); !m.empty()) return "vv_sweep: " + m;
  }
  if (modes.empty()) return "modes: at least one pacing mode";
  if (!(responder_threshold > -100.0 && std::isfinite(responder_threshold)))
    return "responder_threshold must be a finite AHR above -100 %";
  if (const std::string m = graph.validate(); !m.empty()) return m;
  if (!(model_error.ahr_sd >= 0.0 && model_error.ahr_sd <= 100.0))
    return "model_error: the AHR error's standard deviation must lie in [0, 100] %";
  if (!(model_error.shared >= 0.0 && model_error.shared <= 1.0)) return "model_error: shared must lie in [0, 100] %";
  act::PacingPlan probe;
  probe.scar = scar;
  probe.stimuli.push_back({"RV", rv_site, 0.0});
  for (const auto& s : sites()) probe.stimuli.push_back({"LV", s, 0.0});
  if (const std::string m = probe.validate(); !m.empty()) return m;
  return ensemble.validate();
}

act::PacingPlan pacing_plan(const Therapy& therapy, const TherapyOptions& options) {
  act::PacingPlan plan;
  plan.scar = options.scar;
  if (therapy.baseline) return plan;  // the heart's own rhythm
  plan.intrinsic = options.intrinsic_conduction;
  const Timing& t = therapy.timing;
  // The first ventricular stimulus fires av_delay after the atrial event, which sits pr_interval
  // before the intrinsic onset; the LV lead leads the RV lead by vv_delay.
  const double first = t.av_delay - t.pr_interval;
  const double rv = first + std::max(t.vv_delay, 0.0), lv = first + std::max(-t.vv_delay, 0.0);
  const act::LeadSite site = options.sites().at(static_cast<size_t>(therapy.lv_site));
  if (therapy.mode == Mode::kBiventricular) plan.stimuli.push_back({"RV", options.rv_site, rv});
  plan.stimuli.push_back({"LV", site, therapy.mode == Mode::kBiventricular ? lv : first});
  return plan;
}

bool warm_starts_pay(int followers, int unknowns, bool extra_seed) {
  return followers * (kColdBeats - kWarmBeats) > unknowns + (extra_seed ? kColdBeats : 0);
}

namespace {

// One member: (therapy k, point i) -> the raw responses of that run, then two bookkeeping columns
// the study strips: the beats it integrated and 1 when a warm run failed and was run again cold.
// With `warm` (therapies x warm_start_size(), a row per therapy: its seed run's warm start) a
// member starts from its therapy's row; a NaN or zero row (a failed seed) is a cold start.
class MemberModel final : public ForwardModel {
 public:
  static constexpr int kBookkeeping = 2;
  MemberModel(const model::Simulator& model, std::shared_ptr<const std::vector<act::PacingPlan>> plans,
              std::shared_ptr<const Eigen::MatrixXd> thetas, act::GraphPacingOptions graph,
              std::shared_ptr<const Eigen::MatrixXd> warm = nullptr)
      : model_(model.clone()), plans_(std::move(plans)), thetas_(std::move(thetas)), graph_(graph),
        warm_(std::move(warm)), indices_({{"dPdt_max", "SV", "EF", "EDV", "ESV"}}, model_->channels()),
        work_(model_->channels()) {}

  int input_size() const override { return 2; }
  std::vector<std::string> input_names() const override { return {"therapy", "point"}; }
  std::vector<model::Channel> outputs() const override {
    std::vector<model::Channel> out = indices_.outputs();
    const auto w = work_.outputs();
    out.insert(out.begin() + 5, w.front());
    out.push_back({"TAT", "s", "total activation time: latest minus earliest activation outside scar"});
    out.insert(out.end(), w.begin() + 1, w.end());
    out.push_back({"beats", "1", "beats integrated by this member's runs"});
    out.push_back({"cold_retry", "1", "1 when the warm run failed and the member was run again cold"});
    return out;
  }
  int warm_start_size() const override { return model_->warm_start_size(); }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> z) override {
    return evaluate_warm(in, z, Eigen::VectorXd(), nullptr);
  }
  model::Status evaluate_warm(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> z,
                              const Eigen::VectorXd& from, Eigen::VectorXd* produce) override {
    const auto k = static_cast<Eigen::Index>(std::lround(in(0)));
    const auto i = static_cast<Eigen::Index>(std::lround(in(1)));
    act::PacedSimulator paced(*model_, plans_->at(static_cast<size_t>(k)), graph_);
    const Eigen::VectorXd theta = thetas_->row(i).transpose();
    Eigen::VectorXd start = from;
    if (start.size() == 0 && warm_) start = warm_->row(k).transpose();
    const bool warm = start.size() > 0 && start.allFinite() && start.cwiseAbs().maxCoeff() > 0.0;
    model::RunResult r = paced.run_warm(theta, warm ? start : Eigen::VectorXd(), produce);
    double beats = r.info.beats, retried = 0.0;
    if (!r.status.ok() && warm) {  // the estimator's policy: a failed warm run is run again cold
      r = paced.run_warm(theta, Eigen::VectorXd(), produce);
      beats += r.info.beats;
      retried = 1.0;
    }
    if (!r.status.ok()) return r.status;
    Eigen::VectorXd gi(indices_.size()), w(work_.size());
    if (auto s = indices_.observe(r.trajectory, gi); !s.ok()) return s;
    if (auto s = work_.observe(r.trajectory, w); !s.ok()) return s;
    z.head(5) = gi;
    z(5) = w(0);
    z(6) = paced.outcome().total_activation();
    z.segment(7, w.size() - 1) = w.tail(w.size() - 1);
    z(z.size() - 2) = beats;
    z(z.size() - 1) = retried;
    return model::Status::Ok();
  }
  std::unique_ptr<ForwardModel> clone() const override {
    return std::make_unique<MemberModel>(*model_, plans_, thetas_, graph_, warm_);
  }

 private:
  std::unique_ptr<model::Simulator> model_;
  std::shared_ptr<const std::vector<act::PacingPlan>> plans_;
  std::shared_ptr<const Eigen::MatrixXd> thetas_;
  act::GraphPacingOptions graph_;
  std::shared_ptr<const Eigen::MatrixXd> warm_;
  observers::GlobalIndices indices_;
  observers::PumpWork work_;
};

// Raw columns: dPdt_max, SV, EF, EDV, ESV, stroke_work, TAT[, septal_work, lateral_work,
// work_difference]. Change columns: AHR, dSV, dEF, dSW, dTAT[, dWD].
enum Raw : int { kDpdt, kSv, kEf, kEdv, kEsv, kSw, kTat, kSeptal, kLateral, kDifference };

ResponseNames response_names(bool regional) {
  ResponseNames n;
  n.raw = {"dPdt_max", "SV", "EF", "EDV", "ESV", "stroke_work", "TAT"};
  n.raw_units = {"Pa/s", "m^3", "1", "m^3", "m^3", "J", "s"};
  n.change = {"AHR", "dSV", "dEF", "dSW", "dTAT"};
  n.change_units = {"%", "m^3", "1", "J", "s"};
  if (regional) {
    n.raw.insert(n.raw.end(), {"septal_work", "lateral_work", "work_difference"});
    n.raw_units.insert(n.raw_units.end(), {"J", "J", "J"});
    n.change.push_back("dWD");
    n.change_units.push_back("J");
  }
  return n;
}

Eigen::MatrixXd changes(const Eigen::MatrixXd& raw, const Eigen::MatrixXd& base, bool regional) {
  Eigen::MatrixXd c(raw.rows(), regional ? 6 : 5);
  c.col(0) = 100.0 * (raw.col(kDpdt).array() / base.col(kDpdt).array() - 1.0);
  c.col(1) = raw.col(kSv) - base.col(kSv);
  c.col(2) = raw.col(kEf) - base.col(kEf);
  c.col(3) = raw.col(kSw) - base.col(kSw);
  c.col(4) = raw.col(kTat) - base.col(kTat);
  if (regional) c.col(5) = raw.col(kDifference) - base.col(kDifference);
  return c;
}

// The beats and cold retries of an ensemble's finished members (the bookkeeping columns).
void count_runs(const EnsembleResult& r, TherapySummary& summary) {
  const Eigen::Index c = r.Z.cols() - MemberModel::kBookkeeping;
  for (Eigen::Index m = 0; m < r.Z.rows(); ++m) {
    if (!std::isfinite(r.Z(m, c))) continue;
    summary.beats += std::llround(r.Z(m, c));
    const int retried = static_cast<int>(std::lround(r.Z(m, c + 1)));
    summary.cold_retries += retried;
    summary.simulations += retried;
  }
  summary.failures += r.failures();
}

// Runs `therapies` at every point; fills their raw rows and statuses. With `seed` (the full
// parameter vector at the posterior mean) and a model that takes warm starts, each therapy first
// runs at the seed, handing on its periodic state and Jacobian, and its points start from that
// (docs/estimation.md s.12); the seed is the point at the mean when there is one (the star rule's
// centre), else one more run per therapy. Every member depends only on its (therapy, point) and
// its therapy's seed, so the numbers are the same for any thread or rank count.
std::vector<TherapyOutcome> evaluate(const model::Simulator& model, const std::vector<Therapy>& therapies,
                                     const std::shared_ptr<const Eigen::MatrixXd>& thetas, const Eigen::VectorXd& base,
                                     const std::optional<Eigen::VectorXd>& seed, const TherapyOptions& o,
                                     const std::string& phase, TherapySummary& summary) {
  auto plans = std::make_shared<std::vector<act::PacingPlan>>();
  std::vector<TherapyOutcome> out(therapies.size());
  for (size_t k = 0; k < therapies.size(); ++k) {
    plans->push_back(pacing_plan(therapies[k], o));
    // The plan on this model now: a site outside the mesh or a point on the graph is bad input.
    const act::PacedSimulator probe(model, plans->back(), o.graph);
    act::PacingOutcome at_base;
    probe.paced_theta(base, &at_base);
    out[k].therapy = therapies[k];
    out[k].captured = at_base.captured;
    out[k].note = at_base.note;
    out[k].segment_times = at_base.segment_times;
  }
  const int n = static_cast<int>(thetas->rows());
  const int count = static_cast<int>(therapies.size());
  const int members = count * n;
  // The seed row: a point at the mean, else the mean appended after the points.
  int seed_row = -1;
  if (seed)
    for (int i = 0; i < n && seed_row < 0; ++i)
      if ((thetas->row(i).transpose() - *seed).cwiseAbs().maxCoeff() == 0.0) seed_row = i;
  const bool extra = seed_row < 0;
  const int followers = count * (extra ? n : n - 1);
  // The unknowns m of a warm start of 2m + m^2 entries: the beats of its Jacobian.
  const int size = model.warm_start_size();
  const int unknowns = static_cast<int>(std::lround(std::sqrt(1.0 + size) - 1.0));
  const bool warm = seed && n > 1 && size > 0 && o.warm_starts != TherapyOptions::WarmStarts::kNever &&
                    (o.warm_starts == TherapyOptions::WarmStarts::kAlways ||
                     warm_starts_pay(followers / count, unknowns, extra));
  Eigen::MatrixXd Z;
  std::vector<model::Status> status;
  if (!warm) {
    Eigen::MatrixXd inputs(members, 2);
    for (int k = 0; k < count; ++k)
      for (int i = 0; i < n; ++i) inputs.row(k * n + i) << k, i;
    if (o.on_phase) o.on_phase(phase, members);
    const MemberModel prototype(model, plans, thetas, o.graph);
    Ensemble ensemble(prototype, o.ensemble);
    EnsembleResult r = ensemble.evaluate(inputs);
    summary.simulations += members;
    count_runs(r, summary);
    Z = std::move(r.Z);
    status = std::move(r.status);
  } else {
    auto all = std::make_shared<Eigen::MatrixXd>(*thetas);
    if (extra) {
      seed_row = n;
      all->conservativeResize(n + 1, Eigen::NoChange);
      all->row(n) = seed->transpose();
    }
    if (o.on_phase) o.on_phase(phase, count + followers);
    Eigen::MatrixXd seeds(count, 2);
    for (int k = 0; k < count; ++k) seeds.row(k) << k, seed_row;
    const MemberModel seeder(model, plans, all, o.graph);
    Ensemble first(seeder, o.ensemble);
    const EnsembleResult r1 = first.evaluate(seeds, Eigen::VectorXd(), true);
    count_runs(r1, summary);
    // The followers, each from its therapy's warm start (a failed seed's NaN row: cold).
    Eigen::MatrixXd inputs(followers, 2);
    for (int k = 0, m = 0; k < count; ++k)
      for (int i = 0; i < n; ++i)
        if (i != seed_row) inputs.row(m++) << k, i;
    EnsembleOptions eo = o.ensemble;
    if (o.ensemble.progress)
      eo.progress = [p = o.ensemble.progress, count](int done, int total) { p(count + done, count + total); };
    const MemberModel follower(model, plans, all, o.graph, std::make_shared<const Eigen::MatrixXd>(r1.warm));
    Ensemble second(follower, eo);
    const EnsembleResult r2 = second.evaluate(inputs);
    count_runs(r2, summary);
    summary.simulations += count + followers;
    summary.seed_runs += extra ? count : 0;
    Z.resize(members, r1.Z.cols());
    status.resize(static_cast<size_t>(members));
    for (int k = 0, m = 0; k < count; ++k)
      for (int i = 0; i < n; ++i) {
        const int row = k * n + i;
        if (i == seed_row) {
          Z.row(row) = r1.Z.row(k);
          status[static_cast<size_t>(row)] = r1.status[static_cast<size_t>(k)];
        } else {
          Z.row(row) = r2.Z.row(m);
          status[static_cast<size_t>(row)] = r2.status[static_cast<size_t>(m++)];
        }
      }
  }
  for (size_t k = 0; k < therapies.size(); ++k) {
    out[k].raw = Z.block(static_cast<Eigen::Index>(k) * n, 0, n, Z.cols() - MemberModel::kBookkeeping);
    out[k].status.assign(status.begin() + static_cast<long>(k) * n, status.begin() + static_cast<long>(k + 1) * n);
  }
  return out;
}

// Moments of one therapy against the baseline's rows.
void summarise(TherapyOutcome& t, const TherapySummary& s, const Eigen::MatrixXd& base_raw, bool regional,
               const TherapyOptions& o) {
  t.raw_moments = response_moments(s.points, t.raw, o.propagation);
  t.change = changes(t.raw, base_raw, regional);
  t.change_moments = response_moments(s.points, t.change, o.propagation);
  for (size_t i = 0; i < t.status.size() && t.failure.empty(); ++i)
    if (!t.status[i].ok() && !t.change_moments.ok)
      t.failure = "point " + std::to_string(i) + ": " + model::to_string(t.status[i].code) + ": " + t.status[i].message;
  if (t.failure.empty() && !t.change_moments.ok) t.failure = "the baseline failed";
  if (t.failure.empty() && !t.raw_moments.ok) t.failure = "no responses";
  t.ahr_std_posterior = t.change_moments.ok ? t.change_moments.std(TherapySummary::kAhr) : std::nan("");
  if (!t.therapy.baseline && o.model_error.ahr_sd > 0.0)
    add_response_error(t.change_moments, s.points, t.change, TherapySummary::kAhr, o.model_error.ahr_sd, o.propagation);
  t.p_responder =
      probability_above(s.points, t.change, t.change_moments, o.responder_threshold, o.propagation)(TherapySummary::kAhr);
}

}  // namespace

TherapySummary run_therapy_study(const model::Simulator& model, const Eigen::VectorXd& base_theta,
                                 const std::vector<std::vector<int>>& estimated,
                                 const std::optional<Posterior>& posterior, const TherapyOptions& o) {
  if (const std::string m = o.validate(); !m.empty()) throw std::invalid_argument("therapy: " + m);
  if (base_theta.size() != model.parameters().size())
    throw std::invalid_argument("therapy: the parameter vector has the wrong size for " + model.name());
  TherapySummary s;
  // The points: the posterior's, each written into base_theta; without one the base itself.
  auto thetas = std::make_shared<Eigen::MatrixXd>();
  std::optional<Eigen::VectorXd> seed;  // the warm starts' seed: the posterior mean
  if (posterior) {
    if (static_cast<int>(estimated.size()) != posterior->size())
      throw std::invalid_argument("therapy: " + std::to_string(estimated.size()) + " model indices for " +
                                  std::to_string(posterior->size()) + " posterior parameters");
    s.points = propagation_points(*posterior, o.propagation);
    *thetas = base_theta.transpose().replicate(s.points.count(), 1);
    seed = base_theta;
    const Eigen::VectorXd mean = posterior->theta_mean();
    for (size_t j = 0; j < estimated.size(); ++j)
      for (int i : estimated[j]) {
        thetas->col(i) = s.points.theta.col(static_cast<Eigen::Index>(j));
        (*seed)(i) = mean(static_cast<Eigen::Index>(j));
      }
  } else {
    s.points.method = PropagationMethod::kPoint;
    s.points.eta.resize(1, 0);
    s.points.theta.resize(1, 0);
    s.points.wm = s.points.wc = Eigen::VectorXd::Ones(1);
    *thetas = base_theta.transpose();
  }
  TherapyOptions opts = o;
  if (!posterior) opts.propagation.method = PropagationMethod::kPoint;
  const bool graph_route = act::PacedSimulator::route(model) == "segment activation times";
  if (graph_route) {
    s.conduction_velocity = o.graph.conduction_velocity;
    s.conduction_source = "configured";
  }
  if (o.velocity_from_sequence) {
    if (!graph_route)
      throw std::invalid_argument("conduction_velocity: intrinsic: " + model.name() +
                                  " is not paced on the segment graph (its own activation model sets the paced wave)");
    // The intrinsic sequence at the posterior mean (the warm starts' seed; the base without a posterior).
    const Eigen::VectorXd mean = seed ? *seed : base_theta;
    const Therapy baseline{"baseline", true, Mode::kBiventricular, -1, o.timing};
    act::PacingOutcome intrinsic;
    act::PacedSimulator(model, pacing_plan(baseline, o), o.graph).paced_theta(mean, &intrinsic);
    const act::SequenceVelocity v = act::sequence_velocity(intrinsic.segment_times, o.scar);
    if (!v.failure.empty())
      throw std::invalid_argument("conduction_velocity: intrinsic: " + v.failure +
                                  "; give the paced wave's velocity in m/s instead");
    opts.graph.conduction_velocity = s.conduction_velocity = v.velocity;
    std::ostringstream m;
    m << "fitted to the intrinsic sequence at the posterior mean: " << v.segments << " segments, breakthrough at segment";
    for (size_t k = 0; k < v.sources.size(); ++k) m << (k == 0 ? (v.sources.size() > 1 ? "s " : " ") : " and ") << v.sources[k];
    m << ", R^2 " << std::setprecision(3) << v.r_squared;
    s.conduction_source = m.str();
  }
  const bool regional = observers::PumpWork(model.channels()).regional();
  s.names = response_names(regional);

  // Baseline and the map, in one ensemble.
  const auto sites = o.sites();
  s.sites = static_cast<int>(sites.size());
  std::vector<Therapy> therapies = {{"baseline", true, Mode::kBiventricular, -1, o.timing}};
  for (Mode mode : o.modes)
    for (int j = 0; j < s.sites; ++j)
      therapies.push_back({std::string(to_string(mode)) + " LV " + sites[static_cast<size_t>(j)].describe(), false, mode,
                           j, o.timing});
  std::vector<TherapyOutcome> all = evaluate(model, therapies, thetas, base_theta, seed, opts, "baseline and lead-site map", s);
  s.baseline = std::move(all.front());
  s.map.assign(std::make_move_iterator(all.begin() + 1), std::make_move_iterator(all.end()));
  const Eigen::MatrixXd base_raw = s.baseline.raw;
  summarise(s.baseline, s, base_raw, regional, opts);
  for (auto& t : s.map) summarise(t, s, base_raw, regional, opts);

  // The best site of the first mode and the probability of each to be the best (jointly over the
  // points, sites that failed left out).
  std::vector<int> ok_sites;
  for (int j = 0; j < s.sites; ++j)
    if (s.map[static_cast<size_t>(j)].ok()) ok_sites.push_back(j);
  s.p_best = Eigen::VectorXd::Constant(s.sites, std::nan(""));
  if (!ok_sites.empty()) {
    Eigen::MatrixXd ahr(s.points.count(), static_cast<Eigen::Index>(ok_sites.size()));
    for (size_t c = 0; c < ok_sites.size(); ++c) ahr.col(static_cast<Eigen::Index>(c)) = s.map[static_cast<size_t>(ok_sites[c])].change.col(0);
    ResponseMoments m = response_moments(s.points, ahr, opts.propagation);
    // The model error's part independent per site reorders them; the shared part does not.
    const double independent = o.model_error.ahr_sd * std::sqrt(1.0 - o.model_error.shared);
    if (m.ok && independent > 0.0)
      for (Eigen::Index c = 0; c < ahr.cols(); ++c) add_response_error(m, s.points, ahr, c, independent, opts.propagation);
    const Eigen::VectorXd p = probability_largest(s.points, ahr, m, opts.propagation);
    Eigen::Index c = 0;
    m.mean.maxCoeff(&c);
    s.best = ok_sites[static_cast<size_t>(c)];
    for (size_t k = 0; k < ok_sites.size(); ++k) s.p_best(ok_sites[k]) = p(static_cast<Eigen::Index>(k));
  }

  // AV and VV sweeps at the best site (biventricular).
  if (s.best >= 0 && (!o.av_sweep.empty() || !o.vv_sweep.empty())) {
    std::vector<Therapy> sweep;
    const std::string where = " at LV " + sites[static_cast<size_t>(s.best)].describe();
    for (double av : o.av_sweep) {
      Timing t = o.timing;
      t.av_delay = av;
      sweep.push_back({"AV " + std::to_string(std::lround(1e3 * av)) + " ms" + where, false, Mode::kBiventricular, s.best, t});
    }
    for (double vv : o.vv_sweep) {
      Timing t = o.timing;
      t.vv_delay = vv;
      sweep.push_back({"VV " + std::to_string(std::lround(1e3 * vv)) + " ms" + where, false, Mode::kBiventricular, s.best, t});
    }
    s.sweep = evaluate(model, sweep, thetas, base_theta, seed, opts, "AV/VV sweep", s);
    for (auto& t : s.sweep) summarise(t, s, base_raw, regional, opts);
  }

  int failed = 0;
  for (const auto* group : {&s.map, &s.sweep})
    for (const auto& t : *group) failed += t.ok() ? 0 : 1;
  if (!s.baseline.ok()) {
    s.termination = Termination::kBaselineFailed;
    s.message = "the baseline failed (" + s.baseline.failure + "): no therapy has a response";
  } else if (failed > 0) {
    s.termination = Termination::kSomeFailed;
    s.message = std::to_string(failed) + " therapies failed; the others are reported";
  } else {
    s.message = "every therapy ran at every point";
  }
  return s;
}

model::RunResult therapy_beat(const model::Simulator& model, const Eigen::VectorXd& theta, const Therapy& therapy,
                              const TherapyOptions& options) {
  act::PacedSimulator paced(model, pacing_plan(therapy, options), options.graph);
  return paced.run(theta);
}

}  // namespace sigmaheart::estimation::therapy
