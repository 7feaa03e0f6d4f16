//! The verification's test signals, and how each result is read from the device's
//! telemetry (one record per sample), with the standard's tolerances
//! (docs/exposure.md, "ISO 8041-1 verification", cites the tables).
//!
//! Every signal is the same on the three axes (Wk, Wd, Wj, see [`super::AXIS_WEIGHTINGS`]),
//! except the linearity and overload signals' use of the full scale, which is the same
//! for each axis too. A steady indication is read as the root of the mean of the running
//! mean square over a whole number of its ripple's periods, after the running rms and the
//! filters have settled (6 s: five time constants and the 0.4 Hz high-pass's transient).

use std::f64::consts::{LN_10, TAU};

use supine_core::alerts::SensorFault;
use supine_core::blob::DeviceParams;
use supine_core::protocol::Telemetry;

use super::reference::{factor, indicated};
use super::{AXIS_WEIGHTINGS, FULL_SCALE_M_S2, TestResult};

/// The reference frequency, 100 rad/s, Hz.
pub const REFERENCE_HZ: f64 = 100.0 / TAU;

/// Settling time before a steady reading, s.
const SETTLE_S: f64 = 6.0;

/// Shortest steady reading, s.
const READ_S: f64 = 2.0;

/// Reference tolerance, ISO 8041-1 (reference check and linearity): +-4 %.
const REFERENCE_TOLERANCE: f64 = 0.04;

/// The verification's test groups, each one QEMU session per rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// The reference check and the frequency response (stepped sine).
    Response,
    /// The running rms's decay after switch-off.
    Decay,
    /// Tone bursts of 1 to 16 cycles and a continuous signal.
    Bursts,
    /// Amplitude linearity and under-range.
    Linearity,
    /// Overload: the saturated fault.
    Overload,
}

impl Group {
    /// All groups, in the report's order.
    pub const ALL: [Group; 5] = [
        Group::Response,
        Group::Decay,
        Group::Bursts,
        Group::Linearity,
        Group::Overload,
    ];

