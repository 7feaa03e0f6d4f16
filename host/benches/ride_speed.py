#!/usr/bin/env python3
"""Speed and memory of reading a one-hour ride (issue 26), against an independent numpy
computation of the same quantities.

Two rides of one hour: the 500 Hz file `supine ride` writes (66 MB), and a phone's
200 Hz Sensor Logger export of the same kind of road (nanosecond epoch clock jittered by
up to +-1 ms, gravity on the phone's tilted y axis). For each it times, as separate
processes, median of --runs:

- `supine exposure --channel platform_z --weighting wk` (one axis, no model), against
  the numpy reference of one axis: `numpy.loadtxt` of the time and that column, linear
  interpolation onto a uniform grid (the phone's jittered clock), Wk applied in the
  frequency domain from the analog transfer function (docs/exposure.md's table), the
  1 s running rms (exponential, `scipy.signal.lfilter`), MTVV, VDV and rms;
- `supine report` (three axes through the model, the joints, the spectra, the charts,
  report.html), against the numpy reference of three axes (the same steps per axis; no
  model, no charts: a lower bound of what a script would spend).

Peak memory is each process's maximum resident set (`/usr/bin/time`). The numpy reference's
values are printed beside supine's as a check that both computed the same thing
(the weighted z rms within 1 %; the reference skips the 5 s warm-up as supine does).

Run from the repository after `cargo build --release -p supine-host`:

    python3 host/benches/ride_speed.py --supine target/release/supine --runs 3

numpy's loader stands in for phonometry, which the issue measured and which is not
installable on this machine; the figures say which.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

G = 9.80665
WARMUP_S = 5.0


def wk_response(f_hz):
    """ISO 2631-1's Wk (band limiting, acceleration-velocity transition, upward step) at
    `f_hz`, from the analog transfer function (docs/exposure.md, "Frequency
    weightings")."""
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)
    w = lambda f: 2 * np.pi * f  # noqa: E731
    q1 = 1 / np.sqrt(2)
    w1, w2, w3, w4, w5, w6 = w(0.4), w(100.0), w(12.5), w(12.5), w(2.37), w(3.35)
    q4, q5, q6 = 0.63, 0.91, 0.91
    with np.errstate(divide="ignore", invalid="ignore"):
        hp = s**2 / (s**2 + s * w1 / q1 + w1**2)
        lp = w2**2 / (s**2 + s * w2 / q1 + w2**2)
        transition = (1 + s / w3) / (1 + s / (q4 * w4) + s**2 / w4**2)
        step = (s**2 + s * w5 / q5 + w5**2) / (s**2 + s * w6 / q6 + w6**2)
    h = hp * lp * transition * step
    h[~np.isfinite(h)] = 0
    return h


def uniform(t, x, fs):
    """`x` sampled at times `t` on a uniform grid at `fs` (linear interpolation)."""
    grid = np.arange(t[0], t[-1], 1 / fs)
    return np.interp(grid, t, x)


def weighted_values(x, fs):
    """Wk-weighted rms, MTVV (1 s running rms) and VDV of `x` at `fs`, after the
    warm-up."""
    from scipy.signal import lfilter

    n = len(x)
    spectrum = np.fft.rfft(x - x.mean())
    y = np.fft.irfft(spectrum * wk_response(np.fft.rfftfreq(n, 1 / fs)), n)
    alpha = 1 - np.exp(-1 / fs)
    ms = lfilter([alpha], [1, alpha - 1], y * y)
    k = int(WARMUP_S * fs)
    y, ms = y[k:], ms[k:]
    return {
        "rms_m_s2": float(np.sqrt(np.mean(y * y))),
        "mtvv_m_s2": float(np.sqrt(ms.max())),
        "vdv_m_s175": float((np.sum(y**4) / fs) ** 0.25),
    }


