// UM-Bridge on loopback (app/blackbox/umbridge.h): our server, raw HTTP requests against it, and
// our client (`model: umbridge`) against our server, which must give the in-process numbers bit
// for bit (JSON carries doubles as shortest round-trip text).
#include "app/blackbox/register.h"
#include "app/blackbox/umbridge.h"
#include "app/cli.h"
#include "app/config.h"
#include "app/errors.h"
#include "tests/app/blackbox/python_server.h"
#include "tests/app/test_support.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <thread>

namespace sigmaheart::testing {
namespace {

namespace fs = std::filesystem;
namespace bb = app::blackbox;
using nlohmann::json;
using model::StatusCode;

// The beat stand-in (4 parameters, channels V_lv, P_lv, phase) served on a free port.
struct Served {
  std::unique_ptr<bb::UmbridgeServer> server;
  int port = 0;
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port); }
};

Served serve_stand_in(const bb::ServeOptions& o) {
  Served s;
  s.server = std::make_unique<bb::UmbridgeServer>(std::make_unique<BeatStandIn>(BeatStandIn::defaults(), 81), o);
  s.port = s.server->bind("127.0.0.1", 0);
  s.server->start();
  return s;
}

Served serve_stand_in(std::vector<std::string> channels = {"V_lv", "P_lv"}, int frames = 20) {
  bb::ServeOptions o;
  o.channels = std::move(channels);
  o.frames = frames;
  o.threads = 2;
  // stop() waits for a client's idle keep-alive connection to time out (docs/architecture.md
  // s.9): 1 s instead of the default 5 s bounds a test that stops the server under a client.
  o.keep_alive = 1.0;
  return serve_stand_in(o);
}

// `count` keep-alive connections that asked once and stay open, idle.
std::vector<std::unique_ptr<httplib::Client>> idle_connections(const Served& s, int count) {
  std::vector<std::unique_ptr<httplib::Client>> idle;
  for (int i = 0; i < count; ++i) {
    idle.push_back(std::make_unique<httplib::Client>(s.url()));
    idle.back()->set_keep_alive(true);
    EXPECT_TRUE(idle.back()->Get("/Info"));
  }
  return idle;
}

json post(const Served& s, const std::string& path, const std::string& body, int& status) {
  httplib::Client c(s.url());
  auto res = c.Post(path, body, "application/json");
  if (!res) {
    status = -1;
    return {};
  }
  status = res->status;
  return json::parse(res->body);
}

const model::ModelRegistry& models() {
  static const model::ModelRegistry registry = [] {
    model::ModelRegistry r = bb::cli_models();
    register_stand_in(r);
    return r;
  }();
  return registry;
}

fs::path client_config(const fs::path& dir, const std::string& url, int frames = 20,
                       const std::string& extra_parameter = "") {
  return write_file(dir / "c.yaml",
                    "name: c\nsimulator:\n  model: umbridge\n  numerics:\n"
                    "    url: " + url + "\n    name: forward\n    timeout: 10 s\n"
                    "    frames: " + std::to_string(frames) + "\n    period: 0.8 s\n"
                    "    parameters:\n"
                    "      - {name: V_ed, unit: m^3, nominal: 1.4e-4, lower: 1e-5, upper: 5e-4}\n"
                    "      - {name: EF, unit: \"1\", nominal: 0.6, lower: 0.05, upper: 0.9}\n"
                    "      - {name: P_peak, unit: Pa, nominal: 16000, lower: 1000, upper: 40000}\n"
                    "      - {name: fail, unit: \"1\", nominal: 0.0, lower: 0.0, upper: 1.0}\n" +
                        extra_parameter +
                        "    channels:\n"
                        "      - {name: V_lv, unit: m^3}\n"
                        "      - {name: P_lv, unit: Pa}\n");
}

// ---------------------------------------------------------------------------------------------
// Posts `body` to `path` and expects an UM-Bridge error reply: HTTP `status` and error `type`.
json post_error(const Served& s, const std::string& path, const std::string& body, int status,
                const std::string& type) {
  int got = 0;
  json r = post(s, path, body, got);
  EXPECT_EQ(got, status) << path << " " << body;
  EXPECT_EQ(r["error"]["type"], type) << r.dump();
  return r;
}

