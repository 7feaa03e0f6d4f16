#!/usr/bin/env python3
"""`supine fit` against SciPy on many fresh synthetic datasets (BENCHMARKS.md, section
"Identification: robustness and speed over datasets").

Each dataset is made by `supine synth` with its own seed, spread of the subjects'
parameters (e^N(0, 0.15), e^N(0, 0.3) or e^N(0, 0.5)), correlation of a subject's
parameters (0, independent, or 0.8), number of subjects (5-10) and noise (0.005-0.05
m/s^2); every subject is fitted (none held out). On each dataset, back to back on the
same machine:

1. `supine fit --case rigid` (the whole command: reading, spectra, every start), timed
   from outside as the wall time of the process;
2. `scipy_fit.py --case pipeline`: SciPy's own two stages (its two-start rigid fit, the
   paper's two starts; then its litter-board fit bounded by its own rigid minimum);
3. `supine fit --case litter --joints RIGID.toml`: supine's second stage, which also
   explores the other rigid minima of step 1 (pipeline against pipeline: against step 2's
   litter-board cost, and the kept pair's rigid cost against step 2's rigid cost);
4. `supine fit --case litter --no-explore --joints RIGID.toml` and
   `scipy_fit.py --case litter --joints RIGID.toml`: both litter-board fits on the same
   fixed joints, step 1's (stage by stage).

SciPy runs with ftol = xtol = gtol = `--tolerance` (1e-8, tighter than its defaults);
supine with its own defaults (1e-6, docs/model.md#solver-and-tolerances, and the polish at 1e-8) unless
`--supine-tolerance` is given. The speed-up is
SciPy's rigid fit time alone (its reading, spectra and interpreter start-up left out) over
the whole supine rigid command, so it favours SciPy; the same ratio of CPU times (every
thread of supine counted) is printed beside it, as it depends less on what else the
machine runs. The load average is recorded with each dataset.

Sets, disjoint: `selection` (seeds 1001-1012) and `selection-wide` (1101-1112), on which
settings may be chosen; `report` (2001-2024) and `report-wide` (2101-2124), on which they
are reported. The `-wide` sets cycle through (spread 0.5, independent), (0.5, correlated
0.8) and (0.3, correlated 0.8). Issue 30's choice of the pipeline's rigid minimum was made
on `selection-pipeline` (3001-3012, as wide), after `report-wide` had been seen; its
figures come from `report-pipeline` (4001-4024, as wide), run once after it.
`selection-starts` (5001-5012, as wide) weighs more rigid starts against the pipeline's
losses (`--starts`, passed to supine's rigid fits). The litter-board fit's continued rigid
search (`--explore-starts`) was chosen on `selection-starts`, `selection-pipeline` and
`selection-explore` (6001-6024, as wide; first run as a report set, then used to choose),
and reported on `report-explore` (7001-7024, as wide). Its rule, the lowest litter-board
cost over every rigid minimum found (not only those within the rigid fit's 95 %
confidence region, `--within-region`), was chosen on the 44 of those selection datasets
whose fits list every option (docs/model.md#the-pipeline-over-the-rigid-fits-minima);
`report-confirm` (8001-8024) was then run with the region's rule, `report-minima`
(9001-9024) with a screen of the rigid fit's starts since withdrawn, and `report-final`
(10001-10024, as wide) once with the code of that time. The rigid fit's probes at the
bounds and its four starts were chosen on the same selection datasets
(docs/model.md#probes-at-the-bounds); `report-probes` and `report-probes-2` (11001-12024,
as wide) were then run with five starts and the probes (12022 ended above SciPy, and the
speed-up fell to 47x, which is why four starts), and `report-probes-final` and
`report-probes-final-2` (13001-14024, as wide) once with the code as it is:
BENCHMARKS.md's figures.

SciPy's results depend only on the dataset and its tolerance, so each is kept in the
dataset's folder (`scipy-*.json`, by its arguments and, for a stage fit, the joints file's
bytes) and read back on later passes; `--scipy-only` runs just SciPy's pipelines, so that
they can run while supine is being worked on. The speed-up is only meaningful with both
fits timed back to back: `--speed-only` always runs SciPy anew.

Pipeline against pipeline is also scored on both cases' data together: m_r ln C_r + m_l
ln C_l of supine's kept pair less SciPy's pair's (-2 ln of their likelihood ratio, each
case's noise variance unknown; below 0: supine's pair is the likelier).

`--speed-only` times only the two rigid fits, back to back, for the speed-up on a quiet
machine after a full pass has recorded the costs; each dataset's files are read once
before each fit is timed, so that neither waits on the disk.

Usage: fit_robustness.py --set NAME [--set NAME ...] [--only K ...] [--supine BIN]
       [--root DIR] [--tolerance 1e-8] [--supine-tolerance T] [--json OUT.json]
       [--speed-only] [--scipy-only] [--starts N]
"""

