// Pacing: the activation sequence of a ventricle paced from leads (docs/models.md s.3.6, s.4.10).
//
// A pacing plan is a list of stimuli (a lead site and the time it fires) on one clock, the clock of
// the intrinsic beat: t = 0 is the onset of the intrinsic ventricular activation (QRS onset), so a
// stimulus before it has a negative time (an AV delay shorter than the PR interval), and the
// atrial kick of the circulation (the last 0.12 s before t = 0, model/circulation) keeps its place.
// With `intrinsic` the paced wave is fused with the intrinsic sequence by the earliest arrival:
// whichever front reaches the tissue first activates it, and a front stops where the tissue has
// already been activated (the wave collision of an eikonal model). Scar segments neither
// conduct nor capture: a wave reaching a scar segment activates what is left of it there (its
// residual contractility) and stops; a lead in scar does not capture.
//
// Models take a plan in one of two ways:
//  - through the Pacing capability (model/simulator.h, Simulator::pacing(); lv-3d: an eikonal solve
//    with onsets at the lead sites, model/fem/pacing.h);
//  - through their per-segment activation times (parameters tagged activation_time, segments
//    1..17, e.g. Td_XX of lumped-regional): segment_pacing() below computes them on the graph of
//    the 17 AHA segments, and PacedSimulator (paced_simulator.h) writes them into theta.
#pragma once

#include <Eigen/Core>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::model::activation {

inline constexpr int kSegments = 17;

enum class Surface { kEndocardium, kEpicardium };
const char* to_string(Surface surface);

// Where a lead sits: the centroid of an AHA segment on a surface, or a point of a 3D model.
struct LeadSite {
  int segment = 0;  // 1..17, or 0 with a point
  Surface surface = Surface::kEpicardium;
  std::optional<Eigen::Vector3d> point;  // [m], reference configuration (3D models only)
  std::string describe() const;          // "segment 5 (epicardium)", "point (10, 0, -20) mm"
};

struct Stimulus {
  std::string lead;  // "RV", "LV", for reports
  LeadSite site;
  double time = 0.0;  // [s] on the intrinsic clock (t = 0: intrinsic QRS onset)
};

struct PacingPlan {
  std::vector<Stimulus> stimuli;  // may be empty: the intrinsic sequence alone (the baseline)
  bool intrinsic = true;          // fuse with the intrinsic sequence; false: none (AV block)
  std::vector<int> scar;          // AHA segments 1..17 that neither conduct nor capture
  // Empty when valid, else a message naming the offending stimulus or segment.
  std::string validate() const;
  bool in_scar(int segment) const;
};

// What a model did with a plan.
struct PacingOutcome {
  std::vector<bool> captured;                 // per stimulus: false in scar
  std::array<double, kSegments> segment_times{};  // [s] intrinsic clock (3D: mean over the segment)
  double earliest = 0.0;                      // [s] over the activated tissue outside scar
  double latest = 0.0;                        // [s]
  double total_activation() const { return latest - earliest; }  // [s]
  std::string note;                           // e.g. "LV lead in scar segment 7: no capture"
};

// The capability of models whose activation can be set from a pacing plan (Simulator::pacing()).
class Pacing {
 public:
  virtual ~Pacing() = default;
  // Sets the activation of the runs that follow (clones made afterwards inherit it). Throws
  // std::invalid_argument for a site outside the model (outside the mesh, in no segment) or an
  // invalid plan; the model is then unchanged.
  virtual PacingOutcome pace(const PacingPlan& plan) = 0;
};

// --- The 17-segment graph of the lumped models ---------------------------------------------

// The segments' centres on the human-sized truncated ellipsoid of docs/models.md s.3.3 (the one
// behind lumped-regional's area shares and activation patterns: endocardium r_s 25 mm, r_l 45 mm,
// base plane z = 13.2 mm, thirds of the cavity length, apical cap L/12): basal and mid centres at
// mid-ring height and 30 + 60 j deg, apical at 30 + 90 j deg, the apex on the axis. Edges join
// segments that share a border (the rings around, basal k with mid k + 6, a mid segment with the
// apical segments its arc overlaps, every apical segment with the apex), of length the path along
// the wall between their centres: sqrt(ds^2 + (r dphi)^2), ds the meridian arc between the two
// heights, r the mean ring radius. Lengths [m], one row per edge (a, b, length), a < b 1-based.
struct SegmentEdge {
  int a = 0, b = 0;
  double length = 0.0;  // [m]
};
const std::vector<SegmentEdge>& aha17_graph();

struct GraphPacingOptions {
  double conduction_velocity = 0.6;  // [m/s] myocardial (lumped-regional's `pacing` pattern)
  std::string validate() const;
};

// Segment activation times [s] on the intrinsic clock: the paced wave by Dijkstra on aha17_graph()
// from the captured stimuli (their segment at their time), edges traversed at the conduction
// velocity, fused with the intrinsic sequence (`intrinsic`, 17 entries [s], with plan.intrinsic) by
// the earliest arrival. The intrinsic times are the heart's own and are not re-propagated on the
// graph; a segment they activate before the paced wave arrives is refractory: it passes the paced
// wave on no further, and a stimulus there at or after its intrinsic time does not capture. A scar
// segment takes the earliest arrival from a neighbour but passes nothing on, and a stimulus in it
// does not capture. A segment nothing reaches (no intrinsic sequence, no capture) keeps +infinity.
// Throws std::invalid_argument for an invalid plan, a lead given as a point, or `intrinsic` not of
// 17 finite entries.
PacingOutcome segment_pacing(const PacingPlan& plan, const std::array<double, kSegments>& intrinsic,
                             const GraphPacingOptions& options = {});

// The conduction velocity of an intrinsic sequence on the same graph (docs/models.md s.3.6, "The
// paced wave's velocity"): the least-squares line through (distance, time) over the segments outside
// scar, the distance being a segment's shortest path on aha17_graph() from the breakthrough, which
// is the segment, or the pair of neighbouring segments, whose line fits best (largest R^2 among the
// lines of 0.1-10 m/s). The velocity is the line's inverse slope. A paced wave crosses the same
// myocardium as the intrinsic one (the eikonal of lv-3d scales both with its conduction_scale), so a
// sequence that is slower than the graph's default makes a slower paced wave.
struct SequenceVelocity {
  double velocity = 0.0;      // [m/s]; 0 when `failure` is not empty
  int segments = 0;           // in the fit
  std::vector<int> sources;   // the breakthrough segments (1..17)
  double r_squared = 0.0;
  std::string failure;        // why no velocity: a sequence that does not spread (synchronous), too few segments
};
SequenceVelocity sequence_velocity(const std::array<double, kSegments>& times, const std::vector<int>& scar);

}  // namespace sigmaheart::model::activation
