"""scripts/ray-compare DIR [--address A]: runs every pending entry of a fitslam plan as a Ray task
(one CPU each, retried on failure), then writes the report with `fitslam collect DIR`.

Without --address it starts a Ray cluster on this machine (127.0.0.1 only); with one it joins a
running cluster, whose every node must reach the same checkout (the plan's relative world paths
and DIR are taken from the folder this is started in) and the same fitslam build.
"""

import argparse
import sys

import fitslam_sweep as sweep


def main():
    ap = argparse.ArgumentParser(prog="scripts/ray-compare", description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", help="the plan's folder (fitslam plan --out DIR)")
    ap.add_argument("--address", help="a running Ray cluster (ray start --head prints it); default: a local one")
    ap.add_argument("--retries", type=int, default=3, help="attempts after a task's first failure (default 3)")
    ap.add_argument("--fitslam", help="the fitslam binary (default: $FITSLAM, fitslam on PATH, target/release/fitslam)")
    args = ap.parse_args()
    binary = sweep.find_fitslam(args.fitslam)
    todo = sweep.pending(binary, args.dir)
    print(f"ray-compare: {len(todo)} pending entries in {args.dir}", file=sys.stderr, flush=True)
    if todo:
        ray = sweep.connect(args.address)
        try:
            failures = sweep.run_on_ray(ray, binary, args.dir, todo, args.retries, label="ray-compare")
        finally:
            ray.shutdown()
        if failures:
            for index, why in sorted(failures.items()):
                print(f"ray-compare: entry {index} failed: {why}", file=sys.stderr)
            sys.exit(f"ray-compare: {len(failures)} entries failed after {args.retries} retries; run again to retry them")
    sys.stdout.write(sweep.fitslam(binary, "collect", args.dir))


if __name__ == "__main__":
    main()
