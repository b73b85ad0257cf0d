#include "model/periodic_shooting.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

namespace sigmaheart::model {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// y = A v, false when it could not be evaluated (a beat failed, or the beat budget is spent).
using Apply = std::function<bool(const VectorXd& v, VectorXd& y)>;

// GMRES(k) from z = 0 for A z = b (Saad & Schultz 1986, algorithm 4: Arnoldi by modified
// Gram-Schmidt, here with one re-orthogonalisation pass, and the small least-squares problem
// min |beta e1 - H y| solved by QR). Stops at |b - A z| <= rtol |b|, at a breakdown (exact in the
// space), or after kmax vectors (the best z in the space). nullopt when `apply` failed.
std::optional<VectorXd> gmres(const Apply& apply, const VectorXd& b, int kmax, double rtol) {
  const Eigen::Index n = b.size();
  const double beta = b.norm();
  if (beta == 0.0) return VectorXd::Zero(n);
  const int k_max = static_cast<int>(std::min<Eigen::Index>(kmax, n));
  MatrixXd Q(n, k_max + 1);
  MatrixXd H = MatrixXd::Zero(k_max + 1, k_max);
  Q.col(0) = b / beta;
  VectorXd y;
  for (int k = 0; k < k_max; ++k) {
    VectorXd w;
    if (!apply(Q.col(k), w)) return std::nullopt;
    const double w_norm = w.norm();
    for (int pass = 0; pass < 2; ++pass) {
      for (int j = 0; j <= k; ++j) {
        const double h = Q.col(j).dot(w);
        H(j, k) += h;
        w -= h * Q.col(j);
      }
    }
    H(k + 1, k) = w.norm();
    const MatrixXd Hk = H.topLeftCorner(k + 2, k + 1);
    VectorXd rhs = VectorXd::Zero(k + 2);
    rhs(0) = beta;
    y = Hk.colPivHouseholderQr().solve(rhs);
    const bool breakdown = H(k + 1, k) <= 1e-13 * std::max(w_norm, 1.0);
    if (breakdown || (rhs - Hk * y).norm() <= rtol * beta) return VectorXd(Q.leftCols(k + 1) * y);
    Q.col(k + 1) = w / H(k + 1, k);
  }
  return VectorXd(Q.leftCols(k_max) * y);
}

double max_abs(const VectorXd& v) { return v.size() == 0 ? 0.0 : v.cwiseAbs().maxCoeff(); }

// The scale of each entry: its peak over the beat; an entry that is 0 all beat keeps scale 1.
VectorXd entry_scales(const BeatOutcome& b, Eigen::Index n) {
  VectorXd s = b.peak.size() == n && b.peak.allFinite() ? b.peak : VectorXd::Ones(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(s(i) > 0.0)) s(i) = 1.0;
    s(i) = std::max(s(i), std::numeric_limits<double>::min() / std::numeric_limits<double>::epsilon());
  }
  return s;
}

// J = I - dF/dx at x in the scales of b0, the beat from x that the solve ended with, by forward
// differences of fd_step scaled units (n beats, not recorded). nullopt when a beat failed.
std::optional<ShootingWarmStart> measure_warm_start(const VectorXd& x, const BeatOutcome& b0,
                                                    const std::function<BeatOutcome(const VectorXd&)>& run,
                                                    double fd_step) {
  const Eigen::Index n = x.size();
  ShootingWarmStart w;
  w.start = x;
  w.scale = entry_scales(b0, n);
  w.jacobian = MatrixXd::Identity(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    VectorXd xj = x;
    xj(j) += fd_step * w.scale(j);
    const BeatOutcome p = run(xj);
    if (!p.status.ok()) return std::nullopt;
    w.jacobian.col(j) -= (p.end - b0.end).cwiseQuotient(w.scale) / fd_step;
  }
  if (!w.jacobian.allFinite()) return std::nullopt;
  return w;
}

}  // namespace

Eigen::VectorXd ShootingWarmStart::pack() const {
  const Eigen::Index n = start.size();
  VectorXd flat(packed_size(static_cast<int>(n)));
  flat << start, scale, jacobian.reshaped();
  return flat;
}

std::optional<ShootingWarmStart> ShootingWarmStart::unpack(const Eigen::VectorXd& flat, int n) {
  if (n <= 0 || flat.size() != packed_size(n) || !flat.allFinite()) return std::nullopt;
  ShootingWarmStart w;
  w.start = flat.head(n);
  w.scale = flat.segment(n, n);
  w.jacobian = flat.tail(static_cast<Eigen::Index>(n) * n).reshaped(n, n);
  if (!(w.scale.array() > 0.0).all()) return std::nullopt;
  return w;
}

