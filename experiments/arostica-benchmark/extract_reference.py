#!/usr/bin/env python3
"""Step 1 reference curves of the Arostica et al. 2025 cardiac elastodynamics benchmark.

Reads the participating teams' Benchmark 1 / Step 1 curves from the organisers' toolkit
(github.com/Reidmen/cardiac_benchmark_toolkit, results/data/
monoventricular_nonblinded_step_1_group_<team>.pickle, MIT licence) and writes, in mm:

  step1_ensemble.csv  per time sample t_k = 0.01 k s (k = 0..100) and per point/component
                      (p0, p1 x ux, uy, uz): mean, population std, min and max over the teams;
  step1_teams.csv     per team: the p0 and p1 ux minimum and its time, and RED (relative error to
                      the ensemble mean, as the toolkit's results/figures.py defines it:
                      mean over samples of |u_i - u_mean| / |u_mean|, vectors of (ux, uy, uz));
  ellipsoid_0.005.h5  the organisers' tetrahedral mesh (data/monoventricle_mesh/ellipsoid_0.005.h5,
                      legacy DOLFIN HDF5: geometry, topology, facet markers 1 endo / 2 epi / 3 base),
                      the same datasets and values repacked with gzip (1.17 MB -> 0.32 MB); needs h5py.

Curves are stacked by sample index, as the toolkit and the paper do (Ambit and Simula sample at
0.001, 0.01, ..., Simula ends at 0.999 s). Numpy only. The pickles are trusted input (they hold
numpy arrays; unpickling runs code from the file).

Usage (either a checkout of the toolkit or its bare git directory):
  /usr/bin/python3 experiments/arostica-benchmark/extract_reference.py \
      --git-dir /path/to/cardiac_benchmark_toolkit.git --out configs/data/arostica-2025
  /usr/bin/python3 experiments/arostica-benchmark/extract_reference.py --toolkit /path/to/checkout --out ...
"""
import argparse
import io
import os
import pickle
import subprocess

import numpy as np

TEAMS = ["carpentry", "ambit", "4c", "simula", "chimera", "cheart", "lifex", "simvascular_p1p1", "simvascular_p2",
         "comsol"]
POINTS = ["p0", "p1"]
COMPONENTS = ["ux", "uy", "uz"]
PATH = "results/data/monoventricular_nonblinded_step_1_group_{}.pickle"
MESH = "data/monoventricle_mesh/ellipsoid_0.005.h5"
MESH_DATASETS = ["Mesh/mesh/geometry", "Mesh/mesh/topology", "MeshFunction/0/mesh/topology", "MeshFunction/0/values"]


def read_raw(args, path):
    if args.git_dir:
        raw = subprocess.run(["git", "--git-dir", args.git_dir, "show", f"{args.commit}:{path}"], check=True,
                             capture_output=True).stdout
    else:
        with open(os.path.join(args.toolkit, path), "rb") as f:
            raw = f.read()
    return raw


def load(args, team):
    return pickle.load(io.BytesIO(read_raw(args, PATH.format(team))))


def repack_mesh(args):
    import h5py  # Debian python3-h5py
    with h5py.File(io.BytesIO(read_raw(args, MESH)), "r") as src, \
            h5py.File(os.path.join(args.out, "ellipsoid_0.005.h5"), "w") as dst:
        for name in MESH_DATASETS:
            dst.create_dataset(name, data=src[name][()], compression="gzip", compression_opts=9, shuffle=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--git-dir", help="bare git directory of Reidmen/cardiac_benchmark_toolkit")
    src.add_argument("--toolkit", help="checkout of Reidmen/cardiac_benchmark_toolkit")
    ap.add_argument("--commit", default="e8d47553cfc83eb274eba3e177de33148e7f441c")
    ap.add_argument("--out", required=True, help="output directory")
    args = ap.parse_args()

    data = {}  # team -> (101, 2, 3) in mm
    for team in TEAMS:
        d = load(args, team)
        arr = np.stack([np.stack([np.asarray(d["displacement"][p][c], dtype=float) for c in COMPONENTS], axis=1)
                        for p in POINTS], axis=1)
        if arr.shape != (101, 2, 3):
            raise SystemExit(f"{team}: expected 101 samples, got {arr.shape}")
        data[team] = 1e3 * arr
    stack = np.stack([data[t] for t in TEAMS])  # (teams, 101, 2, 3)
    mean, std = stack.mean(axis=0), stack.std(axis=0)
    lo, hi = stack.min(axis=0), stack.max(axis=0)
    time = 0.01 * np.arange(101)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "step1_ensemble.csv"), "w") as f:
        cols = [f"{p}_{c}_{s}_mm" for p in POINTS for c in COMPONENTS for s in ("mean", "std", "min", "max")]
        f.write("time_s," + ",".join(cols) + "\n")
        for k in range(101):
            vals = [v[k, i, j] for i in range(2) for j in range(3) for v in (mean, std, lo, hi)]
            f.write(f"{time[k]:.2f}," + ",".join(f"{x:.5f}" for x in vals) + "\n")
    with open(os.path.join(args.out, "step1_teams.csv"), "w") as f:
        f.write("team,p0_ux_min_mm,p0_ux_min_time_s,p1_ux_min_mm,p1_ux_min_time_s,red_p0,red_p1\n")
        for team in TEAMS:
            u = data[team]
            k0, k1 = int(np.argmin(u[:, 0, 0])), int(np.argmin(u[:, 1, 0]))
            red = [float(np.mean(np.linalg.norm(u[:, i] - mean[:, i], axis=1) / np.linalg.norm(mean[:, i], axis=1)))
                   for i in range(2)]
            f.write(f"{team},{u[k0, 0, 0]:.4f},{time[k0]:.2f},{u[k1, 1, 0]:.4f},{time[k1]:.2f},{red[0]:.4f},{red[1]:.4f}\n")
    repack_mesh(args)


if __name__ == "__main__":
    main()