    /// What the group tests.
    pub fn name(self) -> &'static str {
        match self {
            Group::Response => "reference check and frequency response",
            Group::Decay => "running rms decay",
            Group::Bursts => "signal bursts",
            Group::Linearity => "amplitude linearity and under-range",
            Group::Overload => "overload",
        }
    }

    /// The test signal at `rate_hz`.
    pub fn signal(self, rate_hz: f64) -> Signal {
        let mut s = Signal::new(rate_hz);
        match self {
            Group::Response => {
                for f in response_frequencies(rate_hz) {
                    s.steady(f, 1.0);
                }
            }
            Group::Decay => {
                s.steady(REFERENCE_HZ, 1.0);
                s.silence(10.0);
            }
            Group::Bursts => {
                // The bursts start after the shipping warm-up (5 s), which only primes the
                // filters: the VDV counts from its end (docs/exposure.md).
                s.silence(6.0);
                for cycles in BURST_CYCLES {
                    s.burst(cycles, 8.0);
                }
                s.continuous(10.0);
            }
            Group::Linearity => {
                // Under-range first, from rest: after a signal the running rms only decays
                // towards 0.
                s.under_range(4.0);
                for rms in linearity_levels() {
                    s.steady(REFERENCE_HZ, rms);
                }
            }
            Group::Overload => {
                s.silence(1.0);
                s.overload(2.0);
                s.steady(REFERENCE_HZ, 1.0);
            }
        }
        s
    }

    /// The results of the group's signal `signal` at `rate_hz`, from `telemetry`.
    pub fn evaluate(
        self,
        rate_hz: f64,
        params: &DeviceParams,
        signal: &Signal,
        telemetry: &[Telemetry],
    ) -> Vec<TestResult> {
        let mut out = Vec::new();
        let result = |clause: &str, name: String, weighting: &str, f: Option<f64>| TestResult {
            clause: clause.to_string(),
            name,
            weighting: weighting.to_string(),
            fs_hz: rate_hz,
            frequency_hz: f,
            expected: 0.0,
            measured: 0.0,
            lower_limit: 0.0,
            upper_limit: 0.0,
            unit: "m/s^2".to_string(),
            pass: false,
        };
        for segment in &signal.segments {
            match *segment {
                Segment::Steady {
                    f_hz,
                    rms_m_s2,
                    read,
                } => {
                    for (axis, kind) in AXIS_WEIGHTINGS.iter().enumerate() {
                        let expected = factor(*kind, f_hz) * rms_m_s2;
                        let measured = steady_rms(telemetry, axis, read);
                        let (clause, name, lower, upper) = match self {
                            Group::Response if f_hz == REFERENCE_HZ => (
                                "ISO 8041-1 reference check (100 rad/s, 1 m/s^2, +-4 %)",
                                "reference check".to_string(),
                                1.0 - REFERENCE_TOLERANCE,
                                1.0 + REFERENCE_TOLERANCE,
                            ),
                            Group::Response => {
                                let (lo, hi) = frequency_tolerance(f_hz);
                                (
                                    "ISO 8041-1 frequency weighting, Annex B factors; \
                                     tolerance table (+12/-11 %, skirts +26/-21 %)",
                                    "frequency response".to_string(),
                                    lo,
                                    hi,
                                )
                            }
                            Group::Linearity => (
                                "ISO 8041-1 amplitude linearity (reference tolerance \
                                 +-4 %)",
                                format!("linearity at {} m/s^2 rms input", round4(rms_m_s2)),
                                1.0 - REFERENCE_TOLERANCE,
                                1.0 + REFERENCE_TOLERANCE,
                            ),
                            _ => continue,
                        };
                        out.push(TestResult {
                            expected,
                            measured,
                            lower_limit: expected * lower,
                            upper_limit: expected * upper,
                            pass: (expected * lower..=expected * upper).contains(&measured),
                            ..result(clause, name, weighting_label(*kind), Some(f_hz))
                        });
                    }
                }
                Segment::Silence { from, to } if self == Group::Decay => {
                    for (axis, kind) in AXIS_WEIGHTINGS.iter().enumerate() {
                        let measured = decay_20db_s(telemetry, axis, from, to, rate_hz);
                        // ISO 8041-1's table for exponential averaging, tau 1 s: 4.61 s
                        // +-0.25 s to fall 20 dB (2 ln 10 tau).
                        let expected = 2.0 * LN_10;
                        out.push(TestResult {
                            expected,
                            measured,
                            lower_limit: 4.61 - 0.25,
                            upper_limit: 4.61 + 0.25,
                            unit: "s".to_string(),
                            pass: (4.36..=4.86).contains(&measured),
                            ..result(
                                "ISO 8041-1 running rms, response to a switched-off \
                                 signal (exponential, tau 1 s: 4.61 +-0.25 s to -20 dB)",
                                "decay time to -20 dB".to_string(),
                                weighting_label(*kind),
                                Some(REFERENCE_HZ),
                            )
                        });
                    }
                }
                Segment::UnderRange { from, to } => {
                    let measured = (from..to)
                        .filter_map(|i| telemetry.get(i))
                        .flat_map(|t| t.running_rms_m_s2)
                        .fold(0.0f32, f32::max);
                    out.push(TestResult {
                        measured: f64::from(measured),
                        pass: measured == 0.0,
                        ..result(
                            "ISO 8041-1 under-range: input below the resolution \
                             (2^-9 m/s^2) indicates exactly 0",
                            "under-range indication".to_string(),
                            "none",
                            Some(REFERENCE_HZ),
                        )
                    });
                }
                Segment::Overload { first, last } => {
                    out.extend(
                        overload_results(params, telemetry, first, last, rate_hz).map(
                            |(name, measured, expected, lo, hi)| TestResult {
                                expected,
                                measured,
                                lower_limit: lo,
                                upper_limit: hi,
                                unit: "s".to_string(),
                                pass: (lo..=hi).contains(&measured),
                                ..result(
                                    "ISO 8041-1 overload indication (the saturated fault)",
                                    name.to_string(),
                                    "none",
                                    Some(REFERENCE_HZ),
                                )
                            },
                        ),
                    );
                }
                _ => {}
            }
        }
        if self == Group::Bursts {
            out.extend(burst_results(rate_hz, signal, telemetry));
        }
        out
    }
}

