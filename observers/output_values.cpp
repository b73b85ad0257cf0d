#include "observers/output_values.h"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace sigmaheart::observers {

std::vector<std::string> expand_output_name(const std::string& name, const std::vector<model::Channel>& channels) {
  for (const auto& c : channels) {
    if (c.name == name) return {name};
  }
  std::vector<std::string> out;
  for (int k = 0;; ++k) {
    const std::string element = name + "[" + std::to_string(k) + "]";
    if (std::none_of(channels.begin(), channels.end(), [&](const model::Channel& c) { return c.name == element; })) break;
    out.push_back(element);
  }
  return out;
}

OutputValues::OutputValues(const std::vector<std::string>& names, const std::vector<model::Channel>& channels) {
  if (names.empty()) throw std::invalid_argument("expected at least one model output");
  std::vector<std::string> known;
  for (const auto& c : channels) {
    known.push_back(c.name);
    const auto bracket = c.name.find('[');
    if (bracket != std::string::npos) known.push_back(c.name.substr(0, bracket));
  }
  std::set<std::string> seen;
  for (const auto& name : names) {
    const auto elements = expand_output_name(name, channels);
    if (elements.empty()) {
      std::string msg = "unknown model output '" + name + "'";
      const std::string close = model::closest_match(name, known);
      if (!close.empty()) msg += " (did you mean '" + close + "'?)";
      std::sort(known.begin(), known.end());
      known.erase(std::unique(known.begin(), known.end()), known.end());
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw std::invalid_argument(msg + "; the model's outputs: " + list);
    }
    for (const auto& e : elements) {
      if (!seen.insert(e).second) throw std::invalid_argument("model output '" + e + "' is named twice");
      outputs_.push_back(*std::find_if(channels.begin(), channels.end(), [&](const model::Channel& c) { return c.name == e; }));
    }
  }
}

std::vector<model::Channel> OutputValues::outputs() const { return outputs_; }

model::Status OutputValues::observe(const model::Trajectory& trajectory, Eigen::Ref<Eigen::VectorXd> z) const {
  if (auto s = check_z_size("model outputs", z.size(), outputs_.size()); !s.ok()) return s;
  if (trajectory.samples() != 1) {
    return model::Status::Error(model::StatusCode::kBadOutput,
                                "model outputs: the run returned " + std::to_string(trajectory.samples()) +
                                    " samples; named outputs are read from models that return single values "
                                    "(one sample), curves through `curves:` or `indices:`");
  }
  for (size_t i = 0; i < outputs_.size(); ++i) {
    const auto c = trajectory.channel_index(outputs_[i].name);
    if (!c) {
      return model::Status::Error(model::StatusCode::kBadOutput,
                                  "model outputs: the run returned no output '" + outputs_[i].name + "'");
    }
    z(static_cast<Eigen::Index>(i)) = trajectory.values(0, *c);
  }
  return model::Status::Ok();
}

}  // namespace sigmaheart::observers
