#include "estimation/fit_report.h"

#include "estimation/enum_names.h"
#include "observers/beat.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fixed(double value, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, value);
  return buf;
}

// The frames of one channel: entry index per frame, ordered by frame.
struct ChannelEntries {
  std::string channel;
  std::string unit;
  std::vector<int> entries;  // into the ObservationSet
  std::vector<int> frames;   // -1 for a scalar entry
  bool curve() const { return !frames.empty() && frames.front() >= 0; }
};

std::vector<ChannelEntries> group_by_channel(const observers::ObservationSet& obs) {
  std::vector<ChannelEntries> out;
  std::map<std::string, size_t> where;
  for (int i = 0; i < obs.size(); ++i) {
    const ObservationKey key = parse_observation_name(obs.names[static_cast<size_t>(i)]);
    auto it = where.find(key.channel);
    if (it == where.end()) {
      it = where.emplace(key.channel, out.size()).first;
      out.push_back({key.channel, obs.units[static_cast<size_t>(i)], {}, {}});
    }
    out[it->second].entries.push_back(i);
    out[it->second].frames.push_back(key.frame);
  }
  for (auto& c : out) {  // order a curve's entries by frame
    std::vector<size_t> order(c.entries.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return c.frames[a] < c.frames[b]; });
    ChannelEntries sorted{c.channel, c.unit, {}, {}};
    for (size_t k : order) {
      sorted.entries.push_back(c.entries[k]);
      sorted.frames.push_back(c.frames[k]);
    }
    c = std::move(sorted);
  }
  return out;
}

Eigen::VectorXd gather(const Eigen::Ref<const Eigen::VectorXd>& v, const std::vector<int>& idx) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(idx.size()));
  for (size_t k = 0; k < idx.size(); ++k) out(static_cast<Eigen::Index>(k)) = v(idx[k]);
  return out;
}

const ChannelEntries* find_channel(const std::vector<ChannelEntries>& all, const std::string& name) {
  for (const auto& c : all) {
    if (c.channel == name && c.curve()) return &c;
  }
  return nullptr;
}

// Linear interpolation of (t, x) at s (t increasing, s inside [t0, t_last]).
double lerp_at(const Eigen::VectorXd& t, const Eigen::VectorXd& x, double s) {
  const auto* begin = t.data();
  const auto* end = t.data() + t.size();
  const auto* hi = std::upper_bound(begin, end, s);
  if (hi == begin) return x(0);
  if (hi == end) return x(t.size() - 1);
  const Eigen::Index k = hi - begin;
  const double w = (s - t(k - 1)) / (t(k) - t(k - 1));
  return (1 - w) * x(k - 1) + w * x(k);
}

// Pearson correlation of x[0, n - lag) with x[lag, n).
double lag_correlation(const Eigen::VectorXd& x, Eigen::Index lag) {
  const Eigen::Index n = x.size() - lag;
  const Eigen::VectorXd a = x.head(n).array() - x.head(n).mean();
  const Eigen::VectorXd b = x.segment(lag, n).array() - x.segment(lag, n).mean();
  const double d = std::sqrt(a.squaredNorm() * b.squaredNorm());
  return d > 0 ? a.dot(b) / d : 0.0;
}

model::Status bad(const std::string& message) {
  return model::Status::Error(model::StatusCode::kInvalidArgument, message);
}

}  // namespace

ObservationKey parse_observation_name(const std::string& name) {
  const auto at = name.rfind("@f");
  if (at == std::string::npos || at + 2 >= name.size()) return {name, -1};
  const std::string digits = name.substr(at + 2);
  if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return {name, -1};
  }
  return {name.substr(0, at), std::stoi(digits)};
}

