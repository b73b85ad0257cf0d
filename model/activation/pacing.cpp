#include "model/activation/pacing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::activation {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The reference ellipsoid of docs/models.md s.3.3 [m].
constexpr double kShortRadius = 0.025, kLongRadius = 0.045, kBasePlane = 0.0132;

// Arc length along the meridian from the apex to height z, with the ellipse parametrised by its
// eccentric angle a (z = -r_l cos a, r = r_s sin a): ds/da = sqrt(r_s^2 cos^2 a + r_l^2 sin^2 a);
// Simpson's rule on 256 panels (the integrand is smooth; error far below a micrometre).
double arc_from_apex(double z) {
  const double a_end = std::acos(std::clamp(-z / kLongRadius, -1.0, 1.0));
  const int n = 256;
  const double h = a_end / n;
  auto f = [](double a) { return std::hypot(kShortRadius * std::cos(a), kLongRadius * std::sin(a)); };
  double sum = f(0.0) + f(a_end);
  for (int i = 1; i < n; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * f(i * h);
  return sum * h / 3.0;
}

double radius_at(double z) {
  const double c = z / kLongRadius;
  return kShortRadius * std::sqrt(std::max(0.0, 1.0 - c * c));
}

// Height and azimuth [rad] of the centre of segment s (1-based).
std::pair<double, double> centre(int s) {
  const double apex = -kLongRadius, length = kBasePlane - apex;
  const double base_mid = kBasePlane - length / 3.0, mid_apical = kBasePlane - 2.0 * length / 3.0;
  const double cap = apex + length / 12.0, deg = std::numbers::pi / 180.0;
  if (s <= 6) return {0.5 * (kBasePlane + base_mid), (30.0 + 60.0 * (s - 1)) * deg};
  if (s <= 12) return {0.5 * (base_mid + mid_apical), (30.0 + 60.0 * (s - 7)) * deg};
  if (s <= 16) return {0.5 * (mid_apical + cap), (30.0 + 90.0 * (s - 13)) * deg};
  return {apex, 0.0};
}

double edge_length(int a, int b) {
  const auto [za, pa] = centre(a);
  const auto [zb, pb] = centre(b);
  double dphi = std::abs(pa - pb);
  dphi = std::min(dphi, 2.0 * std::numbers::pi - dphi);
  if (a == kSegments || b == kSegments) dphi = 0.0;  // the apex lies on the axis: along the meridian
  const double ds = arc_from_apex(zb) - arc_from_apex(za);
  return std::hypot(ds, 0.5 * (radius_at(za) + radius_at(zb)) * dphi);
}

}  // namespace

const char* to_string(Surface surface) {
  return surface == Surface::kEndocardium ? "endocardium" : "epicardium";
}

std::string LeadSite::describe() const {
  std::ostringstream s;
  if (point) {
    s << "point (" << 1e3 * point->x() << ", " << 1e3 * point->y() << ", " << 1e3 * point->z() << ") mm";
  } else {
    s << "segment " << segment << " (" << to_string(surface) << ")";
  }
  return s.str();
}

std::string PacingPlan::validate() const {
  std::ostringstream s;
  for (const Stimulus& st : stimuli) {
    if (!st.site.point && (st.site.segment < 1 || st.site.segment > kSegments)) {
      s << st.lead << " lead: segment " << st.site.segment << " is not an AHA segment (1..17)";
      return s.str();
    }
    if (!std::isfinite(st.time) || std::abs(st.time) >= 1.0) {
      s << st.lead << " lead: stimulus time " << st.time << " s must be finite and within 1 s of the intrinsic onset";
      return s.str();
    }
    if (st.site.point && !st.site.point->allFinite()) return st.lead + " lead: the point is not finite";
  }
  for (int k : scar)
    if (k < 1 || k > kSegments) {
      s << "scar segment " << k << " is not an AHA segment (1..17)";
      return s.str();
    }
  if (stimuli.empty() && !intrinsic) return "no stimulus and no intrinsic activation: nothing activates the ventricle";
  return {};
}

bool PacingPlan::in_scar(int segment) const { return std::find(scar.begin(), scar.end(), segment) != scar.end(); }

