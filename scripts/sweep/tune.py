"""scripts/tune: Optuna over the utility's parameters, two objectives, on development worlds.

Each trial is a parameter file (the paper's defaults with the searched values set) and one
fitslam plan of `fit` missions on the given worlds (`fitslam plan --params …`), run on this
machine's threads or as Ray tasks (`--address`), then `fitslam collect`. Its two objectives, both
minimised, come from the plan's summary.csv:
- T_90: the mean over worlds of the mean time to 90 % coverage over the world's seeds (s);
- the primary metric: the geometric mean over worlds of the geometric mean over seeds of the mean
  tr(cov) at matched coverage 25-90 % (docs/experiments.md).
Both are taken over the runs that reached 90 % coverage; a trial whose share of runs that never
did is above --max-unreached is infeasible (an Optuna constraint), so it cannot be on the front.

A front found on a few worlds and seeds is optimistic: each point is the best of many noisy
draws. `--confirm-seed-start K` runs every Pareto point and the paper's trial again on the same
worlds with noise seeds K, K+1, … (as many as --seeds), which the search never saw, and reports
both measurements side by side (STUDY/confirm.csv, pareto.md, hollow markers in the figure).

`--search KEY=LOW..HIGH` (repeatable) adds any other planner parameter to the search, e.g.
`u2.sigma_bearing_rad=0.005..0.05` (integers when both bounds are), or changes a weight's range
(`u2.top_n=1..30`); pareto.csv and pareto.md get a column per parameter any trial searched.

The study lives in STUDY/journal.log (Optuna's journal-file storage): any number of `scripts/tune`
processes, on any machines that share STUDY, add trials to one study. The paper's α = 0.35,
β = 0.4, N = 7 is the study's first trial. `--report` (also run after the trials) writes
STUDY/pareto.csv, pareto.md, pareto.{png,svg} and STUDY/pareto/trial_<n>.toml, a whole parameter
file per Pareto point that `fitslam --params`, the studio and the robot node read.
"""

import argparse
import csv
import json
import math
import os
import sys
import tomllib
from pathlib import Path

import fitslam_sweep as sweep

# The paper's three weights, always searched: name -> (parameter key, kind, low, high), and the
# paper's values (trial 0). `--search KEY=LOW..HIGH` adds any other parameter (named by its key).
SPACE = {
    "alpha": ("u1.alpha", float, 0.0, 1.0),
    "beta": ("u2.beta", float, 0.0, 1.0),
    "top_n": ("u2.top_n", int, 1, 15),
}
PAPER = {"alpha": 0.35, "beta": 0.4, "top_n": 7}
LABELS = {"alpha": "α", "beta": "β", "top_n": "N"}
OBJECTIVES = ("t90_s", "matched_cov_trace")


def numeric_default(key, defaults, flag, text):
    """The default of the planner parameter `key` in `defaults` (`fitslam params` as a dict), None
    when it is unset; a ValueError naming `flag text` when it is not a number."""
    default = defaults
    for part in key.split("."):
        default = default.get(part) if isinstance(default, dict) else None
    if isinstance(default, bool) or not (default is None or isinstance(default, (int, float))):
        raise ValueError(f"{flag} {text!r}: {key} is not a numeric planner parameter (see `fitslam params`)")
    return default


def parse_search(text, defaults):
    """`KEY=LOW..HIGH` -> (name, (key, kind, low, high)), the kind (int or float) that of the
    parameter's default in `defaults` (`fitslam params` as a dict); a paper weight's key
    (u1.alpha, u2.beta, u2.top_n) keeps its name."""
    key, sep, bounds = text.partition("=")
    low, sep2, high = bounds.partition("..")
    key = key.strip()
    if not (sep and sep2 and key):
        raise ValueError(f"--search {text!r}: expected SECTION.KEY=LOW..HIGH, e.g. u2.sigma_bearing_rad=0.005..0.05")
    default = numeric_default(key, defaults, "--search", text)
    if default is None:
        raise ValueError(f"--search {text!r}: {key} is not a numeric planner parameter (see `fitslam params`)")
    kind = type(default)
    try:
        lo, hi = kind(float(low)) if kind is float else int(low), kind(float(high)) if kind is float else int(high)
    except ValueError:
        raise ValueError(f"--search {text!r}: the bounds are not {kind.__name__}s") from None
    if not lo < hi:
        raise ValueError(f"--search {text!r}: LOW must be below HIGH")
    name = next((n for n, spec in SPACE.items() if spec[0] == key), key)
    return name, (key, kind, lo, hi)


