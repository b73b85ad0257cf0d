#include "observers/observer.h"

#include <Eigen/Cholesky>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::observers {

std::string ObservationSet::validate() const {
  const auto n = static_cast<size_t>(y.size());
  if (names.size() != n || units.size() != n) {
    std::ostringstream s;
    s << "observation set: " << n << " values but " << names.size() << " names and "
      << units.size() << " units";
    return s.str();
  }
  if (R.rows() != y.size() || R.cols() != y.size()) {
    return "observation set: noise covariance has the wrong size";
  }
  for (Eigen::Index i = 0; i < y.size(); ++i) {
    if (!std::isfinite(y(i))) return "observation '" + names[static_cast<size_t>(i)] + "' is not finite";
  }
  if (!(R - R.transpose()).isZero(1e-12 * (1.0 + R.cwiseAbs().maxCoeff()))) {
    return "observation set: noise covariance is not symmetric";
  }
  Eigen::LLT<Eigen::MatrixXd> llt(R);
  if (llt.info() != Eigen::Success) {
    return "observation set: noise covariance is not positive definite (every noise level must be > 0)";
  }
  return {};
}

ObservationSet ObservationSet::select(const std::vector<std::string>& wanted) const {
  std::vector<Eigen::Index> idx;
  for (const auto& w : wanted) {
    Eigen::Index found = -1;
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i] == w) found = static_cast<Eigen::Index>(i);
    }
    if (found < 0) {
      std::string msg = "no observation named '" + w + "'";
      const auto guess = model::closest_match(w, names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      throw std::invalid_argument(msg);
    }
    idx.push_back(found);
  }
  ObservationSet out;
  const auto m = static_cast<Eigen::Index>(idx.size());
  out.y.resize(m);
  out.R.resize(m, m);
  for (Eigen::Index a = 0; a < m; ++a) {
    const auto ia = static_cast<size_t>(idx[static_cast<size_t>(a)]);
    out.names.push_back(names[ia]);
    out.units.push_back(units[ia]);
    if (display_units.size() == names.size()) out.display_units.push_back(display_units[ia]);
    out.y(a) = y(idx[static_cast<size_t>(a)]);
    for (Eigen::Index b = 0; b < m; ++b) out.R(a, b) = R(idx[static_cast<size_t>(a)], idx[static_cast<size_t>(b)]);
  }
  out.frame_times = frame_times;
  return out;
}

}  // namespace sigmaheart::observers
