#include "estimation/sensitivity/oat.h"

#include "estimation/enum_names.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>

namespace sigmaheart::estimation::sensitivity {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

SIGMAHEART_ENUM_TEXT(OatMode, parse_oat_mode,
    {OatMode::kRange, "range"}, {OatMode::kRelative, "relative"})

std::string OatOptions::validate() const {
  if (mode == OatMode::kRelative && !(relative_change > 0.0 && relative_change < 1.0)) {
    return "one-at-a-time study: relative_change must be in (0, 1)";
  }
  return ensemble.validate();
}

Eigen::MatrixXd oat_design(const Prior& prior, const OatOptions& options) {
  const int p = prior.size();
  const Eigen::VectorXd nominal = prior.nominal_theta();
  Eigen::MatrixXd thetas = nominal.transpose().replicate(2 * p + 1, 1);
  for (int i = 0; i < p; ++i) {
    const PriorParameter& r = prior[i];
    const bool rel = options.mode == OatMode::kRelative;
    thetas(1 + 2 * i, i) = rel ? r.theta_nominal * (1.0 - options.relative_change) : r.lower;
    thetas(2 + 2 * i, i) = rel ? r.theta_nominal * (1.0 + options.relative_change) : r.upper;
  }
  return thetas;
}

DesignLayout oat_layout(const std::vector<std::string>& names) {
  DesignLayout l;
  l.description = "2p + 1 runs: nominal, then low and high of each parameter in order";
  l.block.push_back("nominal");
  l.row.push_back(0);
  for (const auto& n : names) {
    l.block.push_back("low " + n);
    l.row.push_back(0);
    l.block.push_back("high " + n);
    l.row.push_back(0);
  }
  return l;
}

OatSummary run_oat(const ForwardModel& model, const Prior& prior, const OatOptions& options) {
  check_study_inputs("one-at-a-time study", prior, model, options.validate());
  const int p = prior.size();

  OatSummary r;
  r.parameters = prior.names();
  r.outputs = output_names(model);
  const int m = static_cast<int>(r.outputs.size());
  r.thetas = oat_design(prior, options);
  r.layout = oat_layout(r.parameters);
  r.theta_nominal = r.thetas.row(0).transpose();
  r.theta_low.resize(p);
  r.theta_high.resize(p);
  for (int i = 0; i < p; ++i) {
    r.theta_low(i) = r.thetas(1 + 2 * i, i);
    r.theta_high(i) = r.thetas(2 + 2 * i, i);
  }
  evaluate_design(model, options.ensemble, r);

  r.z_nominal = r.Z.row(0).transpose();
  r.z_low.resize(p, m);
  r.z_high.resize(p, m);
  for (int i = 0; i < p; ++i) {
    r.z_low.row(i) = r.Z.row(1 + 2 * i);
    r.z_high.row(i) = r.Z.row(2 + 2 * i);
  }
  if (!r.failed_runs.empty() && r.failed_runs.front().run == 0) {
    r.status = StudyStatus::kFailedNominal;
    r.message = "the nominal run failed: " + r.failed_runs.front().status.message;
    r.delta_low = r.delta_high = r.normalised = r.swing = Eigen::MatrixXd::Constant(p, m, kNaN);
    return r;
  }
  if (!r.failed_runs.empty()) {
    r.message = std::to_string(r.failed_runs.size()) +
                " runs failed; their parameters' entries are NaN";
  }
  r.delta_low = r.z_low.rowwise() - r.z_nominal.transpose();
  r.delta_high = r.z_high.rowwise() - r.z_nominal.transpose();
  r.swing = (r.delta_high - r.delta_low).cwiseAbs();
  r.normalised.resize(p, m);
  for (int i = 0; i < p; ++i) {
    const double dtheta = (r.theta_high(i) - r.theta_low(i)) / r.theta_nominal(i);
    for (int k = 0; k < m; ++k) {
      const double dz = (r.z_high(i, k) - r.z_low(i, k)) / r.z_nominal(k);
      r.normalised(i, k) = (r.theta_nominal(i) != 0.0 && r.z_nominal(k) != 0.0) ? dz / dtheta : kNaN;
    }
  }
  return r;
}

std::vector<TornadoBar> OatSummary::tornado(int output) const {
  if (output < 0 || output >= static_cast<int>(outputs.size())) {
    throw std::out_of_range("OatSummary::tornado: no output " + std::to_string(output));
  }
  std::vector<TornadoBar> bars;
  if (!ok()) return bars;
  for (int i = 0; i < static_cast<int>(parameters.size()); ++i) {
    TornadoBar b;
    b.parameter = i;
    b.delta_low = delta_low(i, output);
    b.delta_high = delta_high(i, output);
    b.swing = swing(i, output);
    bars.push_back(b);
  }
  std::stable_sort(bars.begin(), bars.end(), [](const TornadoBar& a, const TornadoBar& b) {
    const bool fa = std::isfinite(a.swing), fb = std::isfinite(b.swing);
    if (fa != fb) return fa;
    return fa && a.swing > b.swing;
  });
  return bars;
}

std::string OatSummary::report() const {
  std::ostringstream s;
  s << "One-at-a-time study: " << parameters.size() << " parameters, " << outputs.size()
    << " outputs, " << thetas.rows() << " runs\n";
  if (!message.empty()) s << message << "\n";
  for (const FailedRun& f : failed_runs) {
    s << "  failed: " << f.block << ": " << model::to_string(f.status.code) << " "
      << f.status.message << "\n";
  }
  if (!ok()) return s.str() + "INVALID: no deltas\n";
  s << std::setprecision(4);
  for (int k = 0; k < static_cast<int>(outputs.size()); ++k) {
    s << "output '" << outputs[static_cast<size_t>(k)] << "' (nominal " << z_nominal(k)
      << "): tornado\n";
    for (const TornadoBar& b : tornado(k)) {
      s << "  " << std::setw(14) << std::left << parameters[static_cast<size_t>(b.parameter)]
        << std::right << " low " << std::setw(11) << b.delta_low << "  high " << std::setw(11)
        << b.delta_high << "  elasticity " << normalised(b.parameter, k) << "\n";
    }
  }
  return s.str();
}

}  // namespace sigmaheart::estimation::sensitivity
