#!/usr/bin/python3
"""The table of the foreign regional bench (README.md) from the `personalize` JSON summaries.

    experiments/regional-foreign/summarize.py RESULTS_DIR [--markdown]

Per case: how the run ended, whole-data NIS against its 95 % band, the contractility map (median
of segments 1-16 and the lowest three relative to it), the infarct found or not (AUC of the
infarct against the other segments, lower contractility = infarct; ties count one half), whether a
late-activated healthy segment is among the estimated scar (contractility below 60 % of the
median), the lowest segment relative to the median (healthy and LBBB-only hearts: none below
60 %), member runs and wall time. Segment 17 holds no cavity volume in lv-3d (docs/models.md s.5),
is not observed and is left out of every statistic. Exit 1 when a target is missed.
"""
import json
import sys
from pathlib import Path

# The bench's cases (make-data): infarct segments (40 % contractility in the 3D heart).
CASES = {
    "healthy": [],
    "lbbb": [],
    "lbbb-lad-large": [1, 2, 7, 8, 13, 14, 17],
    "lbbb-lad-small": [7, 13, 14],
    "lbbb-lcx-large": [5, 6, 11, 12, 16],
    "lbbb-lcx-small": [5, 6, 11],
    "lbbb-rca-large": [3, 4, 9, 10, 15],
    "lbbb-rca-small": [4, 10, 15],
}
# The latest-activated segments of the lv-3d LBBB pattern (docs/models.md s.4.6: lateral wall).
LATE = [5, 6, 11, 12, 16]
SEGMENTS = list(range(1, 17))
SCAR_FRACTION = 0.6  # estimated scar: below 60 % of the median contractility


def auc(values, positives):
    """P(value of a positive < value of a negative), ties 1/2."""
    pos = [values[s] for s in positives if s in values]
    neg = [values[s] for s in values if s not in positives]
    if not pos or not neg:
        return float("nan")
    wins = sum((p < n) + 0.5 * (p == n) for p in pos for n in neg)
    return wins / (len(pos) * len(neg))


def summarize(name, j, infarct=None):
    """One case's row; infarct: its infarct segments when the case is not one of CASES."""
    params = j["parameters"]
    sigma = {s: params[f"sigma0_{s:02d}"]["value"] for s in SEGMENTS if f"sigma0_{s:02d}" in params}
    median = sorted(sigma.values())[len(sigma) // 2] if len(sigma) % 2 else \
        0.5 * sum(sorted(sigma.values())[len(sigma) // 2 - 1:len(sigma) // 2 + 1])
    rel = {s: v / median for s, v in sigma.items()}
    infarct = [s for s in (CASES.get(name, []) if infarct is None else infarct) if s in sigma]
    scar = sorted(s for s, r in rel.items() if r < SCAR_FRACTION)
    late_healthy_in_scar = [s for s in scar if s in LATE and s not in infarct]
    mr = j.get("map_refinement", {})
    lo, hi = j["nis_band_95"]
    row = {
        "case": name,
        "termination": j["termination"],
        "map_converged": bool(mr.get("converged", False)),
        "map_steps": mr.get("steps", 0), "map_runs": mr.get("runs", 0),
        "map_on": ("objective" if "(objective)" in mr.get("note", "") else "step")
                  if mr.get("converged") else "not converged",
        "map_fell": mr.get("objective_at_filter_estimate", float("nan")) - mr.get("objective_at_estimate", float("nan")),
        "nis": j["nis_mean"], "band": (lo, hi),
        "nis_within_twice_band": j["nis_mean"] <= 2 * hi,
        "median_kPa": median / 1e3,
        "lowest": sorted(rel.items(), key=lambda kv: kv[1])[:3],
        "scar": scar,
        "auc": auc(sigma, infarct) if infarct else float("nan"),
        "late_healthy_in_scar": late_healthy_in_scar,
        "min_rel": min(rel.values()),
        "runs": j["member_runs"], "seconds": j["wall_seconds"],
        "uninformed": [k for k, p in params.items() if p.get("informed") is False],
    }
    ok = row["termination"] == "completed" and row["nis_within_twice_band"] and not late_healthy_in_scar
    ok = ok and (row["auc"] >= 0.9 if infarct else row["min_rel"] >= SCAR_FRACTION)
    row["targets_met"] = ok
    return row


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    out = Path(sys.argv[1])
    rows = []
    for name in CASES:
        f = out / f"{name}.json"
        if not f.exists():
            print(f"{name}: no results ({f})", file=sys.stderr)
            continue
        rows.append(summarize(name, json.loads(f.read_text())))
    print("| case | ended | MAP refinement: stop, steps, runs, Phi fell by | NIS (95 % band) | median sigma0 [kPa] | "
          "lowest three (x median) | estimated scar (< 60 %) | AUC | late healthy in scar | min / median | runs | "
          "time [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        lowest = ", ".join(f"{s}: {v:.2f}" for s, v in r["lowest"])
        ended = r["termination"] + ("" if r["termination"] == "completed" else
                                    (" (MAP converged)" if r["map_converged"] else ""))
        refinement = f"{r['map_on']}, {r['map_steps']}, {r['map_runs']}, {r['map_fell']:.1f}"
        print(f"| {r['case']} | {ended} | {refinement} | {r['nis']:.1f} ({r['band'][0]:.1f}-{r['band'][1]:.1f}) | "
              f"{r['median_kPa']:.1f} | {lowest} | {r['scar'] or '-'} | "
              f"{'-' if r['auc'] != r['auc'] else format(r['auc'], '.3f')} | "
              f"{r['late_healthy_in_scar'] or 'none'} | {r['min_rel']:.2f} | {r['runs']} | {r['seconds']:.0f} |")
    missed = [r["case"] for r in rows if not r["targets_met"]]
    print(f"\ntargets met in {len(rows) - len(missed)} of {len(rows)} cases" +
          (f"; missed: {', '.join(missed)}" if missed else ""))
    return 1 if missed or len(rows) < len(CASES) else 0


if __name__ == "__main__":
    sys.exit(main())
