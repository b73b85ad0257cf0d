// prepare_personalize_model (app/personalize_setup.h): the simulator `personalize` runs (zones,
// volume shares of the data) and the model times of the frames (alignment on end-diastole).
#include "app/personalize_setup.h"

#include "app/errors.h"
#include "model/regional_volume_shares.h"
#include "model/time_shift.h"
#include "observers/beat.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace sigmaheart::app {

namespace {

// Frames where every column in `cols` of the file is present.
std::vector<Eigen::Index> complete_frames(const model::Trajectory& tr, const std::vector<int>& cols) {
  std::vector<Eigen::Index> out;
  for (Eigen::Index k = 0; k < tr.values.rows(); ++k) {
    bool ok = true;
    for (int c : cols) ok = ok && std::isfinite(tr.values(k, c));
    if (ok) out.push_back(k);
  }
  return out;
}

// The data's cavity volume per frame: the file's V_lv when it has one, else the sum of the
// assimilated regional volume columns (then every regional channel of the model must be observed).
struct DataVolume {
  std::vector<int> columns;  // file columns summed (one: V_lv)
  bool cavity = false;       // the file's V_lv
};
DataVolume data_volume(const PersonalizeProblem& problem, const std::vector<model::Channel>& channels,
                       const std::vector<int>& regional, const ConfigNode& at) {
  const model::Trajectory& tr = problem.file_curves.trajectory;
  DataVolume v;
  if (const auto lv = tr.channel_index("V_lv")) {
    v.columns = {*lv};
    v.cavity = true;
    return v;
  }
  for (int r : regional) {
    const auto c = tr.channel_index(channels[static_cast<size_t>(r)].name);
    if (!c) {
      at.fail("the file has no V_lv and no column " + channels[static_cast<size_t>(r)].name +
              ": the cavity volume of the data is unknown (give V_lv, or every segment's volume)");
    }
    v.columns.push_back(*c);
  }
  return v;
}

double column_sum(const model::Trajectory& tr, Eigen::Index k, const std::vector<int>& cols) {
  double s = 0.0;
  for (int c : cols) s += tr.values(k, c);
  return s;
}

// x(t) of a periodic beat sampled at `times` (from its onset, over one period), linear between
// samples, wrapped.
double periodic_at(const Eigen::VectorXd& times, const Eigen::VectorXd& x, double period, double t) {
  const Eigen::Index n = times.size();
  t = times(0) + std::fmod(std::fmod(t - times(0), period) + period, period);
  const double* first = times.data();
  const Eigen::Index hi = std::upper_bound(first, first + n, t) - first;  // 1..n
  if (hi >= n) {  // between the last sample and the first of the next beat
    const double t1 = times(0) + period, w = (t - times(n - 1)) / (t1 - times(n - 1));
    return (1.0 - w) * x(n - 1) + w * x(0);
  }
  const double w = (t - times(hi - 1)) / (times(hi) - times(hi - 1));
  return (1.0 - w) * x(hi - 1) + w * x(hi);
}

// The shift tau (model time in its beat = file time + tau) that best lays the model's cavity curve
// on the data's: least squares of v_k against a + b V(t_k + tau) (a, b free: the model at the prior
// mean need not eject as much as the data), tau within two frame spacings of the landmark shift
// tau0, on a 0.25 ms grid. The end-diastolic landmark alone is read at the frames' resolution (half
// a spacing, 14 ms at 30 frames of 0.85 s, enough for a NIS of 950 on a twin); the whole curve
// fixes the shift to a fraction of a millisecond.
double refine_shift(const model::Trajectory& beat, const Eigen::VectorXd& V, double period, const Eigen::VectorXd& t,
                    const Eigen::VectorXd& v, double tau0) {
  const Eigen::Index n = t.size();
  const double spacing = (t(n - 1) - t(0)) / static_cast<double>(n - 1);
  const Eigen::VectorXd vc = v.array() - v.mean();
  double best = tau0, best_ss = std::numeric_limits<double>::infinity();
  for (double tau = tau0 - 2.0 * spacing; tau <= tau0 + 2.0 * spacing; tau += 2.5e-4) {
    Eigen::VectorXd m(n);
    for (Eigen::Index k = 0; k < n; ++k) m(k) = periodic_at(beat.times, V, period, t(k) + tau);
    const Eigen::VectorXd mc = m.array() - m.mean();
    const double smm = mc.squaredNorm();
    const double ss = smm > 0.0 ? vc.squaredNorm() - std::pow(vc.dot(mc), 2) / smm : vc.squaredNorm();
    if (ss < best_ss) {
      best_ss = ss;
      best = tau;
    }
  }
  return best;
}

}  // namespace