def params_toml(values, space):
    """A parameter file setting `values` (name -> value; every other parameter keeps its default)."""
    tables = {}
    for name, value in values.items():
        key, kind, _, _ = space[name]
        table, _, leaf = key.rpartition(".")
        tables.setdefault(table, []).append(f"{leaf} = {kind(value)!r}")
    return "".join(f"[{t}]\n" + "\n".join(sorted(lines)) + "\n" for t, lines in sorted(tables.items()))


def objectives(summary_csv, max_unreached):
    """(T_90, primary, unreached share) from a plan's summary.csv (module docstring)."""
    with open(summary_csv, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{summary_csv}: no run")
    worlds = {}
    for r in rows:
        t90, cov = float(r["t90_s"]), float(r["matched_cov_trace"])
        w = worlds.setdefault(r.get("world_seed", ""), {"t90": [], "log_cov": [], "runs": 0})
        w["runs"] += 1
        if math.isfinite(t90) and math.isfinite(cov) and cov > 0:
            w["t90"].append(t90)
            w["log_cov"].append(math.log(cov))
    unreached = sum(w["runs"] - len(w["t90"]) for w in worlds.values()) / len(rows)
    reached = [w for w in worlds.values() if w["t90"]]
    if not reached:
        return math.inf, math.inf, unreached
    t90 = sum(sum(w["t90"]) / len(w["t90"]) for w in reached) / len(reached)
    primary = math.exp(sum(sum(w["log_cov"]) / len(w["log_cov"]) for w in reached) / len(reached))
    return t90, primary, unreached


def pareto_front(points):
    """The points (dicts with both OBJECTIVES) no other point dominates (≤ in both, < in one)."""

    def dominates(a, b):
        return all(a[k] <= b[k] for k in OBJECTIVES) and any(a[k] < b[k] for k in OBJECTIVES)

    return [p for p in points if not any(dominates(q, p) for q in points if q is not p)]


def main():
    ap = argparse.ArgumentParser(prog="scripts/tune", description=__doc__.split("\n\n")[0])
    ap.add_argument("--study", required=True, type=Path, help="the study's folder (journal, trials, report)")
    ap.add_argument("--world", help="the development worlds' world file")
    ap.add_argument("--world-seeds", help="development world seeds A..B (fitslam's --world-seeds)")
    ap.add_argument("--seeds", type=int, default=1, help="noise seeds per world (default 1)")
    ap.add_argument("--time-limit-s", type=float, help="overrides the world file's time limit")
    ap.add_argument("--localisation", help="fitslam's --localisation (default: fitslam's)")
    ap.add_argument("--sim-params", help="a simulator parameter file")
    ap.add_argument("--trials", type=int, default=30, help="trials this process adds (default 30)")
    ap.add_argument("--search", action="append", default=[], metavar="KEY=LOW..HIGH",
                    help="also search this parameter (repeatable), e.g. u2.sigma_bearing_rad=0.005..0.05; "
                         "a paper weight's key (u1.alpha, u2.beta, u2.top_n) changes its range")
    ap.add_argument("--max-unreached", type=float, default=0.1, help="largest feasible share of runs never at 90 %% coverage")
    ap.add_argument("--sampler-seed", type=int, default=0,
                    help="the TPE sampler's seed, plus the study's trial count at start (default 0); give each of several processes started together its own")
    ap.add_argument("--address", help="run each trial's missions as Ray tasks on this cluster")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="threads per trial without --address")
    ap.add_argument("--fitslam", help="the fitslam binary (default: $FITSLAM, fitslam on PATH, target/release/fitslam)")
    ap.add_argument("--report", action="store_true", help="only write the report of the study as it stands")
    ap.add_argument("--confirm-seed-start", type=int,
                    help="re-run the Pareto points and the paper's trial on noise seeds from this one (module doc)")
    args = ap.parse_args()
    binary = sweep.find_fitslam(args.fitslam)
    args.space = dict(SPACE)
    defaults = tomllib.loads(sweep.fitslam(binary, "params")) if args.search else {}
    for text in args.search:
        try:
            name, spec = parse_search(text, defaults)
        except ValueError as e:
            sys.exit(f"scripts/tune: {e}")
        args.space[name] = spec

    if (not args.report or args.confirm_seed_start is not None) and not args.world:
        sys.exit("scripts/tune: --world is needed to run missions")
    if args.report and args.confirm_seed_start is None and not (args.study / "journal.log").exists():
        sys.exit(f"scripts/tune: {args.study}: no study (journal.log) to report")

    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    args.study.mkdir(parents=True, exist_ok=True)
    storage = JournalStorage(JournalFileBackend(str(args.study / "journal.log")))
    study = optuna.create_study(study_name="fitslam", storage=storage, directions=["minimize", "minimize"], load_if_exists=True)
    # Seeded by the trials already there, so that a study resumed in steps does not repeat its
    # first suggestions; processes started together need their own --sampler-seed.
    study.sampler = optuna.samplers.TPESampler(seed=args.sampler_seed + len(study.trials), multivariate=True, n_startup_trials=10)
    ray = sweep.connect(args.address) if args.address and (not args.report or args.confirm_seed_start is not None) else None
    try:
        if not args.report:
            if not study.trials:
                study.enqueue_trial(PAPER)
            study.optimize(lambda t: trial(t, args, binary, ray), n_trials=args.trials)
        report(study, args, binary, ray)
    finally:
        if ray:
            ray.shutdown()


