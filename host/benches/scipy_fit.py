#!/usr/bin/env python3
"""The identification pipeline of `supine fit`, written with SciPy, as a speed and quality
reference for the Rust implementation (see BENCHMARKS.md).

Same data, same method: H1 per subject from scipy.signal.csd (periodic Hann, 2048-sample
segments for 0.1 Hz at 200 Hz, 50 % overlap, constant detrend), geometric mean across
subjects (phase on the branch nearest the circular mean), residuals
(|Hth| - |Hg|) / |Hg| and wrap(arg Hth - arg Hg) / pi for the 12 coupled components over
0.5-16 Hz, unknowns ln p with the bounds of docs/model.md#unknowns-bounds-and-starts, scipy.optimize.least_squares with
method='trf' and the same exact Jacobian (vectorized over frequencies with numpy), from
the same deterministic starts (rigid: the paper's all-ones start and the paper's values).

`--case pipeline` runs SciPy's own two stages, the paper's procedure: the rigid fit, then
the litter-board fit bounded by (and on the joints of) that rigid fit's best minimum;
its JSON holds the rigid fit's fields, its 42 parameters (`rigid_params`) and the
litter-board fit's (`litter`).

The litter-board case (`--case litter --joints RIGID.toml`) keeps the 24 joint parameters
of a rigid fit's parameter file (supine's format) fixed and fits the 18 contacts within
[min(1e-3, rigid value), rigid value], from supine's two deterministic starts (the rigid
fit's contacts, the paper's litter-board contacts clamped into the box): the same problem
as `supine fit --case litter --joints RIGID.toml`. A contact whose box is a single point
(rigid value at or below 1e-3) stays fixed (scipy needs lower < upper).

BLAS is pinned to one thread.

Usage: scipy_fit.py --dataset DIR [--case rigid|litter|pipeline] [--joints RIGID.toml] [--exclude s8]
       [--starts 2] [--ftol 1e-8] [--xtol 1e-8] [--jac exact|2-point] [--json]
"""