TEST(UmbridgeServer, AnswersInfoSizesAndModelInfo) {
  const Served s = serve_stand_in();
  httplib::Client c(s.url());
  auto info = c.Get("/Info");
  ASSERT_TRUE(info);
  EXPECT_EQ(info->status, 200);
  const json j = json::parse(info->body);
  EXPECT_EQ(j["protocolVersion"].get<double>(), 1.0);
  EXPECT_EQ(j["models"], json::array({"forward"}));
  int status = 0;
  const std::string ask = R"({"name": "forward", "config": {}})";
  EXPECT_EQ(post(s, "/InputSizes", ask, status)["inputSizes"], json::array({4}));
  EXPECT_EQ(status, 200);
  EXPECT_EQ(post(s, "/OutputSizes", ask, status)["outputSizes"], json::array({40, 20}));
  const json support = post(s, "/ModelInfo", R"({"name": "forward"})", status)["support"];
  EXPECT_TRUE(support["Evaluate"].get<bool>());
  EXPECT_FALSE(support["Gradient"].get<bool>());
  EXPECT_FALSE(support["ApplyJacobian"].get<bool>());
  EXPECT_FALSE(support["ApplyHessian"].get<bool>());
}

TEST(UmbridgeServer, EvaluateReturnsTheSampledCurves) {
  const Served s = serve_stand_in();
  int status = 0;
  const json r = post(s, "/Evaluate",
                      R"({"name": "forward", "input": [[1.4e-4, 0.6, 16000, 0]], "config": {}})", status);
  ASSERT_EQ(status, 200) << r.dump();
  ASSERT_EQ(r["output"].size(), 2u);
  ASSERT_EQ(r["output"][0].size(), 40u);
  ASSERT_EQ(r["output"][1].size(), 20u);  // the frames' times [s]
  EXPECT_EQ(r["output"][1][0].get<double>(), 0.0);
  EXPECT_EQ(r["output"][1][19].get<double>(), 0.8);
  // V_lv at t = 0 is V_ed; at mid-beat (frame 10 of 20 is t = 0.8 * 10/19, so interpolated)
  // between V_ed (1 - EF) and V_ed.
  EXPECT_DOUBLE_EQ(r["output"][0][0].get<double>(), 1.4e-4);
  EXPECT_DOUBLE_EQ(r["output"][0][19].get<double>(), 1.4e-4);
  EXPECT_NEAR(r["output"][0][20].get<double>(), 1000.0, 1e-9);  // P_lv at t = 0
  EXPECT_EQ(s.server->evaluations(), 1);
}

TEST(UmbridgeServer, ErrorsAreUmbridgeErrorReplies) {
  const Served s = serve_stand_in();
  json r = post_error(s, "/Evaluate", R"({"name": "forward", "input": [[1.4e-4, 0.6, 16000]], "config": {}})",
                      400, "InvalidInput");
  EXPECT_NE(r["error"]["message"].get<std::string>().find("has 3 entries; expected 4"), std::string::npos);
  r = post_error(s, "/Evaluate", R"({"name": "backward", "input": [[1, 2, 3, 4]]})", 400, "ModelNotFound");
  r = post_error(s, "/Evaluate", R"({"name": "forward", "input": [[1, 2)", 400, "InvalidInput");
  // A raw NaN (not JSON): the message says so.
  r = post_error(s, "/Evaluate", R"({"name": "forward", "input": [[NaN, 0.6, 16000, 0]]})",
                 400, "InvalidInput");
  EXPECT_NE(r["error"]["message"].get<std::string>().find("'NaN', which JSON cannot carry"), std::string::npos)
      << r.dump();
  r = post_error(s, "/Gradient", R"({"name": "forward"})", 400, "UnsupportedFeature");
  // Outside the parameter bounds: the client's mistake.
  r = post_error(s, "/Evaluate", R"({"name": "forward", "input": [[1.4e-4, 0.99, 16000, 0]]})",
                 400, "InvalidInput");
  EXPECT_NE(r["error"]["message"].get<std::string>().find("EF"), std::string::npos);
  // A failed run: the model's status travels in the message.
  r = post_error(s, "/Evaluate", R"({"name": "forward", "input": [[1.4e-4, 0.6, 16000, 1]]})",
                 500, "InvalidOutput");
  EXPECT_EQ(r["error"]["message"], "diverged: Newton diverged at t = 0.3 s");
}

