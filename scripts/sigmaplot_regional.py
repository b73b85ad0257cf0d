"""Figures of `sigmaheart personalize` results (kind "personalize"; app/commands/personalize.cpp).

- parameter trajectories over the filter steps with +-2 sigma bands (truth dashed when known);
- AHA 17-segment bull's-eye of the estimated contractility (and of the truth and the signed error
  in twin experiments), drawn here with matplotlib wedges in the standard orientation of
  Cerqueira et al. 2002 (Circulation 105:539): view from the apex, anterior at the top, septum on
  the left; outer ring basal 1-6, then mid 7-12, apical 13-16, apex 17 in the centre;
- regional volume fits: observed frames against the filter's fitted and predicted values, one
  small panel per segment.
"""
from __future__ import annotations

import math
from typing import List

import numpy as np
from matplotlib.patches import Circle, Wedge

import sigmaplot_common as sp
from sigmaplot_common import plt, strings

AHA_NAMES = [
    "basal anterior", "basal anteroseptal", "basal inferoseptal", "basal inferior",
    "basal inferolateral", "basal anterolateral", "mid anterior", "mid anteroseptal",
    "mid inferoseptal", "mid inferior", "mid inferolateral", "mid anterolateral",
    "apical anterior", "apical septal", "apical inferior", "apical lateral", "apex",
]


def _scaled(unit: str):
    """Display factor and unit: Pa is shown in kPa."""
    return (1e-3, "kPa") if unit == "Pa" else (1.0, unit)


def aha_wedges(segment: int):
    """(r_inner, r_outer, theta1, theta2) in degrees counter-clockwise from 3 o'clock for AHA
    segment 1..16, or None for the apex (17). Anterior at the top, septum on the left."""
    if segment <= 12:
        ring = 0 if segment <= 6 else 1
        k = (segment - 1) % 6
        start = 60.0 + 60.0 * k  # segment 1 (anterior) spans 60-120 deg, then counter-clockwise
        r_out = 1.0 - 0.25 * ring
        return r_out - 0.25, r_out, start, start + 60.0
    if segment <= 16:
        k = segment - 13
        start = 45.0 + 90.0 * k  # 13 anterior 45-135, 14 septal 135-225, 15 inferior, 16 lateral
        return 0.25, 0.5, start, start + 90.0
    return None


def bullseye(ax, values, title: str, cmap: str, vmin: float, vmax: float, label: str,
             fmt: str = "{:.0f}", marked=()):
    """Draws a 17-segment bull's-eye of `values` (index 0 = segment 1) on `ax`."""
    norm = plt.Normalize(vmin=vmin, vmax=vmax)
    cm = plt.get_cmap(cmap)
    for s in range(1, 18):
        v = values[s - 1]
        color = cm(norm(v)) if np.isfinite(v) else "#dddddd"
        w = aha_wedges(s)
        edge = dict(edgecolor="black", linewidth=2.2 if s in marked else 0.8)
        if w is None:
            patch = Circle((0, 0), 0.25, facecolor=color, **edge)
            xy = (0.0, 0.0)
        else:
            r0, r1, t0, t1 = w
            patch = Wedge((0, 0), r1, t0, t1, width=r1 - r0, facecolor=color, **edge)
            mid = math.radians(0.5 * (t0 + t1))
            rm = 0.5 * (r0 + r1)
            xy = (rm * math.cos(mid), rm * math.sin(mid))
        ax.add_patch(patch)
        # Light text on the dark end of the map (viridis: low values; RdBu: both ends).
        dark = np.isfinite(v) and (norm(v) < 0.45 if cmap != "RdBu_r" else abs(norm(v) - 0.5) > 0.3)
        ax.text(xy[0], xy[1] - 0.045, fmt.format(v) if np.isfinite(v) else "-", ha="center",
                va="center", fontsize=7, color="white" if dark else "black")
        ax.text(xy[0], xy[1] + 0.05, str(s), ha="center", va="center", fontsize=6,
                color="#dddddd" if dark else "dimgray")
    ax.set_xlim(-1.2, 1.2)
    ax.set_ylim(-1.25, 1.2)
    ax.set_aspect("equal")
    ax.axis("off")
    ax.set_title(title)
    ax.text(0, 1.08, "anterior", ha="center", va="bottom", fontsize=8)
    ax.text(0, -1.08, "inferior", ha="center", va="top", fontsize=8)
    ax.text(-1.08, 0, "septal", ha="right", va="center", fontsize=8, rotation=90)
    ax.text(1.08, 0, "lateral", ha="left", va="center", fontsize=8, rotation=270)
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cm)
    cb = ax.figure.colorbar(sm, ax=ax, fraction=0.046, pad=0.06, orientation="horizontal")
    cb.set_label(label)


