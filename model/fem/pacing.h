// Paced activation on an LV mesh (docs/models.md s.4.10): an eikonal solve (eikonal.h) from the
// intrinsic onsets and the pacing leads together, so the paced and the intrinsic fronts meet where
// they collide (earliest arrival), with scar that neither conducts nor captures.
//
//  - Lead sites (model/activation/pacing.h): an AHA segment's centre on the endocardium or the
//    epicardium, placed on the surface vertex nearest to its AHA coordinates (cavity.h: basal, mid
//    and apical centres at height fractions 5/6, 1/2, 1/6 of the cavity length and angles -30 + 60 j
//    or -30 + 90 j deg; segment 17 at the endocardial or epicardial apex), or a point of the mesh.
//  - The intrinsic onsets are given as eikonal options on the intrinsic clock, t = 0 at the intrinsic
//    onset: a pattern's sites and velocities (solved together with the leads: one eikonal, the fronts
//    collide), or one onset per vertex (times of the heart's own, fused with the paced wave alone by
//    the earliest arrival, not re-propagated; the paced wave then crosses tissue the intrinsic wave
//    activated first, an approximation for these sources).
//  - Scar: the tetrahedra of the scar segments conduct at kScarSlowdown times their velocity, so no
//    front crosses them before the others have gone round; a vertex inside a scar segment (every
//    tetrahedron around it scar) then takes the earliest time on that segment's border: the wave
//    that reaches a scar segment activates what is left of it there and goes no further (the rule of
//    the 17-segment graph, activation::segment_pacing). A lead in a scar segment does not capture.
#pragma once

#include "model/activation/pacing.h"
#include "model/fem/cavity.h"
#include "model/fem/eikonal.h"
#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <vector>

namespace sigmaheart::model::fem {

inline constexpr double kScarSlowdown = 1e-3;

struct PacedActivation {
  Eigen::VectorXd vertex_times;  // [s] per mesh vertex, intrinsic clock
  activation::PacingOutcome outcome;
};

// The surface point of a lead site (its segment's centre on its surface, or the point itself) and
// the AHA segment it lies in. Throws std::invalid_argument for a point outside the mesh.
struct PlacedSite {
  Eigen::Vector3d position;  // [m]
  int segment = 0;           // 1..17
};
PlacedSite place_lead(const Mesh& mesh, const AhaLabels& labels, const activation::LeadSite& site);

// intrinsic: the intrinsic onsets with the velocities and frames of the tissue (one entry per
// tetrahedron or one for the mesh); ignored except its velocities and frames when
// plan.intrinsic is false. Throws std::invalid_argument for an invalid plan or a lead outside the
// mesh.
PacedActivation paced_activation(const Mesh& mesh, const AhaLabels& labels, const EikonalOptions& intrinsic,
                                 const activation::PacingPlan& plan);

}  // namespace sigmaheart::model::fem
