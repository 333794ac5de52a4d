"""scripts/sensitivity: the primary metric and T_90 against one planner parameter at a time.

For each `--vary KEY=V1,V2,…` and each value, a parameter file setting that key alone (every
other parameter at its default) and a fitslam plan of `fit` missions on the given worlds, run on
this machine's threads or as Ray tasks (`--address`), then `fitslam collect` (scripts/tune's
missions: a rerun keeps the runs already there). The default's missions run once and are shared by
every key whose value equals its default.

Per value, over the worlds (each world: the mean over its seeds of the runs that reached 90 %):
- the primary metric, the geometric mean over worlds of tr(cov) at matched coverage 25-90 %, with
  the range of ± one standard error of the worlds' log values;
- T_90, the mean over worlds of the time to 90 % coverage (s), ± one standard error.
OUT/sensitivity.csv holds every point, OUT/sensitivity.{png,svg} one column per key, the default
marked. Development worlds only (docs/protocol.md): what this shows chooses nothing on test worlds.
"""

import argparse
import csv
import math
import sys
import tomllib
from pathlib import Path

import fitslam_sweep as sweep
import tune


def parse_vary(text, defaults):
    """`KEY=V1,V2,…` -> (key, kind, [values], default or None); the kind is the default's type in
    `defaults` (`fitslam params` as a dict), float for a parameter whose default is unset."""
    key, sep, values = text.partition("=")
    key = key.strip()
    if not (sep and key and values):
        raise ValueError(f"--vary {text!r}: expected SECTION.KEY=V1,V2,…, e.g. u2.beta=0,0.2,0.4")
    default = tune.numeric_default(key, defaults, "--vary", text)
    kind = type(default) if default is not None else float
    try:
        parsed = sorted({kind(float(v)) if kind is float else int(v) for v in values.split(",")})
    except ValueError:
        raise ValueError(f"--vary {text!r}: the values are not {kind.__name__}s") from None
    return key, kind, parsed, default


def world_values(summary_csv):
    """Per world (sorted by world seed): (mean T_90, mean log tr(cov)) over its seeds that reached
    90 %; worlds where none did are left out."""
    with open(summary_csv, newline="") as f:
        rows = list(csv.DictReader(f))
    worlds = {}
    for r in rows:
        t90, cov = float(r["t90_s"]), float(r["matched_cov_trace"])
        if math.isfinite(t90) and math.isfinite(cov) and cov > 0:
            w = worlds.setdefault(int(r.get("world_seed") or 0), ([], []))
            w[0].append(t90)
            w[1].append(math.log(cov))
    return [(sum(t) / len(t), sum(c) / len(c)) for _, (t, c) in sorted(worlds.items())]


def mean_se(values):
    """Mean and standard error (sample SD / √n; 0 for one value)."""
    n = len(values)
    mean = sum(values) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1)) if n > 1 else 0.0
    return mean, sd / math.sqrt(n)


