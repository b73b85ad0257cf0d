#include "model/fem/pacing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::fem {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// AHA coordinates (height fraction, angle [deg]) of a segment's centre (cavity.h conventions).
std::pair<double, double> segment_centre(int s) {
  if (s <= 6) return {5.0 / 6.0, -30.0 + 60.0 * (s - 1)};
  if (s <= 12) return {0.5, -30.0 + 60.0 * (s - 7)};
  return {1.0 / 6.0, -30.0 + 90.0 * (s - 13)};
}

// The vertex of surface `tag` with the smallest height along the long axis (its apex).
Eigen::Vector3d surface_apex(const Mesh& mesh, const AhaFrame& f, int tag) {
  double best = kInf;
  Eigen::Vector3d x = f.apex;
  for (int n : mesh.nodes_with_tag(tag)) {
    if (n >= mesh.n_vertices) continue;
    const Eigen::Vector3d p = mesh.nodes.row(n).transpose();
    const double h = (p - f.apex).dot(f.axis);
    if (h < best) {
      best = h;
      x = p;
    }
  }
  return x;
}

}  // namespace

PlacedSite place_lead(const Mesh& mesh, const AhaLabels& labels, const activation::LeadSite& site) {
  PlacedSite out;
  if (site.point) {
    const int tet = locate_point(mesh, *site.point);
    if (tet < 0) throw std::invalid_argument("lead site " + site.describe() + " lies outside the mesh");
    out.position = *site.point;
    out.segment = labels.element_segment[static_cast<size_t>(tet)];
    if (out.segment < 1 || out.segment > kAhaSegments)
      throw std::invalid_argument("lead site " + site.describe() + " lies in no AHA segment");
    return out;
  }
  if (site.segment < 1 || site.segment > kAhaSegments)
    throw std::invalid_argument("lead site segment " + std::to_string(site.segment) + " is not an AHA segment (1..17)");
  const int tag = site.surface == activation::Surface::kEndocardium ? kEndocardium : kEpicardium;
  out.segment = site.segment;
  if (site.segment == kAhaSegments) {
    out.position = surface_apex(mesh, labels.frame, tag);
  } else {
    const auto [h, phi] = segment_centre(site.segment);
    out.position = surface_site(mesh, labels.frame, AhaOptions{}.reference_direction, tag, h, phi);
  }
  return out;
}

