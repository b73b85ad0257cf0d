#!/usr/bin/env python3
"""A real Slurm run of the README's batch script (issue 44, item 5; slow tier).

  slurm_run.py --sigmaheart build/sigmaheart --source SRC [--scratch DIR] [--reference JSON]

Starts a single-node cluster on this machine in a scratch directory (munged with its own key and
socket, slurmctld and slurmd on free loopback ports, a generated slurm.conf: 2 CPUs, proctrack
linuxproc, no accounting), then:
 1. runs the study serially (the reference);
 2. submits the README's Slurm script (the fenced block after "<!-- slurm-job -->", byte for
    byte) with sbatch: 2 tasks x 1 CPU, launched with srun (PMIx); its short time limit and
    `--signal=TERM@...` stop the run midway (exit 143, checkpoint kept);
 3. submits the same script again (`--resume` runs only what is missing) until a job completes;
 4. checks that the first job was signalled and left its checkpoint, that a resumed job loaded
    it, and that the final JSON summary equals the serial run's (numbers to 1e-12 relative,
    provenance and timings excepted; tests/app/mpi/run_mpi_case.py compare_json).
--reference takes the serial run's JSON summary from an earlier run instead of running it again
(it costs as much CPU as the whole study). On a loaded machine each job gets less done before its
signal; the script is submitted up to 40 times.
Where Slurm or munge is missing or cannot start here it prints "SKIP: <why>" and exits 77 (CTest
SKIP_RETURN_CODE). Every daemon it started is stopped by its pid at the end.
"""
import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "mpi"))
import run_mpi_case  # noqa: E402
from run_mpi_case import compare_json  # noqa: E402

# How the work was spread (ranks, threads) differs between the serial and the Slurm run.
run_mpi_case.IGNORED_KEYS.add("parallel")

SKIP = 77


def skip(why):
    print("SKIP: " + why, flush=True)
    sys.exit(SKIP)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def readme_script(source):
    """The fenced block after the marker line in README.md."""
    lines = open(os.path.join(source, "README.md")).read().splitlines()
    start = lines.index("<!-- slurm-job -->")
    body, inside = [], False
    for line in lines[start + 1:]:
        if line.startswith("```"):
            if inside:
                break
            inside = True
            continue
        if inside:
            body.append(line)
    return "\n".join(body) + "\n"


