// The top-level config sections of the built-in commands and the check `sigmaheart validate` runs
// on each (docs/architecture.md, "Configs"). One table, so which sections a config may hold does
// not depend on which commands happen to be set up.
#include "app/calibration_setup.h"
#include "app/config.h"
#include "app/observe_setup.h"
#include "app/personalize_setup.h"
#include "app/sensitivity_setup.h"
#include "app/specificity_setup.h"
#include "app/therapy_setup.h"

namespace sigmaheart::app {

const ConfigSections& builtin_config_sections() {
  static const ConfigSections sections({
      // calibrate and specificity: observations, estimate and calibration are parsed together,
      // so checking one checks all. A specificity config's observations: has no file: (the cases
      // give the files); it is checked with the first case's file, as calibrate would check one.
      {"observations",
       [](const Config& c) {
         if (c.file.root().has("cases")) {
           parse_specificity_setup(c);
         } else {
           parse_calibration_problem(c);
         }
       }},
      {"estimate", [](const Config&) {}},
      {"calibration", [](const Config&) {}},
      {"cases", [](const Config& c) { parse_specificity_setup(c); }},
      {"specificity", [](const Config& c) { parse_specificity_section(c); }},
      {"sensitivity", [](const Config& c) { parse_sensitivity(c); }},
      {"personalize", [](const Config& c) { parse_personalize(c); }},
      {"therapy", [](const Config& c) { parse_therapy(c); }},
      {"observe", [](const Config& c) { parse_observe(c.file); }},
  });
  return sections;
}

}  // namespace sigmaheart::app
