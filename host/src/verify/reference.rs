//! What an ideal whole-body meter indicates, computed from the definitions alone: the
//! analog weighting of ISO 8041-1 (the parameter table, [`WeightingKind::params`]) and
//! the evaluation quantities of ISO 2631-1 (exponential running rms, MTVV, VDV).
//!
//! Independent of the product's filters on purpose (the verification's expected values
//! must not come from the code under test): the response is the analog transfer function
//! evaluated here, and a signal's weighted time history comes from each analog section
//! discretized by the prewarped bilinear transform at [`REFERENCE_RATE_HZ`], far above
//! every supported rate, in f64. No crate evaluates ISO weightings, hence this module.

use std::f64::consts::{FRAC_1_SQRT_2, TAU};

use supine_core::weighting::WeightingKind;

/// The rate the reference simulates the analog weighting at, Hz (32 times 2 kHz).
pub const REFERENCE_RATE_HZ: f64 = 64_000.0;

/// One analog section, `(c2 s^2 + c1 s + c0) / (d2 s^2 + d1 s + d0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Section {
    num: [f64; 3],
    den: [f64; 3],
    /// Where the bilinear transform is prewarped, Hz.
    f_hz: f64,
}

/// The sections of `kind` from the standard's table.
fn sections(kind: WeightingKind) -> Vec<Section> {
    let p = kind.params();
    let (w1, w2) = (TAU * p.f1_hz, TAU * p.f2_hz);
    let q = FRAC_1_SQRT_2;
    let mut out = vec![
        Section {
            num: [1.0, 0.0, 0.0],
            den: [1.0, w1 / q, w1 * w1],
            f_hz: p.f1_hz,
        },
        Section {
            num: [0.0, 0.0, w2 * w2],
            den: [1.0, w2 / q, w2 * w2],
            f_hz: p.f2_hz,
        },
    ];
    if let Some(t) = p.transition {
        let (w3, w4) = (TAU * t.f3_hz, TAU * t.f4_hz);
        out.push(Section {
            num: [0.0, p.gain / w3, p.gain],
            den: [1.0 / (w4 * w4), 1.0 / (t.q4 * w4), 1.0],
            f_hz: t.f4_hz,
        });
    } else {
        out.push(Section {
            num: [0.0, 0.0, p.gain],
            den: [0.0, 0.0, 1.0],
            f_hz: 1.0,
        });
    }
    if let Some(s) = p.step {
        let (w5, w6) = (TAU * s.f5_hz, TAU * s.f6_hz);
        out.push(Section {
            num: [1.0, w5 / s.q5, w5 * w5],
            den: [1.0, w6 / s.q6, w6 * w6],
            f_hz: s.f6_hz,
        });
    }
    out
}

/// `|W(j 2 pi f)|`, the weighting factor the standard prescribes at `f_hz`.
pub fn factor(kind: WeightingKind, f_hz: f64) -> f64 {
    let w = TAU * f_hz;
    sections(kind)
        .iter()
        .map(|s| {
            // c2 (jw)^2 + c1 jw + c0 = (c0 - c2 w^2) + j c1 w.
            let at = |c: [f64; 3]| (c[2] - c[0] * w * w).hypot(c[1] * w);
            at(s.num) / at(s.den)
        })
        .product()
}

/// A section as a digital biquad at `rate_hz` (prewarped bilinear), direct form I state.
struct Digital {
    b: [f64; 3],
    a: [f64; 2],
    x: [f64; 2],
    y: [f64; 2],
}

impl Digital {
    fn new(s: &Section, rate_hz: f64) -> Self {
        let w0 = TAU * s.f_hz;
        let k = w0 / (w0 / (2.0 * rate_hz)).tan();
        let z = |c: [f64; 3]| {
            let (c2, c1, c0) = (c[0] * k * k, c[1] * k, c[2]);
            [c2 + c1 + c0, 2.0 * (c0 - c2), c2 - c1 + c0]
        };
        let (b, a) = (z(s.num), z(s.den));
        Self {
            b: b.map(|v| v / a[0]),
            a: [a[1] / a[0], a[2] / a[0]],
            x: [0.0; 2],
            y: [0.0; 2],
        }
    }

    fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.b[1] * self.x[0] + self.b[2] * self.x[1]
            - self.a[0] * self.y[0]
            - self.a[1] * self.y[1];
        self.x = [x, self.x[0]];
        self.y = [y, self.y[0]];
        y
    }
}

