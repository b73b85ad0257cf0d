#include "app/blackbox/umbridge.h"

#include "app/blackbox/tables.h"
#include "app/io/display.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <optional>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace sigmaheart::app::blackbox {

using nlohmann::json;
using model::Status;
using model::StatusCode;

Eigen::VectorXd sample_curves(const model::Trajectory& trajectory, const std::vector<int>& channels,
                              int frames) {
  if (frames < 2) throw std::invalid_argument("sample_curves: frames must be >= 2");
  const int n = trajectory.samples();
  if (n < 1) throw std::invalid_argument("sample_curves: empty trajectory");
  const Eigen::VectorXd& t = trajectory.times;
  Eigen::VectorXd out(static_cast<Eigen::Index>(channels.size()) * frames);
  const double t0 = t(0), t1 = t(n - 1);
  for (size_t c = 0; c < channels.size(); ++c) {
    int seg = 0;
    for (int k = 0; k < frames; ++k) {
      const double tk = k == frames - 1 ? t1 : t0 + k * (t1 - t0) / (frames - 1);
      while (seg + 1 < n - 1 && t(seg + 1) < tk) ++seg;
      double v;
      if (n == 1) {
        v = trajectory.values(0, channels[c]);
      } else {
        const double a = trajectory.values(seg, channels[c]);
        const double b = trajectory.values(seg + 1, channels[c]);
        const double w = (tk - t(seg)) / (t(seg + 1) - t(seg));
        v = w <= 0.0 ? a : w >= 1.0 ? b : a + w * (b - a);
      }
      out(static_cast<Eigen::Index>(c) * frames + k) = v;
    }
  }
  return out;
}