/// Cycles per burst, ISO 8041-1's signal-burst test.
pub const BURST_CYCLES: [u32; 5] = [1, 2, 4, 8, 16];

/// ISO 8041-1 one-third-octave centres `10^(n/10)` Hz from 0.251 to 158.5 Hz, below 0.4
/// times `rate_hz` (what a sampled signal can carry with room to spare), and the
/// reference frequency first.
pub fn response_frequencies(rate_hz: f64) -> Vec<f64> {
    let mut out = vec![REFERENCE_HZ];
    out.extend(
        (-6..=22)
            .map(|n| 10f64.powf(f64::from(n) / 10.0))
            .filter(|f| *f < 0.4 * rate_hz),
    );
    out
}

/// ISO 8041-1's tolerance on the weighting at `f_hz`, as factors of the expected value:
/// +12/-11 % from 0.631 to 63.1 Hz, +26/-21 % from 0.251 to 0.631 and 63.1 to 158.5 Hz
/// (the band edges are the nominal centres, compared with 1 % slack for their rounding).
pub fn frequency_tolerance(f_hz: f64) -> (f64, f64) {
    if (0.631 * 0.99..=63.1 * 1.01).contains(&f_hz) {
        (0.89, 1.12)
    } else {
        (0.79, 1.26)
    }
}

/// Input levels of the linearity test, m/s^2 rms: 0.01 to just under the full scale
/// (69 dB), in steps of 10 dB.
pub fn linearity_levels() -> Vec<f64> {
    let top = f64::from(FULL_SCALE_M_S2) / 2f64.sqrt() * 0.99;
    let mut levels: Vec<f64> = (0..7).map(|k| 0.01 * 10f64.powf(k as f64 / 2.0)).collect();
    levels.push(top);
    levels
}

/// One part of a test signal, in samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Segment {
    /// A sine at `f_hz`, `rms_m_s2`, read steady over samples `read` (start, end).
    Steady {
        /// Frequency, Hz.
        f_hz: f64,
        /// Input rms, m/s^2.
        rms_m_s2: f64,
        /// Samples read, `[start, end)`.
        read: (usize, usize),
    },
    /// No input, samples `[from, to)`.
    Silence {
        /// First sample.
        from: usize,
        /// One past the last.
        to: usize,
    },
    /// A burst of `cycles` at the reference frequency from `start_s`, read until `end_s`.
    Burst {
        /// Cycles.
        cycles: u32,
        /// Start, s.
        start_s: f64,
        /// End of its reading window, s.
        end_s: f64,
    },
    /// Input below the resolution, samples `[from, to)`.
    UnderRange {
        /// First sample.
        from: usize,
        /// One past the last.
        to: usize,
    },
    /// Input beyond the full scale: the first and last samples that exceed it.
    Overload {
        /// First sample at or beyond the full scale.
        first: usize,
        /// Last one.
        last: usize,
    },
}

/// A test signal and what it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Signal {
    /// Its rate, Hz.
    pub rate_hz: f64,
    /// One sample per step, the same on all three axes, m/s^2.
    pub samples: Vec<[f32; 3]>,
    /// Its parts.
    pub segments: Vec<Segment>,
}

impl Signal {
    fn new(rate_hz: f64) -> Self {
        Self {
            rate_hz,
            samples: Vec::new(),
            segments: Vec::new(),
        }
    }

    fn t(&self, n: usize) -> f64 {
        n as f64 / self.rate_hz
    }

    fn push(&mut self, v: f64) {
        let v = v as f32;
        self.samples.push([v; 3]);
    }