def main():
    ap = argparse.ArgumentParser(prog="scripts/sensitivity", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="output folder (a rerun keeps the runs already there)")
    ap.add_argument("--world", required=True, help="world file (its family's development members)")
    ap.add_argument("--world-seeds", default=None, help="development worlds A..B (default: the file's `world_seeds`, else its world)")
    ap.add_argument("--seeds", default="1", help="noise seeds per world (default 1)")
    ap.add_argument("--vary", action="append", required=True, help="KEY=V1,V2,… (repeatable), e.g. u2.beta=0,0.2,0.4,0.6,0.8,1")
    ap.add_argument("--jobs", type=int, default=None, help="local threads (default: every core)")
    ap.add_argument("--address", default=None, help="a Ray cluster's address (default: run on local threads)")
    ap.add_argument("--time-limit-s", default=None)
    ap.add_argument("--localisation", default=None)
    ap.add_argument("--sim-params", default=None)
    ap.add_argument("--fitslam", default=None, help="the fitslam binary (default: target/release/fitslam, then PATH)")
    args = ap.parse_args()
    args.max_unreached = 1.0  # missions() reports the share; nothing here is infeasible
    binary = sweep.find_fitslam(args.fitslam)
    defaults = tomllib.loads(sweep.fitslam(binary, "params"))
    try:
        varied = [parse_vary(v, defaults) for v in args.vary]
    except ValueError as e:
        sys.exit(f"scripts/sensitivity: {e}")
    ray = sweep.connect(args.address) if args.address else None
    args.out.mkdir(parents=True, exist_ok=True)
    points = []
    for key, kind, values, default in varied:
        for value in values:
            is_default = default is not None and math.isclose(value, default)
            folder = args.out / "runs" / ("default" if is_default else f"{key}={value}")
            folder.mkdir(parents=True, exist_ok=True)
            params = folder / "params.toml"
            table, _, leaf = key.rpartition(".")
            params.write_text("" if is_default else f"[{table}]\n{leaf} = {kind(value)!r}\n")
            _, _, unreached = tune.missions(args, binary, ray, params, folder / "missions", 1, f"{key}={value}")
            per_world = world_values(folder / "missions" / "summary.csv")
            t90, t90_se = mean_se([w[0] for w in per_world])
            log_cov, log_se = mean_se([w[1] for w in per_world])
            points.append(dict(key=key, value=value, default=is_default, worlds=len(per_world), t90_s=t90, t90_se_s=t90_se,
                               matched_cov_trace=math.exp(log_cov), cov_low=math.exp(log_cov - log_se),
                               cov_high=math.exp(log_cov + log_se), unreached=unreached))
            print(f"{key} = {value}: T_90 {t90:.1f} ± {t90_se:.1f} s, tr(cov) {math.exp(log_cov):.4g}, {len(per_world)} worlds",
                  file=sys.stderr, flush=True)
    columns = ["key", "value", "default", "worlds", "t90_s", "t90_se_s", "matched_cov_trace", "cov_low", "cov_high", "unreached"]
    with open(args.out / "sensitivity.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(columns)
        for p in points:
            w.writerow([tune.fmt(p[c]) for c in columns])
    figure(points, [v[0] for v in varied], args)
    print(f"{args.out}: {len(points)} points; sensitivity.csv, sensitivity.png, sensitivity.svg")


def figure(points, keys, args):
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "fitslam"  # the SVG's ids the same from run to run
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(keys), figsize=(3.2 * len(keys), 5.6), dpi=120, squeeze=False, sharey="row")
    for col, key in enumerate(keys):
        ps = [p for p in points if p["key"] == key]
        x = [p["value"] for p in ps]
        top, bottom = axes[0][col], axes[1][col]
        top.errorbar(x, [p["matched_cov_trace"] for p in ps],
                     yerr=[[p["matched_cov_trace"] - p["cov_low"] for p in ps], [p["cov_high"] - p["matched_cov_trace"] for p in ps]],
                     fmt="o-", c="tab:blue", capsize=3)
        bottom.errorbar(x, [p["t90_s"] for p in ps], yerr=[p["t90_se_s"] for p in ps], fmt="o-", c="tab:orange", capsize=3)
        for ax in (top, bottom):
            for p in ps:
                if p["default"]:
                    ax.axvline(p["value"], c="gray", lw=0.8, ls="--")
            ax.grid(alpha=0.3)
        top.set_yscale("log")
        bottom.set_xlabel(key)
    axes[0][0].set_ylabel("tr(cov) at 25–90 % (m² + rad²)")
    axes[1][0].set_ylabel("T_90 (s)")
    worlds = f"worlds {args.world_seeds}" if args.world_seeds else "its world"
    fig.suptitle(f"fit on {Path(args.world).stem}, {worlds} × {args.seeds} seed(s); dashed: default; bars: ± 1 SE over worlds",
                 fontsize=9)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(args.out / f"sensitivity.{ext}", metadata={"Date": None} if ext == "svg" else {})
    plt.close(fig)


if __name__ == "__main__":
    main()
