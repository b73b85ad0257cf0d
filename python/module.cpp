// The C++ half of the `sigmaheart` Python module (docs/python.md): configs, simulators on a
// parameter vector, and the commands run in-process. Bad input raises sigmaheart.InputError with
// the file:line:column message; a run that fails raises sigmaheart.RunFailed. Numbers are SI; every
// array comes with its unit. The package python/sigmaheart/__init__.py wraps this into the API.
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/config.h"
#include "app/errors.h"
#include "estimation/interrupt.h"
#include "observers/global_indices.h"

#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <sstream>
#include <stdexcept>

namespace py = pybind11;

namespace sigmaheart::python {
namespace {

py::handle input_error_type;  // module-lifetime references (never released)
py::handle run_failed_type;

[[noreturn]] void raise(py::handle type, const std::string& message) {
  PyErr_SetString(type.ptr(), message.c_str());
  throw py::error_already_set();
}

// A loaded config and its simulator.
struct LoadedConfig {
  std::shared_ptr<app::Config> config;

  std::string name() const { return config->name; }
  std::string model() const { return config->simulator.model; }
};

LoadedConfig load(const std::string& path, const std::vector<std::string>& overrides) {
  try {
    return {std::make_shared<app::Config>(app::load_config(path, overrides, app::blackbox::cli_models()))};
  } catch (const app::InputError& e) {
    raise(input_error_type, e.what());
  } catch (const std::invalid_argument& e) {
    raise(input_error_type, path + ": " + e.what());
  }
}

py::list parameter_table(const model::ParameterSpace& space) {
  py::list out;
  for (const auto& p : space.all()) {
    py::dict d;
    d["name"] = p.name;
    d["unit"] = p.unit;
    d["nominal"] = p.nominal;
    d["lower"] = p.lower;
    d["upper"] = p.upper;
    d["family"] = p.family;
    d["segment"] = p.segment;
    d["doc"] = p.doc;
    out.append(d);
  }
  return out;
}

// One run at theta (SI): the full vector, or a dict of the parameters that differ from the
// config's values.
py::dict run_simulator(const LoadedConfig& c, const py::object& theta_in) {
  const model::ParameterSpace& space = c.config->simulator.parameters;
  Eigen::VectorXd theta = space.nominal();
  if (py::isinstance<py::dict>(theta_in)) {
    for (const auto& [key, value] : theta_in.cast<py::dict>()) {
      const std::string name = key.cast<std::string>();
      try {
        theta(space.index_or_throw(name)) = value.cast<double>();
      } catch (const std::invalid_argument& e) {
        raise(input_error_type, e.what());
      }
    }
  } else if (!theta_in.is_none()) {
    const Eigen::VectorXd v = theta_in.cast<Eigen::VectorXd>();
    if (v.size() != theta.size()) {
      raise(input_error_type, "expected a parameter vector of " + std::to_string(theta.size()) + " entries (" +
                                  c.config->simulator.model + "), got " + std::to_string(v.size()));
    }
    theta = v;
  }
  if (const std::string bad = space.check(theta); !bad.empty()) raise(input_error_type, bad);
  model::RunResult r;
  {
    py::gil_scoped_release release;
    auto sim = c.config->simulator.make();
    r = sim->run(theta);
  }
  if (!r.status.ok()) {
    raise(run_failed_type, std::string(model::to_string(r.status.code)) + ": " + r.status.message);
  }
  py::dict out;
  out["times"] = r.trajectory.times;
  py::dict curves, units;
  for (size_t i = 0; i < r.trajectory.channels.size(); ++i) {
    const auto& ch = r.trajectory.channels[i];
    curves[py::str(ch.name)] = Eigen::VectorXd(r.trajectory.values.col(static_cast<Eigen::Index>(i)));
    units[py::str(ch.name)] = ch.unit;
  }
  out["curves"] = curves;
  out["units"] = units;
  out["period"] = r.info.period;
  out["theta"] = theta;
  // The heart indices when the channels allow them (observers/global_indices.h); none otherwise.
  py::dict indices, index_units;
  try {
    const observers::GlobalIndices gi({}, r.trajectory.channels);
    Eigen::VectorXd z(gi.size());
    if (gi.observe(r.trajectory, z).ok()) {
      const auto names = gi.outputs();
      for (size_t i = 0; i < names.size(); ++i) {
        indices[py::str(names[i].name)] = z(static_cast<Eigen::Index>(i));
        index_units[py::str(names[i].name)] = names[i].unit;
      }
    }
  } catch (const std::invalid_argument&) {
    // a model without a volume curve: no indices
  }
  out["indices"] = indices;
  out["index_units"] = index_units;
  return out;
}

// `sigmaheart ARGS...` in this process: (exit code, stdout, stderr).
py::tuple run_command(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  int code = 0;
  {
    py::gil_scoped_release release;
    code = app::run_cli(args, out, err, app::blackbox::cli_models());
  }
  return py::make_tuple(code, out.str(), err.str());
}

}  // namespace
}  // namespace sigmaheart::python

PYBIND11_MODULE(_core, m) {
  using namespace sigmaheart::python;
  m.doc() = "sigmaheart: cardiac model personalisation (C++ core); use the `sigmaheart` package";
  input_error_type = PyErr_NewException("sigmaheart.InputError", PyExc_ValueError, nullptr);
  run_failed_type = PyErr_NewException("sigmaheart.RunFailed", PyExc_RuntimeError, nullptr);
  m.attr("InputError") = py::reinterpret_borrow<py::object>(input_error_type);
  m.attr("RunFailed") = py::reinterpret_borrow<py::object>(run_failed_type);
  py::class_<LoadedConfig>(m, "Config")
      .def_property_readonly("name", &LoadedConfig::name)
      .def_property_readonly("model", &LoadedConfig::model)
      .def_property_readonly("parameters",
                             [](const LoadedConfig& c) { return parameter_table(c.config->simulator.parameters); })
      .def("run", &run_simulator, py::arg("theta") = py::none());
  m.def("load_config", &load, py::arg("path"), py::arg("overrides") = std::vector<std::string>{});
  m.def("run_command", &run_command, py::arg("args"));
}
