"""Figures of `sigmaheart simulate` results (kind "simulate"; app/commands/simulate.cpp).

- <stem>-pv-loop.png: the pressure-volume loop coloured by cardiac phase, end-diastole and
  end-systole marked, the summary indices (EDV, ESV, EF, P_max) inside the loop;
- <stem>-curves.png: LV volume, and LV, aortic and atrial pressure over the periodic beat with the
  phases shaded;
- <stem>-regional-volumes.png (models with channels V_seg01..V_segNN: lumped-regional, lv-3d): the
  regional cavity volumes over the beat, one panel per AHA level (basal 1-6, mid 7-12, apical
  13-16, apex 17), and the bull's-eye of the regional ejection fraction (max - min) / max of each
  segment's volume.
"""
from __future__ import annotations

from typing import List

import numpy as np
from matplotlib.patches import Patch

import sigmaplot_regional
from sigmaplot_common import STYLE, curve, plt, provenance_note, save, text, title_of

# The phase channel of the lumped and 3D simulators (model/lumped/sphere.cpp, channel "phase").
PHASES = {
    0: ("filling", "#9ecae1"),
    1: ("isovolumic contraction", "#fdae6b"),
    2: ("ejection", "#e6550d"),
    3: ("isovolumic relaxation", "#a1d99b"),
}


def phase_runs(time: np.ndarray, phase: np.ndarray):
    """Contiguous runs (t_start, t_end, phase) of the phase channel, ends at sample midpoints."""
    if len(time) == 0:
        return []
    edges = np.concatenate(([time[0]], 0.5 * (time[1:] + time[:-1]), [time[-1]]))
    runs, start = [], 0
    for k in range(1, len(phase) + 1):
        if k == len(phase) or phase[k] != phase[start]:
            runs.append((edges[start], edges[k], int(round(phase[start]))))
            start = k
    return runs


def shade_phases(ax, time, phase):
    """Shades the cardiac phases behind a time axis; returns legend handles of the phases seen."""
    seen = []
    for t0, t1, p in phase_runs(time, phase):
        label, color = PHASES.get(p, (f"phase {p}", "#dddddd"))
        ax.axvspan(t0, t1, color=color, alpha=0.25, lw=0, zorder=0)
        if p not in seen:
            seen.append(p)
    return [Patch(facecolor=PHASES.get(p, ("", "#dddddd"))[1], alpha=0.5,
                  label=PHASES.get(p, (f"phase {p}", ""))[0]) for p in sorted(seen)]


def plot_simulate(f, out_dir: str, stem: str) -> List[str]:
    """PV loop coloured by phase, and volume and pressure curves with the phases shaded."""
    g = f["trajectories/simulated"]
    time, time_unit = curve(g, "time")
    volume = curve(g, "V_lv")
    p_lv = curve(g, "P_lv")
    phase = curve(g, "phase")
    written = []
    with plt.rc_context(STYLE):
        if volume is not None and p_lv is not None:
            written.append(save(pv_loop(f, volume, p_lv, phase), out_dir, stem, "pv-loop"))
        written.append(save(curves(f, g, time, time_unit, phase), out_dir, stem, "curves"))
        segments = sorted(int(k[5:]) for k in g.keys() if k.startswith("V_seg") and k[5:].isdigit())
        if segments:
            written.append(save(regional_volumes(f, g, time, time_unit, phase, segments), out_dir, stem,
                                "regional-volumes"))
    return written


# AHA levels (Cerqueira et al. 2002) for the panels of the regional volume figure.
LEVELS = [("basal", range(1, 7)), ("mid-cavity", range(7, 13)), ("apical", range(13, 17)), ("apex", range(17, 18))]


def regional_volumes(f, g, time, time_unit, phase, segments, regional_ef=None,
                     ef_label="(max - min) / max of V_seg [%]", title="Regional cavity volumes over the periodic beat"):
    """One panel per AHA level with its segments' volume curves, then the regional-EF bull's-eye
    (`regional_ef` [%] per segment when given, else (max - min) / max of each curve)."""
    fig = plt.figure(figsize=(13, 6.5))
    grid = fig.add_gridspec(2, 3, width_ratios=[1, 1, 1.1])
    panels = [fig.add_subplot(grid[r, c]) for r, c in ((0, 0), (0, 1), (1, 0), (1, 1))]
    ax_eye = fig.add_subplot(grid[:, 2])
    colors = plt.get_cmap("tab10")
    given = regional_ef is not None
    regional_ef = np.array(regional_ef, dtype=float) if given else np.full(17, np.nan)
    unit = ""
    for ax, (level, members) in zip(panels, LEVELS):
        if phase is not None:
            shade_phases(ax, time, phase[0])
        for j, s in enumerate(m for m in members if m in segments):
            v, unit = curve(g, f"V_seg{s:02d}")
            name = sigmaplot_regional.AHA_NAMES[s - 1] if len(segments) == 17 else f"segment {s}"
            ax.plot(time, v, color=colors(j), lw=1.6, label=f"{s}: {name}")
            if not given and np.max(v) > 0:
                regional_ef[s - 1] = 100.0 * (np.max(v) - np.min(v)) / np.max(v)
        ax.set_title(f"{level} segments", fontsize=9)
        ax.set_ylabel(f"volume [{unit}]", fontsize=8)
        ax.set_xlim(time[0], time[-1])
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6.5, loc="lower left")
    for ax in panels[2:]:
        ax.set_xlabel(f"time in beat [{time_unit}]", fontsize=8)
    if len(segments) == 17:
        finite = regional_ef[np.isfinite(regional_ef)]
        lo, hi = (float(np.min(finite)), float(np.max(finite))) if finite.size else (0.0, 1.0)
        sigmaplot_regional.bullseye(ax_eye, regional_ef, "regional ejection fraction", "viridis", lo,
                                    max(hi, lo + 1e-9), ef_label)
    else:
        ax_eye.set_visible(False)
    fig.suptitle(title_of(f, title))
    fig.text(0.99, 0.0, provenance_note(f), ha="right", va="bottom", fontsize=6, color="0.5")
    fig.tight_layout()
    return fig