import argparse
import hashlib
import json
import math
import os
import re
import resource
import statistics
import subprocess
import sys
import time
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SUBJECTS = [5, 6, 7, 8, 9, 10]
NOISES_M_S2 = [0.005, 0.01, 0.02, 0.05]
# (spread, correlation) cycles of the sets.
NARROW = [(0.15, 0.0), (0.3, 0.0)]
WIDE = [(0.5, 0.0), (0.5, 0.8), (0.3, 0.8)]
SETS = {"selection": (1001, 12, NARROW), "report": (2001, 24, NARROW),
        "selection-wide": (1101, 12, WIDE), "report-wide": (2101, 24, WIDE),
        "selection-pipeline": (3001, 12, WIDE), "report-pipeline": (4001, 24, WIDE),
        "selection-starts": (5001, 12, WIDE), "selection-explore": (6001, 24, WIDE),
        "report-explore": (7001, 24, WIDE), "report-confirm": (8001, 24, WIDE),
        "report-minima": (9001, 24, WIDE), "report-final": (10001, 24, WIDE),
        "report-probes": (11001, 24, WIDE), "report-probes-2": (12001, 24, WIDE),
        "report-probes-final": (13001, 24, WIDE), "report-probes-final-2": (14001, 24, WIDE)}
# Costs this close (relative) are the same minimum up to the rounding of the sum of 3,792
# squares: counted as equal, not as above.
SAME_MINIMUM = 1e-12


def design(name):
    """The datasets of a set: (seed, spread, correlation, subjects, noise). Over 24 datasets
    of `report` every pair of (subjects, noise) from the 12 combinations below meets both
    spreads."""
    first, count, cycle = SETS[name]
    out = []
    for k in range(count):
        spread, correlation = cycle[k % len(cycle)]
        step = k // len(cycle)
        out.append(dict(seed=first + k, spread=spread, correlation=correlation,
                        subjects=SUBJECTS[step % len(SUBJECTS)],
                        noise_m_s2=NOISES_M_S2[step % len(NOISES_M_S2)]))
    return out


def children_cpu_s():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(cmd):
    """Runs `cmd`; its result, wall time and CPU time (user + system, every thread)."""
    started, cpu = time.perf_counter(), children_cpu_s()
    done = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    run.cpu_s = children_cpu_s() - cpu
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr}")
    return done, seconds


def synth(supine, d, directory):
    stamp = os.path.join(directory, "design.json")
    if os.path.exists(stamp) and os.path.exists(os.path.join(directory, "dataset.toml")):
        with open(stamp) as fh:
            if json.load(fh) == d:
                return
    run([supine, "synth", "--out", directory, "--seed", str(d["seed"]),
         "--subjects", str(d["subjects"]), "--noise-m-s2", str(d["noise_m_s2"]),
         "--param-log-sd", str(d["spread"]), "--param-correlation", str(d["correlation"])])
    with open(stamp, "w") as fh:
        json.dump(d, fh)


def fit_table(path):
    with open(path, "rb") as fh:
        return tomllib.load(fh)["fit"]


def final_cost(path):
    return fit_table(path)["final_cost"]


def tolerance_args(tolerance):
    return [a for k in "fxg" for a in (f"--{k}tol", str(tolerance))] if tolerance else []


# `--starts` of supine's rigid fits (None: its own default).
RIGID_STARTS = None


def rigid_args():
    return ["--starts", str(RIGID_STARTS)] if RIGID_STARTS else []


def scipy_cmd(directory, tolerance):
    return [sys.executable, os.path.join(HERE, "scipy_fit.py"), "--dataset", directory,
            "--json"] + tolerance_args(tolerance)


def scipy_once(directory, tolerance, args, key):
    """SciPy's JSON for `args`, run once per dataset and key: its costs depend only on the
    dataset, its tolerance and `key` (the joints file's bytes, for a stage fit), so they
    are kept in the dataset's folder (`scipy-*.json`) and read back on the next pass."""
    digest = hashlib.sha256(json.dumps([args, tolerance]).encode() + key).hexdigest()[:16]
    path = os.path.join(directory, f"scipy-{digest}.json")
    if os.path.exists(path):
        with open(path) as fh:
            return json.load(fh), True
    out, _ = run(scipy_cmd(directory, tolerance) + args)
    result = json.loads(out.stdout)
    with open(path + ".part", "w") as fh:
        json.dump(result, fh)
    os.replace(path + ".part", path)
    return result, False