TEST(UmbridgeServer, RefusesUnknownChannels) {
  bb::ServeOptions o;
  o.channels = {"V_lvv"};
  try {
    bb::UmbridgeServer server(std::make_unique<BeatStandIn>(BeatStandIn::defaults(), 81), o);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'V_lv'"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Our client against our server: the in-process numbers, bit for bit, also from two threads.
TEST(UmbridgeClient, RoundTripGivesTheInProcessNumbersBitForBit) {
  const Served s = serve_stand_in();
  const auto dir = scratch_dir();
  const app::Config config = app::load_config(client_config(dir, s.url()), {}, models());
  auto remote = config.simulator.make();
  EXPECT_EQ(remote->name(), "umbridge");
  BeatStandIn local(BeatStandIn::defaults(), 81);
  const std::vector<Eigen::VectorXd> thetas = {
      (Eigen::VectorXd(4) << 1.4e-4, 0.6, 16000.0, 0.0).finished(),
      (Eigen::VectorXd(4) << 1.234567e-4, 1.0 / 3.0, 12345.678, 0.1).finished()};
  std::vector<model::RunResult> results(thetas.size());
  std::vector<std::thread> threads;
  std::vector<std::unique_ptr<model::Simulator>> clones;
  for (size_t i = 0; i < thetas.size(); ++i) clones.push_back(remote->clone());
  for (size_t i = 0; i < thetas.size(); ++i) {
    threads.emplace_back([&, i] { results[i] = clones[i]->run(thetas[i]); });
  }
  for (auto& t : threads) t.join();
  for (size_t i = 0; i < thetas.size(); ++i) {
    ASSERT_TRUE(results[i].status.ok()) << results[i].status.message;
    const Eigen::VectorXd want = bb::sample_curves(local.run(thetas[i]).trajectory, {0, 1}, 20);
    const model::Trajectory& t = results[i].trajectory;
    ASSERT_EQ(t.samples(), 20);
    EXPECT_EQ(t.channels[1].unit, "Pa");
    for (int k = 0; k < 20; ++k) {
      EXPECT_EQ(t.values(k, 0), want(k)) << k;
      EXPECT_EQ(t.values(k, 1), want(20 + k)) << k;
    }
    EXPECT_DOUBLE_EQ(t.times(19), 0.8);
  }
}

TEST(UmbridgeClient, AFailedEvaluationIsAStatusNeverAnException) {
  const Served s = serve_stand_in();
  const auto dir = scratch_dir();
  const app::Config config = app::load_config(client_config(dir, s.url()), {}, models());
  auto remote = config.simulator.make();
  const model::RunResult r = remote->run((Eigen::VectorXd(4) << 1.4e-4, 0.6, 16000.0, 0.9).finished());
  EXPECT_EQ(r.status.code, StatusCode::kDiverged);
  EXPECT_NE(r.status.message.find("Newton diverged at t = 0.3 s"), std::string::npos) << r.status.message;
  // The server goes away: the next run is a process failure, not a throw.
  const_cast<Served&>(s).server->stop();
  const model::RunResult gone = remote->run((Eigen::VectorXd(4) << 1.4e-4, 0.6, 16000.0, 0.0).finished());
  EXPECT_FALSE(gone.status.ok());
  EXPECT_NE(gone.status.message.find("no reply"), std::string::npos) << gone.status.message;
}

TEST(UmbridgeClient, AnUnreachableServerOrWrongSizesAreBadInput) {
  const auto dir = scratch_dir();
  // A port nothing listens on: bind one, then close it.
  int free_port = 0;
  {
    const Served s = serve_stand_in();
    free_port = s.port;
  }
  std::ostringstream out, err;
  const auto cfg = client_config(dir, "http://127.0.0.1:" + std::to_string(free_port));
  EXPECT_EQ(app::run_cli({"validate", cfg.string()}, out, err, models()), app::kExitBadInput);
  EXPECT_NE(err.str().find("c.yaml:5:10"), std::string::npos) << err.str();
  EXPECT_NE(err.str().find("no UM-Bridge server answers"), std::string::npos) << err.str();

  const Served s = serve_stand_in();
  std::ostringstream out2, err2;
  const auto extra = client_config(dir, s.url(), 20,
                                   "      - {name: extra, unit: s, nominal: 1, lower: 0, upper: 2}\n");
  EXPECT_EQ(app::run_cli({"validate", extra.string()}, out2, err2, models()), app::kExitBadInput);
  EXPECT_NE(err2.str().find("takes 4 inputs; the parameter table has 5"), std::string::npos) << err2.str();
  // One error, not a second one about the key validate removed to look further.
  EXPECT_EQ(err2.str().find("missing required key"), std::string::npos) << err2.str();
  std::ostringstream out3, err3;
  EXPECT_EQ(app::run_cli({"validate", client_config(dir, s.url(), 30).string()}, out3, err3, models()),
            app::kExitBadInput);
  EXPECT_NE(err3.str().find("returns output vectors of sizes [40, 20]; channels x frames = 2 x 30 = 60"),
            std::string::npos)
      << err3.str();
}

// `sigmaheart serve` as a program: prints where it listens, answers, exits 0 on SIGTERM.
TEST(UmbridgeServe, TheServeCommandAnswersAndStopsCleanlyOnSigterm) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "sphere.yaml", "name: sphere\nsimulator:\n  model: lumped-sphere\n");
  const fs::path log = dir / "serve.log";
  const std::string cmd = std::string(SIGMAHEART_BINARY_DIR) + "/sigmaheart serve " + cfg.string() +
                          " --port 0 --frames 10 --channels V_lv,P_lv > " + log.string() +
                          " 2>&1 & echo $!";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  int pid = 0;
  ASSERT_EQ(std::fscanf(p, "%d", &pid), 1);
  ::pclose(p);
  int port = 0;
  for (int i = 0; i < 200 && port == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string text = read_file(log);
    const auto at = text.find("http://127.0.0.1:");
    if (at != std::string::npos) port = std::atoi(text.c_str() + at + 17);
  }
  ASSERT_GT(port, 0) << read_file(log);
  httplib::Client c("http://127.0.0.1:" + std::to_string(port));
  auto res = c.Post("/InputSizes", R"({"name": "forward"})", "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(json::parse(res->body)["inputSizes"][0].get<int>(), model::builtin_models().find("lumped-sphere")->configure_defaults().parameters().size());
  ::kill(pid, SIGTERM);
  int code = -1;
  for (int i = 0; i < 100; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (read_file(log).find("stopped after") != std::string::npos) {
      code = 0;
      break;
    }
  }
  EXPECT_EQ(code, 0) << read_file(log);
}

// ---------------------------------------------------------------------------------------------
// Issue 44, item 3: a server that holds.

TEST(UmbridgeServer, ASecondServerOnTheSamePortFailsAndServeSaysWhy) {
  const Served first = serve_stand_in();
  bb::UmbridgeServer second(std::make_unique<BeatStandIn>(BeatStandIn::defaults(), 81), bb::ServeOptions{});
  EXPECT_THROW(second.bind("127.0.0.1", first.port), std::runtime_error);
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "sphere.yaml", "name: sphere\nsimulator:\n  model: lumped-sphere\n");
  std::ostringstream out, err;
  EXPECT_EQ(app::run_cli({"serve", cfg.string(), "--port", std::to_string(first.port)}, out, err, models()),
            app::kExitBadInput);
  EXPECT_NE(err.str().find("cannot listen on 127.0.0.1:" + std::to_string(first.port) + " (in use"),
            std::string::npos)
      << err.str();
}

