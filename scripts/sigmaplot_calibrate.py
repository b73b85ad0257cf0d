"""Figures of `sigmaheart calibrate` results (kind "calibrate").

- <stem>-fit.png: observed curves (markers, the measured frames) against the model at the prior
  and at the calibrated parameters on the data's time axis (the end-diastole alignment's offset
  applied and stated in the legend), for volume and pressure, and the PV loops; with typed-in
  indices instead of curves, the indices observed vs prior vs calibrated.
- <stem>-parameters.png: each estimated parameter as estimate/prior with +-2 posterior std, the
  prior's +-2 std band and the physiological range, so parameters of different units share one
  axis; parameters in prior conflict are ringed.
- <stem>-residuals.png: residuals per observation in noise standard deviations, before and after.
"""
from __future__ import annotations

import os
from typing import List

import numpy as np

from sigmaplot_common import plt, provenance_note, save, strings, text, title_of, trajectory_curve
from sigmaplot_discrepancy import plot_discrepancy

PRIOR = dict(color="#7f7f7f", lw=1.4, ls="--", label="prior (defaults)")
CALIBRATED = dict(color="#d62728", lw=2.0, label="calibrated")
OBSERVED = dict(color="#1f77b4", marker="o", ms=4, ls="none", label="observed frames")


def observed_curve(f, name):
    return trajectory_curve(f, "observed", name)


model_curve = trajectory_curve


def case_title(f, what: str) -> str:
    """The title names the data's case (the observation file's stem), and the config when its
    name differs (a config calibrates many cases with --set observations.file=...)."""
    case = text(f["observations"].attrs.get("file", "")) if "observations" in f else ""
    case = os.path.splitext(os.path.basename(case))[0]
    name = text(f.attrs.get("name", ""))
    if not case:
        return title_of(f, what)
    return f"{what} \u2014 {case}" + (f" (config {name})" if name and name != case else "")


def aligned_model_curves(f, which: str):
    """{channel: (time [s], values, unit)} of /fit/curves/<which>: the model beat as the frames are
    read from it, on the data's time axis, wrapped into one period from the first measured frame
    and closed (the first sample repeated one period later). The fit figure draws exactly these;
    the model at the frame times (periodic linear interpolation) is /fit/after (which =
    "calibrated") or /fit/before ("prior"). Also returns the time offset [s] added to model time
    as curves["time_offset"]. None when the file has no aligned curves."""
    g = f.get(f"fit/curves/{which}")
    if g is None or "time" not in g:
        return None
    period = float(g.attrs["period"])
    t = g["time"][()]
    observed = f.get("trajectories/observed/time")
    t0 = float(observed[()][0]) if observed is not None else float(np.min(t))
    if period > 0:
        t = t0 + np.mod(t - t0, period)
    order = np.argsort(t, kind="stable")
    out = {"time_offset": float(g.attrs.get("time_offset", 0.0)), "period": period}
    for ch in g:
        if ch == "time" or not isinstance(g[ch], type(g["time"])):
            continue
        v = g[ch][()][order]
        tt = t[order]
        if period > 0:
            tt = np.append(tt, tt[0] + period)
            v = np.append(v, v[0])
        out[ch] = (tt, v, text(g[ch].attrs.get("units", "")))
    return out


