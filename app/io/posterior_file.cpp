#include "app/io/posterior_file.h"

#include "app/io/hdf5_writer.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

namespace sigmaheart::app::io {

namespace {

// The `bounds:` the result's own config gave parameter `name` (calibrate: estimate.<name>;
// personalize: personalize.estimate.<family>), if any.
std::optional<std::pair<double, double>> config_bounds(const ConfigNode& root, const std::string& name,
                                                       const std::string& family) {
  std::vector<ConfigNode> nodes;
  if (root["estimate"].is_map()) nodes.push_back(root["estimate"][name]);
  if (root["personalize"].is_map() && root["personalize"]["estimate"].is_map() && !family.empty())
    nodes.push_back(root["personalize"]["estimate"][family]);
  for (const ConfigNode& node : nodes) {
    if (!node.is_map() || !node.has("bounds")) continue;
    try {
      const auto b = node["bounds"].as<std::vector<double>>();
      if (b.size() == 2) return std::pair{b[0], b[1]};
    } catch (const InputError&) {  // a bound with a unit: not a candidate
    }
  }
  return std::nullopt;
}

// The zones of a personalisation by zones: zone parameter name -> the model indices it sets.
std::map<std::string, std::vector<int>> zones_of(const ConfigNode& root, const model::ParameterSpace& space) {
  std::map<std::string, std::vector<int>> out;
  if (!root["personalize"].is_map() || !root["personalize"]["estimate"].is_map()) return out;
  const ConfigNode est = root["personalize"]["estimate"];
  for (const auto& key : est.keys()) {
    const ConfigNode node = est[key];
    if (!node.is_map() || !node.has("zones") || !node["zones"].is_map()) continue;
    // The key names a family tag or the common stem of its parameters (sigma0 for sigma0_XX).
    std::string family = key;
    if (space.regional(key).empty())
      for (int i = 0; i < space.size(); ++i)
        if (space[i].regional() && space[i].name.rfind(key + "_", 0) == 0) family = space[i].family;
    for (const auto& zone : node["zones"].keys()) {
      std::vector<int>& members = out[key + "_" + zone];
      const ConfigNode list = node["zones"][zone];
      for (size_t k = 0; k < list.size(); ++k)
        if (const auto i = space.find(family, list[k].as<int>())) members.push_back(*i);
    }
  }
  return out;
}

bool reproduces(const estimation::Transform& t, double eta, double value) {
  if (!t.validate().empty()) return false;
  return std::abs(t.to_theta(eta) - value) <= 1e-9 * std::max(std::abs(value), 1e-300);
}

}  // namespace

PosteriorFile read_posterior(const std::filesystem::path& file, const model::ParameterSpace& space,
                             const std::string& model, const ConfigNode& at) {
  const std::string where = "personalisation result '" + file.string() + "'";
  PosteriorFile out;
  try {
    const Hdf5Reader h5(file);
    out.kind = h5.has_attribute("/", "kind") ? h5.string_attribute("/", "kind") : "";
    if (out.kind != "calibrate" && out.kind != "personalize")
      at.fail(where + " is " + (out.kind.empty() ? "not a sigmaheart result" : "a '" + out.kind + "' result") +
              "; expected the HDF5 file of calibrate or personalize");
    const ConfigFile config = ConfigFile::parse(h5.string_attribute("/", "config"), file.string() + ":/config");
    const ConfigNode root = config.root();
    out.model = root["simulator"]["model"].as<std::string>();
    if (out.model != model)
      at.fail(where + " personalised model '" + out.model + "'; this config's simulator is '" + model +
              "' (a personalisation applies to the model it was made with)");
    // Every model parameter: by name, a zoned member from its zone parameter.
    const auto zones = zones_of(root, space);
    const auto names = h5.read_strings("/parameters/names");
    const Eigen::VectorXd values = h5.read_vector("/parameters/values");
    auto value_of = [&](const std::string& name) -> std::optional<double> {
      for (size_t k = 0; k < names.size(); ++k)
        if (names[k] == name) return values(static_cast<Eigen::Index>(k));
      return std::nullopt;
    };
    out.theta.resize(space.size());
    for (int i = 0; i < space.size(); ++i) {
      std::optional<double> v = value_of(space[i].name);
      for (const auto& [zone, members] : zones)
        if (std::find(members.begin(), members.end(), i) != members.end()) v = value_of(zone);
      if (!v)
        at.fail(where + " has no value of " + model + "'s parameter '" + space[i].name +
                "' (its simulator numerics differ, e.g. the number of patches)");
      out.theta(i) = *v;
    }
    const bool calibrate = out.kind == "calibrate";
    if (calibrate) {
      out.converged = h5.double_attribute("/summary", "ok") > 0.5;
      out.status = h5.string_attribute("/summary", "status");
    } else {
      out.status = h5.string_attribute("/summary", "termination");
      out.converged = out.status == "completed";
    }
    if (!h5.exists("/estimate/eta_covariance"))
      at.fail(where + " holds no posterior (the estimator produced no estimate: " + out.status + ")");
    estimation::Posterior& p = out.posterior;
    p.names = h5.read_strings("/estimate/names");
    p.units = h5.read_strings("/estimate/units");
    p.eta_mean = h5.read_vector(calibrate ? "/estimate/eta_mean" : "/estimate/eta");
    p.eta_covariance = h5.read_matrix("/estimate/eta_covariance");
    const Eigen::VectorXd value = h5.read_vector(calibrate ? "/estimate/mean" : "/estimate/value");
    const auto kinds = h5.read_strings("/estimate/transform");
    const auto families = calibrate ? std::vector<std::string>(p.names.size()) : h5.read_strings("/estimate/family");
    if (kinds.size() != p.names.size() || value.size() != p.eta_mean.size() ||
        static_cast<size_t>(p.eta_mean.size()) != p.names.size())
      at.fail(where + ": the sizes of /estimate disagree");
    for (size_t j = 0; j < p.names.size(); ++j) {
      const std::string& name = p.names[j];
      const auto zone = zones.find(name);
      const auto i = space.index(name);
      if (zone == zones.end() && !i)
        at.fail(where + ": estimated parameter '" + name + "' is not a parameter of " + model + " nor a zone");
      out.estimated.push_back(zone != zones.end() ? zone->second : std::vector<int>{*i});
      const int first = out.estimated.back().front();
      const double eta = p.eta_mean(static_cast<Eigen::Index>(j)), v = value(static_cast<Eigen::Index>(j));
      estimation::Transform t;
      t.kind = *estimation::parse_transform_kind(kinds[j]);
      std::vector<estimation::Transform> candidates;
      if (t.kind == estimation::TransformKind::kLog) {
        t.reference = v / std::exp(eta);
        candidates.push_back(t);
      } else if (t.kind == estimation::TransformKind::kLogit) {
        const model::Parameter& q = space[first];
        std::vector<std::pair<double, double>> bounds;
        if (const auto b = config_bounds(root, name, families[j])) bounds.push_back(*b);
        bounds.push_back({std::max(q.lower, 0.0), q.upper});
        bounds.push_back({q.lower, q.upper});
        for (const auto& [lo, hi] : bounds) {
          t.lower = lo;
          t.upper = hi;
          candidates.push_back(t);
        }
      } else {
        candidates.push_back(t);
      }
      bool found = false;
      for (const auto& c : candidates)
        if (!found && reproduces(c, eta, v)) {
          p.transforms.push_back(c);
          found = true;
        }
      if (!found)
        at.fail(where + ": the " + kinds[j] + " transform of '" + name +
                "' cannot be rebuilt (no bounds reproduce its estimate from its eta)");
    }
    if (const std::string m = p.validate(); !m.empty()) at.fail(where + ": " + m);
  } catch (const InputError& e) {
    if (e.file() == at.location().file) throw;
    at.fail(where + ": " + e.message());
  }
  return out;
}

}  // namespace sigmaheart::app::io
