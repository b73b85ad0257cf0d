// Coarse space of the two-level preconditioner of the iterative solver (SparseSolver::
// set_coarse_space; docs/solvers.md s.4): smooth functions of the truncated
// ellipsoid's coordinates that span the thin wall's shell modes, the upper end of the spectrum of
// the preconditioned Schur complement (bench/fem_bench BM_Lv3dSchurSpectrum).
#pragma once

#include "model/fem/mesh.h"

#include <Eigen/SparseCore>

#include <string>

namespace sigmaheart::model::fem {

// Piecewise-linear hats in each ellipsoidal coordinate of the reference nodes (t, s, v) with
// s = theta / theta_base(t) (EllipsoidGeometry::coordinates): `transmural` nodes of t on [0, 1],
// `meridian` nodes of s on [0, 1] (the apex's node s = 0 without dependence on v) and `around`
// periodic nodes of v. Their products are a partition of unity on the wall.
struct EllipsoidCoarseOptions {
  int transmural = 3;
  int meridian = 7;
  int around = 12;
  bool pressure = true;  // a pressure column per hat besides the three displacement ones
  std::string validate() const;  // empty when valid
};

// Which coarse grid ellipsoid_coarse_options() gives (docs/solvers.md s.4):
// - kWallModes: at most 3 x 5 x 8 nodes whatever the mesh, displacement and pressure columns: the
//   smooth shell modes on which SIMPLE's diagonal is furthest from the true Schur complement
//   (without the grad-div term).
// - kHalfMesh: every other mesh node along and around the wall, at most 3 across, displacement
//   columns only: with the grad-div term the Schur side is mesh independent, and this grid
//   catches what the displacement V-cycle leaves, so GMRES takes about as many iterations as with
//   an exact displacement solve (4.7-5.4 per Newton iteration in the beat up to 72 604 unknowns).
enum class CoarseGrid { kWallModes, kHalfMesh };

// The coarse grid for a mesh of (n_transmural, n_longitudinal, n_circumferential) elements. Either
// grid is no finer than every other node of the mesh along and around the wall and than its node
// layers across, so that every hat carries mesh nodes (a coarse space finer than the mesh has
// empty or dependent columns).
EllipsoidCoarseOptions ellipsoid_coarse_options(int n_transmural, int n_longitudinal, int n_circumferential,
                                                CoarseGrid grid = CoarseGrid::kWallModes);

// The prolongation P (n x n_c) of the mixed u-p unknowns of `mesh` ordered as in Mechanics: 3
// displacement components per node (node-major), one pressure per vertex, then `trailing` scalar
// unknowns (e.g. a cavity pressure coupled monolithically; lv-3d's step borders its circulation
// unknowns outside the matrix and has none), each its own coarse unknown. Per scalar hat: three
// displacement columns (x, y, z) and, with o.pressure, one pressure column. Rows of constrained
// unknowns are left to the solver (it ignores the matrix's identity rows).
// std::invalid_argument on invalid options or a negative `trailing`.
Eigen::SparseMatrix<double, Eigen::ColMajor, int> ellipsoid_coarse_space(const Mesh& mesh, const EllipsoidGeometry& g,
                                                                         const EllipsoidCoarseOptions& o,
                                                                         int trailing = 0);

}  // namespace sigmaheart::model::fem
