#!/usr/bin/env python3
"""`supine fit` against SciPy on many fresh synthetic datasets (BENCHMARKS.md, section
"Identification: robustness and speed over datasets").

Each dataset is made by `supine synth` with its own seed, spread of the subjects'
parameters (e^N(0, 0.15) or e^N(0, 0.3)), number of subjects (5-10) and noise
(0.005-0.05 m/s^2); every subject is fitted (none held out). On each dataset, back to
back on the same machine:

1. `supine fit --case rigid` (the whole command: reading, spectra, every start), timed
   from outside as the wall time of the process;
2. `scipy_fit.py --case rigid` (SciPy's two-start fit, the paper's two starts);
3. `supine fit --case litter --joints RIGID.toml` (the joints of step 1 fixed);
4. `scipy_fit.py --case litter --joints RIGID.toml` (the same fixed joints).

SciPy runs with ftol = xtol = gtol = `--tolerance` (1e-8, tighter than its defaults);
supine with its own defaults (1e-6, docs/model.md#solver-and-tolerances, and the polish at 1e-8) unless
`--supine-tolerance` is given. The speed-up is
SciPy's fit time alone (its reading, spectra and interpreter start-up left out) over
the whole supine command, so it favours SciPy; the same ratio of CPU times (every thread
of supine counted) is printed beside it, as it depends less on what else the machine runs.
The load average is recorded with each dataset.

Two disjoint sets: `selection` (seeds 1001-1012), on which settings may be chosen, and
`report` (seeds 2001-2024), on which they are reported.

Usage: fit_robustness.py --set selection|report [--only K ...] [--supine BIN]
       [--root DIR] [--tolerance 1e-8] [--supine-tolerance T] [--json OUT.json]
"""

import argparse
import json
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
SPREADS = [0.15, 0.3]
SUBJECTS = [5, 6, 7, 8, 9, 10]
NOISES_M_S2 = [0.005, 0.01, 0.02, 0.05]
SETS = {"selection": (1001, 12), "report": (2001, 24)}
# Costs this close (relative) are the same minimum up to the rounding of the sum of 3,792
# squares: counted as equal, not as above.
SAME_MINIMUM = 1e-12


