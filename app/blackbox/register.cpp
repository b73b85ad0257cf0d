#include "app/blackbox/register.h"

#include "app/blackbox/external_model.h"
#include "app/blackbox/umbridge.h"

#ifdef SIGMAHEART_HAVE_FEM
#include "model/fem/register.h"
#endif

namespace sigmaheart::app::blackbox {

void register_blackbox_models(model::ModelRegistry& registry) {
  registry.add({"external",
                "a program run once per member: parameters to a file, curves back as CSV "
                "(numerics: command, output, parameters, channels)",
                configure_external,
                {}});
  registry.add({"umbridge",
                "a model on a UM-Bridge server (numerics: url, name, parameters, channels, frames)",
                configure_umbridge,
                {}});
}

const model::ModelRegistry& cli_models() {
  static const model::ModelRegistry models = [] {
    model::ModelRegistry r = model::builtin_models();
#ifdef SIGMAHEART_HAVE_FEM
    // The 3D models live in sigmaheart::fem, outside builtin_models() (model/fem/register.h).
    model::fem::register_fem_models(r);
#endif
    register_blackbox_models(r);
    return r;
  }();
  return models;
}

}  // namespace sigmaheart::app::blackbox