namespace {

json error_body(const std::string& type, const std::string& message) {
  return json{{"error", {{"type", type}, {"message", message}}}};
}

std::optional<StatusCode> status_code_named(const std::string& name) {
  for (StatusCode c : {StatusCode::kDiverged, StatusCode::kNonFinite, StatusCode::kOutOfBounds,
                       StatusCode::kNotPeriodic, StatusCode::kProcessFailed, StatusCode::kTimeout,
                       StatusCode::kBadOutput, StatusCode::kInvalidArgument}) {
    if (name == model::to_string(c)) return c;
  }
  return std::nullopt;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
struct UmbridgeServer::Impl {
  std::unique_ptr<model::Simulator> prototype;
  ServeOptions options;
  std::vector<int> channel_index;
  std::mutex pool_mutex;
  std::vector<std::unique_ptr<model::Simulator>> pool;  // idle clones
  std::atomic<long> evaluations{0};
  httplib::Server server;
  std::thread thread;
  bool bound = false;

  int input_size() const { return prototype->parameters().size(); }
  int output_size() const { return static_cast<int>(channel_index.size()) * options.frames; }

  std::unique_ptr<model::Simulator> acquire() {
    {
      std::lock_guard<std::mutex> lock(pool_mutex);
      if (!pool.empty()) {
        auto s = std::move(pool.back());
        pool.pop_back();
        return s;
      }
    }
    std::lock_guard<std::mutex> lock(pool_mutex);  // clone() reads the prototype
    return prototype->clone();
  }
  void release(std::unique_ptr<model::Simulator> s) {
    std::lock_guard<std::mutex> lock(pool_mutex);
    pool.push_back(std::move(s));
  }

  static void reply(httplib::Response& res, int status, const json& body) {
    res.status = status;
    res.set_content(body.dump(), "application/json");
  }

  // The request body as JSON naming this model; false (and the error reply set) otherwise.
  bool parse_request(const httplib::Request& req, httplib::Response& res, json& body) const {
    body = json::parse(req.body, nullptr, false);
    if (body.is_discarded() || !body.is_object()) {
      reply(res, 400, error_body("InvalidInput", "the request body is not a JSON object"));
      return false;
    }
    if (!body.contains("name") || !body["name"].is_string()) {
      reply(res, 400, error_body("InvalidInput", "the request names no model (\"name\": \"...\")"));
      return false;
    }
    if (body["name"].get<std::string>() != options.name) {
      reply(res, 400, error_body("ModelNotFound", "no model '" + body["name"].get<std::string>() +
                                                      "' here; this server has '" + options.name + "'"));
      return false;
    }
    return true;
  }

  void evaluate(const httplib::Request& req, httplib::Response& res) {
    json body;
    if (!parse_request(req, res, body)) return;
    const int n = input_size();
    if (!body.contains("input") || !body["input"].is_array() || body["input"].size() != 1 ||
        !body["input"][0].is_array()) {
      reply(res, 400, error_body("InvalidInput", "expected \"input\": [[" + std::to_string(n) + " numbers]]"));
      return;
    }
    const json& in = body["input"][0];
    if (static_cast<int>(in.size()) != n) {
      reply(res, 400, error_body("InvalidInput", "input vector 0 has " + std::to_string(in.size()) +
                                                     " entries; expected " + std::to_string(n)));
      return;
    }
    Eigen::VectorXd theta(n);
    for (int i = 0; i < n; ++i) {
      if (!in[static_cast<size_t>(i)].is_number()) {
        reply(res, 400, error_body("InvalidInput", "input entry " + std::to_string(i) + " is not a number"));
        return;
      }
      theta(i) = in[static_cast<size_t>(i)].get<double>();
    }
    ++evaluations;
    const std::string out_of_bounds = prototype->parameters().check(theta);
    if (!out_of_bounds.empty()) {
      reply(res, 400, error_body("InvalidInput", out_of_bounds));
      return;
    }
    auto sim = acquire();
    model::RunResult run;
    try {
      run = sim->run(theta);
    } catch (const std::exception& e) {
      run.status = Status::Error(StatusCode::kInvalidArgument, std::string("exception: ") + e.what());
    }
    release(std::move(sim));
    if (!run.status.ok()) {
      reply(res, 500, error_body("ModelFailed", std::string(model::to_string(run.status.code)) + ": " +
                                                    run.status.message));
      return;
    }
    Eigen::VectorXd z;
    try {
      z = sample_curves(run.trajectory, channel_index, options.frames);
    } catch (const std::exception& e) {
      reply(res, 500, error_body("ModelFailed", std::string(model::to_string(StatusCode::kBadOutput)) +
                                                    ": " + e.what()));
      return;
    }
    json out = json::array();
    out.push_back(std::vector<double>(z.data(), z.data() + z.size()));
    reply(res, 200, json{{"output", out}});
  }
};

UmbridgeServer::UmbridgeServer(std::unique_ptr<model::Simulator> prototype, ServeOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (!prototype) throw std::invalid_argument("UmbridgeServer: no simulator");
  if (options.frames < 2) throw std::invalid_argument("UmbridgeServer: frames must be >= 2");
  const auto channels = prototype->channels();
  if (options.channels.empty()) {
    for (const auto& c : channels) options.channels.push_back(c.name);
  }
  for (const auto& name : options.channels) {
    int found = -1;
    std::vector<std::string> names;
    for (size_t c = 0; c < channels.size(); ++c) {
      names.push_back(channels[c].name);
      if (channels[c].name == name) found = static_cast<int>(c);
    }
    if (found < 0) {
      std::string msg = "unknown channel '" + name + "' of model " + prototype->name();
      const std::string close = model::closest_match(name, names);
      if (!close.empty()) msg += " (did you mean '" + close + "'?)";
      throw std::invalid_argument(msg);
    }
    m.channel_index.push_back(found);
  }
  m.prototype = std::move(prototype);
  m.options = std::move(options);
  const int threads = std::max(1, m.options.threads);
  m.server.set_tcp_nodelay(true);
  m.server.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<size_t>(threads)); };

