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
// The sizes are one integer per input (output) vector; the brief that asked for this module
// wrote [[n]], but the protocol's conformity tests (testing/protocol_conformity_1.0 in the
// UM-Bridge repository) index inputSizes[i] as an integer, which is what is implemented.
//
// sigmaheart's model has one input vector, theta (the full parameter vector, SI, in the order
// of the simulator's parameters()), and one output vector, the curves: channel after channel,
// each sampled at `frames` evenly spaced times from the first to the last time of the run's
// trajectory (linear interpolation; sample_curves() below). A run that fails is an HTTP 500
// reply {"error": {"type": "ModelFailed", "message": "<status code>: <message>"}}, which the
// client turns back into that Status.
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

// ---------------------------------------------------------------------------------------------
// Server: one simulator (any registered model) exposed as UM-Bridge model `name`.
struct ServeOptions {
  std::string name = "forward";         // the UM-Bridge model name
  std::vector<std::string> channels;    // empty: all of the simulator's channels
  int frames = 50;                      // samples per channel
  int threads = 2;                      // HTTP worker threads (concurrent evaluations)
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
  // when it cannot bind.
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
//       frames: 50             # samples per channel in the output vector
//       period: 0.8 s          # the trajectory's times are k period / (frames - 1)
//       parameters: [...]      # tables.h; its size must equal the server's inputSizes
//       channels: [...]        # channels x frames must equal the server's outputSizes
//
// configure_umbridge asks the server (Info, ModelInfo, InputSizes, OutputSizes) before any work
// and reports an unreachable server or a size mismatch at the key concerned (exit 2).
model::ModelBuild configure_umbridge(const model::OptionReader& numerics);

}  // namespace sigmaheart::app::blackbox