ClinicalIndices clinical_indices(const Eigen::Ref<const Eigen::VectorXd>& volume,
                                 const Eigen::Ref<const Eigen::VectorXd>& pressure) {
  ClinicalIndices c{kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};
  if (volume.size() > 0 && volume.allFinite()) {
    Eigen::Index ed = 0;
    c.edv = volume.maxCoeff(&ed);
    c.esv = volume.minCoeff();
    c.sv = c.edv - c.esv;
    c.ef = c.sv / c.edv;
    if (pressure.size() == volume.size() && pressure.allFinite()) {
      // End-diastole is the largest volume of the filling frames. With noisy frames the overall
      // maximum can fall in isovolumic contraction, where the volume is the same to within the
      // noise but the pressure is already rising (an "EDP" of 65 mmHg seen on the foreign bench),
      // so the frames at or above mid-pressure (contraction, ejection, relaxation) are left out,
      // and so are the frames on the isovolumic rise below it: those whose pressure rose from the
      // previous frame (cyclically) by more than a quarter of the steepest frame-to-frame rise
      // (an "EDP" of 50 mmHg on the one-fibre healthy case, frame 2, 42 mmHg above frame 1).
      const double mid = 0.5 * (pressure.minCoeff() + pressure.maxCoeff());
      const Eigen::Index n = pressure.size();
      auto rise = [&](Eigen::Index k) { return pressure(k) - pressure((k + n - 1) % n); };
      double steepest = 0.0;
      for (Eigen::Index k = 0; k < n; ++k) steepest = std::max(steepest, rise(k));
      double best = -std::numeric_limits<double>::infinity();
      for (Eigen::Index k = 0; k < volume.size(); ++k) {
        if (pressure(k) < mid && rise(k) <= 0.25 * steepest && volume(k) > best) {
          best = volume(k);
          ed = k;
        }
      }
      c.edp = pressure(ed);
    }
  }
  if (pressure.size() > 0 && pressure.allFinite()) c.p_max = pressure.maxCoeff();
  return c;
}

constexpr std::array<EnumName<CyclePhase>, kCyclePhases> kCyclePhaseNames{{
    {CyclePhase::kFilling, "filling"},
    {CyclePhase::kIsovolumicContraction, "isovolumic contraction"},
    {CyclePhase::kEjection, "ejection"},
    {CyclePhase::kIsovolumicRelaxation, "isovolumic relaxation"},
}};
const char* to_string(CyclePhase phase) { return enum_to_string(kCyclePhaseNames, phase); }

model::Status classify_phases(const Eigen::Ref<const Eigen::VectorXd>& times,
                              const Eigen::Ref<const Eigen::VectorXd>& volume,
                              const Eigen::Ref<const Eigen::VectorXd>& pressure,
                              const PhaseOptions& options, std::vector<CyclePhase>& phases) {
  phases.clear();
  if (!(options.isovolumic_fraction > 0 && options.isovolumic_fraction < 1)) {
    return bad("phases: isovolumic_fraction must lie in (0, 1)");
  }
  if (volume.size() != times.size() || (pressure.size() != 0 && pressure.size() != times.size())) {
    return bad("phases: the volume and pressure curves need one value per frame");
  }
  const bool with_pressure = pressure.size() > 0;
  Eigen::MatrixXd columns(times.size(), with_pressure ? 2 : 1);
  columns.col(0) = volume;
  if (with_pressure) columns.col(1) = pressure;
  observers::BeatOptions bo = observers::measured_frames();
  bo.period = options.period;
  observers::BeatGrid grid;
  if (model::Status s = observers::make_beat_grid(times, columns, bo, grid); !s.ok()) {
    return bad("phases: " + s.message);
  }
  const Eigen::VectorXd dv = observers::derivative(grid, volume);
  const Eigen::VectorXd dp = with_pressure ? observers::derivative(grid, pressure) : Eigen::VectorXd();
  if (!(volume.maxCoeff() - volume.minCoeff() > 1e-12 * volume.cwiseAbs().maxCoeff())) {
    return bad("phases: the volume curve is constant");
  }
  const double threshold = options.isovolumic_fraction * dv.cwiseAbs().maxCoeff();
  const Eigen::Index n = dv.size();
  std::vector<int> moving(static_cast<size_t>(n), 0);  // -1 ejection, +1 filling, 0 isovolumic
  for (Eigen::Index k = 0; k < n; ++k) {
    if (dv(k) < -threshold) moving[static_cast<size_t>(k)] = -1;
    if (dv(k) > threshold) moving[static_cast<size_t>(k)] = 1;
  }
  phases.resize(static_cast<size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) {
    const int mv = moving[static_cast<size_t>(k)];
    CyclePhase ph = mv < 0 ? CyclePhase::kEjection : CyclePhase::kFilling;
    if (mv == 0) {
      bool contraction = false;
      if (with_pressure) {
        contraction = dp(k) > 0;
      } else {  // the last moving frame before k, walking back around the beat
        for (Eigen::Index back = 1; back <= n; ++back) {
          const int prev = moving[static_cast<size_t>(((k - back) % n + n) % n)];
          if (prev != 0) {
            contraction = prev > 0;
            break;
          }
        }
      }
      ph = contraction ? CyclePhase::kIsovolumicContraction : CyclePhase::kIsovolumicRelaxation;
    }
    phases[static_cast<size_t>(k)] = ph;
  }
  return model::Status::Ok();
}