  Impl* self = &m;
  m.server.Get("/Info", [self](const httplib::Request&, httplib::Response& res) {
    Impl::reply(res, 200, json{{"protocolVersion", 1.0}, {"models", {self->options.name}}});
  });
  m.server.Post("/InputSizes", [self](const httplib::Request& req, httplib::Response& res) {
    json body;
    if (self->parse_request(req, res, body)) Impl::reply(res, 200, json{{"inputSizes", {self->input_size()}}});
  });
  m.server.Post("/OutputSizes", [self](const httplib::Request& req, httplib::Response& res) {
    json body;
    if (self->parse_request(req, res, body)) Impl::reply(res, 200, json{{"outputSizes", {self->output_size()}}});
  });
  m.server.Post("/ModelInfo", [self](const httplib::Request& req, httplib::Response& res) {
    json body;
    if (!self->parse_request(req, res, body)) return;
    Impl::reply(res, 200, json{{"support", {{"Evaluate", true}, {"Gradient", false},
                                            {"ApplyJacobian", false}, {"ApplyHessian", false}}}});
  });
  m.server.Post("/Evaluate", [self](const httplib::Request& req, httplib::Response& res) {
    self->evaluate(req, res);
  });
  for (const char* feature : {"/Gradient", "/ApplyJacobian", "/ApplyHessian"}) {
    const std::string name = feature + 1;
    m.server.Post(feature, [self, name](const httplib::Request& req, httplib::Response& res) {
      json body;
      if (!self->parse_request(req, res, body)) return;
      Impl::reply(res, 400, error_body("UnsupportedFeature", name + " is not supported by this model"));
    });
  }
}

UmbridgeServer::~UmbridgeServer() { stop(); }

int UmbridgeServer::bind(const std::string& host, int port) {
  int bound = -1;
  if (port == 0) {
    bound = impl_->server.bind_to_any_port(host);
  } else if (impl_->server.bind_to_port(host, port)) {
    bound = port;
  }
  if (bound <= 0) {
    throw std::runtime_error("cannot listen on " + host + ":" + std::to_string(port) +
                             " (in use, or not an address of this machine)");
  }
  impl_->bound = true;
  return bound;
}

