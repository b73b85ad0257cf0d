#!/usr/bin/env python3
"""Runs one `sigmaheart` command serially and under mpirun on N ranks and compares the outputs.

  run_mpi_case.py --sigmaheart build/sigmaheart --mpiexec mpirun --np 2 --source SRC CASE

A result case passes when every rank exits 0, the JSON summaries agree with the serial run (numbers
bitwise, or to 1e-12 relative where they went through text; provenance fields excepted), text
outputs (CSV) agree the same way, and only rank 0 printed (stdout has as many lines as the serial
run's). A failure case (`fail-*`) passes when every rank exits with the expected code within the
CTest timeout, i.e. no rank is left waiting in a collective. Cases are listed in CASES below.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

# name -> (arguments with {src} and {out} placeholders, outputs to compare, expected exit code)
CASES = {
    "simulate": (["simulate", "{src}/configs/healthy.yaml", "-o", "{out}/r.h5",
                  "--summary", "{out}/r.json", "--csv", "{out}/r.csv"], ["r.json", "r.csv"], 0),
    "calibrate": (["calibrate", "{src}/configs/calibrate-volunteer.yaml", "-o", "{out}/r.h5",
                   "--summary", "{out}/r.json"],
                  ["r.json"], 0),
    # One pass and one Gauss-Newton step of the MAP refinement (docs/estimation.md s.4.7): the
    # refinement stops at its limit, so every rank exits 1 and the results are written all the same.
    "personalize": (["personalize", "{src}/configs/personalize-lad-infarct.yaml", "-o", "{out}/r.h5",
                     "--summary", "{out}/r.json", "--set", "personalize.filter.beats=1",
                     "--set", "personalize.filter.map_iterations=1"],
                    ["r.json"], 1),
    "sensitivity": (["sensitivity", "{src}/configs/sensitivity-ishigami.yaml", "-o", "{out}/r.h5",
                     "--summary", "{out}/r.json", "--set", "sensitivity.sobol.N=256",
                     "--set", "sensitivity.sobol.bootstrap=20"], ["r.json"], 0),
    "specificity": (["specificity", "{src}/configs/specificity-cohort.yaml", "-o", "{out}/r.h5",
                     "--summary", "{out}/r.json"],
                    ["r.json"], 0),
    "synthesize": (["synthesize", "{src}/configs/healthy.yaml", "-o", "{out}/obs.csv",
                    "--noise", "V_lv=2 mL", "--seed", "3"], ["obs.csv"], 0),
    # the output cannot be written (its parent "directory" is a file): every rank refuses before
    # any work (app/cli.cpp, check_outputs) with exit code 2, none hangs in a collective.
    "fail-unwritable-output": (["calibrate", "{src}/configs/calibrate-volunteer.yaml",
                                "-o", "{out}/blocker/r.h5"], [], 2),
    # bad input: every rank fails the same way with exit code 2.
    "fail-bad-config": (["simulate", "{src}/configs/healthy.yaml", "-o", "{out}/r.h5",
                         "--set", "EF=2"], [], 2),
}

# Provenance and run-environment fields that legitimately differ between the runs.
IGNORED_KEYS = {"command_line", "start_utc", "end_utc", "ranks", "threads", "wall_time",
                "elapsed", "elapsed_s", "wall_time_s", "output", "config_file", "host",
                "git_describe", "version", "seconds", "time_s", "wall_seconds",
                "results_file"}
RELATIVE_TOLERANCE = 1e-12


def close(a, b):
    if a == b:
        return True
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return abs(a - b) <= RELATIVE_TOLERANCE * max(abs(a), abs(b))


def compare_json(a, b, path, problems):
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            problems.append(f"{path}: keys differ: {sorted(set(a) ^ set(b))}")
        for k in set(a) & set(b):
            if k not in IGNORED_KEYS:
                compare_json(a[k], b[k], f"{path}.{k}", problems)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            problems.append(f"{path}: lengths {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            compare_json(x, y, f"{path}[{i}]", problems)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if not close(float(a), float(b)):
            problems.append(f"{path}: {a!r} != {b!r}")
    elif a != b:
        problems.append(f"{path}: {a!r} != {b!r}")


def compare_text(a, b, name, problems):
    la, lb = a.splitlines(), b.splitlines()
    if len(la) != len(lb):
        problems.append(f"{name}: {len(la)} lines != {len(lb)}")
        return
    for n, (x, y) in enumerate(zip(la, lb), 1):
        if x == y:
            continue
        tx, ty = x.split(","), y.split(",")
        try:
            ok = len(tx) == len(ty) and all(close(float(p), float(q)) for p, q in zip(tx, ty))
        except ValueError:
            ok = False
        if not ok:
            problems.append(f"{name}:{n}: {x!r} != {y!r}")


def fill(args, src, out):
    return [a.replace("{src}", src).replace("{out}", out) for a in args]


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--sigmaheart", required=True)
    p.add_argument("--mpiexec", required=True)
    p.add_argument("--np", type=int, required=True)
    p.add_argument("--source", required=True)
    p.add_argument("--mpi-flag", action="append", default=[])
    p.add_argument("case", choices=sorted(CASES))
    o = p.parse_args()
    args, outputs, expected = CASES[o.case]
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    work = tempfile.mkdtemp(prefix=f"sigmaheart-mpi-{o.case}-np{o.np}-")
    try:
        serial_dir, mpi_dir = os.path.join(work, "serial"), os.path.join(work, "mpi")
        for d in (serial_dir, mpi_dir):
            os.makedirs(d)
            with open(os.path.join(d, "blocker"), "w") as f:
                f.write("a file where a directory is expected\n")
        problems = []

        # Every rank records its own exit code, so agreement is checked rank by rank. The wrapper
        # then exits 0: mpirun kills the remaining processes as soon as one exits non-zero, which
        # could stop a rank's wrapper before it wrote its code (the rank itself had already
        # passed the exit-code agreement, since no rank returns before all ranks reached it).
        codes_dir = os.path.join(mpi_dir, "codes")
        os.makedirs(codes_dir)
        wrapper = ('"$@"; c=$?; echo $c > "' + codes_dir +
                   '/rank.${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-0}}"; exit 0')
        mpi_cmd = ([o.mpiexec, "-np", str(o.np)] + o.mpi_flag +
                   ["sh", "-c", wrapper, "sh", o.sigmaheart] + fill(args, o.source, mpi_dir))
        mpi = subprocess.run(mpi_cmd, env=env, cwd=mpi_dir, capture_output=True, text=True)
        codes = {}
        for name in sorted(os.listdir(codes_dir)):
            with open(os.path.join(codes_dir, name)) as f:
                codes[name] = int(f.read().strip())
        if len(codes) != o.np:
            problems.append(f"only {len(codes)} of {o.np} ranks recorded an exit code: {codes}")
        if any(c != expected for c in codes.values()):
            problems.append(f"exit codes per rank {codes}, expected {expected} on every rank")

        if expected == 0:
            serial = subprocess.run([o.sigmaheart] + fill(args, o.source, serial_dir), env=env,
                                    cwd=serial_dir, capture_output=True, text=True)
            if serial.returncode != 0:
                problems.append(f"serial run failed ({serial.returncode}): {serial.stderr}")
            if len(mpi.stdout.splitlines()) != len(serial.stdout.splitlines()):
                problems.append("stdout of the MPI run has %d lines, the serial run's %d "
                                "(only rank 0 should print)" % (len(mpi.stdout.splitlines()),
                                                                 len(serial.stdout.splitlines())))
            for name in outputs:
                a, b = os.path.join(serial_dir, name), os.path.join(mpi_dir, name)
                if not os.path.exists(a) or not os.path.exists(b):
                    problems.append(f"{name}: missing (serial {os.path.exists(a)}, "
                                    f"mpi {os.path.exists(b)})")
                    continue
                with open(a) as fa, open(b) as fb:
                    ta, tb = fa.read(), fb.read()
                if name.endswith(".json"):
                    compare_json(json.loads(ta), json.loads(tb), name, problems)
                else:
                    compare_text(ta, tb, name, problems)
            leftovers = [f for f in os.listdir(mpi_dir) if f.endswith(".tmp")]
            if leftovers:
                problems.append(f"temporary files left: {leftovers}")

        if problems:
            print(f"FAILED {o.case} on {o.np} ranks:")
            for line in problems[:40]:
                print("  " + line)
            print("--- mpirun stderr ---\n" + mpi.stderr[-4000:])
            return 1
        print(f"ok {o.case} on {o.np} ranks: exit codes {sorted(codes.values())}")
        return 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