def plot_curves(f, out_dir, stem) -> List[str]:
    channels = [c for c in ("V_lv", "P_lv") if observed_curve(f, c) is not None]
    if not channels:
        return []
    aligned = {w: aligned_model_curves(f, w) for w in ("prior", "calibrated")}

    def model(which, ch):
        a = aligned[which]
        if a is not None:
            return a.get(ch)
        return model_curve(f, which, ch)  # results written before the aligned curves

    def label(which, style):
        a = aligned[which]
        if a is None:
            return style["label"]
        offset, period = a["time_offset"], a["period"]
        if period > 0:  # the shift on the periodic beat, in (-T/2, T/2]
            offset = offset - period * np.round(offset / period)
        if abs(offset) < 5e-4:
            return style["label"]
        return f"{style['label']} (model time {offset * 1e3:+.0f} ms)"

    ncols = len(channels) + (1 if len(channels) == 2 else 0)
    fig, axes = plt.subplots(1, ncols, figsize=(5.2 * ncols, 4.2))
    axes = np.atleast_1d(axes)
    ed_aligned = text(f["observations"].attrs.get("alignment", "ecg")) == "end-diastole"
    for ax, ch in zip(axes, channels):
        t, y, unit = observed_curve(f, ch)
        for which, style in (("prior", PRIOR), ("calibrated", CALIBRATED)):
            m = model(which, ch)
            if m is not None:
                ax.plot(m[0] * 1e3, m[1], **dict(style, label=label(which, style)))
        ax.plot(t * 1e3, y, **OBSERVED)
        ax.set_xlabel("time in the data file [ms] (model aligned on end-diastole)" if ed_aligned
                      else "time after the ECG trigger [ms]")
        ax.set_ylabel(f"{ch} [{unit}]")
        ax.set_title({"V_lv": "LV volume", "P_lv": "LV pressure"}.get(ch, ch))
    axes[0].legend(loc="best", fontsize=8)
    if len(channels) == 2:
        ax = axes[2]
        for which, style in (("prior", PRIOR), ("calibrated", CALIBRATED)):
            v = model(which, "V_lv")
            p = model(which, "P_lv")
            if v is not None and p is not None:
                ax.plot(v[1], p[1], **style)
        v = observed_curve(f, "V_lv")
        p = observed_curve(f, "P_lv")
        ax.plot(v[1], p[1], **OBSERVED)
        ax.set_xlabel(f"V_lv [{v[2]}]")
        ax.set_ylabel(f"P_lv [{p[2]}]")
        ax.set_title("pressure-volume loop")
    summary = f["summary"].attrs
    fig.suptitle(case_title(f, "calibration fit") +
                 f"  (RMS residual {float(summary.get('rms_normalised_residual_before', np.nan)):.2f}"
                 f" \u2192 {float(summary.get('rms_normalised_residual_after', np.nan)):.2f} noise std)")
    fig.text(0.99, 0.01, provenance_note(f), ha="right", va="bottom", fontsize=7, color="#777777")
    fig.tight_layout()
    return [save(fig, out_dir, stem, "fit")]


def observations(f):
    """(names, units, y, noise std) of /observations, in the units the file names."""
    o = f["observations"]
    return strings(o["names"]), strings(o["units"]), o["y"][()], o["noise_std"][()]


def plot_indices(f, out_dir, stem) -> List[str]:
    names, units, y, s = observations(f)
    before = f["fit/before"][()]
    after = f["fit/after"][()]
    fig, axes = plt.subplots(1, len(names), figsize=(1.9 * len(names) + 1, 3.6), squeeze=False)
    for ax, n, u, yi, si, b, a in zip(axes[0], names, units, y, s, before, after):
        ax.errorbar([0], [yi], yerr=[2 * si], color=OBSERVED["color"], marker="o", capsize=4,
                    label="observed \u00b12 std")
        ax.plot([1], [b], marker="s", color=PRIOR["color"], ls="none", label="prior")
        ax.plot([2], [a], marker="D", color=CALIBRATED["color"], ls="none", label="calibrated")
        ax.set_xticks([0, 1, 2], ["obs", "prior", "cal"])
        ax.set_title(f"{n} [{u}]", fontsize=9)
        ax.set_xlim(-0.6, 2.6)
    axes[0][0].legend(loc="best", fontsize=7)
    fig.suptitle(title_of(f, "calibration fit (indices)"))
    fig.tight_layout()
    return [save(fig, out_dir, stem, "fit")]