def _segment_values(f, family: str, data):
    """17 values (NaN where the segment is not estimated) of per-segment family `family`."""
    out = np.full(17, np.nan)
    seg = np.asarray(f["estimate/segment"][()])
    fam = strings(f["estimate/family"])
    for j, (s, name) in enumerate(zip(seg, fam)):
        if name == family and 1 <= s <= 17:
            out[s - 1] = data[j]
    return out


def _plot_bullseye(f, out_dir, stem) -> List[str]:
    fam = strings(f["estimate/family"])
    seg = np.asarray(f["estimate/segment"][()])
    units = strings(f["estimate/units"])
    families = [n for n in dict.fromkeys(fam) if any(s > 0 for s, m in zip(seg, fam) if m == n)]
    paths = []
    for family in families:
        j0 = fam.index(family)
        k, unit = _scaled(units[j0])
        est = _segment_values(f, family, f["estimate/value"][()]) * k
        has_truth = "truth/values" in f
        truth = _segment_values(f, family, f["truth/values"][()]) * k if has_truth else None
        prior = _segment_values(f, family, f["estimate/prior"][()]) * k
        lo = np.nanmin(np.concatenate([est, truth if has_truth else est, prior]))
        hi = np.nanmax(np.concatenate([est, truth if has_truth else est, prior]))
        ncol = 3 if has_truth else 1
        fig, axes = plt.subplots(1, ncol, figsize=(4.6 * ncol, 5.0), squeeze=False)
        what = "contractility" if family == "sigma0" else family
        bullseye(axes[0, 0], est, f"estimated {what} {family}", "viridis", lo, hi,
                 f"{family} [{unit}]")
        if has_truth:
            marked = [s for s in range(1, 18) if np.isfinite(truth[s - 1]) and truth[s - 1] < 0.999 * np.nanmax(truth)]
            bullseye(axes[0, 1], truth, f"truth {family} (bold: reduced)", "viridis", lo, hi,
                     f"{family} [{unit}]", marked=marked)
            err = 100.0 * (est - truth) / truth
            lim = max(10.0, float(np.nanmax(np.abs(err))))
            bullseye(axes[0, 2], err, "error (estimate - truth) / truth", "RdBu_r", -lim, lim,
                     "relative error [%]", fmt="{:+.1f}")
        fig.suptitle(sp.title_of(f, f"AHA 17-segment bull's-eye of {family} (view from the apex)"))
        fig.text(0.01, 0.01, sp.provenance_note(f), fontsize=6, color="gray")
        paths.append(sp.save(fig, out_dir, stem, f"bullseye-{family}"))
    return paths


def _grid(n: int, max_cols: int = 5, width: float = 3.0, height: float = 2.3):
    return sp.grid(n, max_cols, width, height, sharex=True)


def _segment_name(segment: int, count: int) -> str:
    """The AHA name of a 1-based segment when all 17 are shown, else empty."""
    return AHA_NAMES[segment - 1] if 1 <= segment <= 17 and count >= 17 else ""


def _label_panel(ax, name: str, where: str, unit: str):
    ax.set_title(f"{name} {where}".strip(), fontsize=8)
    ax.set_ylabel(f"[{unit}]", fontsize=8)
    ax.tick_params(labelsize=7)


