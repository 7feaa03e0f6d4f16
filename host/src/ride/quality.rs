//! The data-quality account of a ride: what its clock, rate, gravity and range say about
//! how far its values can be trusted, gathered in one pass over the rows ([`Scan`]) and
//! told as one [`DataQuality`] (the `data_quality` object of `report --json` and
//! `exposure --json`, and the report's data-quality section) with a one-line verdict.
//!
//! The verdict: not usable when the sensor's effective rate is below [`MIN_RATE_HZ`] or
//! more than [`MAX_CLIPPED_FRACTION`] of its samples are clipped or gaps take more than
//! half the span; usable with caveats when any of: the band covered ends below the
//! weighting's 80 Hz, gravity is more than [`GRAVITY_TOLERANCE`] off 9.81 m/s^2, any
//! sample is clipped, there are gaps, sample-and-hold, more than 1 % of rows dropped, or
//! a 99th-percentile step more than twice the median; good otherwise.

use serde::Serialize;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;
use supine_core::weighting::{WeightingKind, analog_response};

use crate::ride::level::Levelling;
use crate::ride::position::TrackAccount;
use crate::ride::regular::RowFate;

/// Lowest effective rate a ride is usable at, Hz.
pub const MIN_RATE_HZ: f64 = 20.0;
/// Largest share of clipped samples a ride is usable with.
pub const MAX_CLIPPED_FRACTION: f64 = 0.01;
/// Largest relative difference of the measured gravity from 9.81 m/s^2 not flagged.
pub const GRAVITY_TOLERANCE: f64 = 0.02;
/// Upper edge of the Wk and Wj weightings' band, Hz (ISO 2631-1).
pub const WEIGHTING_BAND_HZ: (f64, f64) = (0.5, 80.0);
/// Resolution of the step histogram, s.
const STEP_BIN_S: f64 = 1e-6;
/// Steps longer than this share the histogram's last bin, s.
const STEP_RANGE_S: f64 = 1.0;
/// Fewest consecutive samples at an axis' extreme value that count as clipping.
pub const MIN_CLIP_RUN: usize = 3;
/// Most gaps listed one by one (the rest are counted).
pub const MAX_LISTED_GAPS: usize = 100;

/// A gap the ride was split at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Gap {
    /// Time of the last row before it, s (the file's time).
    pub at_s: f64,
    /// Its length, s.
    pub length_s: f64,
}

/// Clipping on one axis: runs of samples at the axis' extreme value.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Clipping {
    /// `x`, `y` or `z` (the file's axes, before levelling).
    pub axis: &'static str,
    /// The value the runs sit at, m/s^2.
    pub value_m_s2: f64,
    /// Samples in the runs.
    pub samples: u64,
    /// Start of the first run, s.
    pub first_s: f64,
    /// Start of the last run, s.
    pub last_s: f64,
}

/// The data-quality account of one ride (leg).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DataQuality {
    /// `good`, `usable with caveats` or `not usable`.
    pub verdict: &'static str,
    /// Why (empty when good).
    pub reasons: Vec<String>,
    /// The file's format (a recognized app's, `--columns`, or the project's).
    pub format: String,
    /// Rows read in the time window.
    pub rows: u64,
    /// The source's rate from its median step, Hz.
    pub source_rate_hz: f64,
    /// Median step between kept rows, s.
    pub step_median_s: f64,
    /// 99th-percentile step between kept rows (gaps excluded), s.
    pub step_p99_s: f64,
    /// The sensor's own rate: kept rows over the time they span (gaps excluded), Hz.
    pub effective_rate_hz: f64,
    /// The rate the ride is evaluated at, Hz.
    pub resampled_rate_hz: f64,
    /// Upper edge of the band the recording covers (half the lower of the effective and
    /// evaluation rates), Hz.
    pub band_upper_hz: f64,
    /// Share of the Wk weighting's power (0.5-80 Hz, flat input) above `band_upper_hz`.
    pub weighting_band_missing_fraction: f64,
    /// Rows dropped because their time was not after the last kept row's.
    pub dropped_samples: u64,
    /// Rows dropped because they repeated the previous row (sample-and-hold).
    pub repeated_samples: u64,
    /// Gaps longer than `max_gap_s`, never bridged.
    pub gaps: u64,
    /// The longest gap, s.
    pub gap_longest_s: f64,
    /// All gaps together, s.
    pub gap_total_s: f64,
    /// The bound, s.
    pub max_gap_s: f64,
    /// The first gaps, where and how long.
    pub gap_list: Vec<Gap>,
    /// Time evaluated (the stretches between gaps), s.
    pub covered_s: f64,
    /// How the ride was levelled (with `--remove-gravity`).
    pub levelling: Option<Levelling>,
    /// Gravity more than 2 % off 9.81 m/s^2: a scale error of the sensor.
    pub gravity_scale_error: bool,
    /// Clipping per axis (axes without it are left out).
    pub clipping: Vec<Clipping>,
    /// What the checks made of the ride's position track, when it has one: its fixes,
    /// those excluded (jumps, out of order) and those of poor accuracy.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub positions: Option<TrackAccount>,
}