def plot_parameters(f, out_dir, stem) -> List[str]:
    """Estimate / prior mean with +-2 posterior std, the prior's +-2 std band (in eta, where the
    prior is Gaussian: exp(+-2 sigma_eta) for log transforms) and the physiological range (green);
    a log axis when an estimate is beyond 5x or below 1/5 of its prior. Labels give prior_z."""
    e = f["estimate"]
    names = strings(e["names"])
    units = strings(e["units"])
    prior = e["prior_mean"][()]
    prior_std = e["prior_std"][()]
    mean = e["mean"][()]
    std = e["std"][()]
    x = np.arange(len(names))
    ratio = mean / prior
    log_axis = bool(np.all(ratio > 0) and (np.max(ratio) > 5 or np.min(ratio) < 0.2))
    fig, ax = plt.subplots(figsize=(max(4.5, 1.2 * len(names) + 2), 4.4))
    if log_axis and "eta_prior_std" in e and "eta_covariance" in e:
        # The bands in eta (exact for log transforms): value x/÷ exp(2 sigma_eta).
        s_eta = e["eta_prior_std"][()]
        lo, hi = np.exp(-2 * s_eta), np.exp(2 * s_eta)
        p_eta = np.sqrt(np.maximum(np.diag(e["eta_covariance"][()]), 0.0))
        yerr = [ratio * (1 - np.exp(-2 * p_eta)), ratio * (np.exp(2 * p_eta) - 1)]
    else:
        lo, hi = 1 - 2 * prior_std / prior, 1 + 2 * prior_std / prior
        yerr = 2 * std / prior
    ax.bar(x, hi - lo, bottom=lo, width=0.5, color="#dddddd", label="prior \u00b12 std")
    ax.axhline(1.0, color=PRIOR["color"], ls="--", lw=1)
    if "range_lower" in e:
        rl, ru = e["range_lower"][()] / prior, e["range_upper"][()] / prior
        ok = np.isfinite(rl) & np.isfinite(ru)
        ax.vlines(x[ok] + 0.3, rl[ok], ru[ok], color="#2ca02c", lw=2.5, label="physiological range")
    ax.errorbar(x, ratio, yerr=yerr, fmt="D", color=CALIBRATED["color"],
                capsize=5, label="estimate \u00b12 posterior std")
    z = e["prior_z"][()] if "prior_z" in e else np.full(len(names), np.nan)
    inr = e["in_range"][()] if "in_range" in e else np.full(len(names), -1)
    bad = (np.abs(z) > 3) | (inr == 0)
    if np.any(bad):
        ax.plot(x[bad], ratio[bad], "o", ms=14, mfc="none", mec="#d62728", mew=1.5,
                label="prior conflict (|z| > 3 or out of range)")
    labels = [f"{n}\n{m:.3g} \u00b1 {sd:.2g}\n[{u}]" + (f"\nz {zz:+.1f}" if np.isfinite(zz) else "")
              for n, m, sd, u, zz in zip(names, mean, std, units, z)]
    ax.set_xticks(x, labels, fontsize=8)
    if log_axis:
        ax.set_yscale("log")
    ax.set_ylabel("value / prior mean [-]")
    ax.set_title(case_title(f, "estimated parameters"))
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return [save(fig, out_dir, stem, "parameters")]


def plot_residuals(f, out_dir, stem) -> List[str]:
    names, _, y, s = observations(f)
    before = (y - f["fit/before"][()]) / s
    after = (y - f["fit/after"][()]) / s
    fig, ax = plt.subplots(figsize=(max(6, 0.14 * len(names) + 3), 3.6))
    x = np.arange(len(names))
    ax.axhspan(-2, 2, color="#eeeeee", zorder=0, label="\u00b12 noise std")
    ax.plot(x, before, "s", color=PRIOR["color"], ms=4, label="prior")
    ax.plot(x, after, "D", color=CALIBRATED["color"], ms=4, label="calibrated")
    step = max(1, len(names) // 30)
    ax.set_xticks(x[::step], names[::step], rotation=70, fontsize=7)
    ax.set_ylabel("(observed \u2212 model) / noise std [-]")
    ax.set_title(case_title(f, "residuals"))
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return [save(fig, out_dir, stem, "residuals")]


def plot_calibrate(f, out_dir: str, stem: str) -> List[str]:
    paths = plot_curves(f, out_dir, stem) if "trajectories/observed" in f else []
    if not paths:
        paths = plot_indices(f, out_dir, stem)
    paths += plot_parameters(f, out_dir, stem) + plot_residuals(f, out_dir, stem)
    if "fit_report" in f:  # where in the cycle the misfit sits, and what the data did not inform
        paths += plot_discrepancy(f, out_dir, stem)
    return paths
