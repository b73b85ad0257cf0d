#include "estimation/specificity/specificity.h"

#include "estimation/ensemble.h"
#include "estimation/interrupt.h"

#include <atomic>

#include "estimation/enum_names.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <mutex>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation::specificity {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

std::string SpecificityOptions::validate() const {
  if (parameters.empty()) return "specificity study: no parameters named";
  if (!(lda_shrinkage >= 0.0 && lda_shrinkage <= 1.0)) {
    return "specificity study: lda_shrinkage must be in [0, 1]";
  }
  if (group_a.empty() != group_b.empty()) {
    return "specificity study: give both group_a and group_b, or neither";
  }
  if (!group_a.empty() && group_a == group_b) return "specificity study: group_a equals group_b";
  if (case_threads < 1) return "specificity study: case_threads must be >= 1";
  if (!(alpha > 0.0 && alpha < 1.0)) return "specificity study: alpha must be in (0, 1)";
  if (min_cases_per_group < 2) return "specificity study: min_cases_per_group must be >= 2";
  return {};
}

ClassifierResult loo_lda(const Eigen::MatrixXd& X, const std::vector<int>& label, double shrinkage) {
  ClassifierResult c;
  const int n = static_cast<int>(X.rows());
  const int d = static_cast<int>(X.cols());
  const int na = static_cast<int>(std::count(label.begin(), label.end(), 0));
  const int nb = n - na;
  c.total = n;
  // Every training set must keep a case of each group and a within-group degree of freedom.
  if (na < 2 || nb < 2) {
    c.message = "leave-one-out LDA needs at least 2 cases per group";
    return c;
  }
  c.predicted_label.assign(static_cast<size_t>(n), -1);
  for (int out = 0; out < n; ++out) {
    // Training set: every case but `out`, standardised by its own mean and sd.
    std::vector<int> train;
    for (int i = 0; i < n; ++i) {
      if (i != out) train.push_back(i);
    }
    const auto nt = static_cast<double>(train.size());
    Eigen::RowVectorXd mean = Eigen::RowVectorXd::Zero(d), sd = Eigen::RowVectorXd::Zero(d);
    for (int i : train) mean += X.row(i);
    mean /= nt;
    for (int i : train) sd += (X.row(i) - mean).cwiseAbs2();
    sd = (sd / (nt - 1.0)).cwiseSqrt();
    for (int j = 0; j < d; ++j) {
      if (!(sd(j) > 0)) sd(j) = 1.0;
    }
    auto standard = [&](int i) { return ((X.row(i) - mean).array() / sd.array()).matrix(); };
    Eigen::RowVectorXd mu[2] = {Eigen::RowVectorXd::Zero(d), Eigen::RowVectorXd::Zero(d)};
    int count[2] = {0, 0};
    for (int i : train) {
      mu[label[static_cast<size_t>(i)]] += standard(i);
      ++count[label[static_cast<size_t>(i)]];
    }
    mu[0] /= count[0];
    mu[1] /= count[1];
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(d, d);
    for (int i : train) {
      const Eigen::RowVectorXd r = standard(i) - mu[label[static_cast<size_t>(i)]];
      S += r.transpose() * r;
    }
    S /= (nt - 2.0);
    Eigen::MatrixXd Sl = (1.0 - shrinkage) * S;
    Sl.diagonal() += shrinkage * S.diagonal();
    // A feature with no within-group spread in the training set: a tiny ridge keeps S invertible.
    Sl.diagonal().array() += 1e-10 * std::max(1.0, S.diagonal().maxCoeff());
    const Eigen::VectorXd w = Sl.ldlt().solve((mu[0] - mu[1]).transpose());
    const double score = (standard(out) - 0.5 * (mu[0] + mu[1])).dot(w.transpose()) +
                         std::log(static_cast<double>(count[0]) / count[1]);
    const int predicted = score > 0 ? 0 : 1;
    c.predicted_label[static_cast<size_t>(out)] = predicted;
    if (predicted == label[static_cast<size_t>(out)]) ++c.correct;
  }
  c.valid = true;
  c.accuracy = static_cast<double>(c.correct) / n;
  return c;
}

