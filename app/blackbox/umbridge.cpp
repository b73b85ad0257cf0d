#include "app/blackbox/umbridge.h"

#include "app/blackbox/umbridge_wire.h"

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

Eigen::VectorXd sample_times(const model::Trajectory& trajectory, int frames) {
  if (frames < 2) throw std::invalid_argument("sample_times: frames must be >= 2");
  const int n = trajectory.samples();
  if (n < 1) throw std::invalid_argument("sample_times: empty trajectory");
  const double t0 = trajectory.times(0), t1 = trajectory.times(n - 1);
  Eigen::VectorXd t(frames);
  for (int k = 0; k < frames; ++k) t(k) = k == frames - 1 ? t1 : t0 + k * (t1 - t0) / (frames - 1);
  return t;
}

namespace wire {

json error_body(const std::string& type, const std::string& message) {
  return json{{"error", {{"type", type}, {"message", message}}}};
}

std::string status_message(const model::Status& status) {
  return std::string(model::to_string(status.code)) + ": " + status.message;
}

std::optional<StatusCode> parse_status_message(const std::string& message, std::string& rest) {
  const auto colon = message.find(": ");
  if (colon == std::string::npos) return std::nullopt;
  const std::string name = message.substr(0, colon);
  for (StatusCode c : {StatusCode::kDiverged, StatusCode::kNonFinite, StatusCode::kOutOfBounds,
                       StatusCode::kNotPeriodic, StatusCode::kProcessFailed, StatusCode::kTimeout,
                       StatusCode::kBadOutput, StatusCode::kInvalidArgument}) {
    if (name == model::to_string(c)) {
      rest = message.substr(colon + 2);
      return c;
    }
  }
  return std::nullopt;
}

json parse_body(const std::string& text, std::string& problem) {
  problem.clear();
  json body;
  try {
    body = json::parse(text);
  } catch (const json::parse_error& e) {
    problem = "the body is not valid JSON (at byte " + std::to_string(e.byte) + ")";
    for (const char* word : {"NaN", "nan", "Infinity", "inf"}) {
      if (text.find(word) != std::string::npos) {
        problem += "; it contains '" + std::string(word) +
                   "', which JSON cannot carry: send finite numbers only";
        break;
      }
    }
    return json();
  }
  if (!body.is_object()) problem = "the body is JSON but not an object ({...})";
  return body;
}

}  // namespace wire

}  // namespace sigmaheart::app::blackbox
