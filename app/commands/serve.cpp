// `sigmaheart serve CONFIG [--port 4242] [--host 127.0.0.1]`: the config's simulator (any
// registered model) as a UM-Bridge model (app/blackbox/umbridge.h, docs/architecture.md s.9).
// Its input is the full parameter vector in SI, in the order `sigmaheart params CONFIG` prints;
// its outputs are the curves (each channel at --frames evenly spaced times of the run) and those
// times. At most --threads evaluations run at once, each on its own clone of the simulator; up to
// --connections connections are served at once on their own threads (an idle keep-alive
// connection is closed after --keep-alive seconds). The port is exclusive: a port in use is exit 2
// with the reason. Runs until SIGINT or SIGTERM, then lets running requests finish and exits 0.
#include "app/blackbox/umbridge.h"
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <memory>
#include <sstream>
#include <thread>

namespace sigmaheart::app {

namespace {

volatile std::sig_atomic_t stop_requested = 0;

extern "C" void request_stop(int) { stop_requested = 1; }

struct ServeCommandOptions {
  std::filesystem::path config;
  std::vector<std::string> overrides;
  std::string host = "127.0.0.1";
  int port = 4242;
  std::string name = "forward";
  int frames = 50;
  std::vector<std::string> channels;
  int threads = 2;
  int connections = 64;
  double keep_alive = 5.0;
};

int run_serve(const ServeCommandOptions& o, CommandContext& ctx) {
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  if (!ctx.root()) return kExitOk;  // one server per machine: only rank 0 serves
  blackbox::ServeOptions serve;
  serve.name = o.name;
  serve.frames = o.frames;
  serve.channels = o.channels;
  serve.threads = o.threads;
  serve.connections = std::max(o.connections, o.threads);
  serve.keep_alive = o.keep_alive;
  std::unique_ptr<blackbox::UmbridgeServer> server;
  try {
    server = std::make_unique<blackbox::UmbridgeServer>(config.simulator.make(), serve);
  } catch (const std::invalid_argument& e) {
    throw InputError(Location{"--channels", 0, 0}, e.what());
  }
  int port = 0;
  try {
    port = server->bind(o.host, o.port);
  } catch (const std::runtime_error& e) {
    throw InputError(Location{"--port", 0, 0}, e.what());
  }
  stop_requested = 0;
  struct sigaction action {}, old_int {}, old_term {};
  action.sa_handler = request_stop;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, &old_int);
  ::sigaction(SIGTERM, &action, &old_term);
  server->start();
  ctx.out << "serving UM-Bridge model '" << o.name << "' (" << config.simulator.model << ", "
          << server->input_size() << " inputs: the parameters in SI; outputs: " << server->output_size()
          << " = " << (o.channels.empty() ? std::string("all channels") : std::to_string(o.channels.size()) + " channels")
          << " x " << o.frames << " frames, then their " << o.frames << " times [s]) at http://" << o.host << ":" << port
          << "; stop with Ctrl-C\n"
          << std::flush;
  while (!stop_requested) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  server->stop();
  ::sigaction(SIGINT, &old_int, nullptr);
  ::sigaction(SIGTERM, &old_term, nullptr);
  ctx.out << "stopped after " << server->evaluations() << " evaluations\n" << std::flush;
  return kExitOk;
}

}  // namespace

void register_serve(CLI::App& app, CommandContext& ctx) {
  auto [sub, opts] = add_config_command(app, ctx, "serve",
                                        "Serve the config's simulator as a UM-Bridge model (HTTP/JSON) until Ctrl-C",
                                        run_serve);
  sub->add_option("--host", opts->host, "Address to listen on")->capture_default_str();
  sub->add_option("--port", opts->port, "TCP port (0: any free port, printed)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  sub->add_option("--name", opts->name, "UM-Bridge model name")->capture_default_str();
  sub->add_option("--frames", opts->frames, "Samples per channel in the output vector")
      ->check(CLI::Range(2, 100000))
      ->capture_default_str();
  sub->add_option("--channels", opts->channels, "Channels in the output (default: all), e.g. V_lv,P_lv")
      ->delimiter(',');
  sub->add_option("--threads", opts->threads, "Concurrent evaluations (each on its own clone)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  sub->add_option("--connections", opts->connections, "Connections served at once (one thread each)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  sub->add_option("--keep-alive", opts->keep_alive, "Seconds an idle connection is kept open")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
}

}  // namespace sigmaheart::app