/// Per-axis state of the clipping search: the extreme so far and its runs.
#[derive(Clone, Copy, Debug)]
struct Extreme {
    value: f64,
    run: usize,
    samples: u64,
    first_s: f64,
    last_s: f64,
    run_start_s: f64,
}

impl Extreme {
    fn new() -> Self {
        Self {
            value: f64::NAN,
            run: 0,
            samples: 0,
            first_s: f64::NAN,
            last_s: f64::NAN,
            run_start_s: 0.0,
        }
    }

    /// Takes a sample; `beyond` says whether `a` is past `b` in this extreme's direction.
    fn take(&mut self, v: f64, t: f64, beyond: fn(f64, f64) -> bool) {
        if self.value.is_nan() || beyond(v, self.value) {
            *self = Self::new();
            self.value = v;
            self.run = 1;
            self.run_start_s = t;
        } else if v == self.value {
            if self.run == 0 {
                self.run_start_s = t;
            }
            self.run += 1;
            if self.run == MIN_CLIP_RUN {
                self.samples += MIN_CLIP_RUN as u64;
                if self.first_s.is_nan() {
                    self.first_s = self.run_start_s;
                }
                self.last_s = self.run_start_s;
            } else if self.run > MIN_CLIP_RUN {
                self.samples += 1;
            }
        } else {
            self.run = 0;
        }
    }
}

/// One pass's gathering of everything the account needs.
#[derive(Clone, Debug)]
pub struct Scan {
    /// Rows read in the window.
    pub rows: u64,
    /// Rows kept.
    pub kept: u64,
    dropped: u64,
    repeated: u64,
    steps: Vec<u32>,
    gap_count: u64,
    gap_longest_s: f64,
    gap_total_s: f64,
    gap_list: Vec<Gap>,
    /// Kept-row count, first and last time of each stretch between gaps.
    pub stretches: Vec<(usize, f64, f64)>,
    last_kept_s: f64,
    sum: [f64; 3],
    max: [Extreme; 3],
    min: [Extreme; 3],
    /// The last kept row, and the rows dropped behind it since.
    behind: RowsBehind,
    /// The longest such run so far.
    longest_behind: RowsBehind,
}

/// Rows dropped one after another because their time was not after one kept row's: a
/// long run of them means that row's time is wrong (a corrupt stamp far ahead), not
/// theirs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RowsBehind {
    /// The kept row's line in the file.
    pub line: u64,
    /// Its time, s.
    pub time_s: f64,
    /// Its step from the kept row before it, s.
    pub step_s: f64,
    /// Rows dropped after it, one after another.
    pub rows: u64,
}

impl Default for Scan {
    fn default() -> Self {
        Self::new()
    }
}

impl Scan {
    /// An empty scan.
    pub fn new() -> Self {
        Self {
            rows: 0,
            kept: 0,
            dropped: 0,
            repeated: 0,
            steps: vec![0; (STEP_RANGE_S / STEP_BIN_S) as usize + 1],
            gap_count: 0,
            gap_longest_s: 0.0,
            gap_total_s: 0.0,
            gap_list: Vec::new(),
            stretches: Vec::new(),
            last_kept_s: f64::NAN,
            sum: [0.0; 3],
            max: [Extreme::new(); 3],
            min: [Extreme::new(); 3],
            behind: RowsBehind::default(),
            longest_behind: RowsBehind::default(),
        }
    }

    /// The longest run of rows dropped behind one kept row (`rows` 0 when none was).
    pub fn longest_run_behind(&self) -> RowsBehind {
        self.longest_behind
    }

