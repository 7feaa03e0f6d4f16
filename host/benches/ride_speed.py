#!/usr/bin/env python3
"""Speed and memory of reading a one-hour ride (issue 26), against phonometry and an
independent numpy computation of the same quantities.

Two rides of one hour: the 500 Hz file `supine ride` writes (66 MB), and a phone's
200 Hz Sensor Logger export of the same kind of road (nanosecond epoch clock jittered by
up to +-1 ms, gravity on the phone's tilted y axis). For each it times, as separate
processes, median of --runs:

- `supine exposure --channel platform_z --weighting wk` (one axis, no model), against
  phonometry on one axis as its user calls it: `numpy.loadtxt` of the time and the
  columns (phonometry reads audio files, not CSV), on the phone's jittered clock linear
  interpolation onto a uniform grid (phonometry wants a uniform record), then
  `phonometry.vibration.human_vibration`'s `apply_weighting(x, fs, name="Wk")` (the
  ISO 8041-1 response in the frequency domain), `mtvv` and `running_rms`, and
  `vibration_dose_value`; and against the numpy reference of the same steps (Wk from
  its analog transfer function, docs/exposure.md's table; the 1 s running rms,
  exponential, `scipy.signal.lfilter`);
- `supine report` (three axes through the model, the joints, the spectra, the charts,
  report.html), against the numpy reference of three axes (the same steps per axis; no
  model, no charts: a lower bound of what a script would spend).

phonometry's time is given two ways: the whole process (the interpreter, importing
numpy, scipy and phonometry, the loader, the evaluation) and its loader and evaluation
alone (timed inside the process, the interpreter and imports left out). The speed-ups are
against the second, the stricter. Peak memory is each process's maximum resident set
(`/usr/bin/time`). The values of phonometry and of the numpy reference are printed beside
supine's as a check that all computed the same thing (rms, MTVV from the exponential 1 s
running rms as supine's, VDV, after supine's 5 s warm-up; phonometry's default `mtvv`,
a linear 1 s average, is printed too: another of ISO 2631-1's running rms forms).

Run from the repository after `cargo build --release -p supine-host`:

    python3 host/benches/ride_speed.py --supine target/release/supine --runs 3 \
        --phonometry-python /path/to/venv/bin/python

phonometry (PyPI, `pip install phonometry`) needs Python 3.13 or later: install it in a
virtual environment of its own (`python3.13 -m venv V && V/bin/pip install phonometry`)
and give that interpreter; without `--phonometry-python` its columns are left out.
"""

import argparse
import json
import os
import shutil
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
    """`x` sampled at times `t` on a uniform grid at `fs` (linear interpolation; `x`
    itself when its clock already is that grid)."""
    if np.all(np.abs(np.diff(t) - 1 / fs) < 1e-6 / fs):
        return x
    grid = np.arange(t[0], t[-1], 1 / fs)
    return np.interp(grid, t, x)


def weighted_values(x, fs):
    """Wk-weighted rms, MTVV (1 s running rms) and VDV of `x` at `fs`, after the
    warm-up, by numpy and scipy."""
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


def phonometry_values(x, fs):
    """The same values by phonometry, as its user calls it: the weighted record, its
    MTVV (phonometry's default, the linear 1 s running rms), its VDV, each from the end
    of supine's warm-up. Also gives a function for the MTVV of the exponential running
    rms (supine's), called after the timing."""
    from phonometry.vibration import human_vibration as hv

    y = hv.apply_weighting(x, fs, name="Wk")[int(WARMUP_S * fs):]
    values = {
        "rms_m_s2": float(np.sqrt(np.mean(y * y))),
        "mtvv_linear_m_s2": hv.mtvv(y, fs, integration_time=1.0),
        "vdv_m_s175": hv.vibration_dose_value(y, fs),
    }

    def exponential_mtvv():
        ms = hv.running_rms(y, fs, integration_time=1.0, method="exponential")
        values["mtvv_m_s2"] = float(ms.max())

    return values, exponential_mtvv


