#!/usr/bin/env python3
"""Kills a `sigmaheart` estimation command at several points and resumes it (issue 12, item 5).

  kill_resume.py --sigmaheart build/sigmaheart --source SRC CASE

For CASE (calibrate, sensitivity, specificity, personalize) it checks, on the built binary:
 1. the uninterrupted run (the reference);
 2. SIGKILL at three points of the run (each after the checkpoint has grown), each time followed
    by `--resume` (the last one runs to the end): the JSON summary equals the reference (numbers bitwise or to 1e-12 relative where they
    went through text; provenance and timings excepted), the checkpoint is gone, no temporary file
    is left;
 3. SIGINT in the middle: exit code 130, the checkpoint is there and nothing else was written, and
    `--resume` ends with the reference numbers;
 4. a new run SIGKILLed while an earlier result exists leaves that result byte for byte intact;
 5. (calibrate) a run that fails (iteration limit, exit 1) does not replace the earlier result: it
    writes <stem>.failed.h5/.json and says where the earlier one is.
Each kill waits until the run has recorded a batch of members, then a fraction of the reference's
wall time: the kills land in different places on any machine; what is asserted holds wherever.
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "mpi"))
import run_mpi_case  # noqa: E402
from run_mpi_case import compare_json  # noqa: E402  (the same comparison as the MPI cases)

# How the cases were spread (one per thread, or each case's ensemble threaded) follows from the
# thread count, which differs between the serial and the rank runs here.
run_mpi_case.IGNORED_KEYS.add("parallel")

CASES = {
    "calibrate": ["calibrate", "{src}/configs/calibrate-volunteer.yaml"],
    "sensitivity": ["sensitivity", "{src}/experiments/sensitivity-bcs/morris.yaml",
                    "--set", "sensitivity.morris.trajectories=60"],
    "specificity": ["specificity", "{src}/configs/specificity-cohort.yaml"],
    "personalize": ["personalize", "{src}/configs/personalize-lad-infarct.yaml",
                    "--set", "personalize.filter.beats=1"],
}
KILL_FRACTIONS = (0.0, 0.1, 0.25)  # of the reference's wall time, after the checkpoint grew


def checkpoint_size(out):
    try:
        return os.path.getsize(os.path.join(out, "r.h5.checkpoint"))
    except OSError:
        return 0


MPI = []  # e.g. ["mpirun", "--oversubscribe", "--allow-run-as-root", "-np"]: set by --mpiexec


def run(exe, args, out, extra=(), kill_after=None, sig=signal.SIGKILL, ranks=1):
    """Runs the command. With kill_after (s) sends `sig` that long after the checkpoint first grew
    (so the kill lands after at least one batch of members was recorded, however slow the machine
    is). Returns (exit code, stderr); a signal's death is 128 + its number."""
    cmd = [exe] + args + ["-o", os.path.join(out, "r.h5"), "--summary", os.path.join(out, "r.json"),
                          "--threads", "2" if ranks == 1 else "1"] + list(extra)
    if ranks > 1:
        cmd = MPI + [str(ranks)] + cmd
    before = checkpoint_size(out) if "--resume" in extra else 0
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if kill_after is not None:
        while p.poll() is None and checkpoint_size(out) <= max(before, 16):
            time.sleep(0.005)
        if p.poll() is None:
            time.sleep(kill_after)
            if p.poll() is None:
                p.send_signal(sig)
    o, e = p.communicate(timeout=900)
    code = p.returncode
    return (128 - code if code < 0 else code), e


