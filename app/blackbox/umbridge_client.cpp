// `model: umbridge`: a model on a UM-Bridge server as a Simulator (umbridge.h, docs/architecture.md
// s.9). Every number crosses in its declared unit: the inputs leave as theta_i / factor_i, the
// outputs come back multiplied by their factor; a curve's time axis is the model's own (the times
// the server returns, or the period taken from theta when it is a parameter).
#include "app/blackbox/tables.h"
#include "app/blackbox/umbridge.h"
#include "app/blackbox/umbridge_wire.h"
#include "app/io/display.h"
#include "model/units.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace sigmaheart::app::blackbox {

using nlohmann::json;
using model::Status;
using model::StatusCode;

namespace {

// One output vector of a generic model: `size` values in `unit`.
struct OutputVector {
  std::string name;
  DeclaredUnit unit;
  int size = 1;
};

struct ClientOptions {
  std::string url;
  std::string name;
  double timeout = 60.0;  // [s]
  json config = json::object();
  // Inputs: the input vector of each parameter, and the vectors' sizes.
  std::vector<int> input_of;
  std::vector<int> input_sizes;
  Eigen::VectorXd parameter_factors;  // theta_SI = factor * sent value
  // Outputs, either curves (output 0 holds channels x frames) or generic vectors (one sample).
  bool curves = true;
  int frames = 50;
  PeriodSource period;
  bool returned_times = false;  // output 1 holds the frames' times
  double time_factor = 1.0;     // of the returned times, to s
  std::vector<model::Channel> channels;  // SI; generic: one per element ("T[0]", "T[1]", ...)
  Eigen::VectorXd channel_factors;       // per channel (curves) or per element (generic)
  std::vector<OutputVector> outputs;     // generic only
  std::vector<int> output_sizes() const {
    if (!curves) {
      std::vector<int> s;
      for (const auto& o : outputs) s.push_back(o.size);
      return s;
    }
    std::vector<int> s = {static_cast<int>(channels.size()) * frames};
    if (returned_times) s.push_back(frames);
    return s;
  }
};

std::unique_ptr<httplib::Client> make_client(const ClientOptions& o) {
  auto c = std::make_unique<httplib::Client>(o.url);
  const auto secs = static_cast<time_t>(o.timeout);
  const auto usecs = static_cast<time_t>((o.timeout - static_cast<double>(secs)) * 1e6);
  c->set_connection_timeout(std::min<time_t>(secs, 10), secs < 10 ? usecs : 0);
  c->set_read_timeout(secs, usecs);
  c->set_write_timeout(secs, usecs);
  c->set_keep_alive(true);
  // Without TCP_NODELAY a small request waits for the delayed ACK (about 40 ms per Evaluate).
  c->set_tcp_nodelay(true);
  return c;
}

// A reply's error as a Status: our server's InvalidOutput "<code>: <message>" gives that code.
Status error_status(const json& e, const std::string& where) {
  const std::string type = e.value("type", std::string("?"));
  const std::string message = e.value("message", std::string());
  std::string text = message;
  StatusCode code = type == wire::kInvalidOutput ? StatusCode::kBadOutput : StatusCode::kProcessFailed;
  if (type == wire::kInvalidOutput) {
    if (const auto c = wire::parse_status_message(message, text)) code = *c;
  }
  if (type == wire::kInvalidInput) code = StatusCode::kInvalidArgument;
  return Status::Error(code, where + ": " + type + ": " + text);
}

class UmbridgeSimulator final : public model::Simulator {
 public:
  UmbridgeSimulator(std::shared_ptr<const ClientOptions> o, model::ParameterSpace p)
      : options_(std::move(o)), parameters_(std::move(p)), client_(make_client(*options_)) {}

