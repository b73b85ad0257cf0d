#include "app/blackbox/external_model.h"

#include "app/blackbox/process.h"
#include "app/blackbox/tables.h"
#include "app/errors.h"
#include "app/io/display.h"
#include "app/io/hdf5_writer.h"
#include "app/io/observation_file.h"
#include "model/units.h"

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

namespace sigmaheart::app::blackbox {

namespace fs = std::filesystem;
using model::Status;
using model::StatusCode;

namespace {

std::atomic<int> next_clone_id{0};

const std::vector<std::string> kPlaceholders = {"params", "output", "dir", "member"};
const std::vector<std::string> kStepPlaceholders = {"params", "state_in", "state_out", "t_end", "dir", "member"};

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

// The HDF5 library is not built thread-safe on every system: one reader at a time.
std::mutex hdf5_mutex;

// An HDF5 output: a dataset /time and one dataset /<channel> per declared channel (vectors of the
// same length), each with an optional `units` attribute (default: s for time, the declared unit).
model::Trajectory read_output_h5(const ExternalOptions& o, const fs::path& file) {
  std::lock_guard<std::mutex> lock(hdf5_mutex);
  io::Hdf5Reader h5(file);
  model::Trajectory t;
  auto unit_of = [&h5](const std::string& path, const std::string& fallback) {
    return h5.has_attribute(path, "units") ? h5.string_attribute(path, "units") : fallback;
  };
  if (!h5.exists("/time")) throw std::runtime_error("no dataset /time");
  t.times = h5.read_vector("/time") * model::units::convert(1.0, unit_of("/time", "s"), "s");
  for (size_t ci = 0; ci < o.channels.size(); ++ci) {
    const model::Channel& c = o.channels[ci];
    const std::string path = "/" + c.name;
    if (!h5.exists(path)) continue;  // reported as a missing column below
    const Eigen::VectorXd v = h5.read_vector(path);
    if (v.size() != t.times.size()) {
      throw std::runtime_error("dataset " + path + " has " + std::to_string(v.size()) + " values, /time has " +
                               std::to_string(t.times.size()));
    }
    // No `units` attribute: the unit declared in the table (converted like any other).
    const std::string unit = unit_of(path, ci < o.channel_units.size() ? o.channel_units[ci].unit : c.unit);
    t.channels.push_back({c.name, c.unit, "", "", 0});
    t.values.conservativeResize(v.size(), t.values.cols() + 1);
    t.values.col(t.values.cols() - 1) = v * (unit == c.unit ? 1.0 : model::units::convert(1.0, unit, c.unit));
  }
  if (t.values.cols() == 0) t.values.resize(t.times.size(), 0);
  return t;
}

// The declared channels out of the program's CSV or HDF5 file, in SI; a Status for anything else.
Status read_output(const ExternalOptions& o, const fs::path& file, model::Trajectory& out) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    return Status::Error(StatusCode::kBadOutput, "the program wrote no output file '" + file.string() + "'");
  }
  io::ObservationCurves curves;
  try {
    if (file.extension() == ".h5") {
      curves.trajectory = read_output_h5(o, file);
    } else {
      curves = io::read_observation_csv(file);
    }
  } catch (const std::exception& e) {
    return Status::Error(StatusCode::kBadOutput, std::string("unreadable output: ") + e.what());
  }
  const model::Trajectory& t = curves.trajectory;
  for (Eigen::Index k = 1; k < t.times.size(); ++k) {
    if (!(t.times(k) > t.times(k - 1))) {
      return Status::Error(StatusCode::kBadOutput, "output '" + file.string() + "': times do not increase at sample " +
                                                       std::to_string(k));
    }
  }
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


// A fresh member directory below the workdir: pid, clone and run counter make the name unique.
Status make_member_dir(const ExternalOptions& o, int clone_id, long& counter, fs::path& dir,
                       std::string& member) {
  std::error_code ec;
  fs::create_directories(o.workdir, ec);
  for (int attempt = 0; attempt < 1000; ++attempt) {
    member = "member-" + std::to_string(::getpid()) + "-" + std::to_string(clone_id) + "-" +
             std::to_string(counter++);
    dir = o.workdir / member;
    if (fs::create_directory(dir, ec)) return Status::Ok();
  }
  return Status::Error(StatusCode::kProcessFailed, "external simulator: cannot create a member directory in " +
                                                       o.workdir.string() + (ec ? ": " + ec.message() : ""));
}

Status write_text(const fs::path& file, const std::string& text) {
  std::ofstream f(file);
  f << text;
  if (!f) return Status::Error(StatusCode::kProcessFailed, "external simulator: cannot write " + file.string());
  return Status::Ok();
}

// Runs the program in `dir`; a failure is kProcessFailed or kTimeout with failure_message().
Status run_in(const ExternalOptions& o, const std::string& executable, const CommandTemplate& command,
              const std::map<std::string, std::string>& values, const fs::path& dir) {
  ProcessOptions p;
  p.executable = executable;
  p.argv = command.expand(values);
  p.workdir = dir;
  p.stdout_file = dir / "stdout.txt";
  p.stderr_file = dir / "stderr.txt";
  p.timeout = o.timeout;
  const ProcessResult r = run_process(p);
  if (r.timed_out) return Status::Error(StatusCode::kTimeout, failure_message(r.describe(o.timeout), dir));
  if (!r.ok()) {
    return Status::Error(StatusCode::kProcessFailed,
                         failure_message(r.started ? "the program ended with " + r.describe(o.timeout)
                                                   : r.describe(o.timeout),
                                         dir));
  }
  return Status::Ok();
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(trim(cell));
  return out;
}

// The header of a state file: time, the state layout, then (when with_channels) the channels.
std::string state_header(const ExternalOptions& o, bool with_channels) {
  std::string h = "time [s]";
  for (const auto& c : o.state) h += ", " + c.name + " [" + c.unit + "]";
  if (with_channels) {
    for (const auto& c : o.channels) h += ", " + c.name + " [" + c.unit + "]";
  }
  return h + "\n";
}

// Reads {state_out}: header `time [s], state..., channels...` and one row; values in the units
// written (converted to the declared SI units when they differ).
Status read_state_file(const ExternalOptions& o, const fs::path& file, double& time, Eigen::VectorXd& x,
                       Eigen::VectorXd& channels) {
  std::ifstream in(file);
  if (!in) return Status::Error(StatusCode::kBadOutput, "the program wrote no state file '" + file.string() + "'");
  std::string line;
  std::vector<std::string> header, row;
  while (std::getline(in, line)) {
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    if (header.empty()) {
      header = split_commas(t);
    } else {
      row = split_commas(t);
      break;
    }
  }
  std::vector<model::Channel> want = {{"time", "s", ""}};
  want.insert(want.end(), o.state.begin(), o.state.end());
  want.insert(want.end(), o.channels.begin(), o.channels.end());
  const std::string where = "state file '" + file.string() + "'";
  if (header.size() != want.size() || row.size() != want.size()) {
    return Status::Error(StatusCode::kBadOutput, where + ": expected a header and one row of " +
                                                     std::to_string(want.size()) + " columns: " +
                                                     state_header(o, true));
  }
  std::vector<double> values(want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    const auto open = header[i].find('[');
    const auto close = header[i].rfind(']');
    const std::string name = trim(header[i].substr(0, open));
    const std::string unit =
        open != std::string::npos && close != std::string::npos && close > open
            ? trim(header[i].substr(open + 1, close - open - 1))
            : std::string();
    if (name != want[i].name) {
      return Status::Error(StatusCode::kBadOutput, where + ": column " + std::to_string(i + 1) + " is '" + name +
                                                       "', expected '" + want[i].name + "'");
    }
    char* end = nullptr;
    double v = std::strtod(row[i].c_str(), &end);
    if (end == row[i].c_str() || *end != '\0' || !std::isfinite(v)) {
      return Status::Error(StatusCode::kBadOutput, where + ": '" + want[i].name + "' is '" + row[i] +
                                                       "', not a finite number");
    }
    if (unit != want[i].unit) {
      try {
        v = model::units::convert(v, unit, want[i].unit);
      } catch (const std::invalid_argument& e) {
        return Status::Error(StatusCode::kBadOutput, where + ": '" + want[i].name + "': " + e.what());
      }
    }
    values[i] = v;
  }
  time = values[0];
  const auto ns = static_cast<Eigen::Index>(o.state.size());
  x = Eigen::Map<const Eigen::VectorXd>(values.data() + 1, ns);
  channels = Eigen::Map<const Eigen::VectorXd>(values.data() + 1 + ns, static_cast<Eigen::Index>(o.channels.size()));
  return Status::Ok();
}

}  // namespace

