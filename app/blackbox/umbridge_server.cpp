// `sigmaheart serve`: one simulator exposed as a UM-Bridge model (umbridge.h, docs/architecture.md
// s.9). Connections and evaluations are limited separately: every connection gets its own worker
// thread (up to ServeOptions::connections), so an idle keep-alive connection never holds up a
// request on another one; evaluations run at most ServeOptions::threads at a time.
#include "app/blackbox/umbridge.h"

#include "app/blackbox/umbridge_wire.h"

#include <httplib.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace sigmaheart::app::blackbox {

using nlohmann::json;
using model::Status;
using model::StatusCode;

namespace {

// A counting semaphore for the evaluation slots (std::counting_semaphore needs a compile-time
// bound).
class Slots {
 public:
  explicit Slots(int n) : free_(n) {}
  void acquire() {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [this] { return free_ > 0; });
    --free_;
  }
  void release() {
    {
      std::lock_guard<std::mutex> lock(m_);
      ++free_;
    }
    cv_.notify_one();
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  int free_;
};

}  // namespace

struct UmbridgeServer::Impl {
  std::unique_ptr<model::Simulator> prototype;
  ServeOptions options;
  std::vector<int> channel_index;
  std::mutex pool_mutex;
  std::vector<std::unique_ptr<model::Simulator>> pool;  // idle clones
  std::unique_ptr<Slots> slots;
  std::atomic<long> evaluations{0};
  httplib::Server server;
  std::thread thread;
  bool bound = false;
  socket_t listen_socket = INVALID_SOCKET;  // the last socket httplib created for listening

  int input_size() const { return prototype->parameters().size(); }
  int output_size() const { return static_cast<int>(channel_index.size()) * options.frames; }