Identifiability identifiability(const std::vector<std::string>& names,
                                const Eigen::Ref<const Eigen::MatrixXd>& posterior_covariance,
                                const Eigen::Ref<const Eigen::VectorXd>& prior_std,
                                double uninformed_ratio, double correlation_threshold) {
  const auto p = static_cast<Eigen::Index>(names.size());
  if (posterior_covariance.rows() != p || posterior_covariance.cols() != p || prior_std.size() != p) {
    throw std::invalid_argument("identifiability: " + std::to_string(p) +
                                " names but a covariance of " +
                                std::to_string(posterior_covariance.rows()) + " x " +
                                std::to_string(posterior_covariance.cols()) + " and " +
                                std::to_string(prior_std.size()) + " prior std");
  }
  Identifiability out;
  out.names = names;
  const Eigen::VectorXd s = posterior_covariance.diagonal().cwiseSqrt();
  out.correlation = s.cwiseInverse().asDiagonal() * posterior_covariance * s.cwiseInverse().asDiagonal();
  out.std_ratio = s.cwiseQuotient(prior_std);
  for (Eigen::Index i = 0; i < p; ++i) {
    if (!(out.std_ratio(i) <= uninformed_ratio)) out.uninformed.push_back(names[static_cast<size_t>(i)]);
    for (Eigen::Index j = i + 1; j < p; ++j) {
      if (std::abs(out.correlation(i, j)) > correlation_threshold) {
        out.correlated.push_back({names[static_cast<size_t>(i)], names[static_cast<size_t>(j)],
                                  out.correlation(i, j)});
      }
    }
  }
  return out;
}

std::string FitReportOptions::validate() const {
  if (!(uninformed_ratio > 0)) return "fit report: uninformed_ratio must be > 0";
  if (!(correlation_threshold > 0 && correlation_threshold < 1)) {
    return "fit report: correlation_threshold must lie in (0, 1)";
  }
  if (!(discrepancy_rms > 0)) return "fit report: discrepancy_rms must be > 0";
  if (!(concentration_share > 0 && concentration_share <= 1)) {
    return "fit report: concentration_share must lie in (0, 1]";
  }
  if (!(phases.isovolumic_fraction > 0 && phases.isovolumic_fraction < 1)) {
    return "fit report: isovolumic_fraction must lie in (0, 1)";
  }
  return {};
}