def scipy_pipeline(directory, tolerance):
    return scipy_once(directory, tolerance, ["--case", "pipeline"], b"")


def measure(supine, d, directory, tolerance, supine_tolerance):
    tol_args = tolerance_args(supine_tolerance)
    rigid = os.path.join(directory, "rigid.toml")
    litter = os.path.join(directory, "litter.toml")
    stage = os.path.join(directory, "litter_stage.toml")
    row = dict(d, load=os.getloadavg()[0])
    warm_page_cache(directory)
    done, row["rust_rigid_s"] = run([supine, "fit", "--dataset", directory, "--case", "rigid",
                                     "--out", rigid] + tol_args + rigid_args())
    row["rust_rigid_cpu_s"] = run.cpu_s
    row["rust_rigid_cost"] = final_cost(rigid)
    stored = fit_table(rigid)["rigid_minima"]
    row["rust_rigid_minima"] = len(stored["minimum"])
    row["rust_rigid_residuals"] = stored["residuals"]
    row["rust_rigid_budget"] = stored["cost_budget"]
    split = re.search(r"reading and spectra ([0-9.]+) s, solver ([0-9.]+) s", done.stderr)
    row["rust_spectra_s"], row["rust_solver_s"] = float(split[1]), float(split[2])
    sp, row["scipy_from_earlier_pass"] = scipy_pipeline(directory, tolerance)
    row["scipy_rigid_s"], row["scipy_rigid_cost"] = sp["fit_s"], sp["best_cost"]
    row["scipy_rigid_cpu_s"] = sp["fit_cpu_s"]
    row["scipy_litter_s"] = sp["litter"]["fit_s"]
    row["scipy_litter_cost"] = sp["litter"]["best_cost"]
    # Pipeline against pipeline: supine's litter-board fit over its rigid minima.
    _, row["rust_litter_s"] = run([supine, "fit", "--dataset", directory, "--case", "litter",
                                   "--joints", rigid, "--out", litter] + tol_args)
    table = fit_table(litter)
    row["rust_litter_cost"] = table["final_cost"]
    explored = table["rigid_minima_explored"]
    row["rust_pair_rigid_cost"] = explored["rigid_cost"]
    row["rust_explored"] = explored["option"]
    row["residuals"] = 24 * table["frequencies"]
    # Stage by stage: both litter-board fits on supine's rigid joints.
    run([supine, "fit", "--dataset", directory, "--case", "litter", "--no-explore",
         "--joints", rigid, "--out", stage] + tol_args)
    row["rust_stage_litter_cost"] = final_cost(stage)
    with open(rigid, "rb") as fh:
        joints = fh.read()
    stage_scipy, _ = scipy_once(directory, tolerance, ["--case", "litter", "--joints", rigid],
                                joints)
    row["scipy_stage_litter_cost"] = stage_scipy["best_cost"]
    row["speedup"] = row["scipy_rigid_s"] / row["rust_rigid_s"]
    row["cpu_speedup"] = row["scipy_rigid_cpu_s"] / row["rust_rigid_cpu_s"]
    return row


def warm_page_cache(directory):
    """Reads every file of the dataset once, so that neither fit timed after it waits on the
    disk for recordings the other has already brought into memory (the first fit timed
    would otherwise pay for both)."""
    for name in sorted(os.listdir(directory)):
        path = os.path.join(directory, name)
        if os.path.isfile(path):
            with open(path, "rb") as fh:
                while fh.read(1 << 20):
                    pass


def measure_speed(supine, d, directory, tolerance, supine_tolerance):
    """Only the rigid fits, back to back (`--speed-only`): for a quiet machine."""
    warm_page_cache(directory)
    rigid = os.path.join(directory, "rigid-speed.toml")
    row = dict(d, load=os.getloadavg()[0])
    _, row["rust_rigid_s"] = run([supine, "fit", "--dataset", directory, "--case", "rigid",
                                  "--out", rigid] + tolerance_args(supine_tolerance)
                                 + rigid_args())
    row["rust_rigid_cpu_s"] = run.cpu_s
    row["rust_rigid_cost"] = final_cost(rigid)
    out, _ = run(scipy_cmd(directory, tolerance) + ["--case", "rigid"])
    sp = json.loads(out.stdout)
    row["scipy_rigid_s"], row["scipy_rigid_cpu_s"] = sp["fit_s"], sp["fit_cpu_s"]
    row["scipy_rigid_cost"] = sp["best_cost"]
    row["speedup"] = row["scipy_rigid_s"] / row["rust_rigid_s"]
    row["cpu_speedup"] = row["scipy_rigid_cpu_s"] / row["rust_rigid_cpu_s"]
    return row