def trial(t, args, binary, ray):
    values = {}
    for name, (_, kind, low, high) in args.space.items():
        values[name] = t.suggest_int(name, low, high) if kind is int else t.suggest_float(name, low, high)
    folder = args.study / "trials" / f"{t.number:04d}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "params.toml").write_text(params_toml(values, args.space))
    t90, primary, unreached = missions(args, binary, ray, folder / "params.toml", folder / "runs", 1, f"trial {t.number}")
    t.set_user_attr("unreached", unreached)
    t.set_user_attr("unreached_excess", unreached - args.max_unreached)
    t.set_constraint("unreached_excess", unreached - args.max_unreached)  # feasible when ≤ 0
    print(f"trial {t.number}: {values} -> T_90 {t90:.1f} s, tr(cov) {primary:.4g}, unreached {unreached:.0%}", file=sys.stderr, flush=True)
    return t90, primary


def missions(args, binary, ray, params, out, seed_start, label):
    """The objectives of `fit` with `params` on the study's worlds, seeds from `seed_start`: a
    fitslam plan in `out`, run on threads or Ray, collected (runs already there are kept)."""
    plan = [
        "plan", "--world", args.world, "--strategies", "fit", "--seeds", args.seeds, "--seed-start", seed_start,
        "--params", params, "--out", out,
    ]
    for flag, value in (("--world-seeds", args.world_seeds), ("--time-limit-s", args.time_limit_s),
                        ("--localisation", args.localisation), ("--sim-params", args.sim_params)):
        if value is not None:
            plan += [flag, value]
    if not (out / "plan.jsonl").exists():
        sweep.fitslam(binary, *plan)
    if ray:
        failures = sweep.run_on_ray(ray, binary, out, sweep.pending(binary, out), label=label)
        if failures:
            raise RuntimeError(f"{label}: {len(failures)} missions failed: {sorted(failures.items())[0]}")
    else:
        sweep.run_local(binary, out, args.jobs)
    sweep.fitslam(binary, "collect", out)
    return objectives(out / "summary.csv", args.max_unreached)