std::string parameter_file_text(const model::ParameterSpace& parameters,
                                const Eigen::Ref<const Eigen::VectorXd>& theta, ParameterFormat format,
                                const std::vector<DeclaredUnit>& declared) {
  const int n = parameters.size();
  const bool as_declared = static_cast<int>(declared.size()) == n;
  std::vector<double> values(static_cast<size_t>(n));
  std::vector<std::string> units(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<size_t>(i);
    values[k] = as_declared ? theta(i) / declared[k].factor : theta(i);
    units[k] = as_declared ? declared[k].unit : parameters[i].unit;
  }
  if (format == ParameterFormat::kJson) {
    nlohmann::ordered_json j;
    j["parameters"] = nlohmann::ordered_json::object();
    for (int i = 0; i < n; ++i) j["parameters"][parameters[i].name] = values[static_cast<size_t>(i)];
    j["names"] = parameters.names();
    j["values"] = values;
    j["units"] = units;
    return j.dump(2) + "\n";
  }
  std::ostringstream s;
  s << "# parameters in the units below; values written with the shortest text that reads back exactly\n";
  s << "parameters:\n";
  for (int i = 0; i < n; ++i) s << "  " << parameters[i].name << ": " << io::format_exact(values[static_cast<size_t>(i)]) << "\n";
  s << "names: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << parameters[i].name;
  s << "]\nvalues: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << io::format_exact(values[static_cast<size_t>(i)]);
  s << "]\nunits: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << yaml_quoted(units[static_cast<size_t>(i)]);
  s << "]\n";
  return s.str();
}

