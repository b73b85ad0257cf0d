// Registration of the 3D models (lv-3d) and the parsing of their `numerics:` sections
// (model/registry.h). The 3D models live in sigmaheart::fem, which depends on sigmaheart::model,
// so they are not in builtin_models() (registry.cpp, part of sigmaheart::model): the command line
// adds them (app/blackbox/register.cpp, cli_models()) and tests call register_fem_models().
#pragma once

#include "model/fem/electromechanics.h"
#include "model/registry.h"

namespace sigmaheart::model::fem {

// Adds "lv-3d".
void register_fem_models(ModelRegistry& registry);

// `numerics:` of lv-3d -> LeftVentricle3DOptions (defaults from the struct). Keys:
//   mesh: coarse | medium | fine          # presets of (transmural, longitudinal, circumferential)
//   mesh: {transmural: 1, longitudinal: 6, circumferential: 12}
//   quadrature_degree: 2 | 5,  fibre_endo: 60 (deg),  fibre_epi: -60 (deg),  base: sliding | fixed
//   dt: 5 ms,  max_step_cuts: 6,  inflation_steps: 4,  min_beats: 1,  max_beats: 20,
//   periodic_tolerance: 1e-3,  output_every: 1,  newton_tolerance: 1e-8,  newton_max_iterations: 20
//   activation: synchronous | apex_distance,  conduction_velocity: 0.6 m/s
//   linear_solver: sparselu (default: the same bits in every thread) | auto | umfpack | amg (GMRES +
//   BoomerAMG block preconditioner, solver.h; slower than umfpack on the bundled meshes,
//   docs/solvers.md s.5)
// Errors go through the reader (file:line:column in app/).
LeftVentricle3DOptions read_lv3d_options(const OptionReader& numerics);

// The mesh presets (n_transmural, n_longitudinal, n_circumferential), the refinements K = 1, 2, 3
// of the Land benchmark mesh (K, 6K, 12K): coarse (1, 6, 12), medium (2, 12, 24), fine (3, 18, 36).
LeftVentricle3DOptions with_mesh_preset(LeftVentricle3DOptions o, const std::string& preset);

}  // namespace sigmaheart::model::fem
