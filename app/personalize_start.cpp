#include "app/personalize_start.h"

#include "app/errors.h"
#include "app/io/hdf5_writer.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>

namespace sigmaheart::app {

std::vector<int> per_segment_family(const model::ParameterSpace& space, const std::string& key) {
  std::set<std::string> families;
  for (const auto& p : space.all()) {
    if (p.regional()) families.insert(p.family);
  }
  for (const auto& f : families) {
    const std::vector<int> members = space.regional(f);
    bool stem = true;
    for (int i : members) stem = stem && space[i].name.rfind(key + "_", 0) == 0;
    if (f == key || stem) return members;
  }
  return {};
}

namespace {

// The transform the calibration used for one parameter, rebuilt from its kind, the model's bounds
// (a log prior on a bounded parameter became logit on [max(lower, 0), upper],
// bounded_by_the_model) and the stored pair (eta_mean, T(eta_mean)); nullopt when none of them
// reproduces the stored estimate to 1e-9.
std::optional<estimation::Transform> rebuild_transform(const std::string& kind, const model::Parameter& p,
                                                       double eta, double theta) {
  std::vector<estimation::Transform> candidates;
  estimation::Transform t;
  if (kind == "identity") {
    candidates.push_back(t);
  } else if (kind == "log") {
    t.kind = estimation::TransformKind::kLog;
    t.reference = theta / std::exp(eta);
    if (t.reference > 0 && std::isfinite(t.reference)) candidates.push_back(t);
  } else if (kind == "logit") {
    t.kind = estimation::TransformKind::kLogit;
    t.lower = p.lower;
    t.upper = p.upper;
    candidates.push_back(t);
    t.lower = std::max(p.lower, 0.0);
    candidates.push_back(t);
  }
  for (const auto& c : candidates) {
    if (std::abs(c.to_theta(eta) - theta) <= 1e-9 * std::max(std::abs(theta), 1e-300)) return c;
  }
  return std::nullopt;
}

// The model of the calibrate run: simulator.model of the config stored in /config.
std::string calibrated_model(const io::Hdf5Reader& h5, const ConfigNode& at) {
  if (!h5.exists("/config")) at.fail("the file holds no /config: not a sigmaheart results file");
  const ConfigFile cfg = ConfigFile::parse(h5.read_text("/config"), "the calibrate config in the file");
  const ConfigNode model = cfg.root()["simulator"]["model"];
  if (!model.defined()) at.fail("the calibrate config stored in the file names no simulator model");
  return model.as<std::string>();
}

}  // namespace

CalibratedStart parse_calibrated_start(const ConfigNode& start, const std::filesystem::path& base,
                                       const model::ParameterSpace& space, const std::string& model) {
  if (!start.is_map()) start.fail("expected {file: CALIBRATE.h5, globals: estimate | hold}");
  start.check_keys({"file", "globals"});
  const ConfigNode file = start.require_child("file");
  CalibratedStart out;
  out.file = input_file(file, file.as<std::string>(), base, "calibrate result");
  out.estimate_globals =
      !start.has("globals") || start["globals"].as_choice({"estimate", "hold"}) == "estimate";
  const io::Hdf5Reader h5(out.file);
  if (!h5.has_attribute("/", "kind") || h5.string_attribute("/", "kind") != "calibrate") {
    file.fail("'" + out.file.string() + "' is not a calibrate result (its kind is '" +
              (h5.has_attribute("/", "kind") ? h5.string_attribute("/", "kind") : std::string("none")) + "')");
  }
  out.model = calibrated_model(h5, file);
  const auto names = h5.read_strings("/estimate/names");
  const auto kinds = h5.read_strings("/estimate/transform");
  const Eigen::VectorXd eta = h5.read_vector("/estimate/eta_mean");
  const Eigen::VectorXd theta = h5.read_vector("/estimate/mean");
  const Eigen::MatrixXd P = h5.read_matrix("/estimate/eta_covariance");
  const auto n = static_cast<Eigen::Index>(names.size());
  if (kinds.size() != names.size() || eta.size() != n || theta.size() != n || P.rows() != n || P.cols() != n) {
    file.fail("the /estimate group of '" + out.file.string() + "' is inconsistent (sizes differ)");
  }
  std::vector<Eigen::Index> kept;
  std::ostringstream unmatched;
  for (Eigen::Index j = 0; j < n; ++j) {
    const std::string& name = names[static_cast<size_t>(j)];
    if (const auto i = space.index(name)) {
      const model::Parameter& p = space[*i];
      const auto t = rebuild_transform(kinds[static_cast<size_t>(j)], p, eta(j), theta(j));
      if (!t) {
        file.fail("the " + kinds[static_cast<size_t>(j)] + " transform of '" + name +
                  "' in the calibrate result does not reproduce its estimate within the bounds of " + model);
      }
      estimation::PriorParameter q;
      q.name = name;
      q.unit = p.unit;
      q.transform = *t;
      q.lower = p.lower;
      q.upper = p.upper;
      q.mean_eta = eta(j);
      q.std_eta = std::sqrt(P(j, j));
      q.theta_nominal = theta(j);
      out.globals.parameters.push_back(std::move(q));
      kept.push_back(j);
    } else if (!per_segment_family(space, name).empty()) {
      out.family_centres.emplace_back(name, theta(j));
    } else {
      unmatched << (unmatched.tellp() > 0 ? ", " : "") << name;
    }
  }
  if (unmatched.tellp() > 0) {
    file.fail("the calibrate result (model " + out.model + ") estimates " + unmatched.str() +
              ", which model " + model + " does not have (neither by name nor as a per-segment family)");
  }
  const auto k = static_cast<Eigen::Index>(kept.size());
  if (k > 0) {
    Eigen::MatrixXd C(k, k);
    for (Eigen::Index a = 0; a < k; ++a) {
      for (Eigen::Index b = 0; b < k; ++b) C(a, b) = P(kept[a], kept[b]) / std::sqrt(P(kept[a], kept[a]) * P(kept[b], kept[b]));
    }
    out.globals.correlation = C;
  }
  if (const std::string e = out.globals.validate(); !e.empty()) {
    file.fail("the posterior in '" + out.file.string() + "' cannot be a prior: " + e);
  }
  return out;
}

}  // namespace sigmaheart::app