ExternalSimulator::ExternalSimulator(std::shared_ptr<const ExternalOptions> options,
                                     model::ParameterSpace parameters)
    : ExternalBase(std::move(options), std::move(parameters), next_clone_id++) {}

model::RunResult ExternalSimulator::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  if (auto refused = refuse_out_of_bounds(parameters_, theta)) return *refused;
  model::RunResult result;
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
    f << parameter_file_text(parameters_, theta, o.parameter_format, o.parameter_units);
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
  result.info.period = o.period.of(theta);
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
  if (!o.period.defined() && result.trajectory.samples() > 1) {
    result.info.period = result.trajectory.times(result.trajectory.samples() - 1) - result.trajectory.times(0);
  }
  if (!o.keep_workdirs) fs::remove_all(dir, ec);
  return result;
}


ExternalSteppableSimulator::ExternalSteppableSimulator(std::shared_ptr<const ExternalOptions> options,
                                                       model::ParameterSpace parameters)
    : ExternalBase(std::move(options), std::move(parameters), next_clone_id++) {}

Status ExternalSteppableSimulator::step(const model::State* in, const Eigen::Ref<const Eigen::VectorXd>& theta,
                                        double t_end, model::State& out_state,
                                        Eigen::VectorXd& out_channels) const {
  const std::string bad = parameters_.check(theta);
  if (!bad.empty()) return Status::Error(StatusCode::kOutOfBounds, bad);
  if (in != nullptr && (in->x.size() != static_cast<Eigen::Index>(options_->state.size()) || !(t_end >= in->time))) {
    return Status::Error(StatusCode::kInvalidArgument,
                         "external simulator: a state of " + std::to_string(in->x.size()) + " entries (expected " +
                             std::to_string(options_->state.size()) + ") or t_end < the state's time");
  }
  const ExternalOptions& o = *options_;
  fs::path dir;
  std::string member;
  if (Status s = make_member_dir(o, clone_id_, counter_, dir, member); !s.ok()) return s;
  const fs::path params = dir / (o.parameter_format == ParameterFormat::kJson ? "params.json" : "params.yaml");
  if (Status s = write_text(params, parameter_file_text(parameters_, theta, o.parameter_format, o.parameter_units)); !s.ok()) return s;
  std::string state_text = state_header(o, false);
  if (in != nullptr) {
    state_text += io::format_exact(in->time);
    for (Eigen::Index i = 0; i < in->x.size(); ++i) state_text += ", " + io::format_exact(in->x(i));
    state_text += "\n";
  }
  const fs::path state_in = dir / "state_in.csv", state_out = dir / "state_out.csv";
  if (Status s = write_text(state_in, state_text); !s.ok()) return s;
  Status s = run_in(o, o.step_executable, o.step_command,
                    {{"params", params.string()}, {"state_in", state_in.string()}, {"state_out", state_out.string()},
                     {"t_end", io::format_exact(t_end)}, {"dir", dir.string()}, {"member", member}},
                    dir);
  if (!s.ok()) return s;
  Status read = read_state_file(o, state_out, out_state.time, out_state.x, out_channels);
  if (read.ok() && std::abs(out_state.time - t_end) > 1e-12 * std::max(1.0, std::abs(t_end))) {
    read = Status::Error(StatusCode::kBadOutput, "the state file's time is " + io::format_exact(out_state.time) +
                                                     " s, expected t_end = " + io::format_exact(t_end) + " s");
  }
  if (!read.ok()) return Status::Error(StatusCode::kBadOutput, failure_message(read.message, dir));
  out_state.time = t_end;  // lands exactly on t_end
  std::error_code ec;
  if (!o.keep_workdirs) fs::remove_all(dir, ec);
  return Status::Ok();
}