SpecificityResult compare_groups(const std::vector<CaseEstimate>& cases,
                                 const SpecificityOptions& options) {
  if (const std::string m = options.validate(); !m.empty()) throw std::invalid_argument(m);
  const int p = static_cast<int>(options.parameters.size());
  SpecificityResult r;
  r.group_a = options.group_a;
  r.group_b = options.group_b;
  if (r.group_a.empty()) {
    std::vector<std::string> labels;
    for (const auto& c : cases) {
      if (std::find(labels.begin(), labels.end(), c.group) == labels.end()) labels.push_back(c.group);
    }
    if (labels.size() != 2) {
      throw std::invalid_argument("specificity study: the cohort has " +
                                  std::to_string(labels.size()) +
                                  " groups; name the two to compare (group_a, group_b)");
    }
    r.group_a = labels[0];
    r.group_b = labels[1];
  }
  std::vector<int> label;
  for (const auto& c : cases) {
    if (c.group != r.group_a && c.group != r.group_b) continue;
    if (c.mean.size() != p || c.sd.size() != p) {
      throw std::invalid_argument("specificity study: case '" + c.id + "' has " +
                                  std::to_string(c.mean.size()) + " means and " +
                                  std::to_string(c.sd.size()) + " sds for " + std::to_string(p) +
                                  " parameters");
    }
    if (!c.mean.allFinite()) {
      throw std::invalid_argument("specificity study: case '" + c.id + "' has non-finite means");
    }
    r.cases.push_back(c);
    label.push_back(c.group == r.group_a ? 0 : 1);
  }
  const int n = static_cast<int>(r.cases.size());
  const int na = static_cast<int>(std::count(label.begin(), label.end(), 0));
  if (na < options.min_cases_per_group || n - na < options.min_cases_per_group) {
    throw std::invalid_argument("specificity study: groups '" + r.group_a + "' (" +
                                std::to_string(na) + " calibrated cases) and '" + r.group_b + "' (" +
                                std::to_string(n - na) + " calibrated cases) need at least " +
                                std::to_string(options.min_cases_per_group) + " each");
  }
  r.adjust = options.adjust;
  r.alpha = options.alpha;

  Eigen::MatrixXd X(n, p), SD(n, p);
  for (int i = 0; i < n; ++i) {
    X.row(i) = r.cases[static_cast<size_t>(i)].mean.transpose();
    SD.row(i) = r.cases[static_cast<size_t>(i)].sd.transpose();
  }
  for (int j = 0; j < p; ++j) {
    Eigen::VectorXd xa(na), xb(n - na), sa(na), sb(n - na);
    for (int i = 0, ia = 0, ib = 0; i < n; ++i) {
      if (label[static_cast<size_t>(i)] == 0) {
        xa(ia) = X(i, j);
        sa(ia++) = SD(i, j);
      } else {
        xb(ib) = X(i, j);
        sb(ib++) = SD(i, j);
      }
    }
    ParameterSeparation s;
    s.name = options.parameters[static_cast<size_t>(j)];
    s.a = summarise(xa);
    s.b = summarise(xb);
    s.posterior_sd_a = sa.mean();
    s.posterior_sd_b = sb.mean();
    s.effect = effect_size(xb, xa);
    s.welch = welch_t_test(xb, xa);
    s.posterior_welch = posterior_welch_test(xb, sb, xa, sa);
    s.mann_whitney = mann_whitney(xb, xa);
    s.direction = auc_direction(s.mann_whitney.auc);
    r.parameters.push_back(s);
  }
  Eigen::VectorXd raw(p);
  for (int j = 0; j < p; ++j) raw(j) = r.parameters[static_cast<size_t>(j)].posterior_welch.p_value;
  const Eigen::VectorXd adjusted = adjust_p_values(raw, options.adjust);
  for (int j = 0; j < p; ++j) {
    auto& q = r.parameters[static_cast<size_t>(j)];
    q.p_adjusted = adjusted(j);
    q.different = q.p_adjusted < options.alpha;  // false for NaN
  }
  r.ranking.resize(static_cast<size_t>(p));
  std::iota(r.ranking.begin(), r.ranking.end(), 0);
  std::stable_sort(r.ranking.begin(), r.ranking.end(), [&](int i, int j) {
    const auto& a = r.parameters[static_cast<size_t>(i)];
    const auto& b = r.parameters[static_cast<size_t>(j)];
    const double pa = std::isnan(a.posterior_welch.p_value) ? 2.0 : a.posterior_welch.p_value;
    const double pb = std::isnan(b.posterior_welch.p_value) ? 2.0 : b.posterior_welch.p_value;
    if (pa != pb) return pa < pb;
    return std::abs(a.mann_whitney.auc - 0.5) > std::abs(b.mann_whitney.auc - 0.5);
  });

  r.classifier = loo_lda(X, label, options.lda_shrinkage);
  for (int l : r.classifier.predicted_label) r.classifier.predicted.push_back(l == 0 ? r.group_a : r.group_b);
  return r;
}