const std::vector<SegmentEdge>& aha17_graph() {
  static const std::vector<SegmentEdge> edges = [] {
    // Neighbours: the three rings around, basal k above mid k + 6, the mid segments' arcs over the
    // apical quarter segments (mid centres at 30 + 60 j deg with 60-deg arcs, apical at 30 + 90 j
    // with 90-deg arcs), the apex below every apical segment.
    const std::vector<std::pair<int, int>> pairs = {
        {1, 2},  {2, 3},  {3, 4},   {4, 5},   {5, 6},   {1, 6},   {7, 8},   {8, 9},   {9, 10},  {10, 11},
        {11, 12}, {7, 12}, {13, 14}, {14, 15}, {15, 16}, {13, 16}, {1, 7},   {2, 8},   {3, 9},   {4, 10},
        {5, 11}, {6, 12}, {7, 13},  {8, 13},  {8, 14},  {9, 14},  {9, 15},  {10, 15}, {11, 15}, {11, 16},
        {12, 16}, {12, 13}, {13, 17}, {14, 17}, {15, 17}, {16, 17}};
    std::vector<SegmentEdge> out;
    for (const auto& [a, b] : pairs) out.push_back({a, b, edge_length(a, b)});
    return out;
  }();
  return edges;
}

std::string GraphPacingOptions::validate() const {
  if (!(conduction_velocity > 0.0 && std::isfinite(conduction_velocity)))
    return "conduction_velocity must be positive and finite [m/s]";
  return {};
}

PacingOutcome segment_pacing(const PacingPlan& plan, const std::array<double, kSegments>& intrinsic,
                             const GraphPacingOptions& options) {
  if (const std::string m = plan.validate(); !m.empty()) throw std::invalid_argument("pacing plan: " + m);
  if (const std::string m = options.validate(); !m.empty()) throw std::invalid_argument("graph pacing: " + m);
  std::array<double, kSegments> intrinsic_t;
  intrinsic_t.fill(kInf);
  if (plan.intrinsic) {
    for (int k = 0; k < kSegments; ++k) {
      if (!std::isfinite(intrinsic[static_cast<size_t>(k)]))
        throw std::invalid_argument("graph pacing: the intrinsic time of segment " + std::to_string(k + 1) +
                                    " is not finite");
      intrinsic_t[static_cast<size_t>(k)] = intrinsic[static_cast<size_t>(k)];
    }
  }
  // The paced wave: Dijkstra from the captured leads. The intrinsic sequence is taken as given (it
  // is the heart's own, not re-propagated on the graph); a segment it activates before the paced
  // wave arrives is refractory and passes the paced wave on no further.
  std::array<double, kSegments> t;
  t.fill(kInf);
  PacingOutcome out;
  std::ostringstream note;
  for (const Stimulus& st : plan.stimuli) {
    if (st.site.point)
      throw std::invalid_argument(st.lead + " lead at " + st.site.describe() +
                                  ": the 17-segment graph takes lead sites by AHA segment, not as points");
    const int s = st.site.segment;
    const bool refractory = st.time >= intrinsic_t[static_cast<size_t>(s - 1)];
    const bool captured = !plan.in_scar(s) && !refractory;
    out.captured.push_back(captured);
    if (captured) {
      t[static_cast<size_t>(s - 1)] = std::min(t[static_cast<size_t>(s - 1)], st.time);
    } else {
      note << (note.tellp() > 0 ? "; " : "") << st.lead << " lead in "
           << (plan.in_scar(s) ? "scar segment " + std::to_string(s)
                               : "segment " + std::to_string(s) + ", already activated by the intrinsic wave")
           << ": no capture";
    }
  }
  // Dijkstra over 17 nodes; a scar segment is reached but relays nothing.
  std::array<std::vector<std::pair<int, double>>, kSegments> next;
  for (const SegmentEdge& e : aha17_graph()) {
    const double dt = e.length / options.conduction_velocity;
    next[static_cast<size_t>(e.a - 1)].push_back({e.b - 1, dt});
    next[static_cast<size_t>(e.b - 1)].push_back({e.a - 1, dt});
  }
  std::array<bool, kSegments> done{};
  for (int round = 0; round < kSegments; ++round) {
    int u = -1;
    for (int k = 0; k < kSegments; ++k)
      if (!done[static_cast<size_t>(k)] && std::isfinite(t[static_cast<size_t>(k)]) &&
          (u < 0 || t[static_cast<size_t>(k)] < t[static_cast<size_t>(u)]))
        u = k;
    if (u < 0) break;
    done[static_cast<size_t>(u)] = true;
    if (plan.in_scar(u + 1) || intrinsic_t[static_cast<size_t>(u)] < t[static_cast<size_t>(u)]) continue;
    for (const auto& [v, dt] : next[static_cast<size_t>(u)])
      t[static_cast<size_t>(v)] = std::min(t[static_cast<size_t>(v)], t[static_cast<size_t>(u)] + dt);
  }
  for (int k = 0; k < kSegments; ++k) t[static_cast<size_t>(k)] = std::min(t[static_cast<size_t>(k)], intrinsic_t[static_cast<size_t>(k)]);
  out.segment_times = t;
  out.earliest = kInf;
  out.latest = -kInf;
  for (int k = 0; k < kSegments; ++k) {
    if (plan.in_scar(k + 1) || !std::isfinite(t[static_cast<size_t>(k)])) continue;
    out.earliest = std::min(out.earliest, t[static_cast<size_t>(k)]);
    out.latest = std::max(out.latest, t[static_cast<size_t>(k)]);
  }
  out.note = note.str();
  return out;
}