def reference(path, columns, time_scale, fs, gravity, axes, engine):
    """The reference `engine` (numpy, phonometry): load the time and the acceleration
    `columns` (x, y, z; all three for a ride with `gravity`, else those of `axes`), put
    them on a uniform grid, weight and evaluate `axes` (1, 2, 3: x, y, z). A ride with
    gravity (a phone's) has its z taken along the mean acceleration, less its magnitude:
    the litter's vertical however the phone lay. Gives the values and the seconds the
    loader and the evaluation took (interpreter and imports left out)."""
    if engine == "phonometry":
        from phonometry.vibration import human_vibration  # noqa: F401
    else:
        from scipy.signal import lfilter  # noqa: F401
    start = time.perf_counter()
    wanted = [1, 2, 3] if gravity else axes
    loaded = np.loadtxt(path, delimiter=",", skiprows=1,
                        usecols=[columns[0]] + [columns[a] for a in wanted])
    data = np.zeros((len(loaded), 4))
    data[:, [0, *wanted]] = loaded
    t = (data[:, 0] - data[0, 0]) * time_scale
    if gravity:
        mean = data[:, 1:4].mean(axis=0)
        up = mean / np.linalg.norm(mean)
        data[:, 3] = data[:, 1:4] @ up - np.linalg.norm(mean)
    out, after = [], []
    for a in axes:
        x = uniform(t, data[:, a], fs)
        if engine == "phonometry":
            values, check = phonometry_values(x, fs)
            out.append(values)
            after.append(check)
        else:
            out.append(weighted_values(x, fs))
    compute_s = time.perf_counter() - start
    for check in after:
        check()
    return {"values": out, "compute_s": compute_s}


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
    p.add_argument("--phonometry-python", help="a Python interpreter with phonometry")
    a = p.parse_args()
    work = tempfile.mkdtemp(prefix="ride_speed_")
    try:
        measure(a, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def measure(a, work):
    """Makes the two rides in `work`, times every tool on them and prints the table."""
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

    def ref(python, path, setup, axes, engine):
        """The reference in its own process: (wall, CPU, peak MB, values, compute s)."""
        cols, scale, fs, gravity = setup
        runs = [run_measured([python, here, "--reference", path,
                              json.dumps([list(cols), scale, fs, gravity, axes, engine])])
                for _ in range(a.runs)]
        out = [json.loads(r[3]) for r in runs]
        return (statistics.median(r[0] for r in runs),
                statistics.median(r[1] for r in runs), max(r[2] for r in runs),
                out[-1]["values"], statistics.median(o["compute_s"] for o in out))

    rows = []
    for name, path, ride_args, setup, channel_col in [
        ("500 Hz logger", logger, [], ((0, 1, 2, 3), 1.0, 500.0, False), 3),
        ("200 Hz phone, jittered", phone, ["--remove-gravity", "--fs", "200"],
         ((0, 4, 3, 2), 1e-9, 200.0, True), 3),
    ]:
        size_mb = os.path.getsize(path) / 1e6
        channel = median_of(a.runs, [a.supine, "exposure", "--input", path, *ride_args,
                                     "--channel", "platform_z", "--weighting", "wk",
                                     "--json"])
        report = median_of(a.runs, lambda i: [
            a.supine, "report", "--input", path, *ride_args,
            "--out", os.path.join(work, f"report_{len(rows)}_{i}"), "--json"])
        phono = (ref(a.phonometry_python, path, setup, [channel_col], "phonometry")
                 if a.phonometry_python else None)
        ref1 = ref(sys.executable, path, setup, [channel_col], "numpy")
        ref3 = ref(sys.executable, path, setup, [1, 2, 3], "numpy")
        rows.append((name, size_mb, channel, report, phono, ref1, ref3,
                     json.loads(channel[3])))
    fmt = lambda m: f"{m[0]:.2f} s ({m[1]:.2f} s CPU, {m[2]:.0f} MB)"  # noqa: E731
    print(f"wall time, median of {a.runs} (CPU time, peak memory); load average "
          f"{os.getloadavg()[0]:.1f} at the end")
    for name, size, ch, rep, ph, r1, r3, _ in rows:
        print(f"\n{name}, {size:.0f} MB:")
        print(f"  supine exposure --channel: {fmt(ch)}")
        print(f"  supine report:             {fmt(rep)}")
        if ph:
            base = ph[4]
            print(f"  phonometry, one axis:      {fmt(ph)}; loader and evaluation "
                  f"{base:.2f} s")
            print(f"  speed-up over phonometry's loader and evaluation: channel "
                  f"{base / ch[0]:.1f}x (reach 3x), report {base / rep[0]:.1f}x "
                  f"(reach 1.5x); over its whole process {ph[0] / ch[0]:.1f}x, "
                  f"{ph[0] / rep[0]:.1f}x")
        print(f"  numpy, one axis:           {fmt(r1)}, {r1[0] / ch[0]:.1f}x the channel")
        print(f"  numpy, three axes:         {fmt(r3)}, {r3[0] / rep[0]:.1f}x the report")
    print("\nweighted z after the warm-up: rms m/s^2, MTVV m/s^2 (exponential 1 s), "
          "VDV m/s^1.75")
    keys = ("rms_m_s2", "mtvv_m_s2", "vdv_m_s175")
    for name, _, _, _, ph, r1, _, sz in rows:
        for who, v in [("supine", sz), ("phonometry", ph and ph[3][0]), ("numpy", r1[3][0])]:
            if v:
                extra = (f"; phonometry's default mtvv (linear) {v['mtvv_linear_m_s2']:.4f}"
                         if "mtvv_linear_m_s2" in v else "")
                diffs = ", ".join(f"{100 * (v[k] / sz[k] - 1):+.2f} %" for k in keys)
                print(f"  {name}, {who}: " + " ".join(f"{v[k]:.4f}" for k in keys)
                      + (f" ({diffs} from supine)" if who != "supine" else "") + extra)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--reference":
        print(json.dumps(reference(sys.argv[2], *json.loads(sys.argv[3]))))
    else:
        main()
