#include "app/io/results.h"

#include "app/io/atomic_file.h"
#include "model/units.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <iomanip>
#include <optional>
#include <sstream>
#include <type_traits>

namespace sigmaheart::app::io {

std::string version() { return SIGMAHEART_VERSION; }
// Defined in the build directory's git_describe.cpp (cmake/git_describe.cmake), at every build.
extern const char* const kGitDescribe;
std::string git_describe() { return kGitDescribe; }

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::ostringstream s;
  s << std::put_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  return s.str();
}

namespace {
const char* const kUnitsConvention =
    "curves and indices in clinical units (mL, mmHg, mL/s, mmHg/s, s); parameters "
    "in the SI unit of their model; each dataset's 'units' attribute names its unit";

// Calls field(key, value) for every provenance field, in the order of the JSON summary; one list
// for the JSON object and the HDF5 root attributes so that the two cannot drift apart. The value
// is a std::string, an int, a std::vector<std::string> or the optional seed; end_utc is passed in
// (the JSON writes the time now when it is not set yet).
template <class Field>
void for_each_provenance_field(const Provenance& p, const std::string& end_utc, Field&& field) {
  field("sigmaheart_version", version());
  field("git_describe", git_describe());
  field("kind", p.kind);
  field("name", p.name);
  field("config_file", p.config_file);
  field("config", p.config_text);
  field("overrides", p.overrides);
  field("command_line", p.command_line);
  field("seed", p.seed);
  field("start_utc", p.start_utc);
  field("end_utc", end_utc);
  field("threads", p.threads);
  field("ranks", p.ranks);
  field("units_convention", std::string(kUnitsConvention));
}

template <class T>
constexpr bool kIsSeed = std::is_same_v<std::decay_t<T>, std::optional<std::uint64_t>>;
}  // namespace

nlohmann::ordered_json provenance_json(const Provenance& p) {
  nlohmann::ordered_json j;
  for_each_provenance_field(p, p.end_utc.empty() ? utc_now() : p.end_utc, [&](const char* key, const auto& value) {
    if constexpr (kIsSeed<decltype(value)>) {
      j[key] = value ? nlohmann::ordered_json(*value) : nlohmann::ordered_json(nullptr);
    } else {
      j[key] = value;
    }
  });
  return j;
}

std::string padded_number(long long value, long long largest) {
  const auto width = std::to_string(std::max(largest, 0LL)).size();
  std::string s = std::to_string(value);
  if (value >= 0 && s.size() < width) s.insert(0, width - s.size(), '0');
  return s;
}

void write_provenance(Hdf5Writer& out, const Provenance& p) {
  for_each_provenance_field(p, p.end_utc, [&](const char* key, const auto& value) {
    if constexpr (kIsSeed<decltype(value)>) {
      if (value) out.set_attribute("/", key, static_cast<std::int64_t>(*value));  // no attribute without one
    } else {
      out.set_attribute("/", key, value);
    }
  });
  out.write_text("/config", p.config_text);
  out.set_attribute("/config", "file", p.config_file);
}

void write_parameters(Hdf5Writer& out, const std::string& group,
                      const model::ParameterSpace& space,
                      const Eigen::Ref<const Eigen::VectorXd>& values) {
  std::vector<std::string> units, docs;
  Eigen::VectorXd lower(space.size()), upper(space.size());
  for (int i = 0; i < space.size(); ++i) {
    units.push_back(space[i].unit);
    docs.push_back(space[i].doc);
    lower(i) = space[i].lower;
    upper(i) = space[i].upper;
  }
  out.create_group(group);
  out.write_strings(group + "/names", space.names());
  out.write_strings(group + "/units", units);
  out.write_strings(group + "/doc", docs);
  out.write_vector(group + "/values", values);
  out.write_vector(group + "/lower", lower);
  out.write_vector(group + "/upper", upper);
  const std::string note = "per parameter, see " + group + "/units";
  for (const char* name : {"values", "lower", "upper"}) {
    out.set_attribute(group + "/" + name, "units", note);
  }
}