// Two idle keep-alive connections do not keep a third client from the one evaluation slot: with
// connections on their own threads the third is answered at once (before, it waited for an idle
// connection to time out; here that would take 30 s and its 10 s read limit would fail it).
TEST(UmbridgeServer, IdleKeepAliveConnectionsNeverHoldAnEvaluationSlot) {
  bb::ServeOptions o;
  o.channels = {"V_lv"};
  o.frames = 10;
  o.threads = 1;
  o.connections = 8;
  o.keep_alive = 30.0;
  const Served s = serve_stand_in(o);
  const auto idle = idle_connections(s, 2);  // connected, answered, left open
  httplib::Client third(s.url());
  third.set_read_timeout(10, 0);
  auto res = third.Post("/Evaluate", R"({"name": "forward", "input": [[1.4e-4, 0.6, 16000, 0]]})",
                        "application/json");
  ASSERT_TRUE(res) << httplib::to_string(res.error());
  EXPECT_EQ(res->status, 200);
}

// N clients x M requests on loopback, with idle keep-alive connections among them: every answer
// equals the in-process run bit for bit. The latencies are printed (bench/blackbox_bench.cpp
// measures throughput); the test bounds count and time by its request count and read limits.
TEST(UmbridgeServer, LoadOfEightClientsWithIdleConnectionsGetsEveryAnswerRight) {
  bb::ServeOptions o;
  o.channels = {"V_lv", "P_lv"};
  o.frames = 20;
  o.threads = 2;
  o.connections = 16;
  o.keep_alive = 30.0;
  const Served s = serve_stand_in(o);
  const auto idle = idle_connections(s, 4);
  const int clients = 8, requests = 40;
  std::vector<std::vector<double>> latency(clients);
  std::vector<int> wrong(clients, 0), failed(clients, 0);
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      httplib::Client client(s.url());
      client.set_keep_alive(true);
      client.set_tcp_nodelay(true);  // as our client (a small request would wait for the delayed ACK)
      client.set_read_timeout(20, 0);
      BeatStandIn local(BeatStandIn::defaults(), 81);
      for (int r = 0; r < requests; ++r) {
        const Eigen::VectorXd theta =
            (Eigen::VectorXd(4) << 1.0e-4 + 1e-6 * (c * requests + r), 0.6, 16000.0, 0.0).finished();
        const json body{{"name", "forward"}, {"input", {std::vector<double>(theta.data(), theta.data() + 4)}}};
        const auto t0 = std::chrono::steady_clock::now();
        auto res = client.Post("/Evaluate", body.dump(), "application/json");
        latency[c].push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        if (!res || res->status != 200) {
          ++failed[c];
          continue;
        }
        const json out = json::parse(res->body)["output"][0];
        const Eigen::VectorXd want = bb::sample_curves(local.run(theta).trajectory, {0, 1}, 20);
        for (int k = 0; k < 40; ++k) wrong[c] += out[static_cast<size_t>(k)].get<double>() != want(k);
      }
    });
  }
  for (auto& t : threads) t.join();
  std::vector<double> all;
  for (int c = 0; c < clients; ++c) {
    EXPECT_EQ(failed[c], 0) << "client " << c;
    EXPECT_EQ(wrong[c], 0) << "client " << c;
    all.insert(all.end(), latency[c].begin(), latency[c].end());
  }
  std::sort(all.begin(), all.end());
  std::printf("load: %d clients x %d requests, 4 idle connections: p50 %.3f ms, p99 %.3f ms, max %.3f ms\n", clients,
              requests, all[all.size() / 2], all[all.size() * 99 / 100], all.back());
  EXPECT_EQ(s.server->evaluations(), clients * requests);
}

