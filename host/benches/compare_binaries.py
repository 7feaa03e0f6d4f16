#!/usr/bin/env python3
"""Two `supine` binaries' `fit --case rigid` wall times on the same datasets, interleaved
(BENCHMARKS.md, "Identification"): a before/after ratio that does not depend
on SciPy. Each dataset of the set (made by `fit_robustness.py`, which this reuses) is
fitted `--reps` times by each binary in turn; the median of each is compared.

Usage: compare_binaries.py BEFORE AFTER [--set report|selection] [--reps 5]
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fit_robustness  # noqa: E402


def wall_s(binary, directory, out):
    started = time.perf_counter()
    subprocess.run([binary, "fit", "--dataset", directory, "--case", "rigid", "--out", out],
                   capture_output=True, check=True)
    return time.perf_counter() - started


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--set", choices=sorted(fit_robustness.SETS), default="report")
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--root", default=os.path.join(fit_robustness.REPO, "target/fit-robustness"))
    args = ap.parse_args()
    ratios, before_s, after_s = [], [], []
    with tempfile.TemporaryDirectory() as scratch:
        out = os.path.join(scratch, "fit.toml")
        for d in fit_robustness.design(args.set):
            directory = os.path.join(args.root, f"seed{d['seed']}")
            fit_robustness.synth(args.after, d, directory)
            times = {args.before: [], args.after: []}
            for _ in range(args.reps):
                for binary in (args.before, args.after):
                    times[binary].append(wall_s(binary, directory, out))
            b, a = statistics.median(times[args.before]), statistics.median(times[args.after])
            before_s.append(b)
            after_s.append(a)
            ratios.append(b / a)
            print(f"seed {d['seed']}: {b:.3f} s -> {a:.3f} s, {b / a:.2f}x", flush=True)
    print(f"speed-up: median {statistics.median(ratios):.2f}x, min {min(ratios):.2f}x, "
          f"max {max(ratios):.2f}x; median command {statistics.median(before_s):.3f} s -> "
          f"{statistics.median(after_s):.3f} s")


if __name__ == "__main__":
    main()
