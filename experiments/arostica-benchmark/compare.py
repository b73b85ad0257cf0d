#!/usr/bin/env python3
"""Our Arostica et al. 2025 Step 1 curves against the teams' ensemble: numbers and a plot.

  /usr/bin/python3 experiments/arostica-benchmark/compare.py ours.csv [more.csv ...] \
      [--labels a,b] [--plot arostica_step1.png]

ours.csv: the output of `sigmaheart benchmark arostica -o ours.csv` (metres, every 0.01 s).
Reference: configs/data/arostica-2025/step1_ensemble.csv and step1_teams.csv (mm). Prints, per
curve, the p0/p1 ux minimum against the teams' range, the largest distance to the ensemble mean
over the plateau 0.30-0.48 s in units of the teams' std, and RED (toolkit definition: mean over
the 101 samples of |u - u_mean| / |u_mean|) beside the teams' REDs. Numpy (+ matplotlib for --plot).
"""
import argparse
import csv
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "configs", "data", "arostica-2025")


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("curves", nargs="+")
    ap.add_argument("--labels", default="")
    ap.add_argument("--plot", default="")
    args = ap.parse_args()
    ref = read_csv(os.path.join(DATA, "step1_ensemble.csv"))
    with open(os.path.join(DATA, "step1_teams.csv")) as f:
        teams = list(csv.DictReader(f))
    labels = args.labels.split(",") if args.labels else [os.path.basename(c) for c in args.curves]
    tref = ref["time_s"]
    mean = {p: np.stack([ref[f"{p}_{c}_mean_mm"] for c in ("ux", "uy", "uz")], axis=1) for p in ("p0", "p1")}
    plateau = (tref >= 0.3 - 1e-9) & (tref <= 0.48 + 1e-9)
    for p in ("p0", "p1"):
        lo = min(float(t[f"{p}_ux_min_mm"]) for t in teams)
        hi = max(float(t[f"{p}_ux_min_mm"]) for t in teams)
        reds = [float(t[f"red_{p}"]) for t in teams]
        print(f"{p}: teams' ux minimum {lo:.3f} .. {hi:.3f} mm; teams' RED {min(reds):.3f} .. {max(reds):.3f}")
    ours = []
    for path, lab in zip(args.curves, labels):
        d = read_csv(path)
        t = d["time_s"]
        u = {p: 1e3 * np.stack([d[f"{p}_{c}_m"] for c in ("ux", "uy", "uz")], axis=1) for p in ("p0", "p1")}
        ours.append((lab, t, u))
        if len(t) != len(tref) or np.max(np.abs(t - tref)) > 1e-9:
            print(f"{lab}: sampled at other times than the reference ({len(t)} samples); RED skipped")
        for p in ("p0", "p1"):
            k = int(np.argmin(u[p][:, 0]))
            line = f"{lab} {p}: ux min {u[p][k, 0]:.3f} mm at {t[k]:.2f} s"
            if len(t) == len(tref):
                red = np.mean(np.linalg.norm(u[p] - mean[p], axis=1) / np.linalg.norm(mean[p], axis=1))
                z = np.abs(u[p][plateau, 0] - ref[f"{p}_ux_mean_mm"][plateau]) / ref[f"{p}_ux_std_mm"][plateau]
                inside = np.all((u[p][plateau, 0] >= ref[f"{p}_ux_min_mm"][plateau]) &
                                (u[p][plateau, 0] <= ref[f"{p}_ux_max_mm"][plateau]))
                line += (f"; RED {red:.4f}; plateau 0.30-0.48 s: max |ux - mean| = {z.max():.2f} std, "
                         f"{'inside' if inside else 'NOT inside'} the teams' min..max")
            print(line)
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharex=True)
        for i, p in enumerate(("p0", "p1")):
            for j, c in enumerate(("ux", "uy", "uz")):
                ax = axes[i, j]
                ax.fill_between(tref, ref[f"{p}_{c}_min_mm"], ref[f"{p}_{c}_max_mm"], color="0.8",
                                label="10 teams: min..max")
                ax.plot(tref, ref[f"{p}_{c}_mean_mm"], "k--", lw=1, label="teams' mean")
                for lab, t, u in ours:
                    ax.plot(t, u[p][:, j], lw=1.2, label=lab)
                ax.set_title(f"{p} {c}")
                ax.set_ylabel("mm")
                if i == 1:
                    ax.set_xlabel("t [s]")
        axes[0, 0].legend(fontsize=7)
        fig.suptitle("Arostica et al. 2025, Benchmark 1 / Step 1: sigmaheart against the participating codes")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
