#include "model/fem/register.h"

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

LeftVentricle3DOptions with_mesh_preset(LeftVentricle3DOptions o, const std::string& preset) {
  if (preset == "coarse") {
    o.n_transmural = 1, o.n_longitudinal = 6, o.n_circumferential = 12;
  } else if (preset == "medium") {
    o.n_transmural = 2, o.n_longitudinal = 12, o.n_circumferential = 24;
  } else if (preset == "fine") {
    o.n_transmural = 3, o.n_longitudinal = 18, o.n_circumferential = 36;
  } else {
    throw std::invalid_argument("unknown mesh preset '" + preset + "' (expected coarse, medium or fine)");
  }
  return o;
}

LeftVentricle3DOptions read_lv3d_options(const OptionReader& node) {
  LeftVentricle3DOptions o;
  node.check_keys({"mesh", "quadrature_degree", "fibre_endo", "fibre_epi", "base", "dt", "max_step_cuts",
                   "inflation_steps", "min_beats", "max_beats", "periodic_tolerance", "output_every",
                   "newton_tolerance", "newton_max_iterations", "activation", "conduction_velocity",
                   "linear_solver", "linear_tolerance", "geometry", "active_stress", "element_order",
                   "bulk_modulus", "pressure_stabilization", "grad_div", "coarse_correction",
                   "exact_displacement_solve", "activation_shape", "conduction_scale"});
  if (node.has("geometry")) {
    // The truncated ellipsoid's radii and base plane (EllipsoidGeometry, docs/models.md s.4.1);
    // keys left out keep the human-sized values.
    const auto g = node.child("geometry");
    if (!g->is_map()) node.fail("geometry", node.path() + ".geometry: expected a map of r_short_endo, "
                                            "r_long_endo, r_short_epi, r_long_epi, z_base [m]");
    g->check_keys({"r_short_endo", "r_long_endo", "r_short_epi", "r_long_epi", "z_base"});
    EllipsoidGeometry& e = o.geometry;
    e.r_short_endo = g->quantity("r_short_endo", "m", e.r_short_endo);
    e.r_long_endo = g->quantity("r_long_endo", "m", e.r_long_endo);
    e.r_short_epi = g->quantity("r_short_epi", "m", e.r_short_epi);
    e.r_long_epi = g->quantity("r_long_epi", "m", e.r_long_epi);
    e.z_base = g->quantity("z_base", "m", e.z_base);
  }
  if (node.has("active_stress"))
    o.active_stress = node.choice("active_stress", {"fibre", "tangent_isotropic"}) == "fibre"
                          ? ActiveStress::kFibre
                          : ActiveStress::kTangentIsotropic;
  if (node.has("mesh")) {
    const auto mesh = node.child("mesh");
    if (mesh->is_map()) {
      mesh->check_keys({"transmural", "longitudinal", "circumferential"});
      o.n_transmural = mesh->integer("transmural", o.n_transmural);
      o.n_longitudinal = mesh->integer("longitudinal", o.n_longitudinal);
      o.n_circumferential = mesh->integer("circumferential", o.n_circumferential);
    } else {
      o = with_mesh_preset(o, node.choice("mesh", {"coarse", "medium", "fine"}));
    }
  }
  o.quadrature_degree = node.integer("quadrature_degree", o.quadrature_degree);
  o.element_order = node.integer("element_order", o.element_order);
  o.bulk_modulus = node.quantity("bulk_modulus", "Pa", o.bulk_modulus);
  o.pressure_stabilization = node.number("pressure_stabilization", o.pressure_stabilization);
  o.grad_div = node.number("grad_div", o.grad_div);
  o.fibre_endo_deg = node.number("fibre_endo", o.fibre_endo_deg);
  o.fibre_epi_deg = node.number("fibre_epi", o.fibre_epi_deg);
  if (node.has("base")) o.base = parse_base_condition(node.choice("base", {"sliding", "fixed"}));
  read_beat_numerics(node, o);
  o.max_step_cuts = node.integer("max_step_cuts", o.max_step_cuts);
  o.inflation_steps = node.integer("inflation_steps", o.inflation_steps);
  if (node.has("activation")) {
    const std::string a = node.choice("activation", {"synchronous", "apex_distance", "healthy", "lbbb"});
    o.activation = a == "synchronous"     ? ActivationSource::kSynchronous
                   : a == "apex_distance" ? ActivationSource::kApexDistance
                   : a == "healthy"       ? ActivationSource::kHealthy
                                          : ActivationSource::kLbbb;
  }
  o.conduction_velocity = node.quantity("conduction_velocity", "m/s", o.conduction_velocity);
  read_activation_input(node, o.activation_input);
  o.conduction_scale = node.number("conduction_scale", o.conduction_scale);
  if (node.has("linear_solver")) {
    o.linear_solver = parse_linear_solver(node.choice("linear_solver", {"auto", "umfpack", "sparselu", "amg"}));
    if (!linear_solver_available(o.linear_solver))
      node.fail("linear_solver", node.path() + ": linear_solver " + node.choice("linear_solver", {"umfpack", "amg"}) +
                                     " is not built in (" +
                                     (o.linear_solver == LinearSolver::kAmg ? "hypre, Debian libhypre-dev"
                                                                            : "SuiteSparse, Debian libsuitesparse-dev") +
                                     "); use sparselu");
  }
  o.linear_tolerance = node.number("linear_tolerance", o.linear_tolerance);
  // Default on for the scalable set-up (linear_solver amg with the grad-div term on linear
  // tetrahedra), where its grid follows the mesh and the beat is 14-37 % faster at the same EF
  // (docs/solvers.md s.4-5); off otherwise.
  o.coarse_correction = node.boolean(
      "coarse_correction", o.coarse_correction || (o.linear_solver == LinearSolver::kAmg && o.grad_div > 0 &&
                                                   o.element_order == 1));
  o.exact_displacement_solve = node.boolean("exact_displacement_solve", o.exact_displacement_solve);
  if (const std::string msg = o.validate(); !msg.empty()) {
    // Messages start with the field name; map it to its key.
    std::string field = msg.substr(0, msg.find_first_of(" ="));
    if (field.rfind("n_", 0) == 0) field = "mesh";
    if (field == "fibre") field = "fibre_endo";
    if (field == "geometry:") field = "geometry";
    if (field == "activation_shape:") field = "activation_shape";
    node.fail(field, node.path() + ": " + msg);
  }
  return o;
}

