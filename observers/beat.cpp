#include "observers/beat.h"

#include "model/enum_names.h"
#include "model/units.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace sigmaheart::observers {
namespace {

using model::Status;
using model::StatusCode;

long floor_div(long a, long n) { return a >= 0 ? a / n : -((-a + n - 1) / n); }

int wrap_index(long k, int n) {
  const long r = k % n;
  return static_cast<int>(r < 0 ? r + n : r);
}

// Slope at s of the parabola through (ta, xa), (tb, xb), (tc, xc) (Lagrange form).
double parabola_slope(double ta, double xa, double tb, double xb, double tc, double xc, double s) {
  return xa * ((s - tb) + (s - tc)) / ((ta - tb) * (ta - tc)) +
         xb * ((s - ta) + (s - tc)) / ((tb - ta) * (tb - tc)) +
         xc * ((s - ta) + (s - tb)) / ((tc - ta) * (tc - tb));
}

// sign = +1 for the maximum, -1 for the minimum.
Extremum find_extremum(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x,
                       bool refine, double sign) {
  const int n = grid.samples();
  int best = 0;
  for (int i = 1; i < n; ++i) {
    if (sign * x(i) > sign * x(best)) best = i;
  }
  Extremum e{grid.times(best), x(best), best};
  const bool has_neighbours = grid.periodic || (best > 0 && best < n - 1);
  if (!refine || !has_neighbours) return e;
  // y = y0 + b s + c s^2 through the extreme sample and its neighbours; vertex at s = -b / 2c.
  const double t0 = grid.time(best);
  const double h1 = t0 - grid.time(best - 1L);
  const double h2 = grid.time(best + 1L) - t0;
  const double dm = x(wrap_index(best - 1L, n)) - x(best);
  const double dp = x(wrap_index(best + 1L, n)) - x(best);
  const double c = (dm * h2 + dp * h1) / (h1 * h2 * (h1 + h2));
  const double b = (dp * h1 * h1 - dm * h2 * h2) / (h1 * h2 * (h1 + h2));
  if (!(sign * c < 0.0)) return e;  // flat or not an extremum of the parabola: keep the sample
  const double s = std::clamp(-b / (2.0 * c), -h1, h2);
  e.value = x(best) + b * s + c * s * s;
  e.time = grid.wrap(t0 + s);
  return e;
}

}  // namespace

constexpr std::array<model::EnumName<Periodicity>, 4> kPeriodicityNames{{
    {Periodicity::kAuto, "auto"}, {Periodicity::kClosed, "closed"}, {Periodicity::kOpen, "open"},
    {Periodicity::kNone, "none"},
}};
const char* to_string(Periodicity periodicity) {
  return model::enum_to_string(kPeriodicityNames, periodicity, "?");
}
std::optional<Periodicity> parse_periodicity(const std::string& text) {
  return model::enum_from_string(kPeriodicityNames, text);
}

constexpr std::array<model::EnumName<Interpolation>, 2> kInterpolationNames{{
    {Interpolation::kLinear, "linear"}, {Interpolation::kCubic, "cubic"},
}};
const char* to_string(Interpolation interpolation) {
  return model::enum_to_string(kInterpolationNames, interpolation, "?");
}
std::optional<Interpolation> parse_interpolation(const std::string& text) {
  return model::enum_from_string(kInterpolationNames, text);
}

double crossing_before(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x, int from,
                       double level) {
  const int n = grid.samples();
  const bool above = x(from) >= level;
  auto same_side = [&](long k) {
    const double v = x(wrap_index(k, n));
    return above ? v >= level : v <= level;
  };
  long k = from;
  while (true) {
    if (!grid.periodic && k == 0) return grid.times(0);
    if (k <= from - n) return grid.time(from) - grid.period;
    if (!same_side(k - 1)) break;
    --k;
  }
  const double xa = x(wrap_index(k - 1, n)), xb = x(wrap_index(k, n));
  const double ta = grid.time(k - 1), tb = grid.time(k);
  const double s = (xa == xb) ? 1.0 : std::clamp((level - xa) / (xb - xa), 0.0, 1.0);
  return ta + s * (tb - ta);
}

VolumeLandmarks volume_landmarks(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& v,
                                 const BeatOptions& options) {
  VolumeLandmarks l;
  l.max = find_max(grid, v, options.refine_extrema);
  l.min = find_min(grid, v, options.refine_extrema);
  const double tol = options.plateau_tolerance;
  const double sv = l.max.value - l.min.value;
  if (tol > 0.0 && sv > 0.0) {
    l.ed_time = crossing_before(grid, v, l.max.index, l.max.value - tol * sv);
    l.es_time = crossing_before(grid, v, l.min.index, l.min.value + tol * sv);
    l.ejection_start = crossing_before(grid, v, l.min.index, l.max.value - tol * sv);
  } else {
    l.ed_time = l.max.time;
    l.es_time = l.min.time;
    l.ejection_start = l.max.time;
    if (grid.periodic && l.ejection_start > l.es_time) l.ejection_start -= grid.period;
  }
  return l;
}