    /// Takes a row (its line, time s, values m/s^2 as read, before levelling) and its
    /// fate.
    pub fn take(&mut self, line: u64, time_s: f64, values: [f64; 3], fate: RowFate) {
        self.rows += 1;
        match fate {
            RowFate::NotIncreasing => {
                self.dropped += 1;
                self.behind.rows += 1;
                if self.behind.rows > self.longest_behind.rows {
                    self.longest_behind = self.behind;
                }
                return;
            }
            RowFate::Repeated => {
                self.repeated += 1;
                return;
            }
            RowFate::Kept => {
                let step = time_s - self.last_kept_s;
                let bin = ((step / STEP_BIN_S).round() as usize).min(self.steps.len() - 1);
                self.steps[bin] += 1;
                if let Some(s) = self.stretches.last_mut() {
                    s.0 += 1;
                    s.2 = time_s;
                }
            }
            RowFate::KeptAfterGap => {
                if self.last_kept_s.is_finite() {
                    let length_s = time_s - self.last_kept_s;
                    self.gap_count += 1;
                    self.gap_total_s += length_s;
                    self.gap_longest_s = self.gap_longest_s.max(length_s);
                    if self.gap_list.len() < MAX_LISTED_GAPS {
                        self.gap_list.push(Gap {
                            at_s: self.last_kept_s,
                            length_s,
                        });
                    }
                }
                self.stretches.push((1, time_s, time_s));
            }
        }
        self.kept += 1;
        self.behind = RowsBehind {
            line,
            time_s,
            step_s: time_s - self.last_kept_s,
            rows: 0,
        };
        self.last_kept_s = time_s;
        for (axis, v) in values.iter().enumerate() {
            self.sum[axis] += v;
            self.max[axis].take(*v, time_s, |a, b| a > b);
            self.min[axis].take(*v, time_s, |a, b| a < b);
        }
    }

    /// Mean of the kept rows, m/s^2.
    pub fn mean_m_s2(&self) -> [f64; 3] {
        self.sum.map(|s| s / self.kept.max(1) as f64)
    }

    /// The `q` quantile of the steps between kept rows (gaps excluded), s.
    fn step_quantile_s(&self, q: f64) -> f64 {
        let total: u64 = self.steps.iter().map(|&c| u64::from(c)).sum();
        if total == 0 {
            return f64::NAN;
        }
        let target = (q * total as f64).ceil().max(1.0) as u64;
        let mut seen = 0u64;
        for (bin, &c) in self.steps.iter().enumerate() {
            seen += u64::from(c);
            if seen >= target {
                return bin as f64 * STEP_BIN_S;
            }
        }
        f64::NAN
    }

    /// Kept rows over the time the stretches span, Hz.
    pub fn effective_rate_hz(&self) -> f64 {
        let span: f64 = self.stretches.iter().map(|s| s.2 - s.1).sum();
        let steps: usize = self.stretches.iter().map(|s| s.0 - 1).sum();
        steps as f64 / span
    }

    /// The account, for a ride evaluated at `resampled_rate_hz` with gaps over
    /// `max_gap_s`, levelled as `levelling` says.
    pub fn account(
        &self,
        format: String,
        resampled_rate_hz: f64,
        max_gap_s: f64,
        levelling: Option<Levelling>,
    ) -> DataQuality {
        let median = self.step_quantile_s(0.5);
        let p99 = self.step_quantile_s(0.99);
        let effective = self.effective_rate_hz();
        let band_upper_hz = 0.5 * effective.min(resampled_rate_hz);
        let missing = missing_band_fraction(WeightingKind::Wk, band_upper_hz);
        let covered_s: f64 = self.stretches.iter().map(|s| s.2 - s.1).sum();
        let mut clipping = Vec::new();
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            for e in [self.max[axis], self.min[axis]] {
                if e.samples > 0 {
                    clipping.push(Clipping {
                        axis: name,
                        value_m_s2: e.value,
                        samples: e.samples,
                        first_s: e.first_s,
                        last_s: e.last_s,
                    });
                }
            }
        }
        let gravity_scale_error = levelling.is_some_and(|l| {
            l.method == "ride-mean"
                && (l.gravity_m_s2 / STANDARD_GRAVITY_M_S2 - 1.0).abs() > GRAVITY_TOLERANCE
        });
        let mut q = DataQuality {
            verdict: "good",
            reasons: Vec::new(),
            format,
            rows: self.rows,
            source_rate_hz: 1.0 / median,
            step_median_s: median,
            step_p99_s: p99,
            effective_rate_hz: effective,
            resampled_rate_hz,
            band_upper_hz,
            weighting_band_missing_fraction: missing,
            dropped_samples: self.dropped,
            repeated_samples: self.repeated,
            gaps: self.gap_count,
            gap_longest_s: self.gap_longest_s,
            gap_total_s: self.gap_total_s,
            max_gap_s,
            gap_list: self.gap_list.clone(),
            covered_s,
            levelling,
            gravity_scale_error,
            clipping,
            positions: None,
        };
        q.judge(self.kept);
        q
    }
}