    /// A sine of `rms_m_s2` at `f_hz` starting at phase 0, long enough to settle, then
    /// read over whole periods of its running mean square's ripple (at 2 f).
    fn steady(&mut self, f_hz: f64, rms_m_s2: f64) {
        let start = self.samples.len();
        let ripple_s = 0.5 / f_hz;
        let periods = (READ_S / ripple_s).ceil().max(1.0);
        let settle = (SETTLE_S.max(3.0 / f_hz) * self.rate_hz).round() as usize;
        let read = (periods * ripple_s * self.rate_hz).round() as usize;
        let amp = rms_m_s2 * 2f64.sqrt();
        for n in 0..settle + read {
            self.push(amp * (TAU * f_hz * self.t(n)).sin());
        }
        self.segments.push(Segment::Steady {
            f_hz,
            rms_m_s2,
            read: (start + settle, start + settle + read),
        });
    }

    fn silence(&mut self, seconds: f64) {
        let from = self.samples.len();
        for _ in 0..(seconds * self.rate_hz).round() as usize {
            self.push(0.0);
        }
        let to = self.samples.len();
        self.segments.push(Segment::Silence { from, to });
    }

    /// `cycles` of the reference frequency at 1 m/s^2 rms, then silence to `window_s`.
    fn burst(&mut self, cycles: u32, window_s: f64) {
        let start = self.samples.len();
        let n = (window_s * self.rate_hz).round() as usize;
        let start_s = self.t(start);
        for k in 0..n {
            let v = burst_value(cycles, self.t(k));
            self.push(v);
        }
        self.segments.push(Segment::Burst {
            cycles,
            start_s,
            end_s: self.t(start + n),
        });
    }

    /// The reference frequency at 1 m/s^2 rms for `seconds`, read as a burst of all of it.
    fn continuous(&mut self, seconds: f64) {
        let start = self.samples.len();
        let start_s = self.t(start);
        let n = (seconds * self.rate_hz).round() as usize;
        for k in 0..n {
            self.push(2f64.sqrt() * (TAU * REFERENCE_HZ * self.t(k)).sin());
        }
        self.segments.push(Segment::Burst {
            cycles: 0,
            start_s,
            end_s: self.t(start + n),
        });
    }

    /// A sine of 0.45 input steps' amplitude: every sample rounds to 0.
    fn under_range(&mut self, seconds: f64) {
        let from = self.samples.len();
        let amp = 0.45 * f64::from(supine_core::input_resolution::INPUT_STEP_M_S2);
        for k in 0..(seconds * self.rate_hz).round() as usize {
            self.push(amp * (TAU * REFERENCE_HZ * self.t(k)).sin());
        }
        let to = self.samples.len();
        self.segments.push(Segment::UnderRange { from, to });
    }

    /// The reference frequency at 1.25 times the full scale's amplitude for `seconds`.
    fn overload(&mut self, seconds: f64) {
        let start = self.samples.len();
        let amp = 1.25 * f64::from(FULL_SCALE_M_S2);
        let (mut first, mut last) = (usize::MAX, 0);
        for k in 0..(seconds * self.rate_hz).round() as usize {
            let v = amp * (TAU * REFERENCE_HZ * self.t(k)).sin();
            if (v as f32).abs() >= FULL_SCALE_M_S2 {
                first = first.min(start + k);
                last = start + k;
            }
            self.push(v);
        }
        self.segments.push(Segment::Overload { first, last });
    }
}

/// How a result names a weighting (`Wk`, `Wd`, `Wj`).
fn weighting_label(kind: supine_core::weighting::WeightingKind) -> &'static str {
    match kind {
        supine_core::weighting::WeightingKind::Wk => "Wk",
        supine_core::weighting::WeightingKind::Wd => "Wd",
        supine_core::weighting::WeightingKind::Wj => "Wj",
    }
}

