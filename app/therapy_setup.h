// The `therapy:` section of a config (docs/estimation.md s.12), parsed and checked against the
// model in one place for `therapy` and `validate`:
//
//   therapy:
//     personalization: ../results/lbbb-personalize.h5   # optional: a calibrate or personalize result
//                                # (its posterior is propagated; the model must be this config's)
//     uncertainty: {method: unscented, sigma_points: star, kappa: 1, samples: 200, seed: 1,
//                   interval: 90 %, inflate: none}  # method unscented | monte-carlo | point
//                                # inflate: none | nis (a personalize result's covariance times its
//                                # mean NIS over its expectation, when above 1) | a factor >= 1
//                   model_error: {ahr: 9 %, shared: 50 %}}   # or none (default): the model's own
//                                # AHR error against a reference (a validation cohort's), added to
//                                # every AHR; `shared`: the part common to every site (0 % default)
//     responder_threshold: 10 %  # AHR above which a therapy counts as a response
//     scar: auto                 # auto (segments whose contractility at the estimate is below
//                                # scar_threshold of the median) | none | [7, 13, ...]
//     scar_threshold: 50 %
//     intrinsic_conduction: true # fuse with the intrinsic activation (false: AV block)
//     conduction_velocity: 0.6 m/s   # the 17-segment graph of models paced by segment times
//     timing: {pr_interval: 160 ms, av_delay: 120 ms, vv_delay: 0 ms}  # vv > 0: LV lead first
//     rv_lead: {segment: 9, surface: epicardium}   # or {point: [x, y, z]} (3D models; m or "10 mm")
//     lv_leads: all              # or [5, 6, 11] or [{segment: 5, surface: endocardium}, {point: [...]}]
//     modes: [biv]               # biv | lv-only
//     sweep: {av_delay: [60 ms, 90 ms, 120 ms, 150 ms, 180 ms], vv_delay: [-40 ms, -20 ms, 0 ms, 20 ms, 40 ms]}
//                                # at the best site; `sweep: none` for none
//     pv_loops: true             # run the baseline and the best site at the posterior mean
//                                # once more for the PV loops of the report (2 runs)
//     threads: 2                 # --threads overrides
//
// Without `personalization` the therapies run once at the config's parameters (no uncertainty):
// how a known heart (a 3D truth) is paced. With it the parameters are the result's (every model
// parameter at its estimate) and the config may not set `simulator.parameters`; the model is
// wrapped as the personalisation fitted it (its volume shares, app/io/posterior_file.h) and an
// estimated t_shift, an observation-time alignment, is marginalised out.
#pragma once

#include "app/config.h"
#include "app/io/posterior_file.h"
#include "estimation/propagation.h"
#include "estimation/therapy/therapy.h"

#include <Eigen/Core>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app {

struct TherapyProblem {
  estimation::therapy::TherapyOptions options;  // ensemble threads from the config (--threads overrides)
  int threads = 0;                              // 0: not given
  bool pv_loops = true;                         // the beats at the posterior mean (2 more runs)
  std::optional<io::PosteriorFile> personalization;
  std::filesystem::path personalization_file;
  model::ParameterSpace space;                  // the parameters of the model run (make_therapy_model)
  Eigen::VectorXd base_theta;                   // every parameter of `space` (SI)
  std::string scar_source;                      // how the scar segments were chosen, for reports
  double inflation = 1.0;                       // the posterior covariance was multiplied by it
  std::string route;                            // how the model is paced (PacedSimulator::route)
};

// Every problem is an InputError at the offending key (file:line:column): a lead site outside the
// mesh or in no segment, a point on a model paced by segment times, an AV delay outside its range,
// a model whose activation cannot be paced, a personalisation file of another model.
TherapyProblem parse_therapy(const Config& config);

// The model the therapies run: the config's, wrapped as the personalisation fitted it.
std::unique_ptr<model::Simulator> make_therapy_model(const Config& config, const TherapyProblem& problem);

}  // namespace sigmaheart::app