  std::string name() const override { return "umbridge"; }
  const model::ParameterSpace& parameters() const override { return parameters_; }
  std::vector<model::Channel> channels() const override { return options_->channels; }
  std::unique_ptr<model::Simulator> clone() const override {
    return std::make_unique<UmbridgeSimulator>(options_, parameters_);
  }

  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override {
    if (auto refused = refuse_out_of_bounds(parameters_, theta)) return *refused;
    model::RunResult result;
    const ClientOptions& o = *options_;
    json input = json::array();
    for (size_t v = 0; v < o.input_sizes.size(); ++v) input.push_back(json::array());
    for (Eigen::Index i = 0; i < theta.size(); ++i) {
      input[static_cast<size_t>(o.input_of[static_cast<size_t>(i)])].push_back(theta(i) / o.parameter_factors(i));
    }
    const json request{{"name", o.name}, {"input", input}, {"config", o.config}};
    const std::string where = "UM-Bridge model '" + o.name + "' at " + o.url;
    auto res = client_->Post("/Evaluate", request.dump(), "application/json");
    if (!res) {
      const auto err = res.error();
      const bool timeout = err == httplib::Error::Read || err == httplib::Error::Write;
      result.status = Status::Error(timeout ? StatusCode::kTimeout : StatusCode::kProcessFailed,
                                    where + ": no reply (" + httplib::to_string(err) +
                                        (timeout ? ", time limit " + io::format_number(o.timeout) + " s)" : ")"));
      client_ = make_client(o);  // a fresh connection for the next run
      return result;
    }
    std::string problem;
    const json body = wire::parse_body(res->body, problem);
    if (!problem.empty()) {
      result.status = Status::Error(StatusCode::kBadOutput, where + ": HTTP " + std::to_string(res->status) + ", " + problem);
      return result;
    }
    if (body.contains("error") && body["error"].is_object()) {
      result.status = error_status(body["error"], where);
      return result;
    }
    result.status = read_outputs(body, theta, where, result);
    return result;
  }

 private:
  // The output vectors, checked (count, sizes, finite numbers), converted to SI.
  Status read_outputs(const json& body, const Eigen::Ref<const Eigen::VectorXd>& theta, const std::string& where,
                      model::RunResult& result) const {
    const ClientOptions& o = *options_;
    const std::vector<int> sizes = o.output_sizes();
    if (!body.contains("output") || !body["output"].is_array() || body["output"].size() < sizes.size()) {
      return Status::Error(StatusCode::kBadOutput, where + ": expected \"output\" with " +
                                                       std::to_string(sizes.size()) + " vectors");
    }
    std::vector<Eigen::VectorXd> out;
    for (size_t v = 0; v < sizes.size(); ++v) {
      const json& vec = body["output"][v];
      if (!vec.is_array() || static_cast<int>(vec.size()) != sizes[v]) {
        return Status::Error(StatusCode::kBadOutput, where + ": output vector " + std::to_string(v) +
                                                         " should have " + std::to_string(sizes[v]) + " numbers");
      }
      Eigen::VectorXd x(sizes[v]);
      for (int k = 0; k < sizes[v]; ++k) {
        const json& e = vec[static_cast<size_t>(k)];
        x(k) = e.is_number() ? e.get<double>() : std::nan("");
        if (!std::isfinite(x(k))) {
          return Status::Error(StatusCode::kBadOutput, where + ": output vector " + std::to_string(v) + " entry " +
                                                           std::to_string(k) + " is not a finite number");
        }
      }
      out.push_back(std::move(x));
    }
    model::Trajectory& t = result.trajectory;
    t.channels = o.channels;
    const auto nc = static_cast<Eigen::Index>(o.channels.size());
    if (!o.curves) {  // one sample at t = 0: the elements of every output vector
      t.times = Eigen::VectorXd::Zero(1);
      t.values.resize(1, nc);
      Eigen::Index c = 0;
      for (const auto& x : out) {
        for (Eigen::Index k = 0; k < x.size(); ++k, ++c) t.values(0, c) = x(k) * o.channel_factors(c);
      }
      return Status::Ok();
    }
    t.values.resize(o.frames, nc);
    for (Eigen::Index c = 0; c < nc; ++c) {
      t.values.col(c) = out[0].segment(c * o.frames, o.frames) * o.channel_factors(c);
    }
    if (o.returned_times) {
      t.times = out[1] * o.time_factor;
      for (int k = 1; k < o.frames; ++k) {
        if (!(t.times(k) > t.times(k - 1))) {
          return Status::Error(StatusCode::kBadOutput, where + ": the returned times do not increase at frame " +
                                                           std::to_string(k));
        }
      }
      result.info.period = t.times(o.frames - 1) - t.times(0);
      return Status::Ok();
    }
    const double period = o.period.of(theta);  // the model's own when it is a parameter
    t.times.resize(o.frames);
    for (int k = 0; k < o.frames; ++k) t.times(k) = k == o.frames - 1 ? period : k * period / (o.frames - 1);
    result.info.period = period;
    return Status::Ok();
  }

