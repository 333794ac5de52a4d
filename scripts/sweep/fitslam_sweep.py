"""Runs the entries of a fitslam plan (`fitslam plan --out DIR`) as Ray tasks or on local threads.

Every entry is one `fitslam run DIR --index I` process: fitslam itself decides what is done (an
entry whose folder holds its hash is skipped), writes aside and renames into place, so a task
killed or retried anywhere leaves nothing half-written. This module only schedules; it never
reads or writes a run's files.
"""

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def find_fitslam(given=None):
    """The fitslam binary as an absolute path: `given`, else $FITSLAM, else `fitslam` on PATH,
    else the repository's target/release/fitslam."""
    for candidate in (given, os.environ.get("FITSLAM"), shutil.which("fitslam"), REPO / "target/release/fitslam"):
        if candidate and Path(candidate).is_file() and os.access(candidate, os.X_OK):
            return str(Path(candidate).resolve())
    sys.exit("no fitslam binary: build it (cargo build --release --bin fitslam) or pass --fitslam PATH")


def fitslam(binary, *args, cwd=None):
    """Runs `fitslam ARGS`; on failure exits with fitslam's own error line."""
    p = subprocess.run([binary, *map(str, args)], cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(last_line(p.stderr) or f"fitslam {' '.join(map(str, args))}: exit {p.returncode}")
    return p.stdout


def last_line(text):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return lines[-1] if lines else ""


def pending(binary, plan_dir, cwd=None):
    """Indices of the plan's entries whose output is not in place yet."""
    return [int(l) for l in fitslam(binary, "run", plan_dir, "--pending", cwd=cwd).split()]


def connect(address=None):
    """Joins the Ray cluster at `address`, or starts a local one on 127.0.0.1 (a Ray cluster
    trusts its network: a local one is never bound to another address)."""
    import ray

    if address:
        ray.init(address=address, logging_level="WARNING", log_to_driver=False)
    else:
        ray.init(_node_ip_address="127.0.0.1", include_dashboard=False, logging_level="WARNING", log_to_driver=False)
    return ray


def run_on_ray(ray, binary, plan_dir, indices, retries=3, label="ray"):
    """Runs `indices` of the plan as Ray tasks (one CPU each; a task that fails or whose worker
    dies is retried up to `retries` times); prints progress. Returns the failures as
    {index: error line}."""
    cwd = os.getcwd()
    plan_dir = str(plan_dir)

    # Self-contained (its imports inside): Ray workers need not find this module.
    @ray.remote(num_cpus=1, max_retries=retries, retry_exceptions=True)
    def run_entry(index):
        import subprocess

        p = subprocess.run([binary, "run", plan_dir, "--index", str(index)], cwd=cwd, capture_output=True, text=True)
        if p.returncode != 0:
            lines = [l for l in p.stderr.strip().splitlines() if l.strip()]
            raise RuntimeError(lines[-1] if lines else f"exit {p.returncode}")
        return index

    refs = {run_entry.remote(i): i for i in indices}
    failures, done, t0 = {}, 0, time.monotonic()
    waiting = list(refs)
    while waiting:
        ready, waiting = ray.wait(waiting, num_returns=1)
        for ref in ready:
            try:
                ray.get(ref)
            except Exception as e:  # a task's last attempt failed: report it, keep the others
                cause = getattr(e, "cause", None) or e
                failures[refs[ref]] = str(cause).strip().splitlines()[-1] if str(cause).strip() else type(cause).__name__
            done += 1
        print(f"{label}: {done}/{len(refs)} entries ({len(failures)} failed), {time.monotonic() - t0:.0f} s", file=sys.stderr, flush=True)
    return failures


def run_local(binary, plan_dir, jobs):
    """Runs every pending entry of the plan on `jobs` threads of this machine."""
    fitslam(binary, "run", plan_dir, "--jobs", jobs)