def report(study, args, binary, ray):
    folder = args.study
    import optuna

    points = []
    for t in study.get_trials(deepcopy=False, states=[optuna.trial.TrialState.COMPLETE]):
        p = {"trial": t.number, **t.params, "t90_s": t.values[0], "matched_cov_trace": t.values[1]}
        p["unreached"] = t.user_attrs["unreached"]
        p["feasible"] = t.user_attrs["unreached_excess"] <= 0 and all(map(math.isfinite, t.values))
        p["paper"] = all(math.isclose(t.params[k], v) for k, v in PAPER.items())
        points.append(p)
    if not points:
        sys.exit(f"scripts/tune: {folder}: no complete trial yet")
    front = sorted(pareto_front([p for p in points if p["feasible"]]), key=lambda p: p["t90_s"])
    on_front = {p["trial"] for p in front}
    paper = [p for p in points if p["paper"]]
    shown = front + [p for p in paper if p["trial"] not in on_front]
    k = args.confirm_seed_start
    if k is not None:
        for p in shown:
            trial_dir = folder / "trials" / f"{p['trial']:04d}"
            p["confirm"] = missions(args, binary, ray, trial_dir / "params.toml", trial_dir / f"confirm_{k}", k,
                                    f"confirm trial {p['trial']}")
        with open(folder / "confirm.csv", "w", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(["trial", "seed_start", "seeds", "t90_s", "matched_cov_trace", "unreached"])
            for p in shown:
                w.writerow([p["trial"], k, args.seeds, *map(fmt, p["confirm"])])
    # The study's parameters: the paper's weights, then any other any trial searched.
    names = [*SPACE, *sorted({n for p in points for n in p} - set(SPACE) - {"trial", "t90_s", "matched_cov_trace", "unreached",
                                                                          "feasible", "paper", "pareto", "confirm"})]
    columns = ["trial", *names, "t90_s", "matched_cov_trace", "unreached", "feasible", "pareto", "paper"]
    with open(folder / "pareto.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(columns)
        for p in sorted(points, key=lambda p: p["trial"]):
            p["pareto"] = p["trial"] in on_front
            w.writerow([fmt(p.get(c, "")) for c in columns])
    codes = sorted({json.loads((folder / "trials" / f"{p['trial']:04d}" / "runs" / "plan.json").read_text())["code"]
                    for p in points if (folder / "trials" / f"{p['trial']:04d}" / "runs" / "plan.json").exists()})
    lines = [
        f"# Pareto front: {len(front)} of {len(points)} complete trials ({sum(p['feasible'] for p in points)} feasible)",
        "",
        f"Missions run by {', '.join(codes) or 'an unknown fitslam'}; the objectives and the study's command: docs/experiments.md, Tuning.",
        "",
        "| trial | " + " | ".join(LABELS.get(n, n) for n in names) + " | T_90 (s) | tr(cov) at 25–90 % (m² + rad²) | runs never at 90 % |"
        + (f" re-measured on seeds from {k}: T_90 (s) | tr(cov) | dominates the paper's re-measured |" if k is not None else "")
        + " |",
        "|---|" + "---|" * len(names) + "---|---|---|" + ("---|---|---|" if k is not None else "") + "---|",
    ]
    paper_confirm = paper[0].get("confirm") if paper else None
    for p in shown:
        mark = "the paper's" if p["paper"] else ""
        if p["trial"] not in on_front:
            mark += ", not on the front"
        row = (f"| {p['trial']} | " + " | ".join(cell(p.get(n)) for n in names) + f" | {p['t90_s']:.1f} | "
               f"{p['matched_cov_trace']:.4g} | {p['unreached']:.0%} |")
        if k is not None:
            t90, cov, _ = p["confirm"]
            beats = "–" if p["paper"] or paper_confirm is None else (
                "yes" if t90 <= paper_confirm[0] and cov <= paper_confirm[1] and (t90, cov) != paper_confirm[:2] else "no")
            row += f" {t90:.1f} | {cov:.4g} | {beats} |"
        lines.append(row + f" {mark} |")
    (folder / "pareto.md").write_text("\n".join(lines) + "\n")
    figure(points, front, folder)
    out = folder / "pareto"
    out.mkdir(exist_ok=True)
    for old in out.glob("trial_*.toml"):
        old.unlink()
    for p in front:
        params = folder / "trials" / f"{p['trial']:04d}" / "params.toml"
        (out / f"trial_{p['trial']:04d}.toml").write_text(sweep.fitslam(binary, "params", "--params", params))
    print(f"{folder}: {len(points)} trials, {len(front)} on the Pareto front; pareto.md, pareto.csv, pareto.png, pareto/")


def cell(v):
    """A parameter in pareto.md: integers as they are, others with 3 decimals (4 significant
    digits below 0.1); – when the trial did not search it."""
    if v is None:
        return "–"
    if isinstance(v, int):
        return str(v)
    return f"{v:.3f}" if abs(v) >= 0.1 else f"{v:.4g}"


def fmt(v):
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def figure(points, front, folder):
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "fitslam"  # the SVG's ids the same from run to run
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=120)
    for feasible, style in ((True, dict(c="tab:blue", alpha=0.5, label="trial")), (False, dict(c="tab:gray", marker="x", label="infeasible trial"))):
        ps = [p for p in points if p["feasible"] == feasible and math.isfinite(p["t90_s"])]
        if ps:
            ax.scatter([p["t90_s"] for p in ps], [p["matched_cov_trace"] for p in ps], **style)
    ax.plot([p["t90_s"] for p in front], [p["matched_cov_trace"] for p in front], "o-", c="tab:orange", label="Pareto front (trial numbers)")
    confirmed = [p for p in points if "confirm" in p]
    for p in confirmed:
        ax.annotate("", xy=p["confirm"][:2], xytext=(p["t90_s"], p["matched_cov_trace"]),
                    arrowprops=dict(arrowstyle="->", color="tab:gray", lw=0.7))
    if confirmed:
        ax.scatter([p["confirm"][0] for p in confirmed], [p["confirm"][1] for p in confirmed], facecolors="none",
                   edgecolors="tab:green", s=50, zorder=4, label="re-measured on unseen noise seeds")
    for p in points:
        if p["paper"]:
            ax.scatter([p["t90_s"]], [p["matched_cov_trace"]], marker="*", s=220, c="tab:red", zorder=5,
                       label="paper: α = 0.35, β = 0.4, N = 7")
    for p in front:  # trial numbers: pareto.md has their values
        ax.annotate(str(p["trial"]), (p["t90_s"], p["matched_cov_trace"]), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xlabel("T_90: mean time to 90 % coverage (s)")
    ax.set_ylabel("tr(cov) at 25–90 % coverage, geometric mean (m² + rad²)")
    ax.set_title("fit on development worlds: T_90 against the primary metric")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(folder / f"pareto.{ext}", metadata={"Date": None} if ext == "svg" else None)
    plt.close(fig)


if __name__ == "__main__":
    main()
