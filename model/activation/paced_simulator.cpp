#include "model/activation/paced_simulator.h"

#include <cmath>
#include <stdexcept>

namespace sigmaheart::model::activation {

namespace {

std::vector<int> segment_times_of(const Simulator& s) {
  const std::vector<int> td = s.parameters().regional("activation_time");
  if (static_cast<int>(td.size()) != kSegments) return {};
  for (int k = 0; k < kSegments; ++k)
    if (s.parameters()[td[static_cast<size_t>(k)]].segment != k + 1) return {};
  return td;
}

}  // namespace

std::string PacedSimulator::route(const Simulator& base) {
  if (base.clone()->pacing() != nullptr) return "pacing capability";
  if (!segment_times_of(base).empty()) return "segment activation times";
  return {};
}

PacedSimulator::PacedSimulator(const Simulator& base, PacingPlan plan, GraphPacingOptions graph)
    : base_(base.clone()), plan_(std::move(plan)), graph_(graph) {
  if (const std::string m = plan_.validate(); !m.empty()) throw std::invalid_argument("pacing plan: " + m);
  if (Pacing* p = base_->pacing()) {
    outcome_ = p->pace(plan_);
    return;
  }
  td_ = segment_times_of(*base_);
  if (td_.empty())
    throw std::invalid_argument("model '" + base_->name() +
                                "' cannot be paced: it has no pacing capability and no activation time per AHA "
                                "segment (17 parameters tagged activation_time)");
  if (const std::string m = graph_.validate(); !m.empty()) throw std::invalid_argument(m);
  const auto period = base_->parameters().find("period");
  if (!period) throw std::invalid_argument("model '" + base_->name() + "' has no parameter tagged period");
  period_ = *period;
  // Checks the plan's sites on the graph now (a lead given as a point is bad input here).
  paced_theta(base_->parameters().nominal(), &outcome_);
}

PacedSimulator::PacedSimulator(const PacedSimulator& other, int)
    : base_(other.base_->clone()), plan_(other.plan_), graph_(other.graph_), td_(other.td_), period_(other.period_),
      outcome_(other.outcome_) {}

std::unique_ptr<Simulator> PacedSimulator::clone() const {
  return std::unique_ptr<Simulator>(new PacedSimulator(*this, 0));
}

Eigen::VectorXd PacedSimulator::paced_theta(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                            PacingOutcome* outcome) const {
  Eigen::VectorXd out = theta;
  if (td_.empty()) {
    if (outcome) *outcome = outcome_;
    return out;
  }
  std::array<double, kSegments> intrinsic{};
  for (int k = 0; k < kSegments; ++k) intrinsic[static_cast<size_t>(k)] = theta(td_[static_cast<size_t>(k)]);
  const PacingOutcome o = segment_pacing(plan_, intrinsic, graph_);
  const double period = theta(period_);
  for (int k = 0; k < kSegments; ++k) {
    const double t = o.segment_times[static_cast<size_t>(k)];
    // A segment nothing reaches is left infinite: run() refuses it.
    out(td_[static_cast<size_t>(k)]) = std::isfinite(t) ? t - std::floor(t / period) * period : t;
  }
  if (outcome) *outcome = o;
  return out;
}

RunResult PacedSimulator::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  return run_warm(theta, Eigen::VectorXd(), nullptr);
}

RunResult PacedSimulator::run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta, const Eigen::VectorXd& from,
                                   Eigen::VectorXd* produce) {
  if (td_.empty()) return base_->run_warm(theta, from, produce);
  RunResult r;
  auto refuse = [&](std::string message) {
    if (produce) *produce = Eigen::VectorXd::Zero(warm_start_size());
    r.status = Status::Error(StatusCode::kInvalidArgument, std::move(message));
    return r;
  };
  if (theta.size() != base_->parameters().size()) return refuse("theta has the wrong size for " + base_->name());
  const Eigen::VectorXd paced = paced_theta(theta, &outcome_);
  for (int k = 0; k < kSegments; ++k)
    if (!std::isfinite(paced(td_[static_cast<size_t>(k)])))
      return refuse("segment " + std::to_string(k + 1) +
                    " is never activated: scar encloses it and no intrinsic wave reaches it");
  return base_->run_warm(paced, from, produce);
}

}  // namespace sigmaheart::model::activation