import os

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS"):
    os.environ[var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402

import numpy as np  # noqa: E402
from scipy import optimize, signal  # noqa: E402

# Paper Table 2 (Dempster): head-neck, torso-arms, pelvis-legs.
MASS = [0.081, 0.455, 0.464]
LENGTH = [0.182, 0.288, 0.530]
TO_HEAD = [0.0, 0.630, 0.10]
TO_FEET = [0.118, 0.370, 0.895]
GYRATION = [0.495, 0.496, 0.326]
SENSORS_Z = [0.10, 0.12, 0.10]

# Paper Tables 3-4 (rigid case), in ParamId::ALL order: per element (J1 translational,
# J1 rotational, J2 translational, J2 rotational, head, torso, pelvis contact) stiffness
# x, y, z then damping x, y, z.
PAPER_RIGID = [
    31967.2, 14553.6, 122987.8, 14335.5, 591.9, 8.1,
    50005.3, 772.9, 48964.0, 1.0, 11.0, 2140.5,
    38485.4, 22719.8, 68341.0, 273.8, 66.5, 46061.6,
    50005.6, 18832.4, 49596.6, 1.0, 278.9, 4992.1,
    21042.5, 24968.7, 109881.9, 6.2, 1.9, 118.4,
    13626.3, 8756.4, 83841.3, 230.8, 425.7, 3574.1,
    9147.7, 6042.0, 107865.1, 487.4, 319.3, 0.156,
]
# Paper Table 4, spinal board on a litter: the 18 contacts (head, torso, pelvis).
PAPER_LITTER_CONTACTS = [
    21042.5, 21382.4, 43148.0, 0.004, 0.9, 117.1,
    13626.3, 7337.7, 0.8, 160.1, 337.3, 488.8,
    4859.3, 6041.9, 66421.1, 458.3, 166.4, 0.023,
]
# Index of the first contact parameter in ParamId::ALL order (the joints come first).
FIRST_CONTACT = 24
# The litter-board case's lower bound in place of 0 (supine's LITTER_FLOOR).
LITTER_FLOOR = 1e-3
# (output row, input column) of the 12 fitted components.
COMPONENTS = [(0, 0), (1, 1), (2, 2), (3, 0), (4, 1), (5, 2), (6, 0), (7, 1), (8, 2),
              (0, 2), (3, 2), (6, 2)]
ACCELERATIONS = ["platform", "head", "torso", "pelvis"]
# The recording's header (docs/model.md#recording-format), and the one before its
# acceleration columns carried their unit.
HEADERS = [",".join(["time_s"] + [f"{p}_{a}{unit}" for p in ACCELERATIONS for a in "xyz"])
           for unit in ("_m_s2", "")]


def trans(seg, axis):
    return 6 * seg + axis


def rot(seg, axis):
    return 6 * seg + 3 + axis


def model_matrices(height_m, mass_kg):
    """Mass matrix, shape vectors (18 x 42), which are stiffness, G and R."""
    m = np.zeros((18, 18))
    la, lb = [], []
    for s in range(3):
        ms = MASS[s] * mass_kg
        length = LENGTH[s] * height_m
        inertia = ms * (GYRATION[s] * length) ** 2
        for a in range(3):
            m[trans(s, a), trans(s, a)] = ms
            m[rot(s, a), rot(s, a)] = inertia
        la.append(TO_HEAD[s] * length)
        lb.append(TO_FEET[s] * length)
    shapes = np.zeros((18, 42))
    stiff = np.zeros(42, dtype=bool)
    p = 0
    for element in range(7):
        for quantity in range(2):
            for a in range(3):
                b = shapes[:, p]
                stiff[p] = quantity == 0
                if element >= 4:
                    b[trans(element - 4, a)] = 1.0
                else:
                    joint, rotational = divmod(element, 2)
                    s, t = joint, joint + 1
                    if rotational:
                        b[rot(t, a)] += 1.0
                        b[rot(s, a)] -= 1.0
                    else:
                        b[trans(t, a)] += 1.0
                        b[trans(s, a)] -= 1.0
                        if a == 1:
                            b[rot(t, 2)] += la[t]
                            b[rot(s, 2)] += lb[s]
                        elif a == 2:
                            b[rot(t, 1)] -= la[t]
                            b[rot(s, 1)] -= lb[s]
                p += 1
    g = np.zeros((18, 3))
    r = np.zeros((9, 18))
    for s in range(3):
        pz = SENSORS_Z[s]
        cross = np.array([[0.0, -pz, 0.0], [pz, 0.0, 0.0], [0.0, 0.0, 0.0]])
        for a in range(3):
            g[trans(s, a), a] = 1.0
            r[3 * s + a, trans(s, a)] = 1.0
            for b in range(3):
                r[3 * s + a, rot(s, b)] = -cross[a, b]
    return m, shapes, stiff, g, r


class Objective:
    """Residuals and exact Jacobian in the free log-parameters; the others stay at `base`."""

    def __init__(self, freqs_hz, target, height_m, mass_kg, base_theta, free):
        self.base = np.asarray(base_theta, dtype=float)
        self.free = np.asarray(free)
        self.omega = 2 * np.pi * np.asarray(freqs_hz)
        self.target = target  # (nf, 9, 3) complex
        self.m, self.b, self.stiff, self.g, self.r = model_matrices(height_m, mass_kg)
        self.rows = np.array([c[0] for c in COMPONENTS])
        self.cols = np.array([c[1] for c in COMPONENTS])
        tg = target[:, self.rows, self.cols]
        self.g_abs = np.abs(tg)
        self.g_arg = np.angle(tg)

    def _full(self, theta_free):
        theta = self.base.copy()
        theta[self.free] = theta_free
        return theta

    def _solve(self, theta):
        p = np.exp(theta)
        k = (self.b[:, self.stiff] * p[self.stiff]) @ self.b[:, self.stiff].T
        c = (self.b[:, ~self.stiff] * p[~self.stiff]) @ self.b[:, ~self.stiff].T
        w = self.omega[:, None, None]
        a = k[None] - w ** 2 * self.m[None] + 1j * w * c[None]
        f = (k @ self.g)[None] + 1j * w * (c @ self.g)[None]
        rhs = np.concatenate([f, np.broadcast_to(self.r.T, (len(self.omega), 18, 9))], axis=2)
        sol = np.linalg.solve(a, rhs)
        x, wr = sol[:, :, :3], sol[:, :, 3:]
        h = np.einsum("jd,fdk->fjk", self.r, x)[:, self.rows, self.cols]
        return p, x, wr, h

    def residuals(self, theta_free):
        _, _, _, h = self._solve(self._full(theta_free))
        return self._res(h)

    def _res(self, h):
        mag = (np.abs(h) - self.g_abs) / self.g_abs
        ph = np.angle(np.exp(1j * (np.angle(h) - self.g_arg))) / np.pi
        return np.stack([mag, ph], axis=2).reshape(-1)

    def jacobian(self, theta_free):
        p, x, wr, h = self._solve(self._full(theta_free))
        u = np.einsum("fdj,dp->fpj", wr, self.b)  # R A^-1 b
        v = np.einsum("dp,fdk->fpk", self.b, self.g[None] - x)  # b^T (G - X)
        s = np.where(self.stiff[None, :], 1.0 + 0j, 1j * self.omega[:, None]) * p[None, :]
        dh = s[:, :, None] * u[:, :, self.rows] * v[:, :, self.cols]  # (nf, np, 12)
        dmag = np.real(np.conj(h)[:, None, :] * dh) / (np.abs(h) * self.g_abs)[:, None, :]
        dph = np.imag(dh / h[:, None, :]) / np.pi
        jac = np.stack([dmag, dph], axis=3)  # (nf, np, 12, 2)
        return jac.transpose(0, 2, 3, 1).reshape(-1, len(p))[:, self.free]


def read_recording(path):
    with open(path) as fh:
        if fh.readline().strip() not in HEADERS:
            raise SystemExit(f"{path}: line 1: unexpected header")
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    return data


def read_joints(path):
    """The 42 parameters of a supine parameter file, in ParamId::ALL order."""
    with open(path, "rb") as fh:
        doc = tomllib.load(fh)
    values = []
    for joint in ("head_torso", "torso_pelvis"):
        for motion, keys in (("translational", ("stiffness_n_per_m", "damping_n_s_per_m")),
                             ("rotational", ("stiffness_nm_per_rad", "damping_nm_s_per_rad"))):
            for key in keys:
                table = doc["joints"][joint][motion][key]
                values.extend(table[a] for a in "xyz")
    for segment in ("head", "torso", "pelvis"):
        for key in ("stiffness_n_per_m", "damping_n_s_per_m"):
            table = doc["contacts"][segment][key]
            values.extend(table[a] for a in "xyz")
    return np.array(values, dtype=float)


def problem(case, joints, stiff):
    """Base log-parameters, free indices, their bounds and the named starts."""
    if case == "rigid":
        free = np.arange(42)
        lo = np.where(stiff, math.log(1.0), math.log(1e-3))
        hi = np.full(42, math.log(1e6))
        starts = [("all ones (paper)", np.zeros(42)), ("paper Tables 3-4", np.log(PAPER_RIGID))]
        return np.zeros(42), free, lo, hi, starts
    rigid = np.log(joints)
    upper = rigid[FIRST_CONTACT:]
    lower = np.log(np.minimum(LITTER_FLOOR, joints[FIRST_CONTACT:]))
    # scipy needs lower < upper: a contact whose box is one point stays fixed there.
    movable = lower < upper
    free = FIRST_CONTACT + np.flatnonzero(movable)
    lo, hi = lower[movable], upper[movable]
    starts = [("rigid-case contacts (paper)", hi.copy()),
              ("paper Table 4 litter-board", np.log(PAPER_LITTER_CONTACTS)[movable])]
    return rigid, free, lo, hi, starts


def geometric_mean(values):
    """values: (subjects, ...) complex; geometric magnitude, mean phase near the circular mean."""
    mag = np.exp(np.mean(np.log(np.abs(values)), axis=0))
    ref = np.angle(np.sum(values / np.abs(values), axis=0))
    dev = np.angle(np.exp(1j * (np.angle(values) - ref[None])))
    return mag * np.exp(1j * (ref + dev.mean(axis=0)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--case", choices=["rigid", "litter", "pipeline"], default="rigid")
    ap.add_argument("--joints", help="the rigid fit (supine parameter file), for --case litter")
    ap.add_argument("--exclude", default="")
    ap.add_argument("--starts", type=int, default=2)
    ap.add_argument("--ftol", type=float, default=1e-8)
    ap.add_argument("--xtol", type=float, default=1e-8)
    ap.add_argument("--gtol", type=float, default=1e-8)
    ap.add_argument("--jac", choices=["exact", "2-point"], default="exact")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if (args.case == "litter") != (args.joints is not None):
        raise SystemExit("--joints FILE goes with --case litter, and only with it")
    exclude = set(filter(None, args.exclude.split(",")))
    with open(os.path.join(args.dataset, "dataset.toml"), "rb") as fh:
        desc = tomllib.load(fh)
    subjects = [s for s in desc["subject"] if s["id"] not in exclude]

    def measured(case):
        """The geometric-mean H of `case` over the subjects, its frequencies, and the time."""
        t0 = time.perf_counter()
        hs = []
        for s in subjects:
            d = read_recording(os.path.join(args.dataset, s[case]))
            fs = (len(d) - 1) / (d[-1, 0] - d[0, 0])
            nperseg = 1 << math.ceil(math.log2(math.ceil(fs / 0.1)))
            kw = dict(fs=fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
                      detrend="constant", scaling="density")
            x, y = d[:, 1:4], d[:, 4:13]
            f, _ = signal.csd(x[:, 0], x[:, 0], **kw)
            sel = (f >= 0.5 - 1e-9) & (f <= 16.0 + 1e-9)
            sxx = np.empty((sel.sum(), 3, 3), complex)
            sxy = np.empty((sel.sum(), 3, 9), complex)
            xy = np.concatenate([x, y], axis=1)
            for i in range(3):
                # S_ab = E[conj(A) B] (scipy's convention): input i against all 12 channels.
                _, pxy = signal.csd(np.broadcast_to(x[:, i : i + 1], xy.shape), xy, axis=0,
                                    **kw)
                sxx[:, i, :] = pxy[sel, :3]
                sxy[:, i, :] = pxy[sel, 3:]
            hs.append(np.linalg.solve(sxx, sxy).transpose(0, 2, 1))
            freqs = f[sel]
        return freqs, geometric_mean(np.array(hs)), time.perf_counter() - t0

    height = np.mean([s["height_m"] for s in subjects])
    mass = np.mean([s["mass_kg"] for s in subjects])
    _, _, stiff, _, _ = model_matrices(height, mass)

    def fit(case, joints):
        """Every start of `case`; its summary and the best start's 42 parameters."""
        freqs, target, t_spectra = measured(case)
        base, free, lo, hi, starts = problem(case, joints, stiff)
        obj = Objective(freqs, target, height, mass, base, free)
        results, best_theta = [], None
        for label, x0 in starts[: args.starts]:
            ts, cpu = time.perf_counter(), time.process_time()
            x0 = np.clip(x0, lo, hi)
            jac = obj.jacobian if args.jac == "exact" else "2-point"
            res = optimize.least_squares(obj.residuals, x0, jac=jac, bounds=(lo, hi),
                                         method="trf", ftol=args.ftol, xtol=args.xtol,
                                         gtol=args.gtol)
            seconds, cpu_seconds = time.perf_counter() - ts, time.process_time() - cpu
            initial_cost = 0.5 * float(np.sum(obj.residuals(x0) ** 2))
            results.append(dict(start=label, initial_cost=initial_cost, cost=float(res.cost),
                                nfev=int(res.nfev), njev=int(res.njev or 0),
                                status=int(res.status), seconds=seconds,
                                cpu_seconds=cpu_seconds))
            if best_theta is None or res.cost < min(r["cost"] for r in results[:-1]):
                best_theta = obj._full(res.x)
        # The starts' own times: the initial costs computed for the table are not the fit's.
        best = min(results, key=lambda r: r["cost"])
        out = dict(case=case, spectra_s=t_spectra, frequencies=len(freqs),
                   fit_s=sum(r["seconds"] for r in results),
                   fit_cpu_s=sum(r["cpu_seconds"] for r in results),
                   best_cost=best["cost"], starts=results)
        return out, np.exp(best_theta)

    if args.case == "pipeline":
        # SciPy's own two stages: its rigid minimum bounds its litter-board fit.
        out, rigid_params = fit("rigid", None)
        out["case"] = "pipeline"
        out["litter"], _ = fit("litter", rigid_params)
        out["rigid_params"] = rigid_params.tolist()
    else:
        out, _ = fit(args.case, read_joints(args.joints) if args.joints else None)
    out["subjects"] = [s["id"] for s in subjects]
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for stage in [out] + ([out["litter"]] if "litter" in out else []):
        print(f"{stage['case']}: spectra {stage['spectra_s']:.3f} s, fit {stage['fit_s']:.3f} s, "
              f"best cost {stage['best_cost']:.6f}")
        for r in stage["starts"]:
            print(f"  {r['start']}: cost {r['initial_cost']:.6f} -> {r['cost']:.6f}, "
                  f"{r['nfev']} evaluations, "
                  f"{r['njev']} Jacobians, status {r['status']}, {r['seconds']:.3f} s")


if __name__ == "__main__":
    main()
