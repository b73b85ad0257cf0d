#!/usr/bin/python3
"""Indices of `sigmaheart simulate --csv` beats, for the LBBB response of both models (README.md):

    experiments/regional-foreign/beat_indices.py BEAT.csv [BEAT.csv ...]

EDV, ESV, SV [mL], EF [%], dP/dt max [mmHg/s] (largest centred difference quotient of P_lv on the
output grid), aortic valve opening and closing and mitral opening [s] (from the `phase` channel), and the
largest and smallest regional share of the mid septum (V_seg08) and the basal inferolateral wall
(V_seg05): V_seg / V_lv relative to its value at end-diastole (the largest V_lv).
"""
import csv
import sys

import numpy as np


def load(path):
    rows = [r for r in csv.reader(line for line in open(path) if not line.startswith("#"))]
    head = [h.split(" [")[0].strip() for h in rows[0]]
    data = np.array([[float(x) for x in r] for r in rows[1:] if r])
    return {name: data[:, i] for i, name in enumerate(head)}


def main():
    for path in sys.argv[1:]:
        d = load(path)
        t = d["time"] / (1000.0 if d["time"][-1] > 5 else 1.0)
        V, P, phase = d["V_lv"], d["P_lv"], d["phase"]
        dpdt = np.max(np.gradient(P, t))
        ejection = np.where(phase == 2)[0]
        filling = [k for k in np.where(phase == 0)[0] if len(ejection) and k > ejection[-1]]
        ed = int(np.argmax(V))
        share = {}
        for s in (8, 5):
            r = d[f"V_seg{s:02d}"] / V
            r = r / r[ed]
            share[s] = (r.min(), r.max())
        print(f"{path}: EDV {V.max():.1f} ESV {V.min():.1f} SV {V.max() - V.min():.1f} mL, "
              f"EF {100 * (1 - V.min() / V.max()):.1f} %, dP/dt max {dpdt:.0f} mmHg/s, "
              f"AVO {t[ejection[0]]:.3f} AVC {t[ejection[-1]]:.3f} MVO {t[filling[0]] if filling else float('nan'):.3f} s, "
              f"share seg08 {share[8][0]:.2f}-{share[8][1]:.2f}, seg05 {share[5][0]:.2f}-{share[5][1]:.2f}")


if __name__ == "__main__":
    main()
