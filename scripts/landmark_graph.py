#!/usr/bin/env python3
"""Writes a seeded synthetic landmark graph in g2o format, 2D or 3D, for checking
`fitslam optimize` against GTSAM on point landmarks (`scripts/compare_gtsam.py`), since no real
g2o landmark dataset ships with the repository.

A robot random-walks for POSES steps of 0.5 m in a 40 m x 40 m box among LANDMARKS points, with
noisy odometry (sigma 2 cm per axis, 5 mrad per rotation axis) and a noisy point (sigma 5 cm
per axis) for every landmark within 5 m. Poses start from composed odometry; every other
landmark has a vertex (its first sighting, 0.3 m off), the others are initialised by the
readers from their first sighting.
- 2D: VERTEX_SE2 / EDGE_SE2, VERTEX_XY / EDGE_SE2_XY (the point in the robot frame).
- 3D (--dim 3): the ground undulates (z, roll, pitch); VERTEX_SE3:QUAT / EDGE_SE3:QUAT, and
  VERTEX_TRACKXYZ / EDGE_SE3_TRACKXYZ seen by a camera mounted 0.2 m ahead and 0.3 m up,
  looking forward in the optical convention (z forward, x right, y down): PARAMS_SE3OFFSET 0.

Usage: python3 scripts/landmark_graph.py OUT.g2o [--dim 2|3] [--poses 2000] [--landmarks 300] [--seed 2]
"""

import argparse
import math
import random

import numpy as np


def relative(a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    d = b[2] - a[2]
    return (c * dx + s * dy, -s * dx + c * dy, math.atan2(math.sin(d), math.cos(d)))


def compose(a, r):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * r[0] - s * r[1], a[1] + s * r[0] + c * r[1], a[2] + r[2])


def walk(rng, poses):
    truth, x, y, th = [], 0.0, 0.0, 0.0
    for _ in range(poses):
        truth.append((x, y, th))
        th += rng.gauss(0, 0.15)
        x = min(max(x + 0.5 * math.cos(th), 0.0), 40.0)
        y = min(max(y + 0.5 * math.sin(th), 0.0), 40.0)
    return truth


def write_2d(args, rng):
    points = [(rng.uniform(-5, 45), rng.uniform(-5, 45)) for _ in range(args.landmarks)]
    truth = walk(rng, args.poses)
    edges, estimate = [], [(0.0, 0.0, 0.0)]
    for i in range(1, args.poses):
        r = relative(truth[i - 1], truth[i])
        r = (r[0] + rng.gauss(0, 0.02), r[1] + rng.gauss(0, 0.02), r[2] + rng.gauss(0, 0.005))
        estimate.append(compose(estimate[-1], r))
        edges.append("EDGE_SE2 %d %d %.9f %.9f %.9f 2500 0 0 2500 0 40000" % (i - 1, i, *r))
    first_seen = {}
    for i, p in enumerate(truth):
        c, s = math.cos(p[2]), math.sin(p[2])
        for j, m in enumerate(points):
            dx, dy = m[0] - p[0], m[1] - p[1]
            if dx * dx + dy * dy < 25.0:
                z = (c * dx + s * dy + rng.gauss(0, 0.05), -s * dx + c * dy + rng.gauss(0, 0.05))
                first_seen.setdefault(j, compose(estimate[i], (z[0], z[1], 0.0)))
                edges.append("EDGE_SE2_XY %d %d %.9f %.9f 400 0 400" % (i, 10000 + j, *z))
    lines = ["VERTEX_SE2 %d %.9f %.9f %.9f" % (i, *p) for i, p in enumerate(estimate)]
    lines += ["VERTEX_XY %d %.9f %.9f" % (10000 + j, m[0] + 0.3, m[1] - 0.3) for j, m in sorted(first_seen.items()) if j % 2 == 0]
    return lines + edges


def hat(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def so3_exp(w):
    t = np.linalg.norm(w)
    if t < 1e-12:
        return np.eye(3) + hat(w)
    k = hat(w / t)
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k


def quaternion(r):
    """(qx, qy, qz, qw) of a rotation matrix, qw >= 0."""
    w = math.sqrt(max(0.0, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2, r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2, r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2, r[1, 0] - r[0, 1])
    return x, y, z, w


def pose_line(tag, ids, r, t):
    return tag + " " + " ".join(str(i) for i in ids) + " %.9f %.9f %.9f %.12f %.12f %.12f %.12f" % (*t, *quaternion(r))


def write_3d(args, rng):
    points = [np.array([rng.uniform(-5, 45), rng.uniform(-5, 45), rng.uniform(0, 2)]) for _ in range(args.landmarks)]
    truth = []
    for x, y, th in walk(rng, args.poses):
        z = 0.3 * math.sin(0.2 * x) * math.cos(0.15 * y)
        r = so3_exp(np.array([0, 0, th])) @ so3_exp(np.array([rng.gauss(0, 0.05), rng.gauss(0, 0.05), 0]))
        truth.append((r, np.array([x, y, z])))
    # Camera on the robot: 0.2 m ahead, 0.3 m up; optical axes (x right, y down, z forward).
    o_r = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    o_t = np.array([0.2, 0.0, 0.3])
    info6 = " ".join("2500" if (i == j and i < 3) else "40000" if i == j else "0" for i in range(6) for j in range(i, 6))
    edges, estimate = [], [(np.eye(3), np.zeros(3))]
    for i in range(1, args.poses):
        (ra, ta), (rb, tb) = truth[i - 1], truth[i]
        dr, dt = ra.T @ rb, ra.T @ (tb - ta)
        dr = dr @ so3_exp(np.array([rng.gauss(0, 0.005) for _ in range(3)]))
        dt = dt + np.array([rng.gauss(0, 0.02) for _ in range(3)])
        re, te = estimate[-1]
        estimate.append((re @ dr, te + re @ dt))
        edges.append(pose_line("EDGE_SE3:QUAT", (i - 1, i), dr, dt) + " " + info6)
    first_seen = {}
    for i, (r, t) in enumerate(truth):
        cam_r, cam_t = r @ o_r, t + r @ o_t
        for j, m in enumerate(points):
            if np.linalg.norm(m - t) < 5.0:
                z = cam_r.T @ (m - cam_t) + np.array([rng.gauss(0, 0.05) for _ in range(3)])
                re, te = estimate[i]
                first_seen.setdefault(j, te + re @ (o_t + o_r @ z))
                edges.append("EDGE_SE3_TRACKXYZ %d %d 0 %.9f %.9f %.9f 400 0 0 400 0 400" % (i, 10000 + j, *z))
    lines = [pose_line("VERTEX_SE3:QUAT", (i,), r, t) for i, (r, t) in enumerate(estimate)]
    lines.append(pose_line("PARAMS_SE3OFFSET", (0,), o_r, o_t))
    lines += ["VERTEX_TRACKXYZ %d %.9f %.9f %.9f" % (10000 + j, m[0] + 0.3, m[1] - 0.3, m[2]) for j, m in sorted(first_seen.items()) if j % 2 == 0]
    return lines + edges


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--dim", type=int, choices=[2, 3], default=2)
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--landmarks", type=int, default=300)
    ap.add_argument("--seed", type=int, default=2)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    lines = write_2d(args, rng) if args.dim == 2 else write_3d(args, rng)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
