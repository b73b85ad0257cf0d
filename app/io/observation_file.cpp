#include "app/io/observation_file.h"

#include "app/io/display.h"

#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "model/units.h"
#include "observers/observation_builder.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <fstream>
#include <algorithm>
#include <istream>
#include <ostream>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::app::io {
namespace {

constexpr const char* kHeaderExample = "'time [ms], V_lv [mL], P_lv [mmHg]'";

struct Field {
  std::string text;  // trimmed
  int column = 1;    // 1-based character column of its first non-blank character
};

// Splits a line (comment already removed) at commas; columns are 1-based.
std::vector<Field> split(const std::string& line) {
  std::vector<Field> out;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    const size_t end = comma == std::string::npos ? line.size() : comma;
    size_t b = start;
    while (b < end && (line[b] == ' ' || line[b] == '\t')) ++b;
    size_t e = end;
    while (e > b && (line[e - 1] == ' ' || line[e - 1] == '\t')) --e;
    out.push_back({line.substr(b, e - b), static_cast<int>(b) + 1});
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

bool blank(const std::string& s) { return s.find_first_not_of(" \t") == std::string::npos; }

std::string lower(std::string s) {
  for (auto& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return s;
}

// A missing value in a data column: an empty cell, NaN in any case, NA or N/A.
bool missing_value(const std::string& text) {
  const std::string l = lower(text);
  return l.empty() || l == "nan" || l == "+nan" || l == "-nan" || l == "na" || l == "n/a";
}

// "t", "time" in any case: the time column.
bool time_name(const std::string& name) {
  const std::string l = lower(name);
  return l == "t" || l == "time";
}

// A header field split into name and unit: "V_lv [mL]", "V_lv (mL)", or for time only a unit
// suffix "t_ms", "time_s". unit_offset: position of the unit's first character in the field.
struct HeaderField {
  std::string name, unit;
  size_t unit_offset = 0;
  bool has_unit = false;
};

HeaderField split_header(const std::string& text) {
  HeaderField h;
  for (const auto& [open_ch, close_ch] : {std::pair{'[', ']'}, std::pair{'(', ')'}}) {
    const auto open = text.find(open_ch);
    if (open == std::string::npos || text.back() != close_ch) continue;
    if (text.find(close_ch) != text.size() - 1) continue;  // one pair, closing the field
    h.name = text.substr(0, open);
    while (!h.name.empty() && (h.name.back() == ' ' || h.name.back() == '\t')) h.name.pop_back();
    h.unit = text.substr(open + 1, text.size() - open - 2);
    size_t lead = 0;
    while (lead < h.unit.size() && h.unit[lead] == ' ') ++lead;
    h.unit.erase(0, lead);
    while (!h.unit.empty() && h.unit.back() == ' ') h.unit.pop_back();
    h.unit_offset = open + 1 + lead;
    h.has_unit = true;
    return h;
  }
  h.name = text;
  if (const auto us = text.rfind('_'); us != std::string::npos && time_name(text.substr(0, us))) {
    const std::string unit = lower(text.substr(us + 1));
    if (unit == "s" || unit == "ms") {
      h.name = text.substr(0, us);
      h.unit = unit;
      h.unit_offset = us + 1;
      h.has_unit = true;
    }
  }
  return h;
}

// The SI unit a column named `name` must measure, or "" when any known unit will do.
std::string required_dimension(const std::string& name) {
  if (name.rfind("V_", 0) == 0) return "m^3";
  if (name.rfind("P_", 0) == 0) return "Pa";
  return {};
}


}  // namespace

ObservationCurves parse_observation_csv(std::istream& in, const std::string& source,
                                        const ColumnMapping& rename) {
  auto fail = [&](int line, int column, const std::string& msg) -> InputError {
    return InputError(source, line, column, msg);
  };

  struct Column {
    std::string name, unit;
    std::string written;  // the header field as written, for messages
    double factor = 1.0;
    std::string si_unit;
  };
  std::vector<Column> columns;
  std::vector<std::vector<double>> rows;
  std::vector<int> row_lines;
  int header_line = 0;
  int last_line = 0;
  int line_no = 0;
  std::string raw;
  while (std::getline(in, raw)) {
    ++line_no;
    if (line_no == 1 && raw.rfind("\xEF\xBB\xBF", 0) == 0) raw.erase(0, 3);  // UTF-8 BOM
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    const std::string line = raw.substr(0, raw.find('#'));
    if (blank(line)) continue;
    last_line = line_no;
    const auto fields = split(line);

    if (columns.empty()) {  // the header
      header_line = line_no;
      for (size_t f = 0; f < fields.size(); ++f) {
        const auto& [text, col] = fields[f];
        const std::string where = "header field " + std::to_string(f + 1);
        const HeaderField h = split_header(text);
        if (!h.has_unit) {
          if (f == 0 && !time_name(h.name)) {
            throw fail(line_no, col, "missing header: expected 'name [unit]' columns such as " +
                                         std::string(kHeaderExample) + ", got '" + text + "'");
          }
          throw fail(line_no, col, "expected 'name [unit]' or 'name (unit)' in " + where +
                                       ", got '" + text + "'");
        }
        Column c;
        c.written = text;
        c.name = h.name;
        c.unit = h.unit;
        const int unit_col = col + static_cast<int>(h.unit_offset);
        if (c.name.empty() || c.name.find_first_of(" \t") != std::string::npos) {
          throw fail(line_no, col, "expected a column name without spaces before the unit in " +
                                       where + ", got '" + c.name + "'");
        }
        if (const auto it = rename.find(c.name); it != rename.end()) c.name = it->second;
        const auto conv = model::units::to_si(c.unit);
        if (!conv) {
          throw fail(line_no, unit_col,
                     "column '" + c.name + "': " + observers::unknown_unit_message(c.unit));
        }
        c.factor = conv->factor;
        c.si_unit = conv->si_unit;
        if (f == 0) {
          if (!time_name(c.name) || c.si_unit != "s") {
            throw fail(line_no, col, "expected the first column to be the time: 'time [ms]' or 'time [s]' "
                                     "(also 't', any case, units in brackets or parentheses), got '" + text + "'");
          }
          c.name = "time";
        } else {
          const std::string dim = required_dimension(c.name);
          if (!dim.empty() && dim != c.si_unit) {
            throw fail(line_no, unit_col,
                       "column '" + c.name + "' expects a unit of " + dim + " (" +
                           (dim == "m^3" ? "mL, L, m^3" : "mmHg, kPa, Pa") + "), got '" + c.unit + "'");
          }
          if (time_name(c.name)) {
            throw fail(line_no, col, "column '" + c.name + "': only the first column is the time");
          }
          for (size_t g = 0; g < columns.size(); ++g) {
            if (columns[g].name == c.name) {
              throw fail(line_no, col, "column '" + c.name + "' appears twice (fields " +
                                           std::to_string(g + 1) + " and " + std::to_string(f + 1) + ")");
            }
          }
        }
        columns.push_back(c);
      }
      if (columns.size() < 2) {
        throw fail(line_no, 1, "expected at least one data column after 'time', e.g. " +
                                   std::string(kHeaderExample));
      }
      for (const auto& [from, to] : rename) {
        bool found = false;
        for (size_t f = 0; f < fields.size(); ++f) {
          found = found || split_header(fields[f].text).name == from;
        }
        if (!found) {
          throw fail(line_no, 1, "column mapping '" + from + "' -> '" + to +
                                     "': the header has no column '" + from + "'");
        }
      }
      continue;
    }

    if (fields.size() != columns.size()) {
      throw fail(line_no, fields.back().column,
                 "ragged row: expected " + std::to_string(columns.size()) +
                     " fields (as in the header on line " + std::to_string(header_line) + "), got " +
                     std::to_string(fields.size()));
    }
    std::vector<double> row(columns.size());
    for (size_t f = 0; f < fields.size(); ++f) {
      const auto& [text, col] = fields[f];
      const std::string what = "field " + std::to_string(f + 1) + " ('" + columns[f].written + "')";
      if (missing_value(text)) {
        if (f == 0) {
          throw fail(line_no, col, what + ": expected a time, got " +
                                       (text.empty() ? std::string("an empty field")
                                                     : "'" + text + "'") +
                                       " (only data cells may be missing)");
        }
        row[f] = std::numeric_limits<double>::quiet_NaN();  // a missing value, kept as NaN
        continue;
      }
      const char* b = text.data();
      const char* e = text.data() + text.size();
      if (*b == '+') ++b;
      double v = 0.0;
      const auto r = std::from_chars(b, e, v);
      if (r.ec != std::errc() || r.ptr != e) {
        throw fail(line_no, col, what + ": expected a number, got '" + text + "'");
      }
      if (!std::isfinite(v)) {
        throw fail(line_no, col, what + ": expected a finite number, got '" + text + "'");
      }
      row[f] = v * columns[f].factor;
    }
    if (!rows.empty() && !(row[0] > rows.back()[0])) {
      std::ostringstream s;
      s << "field 1 ('time'): expected times to increase strictly, got " << fields[0].text << " "
        << columns[0].unit << " after " << format_exact(rows.back()[0] / columns[0].factor) << " "
        << columns[0].unit;
      throw fail(line_no, fields[0].column, s.str());
    }
    rows.push_back(std::move(row));
    row_lines.push_back(line_no);
  }
  if (in.bad()) throw fail(0, 0, "read error");
  if (columns.empty()) {
    throw fail(1, 1,
               "missing header: expected a first line such as " + std::string(kHeaderExample));
  }
  if (static_cast<int>(rows.size()) < kMinFrames) {
    throw fail(last_line, 1, "too few rows: expected at least " + std::to_string(kMinFrames) +
                                 " data rows (one per frame), got " + std::to_string(rows.size()));
  }

  ObservationCurves out;
  out.time_unit = columns[0].unit;
  out.lines = std::move(row_lines);
  const auto n = static_cast<Eigen::Index>(rows.size());
  const auto m = static_cast<Eigen::Index>(columns.size()) - 1;
  out.trajectory.times.resize(n);
  out.trajectory.values.resize(n, m);
  for (Eigen::Index k = 0; k < n; ++k) {
    out.trajectory.times(k) = rows[static_cast<size_t>(k)][0];
    for (Eigen::Index c = 0; c < m; ++c) {
      const double v = rows[static_cast<size_t>(k)][static_cast<size_t>(c) + 1];
      out.trajectory.values(k, c) = v;
      if (std::isnan(v)) ++out.missing;
    }
  }
  for (size_t c = 1; c < columns.size(); ++c) {
    out.trajectory.channels.push_back(
        {columns[c].name, columns[c].si_unit, "read from " + source + " in " + columns[c].unit});
    out.display_units.push_back(columns[c].unit);
  }
  return out;
}

ActivationMap parse_activation_map_csv(std::istream& in, const std::string& source) {
  ActivationMap out;
  double factor = 0.0;  // the time column's unit in s
  int line_no = 0, last_line = 0;
  std::string raw;
  while (std::getline(in, raw)) {
    ++line_no;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    const std::string line = raw.substr(0, raw.find('#'));
    if (blank(line)) continue;
    last_line = line_no;
    const auto fields = split(line);
    if (fields.size() != 2) {
      throw InputError(source, line_no, fields.back().column,
                       "expected two fields, 'segment, time [ms]', got " + std::to_string(fields.size()));
    }
    if (factor == 0.0) {  // the header
      const HeaderField h = split_header(fields[1].text);
      const auto conv = h.has_unit ? model::units::to_si(h.unit) : std::nullopt;
      if (lower(fields[0].text) != "segment" || !conv || conv->si_unit != "s") {
        throw InputError(source, line_no, fields[0].column,
                         "expected the header 'segment, time [ms]' (a time unit in brackets), got '" + line + "'");
      }
      factor = conv->factor;
      continue;
    }
    int segment = 0;
    double t = 0.0;
    const auto& a = fields[0].text;
    const auto& b = fields[1].text;
    const auto ra = std::from_chars(a.data(), a.data() + a.size(), segment);
    if (ra.ec != std::errc() || ra.ptr != a.data() + a.size() || segment < 1) {
      throw InputError(source, line_no, fields[0].column, "expected a segment number >= 1, got '" + a + "'");
    }
    const auto rb = std::from_chars(b.data(), b.data() + b.size(), t);
    if (rb.ec != std::errc() || rb.ptr != b.data() + b.size() || !std::isfinite(t)) {
      throw InputError(source, line_no, fields[1].column, "expected a time, got '" + b + "'");
    }
    for (size_t i = 0; i < out.segments.size(); ++i) {
      if (out.segments[i] == segment) {
        throw InputError(source, line_no, fields[0].column,
                         "segment " + a + " is listed twice (also on line " + std::to_string(out.lines[i]) + ")");
      }
    }
    out.segments.push_back(segment);
    out.times.push_back(t * factor);
    out.lines.push_back(line_no);
  }
  if (factor == 0.0 || out.segments.empty()) {
    throw InputError(source, std::max(last_line, 1), 1, "expected a header 'segment, time [ms]' and one row per segment");
  }
  return out;
}

ActivationMap read_activation_map_csv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, 0, "cannot open the activation map");
  return parse_activation_map_csv(in, path.string());
}