model::Status end_diastole_time(const Eigen::Ref<const Eigen::VectorXd>& times,
                                const Eigen::Ref<const Eigen::VectorXd>& volume, const BeatOptions& options,
                                double& t_ed) {
  BeatGrid grid;
  if (model::Status s = make_beat_grid(times, volume, options, grid); !s.ok()) return s;
  t_ed = volume_landmarks(grid, grid.unique_samples(volume), options).ed_time;
  if (grid.periodic) t_ed = grid.wrap(t_ed);
  return model::Status::Ok();
}

std::string BeatOptions::validate() const {
  if (!(plateau_tolerance >= 0.0 && plateau_tolerance < 0.5)) {
    return "beat plateau_tolerance must lie in [0, 0.5)";
  }
  if (!std::isfinite(period) || period < 0.0) return "beat period must be >= 0 s (0 infers it)";
  if (!std::isfinite(closure_tolerance) || closure_tolerance < 0.0) {
    return "beat closure_tolerance must be >= 0";
  }
  return {};
}

double BeatGrid::time(long k) const {
  const long n = samples();
  const long q = floor_div(k, n);
  return times(k - q * n) + static_cast<double>(q) * period;
}

double BeatGrid::wrap(double t) const {
  if (!periodic) return t;
  double r = std::fmod(t - times(0), period);
  if (r < 0.0) r += period;
  if (r >= period) r = 0.0;  // fmod rounding just below a whole period
  return times(0) + r;
}

Eigen::VectorXd BeatGrid::unique_samples(const Eigen::Ref<const Eigen::VectorXd>& column) const {
  const Eigen::Index n = samples();
  if (!closed) return column.head(n);
  const double mismatch = column(n) - column(0);
  return column.head(n).array() - mismatch * (times.array() - times(0)) / period;
}

Status make_beat_grid(const Eigen::Ref<const Eigen::VectorXd>& times,
                      const Eigen::Ref<const Eigen::MatrixXd>& columns, const BeatOptions& options,
                      BeatGrid& grid) {
  if (auto msg = options.validate(); !msg.empty()) {
    return Status::Error(StatusCode::kInvalidArgument, msg);
  }
  const Eigen::Index n = times.size();
  if (columns.rows() != n) {
    return Status::Error(StatusCode::kInvalidArgument, "beat: columns and times differ in length");
  }
  if (n < 3) {
    return Status::Error(StatusCode::kBadOutput,
                         "beat has " + std::to_string(n) + " samples, at least 3 are needed");
  }
  double min_spacing = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!std::isfinite(times(k))) {
      return Status::Error(StatusCode::kNonFinite, "beat: time " + std::to_string(k) + " is not finite");
    }
    if (k > 0) {
      if (!(times(k) > times(k - 1))) {
        std::ostringstream s;
        s << "beat: times do not increase at sample " << k << " (" << times(k - 1) << " s then "
          << times(k) << " s)";
        return Status::Error(StatusCode::kInvalidArgument, s.str());
      }
      min_spacing = std::min(min_spacing, times(k) - times(k - 1));
    }
  }
  if (!columns.allFinite()) {
    return Status::Error(StatusCode::kNonFinite, "beat: a sample value is NaN or infinite");
  }
  const double span = times(n - 1) - times(0);

  Periodicity kind = options.periodicity;
  if (kind == Periodicity::kAuto) {
    if (options.period > 0.0) {
      kind = std::abs(span - options.period) <= 0.5 * min_spacing ? Periodicity::kClosed
                                                                  : Periodicity::kOpen;
    } else {
      bool closed = columns.cols() > 0;
      for (Eigen::Index c = 0; c < columns.cols(); ++c) {
        const double range = columns.col(c).maxCoeff() - columns.col(c).minCoeff();
        if (std::abs(columns(n - 1, c) - columns(0, c)) > options.closure_tolerance * range) {
          closed = false;
        }
      }
      kind = closed ? Periodicity::kClosed : Periodicity::kOpen;
    }
  }

  grid = BeatGrid{};
  switch (kind) {
    case Periodicity::kNone:
      grid.times = times;
      grid.periodic = false;
      grid.period = 0.0;
      break;
    case Periodicity::kClosed:
      if (n < 4) {
        return Status::Error(StatusCode::kBadOutput,
                             "closed beat has " + std::to_string(n - 1) +
                                 " unique samples, at least 3 are needed");
      }
      if (options.period > 0.0 && std::abs(span - options.period) > 0.5 * min_spacing) {
        std::ostringstream s;
        s << "closed beat spans " << span << " s but the period is " << options.period << " s";
        return Status::Error(StatusCode::kInvalidArgument, s.str());
      }
      grid.times = times.head(n - 1);
      grid.period = span;
      grid.closed = true;
      break;
    case Periodicity::kOpen:
    case Periodicity::kAuto:
      grid.times = times;
      grid.period = options.period > 0.0 ? options.period : span + span / static_cast<double>(n - 1);
      if (!(grid.period > span)) {
        std::ostringstream s;
        s << "open beat spans " << span << " s, not less than its period " << grid.period << " s";
        return Status::Error(StatusCode::kInvalidArgument, s.str());
      }
      break;
  }
  return Status::Ok();
}

