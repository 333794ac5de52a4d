#!/usr/bin/env python3
"""Compare fitslam's SLAM backend with GTSAM on the same pose graphs.

For each file, both solvers start from the same initial estimate (GTSAM's readG2o / load2D,
which fitslam's readers reproduce: vertices as given, missing poses chained along the edges,
landmarks from their first sighting) and solve the same problem: the file's factors plus a
prior of standard deviation SIGMA on every tangent component of the first pose, at its initial
value (fitslam: `--prior-sigma SIGMA`). Both run Levenberg-Marquardt to a tight tolerance,
fitslam with GTSAM's damping schedule by default (`--schedule nielsen` for its own): on
non-convex problems started far from the optimum (MIT, Victoria Park) the local minimum
reached depends on the path.

Printed per file: final chi2 of both (chi2 = 2 x GTSAM's graph.error) and their relative
difference (target 1e-6), the relative difference of the last pose's marginal covariance
(max |ours - gtsam| / max |gtsam|), iterations and optimisation times. GTSAM's Pose3 tangent is
(rotation, translation); fitslam's is (translation, rotation): the GTSAM block is permuted.
Both covariances are in the body frame (right perturbation).

Point landmarks (g2o's VERTEX_XY / EDGE_SE2_XY, and VERTEX_TRACKXYZ / EDGE_SE3_TRACKXYZ with
PARAMS_SE3OFFSET, which GTSAM's readG2o skips) are added to GTSAM's graph as CustomFactors in
Python: chi2 and marginals compare as usual, but GTSAM's time is then dominated by Python
callbacks and says nothing about GTSAM's speed.

Usage (from the repository root; needs `pip install gtsam==4.3.0`):
    python3 scripts/compare_gtsam.py [FILES...]        # default: every file in assets/data/slam
Both solvers are pinned to one core (sched_setaffinity), and fitslam is built in release.
"""

import argparse
import functools
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

try:
    import gtsam
except ImportError:  # pragma: no cover
    sys.exit("compare_gtsam.py needs GTSAM's Python package: pip install gtsam==4.3.0")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "assets", "data", "slam")
DEFAULT_FILES = ["intel.g2o", "MIT.g2o", "CSAIL.g2o", "parking-garage.g2o", "smallGrid3D.g2o", "victoria_park.txt"]


def first_tag(path):
    with open(path) as f:
        for line in f:
            tok = line.split()
            if tok:
                return tok[0]
    return ""


def load_gtsam(path):
    tag = first_tag(path)
    if tag in ("ODOMETRY", "LANDMARK"):
        graph, initial = gtsam.load2D(path)  # NoiseFormatAUTO, as fitslam's victoria reader
        is3d = False
    else:
        is3d = tag.startswith("VERTEX_SE3") or tag.startswith("EDGE_SE3") or tag == "PARAMS_SE3OFFSET"
        graph, initial = gtsam.readG2o(without_point_landmarks(path), is3d)
    add_point_landmarks(path, graph, initial)
    # Pose keys are plain integers; landmarks are Symbol('l', j).
    pose_keys = sorted(k for k in initial.keys() if gtsam.Symbol(k).chr() == 0)
    return graph, initial, pose_keys, is3d


POINT_LANDMARK_TAGS = ("VERTEX_XY", "EDGE_SE2_XY", "VERTEX_TRACKXYZ", "EDGE_SE3_TRACKXYZ", "PARAMS_SE3OFFSET")


def without_point_landmarks(path):
    """`path`, or a temporary copy without the point-landmark lines, which are added apart
    (readG2o skips the 2D ones and refuses EDGE_SE3_TRACKXYZ with a non-identity offset)."""
    with open(path) as f:
        lines = f.readlines()
    kept = [l for l in lines if not l.split() or l.split()[0] not in POINT_LANDMARK_TAGS]
    if len(kept) == len(lines):
        return path
    out = tempfile.NamedTemporaryFile("w", suffix=".g2o", delete=False)
    out.writelines(kept)
    out.close()
    return out.name