ObservationCurves read_observation_csv(const std::filesystem::path& path,
                                       const ColumnMapping& rename) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, 0, "cannot open the observation file");
  return parse_observation_csv(in, path.string(), rename);
}

PresentFrames drop_missing_frames(const ObservationCurves& curves,
                                  const std::vector<std::string>& channels,
                                  const std::string& source) {
  const model::Trajectory& t = curves.trajectory;
  const Eigen::Index n = t.times.size();
  PresentFrames out;
  out.period = n > 1 ? (t.times(n - 1) - t.times(0)) * static_cast<double>(n) /
                           static_cast<double>(n - 1)
                     : 0.0;
  std::vector<Eigen::Index> cols;
  for (size_t c = 0; c < t.channels.size(); ++c) {
    const bool used = channels.empty() ||
                      std::find(channels.begin(), channels.end(), t.channels[c].name) != channels.end();
    if (used) cols.push_back(static_cast<Eigen::Index>(c));
  }
  std::vector<Eigen::Index> keep;
  for (Eigen::Index k = 0; k < n; ++k) {
    bool present = true;
    for (const auto c : cols) present = present && !std::isnan(t.values(k, c));
    const int line = static_cast<size_t>(k) < curves.lines.size() ? curves.lines[static_cast<size_t>(k)] : 0;
    if (present) {
      keep.push_back(k);
    } else {
      out.dropped.push_back(line);
    }
  }
  if (static_cast<int>(keep.size()) < kMinFrames) {
    throw InputError(source, 0, 0,
                     std::to_string(keep.size()) + " frames have every value needed (" +
                         std::to_string(out.dropped.size()) + " have a missing one): expected at least " +
                         std::to_string(kMinFrames));
  }
  out.curves.time_unit = curves.time_unit;
  out.curves.display_units = curves.display_units;
  out.curves.trajectory.channels = t.channels;
  const auto m = static_cast<Eigen::Index>(keep.size());
  out.curves.trajectory.times.resize(m);
  out.curves.trajectory.values.resize(m, t.values.cols());
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::Index k = keep[static_cast<size_t>(i)];
    out.curves.trajectory.times(i) = t.times(k);
    out.curves.trajectory.values.row(i) = t.values.row(k);
    if (static_cast<size_t>(k) < curves.lines.size()) {
      out.curves.lines.push_back(curves.lines[static_cast<size_t>(k)]);
    }
    for (Eigen::Index c = 0; c < t.values.cols(); ++c) {
      if (std::isnan(t.values(k, c))) ++out.curves.missing;  // in channels not used
    }
  }
  return out;
}

