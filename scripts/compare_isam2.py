#!/usr/bin/env python3
"""Compare fitslam's incremental solver (`fitslam optimize --incremental`) with GTSAM's ISAM2 on
the same online replay of a pose graph.

The replay (core/src/slam/incremental/g2o_replay.rs): vertices in increasing id order; step k
adds vertex k with the edges whose later end it is, the new vertex starting at the current
estimate of the other end composed with the first such edge (file order); the first pose is
anchored by a prior of standard deviation SIGMA on every tangent component at its file value.
One ISAM2 update per step, GTSAM's default ISAM2Params (relinearizeThreshold 0.1,
relinearizeSkip 10, Cholesky), as fitslam's defaults (`--relinearize-threshold`,
`--relinearize-skip` set both). Pose graphs (VERTEX_SE2 / EDGE_SE2, VERTEX_SE3:QUAT /
EDGE_SE3:QUAT) are read by GTSAM's readG2o; 3D graphs with point landmarks (VERTEX_TRACKXYZ /
EDGE_SE3_TRACKXYZ, e.g. a mission's graph from `fitslam explore --slam-g2o`) by
read_points_g2o (`--observations` chooses GTSAM's factor for them).

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
import functools
import json
import os
import subprocess
import sys
import time

import numpy as np

from compare_gtsam import point_in_sensor_error, symmetric  # scripts/ is on the path of a script run from it

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


def has_points(path):
    """Whether the file has 3D point landmarks (VERTEX_TRACKXYZ / EDGE_SE3_TRACKXYZ)."""
    with open(path) as f:
        return any(line.startswith(("VERTEX_TRACKXYZ", "EDGE_SE3_TRACKXYZ")) for line in f)


class TimedReplay:
    """An ISAM2 replay's running totals: the updates alone, and with the queries after each."""

    def __init__(self, isam):
        self.isam, self.full = isam, gtsam.NonlinearFactorGraph()
        self.t_update = self.t_query = 0.0
        self.count, self.marginal = 0, None

    def step(self, graph, values, newest, estimate):
        """One update; then `estimate(isam)` (returned) and the marginal of `newest`."""
        for i in range(graph.size()):
            self.full.add(graph.at(i))
        t0 = time.perf_counter()
        self.isam.update(graph, values)
        t1 = time.perf_counter()
        result = estimate(self.isam)
        self.marginal = self.isam.marginalCovariance(newest)
        t2 = time.perf_counter()
        self.t_update += t1 - t0
        self.t_query += t2 - t1
        self.count += 1
        return result

    def result(self):
        chi2 = 2.0 * self.full.error(self.isam.calculateEstimate())
        return {"final_chi2": chi2, "trace": float(np.trace(self.marginal)), "update_ms": 1e3 * self.t_update,
                "total_ms": 1e3 * (self.t_update + self.t_query), "steps": self.count}


def isam2(threshold, skip, factorization):
    params = gtsam.ISAM2Params()
    params.setFactorization(factorization)
    params.setRelinearizeThreshold(threshold)
    params.relinearizeSkip = skip
    return gtsam.ISAM2(params)


def unit_pose(x, y, z, qx, qy, qz, qw):
    n = np.linalg.norm([qw, qx, qy, qz])  # Rot3.Quaternion does not normalise
    return gtsam.Pose3(gtsam.Rot3.Quaternion(qw / n, qx / n, qy / n, qz / n), np.array([x, y, z]))