def point_in_sensor_error(offset, z, this, values, jacobians):
    """g2o's EdgeSE3PointXYZ: e = (x o)^-1 m - z, o the sensor's PARAMS_SE3OFFSET pose."""
    x = values.atPose3(this.keys()[0])
    m = values.atPoint3(this.keys()[1])
    hc = np.zeros((6, 6), order="F")
    sensor = x.compose(offset, hc, None)
    hp, hm = np.zeros((3, 6), order="F"), np.zeros((3, 3), order="F")
    p = sensor.transformTo(m, hp, hm)
    if jacobians is not None:
        jacobians[0], jacobians[1] = hp @ hc, hm
    return p - z


def point_in_pose_error(z, this, values, jacobians):
    """g2o's EdgeSE2PointXY: e = x^-1 m - z."""
    x = values.atPose2(this.keys()[0])
    m = values.atPoint2(this.keys()[1])
    hx, hm = np.zeros((2, 3), order="F"), np.zeros((2, 2), order="F")
    p = x.transformTo(m, hx, hm)
    if jacobians is not None:
        jacobians[0], jacobians[1] = hx, hm
    return p - z


def symmetric(upper, d):
    """The d x d symmetric matrix of an upper triangle given row by row."""
    m, k = np.zeros((d, d)), 0
    for r in range(d):
        for c in range(r, d):
            m[r, c] = m[c, r] = upper[k]
            k += 1
    return m