/// `v` to four significant digits, for a name.
fn round4(v: f64) -> f64 {
    let scale = 10f64.powi(3 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

/// A burst of `cycles` of the reference frequency, 1 m/s^2 rms, at `t_s` from its start.
fn burst_value(cycles: u32, t_s: f64) -> f64 {
    if t_s < f64::from(cycles) / REFERENCE_HZ {
        2f64.sqrt() * (TAU * REFERENCE_HZ * t_s).sin()
    } else {
        0.0
    }
}

/// The steady running rms of `axis` over samples `read`: the root of the mean of its
/// square (the running mean square), m/s^2.
fn steady_rms(telemetry: &[Telemetry], axis: usize, (from, to): (usize, usize)) -> f64 {
    let values: Vec<f64> = (from..to)
        .filter_map(|i| telemetry.get(i))
        .map(|t| f64::from(t.running_rms_m_s2[axis]).powi(2))
        .collect();
    (values.iter().sum::<f64>() / values.len().max(1) as f64).sqrt()
}

/// Time from the switch-off at sample `from` until the running rms of `axis` first falls
/// 20 dB below its steady value before it, s (interpolated between samples; NaN if it
/// never does before `to`).
fn decay_20db_s(telemetry: &[Telemetry], axis: usize, from: usize, to: usize, rate: f64) -> f64 {
    let before = (
        from.saturating_sub((rate / REFERENCE_HZ * 16.0).round() as usize),
        from,
    );
    let level = steady_rms(telemetry, axis, before) / 10.0;
    let rr = |i: usize| {
        telemetry
            .get(i)
            .map_or(0.0, |t| f64::from(t.running_rms_m_s2[axis]))
    };
    for i in from..to {
        if rr(i) <= level {
            let (a, b) = (rr(i.saturating_sub(1)), rr(i));
            let frac = if a > b { (a - level) / (a - b) } else { 1.0 };
            // Sample `from` is the first silent one: it is 1/fs after the switch-off.
            return (i as f64 - 1.0 + frac - from as f64 + 1.0) / rate;
        }
    }
    f64::NAN
}

/// The overload results: (name, measured, expected, lower, upper), s.
fn overload_results(
    params: &DeviceParams,
    telemetry: &[Telemetry],
    first: usize,
    last: usize,
    rate: f64,
) -> [(&'static str, f64, f64, f64, f64); 2] {
    let flagged = |i: usize| {
        telemetry
            .get(i)
            .is_some_and(|t| t.fault_flags.contains(SensorFault::Saturated))
    };
    let onset = (first..telemetry.len())
        .find(|&i| flagged(i))
        .map_or(f64::NAN, |i| (i - first) as f64 / rate);
    let held_to = (last..telemetry.len())
        .take_while(|&i| flagged(i))
        .last()
        .unwrap_or(last);
    let held_through = (first..=last).all(flagged);
    let hold = if held_through {
        (held_to - last) as f64 / rate
    } else {
        f64::NAN
    };
    let clear = f64::from(params.sensor_checks.config.clear_after_s);
    [
        (
            "overload indicated from the first sample beyond full scale (delay)",
            onset,
            0.0,
            0.0,
            0.0,
        ),
        (
            "overload held through it and after it for the clear time (hold)",
            hold,
            clear,
            clear - 1.0 / rate,
            clear + 0.1,
        ),
    ]
}

/// The burst results: per burst, each weighting's MTVV and the vector VDV, against the
/// definitions' values for the same sampled signal.
fn burst_results(rate: f64, signal: &Signal, telemetry: &[Telemetry]) -> Vec<TestResult> {
    let bursts: Vec<(u32, f64, f64)> = signal
        .segments
        .iter()
        .filter_map(|s| match *s {
            Segment::Burst {
                cycles,
                start_s,
                end_s,
            } => Some((cycles, start_s, end_s)),
            _ => None,
        })
        .collect();
    let Some(&(_, _, end)) = bursts.last() else {
        return Vec::new();
    };
    let windows: Vec<(f64, f64)> = bursts.iter().map(|&(_, a, b)| (a, b)).collect();
    let input = |t: f64| {
        bursts.iter().find(|&&(_, a, b)| t >= a && t < b).map_or(
            0.0,
            |&(cycles, a, _)| match cycles {
                0 => 2f64.sqrt() * (TAU * REFERENCE_HZ * (t - a)).sin(),
                c => burst_value(c, t - a),
            },
        )
    };
    let want = indicated(AXIS_WEIGHTINGS, 1.0, input, end, &windows);
    let index = |t: f64| ((t * rate).round() as usize).min(telemetry.len());
    let vdv_at = |i: usize| {
        i.checked_sub(1)
            .and_then(|i| telemetry.get(i))
            .map_or(0.0, |t| f64::from(t.vdv_m_s175))
    };
    let mut out = Vec::new();
    for (k, &(cycles, a, b)) in bursts.iter().enumerate() {
        let (i0, i1) = (index(a), index(b));
        let label = match cycles {
            0 => "continuous signal".to_string(),
            1 => "burst of 1 cycle".to_string(),
            c => format!("burst of {c} cycles"),
        };
        for (axis, kind) in AXIS_WEIGHTINGS.iter().enumerate() {
            let measured = (i0..i1)
                .filter_map(|i| telemetry.get(i))
                .map(|t| f64::from(t.running_rms_m_s2[axis]))
                .fold(0.0, f64::max);
            let expected = want.mtvv_m_s2[k][axis];
            out.push(burst_result(
                rate,
                &label,
                "MTVV",
                weighting_label(*kind),
                expected,
                measured,
                0.10,
            ));
        }
        let measured = (vdv_at(i1).powi(4) - vdv_at(i0).powi(4))
            .max(0.0)
            .powf(0.25);
        let expected = want.vdv_m_s175[k];
        let mut r = burst_result(rate, &label, "VDV", "vector", expected, measured, 0.12);
        r.unit = "m/s^1.75".to_string();
        out.push(r);
    }
    out
}

fn burst_result(
    rate: f64,
    label: &str,
    quantity: &str,
    weighting: &str,
    expected: f64,
    measured: f64,
    tolerance: f64,
) -> TestResult {
    let (lo, hi) = (expected * (1.0 - tolerance), expected * (1.0 + tolerance));
    TestResult {
        clause: format!(
            "ISO 8041-1 signal bursts at 15.9155 Hz ({quantity} +-{:.0} % of the \
             definition's value)",
            tolerance * 100.0
        ),
        name: format!("{label}: {quantity}"),
        weighting: weighting.to_string(),
        fs_hz: rate,
        frequency_hz: Some(REFERENCE_HZ),
        expected,
        measured,
        lower_limit: lo,
        upper_limit: hi,
        unit: "m/s^2".to_string(),
        pass: (lo..=hi).contains(&measured),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frequencies_stay_below_the_rate_and_the_tolerances_follow_the_bands() {
        let f = response_frequencies(100.0);
        assert_eq!(f[0], REFERENCE_HZ);
        assert!(f.iter().all(|f| *f < 40.0));
        assert_eq!(response_frequencies(2000.0).len(), 30);
        assert_eq!(frequency_tolerance(1.0), (0.89, 1.12));
        assert_eq!(frequency_tolerance(63.0957), (0.89, 1.12));
        assert_eq!(frequency_tolerance(79.43), (0.79, 1.26));
        assert_eq!(frequency_tolerance(0.398), (0.79, 1.26));
        let levels = linearity_levels();
        assert!(20.0 * (levels[levels.len() - 1] / levels[0]).log10() > 60.0);
    }

    #[test]
    fn a_steady_segment_reads_whole_ripple_periods_after_settling() {
        let mut s = Signal::new(500.0);
        s.steady(10.0, 1.0);
        let Segment::Steady { read, .. } = s.segments[0] else {
            panic!("steady")
        };
        assert_eq!(read.0, 3000);
        // 2 s of a 20 Hz ripple: 40 periods of 25 samples.
        assert_eq!(read.1 - read.0, 1000);
        assert_eq!(s.samples.len(), read.1);
    }
}
