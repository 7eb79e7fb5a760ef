#!/usr/bin/env python3
"""Random tours on every world with places: issue 36's navigation targets, measured.

Runs `orsa run --world W --tour N --seed S` for each world and seed (two at a time), reads each
run's report and prints, per world and over all: goals reached, SPL, localization RMS (the
largest run's and the mean), bumps, and how much faster than real time the runs went.

    cargo build --release
    python3 experiments/tours.py                      # 6 worlds x seeds 1-10 x 20 places
    python3 experiments/tours.py --worlds office loop --seeds 1-3 --places 5

Each run's report, plot and log are kept in --out (default out/tours/WORLD-SEED.*); a run that
missed a goal names it and why at the end. Exits 1 if any run failed to start or finish.
A goal counts as reached as the report counts it: the planner said `succeeded` and the robot truly
stopped within 0.25 m of it (a planner fooled by a wrong estimate does not count).
`--summarize` sums up the reports already in --out without running anything.
"""

import argparse
import concurrent.futures
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WORLDS = ["office", "suite", "loop", "lshape", "narrow", "hall"]


def seeds(text):
    """`1-10`, `1,3,5` or both: `1-3,7`."""
    out = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-", 1)
            out.extend(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def run(orsa, world, seed, places, out, config=None):
    stem = os.path.join(out, f"{world}-{seed}")
    cmd = [orsa, "run", "--world", os.path.join(ROOT, "worlds", f"{world}.toml"), "--tour", str(places),
           "--seed", str(seed), "--quiet", "--report", stem + ".json", "--plot", stem + ".svg"]
    if config:
        cmd += ["--config", config]
    with open(stem + ".log", "w") as log:
        p = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT)
    # 0: every place reached; 4: one was not (the report says which). Anything else failed.
    if p.returncode not in (0, 4):
        return world, seed, None, f"exit {p.returncode}, see {stem}.log"
    with open(stem + ".json") as f:
        return world, seed, json.load(f), None


SUCCESS_RADIUS_M = 0.25  # orsa/src/mission/navigation.rs


def reached(goal):
    """Whether a goal of a report was truly reached (the report's `success_rate` counts so)."""
    off = goal.get("final_error_m")
    return goal["status"] == "succeeded" and (off is None or off <= SUCCESS_RADIUS_M)


def summary(name, reports):
    goals = [g for r in reports for g in r["navigation"]["goals"]]
    reached_n = sum(reached(g) for g in goals)
    spl = statistics.mean(r["navigation"]["spl"] for r in reports)
    rms = [r["navigation"]["localization"]["rms_m"] for r in reports]
    bumps = sum(r["bumps"] for r in reports)
    speed = [r["sim_seconds"] / r["wall_seconds"] for r in reports if r["wall_seconds"] > 0]
    return (f"| {name} | {len(reports)} | {reached_n} / {len(goals)} ({100.0 * reached_n / max(len(goals), 1):.1f} %) "
            f"| {spl:.3f} | {statistics.mean(rms):.3f} m (largest run {max(rms):.3f} m) | {bumps} "
            f"| {min(speed):.0f}-{max(speed):.0f}x |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", nargs="+", default=WORLDS)
    ap.add_argument("--seeds", type=seeds, default=seeds("1-10"))
    ap.add_argument("--places", type=int, default=20)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "tours"))
    ap.add_argument("--orsa", default=os.path.join(ROOT, "target", "release", "orsa"))
    ap.add_argument("--config", help="a configuration file for every run (default: the tour's own)")
    ap.add_argument("--summarize", action="store_true", help="only sum up the reports already in --out")
    a = ap.parse_args()
    if a.summarize:
        global run
        def run(_orsa, world, seed, _places, out, _config=None):  # noqa: E306 (read what a run left)
            path = os.path.join(out, f"{world}-{seed}.json")
            if not os.path.exists(path):
                return world, seed, None, f"no report {path}"
            with open(path) as f:
                return world, seed, json.load(f), None
    elif not os.path.exists(a.orsa):
        sys.exit(f"{a.orsa} not found: run `cargo build --release` first")
    os.makedirs(a.out, exist_ok=True)
    jobs = [(w, s) for w in a.worlds for s in a.seeds]
    results = {}
    failed = []
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        for world, seed, report, error in pool.map(lambda j: run(a.orsa, j[0], j[1], a.places, a.out, a.config), jobs):
            if error:
                failed.append(f"{world} seed {seed}: {error}")
            else:
                results[(world, seed)] = report
    print(f"random tours of {a.places} places, seeds {', '.join(map(str, a.seeds))}\n")
    print("| world | runs | goals reached | SPL (mean) | localization RMS (mean) | bumps | real time |")
    print("|---|---|---|---|---|---|---|")
    for w in a.worlds:
        reports = [results[(w, s)] for s in a.seeds if (w, s) in results]
        if reports:
            print(summary(w, reports))
    if results:
        print(summary("all", list(results.values())))
    missed = [(w, s, g) for (w, s), r in sorted(results.items()) for g in r["navigation"]["goals"]
              if not reached(g)]
    if missed:
        print("\nnot reached:")
        for w, s, g in missed:
            why = g["reason"]
            if g["status"] == "succeeded":
                why += f" (but truly {g['final_error_m']:.2f} m off: the estimate was wrong)"
            print(f"- {w} seed {s}: {g['target']} {g['status']} after {g['time_s']:.1f} s: {why}")
    for f in failed:
        print(f"FAILED {f}")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
