"""Figures of `sigmaheart calibrate` results (kind "calibrate").

- <stem>-fit.png: observed curves (markers, the measured frames) against the model at the prior
  and at the calibrated parameters, for volume and pressure, and the PV loops; with typed-in
  indices instead of curves, the indices observed vs prior vs calibrated.
- <stem>-parameters.png: each estimated parameter as estimate/prior with +-2 posterior std (and
  the prior's +-2 std band), so parameters of different units share one axis.
- <stem>-residuals.png: residuals per observation in noise standard deviations, before and after.
"""
from __future__ import annotations

from typing import List

import numpy as np

from sigmaplot_common import plt, provenance_note, save, strings, title_of, trajectory_curve
from sigmaplot_discrepancy import plot_discrepancy

PRIOR = dict(color="#7f7f7f", lw=1.4, ls="--", label="prior (defaults)")
CALIBRATED = dict(color="#d62728", lw=2.0, label="calibrated")
OBSERVED = dict(color="#1f77b4", marker="o", ms=4, ls="none", label="observed frames")


def observed_curve(f, name):
    return trajectory_curve(f, "observed", name)


model_curve = trajectory_curve


def plot_curves(f, out_dir, stem) -> List[str]:
    channels = [c for c in ("V_lv", "P_lv") if observed_curve(f, c) is not None]
    if not channels:
        return []
    ncols = len(channels) + (1 if len(channels) == 2 else 0)
    fig, axes = plt.subplots(1, ncols, figsize=(5.2 * ncols, 4.2))
    axes = np.atleast_1d(axes)
    for ax, ch in zip(axes, channels):
        t, y, unit = observed_curve(f, ch)
        for which, style in (("prior", PRIOR), ("calibrated", CALIBRATED)):
            m = model_curve(f, which, ch)
            if m is not None:
                ax.plot(m[0] * 1e3, m[1], **style)
        ax.plot(t * 1e3, y, **OBSERVED)
        ax.set_xlabel("time after the ECG trigger [ms]")
        ax.set_ylabel(f"{ch} [{unit}]")
        ax.set_title({"V_lv": "LV volume", "P_lv": "LV pressure"}.get(ch, ch))
    axes[0].legend(loc="best")
    if len(channels) == 2:
        ax = axes[2]
        for which, style in (("prior", PRIOR), ("calibrated", CALIBRATED)):
            v = model_curve(f, which, "V_lv")
            p = model_curve(f, which, "P_lv")
            if v is not None and p is not None:
                ax.plot(v[1], p[1], **style)
        v = observed_curve(f, "V_lv")
        p = observed_curve(f, "P_lv")
        ax.plot(v[1], p[1], **OBSERVED)
        ax.set_xlabel(f"V_lv [{v[2]}]")
        ax.set_ylabel(f"P_lv [{p[2]}]")
        ax.set_title("pressure-volume loop")
    summary = f["summary"].attrs
    fig.suptitle(title_of(f, "calibration fit") +
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
    e = f["estimate"]
    names = strings(e["names"])
    units = strings(e["units"])
    prior = e["prior_mean"][()]
    prior_std = e["prior_std"][()]
    mean = e["mean"][()]
    std = e["std"][()]
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(max(4.5, 1.2 * len(names) + 2), 4.0))
    ax.bar(x, 4 * prior_std / prior, bottom=1 - 2 * prior_std / prior, width=0.5,
           color="#dddddd", label="prior \u00b12 std")
    ax.axhline(1.0, color=PRIOR["color"], ls="--", lw=1)
    ax.errorbar(x, mean / prior, yerr=2 * std / prior, fmt="D", color=CALIBRATED["color"],
                capsize=5, label="estimate \u00b12 posterior std")
    labels = [f"{n}\n{m:.3g} \u00b1 {sd:.2g}\n[{u}]" for n, m, sd, u in zip(names, mean, std, units)]
    ax.set_xticks(x, labels, fontsize=8)
    ax.set_ylabel("value / prior mean [-]")
    ax.set_title(title_of(f, "estimated parameters"))
    ax.legend(loc="best")
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
    ax.set_title(title_of(f, "residuals"))
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