def speed_summary(rows):
    for r in rows:
        print(f"seed {r['seed']}: load {r['load']:.2f}, supine {r['rust_rigid_s']:.3f} s, "
              f"SciPy {r['scipy_rigid_s']:.2f} s, {r['speedup']:.1f}x ({r['cpu_speedup']:.1f}x CPU), "
              f"rigid cost {r['rust_rigid_cost']:.6f} vs {r['scipy_rigid_cost']:.6f}")
    above = [r["seed"] for r in rows
             if r["rust_rigid_cost"] > r["scipy_rigid_cost"] * (1 + SAME_MINIMUM)]
    print(f"rigid cost above SciPy's on {len(above)} of {len(rows)}: {above}")
    for name in ("speedup", "cpu_speedup", "load", "rust_rigid_s", "scipy_rigid_s"):
        values = [r[name] for r in rows]
        print(f"{name}: min {min(values):.3f}, median {statistics.median(values):.3f}, "
              f"max {max(values):.3f}")


def compare(ours, scipy):
    """`below`, `equal` (within SAME_MINIMUM) or `above`."""
    if ours <= scipy:
        return "below"
    return "equal" if ours <= scipy * (1 + SAME_MINIMUM) else "above"


def summary(rows):
    print("| seed | spread | corr. | subjects | noise m/s^2 | load | rigid: supine | SciPy "
          "| speed-up (CPU) | pipeline litter: supine | SciPy | pair's rigid "
          "| stage litter: supine | SciPy |")
    print("|" + "---|" * 14)
    marks = {"below": "", "equal": " (equal)", "above": " (ABOVE)"}
    for r in rows:
        def mark(ours, theirs):
            return marks[compare(r[ours], r[theirs])]
        print(f"| {r['seed']} | {r['spread']} | {r['correlation']} | {r['subjects']} "
              f"| {r['noise_m_s2']} | {r['load']:.2f} "
              f"| {r['rust_rigid_cost']:.6f}{mark('rust_rigid_cost', 'scipy_rigid_cost')} "
              f"| {r['scipy_rigid_cost']:.6f} | {r['speedup']:.0f}x ({r['cpu_speedup']:.0f}x) "
              f"| {r['rust_litter_cost']:.6f}{mark('rust_litter_cost', 'scipy_litter_cost')} "
              f"| {r['scipy_litter_cost']:.6f} "
              f"| {r['rust_pair_rigid_cost']:.6f}"
              f"{mark('rust_pair_rigid_cost', 'scipy_rigid_cost')} "
              f"| {r['rust_stage_litter_cost']:.6f}"
              f"{mark('rust_stage_litter_cost', 'scipy_stage_litter_cost')} "
              f"| {r['scipy_stage_litter_cost']:.6f} |")

    def spread(name, values, fmt):
        lo, mid, hi = min(values), statistics.median(values), max(values)
        print(f"{name}: min {fmt(lo)}, median {fmt(mid)}, max {fmt(hi)}")

    print()
    spread("speed-up (SciPy rigid fit s / supine rigid command s, wall)",
           [r["speedup"] for r in rows], lambda v: f"{v:.1f}x")
    spread("speed-up in CPU time (SciPy rigid fit / supine command, all its threads)",
           [r["cpu_speedup"] for r in rows], lambda v: f"{v:.1f}x")
    spread("load average (1 min) at each dataset", [r["load"] for r in rows],
           lambda v: f"{v:.2f}")
    spread("supine rigid command s", [r["rust_rigid_s"] for r in rows], lambda v: f"{v:.3f}")
    spread("supine litter-board command s (exploring)", [r["rust_litter_s"] for r in rows],
           lambda v: f"{v:.3f}")
    spread("SciPy rigid fit s", [r["scipy_rigid_s"] for r in rows], lambda v: f"{v:.2f}")
    spread("rigid minima kept for the litter-board fit", [r["rust_rigid_minima"] for r in rows],
           lambda v: f"{v}")
    both = [r["residuals"] * (math.log(r["rust_pair_rigid_cost"] / r["scipy_rigid_cost"])
                              + math.log(r["rust_litter_cost"] / r["scipy_litter_cost"]))
            for r in rows]
    spread(f"pipeline on both cases' data: m ln C_r + m ln C_l, supine's pair less SciPy's "
           f"({sum(v > 0 for v in both)} above 0)", both, lambda v: f"{v:+.1f}")
    spread("pipeline: the kept pair's rigid rise / the rigid fit's 95 % confidence region",
           [(r["rust_pair_rigid_cost"] - r["rust_rigid_cost"]) / r["rust_rigid_budget"]
            for r in rows], lambda v: f"{v:.2f}")
    for name, ours, theirs in (
            ("rigid", "rust_rigid_cost", "scipy_rigid_cost"),
            ("pipeline litter-board", "rust_litter_cost", "scipy_litter_cost"),
            ("pipeline: the kept pair's rigid", "rust_pair_rigid_cost", "scipy_rigid_cost"),
            ("stage litter-board (same joints)", "rust_stage_litter_cost",
             "scipy_stage_litter_cost")):
        rel = [r[ours] / r[theirs] - 1 for r in rows]
        verdicts = [compare(r[ours], r[theirs]) for r in rows]
        counts = ", ".join(f"{verdicts.count(v)} {v}" for v in ("below", "equal", "above"))
        spread(f"{name}: supine cost / SciPy cost - 1 ({counts})", rel,
               lambda v: f"{100 * v:+.2e} %")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", choices=sorted(SETS), action="append", default=[])
    ap.add_argument("--only", type=int, nargs="*", help="dataset indices within the set")
    ap.add_argument("--supine", default=os.path.join(REPO, "target/release/supine"))
    ap.add_argument("--root", default=os.path.join(REPO, "target/fit-robustness"))
    ap.add_argument("--tolerance", type=float, default=1e-8, help="SciPy's ftol, xtol, gtol")
    ap.add_argument("--supine-tolerance", type=float, help="supine's (default: its own)")
    ap.add_argument("--starts", type=int, help="supine's rigid starts (default: its own)")
    ap.add_argument("--json", help="also write the rows here")
    ap.add_argument("--summary", help="only print the table and summary of this --json file")
    ap.add_argument("--scipy-only", action="store_true",
                    help="only run SciPy's pipelines (kept for the next pass), no supine fit")
    ap.add_argument("--speed-only", action="store_true",
                    help="only time the rigid fits (supine's command, SciPy's fit) back to back")
    args = ap.parse_args()
    global RIGID_STARTS
    RIGID_STARTS = args.starts
    if args.summary:
        with open(args.summary) as fh:
            summary(json.load(fh))
        return
    datasets = [d for name in args.set for d in design(name)]
    if args.only:
        datasets = [datasets[k] for k in args.only]
    rows = []
    for d in datasets:
        directory = os.path.join(args.root, f"seed{d['seed']}")
        synth(args.supine, d, directory)
        if args.scipy_only:
            _, earlier = scipy_pipeline(directory, args.tolerance)
            print(f"seed {d['seed']}: SciPy's pipeline {'kept' if earlier else 'run'}",
                  file=sys.stderr)
            continue
        if args.speed_only:
            rows.append(measure_speed(args.supine, d, directory, args.tolerance,
                                      args.supine_tolerance))
            print(f"seed {d['seed']}: {rows[-1]['speedup']:.1f}x", file=sys.stderr)
            if args.json:
                with open(args.json, "w") as fh:
                    json.dump(rows, fh, indent=1)
            continue
        rows.append(measure(args.supine, d, directory, args.tolerance, args.supine_tolerance))
        r = rows[-1]
        print(f"seed {d['seed']}: rigid {r['rust_rigid_cost']:.6f} vs {r['scipy_rigid_cost']:.6f}"
              f" ({r['rust_rigid_s']:.3f} s vs {r['scipy_rigid_s']:.2f} s), litter "
              f"{r['rust_litter_cost']:.6f} vs {r['scipy_litter_cost']:.6f} (pipelines), "
              f"{r['rust_stage_litter_cost']:.6f} vs {r['scipy_stage_litter_cost']:.6f} "
              f"(same joints)", file=sys.stderr)
        if args.json:
            # After every dataset, so that an interrupted run keeps what it measured.
            with open(args.json, "w") as fh:
                json.dump(rows, fh, indent=1)
    if args.scipy_only:
        return
    if args.speed_only:
        speed_summary(rows)
        return
    summary(rows)


if __name__ == "__main__":
    main()