def read_points_g2o(path, observations, cauchy_k):
    """A 3D g2o file with point landmarks: the vertices' values by id, and the edges as
    (from, to, factor, initialise(known value) -> value of `to`). Odometry is a
    BetweenFactorPose3 (information permuted to GTSAM's (rotation, translation) order, as
    readG2o does); an observation (EDGE_SE3_TRACKXYZ through PARAMS_SE3OFFSET) is either the
    exact residual (compare_gtsam.py's point_in_sensor_error) as a CustomFactor (`exact`: the same chi2 as fitslam's, but a
    Python call per linearisation) or a BearingRangeFactor3D from the same point (`bearing-range`:
    the same graph structure, all in C++, its noise isotropic of the same mean variance: for
    timing, its chi2 is not comparable). With `cauchy_k`, a Cauchy kernel on every observation."""
    offsets, values, edges = {}, {}, []
    with open(path) as f:
        rows = [t for t in (line.split() for line in f) if t]
    for t in rows:
        if t[0] == "PARAMS_SE3OFFSET":
            offsets[int(t[1])] = unit_pose(*(float(v) for v in t[2:9]))
        elif t[0] == "VERTEX_SE3:QUAT":
            values[int(t[1])] = unit_pose(*(float(v) for v in t[2:9]))
        elif t[0] == "VERTEX_TRACKXYZ":
            values[int(t[1])] = np.array([float(v) for v in t[2:5]])
    for t in rows:
        if t[0] == "EDGE_SE3:QUAT":
            i, j = int(t[1]), int(t[2])
            z = unit_pose(*(float(v) for v in t[3:10]))
            m = symmetric([float(v) for v in t[10:31]], 6)
            g = np.block([[m[3:, 3:], m[3:, :3]], [m[:3, 3:], m[:3, :3]]])
            factor = gtsam.BetweenFactorPose3(i, j, z, gtsam.noiseModel.Gaussian.Information(g))
            edges.append((i, j, factor, lambda x, z=z: x.compose(z), lambda x, z=z: x.compose(z.inverse())))
        elif t[0] == "EDGE_SE3_TRACKXYZ":
            i, j, o = int(t[1]), int(t[2]), offsets[int(t[3])]
            z_sensor = np.array([float(v) for v in t[4:7]])
            info = symmetric([float(v) for v in t[7:13]], 3)  # of the residual in the sensor frame
            z = o.transformFrom(z_sensor)  # in the body frame
            if observations == "exact":
                noise = gtsam.noiseModel.Gaussian.Information(info)
            else:
                sigma = np.sqrt(np.trace(np.linalg.inv(info)) / 3.0)  # the trace does not depend on the frame
                rng = float(np.linalg.norm(z))
                noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([sigma / rng, sigma / rng, sigma]))
            if cauchy_k is not None:
                noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Cauchy.Create(cauchy_k), noise)
            if observations == "exact":
                factor = gtsam.CustomFactor(noise, [i, j], functools.partial(point_in_sensor_error, o, z_sensor))
            else:
                factor = gtsam.BearingRangeFactor3D(i, j, gtsam.Unit3(z), rng, noise)
            edges.append((i, j, factor, lambda x, z=z: x.transformFrom(z), None))
    return values, edges


def replay_gtsam_points(path, sigma, threshold, skip, factorization, observations, cauchy_k):
    """fitslam's replay (core/src/slam/incremental/g2o_replay.rs) of a 3D graph with point
    landmarks: vertices by increasing id, step r with the edges whose later end is vertex r,
    new vertices composed from a known end (passes until none is reached), the first pose
    anchored. Timed: the updates alone, and with the newest pose's estimate and marginal."""
    values, edges = read_points_g2o(path, observations, cauchy_k)
    ids = sorted(set(values) | {e[0] for e in edges} | {e[1] for e in edges})
    rank = {k: r for r, k in enumerate(ids)}
    steps = {}
    for e in edges:
        steps.setdefault(max(rank[e[0]], rank[e[1]]), []).append(e)
    first = min(k for k in values if isinstance(values[k], gtsam.Pose3))
    isam = isam2(threshold, skip, factorization)
    replay = TimedReplay(isam)
    entered, is_pose = set(), {}

    def known(key):
        if is_pose[key]:
            return isam.calculateEstimatePose3(key)
        return isam.calculateEstimatePoint3(key)

    for r in sorted(set(steps) | {rank[first]}):
        new_graph, new_values, fresh = gtsam.NonlinearFactorGraph(), gtsam.Values(), {}
        if ids[r] == first:
            fresh[first] = values[first]
            new_graph.add(gtsam.PriorFactorPose3(first, values[first], gtsam.noiseModel.Isotropic.Sigma(6, sigma)))
        step = steps.get(r, [])
        progress = True
        while progress:
            progress = False
            for a, b, _, forward, backward in step:
                a_known, b_known = a in entered or a in fresh, b in entered or b in fresh
                if a_known and not b_known:
                    fresh[b] = forward(fresh[a] if a in fresh else known(a))
                    progress = True
                elif b_known and not a_known and backward is not None:
                    fresh[a] = backward(fresh[b] if b in fresh else known(b))
                    progress = True
        for a, b, factor, _, _ in step:
            for k in (a, b):
                if k not in entered and k not in fresh:
                    fresh[k] = values[k]  # reached by no edge: the file's value
            new_graph.add(factor)
        for k in sorted(fresh, key=lambda k: rank[k]):
            new_values.insert(k, fresh[k])
            is_pose[k] = isinstance(fresh[k], gtsam.Pose3)
            entered.add(k)
        replay.step(new_graph, new_values, ids[r], lambda i, k=ids[r]: i.calculateEstimatePose3(k))
    return replay.result()


