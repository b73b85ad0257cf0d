// UM-Bridge (Seelinger et al. 2023, "UM-Bridge: Uncertainty quantification and modeling bridge",
// JOSS 8:4748; protocol version 1.0, um-bridge-benchmarks.readthedocs.io "Protocol"): a model is
// a function from input vectors to output vectors reached over HTTP with JSON bodies.
//
//   GET  /Info          -> {"protocolVersion": 1.0, "models": ["forward"]}
//   POST /InputSizes    {"name": "forward", "config": {}} -> {"inputSizes": [n]}
//   POST /OutputSizes   {"name": "forward", "config": {}} -> {"outputSizes": [m]}
//   POST /ModelInfo     {"name": "forward"} -> {"support": {"Evaluate": true, "Gradient": false,
//                                               "ApplyJacobian": false, "ApplyHessian": false}}
//   POST /Evaluate      {"name": "forward", "input": [[...n...]], "config": {}}
//                       -> {"output": [[...m...]]}
//   errors: HTTP 400 with {"error": {"type": "InvalidInput" | "ModelNotFound" |
//                                             "UnsupportedFeature" | ..., "message": "..."}}
//   errors: {"error": {"type": "InvalidInput" | "InvalidOutput" | "ModelNotFound" |
//                              "UnsupportedFeature", "message": "..."}} (umbridge_wire.h)
// The sizes are one integer per input (output) vector, as the protocol's conformity tests
// (testing/protocol_conformity_1.0 in the UM-Bridge repository) read them.
//
// Our server's model has one input vector, theta (the full parameter vector, SI, in the order of
// the simulator's parameters()), and two output vectors: the curves (channel after channel, each
// sampled at `frames` evenly spaced times from the first to the last time of the run's
// trajectory; sample_curves() below) and those `frames` times [s] (sample_times()), so a client
// puts the curves on the model's own time axis. A run that fails is an HTTP 500 reply
// {"error": {"type": "InvalidOutput", "message": "<status code>: <message>"}}, which the client
// turns back into that Status.
#pragma once

#include "model/registry.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app::blackbox {

// The output vector of a trajectory: for each channel index in `channels`, `frames` (>= 2)
// samples at t_k = t_0 + k (t_last - t_0) / (frames - 1), linearly interpolated.
// std::invalid_argument for an empty trajectory or frames < 2.
Eigen::VectorXd sample_curves(const model::Trajectory& trajectory, const std::vector<int>& channels,
                              int frames);

// The `frames` times sample_curves() samples at [s].
Eigen::VectorXd sample_times(const model::Trajectory& trajectory, int frames);

// ---------------------------------------------------------------------------------------------
// Server: one simulator (any registered model) exposed as UM-Bridge model `name`.
struct ServeOptions {
  std::string name = "forward";         // the UM-Bridge model name
  std::vector<std::string> channels;    // empty: all of the simulator's channels
  int frames = 50;                      // samples per channel
  int threads = 2;                      // concurrent evaluations (each on its own clone)
  // Connections served at once, each on its own worker thread (>= threads): idle keep-alive
  // connections hold a connection thread, never an evaluation slot. A connection idle for
  // keep_alive seconds is closed; with all `connections` busy a new one waits for a free thread.
  int connections = 64;
  double keep_alive = 5.0;              // [s]
};

class UmbridgeServer {
 public:
  // `prototype` is cloned once per concurrent evaluation. std::invalid_argument for an unknown
  // channel or frames < 2.
  UmbridgeServer(std::unique_ptr<model::Simulator> prototype, ServeOptions options);
  ~UmbridgeServer();
  UmbridgeServer(const UmbridgeServer&) = delete;
  UmbridgeServer& operator=(const UmbridgeServer&) = delete;

  // Binds to host:port (port 0: a free port) and returns the port; throws std::runtime_error
  // when it cannot bind. The port is exclusive (SO_REUSEADDR without SO_REUSEPORT): a second
  // server on a port in use fails here.
  int bind(const std::string& host, int port);
  // Serves on a background thread until stop().
  void start();
  void stop();

  int input_size() const;
  int output_size() const;
  long evaluations() const;  // successful or not, since construction

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------------
// Client: `model: umbridge`.
//
//   simulator:
//     model: umbridge
//     numerics:
//       url: http://localhost:4242
//       name: forward
//       timeout: 60 s          # per Evaluate
//       config: {a: 2.0}       # the model's own configuration, sent with every request as is
//       parameters: [...]      # tables.h; `input: k` puts a parameter in input vector k (0)
//       # curves (a heart model): output vector 0 is channels x frames
//       frames: 50
//       period: 0.8 s          # or the name of the period parameter; or instead
//       times: returned        # output vector 1 holds the frames' times (time_unit: s)
//       channels: [...]        # tables.h, each in its declared unit
//       # or generic outputs: each output vector a list of single values
//       outputs: [{name: log_density, unit: "1", size: 1}, {name: T, unit: "1", size: 2}]
//
// With `outputs:` the run's Trajectory has one sample (t = 0) and one channel per value: the
// vector's name when its size is 1, else name[0], name[1], ... (docs/architecture.md s.2).
// configure_umbridge asks the server (Info with its protocolVersion, ModelInfo, InputSizes,
// OutputSizes) before any work and reports an unreachable server, another protocol version, an
// unknown model or a size mismatch at the key concerned (exit 2).
model::ModelBuild configure_umbridge(const model::OptionReader& numerics);

}  // namespace sigmaheart::app::blackbox