impl DataQuality {
    /// Sets the verdict and its reasons from the figures.
    fn judge(&mut self, kept: u64) {
        let mut fatal = Vec::new();
        let mut caveats = Vec::new();
        let clipped: u64 = self.clipping.iter().map(|c| c.samples).sum();
        if self.effective_rate_hz < MIN_RATE_HZ {
            fatal.push(format!(
                "the sensor's effective rate {:.1} Hz is below {MIN_RATE_HZ} Hz",
                self.effective_rate_hz
            ));
        }
        if clipped as f64 > MAX_CLIPPED_FRACTION * kept as f64 {
            fatal.push(format!(
                "{clipped} samples clipped ({:.1} %)",
                100.0 * clipped as f64 / kept.max(1) as f64
            ));
        } else if clipped > 0 {
            caveats.push(format!("{clipped} samples clipped (peaks under-read)"));
        }
        if self.gap_total_s > self.covered_s {
            fatal.push(format!(
                "gaps take {:.1} s of {:.1} s",
                self.gap_total_s,
                self.gap_total_s + self.covered_s
            ));
        } else if self.gaps > 0 {
            caveats.push(format!(
                "{} gap{} ({:.2} s in all) not evaluated",
                self.gaps,
                if self.gaps == 1 { "" } else { "s" },
                self.gap_total_s
            ));
        }
        if self.band_upper_hz < WEIGHTING_BAND_HZ.1 {
            caveats.push(format!(
                "the band ends at {:.1} Hz, below the weighting's 80 Hz ({:.1} % of Wk's band missing: values can read low)",
                self.band_upper_hz,
                100.0 * self.weighting_band_missing_fraction
            ));
        }
        if self.gravity_scale_error
            && let Some(l) = self.levelling
        {
            caveats.push(format!(
                "gravity reads {:.2} m/s^2 ({:+.1} % off 9.81: a scale error, values read {})",
                l.gravity_m_s2,
                100.0 * (l.gravity_m_s2 / STANDARD_GRAVITY_M_S2 - 1.0),
                if l.gravity_m_s2 > STANDARD_GRAVITY_M_S2 {
                    "high"
                } else {
                    "low"
                }
            ));
        }
        if self.repeated_samples > 0 {
            caveats.push(format!(
                "sample-and-hold: {} rows repeated, the sensor's own rate is {:.1} Hz",
                self.repeated_samples, self.effective_rate_hz
            ));
        }
        if self.dropped_samples as f64 > 0.01 * self.rows as f64 {
            caveats.push(format!(
                "{} rows dropped (time not increasing)",
                self.dropped_samples
            ));
        }
        if self.step_p99_s > 2.0 * self.step_median_s {
            caveats.push(format!(
                "jittered clock (99th-percentile step {:.1} ms, median {:.1} ms)",
                1e3 * self.step_p99_s,
                1e3 * self.step_median_s
            ));
        }
        (self.verdict, self.reasons) = if !fatal.is_empty() {
            ("not usable", fatal)
        } else if !caveats.is_empty() {
            ("usable with caveats", caveats)
        } else {
            ("good", Vec::new())
        };
    }

    /// The one-line verdict: `good`, or the verdict and its reasons.
    pub fn verdict_line(&self) -> String {
        if self.reasons.is_empty() {
            return self.verdict.to_string();
        }
        format!("{}: {}", self.verdict, self.reasons.join("; "))
    }
}

/// Share of `kind`'s squared response over its band (flat input, integrated on a log grid
/// of 1000 points per decade) that lies above `upper_hz`.
pub fn missing_band_fraction(kind: WeightingKind, upper_hz: f64) -> f64 {
    let (lo, hi) = WEIGHTING_BAND_HZ;
    if upper_hz >= hi {
        return 0.0;
    }
    let points = 3000;
    let (mut total, mut above) = (0.0, 0.0);
    for i in 0..points {
        let f = lo * (hi / lo).powf((i as f64 + 0.5) / points as f64);
        // d f = f d(ln f): weight each log step by f.
        let p = analog_response(kind, f).abs().powi(2) * f;
        total += p;
        if f > upper_hz {
            above += p;
        }
    }
    above / total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_is_runs_at_the_extreme_and_a_single_touch_is_not() {
        let mut e = Extreme::new();
        let values = [1.0, 2.0, 2.0, 2.0, 2.0, 1.0, 2.0, 0.5, 2.0, 2.0, 2.0];
        for (k, v) in values.iter().enumerate() {
            e.take(*v, k as f64, |a, b| a > b);
        }
        assert_eq!(e.samples, 7);
        assert_eq!((e.first_s, e.last_s), (1.0, 8.0));
        let mut e = Extreme::new();
        for (k, v) in [1.0, 2.0, 2.0, 1.0, 3.0].iter().enumerate() {
            e.take(*v, k as f64, |a, b| a > b);
        }
        assert_eq!(e.samples, 0);
    }

    #[test]
    fn the_band_missing_is_none_at_80_hz_and_all_at_half_a_hertz() {
        assert_eq!(missing_band_fraction(WeightingKind::Wk, 80.0), 0.0);
        assert!((missing_band_fraction(WeightingKind::Wk, 0.5) - 1.0).abs() < 1e-12);
        let at_25 = missing_band_fraction(WeightingKind::Wk, 25.0);
        assert!(at_25 > 0.05 && at_25 < 0.5, "{at_25}");
    }
}