constexpr std::array<EnumName<SpecificityStatus>, 2> kSpecificityStatusNames{{
    {SpecificityStatus::kOk, "ok"}, {SpecificityStatus::kNoStatistics, "no-statistics"},
}};
const char* to_string(SpecificityStatus status) {
  return enum_to_string(kSpecificityStatusNames, status);
}

double CaseCalibration::relative_error_percent(const Eigen::VectorXd& scale) const {
  if (fitted.size() == 0 || fitted.size() != observed.size()) return kNaN;
  const bool scaled = scale.size() == observed.size();
  const Eigen::VectorXd f = scaled ? Eigen::VectorXd(fitted.cwiseProduct(scale)) : fitted;
  const Eigen::VectorXd o = scaled ? Eigen::VectorXd(observed.cwiseProduct(scale)) : observed;
  return 100.0 * ((f - o).cwiseAbs().array() / o.cwiseAbs().array().max(1e-300)).mean();
}

bool SpecificitySummary::case_ok(int i) const {
  const CaseCalibration& c = calibrations.at(static_cast<size_t>(i));
  return c.status.ok() && c.mean.size() == static_cast<Eigen::Index>(parameter_names.size());
}

std::string SpecificitySummary::case_status(int i) const {
  if (case_ok(i)) return "ok";
  const CaseCalibration& c = calibrations.at(static_cast<size_t>(i));
  return c.termination + ": " + (c.message.empty() ? c.status.message : c.message);
}

namespace {
template <class F>
Eigen::MatrixXd per_case(const SpecificitySummary& s, F row) {
  const auto n = static_cast<Eigen::Index>(s.cohort.size());
  const auto p = static_cast<Eigen::Index>(s.parameter_names.size());
  Eigen::MatrixXd out = Eigen::MatrixXd::Constant(n, p, kNaN);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::VectorXd v = row(static_cast<int>(i));
    if (v.size() == p) out.row(i) = v.transpose();
  }
  return out;
}
}  // namespace

Eigen::MatrixXd SpecificitySummary::means() const {
  return per_case(*this, [&](int i) {
    return case_ok(i) ? calibrations[static_cast<size_t>(i)].mean : Eigen::VectorXd();
  });
}
Eigen::MatrixXd SpecificitySummary::sds() const {
  return per_case(*this, [&](int i) {
    return case_ok(i) ? calibrations[static_cast<size_t>(i)].sd : Eigen::VectorXd();
  });
}
Eigen::MatrixXd SpecificitySummary::truths() const {
  return per_case(*this, [&](int i) { return cohort[static_cast<size_t>(i)].truth; });
}
bool SpecificitySummary::any_truth() const {
  const Eigen::MatrixXd t = truths();
  return (t.array() == t.array()).any();
}

namespace {
// The prototype of the ensemble over cases: its members run calibrations, not this model.
class NoForwardModel final : public ForwardModel {
 public:
  int input_size() const override { return 0; }
  std::vector<std::string> input_names() const override { return {}; }
  std::vector<model::Channel> outputs() const override { return {}; }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>&, Eigen::Ref<Eigen::VectorXd>) override {
    return model::Status::Error(model::StatusCode::kInvalidArgument, "not a forward model");
  }
  std::unique_ptr<ForwardModel> clone() const override { return std::make_unique<NoForwardModel>(); }
};
}  // namespace