PacedActivation paced_activation(const Mesh& mesh, const AhaLabels& labels, const EikonalOptions& intrinsic,
                                 const activation::PacingPlan& plan) {
  if (const std::string m = plan.validate(); !m.empty()) throw std::invalid_argument("pacing plan: " + m);
  const int n_tets = mesh.n_tets();
  std::vector<char> scar(static_cast<size_t>(n_tets), 0);
  for (int e = 0; e < n_tets; ++e) scar[static_cast<size_t>(e)] = plan.in_scar(labels.element_segment[static_cast<size_t>(e)]);

  EikonalOptions o;
  o.frames = intrinsic.frames;
  o.source_radius = intrinsic.source_radius;
  o.tolerance = intrinsic.tolerance;
  o.velocities.resize(static_cast<size_t>(n_tets));
  for (int e = 0; e < n_tets; ++e) {
    ConductionVelocities v = intrinsic.velocities.size() == 1 ? intrinsic.velocities[0]
                                                              : intrinsic.velocities.at(static_cast<size_t>(e));
    if (scar[static_cast<size_t>(e)]) v = {v.fibre * kScarSlowdown, v.sheet * kScarSlowdown, v.normal * kScarSlowdown};
    o.velocities[static_cast<size_t>(e)] = v;
  }
  if (plan.intrinsic) {
    o.sites = intrinsic.sites;
    o.vertex_onsets = intrinsic.vertex_onsets;
    if (!o.sites.empty()) {
      // A pattern's sites: shift them so that the intrinsic sequence alone starts at t = 0.
      const double t0 = solve_eikonal(mesh, o).earliest;
      for (OnsetSite& s : o.sites) s.time -= t0;
    }
  }
  PacedActivation out;
  std::ostringstream note;
  for (const activation::Stimulus& st : plan.stimuli) {
    const PlacedSite p = place_lead(mesh, labels, st.site);
    const bool captured = !plan.in_scar(p.segment);
    out.outcome.captured.push_back(captured);
    if (captured) {
      o.sites.push_back({p.position, st.time});
    } else {
      note << (note.tellp() > 0 ? "; " : "") << st.lead << " lead at " << st.site.describe() << " in scar segment "
           << p.segment << ": no capture";
    }
  }
  out.outcome.note = note.str();
  // Intrinsic times given per vertex (not a pattern of onsets): the heart's own, fused with the paced
  // wave alone by the earliest arrival rather than re-propagated with the paced wave's velocities.
  const bool vertex_intrinsic = plan.intrinsic && intrinsic.sites.empty() && !intrinsic.vertex_onsets.empty();
  Eigen::VectorXd own = Eigen::VectorXd::Constant(mesh.n_vertices, kInf);
  if (vertex_intrinsic) {
    for (const VertexOnset& v : o.vertex_onsets) own(v.vertex) = std::min(own(v.vertex), v.time);
    o.vertex_onsets.clear();
  }
  if (o.sites.empty() && o.vertex_onsets.empty() && !vertex_intrinsic)
    throw std::invalid_argument("pacing plan: no lead captures and there is no intrinsic activation");
  EikonalResult r;
  r.times = own;
  if (!o.sites.empty() || !o.vertex_onsets.empty()) {
    r = solve_eikonal(mesh, o);
    if (vertex_intrinsic) r.times = r.times.cwiseMin(own);
  }
  out.vertex_times = r.times;

  // Vertices with a non-scar tetrahedron around them; the border of each scar segment.
  std::vector<char> live(static_cast<size_t>(mesh.n_vertices), 0);
  for (int e = 0; e < n_tets; ++e)
    if (!scar[static_cast<size_t>(e)])
      for (int k = 0; k < 4; ++k) live[static_cast<size_t>(mesh.tets(e, k))] = 1;
  std::vector<double> border(kAhaSegments + 1, kInf);
  for (int e = 0; e < n_tets; ++e) {
    if (!scar[static_cast<size_t>(e)]) continue;
    const int s = labels.element_segment[static_cast<size_t>(e)];
    for (int k = 0; k < 4; ++k) {
      const int v = mesh.tets(e, k);
      if (live[static_cast<size_t>(v)]) border[static_cast<size_t>(s)] = std::min(border[static_cast<size_t>(s)], r.times(v));
    }
  }
  const double any_border = *std::min_element(border.begin(), border.end());
  for (int e = 0; e < n_tets; ++e) {
    if (!scar[static_cast<size_t>(e)]) continue;
    const int s = labels.element_segment[static_cast<size_t>(e)];
    const double t = std::isfinite(border[static_cast<size_t>(s)]) ? border[static_cast<size_t>(s)] : any_border;
    for (int k = 0; k < 4; ++k) {
      const int v = mesh.tets(e, k);
      if (!live[static_cast<size_t>(v)]) out.vertex_times(v) = std::min(r.times(v), t);
    }
  }

  // Segment times: the mean over each segment's tetrahedra of their vertex means.
  std::array<double, kAhaSegments> sum{};
  std::array<int, kAhaSegments> count{};
  for (int e = 0; e < n_tets; ++e) {
    const int s = labels.element_segment[static_cast<size_t>(e)] - 1;
    double t = 0.0;
    for (int k = 0; k < 4; ++k) t += 0.25 * out.vertex_times(mesh.tets(e, k));
    sum[static_cast<size_t>(s)] += t;
    ++count[static_cast<size_t>(s)];
  }
  for (int s = 0; s < kAhaSegments; ++s)
    out.outcome.segment_times[static_cast<size_t>(s)] =
        count[static_cast<size_t>(s)] > 0 ? sum[static_cast<size_t>(s)] / count[static_cast<size_t>(s)] : kInf;
  out.outcome.earliest = kInf;
  out.outcome.latest = -kInf;
  for (int v = 0; v < mesh.n_vertices; ++v) {
    if (!live[static_cast<size_t>(v)] || !std::isfinite(out.vertex_times(v))) continue;
    out.outcome.earliest = std::min(out.outcome.earliest, out.vertex_times(v));
    out.outcome.latest = std::max(out.outcome.latest, out.vertex_times(v));
  }
  return out;
}

}  // namespace sigmaheart::model::fem