namespace {
// `last` receives the beat from the returned start when the solve converged.
ShootingResult solve_periodic_state(const VectorXd& x0, const BeatMap& beat,
                                    const ShootingOptions& o, const ShootingWarmStart* warm,
                                    BeatOutcome& last);
}  // namespace

ShootingResult find_periodic_state(const VectorXd& x0, const BeatMap& beat,
                                   const ShootingOptions& o, const ShootingWarmStart* warm) {
  BeatOutcome last;
  ShootingResult res = solve_periodic_state(x0, beat, o, warm, last);
  if (o.jacobian && res.status.ok()) {
    res.warm = measure_warm_start(
        res.start, last, [&](const VectorXd& x) {
          ++res.beats;
          return beat(x, false);
        },
        o.fd_step);
  }
  return res;
}

namespace {
ShootingResult solve_periodic_state(const VectorXd& x0, const BeatMap& beat,
                                    const ShootingOptions& o, const ShootingWarmStart* warm,
                                    BeatOutcome& last) {
  ShootingResult res;
  const Eigen::Index n = x0.size();
  auto run = [&](const VectorXd& start, bool record) {
    BeatOutcome b = beat(start, record);
    ++res.beats;
    return b;
  };
  auto fail = [&](Status st, const VectorXd& x) {
    res.status = std::move(st);
    res.start = x;
    return res;
  };
  // Periodic: `start` with its last correction, `from_start` the (recorded) beat from it.
  auto succeed = [&](const VectorXd& start, double correction, BeatOutcome from_start) {
    res.correction = correction;
    res.start = start;
    res.status = Status::Ok();
    last = std::move(from_start);
    return res;
  };

  VectorXd x = x0;
  BeatOutcome base;
  bool started = false;  // x and base hold a recorded beat to go on from
  if (warm && warm->start.size() == n && warm->scale.size() == n && warm->jacobian.rows() == n &&
      warm->jacobian.cols() == n) {
    // Chord steps from the warm start (see ShootingWarmStart): dx = S_w J_w^-1 S_w^-1 G(x), one
    // beat each; the same stopping rule as the Newton steps below (a step below the tolerance is
    // the last one, taken whole, and its beat is the periodic beat).
    const Eigen::PartialPivLU<MatrixXd> lu(warm->jacobian);
    constexpr int kChordSteps = 8;
    x = warm->start;
    base = run(x, true);
    started = base.status.ok();
    for (int k = 0; started && k < kChordSteps && res.beats < o.max_beats; ++k) {
      const VectorXd s = entry_scales(base, n);
      const VectorXd g = base.end - x;
      const VectorXd r = g.cwiseQuotient(s);
      if (!r.allFinite()) break;
      if (max_abs(r) == 0.0) return succeed(x, 0.0, std::move(base));
      const VectorXd dx = warm->scale.cwiseProduct(lu.solve(g.cwiseQuotient(warm->scale)));
      if (!dx.allFinite()) break;
      const double step = max_abs(dx.cwiseQuotient(s));
      const VectorXd xt = x + dx;
      BeatOutcome t = run(xt, true);
      if (!t.status.ok()) {
        base = run(x, true);  // the beat recorded last must be the one returned
        started = base.status.ok();
        break;
      }
      ++res.chord_steps;
      if (step <= o.tolerance) return succeed(xt, step, std::move(t));
      const double rt = (t.end - xt).cwiseQuotient(s).norm();
      if (!(rt <= 0.5 * r.norm())) {  // not contracting: Newton-Krylov from the better point
        if (rt < r.norm()) {
          x = xt;
          base = std::move(t);
        } else {
          base = run(x, true);
          started = base.status.ok();
        }
        break;
      }
      x = xt;
      base = std::move(t);
    }
  }
  if (!started) {  // cold: plain beats first (the fast modes decay)
    x = x0;
    base = run(x, true);
    for (int b = 1; base.status.ok() && b < o.min_beats; ++b) {
      x = base.end;
      base = run(x, true);
    }
  }
  if (!base.status.ok()) return fail(base.status, x);

  // Watchdog (Chamberlain, Powell, Lemarechal & Pedersen 1982, Math Program Stud 16:1; Nocedal &
  // Wright 2006 s.15.6): a full Newton step that raises |G| is still taken once, and the method
  // returns to the point before it unless |G| falls below that point's value within kWatch
  // steps. The beat map has kinks (a valve starts to open) next to nearly neutral modes: from the
  // flat side of a kink Newton overshoots into the steep side, from which it converges, but a
  // monotone line search never lets it cross. A step that halves |G| does not count against the
  // window (the beats are still bounded by max_beats).
  constexpr int kWatch = 6;
  VectorXd x_ref;
  double ref_norm = 0.0, last_norm = 0.0;
  // The Newton correction at x_ref (scaled, max norm) when the watch began with a full Newton step
  // from x_ref; 0 when it is not known (a jump over a kink), which disables the test below.
  double ref_step = 0.0;
  int watching = 0;  // steps left in the watch window; 0: not watching
  bool free_step = true;
  bool search_ray = false;  // after a failed watch: find the root along the Newton ray
  constexpr int kKinkJumps = 4;  // jumps over a kink per solve (each costs one beat and a watch)
  // Only after this many ray searches in a row closed on a kink: jumping at the first one made
  // the 12-parameter foreign calibration fail 412 members instead of 198 (members that creep to
  // the tolerance within max_beats lost their beats to the watch), 5446 runs instead of 5011.
  constexpr int kPoorRays = 2;
  int kink_jumps = 0, poor_rays = 0;

  // The root of phi(lambda) = G(x + lambda S dz) . G(x) / |G(x)|^2 on the Newton ray, bracketed by
  // phi(0) = 1 and an overshooting full step (phi(1) < 0), by the Illinois variant of regula falsi
  // (Dowell & Jarratt 1971, BIT 11:168), which keeps its superlinear rate when G is steep on one
  // side of a kink and flat on the other: where the watchdog came back without progress, the
  // periodic state sits just past such a kink, and Newton steps from either side overshoot it.
  // Takes the point with the smallest |G| if it decreases |G| (Armijo), leaving its beat recorded,
  // and returns its lambda (0: no step; the full step lambda = 1 has then been tried).
  auto root_on_ray = [&](VectorXd& x_io, const VectorXd& dz, const VectorXd& s, const VectorXd& r,
                         BeatOutcome& base_io) {
    const double r_norm = r.norm();
    double best_norm = r_norm, best_lam = -1.0, last_lam = -1.0;
    BeatOutcome best;
    auto phi_at = [&](double lam, double* phi) {
      const VectorXd xt = x_io + lam * dz.cwiseProduct(s);
      BeatOutcome t = run(xt, true);
      last_lam = lam;
      if (!t.status.ok()) return false;
      const VectorXd rt = (t.end - xt).cwiseQuotient(s);
      if (!rt.allFinite()) return false;
      *phi = rt.dot(r) / (r_norm * r_norm);
      if (rt.norm() < best_norm) {
        best_norm = rt.norm();
        best_lam = lam;
        best = std::move(t);
      }
      return true;
    };
    double lo = 0.0, phi_lo = 1.0, hi = 1.0, phi_hi = 0.0;
    const bool overshoot = phi_at(1.0, &phi_hi) && phi_hi < 0.0;
    int side = 0;
    for (int k = 0; overshoot && k < 30 && res.beats < o.max_beats && best_norm > 1e-3 * r_norm &&
                    hi - lo > 1e-12;
         ++k) {
      double lam = hi - phi_hi * (hi - lo) / (phi_hi - phi_lo);
      if (!(lam > lo && lam < hi)) lam = 0.5 * (lo + hi);
      double phi = 0.0;
      if (!phi_at(lam, &phi)) {  // a failed beat: treat as past the root
        hi = lam;
        continue;
      }
      if (phi < 0.0) {
        hi = lam;
        phi_hi = phi;
        if (side == -1) phi_lo *= 0.5;
        side = -1;
      } else {
        lo = lam;
        phi_lo = phi;
        if (side == 1) phi_hi *= 0.5;
        side = 1;
      }
    }
    const bool improves = best_lam > 0.0 && best_norm <= (1.0 - 1e-4 * best_lam) * r_norm;
    // A bracket that closed where |G| stays large (above half its value at x) is a kink, not a
    // root: G is flat on the near side (the Jacobian there sees no valve opening) and steep on the
    // far side. Newton from the steep side lands on the root; from the flat side it only comes
    // back to the kink (regional census points 401, 889, 2256 crept at |G| ~ 2e-5 until the beats
    // ran out). So the iterate jumps to the far side, ten finite-difference steps past the
    // bracket, and the watchdog keeps the best point of the ray to come back to.
    const bool poor = overshoot && best_norm > 0.5 * r_norm;
    poor_rays = poor ? poor_rays + 1 : 0;
    if (poor && poor_rays >= kPoorRays && watching == 0 && kink_jumps < kKinkJumps &&
        res.beats < o.max_beats) {
      ++kink_jumps;
      const double lam_far = std::min(1.0, hi + 10.0 * o.fd_step / max_abs(dz));
      const VectorXd x_far = x_io + lam_far * dz.cwiseProduct(s);
      BeatOutcome far = run(x_far, true);
      if (far.status.ok() && (far.end - x_far).cwiseQuotient(s).allFinite()) {
        x_ref = improves ? VectorXd(x_io + best_lam * dz.cwiseProduct(s)) : x_io;
        ref_norm = improves ? best_norm : r_norm;
        ref_step = 0.0;
        last_norm = std::numeric_limits<double>::infinity();
        watching = kWatch;
        free_step = false;
        x_io = x_far;
        base_io = std::move(far);
        return lam_far;
      }
    }
    if (!improves) return 0.0;
    x_io += best_lam * dz.cwiseProduct(s);
    base_io = best_lam == last_lam ? std::move(best) : run(x_io, true);
    return base_io.status.ok() ? best_lam : 0.0;
  };

  while (true) {
    // Scales: each entry by its peak over the current beat; an entry that is 0 all beat keeps
    // scale 1. Not the largest peak ever seen: one far trial beat (a watchdog step) inflated the
    // scale for the rest of the solve, and with it the finite-difference steps, which then
    // straddled a valve kink (census point 677 of the sphere stalled at |G| = 3.4e-5).
    const VectorXd s = entry_scales(base, n);
    const VectorXd r = (base.end - x).cwiseQuotient(s);  // G(x) = F(x) - x, scaled
    if (!r.allFinite()) {
      return fail(Status::Error(StatusCode::kNonFinite, "the beat map gave a non-finite state"), x);
    }
    res.correction = max_abs(r);
    if (res.correction == 0.0) break;  // already exactly periodic (e.g. a state at rest)
    if (res.beats >= o.max_beats) break;
    bool window_closes = false;  // the watch ends at this point unless the error test passes
    if (watching > 0) {
      const bool fast = r.norm() < 0.5 * last_norm;  // still closing in: the window stays open
      last_norm = r.norm();
      if (r.norm() < ref_norm) {  // paid off; another free step only after a clear gain
        watching = 0;
        free_step = r.norm() < 0.1 * ref_norm;
      } else if (!fast && watching == 1) {
        window_closes = true;
      } else if (!fast) {
        --watching;
      }
    }
    // The watch did not pay off in |G|. The beat map's nearly neutral arterial mode (I - dF/dx has
    // a singular value of 8e-5 and 5e-4 at regional census points 2958 and 2491) makes |G| a poor
    // measure of the distance to the fixed point: a state kPa away from it on the branch without
    // ejection had |G| = 1.2e-4, the iterate 17 Pa from it |G| = 9.9e-4, so the watchdog went back
    // to the far state, and the runs ran out of beats although full Newton steps from the iterate
    // converge quadratically. The Newton correction estimates that distance independently of the
    // scaling of G (affine covariance; Deuflhard 2004, Newton Methods for Nonlinear Problems,
    // Springer SSCM 35, s.3.3, the natural monotonicity test with lambda = 1: the correction must
    // fall below 3/4 of the previous one). So the watch also pays off when the Newton correction
    // here is below 3/4 of the one at x_ref (each with its own Jacobian: the correction at x_ref is
    // the free step, and the one here is needed for the next step anyway).
    auto back_to_ref = [&]() {  // the free step did not pay off: back to where it started
      watching = 0;
      x = x_ref;
      base = run(x, true);
      free_step = false;
      search_ray = true;
    };
    if (window_closes && !(ref_step > 0.0)) {
      back_to_ref();
      if (!base.status.ok()) return fail(base.status, x);
      continue;
    }

    // Newton step: (I - dF/dx) dz = r in scaled units, dF/dx v by a forward difference.
    const Apply apply = [&](const VectorXd& v, VectorXd& y) {
      if (res.beats >= o.max_beats) return false;
      const BeatOutcome p = run(x + o.fd_step * v.cwiseProduct(s), false);
      if (!p.status.ok()) return false;
      y = v - (p.end - base.end).cwiseQuotient(s) / o.fd_step;
      return y.allFinite();
    };
    const std::optional<VectorXd> dz = gmres(apply, r, o.max_krylov, o.krylov_tolerance);
    if (window_closes) {
      if (res.beats >= o.max_beats) break;
      const double here = dz && dz->allFinite() ? max_abs(*dz) : std::numeric_limits<double>::infinity();
      if (!(here <= 0.75 * ref_step)) {
        back_to_ref();
        if (!base.status.ok()) return fail(base.status, x);
        continue;
      }
      // Paid off in the Newton correction: Newton contracts here, so the next step is tried whole
      // again, as after a passed natural monotonicity test (Deuflhard 2004, s.3.3), and watched
      // from this iterate. Allowing it only after a tenfold fall (the rule for |G| above) left
      // regional census point 2368 creeping by line searches on |G|: 266 beats instead of 92.
      watching = 0;
      free_step = true;
    }
    bool moved = false;
    if (dz && dz->allFinite()) {
      ++res.newton_steps;
      const double step = max_abs(*dz);
      // Backtracking on |G|_2 (Armijo constant 1e-4, halving). A step below the tolerance is the
      // last one: it is taken whole and its beat is the periodic beat.
      // The ray search evaluates the full step first; backtracking then starts at one half.
      bool full_step_tried = false;
      if ((search_ray || !free_step) && watching == 0 && step > o.tolerance &&
          res.beats < o.max_beats) {
        search_ray = false;
        full_step_tried = true;
        const double taken = root_on_ray(x, *dz, s, r, base);
        moved = taken > 0.0;
        if (taken == 1.0) free_step = true;  // a full Newton step re-arms the watchdog
      }
      double lambda = full_step_tried ? 0.5 : 1.0;
      for (int ls = full_step_tried ? 1 : 0; ls < 6 && !moved && res.beats < o.max_beats;
           ++ls, lambda *= 0.5) {
        const VectorXd xt = x + lambda * dz->cwiseProduct(s);
        BeatOutcome trial = run(xt, true);
        if (!trial.status.ok()) continue;
        const VectorXd rt = (trial.end - xt).cwiseQuotient(s);
        const bool armijo = rt.norm() <= (1.0 - 1e-4 * lambda) * r.norm();
        if (!armijo && ls == 0 && free_step && watching == 0 && step > o.tolerance) {
          x_ref = x;
          ref_norm = r.norm();
          ref_step = step;
          last_norm = std::numeric_limits<double>::infinity();
          watching = kWatch;
          free_step = false;
          x = xt;
          base = std::move(trial);
          moved = true;
          break;
        }
        if (step <= o.tolerance || armijo) {
          if (watching == 0 && ls == 0) free_step = true;  // a full Newton step re-arms it
          // A damped step that lowered |G| by less than a tenth re-arms it as well: the full
          // step is tried (and watched) again. Without this, one failed watch left every later
          // step damped; next to a nearly neutral arterial mode (R_d C_d ~ 1e4 s) by a valve
          // kink, Armijo accepted ~3 % of each step and atrium-sphere census points 987 and
          // 2865 crept to 450 and 753 beats; re-armed they converge in 111 and 123
          // (experiments/lumped-census/NOTES.md).
          if (watching == 0 && ls > 0 && rt.norm() > 0.9 * r.norm()) free_step = true;
          x = xt;
          base = std::move(trial);
          moved = true;
          break;
        }
      }
      if (moved && step <= o.tolerance) return succeed(x, step, std::move(base));
    }
    if (!moved) {  // no usable Newton step: one plain beat, which never makes things worse
      if (res.beats >= o.max_beats) break;
      x = base.end;
      base = run(x, true);
      if (!base.status.ok()) return fail(base.status, x);
    }
  }
  if (res.correction == 0.0) return succeed(x, 0.0, std::move(base));
  std::ostringstream m;
  m << "not periodic after " << res.beats << " beats (max_beats " << o.max_beats << ", "
    << res.newton_steps << " Newton steps): the start state still changes by "
    << res.correction << " of its scale per beat (tolerance " << o.tolerance << ")";
  return fail(Status::Error(StatusCode::kNotPeriodic, m.str()), x);
}
}  // namespace

}  // namespace sigmaheart::model
