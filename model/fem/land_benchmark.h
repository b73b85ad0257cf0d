// The cardiac mechanics verification benchmark of Land et al. 2015 (Proc R Soc A 471:20150641).
//
//  Problem 1: beam 10 x 1 x 1 mm, Guccione C = 2 kPa, bf 8, bt 2, bfs 4, fibres along x, x = 0
//             clamped, follower pressure 0.004 kPa on the bottom face z = 0. Output: z of the
//             point (10, 0.5, 1) mm after deformation.
//  Problem 2: truncated ellipsoid (mesh.h), Guccione C = 10 kPa, bf = bt = bfs = 1,
//             incompressible, endocardial pressure 10 kPa, base fixed. Output: z of the
//             endocardial and epicardial apex.
//  Problem 3: as 2 with C = 2 kPa, bf 8, bt 2, bfs 4, helix angle +90 deg endo to -90 deg epi,
//             pressure 15 kPa, then active tension Ta = 60 kPa with S_act = Ta f0 (x) f0.
// Internally SI; the results are reported in mm like the paper.
#pragma once

#include "model/fem/mechanics.h"
#include "model/fem/mesh.h"

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// Published reference values [mm] used for comparison (see experiments/land-benchmark/README.md
// for where each comes from and how sure we are).
struct LandReference {
  static constexpr double kProblem1Deflection = 4.17;   // z of (10, 0.5, 1) (verify)
  static constexpr double kProblem2EndoApex = -26.5;    // (verify)
  static constexpr double kProblem2EpiApex = -28.2;     // (verify)
  static constexpr double kProblem3EndoApexLow = -12.5, kProblem3EndoApexHigh = -12.0;  // (verify)
  static constexpr double kProblem3EpiApexLow = -15.5, kProblem3EpiApexHigh = -15.2;    // (verify)
};

struct LandOptions {
  int problem = 2;                  // 1, 2 or 3
  int refinement = 1;               // K >= 1: beam 8K x K x K, ellipsoid K x 6K x 12K (P2)
  int load_steps = 0;               // 0: problem default
  int quadrature_degree = 5;
  BaseCondition base = BaseCondition::kFixed;
  LinearSolver linear_solver = LinearSolver::kAuto;
  std::string validate() const;
};

struct LandResult {
  int problem = 0;
  int refinement = 0;
  int n_tets = 0, n_nodes = 0, n_unknowns = 0;
  // Problem 1: the deflection (z of the tracked point) in `primary`; 2 and 3: endocardial apex z
  // in `primary`, epicardial apex z in `secondary` [mm].
  double primary = 0.0, secondary = 0.0;
  double seconds = 0.0;
  Summary summary;
  Mesh mesh;
  State state;
  std::vector<Frame> element_fibres;
};

// Builds the problem's mesh, fibres and mechanics and solves it. Never throws for a failed
// Newton solve (summary.converged false); throws std::invalid_argument for bad options.
LandResult run_land_problem(const LandOptions& options, const ProgressCallback& progress = {});

// Mesh of problem `problem` at refinement K (for tests and benches).
Mesh land_mesh(int problem, int refinement);
// The problem's mechanics (mesh, fibres, law, boundary conditions), unsolved.
std::unique_ptr<Mechanics> land_mechanics(const LandOptions& options);
// The problem's final load (problem 3: pressure 15 kPa and Ta 60 kPa; reached in two stages).
Load land_load(int problem);

}  // namespace sigmaheart::model::fem
