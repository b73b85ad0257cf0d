#!/usr/bin/python3
"""Figures of the fit report (app/io/fit_report_io.h, docs/estimation.md s.11): where in the
cardiac cycle the model misses the data.

    /usr/bin/python3 scripts/sigmaplot_discrepancy.py results/volunteer-calibrate.h5 [-g /fit_report] [-o DIR]

- <stem>-discrepancy.png: per channel observed at frames, the observed curve (markers) and the fit
  (line) on the cycle phases shaded (filling, isovolumic contraction, ejection, isovolumic
  relaxation), and under it the residual in noise standard deviations per frame coloured by phase,
  with the +-2 std band; the title gives the channel's RMS and, for channels above the threshold,
  each phase's share of the squared residual. The report's sentence is the figure's caption.
- <stem>-identifiability.png (when the report has one): the posterior correlation matrix and the
  posterior/prior std ratio per parameter, the uninformed threshold drawn.

``plot_discrepancy(f, out_dir, stem, group)`` is what sigmaplot.py's plotters can call for a results
file that carries the group. Exit codes: 0 ok, 2 bad input (missing file or group).
"""
from __future__ import annotations

import argparse
import textwrap
import os
import sys
from typing import List

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))

from sigmaplot_common import curve, plt, provenance_note, save, strings, text, title_of  # noqa: E402

# One colour per CyclePhase code (estimation/fit_report.h order).
PHASE_COLOURS = ["#9ecae1", "#fdd0a2", "#fc9272", "#c7e9c0"]


def phase_spans(times, phases, period):
    """(start, end, code) runs of equal phase; each frame owns the half-intervals around it."""
    n = len(times)
    edges = np.empty(n + 1)
    edges[1:-1] = 0.5 * (times[1:] + times[:-1])
    edges[0] = times[0] - 0.5 * (times[1] - times[0])
    edges[-1] = times[-1] + 0.5 * (period - (times[-1] - times[0])) if period else times[-1]
    spans = []
    start = 0
    for k in range(1, n + 1):
        if k == n or phases[k] != phases[start]:
            spans.append((edges[start], edges[k], int(phases[start])))
            start = k
    return spans


def plot_curves(f, g, out_dir, stem) -> List[str]:
    if "curves" not in g:
        return []
    channels = list(g["curves"].keys())
    names = strings(g["phases/names"]) if "phases" in g else []
    has_phases = "phases" in g
    fig, axes = plt.subplots(2, len(channels), figsize=(5.4 * len(channels), 6.4), squeeze=False,
                             sharex="col", gridspec_kw={"height_ratios": [3, 2]})
    for col, ch in enumerate(channels):
        c = g["curves"][ch]
        t = c["time"][()] * 1e3
        observed, unit = curve(c, "observed")
        fitted = c["fitted"][()]
        r = c["normalised_residual"][()]
        top, bottom = axes[0][col], axes[1][col]
        codes = np.zeros(len(t), dtype=int)
        if has_phases:
            pt = g["phases/time"][()] * 1e3
            pc = g["phases/phase"][()]
            if len(pt) == len(t) and np.allclose(pt, t):
                codes = pc
                dt = np.mean(np.diff(pt)) if len(pt) > 1 else 0.0
                period = pt[-1] - pt[0] + dt
                for a, b, code in phase_spans(pt, pc, period):
                    for ax in (top, bottom):
                        ax.axvspan(a, b, color=PHASE_COLOURS[code], alpha=0.35, lw=0, zorder=0)
        top.plot(t, observed, "o", color="#1f77b4", ms=4, label="observed frames")
        top.plot(t, fitted, "-", color="#d62728", lw=1.8, label="fit")
        top.set_ylabel(f"{ch} [{unit}]")
        rms = float(g["channels/rms_normalised"][()][strings(g["channels/names"]).index(ch)])
        title = f"{ch}: RMS {rms:.2f} noise std"
        if "discrepancy" in g and ch in g["discrepancy"]:
            d = g["discrepancy"][ch]
            shares = d["share"][()]
            parts = [f"{n} {100 * s:.0f} %" for n, s in zip(strings(d["phase_names"]), shares) if s > 0.005]
            title += "".join((",\n" if k % 2 == 0 else ", ") + p for k, p in enumerate(parts))[1:]
        top.set_title(title, fontsize=10)
        colours = [PHASE_COLOURS[int(k)] if has_phases else "#777777" for k in codes]
        bottom.axhspan(-2, 2, color="#eeeeee", zorder=0)
        bottom.bar(t, r, width=0.8 * (np.mean(np.diff(t)) if len(t) > 1 else 1.0), color=colours,
                   edgecolor="#444444", lw=0.5, zorder=2)
        bottom.axhline(0, color="#444444", lw=0.8)
        bottom.set_ylabel("(observed \u2212 fit) / noise std [-]")
        bottom.set_xlabel("time after end-diastole [ms]")
    axes[0][0].legend(loc="best", fontsize=8)
    if names:
        handles = [plt.Rectangle((0, 0), 1, 1, color=PHASE_COLOURS[k], alpha=0.6) for k in range(len(names))]
        fig.legend(handles, names, loc="lower center", bbox_to_anchor=(0.5, 0.985), ncol=len(names), fontsize=8,
                   frameon=False)
    fig.suptitle(title_of(f, "fit report: residual by cycle phase"), y=1.06)
    summary = textwrap.fill(text(g.attrs.get("summary", "")), width=int(52 * len(channels)))
    fig.text(0.01, -0.02, summary, ha="left", va="top", fontsize=8)
    fig.text(0.99, -0.07, provenance_note(f), ha="right", va="top", fontsize=7, color="#777777")
    fig.tight_layout()
    return [save(fig, out_dir, stem, "discrepancy")]


