#!/usr/bin/env python3
"""Compare fitslam's incremental solver (`fitslam optimize --incremental`) with GTSAM's ISAM2 on
the same online replay of a pose graph.

The replay (core/src/slam/incremental/g2o_replay.rs): vertices in increasing id order; step k
adds vertex k with the edges whose later end it is, the new vertex starting at the current
estimate of the other end composed with the first such edge (file order); the first pose is
anchored by a prior of standard deviation SIGMA on every tangent component at its file value.
One ISAM2 update per step, GTSAM's default ISAM2Params (relinearizeThreshold 0.1,
relinearizeSkip 10, Cholesky), as fitslam's defaults (`--relinearize-threshold`,
`--relinearize-skip` set both). Pose graphs only (VERTEX_SE2 / EDGE_SE2,
VERTEX_SE3:QUAT / EDGE_SE3:QUAT), read by GTSAM's readG2o.

Printed per file: both final chi2 (2 x the full graph's error at the final estimate), their
relative difference, the traces of the newest pose's marginal at the end and their relative
difference (the trace does not depend on the tangent's order), fitslam's total time (every
update with the newest estimate and marginal) and GTSAM's time for the updates alone and for
updates + newest estimate + marginal. Both run pinned to one core. Where GTSAM's Cholesky stops
with IndeterminateSystemException, its replay runs again with QR (slower), and the row says so.

Usage (needs `pip install gtsam==4.3.0 numpy`; from the repository root):
    python3 scripts/compare_isam2.py [FILES...]   # default: the pose graphs in assets/data/slam
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

try:
    import gtsam
except ImportError:  # pragma: no cover
    sys.exit("compare_isam2.py needs GTSAM's Python package: pip install gtsam==4.3.0")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "assets", "data", "slam")
DEFAULT_FILES = ["intel.g2o", "MIT.g2o", "CSAIL.g2o", "parking-garage.g2o", "smallGrid3D.g2o"]


def is_3d(path):
    with open(path) as f:
        for line in f:
            tok = line.split()
            if tok:
                return tok[0].startswith("VERTEX_SE3") or tok[0].startswith("EDGE_SE3")
    return False


def run_gtsam(path, sigma, threshold, skip):
    """The replay through ISAM2 with Cholesky; on GTSAM's IndeterminateSystemException (some
    public graphs' near-singular edges) again with QR, which the result then says."""
    try:
        return dict(replay_gtsam(path, sigma, threshold, skip, "CHOLESKY"), factorization="Cholesky")
    except RuntimeError:
        return dict(replay_gtsam(path, sigma, threshold, skip, "QR"), factorization="QR")


def replay_gtsam(path, sigma, threshold, skip, factorization):
    three_d = is_3d(path)
    graph, initial = gtsam.readG2o(path, three_d)
    factors = [graph.at(i) for i in range(graph.size()) if graph.at(i) is not None]
    ids = sorted(initial.keys())
    rank = {k: r for r, k in enumerate(ids)}
    steps = {r: [] for r in range(len(ids))}
    for f in factors:
        a, b = f.keys()
        steps[max(rank[a], rank[b])].append(f)
    dim = 6 if three_d else 3
    prior_noise = gtsam.noiseModel.Isotropic.Sigma(dim, sigma)
    value = initial.atPose3 if three_d else initial.atPose2
    params = gtsam.ISAM2Params()
    params.setFactorization(factorization)
    params.setRelinearizeThreshold(threshold)
    params.relinearizeSkip = skip
    isam = gtsam.ISAM2(params)
    full = gtsam.NonlinearFactorGraph()
    t_update = t_query = 0.0
    entered = set()
    estimate = gtsam.Values()
    marginal = None
    count = 0
    for r, key in enumerate(ids):
        new_graph, new_values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        if r == 0:
            prior = gtsam.PriorFactorPose3(key, value(key), prior_noise) if three_d else gtsam.PriorFactorPose2(key, value(key), prior_noise)
            new_graph.add(prior)
            new_values.insert(key, value(key))
            entered.add(key)
        for f in steps[r]:
            a, b = f.keys()
            for new, old, forward in ((b, a, True), (a, b, False)):
                if new not in entered and old in entered:
                    z = f.measured()
                    base = estimate.atPose3(old) if three_d and estimate.exists(old) else (
                        estimate.atPose2(old) if estimate.exists(old) else value(old))
                    pose = base.compose(z) if forward else base.compose(z.inverse())
                    new_values.insert(new, pose)
                    entered.add(new)
            new_graph.add(f)
        if new_graph.size() == 0:
            continue  # a vertex with no edge to an earlier one enters with a later vertex
        for i in range(new_graph.size()):
            full.add(new_graph.at(i))
        t0 = time.perf_counter()
        isam.update(new_graph, new_values)
        t1 = time.perf_counter()
        newest = max(entered, key=lambda k: rank[k])
        estimate = isam.calculateEstimate()
        marginal = isam.marginalCovariance(newest)
        t2 = time.perf_counter()
        t_update += t1 - t0
        t_query += t2 - t1
        count += 1
    chi2 = 2.0 * full.error(isam.calculateEstimate())
    return {"final_chi2": chi2, "trace": float(np.trace(marginal)), "update_ms": 1e3 * t_update,
            "total_ms": 1e3 * (t_update + t_query), "steps": count}


def run_fitslam(path, threshold, skip):
    exe = os.path.join(ROOT, "target", "release", "fitslam")
    cmd = [exe, "optimize", "--incremental", "--g2o", path, "--json", "--relinearize-threshold", str(threshold), "--relinearize-skip", str(skip)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    j = json.loads(out.stdout)
    m = np.array(j["last_marginal"], dtype=float)
    n = int(round(len(m) ** 0.5))
    j["trace"] = float(np.trace(m.reshape(n, n)))
    return j


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*")
    ap.add_argument("--sigma", type=float, default=1e-3, help="first-pose prior sigma (fitslam's default)")
    ap.add_argument("--relinearize-threshold", type=float, default=0.1, help="both solvers (GTSAM's default)")
    ap.add_argument("--relinearize-skip", type=int, default=10, help="both solvers (GTSAM's default)")
    args = ap.parse_args()
    files = args.files or [os.path.join(DATA, f) for f in DEFAULT_FILES]
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core, inherited by fitslam
    subprocess.run(["cargo", "build", "--release", "-q", "--bin", "fitslam"], cwd=ROOT, check=True)
    print(f"{'file':<20} {'steps f/g':>11} {'chi2 fitslam':>14} {'chi2 gtsam':>14} {'rel':>9} {'tr fitslam':>12} {'tr gtsam':>12} {'rel':>9}"
          f" {'ms fitslam':>11} {'ms g upd':>9} {'ms g all':>9} gtsam")
    for path in files:
        t, k = args.relinearize_threshold, args.relinearize_skip
        ours, ref = run_fitslam(path, t, k), run_gtsam(path, args.sigma, t, k)
        rel_chi2 = (ours["final_chi2"] - ref["final_chi2"]) / ref["final_chi2"]
        rel_tr = (ours["trace"] - ref["trace"]) / ref["trace"]
        print(f"{os.path.basename(path):<20} {ours['steps']:>5}/{ref['steps']:<5} {ours['final_chi2']:>14.6f} {ref['final_chi2']:>14.6f} {rel_chi2:>9.2e}"
              f" {ours['trace']:>12.6g} {ref['trace']:>12.6g} {rel_tr:>9.2e} {ours['total_ms']:>11.1f} {ref['update_ms']:>9.1f} {ref['total_ms']:>9.1f} {ref['factorization']}")


if __name__ == "__main__":
    main()