void write_trajectory(Hdf5Writer& out, const std::string& group, const model::Trajectory& t) {
  out.create_group(group);
  out.write_vector(group + "/time", t.times, "s");
  std::vector<std::string> names;
  for (size_t c = 0; c < t.channels.size(); ++c) {
    const auto& ch = t.channels[c];
    const DisplayUnit d = display_unit(ch.unit);
    const std::string path = group + "/" + ch.name;
    out.write_vector(path, t.values.col(static_cast<Eigen::Index>(c)) * d.from_si, d.unit);
    if (!ch.doc.empty()) out.set_attribute(path, "doc", ch.doc);
    out.attach_scale(path, 0, group + "/time", "time");  // H5DS: the time axis of the curve
    names.push_back(ch.name);
  }
  out.set_attribute(group, "channels", names);
}

void write_trajectory_csv(const std::filesystem::path& path, const model::Trajectory& t) {
  std::vector<DisplayUnit> units;
  for (const auto& ch : t.channels) units.push_back(display_unit(ch.unit));
  write_text_file(path, [&](std::ostream& s) {
    s << "time [s]";
    for (size_t c = 0; c < t.channels.size(); ++c) {
      s << "," << t.channels[c].name << " [" << units[c].unit << "]";
    }
    s << "\n" << std::setprecision(10);
    for (int k = 0; k < t.samples(); ++k) {
      s << t.times(k);
      for (size_t c = 0; c < t.channels.size(); ++c) {
        s << "," << t.values(k, static_cast<Eigen::Index>(c)) * units[c].from_si;
      }
      s << "\n";
    }
  });
}

void write_indicators(Hdf5Writer& out, const std::string& group,
                      const std::vector<Indicator>& indicators) {
  out.create_group(group);
  std::vector<std::string> names;
  for (const auto& i : indicators) names.push_back(i.name);
  out.set_attribute(group, "names", names);
  for (const auto& i : indicators) {
    out.set_attribute(group, i.name, i.value);
    out.set_attribute(group, i.name + ".units", i.unit);
  }
}

void write_indicators_json(const std::filesystem::path& path,
                           const std::vector<Indicator>& indicators, const Provenance* provenance,
                           const std::string& status) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  if (!status.empty()) j["status"] = status;
  for (const auto& i : indicators) {
    // JSON has no NaN: a value that could not be computed is null.
    j[i.name] = {{"value", std::isfinite(i.value) ? nlohmann::ordered_json(i.value) : nullptr},
                 {"unit", i.unit}};
  }
  if (provenance) j["provenance"] = provenance_json(*provenance);
  write_text_file(path, [&](std::ostream& s) { s << j.dump(2) << "\n"; });
}

std::string format_indicators(const std::vector<Indicator>& indicators) {
  size_t name_w = 0, unit_w = 0;
  for (const auto& i : indicators) {
    name_w = std::max(name_w, i.name.size());
    unit_w = std::max(unit_w, i.unit.size());
  }
  std::ostringstream s;
  for (const auto& i : indicators) {
    std::ostringstream v;
    const double a = std::abs(i.value);
    if (i.value == std::round(i.value) && a < 1e6) {
      v << static_cast<long long>(i.value);
    } else if (i.value == 0.0 || (a >= 0.01 && a < 1e6)) {
      v << std::fixed << std::setprecision(a >= 100 ? 1 : a >= 1 ? 2 : 4) << i.value;
    } else {
      v << std::setprecision(3) << i.value;
    }
    s << "  " << std::left << std::setw(static_cast<int>(name_w)) << i.name << "  " << std::right
      << std::setw(10) << v.str() << " " << std::left << std::setw(static_cast<int>(unit_w))
      << i.unit;
    if (!i.doc.empty()) s << "  " << i.doc;
    s << "\n";
  }
  return s.str();
}

}  // namespace sigmaheart::app::io