std::unique_ptr<model::SteppableSimulator> prepare_personalize_model(
    const Config& config, PersonalizeProblem& problem, std::unique_ptr<model::SteppableSimulator> simulator) {
  if (!problem.zones.empty()) simulator = std::make_unique<model::ZonedSimulator>(std::move(simulator), problem.zones);
  if (!problem.shares_from_data && !problem.align_end_diastole) return simulator;

  const ConfigNode obs = config.file.root()["personalize"]["observations"];
  const ConfigNode at = problem.shares_from_data ? obs["shares"] : obs["align"];
  const std::vector<model::Channel> channels = simulator->channels();
  const std::vector<int> regional = model::RegionalVolumeShares::regional_channels(channels);
  if (regional.empty()) at.fail("model " + config.simulator.model + " has no regional volume channels");
  const model::Trajectory& tr = problem.file_curves.trajectory;
  const DataVolume dv = data_volume(problem, channels, regional, at);
  const std::vector<Eigen::Index> frames = complete_frames(tr, dv.columns);
  if (frames.size() < 3) at.fail("fewer than 3 frames have the data's cavity volume");

  // One periodic beat of the model at the prior mean (problem.space may append the share law's
  // exponents to the model's parameters: the model runs on the head).
  Eigen::VectorXd full = problem.filter.base_theta;
  for (int j = 0; j < problem.prior.size(); ++j) {
    full(problem.space.index_or_throw(problem.prior[j].name)) = problem.prior[j].to_theta(problem.prior[j].mean_eta);
  }
  const Eigen::VectorXd theta0 = full.head(simulator->parameters().size());
  const model::RunResult run = simulator->run(theta0);
  if (!run.status.ok()) {
    at.fail("the model's beat at the prior mean, needed for " +
            std::string(problem.shares_from_data ? "the volume shares" : "the alignment") + ", failed: " + run.status.message);
  }
  const model::Trajectory& beat = run.trajectory;
  Eigen::VectorXd V = Eigen::VectorXd::Zero(beat.times.size());
  for (int r : regional) V += beat.values.col(r);

  std::ostringstream note;
  note.precision(4);
  if (problem.shares_from_data) {
    // The data's shares over the beat, volume-weighted: sum_k V_p(k) / sum_k V(k) over the frames
    // (evenly spaced over one beat: the mean does not depend on where the frames start, and the
    // noise of one frame is not carried into every other, as a share from one frame would be).
    Eigen::Index ed = frames.front();
    double V_sum = 0.0;
    for (Eigen::Index k : frames) {
      V_sum += column_sum(tr, k, dv.columns);
      if (column_sum(tr, k, dv.columns) > column_sum(tr, ed, dv.columns)) ed = k;
    }
    const double V_ed = column_sum(tr, ed, dv.columns);
    const auto n = static_cast<Eigen::Index>(regional.size());
    Eigen::VectorXd d = Eigen::VectorXd::Constant(n, std::nan(""));
    double observed = 0.0;
    for (Eigen::Index p = 0; p < n; ++p) {
      const auto c = tr.channel_index(channels[static_cast<size_t>(regional[static_cast<size_t>(p)])].name);
      if (!c) continue;
      double sum = 0.0;
      for (Eigen::Index k : frames) sum += std::isfinite(tr.values(k, *c)) ? std::max(tr.values(k, *c), 0.0) : std::nan("");
      if (!std::isfinite(sum)) {
        at.fail("shares: data needs " + channels[static_cast<size_t>(regional[static_cast<size_t>(p)])].name +
                " in every frame that has the cavity volume");
      }
      d(p) = sum / V_sum;
      observed += d(p);
    }
    // Segments the file does not give hold what the cavity volume leaves (about 0 for the apical
    // cap of a 3D ventricle, docs/models.md s.5), shared equally.
    const double rest = std::max(0.0, 1.0 - observed);
    const auto missing = static_cast<double>((d.array().isNaN()).count());
    for (Eigen::Index p = 0; p < n; ++p) {
      if (std::isnan(d(p))) d(p) = rest / missing;
    }
    // omega_p = d_p / c_p, c_p the model's own beat-mean share over its reference one.
    const Eigen::VectorXd s = model::RegionalVolumeShares::reference_shares(*simulator, theta0);
    Eigen::VectorXd omega(n);
    for (Eigen::Index p = 0; p < n; ++p) {
      const double c = beat.values.col(regional[static_cast<size_t>(p)]).sum() / V.sum() / s(p);
      omega(p) = d(p) / c;
    }
    omega /= omega.sum();
    problem.volume_shares = omega;
    problem.reference_shares = s;
    problem.reference_volume = V_ed;
    simulator = std::make_unique<model::RegionalVolumeShares>(std::move(simulator), omega, s, V_ed,
                                                              problem.share_exponents);
    note << "volume shares from the data's beat (" << frames.size() << " frames" << (dv.cavity ? " of V_lv" : "")
         << ", end-diastole " << 1e6 * V_ed << " mL on line " << problem.file_curves.lines[static_cast<size_t>(ed)] << "): "
         << 100.0 * omega.minCoeff() << "-" << 100.0 * omega.maxCoeff() << " % per segment";
    problem.notes.push_back(note.str());
    note.str("");
  }
  if (problem.align_end_diastole) {
    Eigen::VectorXd t(static_cast<Eigen::Index>(frames.size())), v(static_cast<Eigen::Index>(frames.size()));
    for (size_t i = 0; i < frames.size(); ++i) {
      t(static_cast<Eigen::Index>(i)) = tr.times(frames[i]);
      v(static_cast<Eigen::Index>(i)) = column_sum(tr, frames[i], dv.columns);
    }
    observers::BeatOptions measured = observers::measured_frames();
    measured.period = problem.period;
    double t_data = 0.0, t_model = 0.0;
    if (auto st = observers::end_diastole_time(t, v, measured, t_data); !st.ok()) {
      at.fail("end-diastole of the data: " + st.message);
    }
    if (auto st = observers::end_diastole_time(beat.times, V, observers::BeatOptions{}, t_model); !st.ok()) {
      at.fail("end-diastole of the model's beat: " + st.message);
    }
    if (t_model > 0.5 * problem.period) t_model -= problem.period;  // just before the onset
    const double landmark = t_model - t_data;
    const double tau = refine_shift(beat, V, problem.period, t, v, landmark);
    problem.data_ed_time = t_model - tau;  // the file time that meets the model's end-diastole
    problem.model_ed_time = t_model;
    const double shift = problem.start_beats * problem.period + tau;
    problem.data.times = problem.file_times.array() + shift;
    if (!(problem.data.times(0) > 0.0)) {
      obs["start_beats"].fail("with the alignment the first frame falls at " + std::to_string(problem.data.times(0)) +
                              " s, before the model's initial state: raise start_beats");
    }
    note << "aligned on end-diastole: the data's at " << 1e3 * t_data << " ms (file time), the model's at "
         << 1e3 * t_model << " ms after its onset, refined on the cavity curve by " << 1e3 * (tau - landmark)
         << " ms; time in the model's beat = file time " << (tau >= 0 ? "+ " : "- ") << 1e3 * std::abs(tau) << " ms";
    problem.notes.push_back(note.str());
    // The shift that remains: t_shift, 0 unless estimated (model/time_shift.h).
    simulator = std::make_unique<model::TimeShift>(std::move(simulator));
  }
  return simulator;
}

}  // namespace sigmaheart::app