def pv_loop(f, volume, pressure, phase):
    (v, v_unit), (p, p_unit) = volume, pressure
    fig, ax = plt.subplots(figsize=(5.5, 5))
    if phase is not None:
        ph = phase[0]
        for code, (label, color) in PHASES.items():
            mask = ph == code
            if not mask.any():
                continue
            # Segments of consecutive samples in this phase (joined to the next sample).
            idx = np.flatnonzero(mask)
            breaks = np.flatnonzero(np.diff(idx) > 1)
            for seg_i, seg in enumerate(np.split(idx, breaks + 1)):
                seg = np.append(seg, min(seg[-1] + 1, len(v) - 1))
                ax.plot(v[seg], p[seg], color=color, lw=2.2,
                        label=label if seg_i == 0 else None, solid_capstyle="round")
    else:
        ax.plot(v, p, color="k", lw=2, label="LV")
    ed, es = int(np.argmax(v)), int(np.argmin(v))
    ax.plot(v[ed], p[ed], "o", color="#08519c", ms=7, zorder=5,
            label=f"end-diastole ({v[ed]:.0f} {v_unit}, {p[ed]:.1f} {p_unit})")
    ax.plot(v[es], p[es], "s", color="#a50f15", ms=7, zorder=5,
            label=f"end-systole ({v[es]:.0f} {v_unit}, {p[es]:.0f} {p_unit})")
    ax.set_xlabel(f"LV volume [{v_unit}]")
    ax.set_ylabel(f"LV pressure [{p_unit}]")
    ax.set_ylim(bottom=min(0.0, float(np.min(p))))
    ax.set_title(title_of(f, "Pressure-volume loop"))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8)
    add_summary_box(f, ax)
    fig.text(0.99, 0.0, provenance_note(f), ha="right", va="bottom", fontsize=6, color="0.5")
    return fig


def add_summary_box(f, ax):
    if "summary" not in f:
        return
    s = f["summary"].attrs
    lines = []
    for name, fmt in (("EDV", "{:.0f}"), ("ESV", "{:.0f}"), ("EF", "{:.0f}"), ("P_max", "{:.0f}")):
        if name in s:
            lines.append(f"{name} {fmt.format(float(s[name]))} {text(s.get(name + '.units', ''))}")
    if lines:
        # Inside the loop, where no curve runs.
        ax.text(0.45, 0.5, "\n".join(lines), transform=ax.transAxes, va="center", ha="center",
                fontsize=8, family="monospace",
                bbox=dict(boxstyle="round", facecolor="white", edgecolor="0.8", alpha=0.9))


def curves(f, g, time, time_unit, phase):
    fig, (ax_v, ax_p) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True,
                                     gridspec_kw=dict(height_ratios=[1, 1.3]))
    handles = []
    for ax in (ax_v, ax_p):
        if phase is not None:
            handles = shade_phases(ax, time, phase[0])
    volume = curve(g, "V_lv")
    if volume is not None:
        ax_v.plot(time, volume[0], color="#08519c", lw=2, label="LV volume")
        ax_v.set_ylabel(f"volume [{volume[1]}]")
    pressures = [("P_lv", "LV", "#a50f15", "-"), ("P_ar", "aortic", "#252525", "-"),
                 ("P_at", "atrial", "#31a354", "--")]
    unit = ""
    for name, label, color, ls in pressures:
        c = curve(g, name)
        if c is not None:
            ax_p.plot(time, c[0], color=color, ls=ls, lw=1.8, label=label)
            unit = c[1]
    ax_p.set_ylabel(f"pressure [{unit}]")
    ax_p.set_xlabel(f"time in beat [{time_unit}]")
    ax_p.set_xlim(time[0], time[-1])
    ax_v.legend(loc="lower left", fontsize=8)
    lines = ax_p.legend(loc="upper right", fontsize=8)
    if handles:
        ax_p.add_artist(lines)
        fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8,
                   bbox_to_anchor=(0.5, 0.025), title="cardiac phase", title_fontsize=8)
    ax_v.set_title(title_of(f, "Volume and pressure over the periodic beat"))
    fig.text(0.99, 0.0, provenance_note(f), ha="right", va="bottom", fontsize=6, color="0.5")
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    return fig