def plot_identifiability(f, g, out_dir, stem) -> List[str]:
    if "identifiability" not in g:
        return []
    i = g["identifiability"]
    names = strings(i["names"])
    corr = i["correlation"][()]
    ratio = i["std_ratio"][()]
    threshold = float(i.attrs.get("uninformed_ratio", 0.9))
    fig, (a, b) = plt.subplots(1, 2, figsize=(4.2 + 0.9 * len(names), 3.8),
                               gridspec_kw={"width_ratios": [1.2, 1]})
    im = a.imshow(corr, vmin=-1, vmax=1, cmap="RdBu_r")
    a.set_xticks(range(len(names)), names, rotation=60, fontsize=8)
    a.set_yticks(range(len(names)), names, fontsize=8)
    a.grid(False)
    for (r, c), v in np.ndenumerate(corr):
        a.text(c, r, f"{v:.2f}", ha="center", va="center", fontsize=7,
               color="white" if abs(v) > 0.6 else "black")
    fig.colorbar(im, ax=a, label="posterior correlation [-]")
    b.bar(range(len(names)), ratio, color=["#d62728" if v > threshold else "#2ca02c" for v in ratio])
    b.axhline(threshold, color="#444444", ls="--", lw=1, label=f"not informed above {threshold:g}")
    b.set_xticks(range(len(names)), names, rotation=60, fontsize=8)
    b.set_ylabel("posterior std / prior std [-]")
    b.legend(loc="best", fontsize=8)
    fig.suptitle(title_of(f, "identifiability"))
    fig.tight_layout()
    return [save(fig, out_dir, stem, "identifiability")]


def plot_discrepancy(f, out_dir: str, stem: str, group: str = "fit_report") -> List[str]:
    g = f[group.strip("/")]
    return plot_curves(f, g, out_dir, stem) + plot_identifiability(f, g, out_dir, stem)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("result", help="results file (HDF5) with a fit report group")
    parser.add_argument("-g", "--group", default="/fit_report", help="the report's group (default /fit_report)")
    parser.add_argument("-o", "--output-dir", help="directory for the PNGs (default: beside the file)")
    args = parser.parse_args()
    import h5py

    if not os.path.isfile(args.result):
        print(f"error: {args.result}: no such file", file=sys.stderr)
        return 2
    out_dir = args.output_dir or os.path.dirname(os.path.abspath(args.result))
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.splitext(os.path.basename(args.result))[0]
    with h5py.File(args.result, "r") as f:
        if args.group.strip("/") not in f:
            print(f"error: {args.result}: no group {args.group} (written by app/io/fit_report_io.h)",
                  file=sys.stderr)
            return 2
        for path in plot_discrepancy(f, out_dir, stem, args.group):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