def reference(path, columns, time_scale, fs, axes):
    """The numpy reference: load `columns` (time, x, y, z), put them on a uniform grid,
    weight and evaluate `axes` (1, 2, 3: x, y, z). A ride with gravity (a phone's) has
    its z taken along the mean acceleration, less its magnitude: the litter's vertical
    however the phone lay."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=columns)
    t = (data[:, 0] - data[0, 0]) * time_scale
    mean = data[:, 1:4].mean(axis=0)
    if np.linalg.norm(mean) > G / 2:
        up = mean / np.linalg.norm(mean)
        data[:, 3] = data[:, 1:4] @ up - np.linalg.norm(mean)
    out = []
    for a in axes:
        x = uniform(t, data[:, a], fs)
        out.append(weighted_values(x, fs))
    return out


def run_measured(cmd):
    """Runs `cmd`; returns (wall s, user+sys s, peak RSS MB, stdout). The peak comes from
    `/usr/bin/time`: a child forked from this Python process would report Python's own
    resident set as its peak (Linux carries it across exec)."""
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-f", "peak_kb %M cpu_s %U %S", *cmd],
                          capture_output=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed: {proc.stderr.decode()}")
    last = proc.stderr.decode().strip().splitlines()[-1].split()
    return wall, float(last[3]) + float(last[4]), int(last[1]) / 1024, proc.stdout


def median_of(runs, cmd):
    """`cmd` (a list, or a function of the run's number giving one) run `runs` times."""
    results = [run_measured(cmd(i) if callable(cmd) else cmd) for i in range(runs)]
    pick = lambda i: statistics.median(r[i] for r in results)  # noqa: E731
    return pick(0), pick(1), max(r[2] for r in results), results[-1][3]


def phone_ride(src, dst, seed=1):
    """The 200 Hz ride `src` (supine ride's CSV) as a phone logs it (Sensor Logger)."""
    data = np.loadtxt(src, delimiter=",", skiprows=1)
    rng = np.random.default_rng(seed)
    t = data[:, 0] + rng.uniform(-0.001, 0.001, len(data))
    t = np.maximum.accumulate(t)
    tilt = np.radians(20)
    vertical = data[:, 3] + G
    y = np.cos(tilt) * vertical - np.sin(tilt) * data[:, 2]
    z = np.sin(tilt) * vertical + np.cos(tilt) * data[:, 2]
    ns = 1_718_030_736_872_695_300 + np.round(t * 1e9).astype(np.int64)
    with open(dst, "w") as f:
        f.write("time,seconds_elapsed,z,y,x\n")
        for row in zip(ns, t, z, y, data[:, 1]):
            f.write("%d,%.9f,%.6f,%.6f,%.6f\n" % row)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--supine", default="target/release/supine")
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--duration-s", type=float, default=3600)
    a = p.parse_args()
    work = tempfile.mkdtemp(prefix="ride_speed_")
    logger = os.path.join(work, "logger_500hz.csv")
    phone_src = os.path.join(work, "phone_src.csv")
    phone = os.path.join(work, "phone_200hz.csv")
    dur = str(a.duration_s)
    subprocess.run([a.supine, "ride", "--profile", "road-trip", "--duration-s", dur,
                    "--fs", "500", "--seed", "5", "--out", logger], check=True,
                   capture_output=True)
    subprocess.run([a.supine, "ride", "--profile", "road-trip", "--duration-s", dur,
                    "--fs", "200", "--seed", "6", "--out", phone_src], check=True,
                   capture_output=True)
    phone_ride(phone_src, phone)
    here = os.path.abspath(__file__)
    rows = []
    for name, path, ride_args, cols, scale, fs, channel_col in [
        ("500 Hz logger", logger, [], (0, 1, 2, 3), 1.0, 500.0, 3),
        ("200 Hz phone, jittered", phone, ["--remove-gravity", "--fs", "200"],
         (0, 4, 3, 2), 1e-9, 200.0, 3),
    ]:
        size_mb = os.path.getsize(path) / 1e6
        channel = median_of(a.runs, [a.supine, "exposure", "--input", path, *ride_args,
                                     "--channel", "platform_z", "--weighting", "wk",
                                     "--json"])
        report = median_of(a.runs, lambda i: [
            a.supine, "report", "--input", path, *ride_args,
            "--out", os.path.join(work, f"report_{len(rows)}_{i}"), "--json"])
        ref1 = median_of(a.runs, [sys.executable, here, "--reference", path,
                                  json.dumps([list(cols), scale, fs, [channel_col]])])
        ref3 = median_of(a.runs, [sys.executable, here, "--reference", path,
                                  json.dumps([list(cols), scale, fs, [1, 2, 3]])])
        supine_z = json.loads(channel[3])
        ref_z = json.loads(ref1[3])[0]
        rows.append((name, size_mb, channel, report, ref1, ref3, supine_z, ref_z))
    print("wall time, median of", a.runs, "(CPU time, peak memory)")
    print("| ride | size | supine exposure --channel | numpy, one axis | speed-up "
          "| supine report | numpy, three axes | speed-up |")
    print("|---|---|---|---|---|---|---|---|")
    for name, size, ch, rep, r1, r3, _, _ in rows:
        fmt = lambda m: f"{m[0]:.2f} s ({m[1]:.2f} s, {m[2]:.0f} MB)"  # noqa: E731
        print(f"| {name} | {size:.0f} MB | {fmt(ch)} | {fmt(r1)} | {r1[0] / ch[0]:.1f}x "
              f"| {fmt(rep)} | {fmt(r3)} | {r3[0] / rep[0]:.1f}x |")
    for name, *_, sz, rz in rows:
        print(f"{name}: weighted z rms supine {sz['rms_m_s2']:.4f}, "
              f"numpy {rz['rms_m_s2']:.4f} m/s^2")


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--reference":
        cols, scale, fs, axes = json.loads(sys.argv[3])
        print(json.dumps(reference(sys.argv[2], cols, scale, fs, axes)))
    else:
        main()