void UmbridgeServer::start() {
  if (!impl_->bound) throw std::logic_error("UmbridgeServer::start before bind");
  impl_->thread = std::thread([this] { impl_->server.listen_after_bind(); });
  // Back once the server accepts connections (httplib 0.11 has no wait_until_ready()).
  for (int i = 0; i < 5000 && !impl_->server.is_running(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void UmbridgeServer::stop() {
  if (!impl_) return;
  if (impl_->thread.joinable()) {
    impl_->server.stop();
    impl_->thread.join();
  }
}

int UmbridgeServer::input_size() const { return impl_->input_size(); }
int UmbridgeServer::output_size() const { return impl_->output_size(); }
long UmbridgeServer::evaluations() const { return impl_->evaluations.load(); }

// ---------------------------------------------------------------------------------------------
namespace {

struct ClientOptions {
  std::string url;
  std::string name;
  double timeout = 60.0;  // [s]
  int frames = 50;
  double period = 1.0;    // [s]
  std::vector<model::Channel> channels;
};

// Splits "http://host:port" for httplib (which takes scheme://host:port itself).
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
    model::RunResult result;
    const std::string bad = parameters_.check(theta);
    if (!bad.empty()) {
      result.status = Status::Error(StatusCode::kOutOfBounds, bad);
      return result;
    }
    const ClientOptions& o = *options_;
    json request{{"name", o.name},
                 {"input", json::array({std::vector<double>(theta.data(), theta.data() + theta.size())})},
                 {"config", json::object()}};
    const std::string where = "UM-Bridge model '" + o.name + "' at " + o.url;
    auto res = client_->Post("/Evaluate", request.dump(), "application/json");
    if (!res) {
      const auto err = res.error();
      const StatusCode code = err == httplib::Error::Read || err == httplib::Error::Write
                                  ? StatusCode::kTimeout
                                  : StatusCode::kProcessFailed;
      result.status = Status::Error(code, where + ": no reply (" + httplib::to_string(err) +
                                              (code == StatusCode::kTimeout
                                                   ? ", time limit " + io::format_number(o.timeout) + " s)"
                                                   : ")"));
      client_ = make_client(o);  // a fresh connection for the next run
      return result;
    }
    const json body = json::parse(res->body, nullptr, false);
    if (body.is_discarded() || !body.is_object()) {
      result.status = Status::Error(StatusCode::kBadOutput, where + ": HTTP " + std::to_string(res->status) +
                                                                ", the reply is not JSON");
      return result;
    }
    if (body.contains("error")) {
      const json& e = body["error"];
      const std::string type = e.value("type", std::string("?"));
      const std::string message = e.value("message", std::string());
      StatusCode code = StatusCode::kProcessFailed;
      std::string text = message;
      if (type == "ModelFailed") {
        const auto colon = message.find(": ");
        if (colon != std::string::npos) {
          if (const auto c = status_code_named(message.substr(0, colon))) {
            code = *c;
            text = message.substr(colon + 2);
          }
        }
      }
      result.status = Status::Error(code, where + ": " + type + ": " + text);
      return result;
    }
    const int m = static_cast<int>(o.channels.size()) * o.frames;
    if (!body.contains("output") || !body["output"].is_array() || body["output"].empty() ||
        !body["output"][0].is_array() || static_cast<int>(body["output"][0].size()) != m) {
      result.status = Status::Error(StatusCode::kBadOutput,
                                    where + ": expected \"output\": [[" + std::to_string(m) + " numbers]]");
      return result;
    }
    const json& out = body["output"][0];
    model::Trajectory& t = result.trajectory;
    t.channels = o.channels;
    t.times.resize(o.frames);
    t.values.resize(o.frames, static_cast<Eigen::Index>(o.channels.size()));
    for (int k = 0; k < o.frames; ++k) t.times(k) = k == o.frames - 1 ? o.period : k * o.period / (o.frames - 1);
    for (size_t c = 0; c < o.channels.size(); ++c) {
      for (int k = 0; k < o.frames; ++k) {
        const json& v = out[c * static_cast<size_t>(o.frames) + static_cast<size_t>(k)];
        const double x = v.is_number() ? v.get<double>() : std::nan("");
        if (!std::isfinite(x)) {
          result.status = Status::Error(StatusCode::kBadOutput,
                                        where + ": output entry " + std::to_string(c * static_cast<size_t>(o.frames) + static_cast<size_t>(k)) +
                                            " (" + o.channels[c].name + ") is not a finite number");
          return result;
        }
        t.values(k, static_cast<Eigen::Index>(c)) = x;
      }
    }
    result.info.period = o.period;
    return result;
  }

 private:
  std::shared_ptr<const ClientOptions> options_;
  model::ParameterSpace parameters_;
  std::unique_ptr<httplib::Client> client_;
};

// POSTs {"name": name, "config": {}} to `path` and returns the JSON reply; fails at `key`.
json ask(httplib::Client& client, const model::OptionReader& numerics, const ClientOptions& o,
         const std::string& path) {
  const json request{{"name", o.name}, {"config", json::object()}};
  auto res = client.Post(path, request.dump(), "application/json");
  if (!res) {
    numerics.fail("url", "no UM-Bridge server answers at " + o.url + path + " (" + httplib::to_string(res.error()) + ")");
  }
  const json body = json::parse(res->body, nullptr, false);
  if (body.is_discarded() || !body.is_object()) {
    numerics.fail("url", o.url + path + " replied HTTP " + std::to_string(res->status) + " without JSON");
  }
  if (body.contains("error")) {
    const json& e = body["error"];
    numerics.fail(e.value("type", std::string()) == "ModelNotFound" ? "name" : "url",
                  o.url + path + ": " + e.value("type", std::string("error")) + ": " +
                      e.value("message", std::string()));
  }
  return body;
}

int single_size(const json& body, const std::string& key) {
  if (!body.contains(key) || !body[key].is_array() || body[key].size() != 1) return -1;
  const json& v = body[key][0];
  if (v.is_number_integer()) return v.get<int>();
  if (v.is_array() && v.size() == 1 && v[0].is_number_integer()) return v[0].get<int>();  // [[n]]
  return -1;
}

}  // namespace

model::ModelBuild configure_umbridge(const model::OptionReader& numerics) {
  if (!numerics.defined() || !numerics.is_map()) {
    numerics.fail("", "model umbridge needs a numerics: section with url, name, parameters and channels "
                      "(docs/architecture.md s.9)");
  }
  numerics.check_keys({"url", "name", "timeout", "frames", "period", "parameters", "channels"});
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
  o->frames = numerics.integer("frames", o->frames);
  if (o->frames < 2) numerics.fail("frames", "expected frames >= 2");
  o->period = numerics.quantity("period", "s", o->period);
  if (!(o->period > 0.0)) numerics.fail("period", "expected a period > 0 s");
  model::ParameterSpace parameters = read_parameter_table(numerics);
  o->channels = read_channel_table(numerics);

  // Before any work: the server answers and its sizes match the tables.
  ClientOptions probe = *o;
  probe.timeout = std::min(o->timeout, 10.0);
  auto client = make_client(probe);
  auto info = client->Get("/Info");
  if (!info) {
    numerics.fail("url", "no UM-Bridge server answers at " + o->url + " (" + httplib::to_string(info.error()) +
                             "); start it first, e.g. `sigmaheart serve CONFIG --port 4242`");
  }
  const json info_body = json::parse(info->body, nullptr, false);
  if (info_body.is_discarded() || !info_body.contains("models") || !info_body["models"].is_array()) {
    numerics.fail("url", o->url + "/Info did not reply with a UM-Bridge model list");
  }
  std::vector<std::string> models;
  for (const auto& m : info_body["models"]) {
    if (m.is_string()) models.push_back(m.get<std::string>());
  }
  if (std::find(models.begin(), models.end(), o->name) == models.end()) {
    std::string list;
    for (const auto& m : models) list += (list.empty() ? "" : ", ") + m;
    numerics.fail("name", "the server at " + o->url + " has no model '" + o->name + "' (it has: " + list + ")");
  }
  const json support = ask(*client, numerics, *o, "/ModelInfo");
  if (!support.contains("support") || !support["support"].value("Evaluate", false)) {
    numerics.fail("name", "model '" + o->name + "' at " + o->url + " does not support Evaluate");
  }
  const int n = single_size(ask(*client, numerics, *o, "/InputSizes"), "inputSizes");
  if (n != parameters.size()) {
    numerics.fail("parameters", "the server's model '" + o->name + "' takes " +
                                    (n < 0 ? std::string("not exactly one input vector") : std::to_string(n) + " inputs") +
                                    "; the parameter table has " + std::to_string(parameters.size()));
  }
  const int m = single_size(ask(*client, numerics, *o, "/OutputSizes"), "outputSizes");
  const int expected = static_cast<int>(o->channels.size()) * o->frames;
  if (m != expected) {
    numerics.fail("channels", "the server's model '" + o->name + "' returns " +
                                  (m < 0 ? std::string("not exactly one output vector") : std::to_string(m) + " outputs") +
                                  "; channels x frames = " + std::to_string(o->channels.size()) + " x " +
                                  std::to_string(o->frames) + " = " + std::to_string(expected));
  }
  std::shared_ptr<const ClientOptions> shared = o;
  return model::ModelBuild(std::move(parameters), [shared](const model::ParameterSpace& p) {
    return std::make_unique<UmbridgeSimulator>(shared, p);
  });
}

}  // namespace sigmaheart::app::blackbox
