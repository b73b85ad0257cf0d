"""Figures of `sigmaheart therapy` results (kind "therapy"): the lead-site bull's-eye of the acute
haemodynamic response (mean and 90 % interval), the PV loops at baseline and at the best site, and
the AV/VV sweep at the best site (docs/estimation.md s.12)."""
from __future__ import annotations

from typing import List

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from sigmaplot_common import provenance_note, save, strings, text, title_of, trajectory_curve  # noqa: E402
from sigmaplot_regional import bullseye  # noqa: E402


def _site_values(f, column):
    """17 values by LV segment of the first pacing mode's map (NaN where no site)."""
    seg = np.asarray(f["map/lv_segment"][()])
    mode = strings(f["map/mode"])
    out = np.full(17, np.nan)
    first = mode[0] if mode else ""
    for k, (s, m) in enumerate(zip(seg, mode)):
        if m == first and 1 <= s <= 17 and np.isnan(out[s - 1]):
            out[s - 1] = column[k]
    return out


def _plot_map(f, out_dir, stem) -> List[str]:
    names = strings(f["responses/change_names"])
    j = names.index("AHR")
    mean = _site_values(f, f["map/change_mean"][()][:, j])
    lower = _site_values(f, f["map/change_lower"][()][:, j])
    upper = _site_values(f, f["map/change_upper"][()][:, j])
    p_best = _site_values(f, f["map/p_best"][()])
    best = int(f["best"].attrs.get("index", -1))
    best_seg = int(f["map/lv_segment"][()][best]) if best >= 0 else 0
    span = np.nanmax(np.abs(np.concatenate([lower, upper]))) if np.isfinite(mean).any() else 10.0
    fig, axes = plt.subplots(1, 3, figsize=(12.5, 4.8))
    bullseye(axes[0], mean, "AHR, mean", "RdBu_r", -span, span, "dP/dt max change [%]",
             fmt="{:.1f}", marked=(best_seg,) if best_seg else ())
    width = upper - lower
    model_error = float(f["summary"].attrs.get("model_error_ahr", 0.0))
    width_title = "AHR, width of the 90 % interval" + (
        f"\n(with the model error, {model_error:.3g} points SD)" if model_error > 0 else "")
    bullseye(axes[1], width, width_title, "viridis", 0.0,
             max(np.nanmax(width), 0.1) if np.isfinite(width).any() else 1.0, "percentage points",
             fmt="{:.1f}")
    bullseye(axes[2], p_best, "probability of the best site", "viridis", 0.0, 1.0, "P(best)", fmt="{:.2f}")
    fig.suptitle(title_of(f, "lead-site map") + f"   (best: {text(f['best'].attrs.get('label', 'none'))})")
    fig.text(0.01, 0.01, provenance_note(f), fontsize=6, color="gray")
    return [save(fig, out_dir, stem, "lead-map")]


def _plot_loops(f, out_dir, stem) -> List[str]:
    if "trajectories/baseline" not in f:
        return []
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    for which, style, label in (("baseline", "-", "baseline"), ("best", "--", "best site")):
        if f"trajectories/{which}" not in f:
            continue
        _, v, _ = trajectory_curve(f, which, "V_lv")
        _, p, _ = trajectory_curve(f, which, "P_lv")
        ax.plot(v, p, style, label=label)  # written in mL and mmHg
    ax.set_xlabel("V_lv [mL]")
    ax.set_ylabel("P_lv [mmHg]")
    ax.legend()
    ax.set_title(title_of(f, "PV loops at the posterior mean"))
    return [save(fig, out_dir, stem, "pv-loops")]


def _plot_sweep(f, out_dir, stem) -> List[str]:
    if "sweep" not in f:
        return []
    names = strings(f["responses/change_names"])
    j = names.index("AHR")
    labels = strings(f["sweep/label"])
    av = np.asarray(f["sweep/av_delay"][()])
    vv = np.asarray(f["sweep/vv_delay"][()])
    mean, lo, hi = (f[f"sweep/change_{k}"][()][:, j] for k in ("mean", "lower", "upper"))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, x in ((axes[0], "AV", av), (axes[1], "VV", vv)):
        sel = np.array([lab.startswith(key + " ") for lab in labels])
        if not sel.any():
            ax.set_visible(False)
            continue
        order = np.argsort(x[sel])
        xs, m = x[sel][order], mean[sel][order]
        ax.fill_between(xs, lo[sel][order], hi[sel][order], alpha=0.3, label="90 % interval")
        ax.plot(xs, m, "o-", label="mean")
        ax.axhline(float(f["summary"].attrs.get("responder_threshold", 10.0)), color="gray", ls=":",
                   label="responder threshold")
        ax.set_xlabel(f"{key} delay [ms]" + (" (> 0: LV first)" if key == "VV" else ""))
        ax.set_ylabel("AHR [%]")
        ax.legend(fontsize=8)
    fig.suptitle(title_of(f, "AV/VV sweep at the best site"))
    return [save(fig, out_dir, stem, "sweep")]


def plot_therapy(f, out_dir: str, stem: str) -> List[str]:
    return _plot_map(f, out_dir, stem) + _plot_loops(f, out_dir, stem) + _plot_sweep(f, out_dir, stem)
