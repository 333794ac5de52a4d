#!/usr/bin/env python3
"""Writes a seeded synthetic 2D landmark graph in g2o format, for checking `fitslam optimize`
against GTSAM on point landmarks (`scripts/compare_gtsam.py`), since no real g2o landmark
dataset ships with the repository.

A robot random-walks for POSES steps of 0.5 m in a 40 m x 40 m box among LANDMARKS points,
with noisy odometry (EDGE_SE2, sigma 2 cm / 2 cm / 5 mrad) and a noisy robot-frame point for
every landmark within 5 m (EDGE_SE2_XY, sigma 5 cm). Poses start from composed odometry; every
other landmark has a VERTEX_XY (its first sighting, 0.3 m off), the others are initialised by
the readers from their first sighting.

Usage: python3 scripts/landmark_graph_2d.py OUT.g2o [--poses 2000] [--landmarks 300] [--seed 2]
"""

import argparse
import math
import random


def relative(a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    d = b[2] - a[2]
    return (c * dx + s * dy, -s * dx + c * dy, math.atan2(math.sin(d), math.cos(d)))


def compose(a, r):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * r[0] - s * r[1], a[1] + s * r[0] + c * r[1], a[2] + r[2])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--landmarks", type=int, default=300)
    ap.add_argument("--seed", type=int, default=2)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    points = [(rng.uniform(-5, 45), rng.uniform(-5, 45)) for _ in range(args.landmarks)]
    truth, x, y, th = [], 0.0, 0.0, 0.0
    for _ in range(args.poses):
        truth.append((x, y, th))
        th += rng.gauss(0, 0.15)
        x = min(max(x + 0.5 * math.cos(th), 0.0), 40.0)
        y = min(max(y + 0.5 * math.sin(th), 0.0), 40.0)
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
    with open(args.out, "w") as f:
        for i, p in enumerate(estimate):
            f.write("VERTEX_SE2 %d %.9f %.9f %.9f\n" % (i, *p))
        for j in sorted(first_seen):
            if j % 2 == 0:
                m = first_seen[j]
                f.write("VERTEX_XY %d %.9f %.9f\n" % (10000 + j, m[0] + 0.3, m[1] - 0.3))
        f.write("\n".join(edges) + "\n")


if __name__ == "__main__":
    main()