FitReport make_fit_report(const observers::ObservationSet& obs,
                          const Eigen::Ref<const Eigen::VectorXd>& z,
                          const std::optional<PosteriorSpread>& posterior,
                          const FitReportOptions& options) {
  if (std::string e = obs.validate(); !e.empty()) throw std::invalid_argument("fit report: " + e);
  if (std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  if (z.size() != obs.size()) {
    throw std::invalid_argument("fit report: " + std::to_string(z.size()) + " model outputs for " +
                                std::to_string(obs.size()) + " observations");
  }
  FitReport report;
  const Eigen::VectorXd sigma = obs.R.diagonal().cwiseSqrt();
  const Eigen::VectorXd normalised = (obs.y - z).cwiseQuotient(sigma);
  const std::vector<ChannelEntries> groups = group_by_channel(obs);
  for (const auto& g : groups) {
    for (int f : g.frames) {
      if (f >= obs.frame_times.size()) {
        throw std::invalid_argument("fit report: observation '" + g.channel + "@f" + std::to_string(f) +
                                    "' has no frame time (" + std::to_string(obs.frame_times.size()) +
                                    " frame times)");
      }
    }
  }

  // Headline: RMS per channel.
  for (const auto& g : groups) {
    const Eigen::VectorXd r = gather(normalised, g.entries);
    const Eigen::VectorXd d = gather(obs.y - z, g.entries);
    ChannelFit c;
    c.channel = g.channel;
    c.unit = g.unit;
    c.count = static_cast<int>(r.size());
    c.rms_normalised = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
    c.rms_residual = std::sqrt(d.squaredNorm() / static_cast<double>(d.size()));
    c.max_abs_normalised = r.cwiseAbs().maxCoeff();
    report.channels.push_back(c);
    if (!g.curve()) continue;
    CurveResidual cr{g.channel, g.unit, Eigen::VectorXd(r.size()), gather(obs.y, g.entries),
                     gather(z, g.entries), gather(sigma, g.entries)};
    for (size_t k = 0; k < g.frames.size(); ++k) cr.times(static_cast<Eigen::Index>(k)) = obs.frame_times(g.frames[k]);
    report.curves.push_back(std::move(cr));
  }

  // Clinical indices and phases need the volume curve at frames.
  const ChannelEntries* vol = find_channel(groups, options.volume_channel);
  const ChannelEntries* pre = find_channel(groups, options.pressure_channel);
  if (pre && vol && pre->frames != vol->frames) {
    report.notes.push_back(options.pressure_channel + " is not observed at the frames of " +
                           options.volume_channel + ": pressure indices and phases use volume only");
    pre = nullptr;
  }
  if (!vol) {
    report.notes.push_back("no " + options.volume_channel +
                           " curve at frames: no clinical indices and no phase report");
  } else {
    const Eigen::VectorXd yp = pre ? gather(obs.y, pre->entries) : Eigen::VectorXd();
    const Eigen::VectorXd zp = pre ? gather(z, pre->entries) : Eigen::VectorXd();
    const ClinicalIndices o = clinical_indices(gather(obs.y, vol->entries), yp);
    const ClinicalIndices f = clinical_indices(gather(z, vol->entries), zp);
    auto add = [&](const char* name, const char* unit, double a, double b) {
      if (std::isnan(a)) return;
      report.indices.push_back({name, unit, a, b, b - a});
    };
    add("EDV", "m^3", o.edv, f.edv);
    add("ESV", "m^3", o.esv, f.esv);
    add("SV", "m^3", o.sv, f.sv);
    add("EF", "1", o.ef, f.ef);
    add("P_max", "Pa", o.p_max, f.p_max);
    add("EDP", "Pa", o.edp, f.edp);

    Eigen::VectorXd t(static_cast<Eigen::Index>(vol->frames.size()));
    for (size_t k = 0; k < vol->frames.size(); ++k) t(static_cast<Eigen::Index>(k)) = obs.frame_times(vol->frames[k]);
    std::vector<CyclePhase> phases;
    const model::Status s = classify_phases(t, gather(obs.y, vol->entries), yp, options.phases, phases);
    if (!s.ok()) {
      report.notes.push_back("phases not classified: " + s.message);
    } else {
      report.frame_times = t;
      report.frame_phases = phases;
    }
  }

  // Discrepancy: channels above the threshold observed at the classified frames.
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const auto& g = groups[gi];
    const double rms = report.channels[gi].rms_normalised;
    if (!(rms > options.discrepancy_rms) || !g.curve() || report.frame_phases.empty()) continue;
    if (g.frames != vol->frames) {
      report.notes.push_back(g.channel + " is not observed at the classified frames: no phase report");
      continue;
    }
    ChannelDiscrepancy d;
    d.channel = g.channel;
    d.rms_normalised = rms;
    const Eigen::VectorXd r = gather(normalised, g.entries);
    const double total = r.squaredNorm();
    for (int ph = 0; ph < kCyclePhases; ++ph) {
      PhaseResidual pr;
      pr.phase = static_cast<CyclePhase>(ph);
      double sum = 0.0;
      for (Eigen::Index k = 0; k < r.size(); ++k) {
        if (report.frame_phases[static_cast<size_t>(k)] != pr.phase) continue;
        ++pr.frames;
        sum += r(k) * r(k);
      }
      pr.rms_normalised = pr.frames > 0 ? std::sqrt(sum / pr.frames) : kNaN;
      pr.share = total > 0 ? sum / total : 0.0;
      d.phases.push_back(pr);
    }
    d.dominant = std::max_element(d.phases.begin(), d.phases.end(), [](const auto& a, const auto& b) {
                   return a.share < b.share;
                 })->phase;
    report.discrepancies.push_back(d);
  }

  if (posterior && !posterior->covariance.allFinite()) {
    report.notes.push_back("the posterior covariance is not finite: no identifiability report");
  } else if (posterior) {
    report.identifiability = identifiability(posterior->names, posterior->covariance,
                                             posterior->prior_std, options.uninformed_ratio,
                                             options.correlation_threshold);
  }

  // The summary in words.
  std::ostringstream s;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const ChannelFit& c = report.channels[gi];
    s << (gi ? "; " : "");
    if (std::isnan(c.rms_normalised)) {
      s << c.channel << ": no model output (failed run)";
      continue;
    }
    if (c.rms_normalised <= options.discrepancy_rms) {
      s << c.channel << " fits to " << fixed(c.rms_normalised, 1) << " noise std";
      continue;
    }
    s << c.channel << " misfit " << fixed(c.rms_normalised, 1) << " noise std";
    const auto d = std::find_if(report.discrepancies.begin(), report.discrepancies.end(),
                                [&](const auto& x) { return x.channel == c.channel; });
    if (d == report.discrepancies.end()) {
      s << ": beyond the noise";
      continue;
    }
    const PhaseResidual& top = d->phases[static_cast<size_t>(d->dominant)];
    if (top.share >= options.concentration_share) {
      s << " concentrated in " << to_string(top.phase) << " (" << fixed(100 * top.share, 0)
        << " % of squared residual on " << top.frames << " of " << c.count
        << " frames): model discrepancy";
    } else {
      s << " spread over the cycle (largest share " << fixed(100 * top.share, 0) << " % in "
        << to_string(top.phase) << "): model discrepancy or noise underestimated";
    }
  }
  if (report.identifiability) {
    if (!report.identifiability->uninformed.empty()) {
      s << "; not informed by the data (posterior std > " << fixed(100 * options.uninformed_ratio, 0)
        << " % of prior):";
      for (const auto& n : report.identifiability->uninformed) s << ' ' << n;
    }
    for (const auto& pr : report.identifiability->correlated) {
      s << "; " << pr.a << " and " << pr.b << " strongly correlated (rho " << fixed(pr.rho, 2) << ")";
    }
  }
  report.summary = s.str();
  return report;
}