SpecificitySummary run_specificity(const std::vector<CohortCase>& cases, const CalibrateFn& calibrate,
                                   const SpecificityOptions& options) {
  if (const std::string m = options.validate(); !m.empty()) throw std::invalid_argument(m);
  if (!calibrate) throw std::invalid_argument("specificity study: no calibration given");
  const int n = static_cast<int>(cases.size());
  std::vector<CaseCalibration> results(static_cast<size_t>(n));
  // The cases are the members of an ensemble over threads and ranks: each case's calibration is
  // packed into a row of doubles (NaN as kNaNCode, since a member's row must be finite) and its
  // texts into the member's status message, so that the pool can gather it and the checkpoint
  // record it.
  const int p = static_cast<int>(options.parameters.size());
  int m_obs = 0;
  for (const auto& c : cases) m_obs = std::max(m_obs, c.observations);
  const int width = 8 + 2 * p + 2 * m_obs;
  constexpr double kNaNCode = std::numeric_limits<double>::max();
  constexpr char kSep = '\x1f';
  auto pack = [&](const Eigen::VectorXd& v, Eigen::Ref<Eigen::VectorXd> out) {
    for (Eigen::Index j = 0; j < out.size(); ++j) {
      out(j) = j < v.size() && std::isfinite(v(j)) ? v(j) : kNaNCode;
    }
  };
  auto unpack = [&](Eigen::Index size, const Eigen::Ref<const Eigen::VectorXd>& in) {
    Eigen::VectorXd v(size);
    for (Eigen::Index j = 0; j < size; ++j) v(j) = in(j) == kNaNCode ? kNaN : in(j);
    return v;
  };
  EnsembleOptions eo;
  eo.backend = options.case_threads > 1 ? Backend::kThreads : Backend::kSerial;
  eo.threads = std::max(1, options.case_threads);
  eo.communicator = options.communicator;
  eo.checkpoint = options.checkpoint;
  eo.checkpoint_scope = "cases";
  std::mutex progress_mutex;
  if (options.progress) {
    eo.progress = [&](int done, int total) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      options.progress(done, total, std::string());
    };
  }
  const NoForwardModel no_model;
  Ensemble ensemble(no_model, eo);
  const EnsembleResult rows = ensemble.map_rows(
      n, width, [&](int i, int, Eigen::Ref<Eigen::VectorXd> row) -> model::Status {
        const CohortCase& c = cases[static_cast<size_t>(i)];
        CaseCalibration cal;
        try {
          cal = calibrate(c);
        } catch (const Interrupted&) {
          return model::Status::Error(model::StatusCode::kCancelled, "interrupted while calibrating");
        } catch (const std::exception& e) {
          cal.status = model::Status::Error(model::StatusCode::kInvalidArgument,
                                            std::string("calibration threw: ") + e.what());
        }
        row(0) = static_cast<double>(cal.status.code);
        row(1) = cal.iterations;
        row(2) = cal.simulations;
        row(3) = cal.seconds;
        row(4) = static_cast<double>(cal.mean.size());
        row(5) = static_cast<double>(cal.sd.size());
        row(6) = static_cast<double>(cal.observed.size());
        row(7) = static_cast<double>(cal.fitted.size());
        if (cal.mean.size() > p || cal.sd.size() > p || cal.fitted.size() > m_obs || cal.observed.size() > m_obs) {
          row(0) = static_cast<double>(model::StatusCode::kBadOutput);
          row.segment(4, 4).setZero();
        }
        pack(cal.mean, row.segment(8, p));
        pack(cal.sd, row.segment(8 + p, p));
        pack(cal.fitted, row.segment(8 + 2 * p, m_obs));
        pack(cal.observed, row.segment(8 + 2 * p + m_obs, m_obs));
        model::Status packed = model::Status::Ok();
        packed.message = cal.termination + kSep + cal.message + kSep + cal.status.message;
        return packed;
      });
  for (int i = 0; i < n; ++i) {
    CaseCalibration& cal = results[static_cast<size_t>(i)];
    const model::Status& st = rows.status[static_cast<size_t>(i)];
    const Eigen::VectorXd row = rows.Z.row(i).transpose();
    if (!st.ok()) {  // the case's packing itself failed (cannot happen short of a bug)
      cal.status = st;
      continue;
    }
    const std::string& text = st.message;
    const size_t a = text.find(kSep), b = text.find(kSep, a + 1);
    cal.termination = text.substr(0, a);
    cal.message = text.substr(a + 1, b - a - 1);
    cal.status = {static_cast<model::StatusCode>(static_cast<int>(row(0))), text.substr(b + 1)};
    cal.iterations = static_cast<int>(row(1));
    cal.simulations = static_cast<int>(row(2));
    cal.seconds = row(3);
    cal.mean = unpack(static_cast<Eigen::Index>(row(4)), row.segment(8, p));
    cal.sd = unpack(static_cast<Eigen::Index>(row(5)), row.segment(8 + p, p));
    cal.fitted = unpack(static_cast<Eigen::Index>(row(7)), row.segment(8 + 2 * p, m_obs));
    cal.observed = unpack(static_cast<Eigen::Index>(row(6)), row.segment(8 + 2 * p + m_obs, m_obs));
  }

  std::vector<CaseEstimate> estimates;
  std::vector<std::string> failed;
  std::vector<model::Status> failure;
  for (int i = 0; i < n; ++i) {
    const CohortCase& c = cases[static_cast<size_t>(i)];
    CaseCalibration& cal = results[static_cast<size_t>(i)];
    if (cal.status.ok() && !(cal.mean.allFinite() &&
                             cal.mean.size() == static_cast<Eigen::Index>(options.parameters.size()))) {
      cal.status = model::Status::Error(model::StatusCode::kBadOutput,
                                        "calibration returned non-finite or wrongly sized means");
    }
    if (cal.status.ok()) {
      if (cal.sd.size() != cal.mean.size()) cal.sd = Eigen::VectorXd::Constant(cal.mean.size(), kNaN);
      estimates.push_back({c.id, c.group, cal.mean, cal.sd});
    } else {
      failed.push_back(c.id);
      failure.push_back(cal.status);
    }
  }
  SpecificitySummary r;
  try {
    static_cast<SpecificityResult&>(r) = compare_groups(estimates, options);
  } catch (const std::invalid_argument& e) {
    r.status = SpecificityStatus::kNoStatistics;
    r.message = e.what();
  }
  if (r.ok() && r.cases.empty()) {
    r.status = SpecificityStatus::kNoStatistics;
    r.message = "no case was calibrated";
  }
  r.failed_cases = std::move(failed);
  r.failure_status = std::move(failure);
  r.parameter_names = options.parameters;
  r.cohort = cases;
  r.calibrations = std::move(results);
  return r;
}