model::State ExternalSteppableSimulator::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  model::State state;
  Eigen::VectorXd channels;
  const Status s = step(nullptr, theta, 0.0, state, channels);
  if (!s.ok()) throw std::runtime_error("external simulator: no initial state: " + s.message);
  return state;
}

Status ExternalSteppableSimulator::advance(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                                           double t_end) {
  model::State next;
  Eigen::VectorXd channels;
  const Status s = step(&state, theta, t_end, next, channels);
  if (s.ok()) state = std::move(next);  // on failure the state stays at the last good time
  return s;
}

Eigen::VectorXd ExternalSteppableSimulator::sample(const model::State& state,
                                                   const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  model::State same;
  Eigen::VectorXd channels;
  const Status s = step(&state, theta, state.time, same, channels);
  if (!s.ok()) {
    return Eigen::VectorXd::Constant(static_cast<Eigen::Index>(options_->channels.size()),
                                     std::numeric_limits<double>::quiet_NaN());
  }
  return channels;
}

model::RunResult ExternalSteppableSimulator::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  model::RunResult result;
  const ExternalOptions& o = *options_;
  model::State state;
  Eigen::VectorXd channels;
  result.status = step(nullptr, theta, 0.0, state, channels);
  if (!result.status.ok()) return result;
  model::Trajectory& t = result.trajectory;
  t.channels = o.channels;
  t.times.resize(o.frames);
  t.values.resize(o.frames, static_cast<Eigen::Index>(o.channels.size()));
  const double period = o.period.of(theta);  // the model's own: a studied period moves the axis
  for (int k = 0; k < o.frames; ++k) {
    const double tk = k == o.frames - 1 ? period : period * k / (o.frames - 1);
    if (k > 0) {
      model::State next;
      result.status = step(&state, theta, tk, next, channels);
      if (!result.status.ok()) {
        t.times.conservativeResize(k);
        t.values.conservativeResize(k, t.values.cols());
        return result;
      }
      state = std::move(next);
    }
    t.times(k) = tk;
    t.values.row(k) = channels.transpose();
  }
  result.info.period = period;
  return result;
}