def _finish_grid(f, fig, axes, xlabel: str, ncol: int, title: str, out_dir, stem, suffix):
    """x labels on the bottom row, the first panel's legend for the figure, title, save."""
    for ax in axes[-1, :]:
        ax.set_xlabel(xlabel, fontsize=8)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper right", ncol=ncol)
    fig.suptitle(sp.title_of(f, title), y=1.0)
    fig.tight_layout()
    return [sp.save(fig, out_dir, stem, suffix)]


def _plot_trajectories(f, out_dir, stem) -> List[str]:
    names = strings(f["estimate/names"])
    units = strings(f["estimate/units"])
    seg = np.asarray(f["estimate/segment"][()])
    theta = np.asarray(f["steps/theta"][()])
    lo = np.asarray(f["steps/theta_lower"][()])
    hi = np.asarray(f["steps/theta_upper"][()])
    beat = np.asarray(f["steps/beat"][()])
    frames = len(f["observations/time"][()])
    x = np.arange(theta.shape[0]) / frames  # passes over the measured beat
    truth = np.asarray(f["truth/values"][()]) if "truth/values" in f else None
    prior = np.asarray(f["estimate/prior"][()])
    fig, axes = _grid(len(names))
    for j, name in enumerate(names):
        ax = axes.flat[j]
        k, unit = _scaled(units[j])
        ax.fill_between(x, lo[:, j] * k, hi[:, j] * k, color="tab:blue", alpha=0.25, lw=0,
                        label="\u00b12\u03c3")
        ax.plot(x, theta[:, j] * k, color="tab:blue", lw=1.4, label="estimate")
        ax.axhline(prior[j] * k, color="gray", lw=0.8, ls=":", label="prior")
        if truth is not None:
            ax.axhline(truth[j] * k, color="black", lw=1.2, ls="--", label="truth")
        for b in range(1, int(beat.max()) + 1 if len(beat) else 1):
            ax.axvline(b, color="gray", lw=0.5, alpha=0.5)
        _label_panel(ax, name, _segment_name(seg[j], len(names)), unit)
    return _finish_grid(f, fig, axes, "filter time [passes over the beat]", 4,
                        "ROUKF parameter trajectories", out_dir, stem, "trajectories")


def _plot_volume_fits(f, out_dir, stem) -> List[str]:
    names = strings(f["observations/names"])
    units = strings(f["observations/units"])
    t = np.asarray(f["observations/time"][()]) * 1e3
    y = np.asarray(f["observations/values"][()])
    fitted = np.asarray(f["steps/fitted"][()])
    forecast = np.asarray(f["steps/forecast"][()])
    beat = np.asarray(f["steps/beat"][()])
    frames = len(t)
    first = np.where(beat == 0)[0][:frames]
    last = np.where(beat == beat.max())[0][-frames:]
    noise = np.asarray(f["observations/noise_std"][()])
    fig, axes = _grid(len(names), max_cols=6, width=2.6, height=2.1)
    for c, name in enumerate(names):
        ax = axes.flat[c]
        ax.errorbar(t, y[:, c], yerr=2 * noise[c], fmt="o", ms=2.5, color="black", lw=0.6,
                    label="observed (\u00b12 noise std)")
        if len(first) == frames:
            ax.plot(t, forecast[first, c], color="tab:orange", lw=1.0, ls="--",
                    label="predicted, pass 1")
        if len(last) == frames:
            ax.plot(t, fitted[last, c], color="tab:blue", lw=1.4,
                    label=f"fitted, pass {int(beat.max()) + 1}")
        seg = int(name[-2:]) if name[-2:].isdigit() else 0
        _label_panel(ax, name, _segment_name(seg, len(names)), units[c])
    return _finish_grid(f, fig, axes, "time in beat [ms]", 3, "regional volume fits", out_dir,
                        stem, "volume-fits")


def plot_personalize(f, out_dir: str, stem: str) -> List[str]:
    with plt.rc_context(sp.STYLE):
        return _plot_trajectories(f, out_dir, stem) + _plot_bullseye(f, out_dir, stem) + \
            _plot_volume_fits(f, out_dir, stem)