  std::shared_ptr<const ClientOptions> options_;
  model::ParameterSpace parameters_;
  std::unique_ptr<httplib::Client> client_;
};

// POSTs {"name", "config"} to `path` and returns the JSON reply; fails at `key`.
json ask(httplib::Client& client, const model::OptionReader& numerics, const ClientOptions& o,
         const std::string& path) {
  const json request{{"name", o.name}, {"config", o.config}};
  auto res = client.Post(path, request.dump(), "application/json");
  if (!res) {
    numerics.fail("url", "no UM-Bridge server answers at " + o.url + path + " (" + httplib::to_string(res.error()) + ")");
  }
  std::string problem;
  const json body = wire::parse_body(res->body, problem);
  if (!problem.empty()) numerics.fail("url", o.url + path + " replied HTTP " + std::to_string(res->status) + ": " + problem);
  if (body.contains("error")) {
    const json& e = body["error"];
    numerics.fail(e.value("type", std::string()) == wire::kModelNotFound ? "name" : "url",
                  o.url + path + ": " + e.value("type", std::string("error")) + ": " +
                      e.value("message", std::string()));
  }
  return body;
}

// inputSizes / outputSizes: one integer per vector ([[n]] is read as [n], as older servers wrote).
std::vector<int> sizes(const json& body, const std::string& key) {
  std::vector<int> out;
  if (!body.contains(key) || !body[key].is_array()) return out;
  for (const json& v : body[key]) {
    if (v.is_number_integer()) {
      out.push_back(v.get<int>());
    } else if (v.is_array() && v.size() == 1 && v[0].is_number_integer()) {
      out.push_back(v[0].get<int>());
    } else {
      return {};
    }
  }
  return out;
}

std::string list_text(const std::vector<int>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}

// `outputs:` of a generic model: [{name, unit, size}], one per output vector.
void read_output_vectors(const model::OptionReader& numerics, ClientOptions& o) {
  const int n = numerics.list_size("outputs");
  if (n == 0) numerics.fail("outputs", "expected a list of output vectors ({name, unit, size})");
  std::set<std::string> seen;
  std::vector<double> factors;
  for (int i = 0; i < n; ++i) {
    const auto item = numerics.item("outputs", i);
    if (!item->is_map()) item->fail("", "expected a map {name, unit, size}");
    item->check_keys({"name", "unit", "size", "doc"});
    OutputVector v;
    v.name = item->text("name", "");
    if (v.name.empty() || !seen.insert(v.name).second) item->fail("name", "expected a unique output name");
    if (!item->has("unit")) item->fail("unit", "missing required key 'unit' (e.g. \"1\", mL, mmHg)");
    const std::string unit = item->text("unit", "");
    const auto si = model::units::to_si(unit);
    if (!si) item->fail("unit", "unknown unit '" + unit + "': expected a unit of model/units.h (\"1\", mL, mmHg, s, ...)");
    v.unit = {unit, si->factor};
    v.size = item->integer("size", 1);
    if (v.size < 1) item->fail("size", "expected size >= 1");
    const std::string doc = item->text("doc", "output of the UM-Bridge model");
    for (int k = 0; k < v.size; ++k) {
      o.channels.push_back({v.size == 1 ? v.name : v.name + "[" + std::to_string(k) + "]", si->si_unit, doc, "", 0});
      factors.push_back(si->factor);
    }
    o.outputs.push_back(v);
  }
  o.channel_factors = Eigen::Map<const Eigen::VectorXd>(factors.data(), static_cast<Eigen::Index>(factors.size()));
}

// The curve form: channels at `frames` times, from a period or returned times.
void read_curve_outputs(const model::OptionReader& numerics, const model::ParameterSpace& parameters,
                        ClientOptions& o) {
  o.frames = numerics.integer("frames", o.frames);
  if (o.frames < 2) numerics.fail("frames", "expected frames >= 2");
  o.channels = read_channel_table(numerics);
  o.channel_factors = unit_factors(declared_units(numerics, "channels"));
  if (numerics.has("times")) {
    if (numerics.choice("times", {"returned"}) == "returned") o.returned_times = true;
    if (numerics.has("period")) numerics.fail("period", "give either `times: returned` or `period:`, not both");
    const std::string unit = numerics.text("time_unit", "s");
    const auto si = model::units::to_si(unit);
    if (!si || si->si_unit != "s") numerics.fail("time_unit", "expected a time unit (s, ms), got '" + unit + "'");
    o.time_factor = si->factor;
    return;
  }
  if (numerics.has("time_unit")) numerics.fail("time_unit", "time_unit is the unit of `times: returned`");
  o.period = read_period(numerics, parameters, true);
}

// Before any work: the server answers the protocol we speak, has the model, and its sizes match.
void check_server(const model::OptionReader& numerics, const ClientOptions& o) {
  ClientOptions probe = o;
  probe.timeout = std::min(o.timeout, 10.0);
  auto client = make_client(probe);
  auto info = client->Get("/Info");
  if (!info) {
    numerics.fail("url", "no UM-Bridge server answers at " + o.url + " (" + httplib::to_string(info.error()) +
                             "); start it first, e.g. `sigmaheart serve CONFIG --port 4242`");
  }
  std::string problem;
  const json info_body = wire::parse_body(info->body, problem);
  if (!problem.empty() || !info_body.contains("models") || !info_body["models"].is_array()) {
    numerics.fail("url", o.url + "/Info did not reply with a UM-Bridge model list");
  }
  if (!info_body.contains("protocolVersion") || !info_body["protocolVersion"].is_number() ||
      info_body["protocolVersion"].get<double>() != wire::kProtocolVersion) {
    numerics.fail("url", o.url + " speaks UM-Bridge protocol version " +
                             (info_body.contains("protocolVersion") ? info_body["protocolVersion"].dump() : "(none)") +
                             "; this client speaks " + io::format_number(wire::kProtocolVersion));
  }
  std::vector<std::string> models;
  for (const auto& m : info_body["models"]) {
    if (m.is_string()) models.push_back(m.get<std::string>());
  }
  if (std::find(models.begin(), models.end(), o.name) == models.end()) {
    std::string list;
    for (const auto& m : models) list += (list.empty() ? "" : ", ") + m;
    numerics.fail("name", "the server at " + o.url + " has no model '" + o.name + "' (it has: " + list + ")");
  }
  const json support = ask(*client, numerics, o, "/ModelInfo");
  if (!support.contains("support") || !support["support"].value("Evaluate", false)) {
    numerics.fail("name", "model '" + o.name + "' at " + o.url + " does not support Evaluate");
  }
  const std::vector<int> in = sizes(ask(*client, numerics, o, "/InputSizes"), "inputSizes");
  if (in != o.input_sizes) {
    numerics.fail("parameters", "the server's model '" + o.name + "' takes input vectors of sizes " + list_text(in) +
                                    "; the parameter table gives " + list_text(o.input_sizes) +
                                    (o.input_sizes.size() == 1 && in.size() == 1
                                         ? " (it takes " + std::to_string(in[0]) + " inputs; the parameter table has " +
                                               std::to_string(o.input_sizes[0]) + ")"
                                         : std::string(" (`input:` of each parameter picks its vector)")));
  }
  const std::vector<int> out = sizes(ask(*client, numerics, o, "/OutputSizes"), "outputSizes");
  const std::vector<int> want = o.output_sizes();
  // The declared vectors must be the server's first ones; further vectors are not read.
  if (out.size() < want.size() || !std::equal(want.begin(), want.end(), out.begin())) {
    std::string how = o.curves ? "channels x frames = " + std::to_string(o.channels.size()) + " x " +
                                     std::to_string(o.frames) + " = " + std::to_string(want[0]) +
                                     (o.returned_times ? ", then the " + std::to_string(o.frames) + " times" : "")
                               : "the outputs: table gives " + list_text(want);
    numerics.fail(o.curves ? "channels" : "outputs",
                  "the server's model '" + o.name + "' returns output vectors of sizes " + list_text(out) + "; " + how);
  }
}

}  // namespace

