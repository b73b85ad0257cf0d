#include "app/blackbox/external_model.h"

#include "app/blackbox/process.h"
#include "app/blackbox/tables.h"
#include "app/errors.h"
#include "app/io/display.h"
#include "app/io/observation_file.h"

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <sstream>

namespace sigmaheart::app::blackbox {

namespace fs = std::filesystem;
using model::Status;
using model::StatusCode;

namespace {

std::atomic<int> next_clone_id{0};

const std::vector<std::string> kPlaceholders = {"params", "output", "dir", "member"};

std::string yaml_quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  return out + "\"";
}

// The reason and the kept directory, then the program's last words.
std::string failure_message(const std::string& what, const fs::path& dir) {
  std::string msg = "external simulator: " + what + "; work directory kept: " + dir.string();
  const std::string tail = tail_lines(dir / "stderr.txt", 10);
  msg += tail.empty() ? "; stderr was empty" : "; last lines of stderr:\n" + tail;
  return msg;
}

// The declared channels out of the program's CSV, in SI; a Status for anything else.
Status read_output(const ExternalOptions& o, const fs::path& file, model::Trajectory& out) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    return Status::Error(StatusCode::kBadOutput, "the program wrote no output file '" + file.string() + "'");
  }
  io::ObservationCurves curves;
  try {
    curves = io::read_observation_csv(file);
  } catch (const std::exception& e) {
    return Status::Error(StatusCode::kBadOutput, std::string("unreadable output: ") + e.what());
  }
  const model::Trajectory& t = curves.trajectory;
  out.times = t.times;
  out.channels = o.channels;
  out.values.resize(t.samples(), static_cast<Eigen::Index>(o.channels.size()));
  for (size_t c = 0; c < o.channels.size(); ++c) {
    const auto& want = o.channels[c];
    const auto col = t.channel_index(want.name);
    if (!col) {
      return Status::Error(StatusCode::kBadOutput, "output '" + file.string() + "' has no column '" +
                                                       want.name + "' (declared in channels:)");
    }
    if (t.channels[static_cast<size_t>(*col)].unit != want.unit) {
      return Status::Error(StatusCode::kBadOutput,
                           "output '" + file.string() + "': column '" + want.name + "' is in " +
                               t.channels[static_cast<size_t>(*col)].unit + ", declared " + want.unit);
    }
    out.values.col(static_cast<Eigen::Index>(c)) = t.values.col(*col);
  }
  for (Eigen::Index k = 0; k < out.values.rows(); ++k) {
    for (Eigen::Index c = 0; c < out.values.cols(); ++c) {
      if (!std::isfinite(out.values(k, c))) {
        return Status::Error(StatusCode::kBadOutput,
                             "output '" + file.string() + "': channel '" + o.channels[static_cast<size_t>(c)].name +
                                 "' is missing or not finite at t = " + io::format_number(out.times(k)) + " s");
      }
    }
  }
  return Status::Ok();
}

}  // namespace

std::string parameter_file_text(const model::ParameterSpace& parameters,
                                const Eigen::Ref<const Eigen::VectorXd>& theta, ParameterFormat format) {
  const int n = parameters.size();
  if (format == ParameterFormat::kJson) {
    nlohmann::ordered_json j;
    j["parameters"] = nlohmann::ordered_json::object();
    for (int i = 0; i < n; ++i) j["parameters"][parameters[i].name] = theta(i);
    j["names"] = parameters.names();
    j["values"] = std::vector<double>(theta.data(), theta.data() + n);
    std::vector<std::string> units;
    for (const auto& p : parameters.all()) units.push_back(p.unit);
    j["units"] = units;
    return j.dump(2) + "\n";
  }
  std::ostringstream s;
  s << "# parameters in SI; values written with the shortest text that reads back exactly\n";
  s << "parameters:\n";
  for (int i = 0; i < n; ++i) s << "  " << parameters[i].name << ": " << io::format_exact(theta(i)) << "\n";
  s << "names: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << parameters[i].name;
  s << "]\nvalues: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << io::format_exact(theta(i));
  s << "]\nunits: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << yaml_quoted(parameters[i].unit);
  s << "]\n";
  return s.str();
}

ExternalSimulator::ExternalSimulator(std::shared_ptr<const ExternalOptions> options,
                                     model::ParameterSpace parameters)
    : options_(std::move(options)), parameters_(std::move(parameters)), clone_id_(next_clone_id++) {}