// ---------------------------------------------------------------------------------------------
std::string PeriodEstimate::describe() const {
  if (!status.ok()) return "no period: " + status.message;
  std::ostringstream s;
  s.precision(4);
  s << period << " s ";
  if (method == Method::kAutocorrelation) {
    s << "from the autocorrelation (" << fixed(beats, 1) << " beats, r = " << fixed(correlation, 3) << ")";
  } else {
    s << "from the time span of one beat";
  }
  return s.str();
}

PeriodEstimate estimate_period(const Eigen::Ref<const Eigen::VectorXd>& times,
                               const Eigen::Ref<const Eigen::VectorXd>& values,
                               const PeriodOptions& options) {
  PeriodEstimate out;
  const Eigen::Index n = times.size();
  if (n < 3 || values.size() != n) {
    out.status = bad("period: need at least 3 samples with one value each, got " +
                     std::to_string(n) + " times and " + std::to_string(values.size()) + " values");
    return out;
  }
  if (!times.allFinite() || !values.allFinite()) {
    out.status = bad("period: times and values must be finite");
    return out;
  }
  for (Eigen::Index k = 1; k < n; ++k) {
    if (!(times(k) > times(k - 1))) {
      out.status = bad("period: times must increase strictly (sample " + std::to_string(k) + ")");
      return out;
    }
  }
  const double span = times(n - 1) - times(0);
  const double dt = span / static_cast<double>(n - 1);
  out.period = span + dt;  // one open beat
  out.beats = 1.0;
  out.method = PeriodEstimate::Method::kTimeSpan;

  // Uniform resampling at the mean spacing, then the first autocorrelation peak after a sign change.
  const Eigen::VectorXd t = times;
  const Eigen::VectorXd x = values;
  Eigen::VectorXd u(n);
  for (Eigen::Index k = 0; k < n; ++k) u(k) = lerp_at(t, x, times(0) + static_cast<double>(k) * dt);
  const auto max_lag = static_cast<Eigen::Index>(std::floor(options.max_lag_fraction * static_cast<double>(n - 1)));
  Eigen::VectorXd r = Eigen::VectorXd::Zero(max_lag + 2);
  for (Eigen::Index lag = 0; lag <= std::min(max_lag + 1, n - 3); ++lag) r(lag) = lag_correlation(u, lag);
  Eigen::Index lag = 1;
  while (lag <= max_lag && r(lag) >= 0) ++lag;  // first drop below zero
  Eigen::Index best = -1;
  for (; lag <= max_lag && lag + 1 < r.size(); ++lag) {
    if (r(lag) >= r(lag - 1) && r(lag) >= r(lag + 1) && r(lag) > 0) {
      best = lag;
      break;
    }
  }
  if (best > 0 && r(best) >= options.min_correlation) {
    const double a = r(best - 1), b = r(best), c = r(best + 1);
    const double denom = a - 2 * b + c;
    const double offset = denom < 0 ? 0.5 * (a - c) / denom : 0.0;  // parabola vertex, |offset| <= 1/2
    out.period = (static_cast<double>(best) + offset) * dt;
    out.correlation = b;
    out.method = PeriodEstimate::Method::kAutocorrelation;
    out.beats = (span + dt) / out.period;
  }
  return out;
}