def add_point_landmarks(path, graph, initial):
    """Adds the file's point landmarks (VERTEX_XY / EDGE_SE2_XY, VERTEX_TRACKXYZ /
    EDGE_SE3_TRACKXYZ through PARAMS_SE3OFFSET) as Symbol('l', id) points and CustomFactors, a
    missing landmark initialised at its first sighting (as fitslam does)."""
    with open(path, encoding="utf-8-sig") as f:
        rows = [t for t in (line.split("#")[0].split() for line in f) if t]
    offsets = {}
    for t in rows:
        if t[0] == "PARAMS_SE3OFFSET":
            x, y, z, qx, qy, qz, qw = (float(v) for v in t[2:9])
            # Rot3.Quaternion does not normalise (readG2o does, for vertices and edges).
            n = np.linalg.norm([qw, qx, qy, qz])
            rot = gtsam.Rot3.Quaternion(qw / n, qx / n, qy / n, qz / n)
            offsets[int(t[1])] = gtsam.Pose3(rot, np.array([x, y, z]))
    # Every VERTEX line first: a landmark listed after an edge to it starts where its line says.
    for t in rows:
        if t[0] in ("VERTEX_XY", "VERTEX_TRACKXYZ"):
            key = gtsam.symbol("l", int(t[1]))
            if not initial.exists(key):
                initial.insert(key, np.array([float(v) for v in t[2:]]))
    for t in rows:
        if t[0] in ("EDGE_SE2_XY", "EDGE_SE3_TRACKXYZ"):
            i, key = int(t[1]), gtsam.symbol("l", int(t[2]))
            if t[0] == "EDGE_SE2_XY":
                d, z = 2, np.array([float(v) for v in t[3:5]])
                sensor, error = initial.atPose2(i), functools.partial(point_in_pose_error, z)
            else:
                offset = offsets[int(t[3])]
                d, z = 3, np.array([float(v) for v in t[4:7]])
                sensor, error = initial.atPose3(i).compose(offset), functools.partial(point_in_sensor_error, offset, z)
            info = symmetric([float(v) for v in t[len(t) - d * (d + 1) // 2:]], d)
            if not initial.exists(key):
                initial.insert(key, sensor.transformFrom(z))
            graph.add(gtsam.CustomFactor(gtsam.noiseModel.Gaussian.Information(info), [i, key], error))


def run_gtsam(path, sigma, max_iterations, rel_tol):
    graph, initial, pose_keys, is3d = load_gtsam(path)
    first, last = pose_keys[0], pose_keys[-1]
    if is3d:
        graph.add(gtsam.PriorFactorPose3(first, initial.atPose3(first), gtsam.noiseModel.Isotropic.Sigma(6, sigma)))
    else:
        graph.add(gtsam.PriorFactorPose2(first, initial.atPose2(first), gtsam.noiseModel.Isotropic.Sigma(3, sigma)))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    params.setRelativeErrorTol(rel_tol)
    params.setAbsoluteErrorTol(1e-12)
    initial_chi2 = 2.0 * graph.error(initial)
    t0 = time.perf_counter()
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    result = optimizer.optimize()
    time_ms = (time.perf_counter() - t0) * 1e3
    cov = gtsam.Marginals(graph, result).marginalCovariance(last)
    if is3d:
        perm = [3, 4, 5, 0, 1, 2]  # GTSAM (rot, trans) -> fitslam (trans, rot)
        cov = cov[np.ix_(perm, perm)]
    return {
        "initial_chi2": initial_chi2,
        "final_chi2": 2.0 * graph.error(result),
        "iterations": optimizer.iterations(),
        "time_ms": time_ms,
        "last_marginal": cov,
    }


def run_fitslam(path, sigma, max_iterations, rel_tol, schedule):
    cmd = [
        "cargo", "run", "--release", "-q", "--", "optimize", "--g2o", path, "--json",
        "--prior-sigma", repr(sigma), "--max-iterations", str(max_iterations),
        "--relative-tolerance", repr(rel_tol), "--lambda-schedule", schedule,
    ]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
    r = json.loads(out.stdout)
    d = int(round(len(r["last_marginal"]) ** 0.5))
    r["last_marginal"] = np.array(r["last_marginal"]).reshape(d, d)
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*", help="pose graphs (default: assets/data/slam/*)")
    ap.add_argument("--sigma", type=float, default=1e-3, help="prior sigma on the first pose (default 1e-3)")
    ap.add_argument("--max-iterations", type=int, default=1000)
    ap.add_argument("--relative-tolerance", type=float, default=1e-10)
    ap.add_argument("--schedule", choices=["gtsam", "nielsen"], default="gtsam",
                    help="fitslam's LM damping schedule (default gtsam: same path as GTSAM)")
    args = ap.parse_args()
    files = args.files or [os.path.join(DATA, f) for f in DEFAULT_FILES]
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core, inherited by cargo
    # Build once so that the first timing does not include compilation.
    subprocess.run(["cargo", "build", "--release", "-q"], cwd=ROOT, check=True)
    print(f"prior sigma {args.sigma}, LM (fitslam schedule: {args.schedule}), rel tol {args.relative_tolerance}")
    header = f"{'file':<20} {'chi2 fitslam':>16} {'chi2 gtsam':>16} {'rel diff':>9} {'marg rel':>9} {'it f/g':>9} {'ms fitslam':>10} {'ms gtsam':>10}"
    print(header)
    worst = 0.0
    for path in files:
        ours = run_fitslam(path, args.sigma, args.max_iterations, args.relative_tolerance, args.schedule)
        ref = run_gtsam(path, args.sigma, args.max_iterations, args.relative_tolerance)
        rel = abs(ours["final_chi2"] - ref["final_chi2"]) / max(abs(ref["final_chi2"]), 1e-300)
        a, b = ours["last_marginal"], ref["last_marginal"]
        marg = float(np.max(np.abs(a - b)) / np.max(np.abs(b))) if a.shape == b.shape else float("nan")
        init_rel = abs(ours["initial_chi2"] - ref["initial_chi2"]) / max(abs(ref["initial_chi2"]), 1e-300)
        worst = max(worst, rel)
        print(
            f"{os.path.basename(path):<20} {ours['final_chi2']:>16.9f} {ref['final_chi2']:>16.9f} {rel:>9.1e} {marg:>9.1e} "
            f"{ours['iterations']:>4}/{ref['iterations']:<4} {ours['time_ms']:>10.1f} {ref['time_ms']:>10.1f}"
            + ("" if init_rel < 1e-9 else f"   (initial chi2 differs: {ours['initial_chi2']:.9g} vs {ref['initial_chi2']:.9g})")
        )
    print(f"worst relative chi2 difference: {worst:.1e} ({'within' if worst <= 1e-6 else 'ABOVE'} 1e-6)")


if __name__ == "__main__":
    main()
