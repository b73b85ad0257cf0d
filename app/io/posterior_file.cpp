#include "app/io/posterior_file.h"

#include "app/io/hdf5_writer.h"
#include "model/regional_volume_shares.h"
#include "model/time_shift.h"

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

PosteriorFile read_posterior(const std::filesystem::path& file, const model::ParameterSpace& inner_space,
                             const std::string& model, const ConfigNode& at, model::SteppableSimulator* simulator) {
  const std::string where = "personalisation result '" + file.string() + "'";
  PosteriorFile out;
  out.space = inner_space;
  const model::ParameterSpace& space = out.space;
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
    // The volume-share wrapper the personalisation fitted with (shares: data).
    if (h5.exists("/setup/volume_shares")) {
      VolumeShareSetup v;
      v.shares = h5.read_vector("/setup/volume_shares");
      if (h5.exists("/setup/reference_shares")) v.reference = h5.read_vector("/setup/reference_shares");
      v.level_exponents = h5.has_attribute("/setup", "share_exponents")
                              ? h5.double_attribute("/setup", "share_exponents") > 0.5
                              : v.shares.size() == 17;  // personalize's rule before the attribute
      if (h5.has_attribute("/setup", "reference_volume")) v.reference_volume = h5.double_attribute("/setup", "reference_volume");
      out.volume_shares = v;
      try {
        out.space = model::RegionalVolumeShares::shares_space(inner_space, v.level_exponents);
      } catch (const std::invalid_argument& e) {
        at.fail(where + ": its volume shares do not fit " + model + ": " + e.what());
      }
    }
    // Every model parameter: by name, a zoned member from its zone parameter.
    const auto zones = zones_of(root, inner_space);
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
    if (out.volume_shares) {
      VolumeShareSetup& v = *out.volume_shares;
      if (v.reference.size() == 0) {  // a file from before /setup/reference_shares: the model's own
        if (!simulator) at.fail(where + " holds no /setup/reference_shares");
        try {
          v.reference = model::RegionalVolumeShares::reference_shares(*simulator, out.theta.head(inner_space.size()));
        } catch (const std::invalid_argument& e) {
          at.fail(where + ": " + e.what());
        }
      }
      if (v.level_exponents && !(v.reference_volume > 0.0)) {
        // Older files: V_ref matters only when a level exponent is not 0.
        const bool flat = out.theta.segment(inner_space.size(), 3).cwiseAbs().maxCoeff() == 0.0;
        if (!flat) at.fail(where + " holds share-law exponents but no /setup reference_volume: rerun personalize");
        v.reference_volume = 1.0;
      }
      if (v.shares.size() != v.reference.size())
        at.fail(where + ": /setup/volume_shares and /setup/reference_shares differ in size");
    }
    const bool calibrate = out.kind == "calibrate";
    if (calibrate) {
      out.converged = h5.double_attribute("/summary", "ok") > 0.5;
      out.status = h5.string_attribute("/summary", "status");
    } else {
      out.status = h5.string_attribute("/summary", "termination");
      out.converged = out.status == "completed";
      if (h5.has_attribute("/summary", "nis_mean") && h5.exists("/observations/names")) {
        out.nis_mean = h5.double_attribute("/summary", "nis_mean");
        out.nis_expected = static_cast<double>(h5.read_strings("/observations/names").size());
      }
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
    std::vector<Eigen::Index> keep;  // the posterior parameters a therapy propagates
    for (size_t j = 0; j < p.names.size(); ++j) {
      const std::string& name = p.names[j];
      if (name == model::TimeShift::kName && !space.index(name)) {
        out.marginalised.push_back(name);  // the observation clock, not the heart (header)
        continue;
      }
      keep.push_back(static_cast<Eigen::Index>(j));
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
    if (static_cast<size_t>(keep.size()) != p.names.size()) {
      std::vector<std::string> kept_names, kept_units;
      for (Eigen::Index j : keep) {
        kept_names.push_back(p.names[static_cast<size_t>(j)]);
        kept_units.push_back(p.units[static_cast<size_t>(j)]);
      }
      p.names = kept_names;
      p.units = kept_units;
      p.eta_mean = Eigen::VectorXd(p.eta_mean(keep));
      p.eta_covariance = Eigen::MatrixXd(p.eta_covariance(keep, keep));
    }
    if (p.names.empty()) at.fail(where + " estimated nothing a therapy depends on (only " + model::TimeShift::kName + ")");
    if (const std::string m = p.validate(); !m.empty()) at.fail(where + ": " + m);
  } catch (const InputError& e) {
    if (e.file() == at.location().file) throw;
    at.fail(where + ": " + e.message());
  }
  return out;
}

std::unique_ptr<model::SteppableSimulator> wrap_as_fitted(const PosteriorFile& file,
                                                          std::unique_ptr<model::SteppableSimulator> inner) {
  if (!file.volume_shares) return inner;
  const VolumeShareSetup& v = *file.volume_shares;
  return std::make_unique<model::RegionalVolumeShares>(std::move(inner), v.shares, v.reference, v.reference_volume,
                                                        v.level_exponents);
}

}  // namespace sigmaheart::app::io