def run_gtsam(path, sigma, threshold, skip, observations, cauchy_k):
    """The replay through ISAM2 with Cholesky; on GTSAM's IndeterminateSystemException (some
    public graphs' near-singular edges) again with QR, which the result then says."""
    replay = (functools.partial(replay_gtsam_points, observations=observations, cauchy_k=cauchy_k) if has_points(path)
              else replay_gtsam)
    try:
        return dict(replay(path, sigma, threshold, skip, "CHOLESKY"), factorization="Cholesky")
    except RuntimeError:
        return dict(replay(path, sigma, threshold, skip, "QR"), factorization="QR")


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
    isam = isam2(threshold, skip, factorization)
    replay = TimedReplay(isam)
    entered = set()
    estimate = gtsam.Values()
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
        newest = max(entered, key=lambda k: rank[k])
        estimate = replay.step(new_graph, new_values, newest, lambda i: i.calculateEstimate())
    return replay.result()


def run_fitslam(exe, path, threshold, skip, cauchy_k):
    cmd = [exe, "optimize", "--incremental", "--g2o", path, "--json", "--relinearize-threshold", str(threshold), "--relinearize-skip", str(skip)]
    if cauchy_k is not None:
        cmd += ["--landmark-cauchy-k", str(cauchy_k)]
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
    ap.add_argument("--observations", choices=["exact", "bearing-range"], default="exact",
                    help="GTSAM's factor for point observations (see read_points_g2o)")
    ap.add_argument("--landmark-cauchy-k", type=float, default=None,
                    help="both solvers: a Cauchy kernel of this scale on every point observation (the simulator's SLAM: 4)")
    ap.add_argument("--fitslam", default=os.path.join(ROOT, "target", "release", "fitslam"),
                    help="the fitslam binary (built first when it is the default)")
    args = ap.parse_args()
    files = args.files or [os.path.join(DATA, f) for f in DEFAULT_FILES]
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core, inherited by fitslam
    if args.fitslam == ap.get_default("fitslam"):
        subprocess.run(["cargo", "build", "--release", "-q", "--bin", "fitslam"], cwd=ROOT, check=True)
    print(f"{'file':<20} {'steps f/g':>11} {'chi2 fitslam':>14} {'chi2 gtsam':>14} {'rel':>9} {'tr fitslam':>12} {'tr gtsam':>12} {'rel':>9}"
          f" {'ms fitslam':>11} {'ms g upd':>9} {'ms g all':>9} gtsam")
    for path in files:
        t, k = args.relinearize_threshold, args.relinearize_skip
        c = args.landmark_cauchy_k
        ours, ref = run_fitslam(args.fitslam, path, t, k, c), run_gtsam(path, args.sigma, t, k, args.observations, c)
        rel_chi2 = (ours["final_chi2"] - ref["final_chi2"]) / ref["final_chi2"]
        rel_tr = (ours["trace"] - ref["trace"]) / ref["trace"]
        print(f"{os.path.basename(path):<20} {ours['steps']:>5}/{ref['steps']:<5} {ours['final_chi2']:>14.6f} {ref['final_chi2']:>14.6f} {rel_chi2:>9.2e}"
              f" {ours['trace']:>12.6g} {ref['trace']:>12.6g} {rel_tr:>9.2e} {ours['total_ms']:>11.1f} {ref['update_ms']:>9.1f} {ref['total_ms']:>9.1f} {ref['factorization']}")


if __name__ == "__main__":
    main()