namespace {

// The least-squares line through (distance, time) over the segments outside scar, the distances
// from `sources` on the graph.
struct LineFit {
  double slope = 0.0;  // [s/m]
  double r_squared = 0.0;
  int n = 0;
  bool spread = false;  // the distances differ
};
LineFit fit_from(const std::array<double, kSegments>& times, const std::vector<bool>& in_scar,
                 const std::vector<int>& sources) {
  PacingPlan plan;
  plan.intrinsic = false;
  for (int k : sources) plan.stimuli.push_back({"source", {k + 1, Surface::kEpicardium, std::nullopt}, 0.0});
  std::array<double, kSegments> none;
  none.fill(kInf);
  const std::array<double, kSegments> d = segment_pacing(plan, none, {1.0}).segment_times;  // [m] at 1 m/s
  double n = 0.0, sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0, syy = 0.0;
  for (int k = 0; k < kSegments; ++k) {
    const double x = d[static_cast<size_t>(k)], y = times[static_cast<size_t>(k)];
    if (in_scar[static_cast<size_t>(k)] || !std::isfinite(x) || !std::isfinite(y)) continue;
    n += 1.0;
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    syy += y * y;
  }
  LineFit f;
  f.n = static_cast<int>(n);
  const double vx = n * sxx - sx * sx, vy = n * syy - sy * sy, cxy = n * sxy - sx * sy;
  if (f.n < 3 || vx <= 1e-12 * n * sxx) return f;
  f.spread = true;
  f.slope = cxy / vx;
  f.r_squared = vy > 0.0 ? cxy * cxy / (vx * vy) : 0.0;
  return f;
}

}  // namespace

SequenceVelocity sequence_velocity(const std::array<double, kSegments>& times, const std::vector<int>& scar) {
  SequenceVelocity out;
  std::vector<bool> in_scar(kSegments, false);
  for (int s : scar)
    if (s >= 1 && s <= kSegments) in_scar[static_cast<size_t>(s - 1)] = true;
  // Candidate breakthroughs: every segment outside scar, alone or with a neighbour.
  std::vector<std::vector<int>> candidates;
  for (int k = 0; k < kSegments; ++k)
    if (!in_scar[static_cast<size_t>(k)] && std::isfinite(times[static_cast<size_t>(k)])) candidates.push_back({k});
  for (const SegmentEdge& e : aha17_graph())
    if (!in_scar[static_cast<size_t>(e.a - 1)] && !in_scar[static_cast<size_t>(e.b - 1)] &&
        std::isfinite(times[static_cast<size_t>(e.a - 1)]) && std::isfinite(times[static_cast<size_t>(e.b - 1)]))
      candidates.push_back({e.a - 1, e.b - 1});
  if (candidates.empty()) {
    out.failure = "no segment outside scar has a finite activation time";
    return out;
  }
  // Slower than 0.1 m/s or faster than 10 m/s is no myocardial conduction (0.3-1 m/s, Durrer et al.
  // 1970; the Purkinje system 2-4 m/s).
  constexpr double kMinSlope = 0.1, kMaxSlope = 10.0;  // [s/m]
  double best_r2 = -1.0;
  bool any_spread = false;
  for (const auto& c : candidates) {
    const LineFit f = fit_from(times, in_scar, c);
    if (!f.spread) continue;
    any_spread = true;
    if (f.slope > kMinSlope && f.slope < kMaxSlope && f.r_squared > best_r2) {
      best_r2 = f.r_squared;
      out.velocity = 1.0 / f.slope;
      out.r_squared = f.r_squared;
      out.segments = f.n;
      out.sources.clear();
      for (int k : c) out.sources.push_back(k + 1);
    }
  }
  if (best_r2 >= 0.0) return out;
  out.velocity = 0.0;
  if (!any_spread) {
    out.failure = "fewer than 3 segments outside scar with activation times";
  } else {
    out.failure = "the activation times do not spread with the distance from any segment or pair of neighbours "
                  "(a conduction velocity of 0.1-10 m/s; a synchronous sequence has none)";
  }
  return out;
}

}  // namespace sigmaheart::model::activation