void check_frames_in_one_beat(const ObservationCurves& curves, double period,
                              const std::string& source, bool times_after_trigger) {
  const Eigen::VectorXd& t = curves.trajectory.times;
  if (t.size() == 0 || !(period > 0.0)) return;
  const double origin = times_after_trigger ? std::min(0.0, t(0)) : t(0);
  double spacing = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 1; k < t.size(); ++k) spacing = std::min(spacing, t(k) - t(k - 1));
  const double last_allowed = origin + period + 0.5 * (std::isfinite(spacing) ? spacing : 0.0);
  const double unit = model::units::to_si(curves.time_unit) ? model::units::to_si(curves.time_unit)->factor : 1.0;
  for (Eigen::Index k = 0; k < t.size(); ++k) {
    if (t(k) <= last_allowed) continue;
    const auto i = static_cast<size_t>(k);
    std::ostringstream s;
    s << "frame " << k << " at t = " << format_exact(t(k) / unit) << " " << curves.time_unit
      << " lies beyond one beat: the simulated period is " << format_exact(period / unit) << " "
      << curves.time_unit << " (parameter 'period'), and the frames must lie within one beat ("
      << (times_after_trigger ? "times after the ECG trigger, from " : "from the first frame, ")
      << format_exact(origin / unit) << " " << curves.time_unit
      << "); give one beat of frames, or set the period to the measured one";
    throw InputError(source, i < curves.lines.size() ? curves.lines[i] : 0, 1, s.str());
  }
}