Eigen::VectorXd derivative(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x) {
  const int n = grid.samples();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i) {
    long a = i - 1;
    long c = i + 1;
    if (!grid.periodic) {
      if (i == 0) { a = 1; c = 2; }
      if (i == n - 1) { a = n - 3; c = n - 2; }
    }
    const double ta = grid.time(a), tc = grid.time(c);
    const double xa = x(wrap_index(a, n)), xc = x(wrap_index(c, n));
    const double ti = grid.times(i);
    // Order the three nodes however they fall; the Lagrange slope does not care.
    d(i) = parabola_slope(ta, xa, ti, x(i), tc, xc, ti);
  }
  return d;
}

Extremum find_max(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x, bool refine) {
  return find_extremum(grid, x, refine, +1.0);
}

Extremum find_min(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x, bool refine) {
  return find_extremum(grid, x, refine, -1.0);
}

std::optional<double> interpolate(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::VectorXd* dxdt, double t,
                                  Interpolation interpolation) {
  const int n = grid.samples();
  const auto& ts = grid.times;
  long k = 0;
  double tw = t;
  if (grid.periodic) {
    tw = grid.wrap(t);
    k = std::upper_bound(ts.data(), ts.data() + n, tw) - ts.data() - 1;
    k = std::clamp(k, 0L, static_cast<long>(n - 1));
  } else {
    const double eps = 1e-9 * (ts(n - 1) - ts(0));
    if (t < ts(0) - eps || t > ts(n - 1) + eps) return std::nullopt;
    tw = std::clamp(t, ts(0), ts(n - 1));
    k = std::upper_bound(ts.data(), ts.data() + n, tw) - ts.data() - 1;
    k = std::clamp(k, 0L, static_cast<long>(n - 2));
  }
  const double t0 = grid.time(k), t1 = grid.time(k + 1);
  const int i0 = wrap_index(k, n), i1 = wrap_index(k + 1, n);
  const double h = t1 - t0;
  const double s = (tw - t0) / h;
  if (interpolation == Interpolation::kLinear || dxdt == nullptr) {
    return x(i0) + s * (x(i1) - x(i0));
  }
  const double s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * x(i0) + (s3 - 2 * s2 + s) * h * (*dxdt)(i0) +
         (-2 * s3 + 3 * s2) * x(i1) + (s3 - s2) * h * (*dxdt)(i1);
}

Status channel_in_si(const model::Trajectory& trajectory, const std::string& name,
                     const std::string& si_unit, Eigen::VectorXd& column) {
  const auto idx = trajectory.channel_index(name);
  if (!idx) {
    std::vector<std::string> names;
    for (const auto& c : trajectory.channels) names.push_back(c.name);
    std::string msg = "trajectory has no channel '" + name + "'";
    const auto guess = model::closest_match(name, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    return Status::Error(StatusCode::kInvalidArgument, msg);
  }
  const auto& unit = trajectory.channels[static_cast<size_t>(*idx)].unit;
  double factor = 1.0;
  if (!unit.empty() && unit != si_unit) {
    const auto conv = model::units::to_si(unit);
    if (!conv || conv->si_unit != si_unit) {
      return Status::Error(StatusCode::kInvalidArgument,
                           "channel '" + name + "' has unit '" + unit + "', expected a unit of '" +
                               si_unit + "'");
    }
    factor = conv->factor;
  }
  if (trajectory.values.rows() != trajectory.times.size() ||
      trajectory.values.cols() != static_cast<Eigen::Index>(trajectory.channels.size())) {
    return Status::Error(StatusCode::kInvalidArgument,
                         "trajectory values do not match its times and channels");
  }
  column = factor * trajectory.values.col(*idx);
  return Status::Ok();
}

}  // namespace sigmaheart::observers