model::RunResult ExternalSimulator::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  model::RunResult result;
  const std::string bad = parameters_.check(theta);
  if (!bad.empty()) {
    result.status = Status::Error(StatusCode::kOutOfBounds, bad);
    return result;
  }
  const ExternalOptions& o = *options_;
  // A fresh member directory: pid, clone and run counter make the name unique in the workdir.
  std::error_code ec;
  fs::create_directories(o.workdir, ec);
  fs::path dir;
  std::string member;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    member = "member-" + std::to_string(::getpid()) + "-" + std::to_string(clone_id_) + "-" +
             std::to_string(counter_++);
    dir = o.workdir / member;
    if (fs::create_directory(dir, ec)) break;
    dir.clear();
  }
  if (dir.empty()) {
    result.status = Status::Error(StatusCode::kProcessFailed,
                                  "external simulator: cannot create a member directory in " +
                                      o.workdir.string() + (ec ? ": " + ec.message() : ""));
    return result;
  }
  const fs::path params =
      dir / (o.parameter_format == ParameterFormat::kJson ? "params.json" : "params.yaml");
  {
    std::ofstream f(params);
    f << parameter_file_text(parameters_, theta, o.parameter_format);
    if (!f) {
      result.status = Status::Error(StatusCode::kProcessFailed,
                                    "external simulator: cannot write " + params.string());
      return result;
    }
  }
  const fs::path output = dir / o.output;
  ProcessOptions p;
  p.executable = o.executable;
  p.argv = o.command.expand({{"params", params.string()}, {"output", output.string()},
                             {"dir", dir.string()}, {"member", member}});
  p.workdir = dir;
  p.stdout_file = dir / "stdout.txt";
  p.stderr_file = dir / "stderr.txt";
  p.timeout = o.timeout;
  const ProcessResult r = run_process(p);
  result.info.period = o.period;
  if (!r.started) {
    result.status = Status::Error(StatusCode::kProcessFailed, failure_message(r.describe(o.timeout), dir));
    return result;
  }
  if (r.timed_out) {
    result.status = Status::Error(StatusCode::kTimeout, failure_message(r.describe(o.timeout), dir));
    return result;
  }
  if (!r.ok()) {
    result.status = Status::Error(StatusCode::kProcessFailed,
                                  failure_message("the program ended with " + r.describe(o.timeout), dir));
    return result;
  }
  const Status read = read_output(o, output, result.trajectory);
  if (!read.ok()) {
    result.status = Status::Error(StatusCode::kBadOutput, failure_message(read.message, dir));
    return result;
  }
  if (o.period <= 0.0 && result.trajectory.samples() > 1) {
    result.info.period = result.trajectory.times(result.trajectory.samples() - 1) - result.trajectory.times(0);
  }
  if (!o.keep_workdirs) fs::remove_all(dir, ec);
  return result;
}

model::ModelBuild configure_external(const model::OptionReader& numerics) {
  if (!numerics.defined() || !numerics.is_map()) {
    numerics.fail("", "model external needs a numerics: section with command, output, parameters "
                      "and channels (docs/architecture.md s.9)");
  }
  numerics.check_keys({"command", "workdir", "parameter_format", "output", "timeout", "period",
                       "keep_workdirs", "parameters", "channels"});
  auto o = std::make_shared<ExternalOptions>();
  if (!numerics.has("command")) numerics.fail("command", "missing required key 'command'");
  const std::string command = numerics.text("command", "");
  try {
    o->command = CommandTemplate::parse(command, kPlaceholders);
  } catch (const std::invalid_argument& e) {
    numerics.fail("command", e.what());
  }
  if (o->command.program_has_placeholder()) {
    numerics.fail("command", "the program (first word) may not hold a placeholder; it is checked "
                             "before any run");
  }
  std::string why;
  const auto exe = resolve_executable(o->command.program(), numerics.base_directory(), why);
  if (!exe) numerics.fail("command", "cannot run the command: " + why);
  o->executable = *exe;
  // Without {output} the program writes the file under its fixed name in {dir}, its working
  // directory.

  fs::path workdir = numerics.text("workdir", "runs");
  if (workdir.empty()) numerics.fail("workdir", "expected a directory");
  if (workdir.is_relative() && !numerics.base_directory().empty()) {
    workdir = fs::path(numerics.base_directory()) / workdir;
  }
  std::error_code ec;
  workdir = fs::absolute(workdir, ec).lexically_normal();
  // The nearest existing ancestor must be a directory this process may create entries in.
  fs::path probe = workdir;
  while (!probe.empty() && !fs::exists(probe, ec)) probe = probe.parent_path();
  if (probe.empty() || !fs::is_directory(probe, ec) || ::access(probe.c_str(), W_OK | X_OK) != 0) {
    numerics.fail("workdir", "cannot create member directories below '" + workdir.string() + "' ('" +
                                 probe.string() + "' is not a writable directory)");
  }
  o->workdir = workdir;

  const std::string format = numerics.text("parameter_format", "json");
  if (format == "json") {
    o->parameter_format = ParameterFormat::kJson;
  } else if (format == "yaml") {
    o->parameter_format = ParameterFormat::kYaml;
  } else {
    numerics.fail("parameter_format", "unknown value '" + format + "'; expected json or yaml");
  }
  if (!numerics.has("output")) numerics.fail("output", "missing required key 'output' (the CSV the program writes)");
  o->output = numerics.text("output", "");
  if (o->output.empty() || o->output.find('/') != std::string::npos || o->output == "." || o->output == "..") {
    numerics.fail("output", "expected a file name (no '/') inside the member directory, got '" + o->output + "'");
  }
  const std::string ext = fs::path(o->output).extension().string();
  if (ext != ".csv" && ext != ".CSV") {
    numerics.fail("output", "expected a .csv file with `name [unit]` headers (app/io/observation_file.h); "
                            "HDF5 output is not supported yet");
  }
  for (const char* reserved : {"stdout.txt", "stderr.txt", "params.json", "params.yaml"}) {
    if (o->output == reserved) numerics.fail("output", std::string("'") + reserved + "' is reserved for the runner");
  }
  o->timeout = numerics.quantity("timeout", "s", o->timeout);
  if (!(o->timeout > 0.0)) numerics.fail("timeout", "expected a time limit > 0 s");
  o->period = numerics.quantity("period", "s", 0.0);
  if (o->period < 0.0 || (numerics.has("period") && o->period == 0.0)) {
    numerics.fail("period", "expected a period > 0 s");
  }
  o->keep_workdirs = numerics.boolean("keep_workdirs", false);
  model::ParameterSpace parameters = read_parameter_table(numerics);
  o->channels = read_channel_table(numerics);
  std::shared_ptr<const ExternalOptions> shared = o;
  return model::ModelBuild(std::move(parameters), [shared](const model::ParameterSpace& p) {
    return std::make_unique<ExternalSimulator>(shared, p);
  });
}

}  // namespace sigmaheart::app::blackbox