AlignedBeat align_on_end_diastole(const model::Trajectory& measured, const AlignmentOptions& options) {
  AlignedBeat out;
  const Eigen::Index n = measured.times.size();
  if (n < 3 || measured.values.rows() != n || measured.channels.empty()) {
    out.status = bad("alignment: need at least 3 samples of at least one channel");
    return out;
  }
  const auto ci = options.landmark == AlignmentOptions::Landmark::kMaxVolume
                      ? measured.channel_index(options.channel)
                      : std::optional<int>(measured.channel_index(options.channel).value_or(0));
  if (!ci) {
    out.status = bad("alignment: no channel '" + options.channel + "' to find end-diastole on");
    return out;
  }
  const Eigen::VectorXd x = measured.values.col(*ci);
  double period = options.period;
  if (period <= 0) {
    const PeriodEstimate pe = estimate_period(measured.times, x);
    if (!pe.status.ok()) {
      out.status = bad("alignment: " + pe.status.message);
      return out;
    }
    period = pe.period;
  }
  const double t_first = measured.times(0);
  const double t_last = measured.times(n - 1);
  const double dt = (t_last - t_first) / static_cast<double>(n - 1);
  if (!(period > 2 * dt)) {
    out.status = bad("alignment: period " + std::to_string(period) + " s is not longer than two samples");
    return out;
  }
  // The landmark in the first beat of the record.
  double t0 = 0.0;
  if (options.landmark == AlignmentOptions::Landmark::kMaxVolume) {
    Eigen::Index k_max = 0;
    double best = -std::numeric_limits<double>::infinity();
    for (Eigen::Index k = 0; k < n && measured.times(k) < t_first + period - 0.5 * dt; ++k) {
      if (x(k) > best) {
        best = x(k);
        k_max = k;
      }
    }
    t0 = measured.times(k_max);
  }
  t0 += options.shift;
  out.landmark_time = t0;
  out.period = period;

  const bool several_beats = t_last - t0 >= period - 0.5 * dt && t_last - t_first >= period + 0.5 * dt;
  std::vector<std::pair<double, Eigen::Index>> rows;  // (aligned time, input row)
  for (Eigen::Index k = 0; k < n; ++k) {
    const double s = measured.times(k) - t0;
    if (several_beats) {
      if (s >= -1e-12 * period && s < period - 0.5 * dt) rows.emplace_back(std::max(s, 0.0), k);
    } else {
      double w = std::fmod(s, period);
      if (w < 0) w += period;
      if (w >= period - 1e-12 * period) w = 0.0;
      rows.emplace_back(w, k);
    }
  }
  std::stable_sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t k = 1; k < rows.size(); ++k) {
    if (!(rows[k].first > rows[k - 1].first)) {
      out.status = bad("alignment: two samples fall on the same time of the beat (t = " +
                       std::to_string(rows[k].first) + " s): is the period right?");
      return out;
    }
  }
  out.trajectory.channels = measured.channels;
  out.trajectory.times.resize(static_cast<Eigen::Index>(rows.size()));
  out.trajectory.values.resize(static_cast<Eigen::Index>(rows.size()), measured.values.cols());
  for (size_t k = 0; k < rows.size(); ++k) {
    out.trajectory.times(static_cast<Eigen::Index>(k)) = rows[k].first;
    out.trajectory.values.row(static_cast<Eigen::Index>(k)) = measured.values.row(rows[k].second);
  }
  return out;
}

void note_prior_conflict(FitReport& report, const PriorConflict& conflict) {
  report.prior_conflict = conflict.describe();
  if (report.prior_conflict.empty()) return;
  report.summary += (report.summary.empty() ? "" : "; ") + report.prior_conflict;
}

}  // namespace sigmaheart::estimation