void write_observation_csv(const std::filesystem::path& path, const model::Trajectory& trajectory,
                           const std::string& time_unit,
                           const std::vector<std::string>& display_units,
                           const std::vector<std::string>& comment) {
  const auto m = trajectory.channels.size();
  if (!display_units.empty() && display_units.size() != m) {
    throw std::invalid_argument("observation file: " + std::to_string(display_units.size()) +
                                " display units for " + std::to_string(m) + " channels");
  }
  if (trajectory.values.rows() != trajectory.times.size() ||
      trajectory.values.cols() != static_cast<Eigen::Index>(m)) {
    throw std::invalid_argument("observation file: trajectory values do not match times and channels");
  }
  const auto time_conv = model::units::to_si(time_unit);
  if (!time_conv || time_conv->si_unit != "s") {
    throw std::invalid_argument("observation file: time unit must be 'ms' or 's', got '" + time_unit + "'");
  }
  std::vector<double> scale(m);  // value_display = value_stored * scale
  std::vector<std::string> units(m);
  for (size_t c = 0; c < m; ++c) {
    const auto& ch = trajectory.channels[c];
    const std::string stored = ch.unit.empty() ? (required_dimension(ch.name).empty() ? "1" : required_dimension(ch.name)) : ch.unit;
    units[c] = display_units.empty() || display_units[c].empty() ? stored : display_units[c];
    if (ch.name.empty() || ch.name.find_first_of(" \t,#[]") != std::string::npos) {
      throw std::invalid_argument("observation file: channel name '" + ch.name + "' cannot be a column name");
    }
    scale[c] = model::units::convert(1.0, stored, units[c]);  // throws on unknown / mismatched
  }
  write_text_file(path, [&](std::ostream& out) {
    for (const auto& line : comment) out << "# " << line << '\n';
    out << "time [" << time_unit << "]";
    for (size_t c = 0; c < m; ++c) out << ", " << trajectory.channels[c].name << " [" << units[c] << "]";
    out << '\n';
    for (Eigen::Index k = 0; k < trajectory.times.size(); ++k) {
      out << format_exact(trajectory.times(k) / time_conv->factor);
      for (size_t c = 0; c < m; ++c) {
        out << ", " << format_exact(trajectory.values(k, static_cast<Eigen::Index>(c)) * scale[c]);
      }
      out << '\n';
    }
  });
}

}  // namespace sigmaheart::app::io