class Cluster:
    def __init__(self, root):
        self.root = root
        self.pids = []
        self.env = dict(os.environ, SLURM_CONF=os.path.join(root, "slurm.conf"))

    def start(self):
        for tool in ("munged", "slurmctld", "slurmd", "sbatch", "srun", "scontrol", "sinfo"):
            if shutil.which(tool) is None and not os.path.exists("/usr/sbin/" + tool):
                skip(tool + " is not installed (Debian: slurm-wlm, munge)")
        r = self.root
        os.chmod(r, 0o755)
        for d in ("state", "spool"):
            os.makedirs(os.path.join(r, d))
        key = os.path.join(r, "munge.key")
        with open(key, "wb") as f:
            f.write(os.urandom(1024))
        os.chmod(key, 0o400)
        self.munge_socket = os.path.join(r, "munge.sock")
        code = subprocess.call(["munged", "-f", "--key-file=" + key, "--socket=" + self.munge_socket,
                                "--pid-file=" + os.path.join(r, "munged.pid"),
                                "--log-file=" + os.path.join(r, "munged.log"),
                                "--seed-file=" + os.path.join(r, "munged.seed")])
        if code != 0:
            skip("munged could not start (exit %d): %s" % (code, self.tail("munged.log")))
        self.pids.append(self.pid("munged.pid"))
        host = socket.gethostname().split(".")[0]
        with open(os.path.join(r, "slurm.conf"), "w") as f:
            f.write(f"""ClusterName=sigmaheart-test
SlurmctldHost={host}(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
AuthType=auth/munge
AuthInfo=socket={self.munge_socket}
CredType=cred/munge
StateSaveLocation={r}/state
SlurmdSpoolDir={r}/spool
SlurmctldPidFile={r}/slurmctld.pid
SlurmdPidFile={r}/slurmd.pid
SlurmctldLogFile={r}/slurmctld.log
SlurmdLogFile={r}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
KillWait=30
InactiveLimit=0
MinJobAge=600
NodeName={host} NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
""")
        for daemon, args, pidfile in (("slurmctld", ["-i"], "slurmctld.pid"), ("slurmd", ["-N", host], "slurmd.pid")):
            code = subprocess.call([daemon] + args, env=self.env)
            if code != 0:
                skip("%s could not start (exit %d): %s" % (daemon, code, self.tail(daemon + ".log")))
            for _ in range(100):
                if os.path.exists(os.path.join(r, pidfile)):
                    break
                time.sleep(0.1)
            self.pids.append(self.pid(pidfile))
        for _ in range(60):
            state = subprocess.run(["sinfo", "-h", "-o", "%t"], env=self.env, capture_output=True, text=True)
            if state.stdout.strip() == "idle":
                return
            time.sleep(1)
        skip("the node did not become idle: sinfo says %r; %s" % (state.stdout.strip() + state.stderr.strip(),
                                                                 self.tail("slurmd.log")))

    def pid(self, name):
        try:
            return int(open(os.path.join(self.root, name)).read().split()[0])
        except (OSError, ValueError, IndexError):
            return None

    def tail(self, name, n=5):
        try:
            return " | ".join(open(os.path.join(self.root, name)).read().splitlines()[-n:])
        except OSError:
            return "(no %s)" % name

    def stop(self):
        for pid in reversed([p for p in self.pids if p]):
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        time.sleep(1)

    def submit(self, script, workdir):
        out = subprocess.run(["sbatch", "--parsable", "--chdir=" + workdir, script], env=self.env,
                             capture_output=True, text=True)
        if out.returncode != 0:
            raise RuntimeError("sbatch failed: " + out.stderr)
        return out.stdout.strip().split(";")[0]

    def job(self, job_id):
        out = subprocess.run(["scontrol", "show", "job", "-o", job_id], env=self.env, capture_output=True, text=True)
        return dict(kv.split("=", 1) for kv in out.stdout.split() if "=" in kv)

    def wait(self, job_id, limit_s):
        t0 = time.time()
        while time.time() - t0 < limit_s:
            j = self.job(job_id)
            if j.get("JobState") in ("COMPLETED", "FAILED", "TIMEOUT", "CANCELLED", "NODE_FAIL", "OUT_OF_MEMORY"):
                return j
            time.sleep(2)
        subprocess.call(["scancel", job_id], env=self.env)
        raise RuntimeError("job %s did not end within %d s" % (job_id, limit_s))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sigmaheart", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--scratch")
    ap.add_argument("--reference", help="the serial run's JSON summary from an earlier run")
    a = ap.parse_args()
    if os.geteuid() != 0:
        skip("the single-node cluster runs its daemons as root (SlurmUser=root); not root here")
    scratch = a.scratch or tempfile.mkdtemp(prefix="sigmaheart-slurm-")
    shutil.rmtree(scratch, ignore_errors=True)
    os.makedirs(scratch)
    cluster = Cluster(os.path.join(scratch, "cluster"))
    os.makedirs(cluster.root)
    problems = []
    try:
        cluster.start()
        # The job's working directory: build/ and configs/ as the README's script names them.
        work = os.path.join(scratch, "work")
        os.makedirs(os.path.join(work, "build"))
        os.makedirs(os.path.join(work, "results"))
        os.symlink(os.path.abspath(a.sigmaheart), os.path.join(work, "build", "sigmaheart"))
        os.symlink(os.path.join(a.source, "configs"), os.path.join(work, "configs"))
        script_text = readme_script(a.source)
        script = os.path.join(work, "job.sh")
        open(script, "w").write(script_text)
        srun_line = script_text.replace("\\\n", " ").split("srun", 1)[1].split("\n")[0]
        study = srun_line.split()
        # The serial reference: the same command line without srun's options and --resume.
        cmd = [w for w in study if not w.startswith("--mpi")][0:]
        cmd = [os.path.abspath(a.sigmaheart)] + cmd[1:]
        cmd = [w for w in cmd if w != "--resume"]
        summary = [w for i, w in enumerate(cmd) if i > 0 and cmd[i - 1] == "--summary"][0]
        if a.reference:
            reference = json.load(open(a.reference))
        else:
            ref = os.path.join(scratch, "reference")
            os.makedirs(os.path.join(ref, "results"))
            os.symlink(os.path.join(a.source, "configs"), os.path.join(ref, "configs"))
            t0 = time.time()
            r = subprocess.run(cmd, cwd=ref, capture_output=True, text=True,
                               env=dict(os.environ, OMP_NUM_THREADS="1"))
            print("serial reference: exit %d in %.0f s" % (r.returncode, time.time() - t0), flush=True)
            if r.returncode != 0:
                raise RuntimeError("the serial reference failed:\n" + r.stderr[-2000:])
            reference = json.load(open(os.path.join(ref, summary)))

        # Submit until a job completes (each is stopped by its time-limit signal until then).
        jobs = []
        for _ in range(40):
            job_id = cluster.submit(script, work)
            j = cluster.wait(job_id, 600)
            log = open(os.path.join(work, "slurm-%s.out" % job_id)).read()
            jobs.append((job_id, j, log))
            print("job %s: %s, exit %s, run time %s" % (job_id, j.get("JobState"), j.get("ExitCode"),
                                                        j.get("RunTime")), flush=True)
            if j.get("JobState") == "COMPLETED":
                break
            if not j.get("ExitCode", "").startswith("143"):
                problems.append("job %s ended %s with exit %s, not by its SIGTERM (143):\n%s"
                                % (job_id, j.get("JobState"), j.get("ExitCode"), log[-3000:]))
                break
            checkpoint = os.path.join(work, summary.replace(".json", ".h5") + ".checkpoint")
            if not os.path.exists(checkpoint):
                problems.append("job %s was signalled but left no checkpoint:\n%s" % (job_id, log[-2000:]))
                break
        if not problems:
            if len(jobs) < 2:
                problems.append("the first job completed before its time-limit signal: the study is too short "
                                "for this machine to test the signal and the resume")
            elif jobs[-1][1].get("JobState") != "COMPLETED":
                problems.append("no job completed in %d submissions" % len(jobs))
            else:
                if not any("finished member(s) recorded" in log for _, _, log in jobs[1:]):
                    problems.append("no resubmitted job loaded the checkpoint:\n" + jobs[-1][2][-2000:])
                compare_json(reference, json.load(open(os.path.join(work, summary))), "slurm-resume", problems)
                print("%d jobs: %d stopped by the signal, then completed" % (len(jobs), len(jobs) - 1))
    except RuntimeError as e:
        problems.append(str(e))
    finally:
        cluster.stop()
    if problems:
        print("FAILED:\n" + "\n".join(problems))
        return 1
    print("ok: the signalled and resubmitted Slurm job gives the serial run's numbers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
