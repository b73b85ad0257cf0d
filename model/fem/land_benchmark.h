// The cardiac mechanics verification benchmark of Land et al. 2015 (Proc R Soc A 471:20150641,
// open access as PMC4707707), set-up as in its section 2(c):
//
//  Problem 1: beam [0, 10] x [0, 1] x [0, 1] mm, Guccione C = 2 kPa, bf 8, bt 2, bfs 4, fibres
//             along x; the face x = 0 fixed in all directions; pressure 0.004 kPa on the bottom
//             face z = 0 (a follower load). Output: z of the point (10, 0.5, 1) mm after deformation.
//  Problem 2: truncated ellipsoid (mesh.h), Guccione C = 10 kPa, bf = bt = bfs = 1,
//             incompressible, endocardial pressure 10 kPa; the base plane z = 5 mm fixed in all
//             directions (not sliding). Output: z of the endocardial and epicardial apex.
//  Problem 3: as 2 with C = 2 kPa, bf 8, bt 2, bfs 4, helix angle alpha = 90 - 180 t deg (+90 endo,
//             -90 epi) on the directions dx/du, dx/dv of the ellipsoid (eqs 2.7-2.12), pressure
//             15 kPa and a second Piola-Kirchhoff active stress Ta f f^T with Ta = 60 kPa (eq 2.13);
//             base fixed as in problem 2.
// Internally SI; the results are reported in mm like the paper.
#pragma once

#include "model/fem/mechanics.h"
#include "model/fem/mesh.h"

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// Closed interval [low, high] [mm].
struct LandRange {
  double low = 0.0, high = 0.0;
  bool contains(double x) const { return x >= low && x <= high; }
};

// Published references [mm]: the spread (min..max) over the participating codes of each code's
// finest submitted solution, read off the paper's figures 3, 6 and 9 (the values are plotted, not
// tabulated; experiments/land-benchmark/README.md lists the value of every code and how it was
// read). Each bound is the extreme marker widened by one pixel of the 200 ppi figure (0.0004 mm in
// fig. 3, 0.008 mm in fig. 6, 0.009 mm in fig. 9) and rounded outward to the digits shown.
struct LandReference {
  // Fig. 3, 11 codes: Hopkins-MESCAL 4.152 .. glasgowHeart-IBFE 4.179 mm.
  static constexpr LandRange kProblem1Deflection{4.151, 4.180};
  // Fig. 6, 10 codes (PUC-FEAP submitted none): endocardial apex LifeV -26.04 .. IBFE -26.79 mm,
  // epicardial apex LifeV -27.83 .. IBFE -28.60 mm.
  static constexpr LandRange kProblem2EndoApex{-26.80, -26.02};
  static constexpr LandRange kProblem2EpiApex{-28.61, -27.82};
  // The same without LifeV, whose solution the paper names as the largest error among the codes
  // with 3D elements (section 4): endo up to CARP -26.41, epi up to MOOSE-EWE -28.12 mm.
  static constexpr LandRange kProblem2EndoApexWithoutLifeV{-26.80, -26.39};
  static constexpr LandRange kProblem2EpiApexWithoutLifeV{-28.61, -28.11};
  // Fig. 9, 10 codes: endocardial apex Cardioid -12.35 .. MOOSE-EWE -11.86 mm, epicardial apex
  // glasgowHeart-IBFE -15.59 .. LifeV -15.30 mm.
  static constexpr LandRange kProblem3EndoApex{-12.36, -11.84};
  static constexpr LandRange kProblem3EpiApex{-15.61, -15.28};
};

struct LandOptions {
  int problem = 2;                  // 1, 2 or 3
  int refinement = 1;               // K >= 1: beam 8K x K x K, ellipsoid K x 6K x 12K (P2)
  int load_steps = 0;               // 0: problem default
  int quadrature_degree = 5;
  BaseCondition base = BaseCondition::kFixed;  // the paper's condition; kSliding for comparison only
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