// Presets of lv-3d (docs/models.md s.4.8, "Presets"). `healthy`: every segment's contractility
// 90 kPa (default 80) and a faster contraction rate k_ATP 17 1/s (default 8), tuned on the coarse
// mesh with `dt` 20 ms and the healthy eikonal activation so that the periodic beat lies in the
// adult ranges of docs/models.md s.7 (EDV 147.8 mL, ESV 52.8 mL, EF 64.3 %, peak 130.4 mmHg,
// dP/dt max 1298 mmHg/s, EDP 6.9 mmHg, aortic 127.1/71.9 mmHg; tests/model/fem/electromechanics_slow_test.cpp). `lbbb-heart-failure`: below.
namespace {

std::string segment_name(int k) { return std::string("sigma0_") + (k < 10 ? "0" : "") + std::to_string(k); }

std::vector<Preset> lv3d_presets() {
  Preset healthy{"healthy",
                 "healthy adult beat on the coarse mesh with healthy activation: sigma0_XX 90 kPa, k_ATP 17 1/s "
                 "(docs/models.md s.4.8)",
                 {{"k_ATP", 17.0}},
                 {}};
  for (int k = 1; k <= kAhaSegments; ++k) healthy.values.emplace_back(segment_name(k), 9.0e4);

  // The dyssynchronous failing heart (the usual candidate for resynchronisation therapy): left
  // bundle branch block activation and a dilated, thinner ventricle, with the remodelling of the
  // lumped `heart-failure` preset (docs/models.md s.7): stiffer tissue (c1, c2, c_exp x1.5, x1.5,
  // x2.5: fibrosis), 6 % lower contractility and a slower contraction rate than `healthy`, raised
  // filling pressure with a weak atrial kick, +10 % peripheral resistance. Geometry: endocardium
  // 28/48 mm (short/long radius), epicardium 36/56 mm (8 mm wall against the healthy 10 mm), the
  // base plane scaled with the long axis (5 mm x 48/17). Tuned on the coarse mesh at `dt` 20 ms
  // (docs/models.md s.4.8, "Presets"; tests/model/fem/electromechanics_slow_test.cpp).
  Preset failing{"lbbb-heart-failure",
                 "dilated failing ventricle with left bundle branch block (HFrEF, EF ~25 %): activation lbbb, "
                 "endocardium 28/48 mm, epicardium 36/56 mm, stiffer and weaker tissue, filling pressure 18 mmHg "
                 "(docs/models.md s.4.8)",
                 {{"c1", 900.0},
                  {"c2", 1350.0},
                  {"c_exp", 1500.0},
                  {"k_ATP", 15.0},
                  {"P_at0", 2400.0},      // 18 mmHg
                  {"P_at_kick", 266.6},   // 2 mmHg
                  {"R_d", 1.1e8}},
                 {{"activation", "lbbb"},
                  {"geometry.r_short_endo", "0.028"},
                  {"geometry.r_long_endo", "0.048"},
                  {"geometry.r_short_epi", "0.036"},
                  {"geometry.r_long_epi", "0.056"},
                  {"geometry.z_base", "0.014118"}}};
  for (int k = 1; k <= kAhaSegments; ++k) failing.values.emplace_back(segment_name(k), 8.5e4);
  return {healthy, failing};
}

}  // namespace

void register_fem_models(ModelRegistry& registry) {
  registry.add(ModelSetup{
      "lv-3d",
      "3D BCS left ventricle (P2-P1 finite elements, truncated ellipsoid) with the cavity pressure coupled "
      "monolithically to valves and Windkessel; regional volumes V_segXX",
      [](const OptionReader& numerics) {
        const LeftVentricle3DOptions options = read_lv3d_options(numerics);
        return ModelBuild(LeftVentricle3D::default_parameters(),
                          [options](const ParameterSpace& p) -> std::unique_ptr<Simulator> {
                            return std::make_unique<LeftVentricle3D>(options, p);
                          });
      },
      lv3d_presets()});
}

}  // namespace sigmaheart::model::fem
