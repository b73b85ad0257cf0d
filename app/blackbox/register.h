// The black-box models (`model: external`, `model: umbridge`; docs/architecture.md s.9). They
// live in app/ because they do file and network I/O, which model/ never does; the `sigmaheart`
// executable runs with cli_models() = the built-in models plus these.
#pragma once

#include "model/registry.h"

namespace sigmaheart::app::blackbox {

// Adds `external` and `umbridge` to `registry`.
void register_blackbox_models(model::ModelRegistry& registry);

// model::builtin_models(), the 3D models of sigmaheart::fem (lv-3d, when built) and the
// black-box models, built once.
const model::ModelRegistry& cli_models();

}  // namespace sigmaheart::app::blackbox