/// What the definitions give for one signal: per weighting the MTVV (largest exponential
/// running rms) over each window, and the VDV of their vector sum (k = 1) per window.
#[derive(Clone, Debug, PartialEq)]
pub struct Indicated {
    /// `[window][axis]` MTVV, m/s^2.
    pub mtvv_m_s2: Vec<[f64; 3]>,
    /// `[window]` VDV of the vector sum over the window, m/s^1.75.
    pub vdv_m_s175: Vec<f64>,
}

/// Runs `signal` (m/s^2 at time t, s; the same on every axis) from 0 to `end_s` through
/// the analog weightings `kinds` (one per axis), with running-rms time constant `tau_s`,
/// and evaluates each of `windows` (start, end, s).
pub fn indicated(
    kinds: [WeightingKind; 3],
    tau_s: f64,
    signal: impl Fn(f64) -> f64,
    end_s: f64,
    windows: &[(f64, f64)],
) -> Indicated {
    let h = 1.0 / REFERENCE_RATE_HZ;
    let mut filters: Vec<Vec<Digital>> = kinds
        .iter()
        .map(|k| {
            sections(*k)
                .iter()
                .map(|s| Digital::new(s, REFERENCE_RATE_HZ))
                .collect()
        })
        .collect();
    let gain = 1.0 - (-h / tau_s).exp();
    let mut ms = [0.0f64; 3];
    let mut mtvv = vec![[0.0f64; 3]; windows.len()];
    let mut dose = vec![0.0f64; windows.len()];
    let steps = (end_s * REFERENCE_RATE_HZ).ceil() as usize;
    for n in 0..steps {
        let t = n as f64 * h;
        let x = signal(t);
        let mut vector_sq = 0.0;
        for (axis, chain) in filters.iter_mut().enumerate() {
            let a = chain.iter_mut().fold(x, |v, f| f.step(v));
            ms[axis] += (a * a - ms[axis]) * gain;
            vector_sq += a * a;
        }
        for (w, &(start, end)) in windows.iter().enumerate() {
            if t >= start && t < end {
                for axis in 0..3 {
                    mtvv[w][axis] = mtvv[w][axis].max(ms[axis].sqrt());
                }
                dose[w] += vector_sq * vector_sq * h;
            }
        }
    }
    Indicated {
        mtvv_m_s2: mtvv,
        vdv_m_s175: dose.iter().map(|d| d.powf(0.25)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The standard's calibration factors at 100 rad/s and its peaks (the design notes'
    /// values, themselves cross-checked against the ISO 8041 table).
    #[test]
    fn the_factors_are_the_standards() {
        let f_ref = 100.0 / TAU;
        for (kind, at_ref) in [
            (WeightingKind::Wk, 0.7718),
            (WeightingKind::Wd, 0.1261),
            (WeightingKind::Wj, 1.019),
        ] {
            let f = factor(kind, f_ref);
            assert!((f / at_ref - 1.0).abs() < 1e-3, "{kind:?}: {f}");
        }
        assert!((factor(WeightingKind::Wk, 6.17) - 1.0545).abs() < 2e-3);
        assert!((factor(WeightingKind::Wd, 1.09) - 1.0126).abs() < 2e-3);
    }

    /// A steady sine through the simulated weighting indicates its factor times its rms;
    /// its VDV over a whole number of periods is (3/8 A^4 T)^(1/4) per axis.
    #[test]
    fn a_steady_sine_indicates_the_factor_and_the_closed_form_vdv() {
        let f = 15.915;
        let amp = 2f64.sqrt();
        let kinds = [WeightingKind::Wk; 3];
        let start = 10.0;
        let end = start + 40.0 / f;
        let r = indicated(
            kinds,
            1.0,
            |t| amp * (TAU * f * t).sin(),
            end,
            &[(start, end)],
        );
        let w = factor(WeightingKind::Wk, f);
        assert!(
            (r.mtvv_m_s2[0][0] / w - 1.0).abs() < 0.01,
            "{:?}",
            r.mtvv_m_s2
        );
        // Three equal axes: the vector's fourth power is 9 times one axis's.
        let one_axis = (3.0 / 8.0 * (amp * w).powi(4) * (end - start)).powf(0.25);
        let want = one_axis * 9f64.powf(0.25);
        assert!(
            (r.vdv_m_s175[0] / want - 1.0).abs() < 0.01,
            "{:?}",
            r.vdv_m_s175
        );
    }
}