// The client converts what it reads by the declared unit: a server that returns Pa, declared as
// mmHg, gives values 133.322 times larger (before issue 44 they passed unconverted).
TEST(UmbridgeClient, OutputsAreConvertedByTheirDeclaredUnit) {
  const Served s = serve_stand_in();
  const auto dir = scratch_dir();
  std::string text = read_file(client_config(dir, s.url()));
  text.replace(text.find("{name: P_lv, unit: Pa}"), 22, "{name: P_lv, unit: mmHg}");
  const app::Config config = app::load_config(write_file(dir / "mmhg.yaml", text), {}, models());
  const model::RunResult r = config.simulator.make()->run(BeatStandIn::defaults().nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_NEAR(r.trajectory.values(0, 1), 1000.0 * 133.322, 1e-9);  // the server sent 1000
  EXPECT_EQ(r.trajectory.channels[1].unit, "Pa");
}

TEST(UmbridgeClient, AnotherProtocolVersionIsBadInput) {
  const PythonServer server(benchmark_script(), {"--model", "testmodel", "--port", "0", "--protocol-version", "0.9"});
  ASSERT_FALSE(server.url().empty());
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "v.yaml", "name: v\nsimulator:\n  model: umbridge\n  numerics:\n    url: " +
                                                  server.url() + "\n    name: forward\n"
                                                  "    outputs: [{name: y, unit: \"1\"}]\n"
                                                  "    parameters: [{name: x, unit: \"1\", nominal: 1, lower: 0, upper: 2}]\n");
  std::ostringstream out, err;
  EXPECT_EQ(app::run_cli({"validate", cfg.string()}, out, err, models()), app::kExitBadInput);
  EXPECT_NE(err.str().find("speaks UM-Bridge protocol version 0.9; this client speaks 1"), std::string::npos)
      << err.str();
}

}  // namespace
}  // namespace sigmaheart::testing