def design(name):
    """The datasets of a set: (seed, spread, subjects, noise). Over 24 datasets every pair of
    (subjects, noise) from the 12 combinations below meets both spreads."""
    first, count = SETS[name]
    out = []
    for k in range(count):
        out.append(dict(seed=first + k, spread=SPREADS[k % 2],
                        subjects=SUBJECTS[(k // 2) % len(SUBJECTS)],
                        noise_m_s2=NOISES_M_S2[(k // 2) % len(NOISES_M_S2)]))
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
         "--param-log-sd", str(d["spread"])])
    with open(stamp, "w") as fh:
        json.dump(d, fh)


def final_cost(path):
    with open(path, "rb") as fh:
        return tomllib.load(fh)["fit"]["final_cost"]


def tolerance_args(tolerance):
    return [a for k in "fxg" for a in (f"--{k}tol", str(tolerance))] if tolerance else []


def measure(supine, d, directory, tolerance, supine_tolerance):
    tol_args = tolerance_args(supine_tolerance)
    scipy = [sys.executable, os.path.join(HERE, "scipy_fit.py"), "--dataset", directory,
             "--json"] + tolerance_args(tolerance)
    rigid = os.path.join(directory, "rigid.toml")
    litter = os.path.join(directory, "litter.toml")
    row = dict(d, load=os.getloadavg()[0])
    done, row["rust_rigid_s"] = run([supine, "fit", "--dataset", directory, "--case", "rigid",
                                     "--out", rigid] + tol_args)
    row["rust_rigid_cpu_s"] = run.cpu_s
    row["rust_rigid_cost"] = final_cost(rigid)
    split = re.search(r"reading and spectra ([0-9.]+) s, solver ([0-9.]+) s", done.stderr)
    row["rust_spectra_s"], row["rust_solver_s"] = float(split[1]), float(split[2])
    out, row["scipy_rigid_total_s"] = run(scipy + ["--case", "rigid"])
    sp = json.loads(out.stdout)
    row["scipy_rigid_s"], row["scipy_rigid_cost"] = sp["fit_s"], sp["best_cost"]
    row["scipy_rigid_cpu_s"] = sp["fit_cpu_s"]
    _, row["rust_litter_s"] = run([supine, "fit", "--dataset", directory, "--case", "litter",
                                   "--joints", rigid, "--out", litter] + tol_args)
    row["rust_litter_cost"] = final_cost(litter)
    out, _ = run(scipy + ["--case", "litter", "--joints", rigid])
    sp = json.loads(out.stdout)
    row["scipy_litter_s"], row["scipy_litter_cost"] = sp["fit_s"], sp["best_cost"]
    row["speedup"] = row["scipy_rigid_s"] / row["rust_rigid_s"]
    row["cpu_speedup"] = row["scipy_rigid_cpu_s"] / row["rust_rigid_cpu_s"]
    return row


def compare(ours, scipy):
    """`below`, `equal` (within SAME_MINIMUM) or `above`."""
    if ours <= scipy:
        return "below"
    return "equal" if ours <= scipy * (1 + SAME_MINIMUM) else "above"


def summary(rows):
    print("| seed | spread | subjects | noise m/s^2 | load | rigid: supine cost | SciPy cost "
          "| supine s (reading + spectra, solver) | SciPy fit s | speed-up | CPU speed-up "
          "| litter: supine cost | SciPy cost | supine s | SciPy fit s |")
    print("|" + "---|" * 15)
    for r in rows:
        marks = {"below": "", "equal": " (equal)", "above": " (ABOVE)"}
        rigid_mark = marks[compare(r["rust_rigid_cost"], r["scipy_rigid_cost"])]
        litter_mark = marks[compare(r["rust_litter_cost"], r["scipy_litter_cost"])]
        print(f"| {r['seed']} | {r['spread']} | {r['subjects']} | {r['noise_m_s2']} "
              f"| {r['load']:.2f} | {r['rust_rigid_cost']:.6f}{rigid_mark} "
              f"| {r['scipy_rigid_cost']:.6f} | {r['rust_rigid_s']:.3f} "
              f"({r['rust_spectra_s']:.3f}, {r['rust_solver_s']:.3f}) "
              f"| {r['scipy_rigid_s']:.2f} | {r['speedup']:.0f}x | {r['cpu_speedup']:.0f}x "
              f"| {r['rust_litter_cost']:.6f}{litter_mark} | {r['scipy_litter_cost']:.6f} "
              f"| {r['rust_litter_s']:.3f} | {r['scipy_litter_s']:.2f} |")

    def spread(name, values, fmt):
        lo, mid, hi = min(values), statistics.median(values), max(values)
        print(f"{name}: min {fmt(lo)}, median {fmt(mid)}, max {fmt(hi)}")

    print()
    spread("speed-up (SciPy fit s / supine rigid command s, wall)",
           [r["speedup"] for r in rows], lambda v: f"{v:.1f}x")
    spread("speed-up in CPU time (SciPy fit / supine command, all its threads)",
           [r["cpu_speedup"] for r in rows], lambda v: f"{v:.1f}x")
    spread("load average (1 min) at each dataset", [r["load"] for r in rows],
           lambda v: f"{v:.2f}")
    spread("supine rigid command CPU s (all threads)", [r["rust_rigid_cpu_s"] for r in rows],
           lambda v: f"{v:.3f}")
    spread("SciPy fit CPU s", [r["scipy_rigid_cpu_s"] for r in rows], lambda v: f"{v:.2f}")
    spread("supine reading + spectra s", [r["rust_spectra_s"] for r in rows],
           lambda v: f"{v:.3f}")
    spread("supine solver s", [r["rust_solver_s"] for r in rows], lambda v: f"{v:.3f}")
    spread("SciPy fit s", [r["scipy_rigid_s"] for r in rows], lambda v: f"{v:.2f}")
    for case in ("rigid", "litter"):
        rel = [r[f"rust_{case}_cost"] / r[f"scipy_{case}_cost"] - 1 for r in rows]
        verdicts = [compare(r[f"rust_{case}_cost"], r[f"scipy_{case}_cost"]) for r in rows]
        counts = ", ".join(f"{verdicts.count(v)} {v}" for v in ("below", "equal", "above"))
        spread(f"{case}: supine cost / SciPy cost - 1 ({counts})", rel,
               lambda v: f"{100 * v:+.2e} %")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", choices=sorted(SETS), required=True)
    ap.add_argument("--only", type=int, nargs="*", help="dataset indices within the set")
    ap.add_argument("--supine", default=os.path.join(REPO, "target/release/supine"))
    ap.add_argument("--root", default=os.path.join(REPO, "target/fit-robustness"))
    ap.add_argument("--tolerance", type=float, default=1e-8, help="SciPy's ftol, xtol, gtol")
    ap.add_argument("--supine-tolerance", type=float, help="supine's (default: its own)")
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args()
    datasets = design(args.set)
    if args.only:
        datasets = [datasets[k] for k in args.only]
    rows = []
    for d in datasets:
        directory = os.path.join(args.root, f"seed{d['seed']}")
        synth(args.supine, d, directory)
        rows.append(measure(args.supine, d, directory, args.tolerance, args.supine_tolerance))
        r = rows[-1]
        print(f"seed {d['seed']}: rigid {r['rust_rigid_cost']:.6f} vs {r['scipy_rigid_cost']:.6f}"
              f" ({r['rust_rigid_s']:.3f} s vs {r['scipy_rigid_s']:.2f} s), litter "
              f"{r['rust_litter_cost']:.6f} vs {r['scipy_litter_cost']:.6f}", file=sys.stderr)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    summary(rows)


if __name__ == "__main__":
    main()