  std::unique_ptr<model::Simulator> acquire() {
    std::lock_guard<std::mutex> lock(pool_mutex);  // clone() reads the prototype
    if (pool.empty()) return prototype->clone();
    auto s = std::move(pool.back());
    pool.pop_back();
    return s;
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
    std::string problem;
    body = wire::parse_body(req.body, problem);
    if (!problem.empty()) {
      reply(res, 400, wire::error_body(wire::kInvalidInput, problem));
      return false;
    }
    if (!body.contains("name") || !body["name"].is_string()) {
      reply(res, 400, wire::error_body(wire::kInvalidInput, "the request names no model (\"name\": \"...\")"));
      return false;
    }
    if (body["name"].get<std::string>() != options.name) {
      reply(res, 400, wire::error_body(wire::kModelNotFound, "no model '" + body["name"].get<std::string>() +
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
      reply(res, 400, wire::error_body(wire::kInvalidInput, "expected \"input\": [[" + std::to_string(n) + " numbers]]"));
      return;
    }
    const json& in = body["input"][0];
    if (static_cast<int>(in.size()) != n) {
      reply(res, 400, wire::error_body(wire::kInvalidInput, "input vector 0 has " + std::to_string(in.size()) +
                                                               " entries; expected " + std::to_string(n)));
      return;
    }
    Eigen::VectorXd theta(n);
    for (int i = 0; i < n; ++i) {
      const json& v = in[static_cast<size_t>(i)];
      if (!v.is_number()) {
        reply(res, 400, wire::error_body(wire::kInvalidInput, "input entry " + std::to_string(i) + " (" +
                                                                 prototype->parameters()[i].name +
                                                                 ") is not a number: " + v.dump()));
        return;
      }
      theta(i) = v.get<double>();
    }
    ++evaluations;
    const std::string out_of_bounds = prototype->parameters().check(theta);
    if (!out_of_bounds.empty()) {
      reply(res, 400, wire::error_body(wire::kInvalidInput, out_of_bounds));
      return;
    }
    model::RunResult run;
    slots->acquire();
    {
      auto sim = acquire();
      try {
        run = sim->run(theta);
      } catch (const std::exception& e) {
        run.status = Status::Error(StatusCode::kInvalidArgument, std::string("exception: ") + e.what());
      }
      release(std::move(sim));
    }
    slots->release();
    if (!run.status.ok()) {
      reply(res, 500, wire::error_body(wire::kInvalidOutput, wire::status_message(run.status)));
      return;
    }
    Eigen::VectorXd z;
    try {
      z = sample_curves(run.trajectory, channel_index, options.frames);
    } catch (const std::exception& e) {
      reply(res, 500, wire::error_body(wire::kInvalidOutput,
                                       wire::status_message(Status::Error(StatusCode::kBadOutput, e.what()))));
      return;
    }
    // Output 1: the model's own times of those frames [s] (a studied period moves them).
    const Eigen::VectorXd times = sample_times(run.trajectory, options.frames);
    json out = json::array();
    out.push_back(std::vector<double>(z.data(), z.data() + z.size()));
    out.push_back(std::vector<double>(times.data(), times.data() + times.size()));
    reply(res, 200, json{{"output", out}});
  }
};

UmbridgeServer::UmbridgeServer(std::unique_ptr<model::Simulator> prototype, ServeOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (!prototype) throw std::invalid_argument("UmbridgeServer: no simulator");
  if (options.frames < 2) throw std::invalid_argument("UmbridgeServer: frames must be >= 2");
  if (options.threads < 1 || options.connections < options.threads) {
    throw std::invalid_argument("UmbridgeServer: expected 1 <= threads <= connections");
  }
  if (!(options.keep_alive > 0.0)) throw std::invalid_argument("UmbridgeServer: keep_alive must be > 0 s");
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
  m.slots = std::make_unique<Slots>(m.options.threads);
  const auto connections = static_cast<size_t>(m.options.connections);
  m.server.set_tcp_nodelay(true);
  // One worker per connection: an idle keep-alive connection holds a connection thread (for at
  // most keep_alive seconds), never an evaluation slot.
  m.server.new_task_queue = [connections] { return new httplib::ThreadPool(connections); };
  const double ka = m.options.keep_alive;
  m.server.set_keep_alive_timeout(static_cast<time_t>(std::max(1.0, ka)));
  m.server.set_read_timeout(static_cast<time_t>(ka), static_cast<time_t>((ka - std::floor(ka)) * 1e6));
  // An exclusive port: SO_REUSEADDR only (cpp-httplib's default adds SO_REUSEPORT, with which a
  // second server binds the same port and the kernel splits the connections between them).
  Impl* self = &m;
  m.server.set_socket_options([self](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    self->listen_socket = sock;
  });

  m.server.Get("/Info", [self](const httplib::Request&, httplib::Response& res) {
    Impl::reply(res, 200, json{{"protocolVersion", wire::kProtocolVersion}, {"models", {self->options.name}}});
  });
  m.server.Post("/InputSizes", [self](const httplib::Request& req, httplib::Response& res) {
    json body;
    if (self->parse_request(req, res, body)) Impl::reply(res, 200, json{{"inputSizes", {self->input_size()}}});
  });
  m.server.Post("/OutputSizes", [self](const httplib::Request& req, httplib::Response& res) {
    json body;
    if (self->parse_request(req, res, body)) {
      Impl::reply(res, 200, json{{"outputSizes", {self->output_size(), self->options.frames}}});
    }
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
      Impl::reply(res, 400, wire::error_body(wire::kUnsupportedFeature, name + " is not supported by this model"));
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
                             " (in use by another program, or not an address of this machine)");
  }
  // cpp-httplib listens with a backlog of 5: a sixth simultaneous connect lost its SYN and
  // waited for the 1 s retransmission (8 clients: 382 requests/s instead of thousands). Listening
  // again on the bound socket raises the backlog (Linux keeps the socket, changes the queue).
  if (impl_->listen_socket != INVALID_SOCKET) ::listen(impl_->listen_socket, 256);
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

}  // namespace sigmaheart::app::blackbox