model::ModelBuild configure_umbridge(const model::OptionReader& numerics) {
  if (!numerics.defined() || !numerics.is_map()) {
    numerics.fail("", "model umbridge needs a numerics: section with url, name, parameters and channels "
                      "or outputs (docs/architecture.md s.9)");
  }
  numerics.check_keys({"url", "name", "timeout", "config", "frames", "period", "times", "time_unit",
                       "parameters", "channels", "outputs"});
  auto o = std::make_shared<ClientOptions>();
  if (!numerics.has("url")) numerics.fail("url", "missing required key 'url' (e.g. http://localhost:4242)");
  o->url = numerics.text("url", "");
  if (o->url.rfind("http://", 0) != 0) {
    numerics.fail("url", "expected an http:// address (e.g. http://localhost:4242), got '" + o->url + "'");
  }
  while (!o->url.empty() && o->url.back() == '/') o->url.pop_back();
  o->name = numerics.text("name", "forward");
  o->timeout = numerics.quantity("timeout", "s", o->timeout);
  if (!(o->timeout > 0.0)) numerics.fail("timeout", "expected a time limit > 0 s");
  o->config = json::parse(numerics.json_text("config"));
  if (!o->config.is_object()) numerics.fail("config", "expected a map (the model's own configuration, sent as is)");
  model::ParameterSpace parameters = read_parameter_table(numerics, "parameters", true);
  o->parameter_factors = unit_factors(declared_units(numerics, "parameters"));
  o->input_of = input_vectors(numerics);
  for (int v : o->input_of) {
    if (v >= static_cast<int>(o->input_sizes.size())) o->input_sizes.resize(static_cast<size_t>(v) + 1, 0);
    ++o->input_sizes[static_cast<size_t>(v)];
  }
  for (size_t v = 0; v < o->input_sizes.size(); ++v) {
    if (o->input_sizes[v] == 0) numerics.fail("parameters", "no parameter goes to input vector " + std::to_string(v));
  }
  o->curves = !numerics.has("outputs");
  if (!numerics.has("outputs") && !numerics.has("channels")) {
    numerics.fail("", "missing required key 'channels' or 'outputs' (curves: channels x frames in output "
                      "vector 0; or output vectors of single values)");
  }
  if (numerics.has("outputs") && numerics.has("channels")) {
    numerics.fail("channels", "give either `channels:` (curves) or `outputs:` (output vectors of single "
                              "values), not both");
  }
  if (o->curves) {
    read_curve_outputs(numerics, parameters, *o);
  } else {
    for (const char* curve_only : {"frames", "period", "times", "time_unit"}) {
      if (numerics.has(curve_only)) numerics.fail(curve_only, std::string("'") + curve_only + "' belongs to `channels:` (curves)");
    }
    read_output_vectors(numerics, *o);
  }
  check_server(numerics, *o);
  std::shared_ptr<const ClientOptions> shared = o;
  return model::ModelBuild(std::move(parameters), [shared](const model::ParameterSpace& p) {
    return std::make_unique<UmbridgeSimulator>(shared, p);
  });
}

}  // namespace sigmaheart::app::blackbox