model::ModelBuild configure_external(const model::OptionReader& numerics) {
  if (!numerics.defined() || !numerics.is_map()) {
    numerics.fail("", "model external needs a numerics: section with command, output, parameters "
                      "and channels (docs/architecture.md s.9)");
  }
  numerics.check_keys({"command", "workdir", "parameter_format", "output", "timeout", "period",
                       "keep_workdirs", "parameters", "channels", "steppable", "step_command", "state",
                       "frames"});
  auto o = std::make_shared<ExternalOptions>();
  o->steppable = numerics.boolean("steppable", false);
  // A template and its program, both checked now.
  auto parse_command = [&numerics](const std::string& key, const std::vector<std::string>& placeholders,
                                   CommandTemplate& command, std::string& executable) {
    if (!numerics.has(key)) numerics.fail(key, "missing required key '" + key + "'");
    try {
      command = CommandTemplate::parse(numerics.text(key, ""), placeholders);
    } catch (const std::invalid_argument& e) {
      numerics.fail(key, e.what());
    }
    if (command.program_has_placeholder()) {
      numerics.fail(key, "the program (first word) may not hold a placeholder; it is checked before any run");
    }
    std::string why;
    const auto exe = resolve_executable(command.program(), numerics.base_directory(), why);
    if (!exe) numerics.fail(key, "cannot run the command: " + why);
    executable = *exe;
  };
  if (o->steppable) {
    for (const char* unused : {"command", "output"}) {
      if (numerics.has(unused)) {
        numerics.fail(unused, std::string("'") + unused + "' is not used with steppable: true (step_command "
                                                          "writes the state and the channels)");
      }
    }
    parse_command("step_command", kStepPlaceholders, o->step_command, o->step_executable);
    for (const char* required : {"state_in", "state_out", "t_end"}) {
      if (!o->step_command.uses(required)) {
        numerics.fail("step_command", std::string("the step command must pass {") + required + "} to the program");
      }
    }
    o->state = read_channel_table(numerics, "state");
    o->frames = numerics.integer("frames", o->frames);
    if (o->frames < 2) numerics.fail("frames", "expected frames >= 2");
  } else {
    for (const char* steppable_only : {"step_command", "state", "frames"}) {
      if (numerics.has(steppable_only)) {
        numerics.fail(steppable_only, std::string("'") + steppable_only + "' needs steppable: true");
      }
    }
    parse_command("command", kPlaceholders, o->command, o->executable);
  }
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
  if (!o->steppable) {
    if (!numerics.has("output")) numerics.fail("output", "missing required key 'output' (the CSV the program writes)");
    o->output = numerics.text("output", "");
    if (o->output.empty() || o->output.find('/') != std::string::npos || o->output == "." || o->output == "..") {
      numerics.fail("output", "expected a file name (no '/') inside the member directory, got '" + o->output + "'");
    }
    const std::string ext = fs::path(o->output).extension().string();
    if (ext != ".csv" && ext != ".h5") {
      numerics.fail("output", "expected a .csv file with `name [unit]` headers (app/io/observation_file.h) "
                              "or an .h5 file with datasets /time and /<channel>");
    }
    for (const char* reserved : {"stdout.txt", "stderr.txt", "params.json", "params.yaml", "state_in.csv", "state_out.csv"}) {
      if (o->output == reserved) numerics.fail("output", std::string("'") + reserved + "' is reserved for the runner");
    }
  }
  o->timeout = numerics.quantity("timeout", "s", o->timeout);
  if (!(o->timeout > 0.0)) numerics.fail("timeout", "expected a time limit > 0 s");
  o->keep_workdirs = numerics.boolean("keep_workdirs", false);
  model::ParameterSpace parameters = read_parameter_table(numerics);
  // steppable: run() samples one period, so it is required.
  o->period = read_period(numerics, parameters, o->steppable);
  o->channels = read_channel_table(numerics);
  o->parameter_units = declared_units(numerics, "parameters");
  o->channel_units = declared_units(numerics, "channels");
  std::shared_ptr<const ExternalOptions> shared = o;
  return model::ModelBuild(std::move(parameters), [shared](const model::ParameterSpace& p) -> std::unique_ptr<model::Simulator> {
    if (shared->steppable) return std::make_unique<ExternalSteppableSimulator>(shared, p);
    return std::make_unique<ExternalSimulator>(shared, p);
  });
}

}  // namespace sigmaheart::app::blackbox