std::string SpecificityResult::report() const {
  std::ostringstream s;
  const auto na = std::count_if(cases.begin(), cases.end(),
                                [&](const CaseEstimate& c) { return c.group == group_a; });
  s << "Specificity: '" << group_b << "' (" << cases.size() - static_cast<size_t>(na) << " cases) against '"
    << group_a << "' (" << na << " cases), p adjusted by " << to_string(adjust);
  if (!failed_cases.empty()) s << ", " << failed_cases.size() << " calibrations failed";
  s << "\n";
  for (size_t i = 0; i < failed_cases.size(); ++i) {
    s << "  failed: " << failed_cases[i] << ": " << failure_status[i].message << "\n";
  }
  s << std::setprecision(4);
  for (int j : ranking) {
    const ParameterSeparation& q = parameters[static_cast<size_t>(j)];
    s << "  " << std::setw(14) << std::left << q.name << std::right << " " << q.a.mean << " +- "
      << q.a.sd << " vs " << q.b.mean << " +- " << q.b.sd << "  g " << q.effect.hedges_g
      << "  Welch p " << q.welch.p_value << ", with posterior p " << q.posterior_welch.p_value
      << " (adjusted " << q.p_adjusted << (q.different ? ", different" : "") << ")  U " << q.mann_whitney.U
      << " (p " << q.mann_whitney.p_value << (q.mann_whitney.exact ? ", exact" : "") << ")  AUC(B > A) "
      << q.mann_whitney.auc << " " << q.direction << "\n";
  }
  if (classifier.valid) {
    s << "leave-one-out LDA accuracy " << classifier.accuracy << " (" << classifier.correct << "/"
      << classifier.total << ")\n";
  } else {
    s << "classifier: " << classifier.message << "\n";
  }
  return s.str();
}

}  // namespace sigmaheart::estimation::specificity