def leftovers(out):
    return sorted(f for f in os.listdir(out) if f.endswith(".tmp") or ".checkpoint" in f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sigmaheart", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--mpiexec", help="also: SIGTERM a 2-rank run and resume it serially, SIGINT a "
                    "serial run and resume it on 3 ranks")
    ap.add_argument("--mpi-flag", action="append", default=[])
    ap.add_argument("case", choices=sorted(CASES))
    a = ap.parse_args()
    if a.mpiexec:
        MPI.extend([a.mpiexec] + a.mpi_flag + ["-np"])
    args = [x.format(src=a.source) for x in CASES[a.case]]
    problems = []
    with tempfile.TemporaryDirectory() as tmp:
        ref_dir, out = os.path.join(tmp, "ref"), os.path.join(tmp, "out")
        os.makedirs(ref_dir)
        os.makedirs(out)
        t0 = time.monotonic()
        code, err = run(a.sigmaheart, args, ref_dir)
        wall = time.monotonic() - t0
        if code != 0:
            print(f"reference run failed ({code}):\n{err}")
            return 1
        reference = json.load(open(os.path.join(ref_dir, "r.json")))
        print(f"{a.case}: reference run {wall:.2f} s")

        # 2. SIGKILL at several points, resumed each time.
        resumed = False  # some run took members from the checkpoint
        for i, f in enumerate(KILL_FRACTIONS):
            code, err = run(a.sigmaheart, args, out, ["--resume"] if i else [], kill_after=f * wall)
            resumed |= "taken from the checkpoint" in err
            print(f"  SIGKILL {f * wall:.2f} s after the first record: exit {code}")
        code, err = run(a.sigmaheart, args, out, ["--resume"])
        if code != 0:
            problems.append(f"resumed run exit {code}:\n{err}")
        else:
            compare_json(reference, json.load(open(os.path.join(out, "r.json"))), "resumed", problems)
            if not resumed and "taken from the checkpoint" not in err:
                problems.append("no resumed run took anything from the checkpoint:\n" + err)
        if leftovers(out):
            problems.append(f"left after the resumed run: {leftovers(out)}")

        # 3. SIGINT in the middle: 130, checkpoint kept, nothing else written; resume.
        sig_dir = os.path.join(tmp, "sigint")
        os.makedirs(sig_dir)
        code, err = run(a.sigmaheart, args, sig_dir, kill_after=0.1 * wall, sig=signal.SIGINT)
        print(f"  SIGINT {0.1 * wall:.2f} s after the first record: exit {code}")
        if code == 130:
            files = sorted(os.listdir(sig_dir))
            if files != ["r.h5.checkpoint"]:
                problems.append(f"after SIGINT the directory holds {files}, expected only the checkpoint")
            if "--resume" not in err:
                problems.append("SIGINT: stderr does not say how to resume:\n" + err)
            code, err = run(a.sigmaheart, args, sig_dir, ["--resume"])
            if code != 0:
                problems.append(f"resume after SIGINT: exit {code}\n{err}")
            else:
                compare_json(reference, json.load(open(os.path.join(sig_dir, "r.json"))), "after-sigint",
                             problems)
        elif code != 0:
            problems.append(f"SIGINT: exit {code}, expected 130\n{err}")

        # 3b. Across rank counts: a 2-rank run stopped by SIGTERM (what Slurm sends) resumed on one
        # rank, a serial run stopped by SIGINT resumed on 3 ranks.
        if a.mpiexec:
            for first, second, sig in ((2, 1, signal.SIGTERM), (1, 3, signal.SIGINT)):
                d = os.path.join(tmp, f"ranks{first}{second}")
                os.makedirs(d)
                code, err = run(a.sigmaheart, args, d, kill_after=0.1 * wall, sig=sig, ranks=first)
                print(f"  {sig.name} on {first} rank(s): exit {code}")
                if not os.path.exists(os.path.join(d, "r.h5.checkpoint")) and \
                        os.path.exists(os.path.join(d, "r.json")):
                    continue  # finished before the signal reached the ranks: nothing to resume
                if not os.path.exists(os.path.join(d, "r.h5.checkpoint")):
                    problems.append(f"{sig.name} on {first} rank(s) (exit {code}) left no checkpoint:\n{err}")
                    continue
                code, err = run(a.sigmaheart, args, d, ["--resume"], ranks=second)
                if code != 0:
                    problems.append(f"resume on {second} rank(s): exit {code}\n{err}")
                else:
                    compare_json(reference, json.load(open(os.path.join(d, "r.json"))),
                                 f"ranks-{first}-to-{second}", problems)
                    # Rank 0 logs what it loaded (every rank's records); what each rank then
                    # takes depends on which cases it is handed, so the count is not asserted.
                    if "finished member(s) recorded" not in err:
                        problems.append(f"the resume on {second} rank(s) loaded nothing from the checkpoint")
                if leftovers(d):
                    problems.append(f"left after the resume on {second} rank(s): {leftovers(d)}")

        # 4. A killed run leaves the earlier result intact.
        before = {f: open(os.path.join(out, f), "rb").read() for f in ("r.h5", "r.json")}
        code, err = run(a.sigmaheart, args, out, kill_after=0.0)
        for f, data in before.items():
            if code == 128 + signal.SIGKILL and open(os.path.join(out, f), "rb").read() != data:
                problems.append(f"{f} changed although the run writing it was killed (exit {code})")

        # 5. A failed run keeps the earlier result.
        if a.case == "calibrate":
            code, err = run(a.sigmaheart, args, out, ["--set", "calibration.max_iterations=1"])
            if code != 1:
                problems.append(f"the failing calibration exited {code}, expected 1")
            for f, data in before.items():
                if open(os.path.join(out, f), "rb").read() != data:
                    problems.append(f"the failed run replaced {f}")
            for f in ("r.failed.h5", "r.failed.json"):
                if not os.path.exists(os.path.join(out, f)):
                    problems.append(f"the failed run did not write {f}")
            if "the earlier result" not in err or "was kept" not in err:
                problems.append("the failed run does not say the earlier result was kept:\n" + err)
    for p in problems:
        print("PROBLEM:", p)
    print("ok" if not problems else f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
