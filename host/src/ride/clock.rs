//! The time column of a ride, in whatever form a logger writes it: a number in s, ms, us
//! or ns ([`TimeUnit`]), or date-time text ([`TimeUnit::Text`]).
//!
//! Text times are read in the forms real phone apps write (found in public exports):
//! ISO 8601 / RFC 3339 (`2024-06-10T14:45:36.872Z`, `...+02:00`), a date and a clock
//! time with a space (`2018-10-03 17:23:55.4640`, Physics Toolbox on iOS), and clock
//! times alone (`17:23:55.464`, `17:23:55:464` with the milliseconds after a colon, and
//! `23:55.464` minutes and seconds). Dates are read by the `time` crate; a clock time
//! without a date is a few fields, read here. A clock time that goes back by more than
//! 12 h is taken to have passed midnight.
//!
//! Times are returned in seconds since the file's first time where the column counts
//! from an arbitrary origin (integers in ns or us, whose epoch values lose their
//! nanoseconds in an f64; date-time text), and as written otherwise (s, ms), so a ride's
//! own `time_s` reads as it is.

use clap::ValueEnum;
use time::format_description::well_known::Rfc3339;
use time::macros::format_description;
use time::{OffsetDateTime, PrimitiveDateTime};

/// Nanoseconds in a day, for clock times that pass midnight.
const DAY_NS: i128 = 86_400 * 1_000_000_000;

/// Unit (or form) of the time column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum TimeUnit {
    /// Seconds.
    #[default]
    S,
    /// Milliseconds.
    Ms,
    /// Microseconds.
    Us,
    /// Nanoseconds (Android's `uptimeNanos`, Sensor Logger's `time`).
    Ns,
    /// Date-time or clock-time text (ISO 8601, `YYYY-MM-DD HH:MM:SS.f`, `HH:MM:SS.f`).
    Text,
}

impl TimeUnit {
    /// Seconds per unit (1 for text, whose value is already in s).
    pub const fn to_s(self) -> f64 {
        match self {
            TimeUnit::S | TimeUnit::Text => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
            TimeUnit::Ns => 1e-9,
        }
    }

    /// What a cell of this unit is, as errors say it.
    pub fn expected(self) -> &'static str {
        match self {
            TimeUnit::S => "a time in s",
            TimeUnit::Ms => "a time in ms",
            TimeUnit::Us => "a time in us",
            TimeUnit::Ns => "a time in ns",
            TimeUnit::Text => "a date-time (ISO 8601) or clock time (HH:MM:SS.f)",
        }
    }
}

/// Reads one time column's cells into seconds, keeping the origin of relative clocks.
#[derive(Clone, Debug)]
pub struct Clock {
    unit: TimeUnit,
    /// The first integer time (us, ns), subtracted exactly before the conversion to s.
    integer_origin: Option<i128>,
    /// The first text time, ns since its day's or the epoch's start.
    text_origin_ns: Option<i128>,
    /// Days added to clock times that passed midnight, ns.
    midnights_ns: i128,
    previous_text_ns: Option<i128>,
}

impl Clock {
    /// A clock for cells in `unit`.
    pub fn new(unit: TimeUnit) -> Self {
        Self {
            unit,
            integer_origin: None,
            text_origin_ns: None,
            midnights_ns: 0,
            previous_text_ns: None,
        }
    }

    /// The unit read.
    pub fn unit(&self) -> TimeUnit {
        self.unit
    }

    /// The time of `cell`, s; `None` when it is not a time of this clock's form.
    pub fn seconds(&mut self, cell: &str) -> Option<f64> {
        CellTime::read(self.unit, cell).map(|t| self.place(t))
    }

    /// The time of a cell read by [`CellTime::read`] (in this clock's unit), s, its
    /// origin and midnights counted from the cells placed before it.
    pub fn place(&mut self, time: CellTime) -> f64 {
        match time {
            CellTime::Seconds(s) => s,
            CellTime::Count(i) => {
                let origin = *self.integer_origin.get_or_insert(i);
                (i - origin) as f64 * self.unit.to_s()
            }
            CellTime::DecimalCount(v) => {
                let origin = *self.integer_origin.get_or_insert(v as i128);
                (v - origin as f64) * self.unit.to_s()
            }
            CellTime::Text { ns: raw_ns, dated } => {
                let mut ns = raw_ns;
                if !dated {
                    if let Some(previous) = self.previous_text_ns
                        && raw_ns + self.midnights_ns < previous - DAY_NS / 2
                    {
                        self.midnights_ns += DAY_NS;
                    }
                    ns += self.midnights_ns;
                }
                self.previous_text_ns = Some(ns);
                let origin = *self.text_origin_ns.get_or_insert(ns);
                (ns - origin) as f64 * 1e-9
            }
        }
    }
}

/// A time cell as read, before a [`Clock`] places it on the ride's time line: reading
/// depends on the cell alone, so a file's lines can be read on several threads and placed
/// in order after.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CellTime {
    /// A time in s (a cell in s or ms).
    Seconds(f64),
    /// An integer count of us or ns.
    Count(i128),
    /// A decimal count of us or ns (some exports write ns as floats).
    DecimalCount(f64),
    /// Date-time text (`dated`, ns since the Unix epoch) or a clock time (ns since the
    /// day's start).
    Text {
        /// Nanoseconds.
        ns: i128,
        /// Whether the text has a date.
        dated: bool,
    },
}

impl CellTime {
    /// `cell` as a time in `unit`; `None` when it is not one.
    pub fn read(unit: TimeUnit, cell: &str) -> Option<Self> {
        let cell = cell.trim();
        match unit {
            TimeUnit::S | TimeUnit::Ms => fast_float2::parse::<f64, _>(cell)
                .ok()
                .filter(|v| v.is_finite())
                .map(|v| CellTime::Seconds(v * unit.to_s())),
            TimeUnit::Us | TimeUnit::Ns => {
                if let Ok(i) = cell.parse::<i128>() {
                    return Some(CellTime::Count(i));
                }
                fast_float2::parse::<f64, _>(cell)
                    .ok()
                    .filter(|v| v.is_finite())
                    .map(CellTime::DecimalCount)
            }
            TimeUnit::Text => parse_text_ns(cell).map(|(ns, dated)| CellTime::Text { ns, dated }),
        }
    }
}

/// Whether `cell` looks like date-time or clock-time text (a `:` or a date's `-` between
/// digits), so that a header's time column can be told apart from a number.
pub fn looks_like_text_time(cell: &str) -> bool {
    let cell = cell.trim();
    cell.contains(':') || (cell.len() >= 10 && cell.as_bytes()[4] == b'-')
}

/// Nanoseconds of a text time: since the Unix epoch for a date-time (`true`), since the
/// day's start for a clock time (`false`).
fn parse_text_ns(cell: &str) -> Option<(i128, bool)> {
    if cell.len() >= 10 && cell.as_bytes().get(4) == Some(&b'-') {
        return parse_date_time_ns(cell).map(|ns| (ns, true));
    }
    parse_clock_s(cell).map(|s| ((s * 1e9).round() as i128, false))
}

/// A date and time, ns since the Unix epoch: RFC 3339 with its offset, else a local
/// date-time (`T` or a space between date and time, fraction optional) taken as UTC.
fn parse_date_time_ns(cell: &str) -> Option<i128> {
    let unix = |t: OffsetDateTime| t.unix_timestamp_nanos();
    if let Ok(t) = OffsetDateTime::parse(cell, &Rfc3339) {
        return Some(unix(t));
    }
    let with_fraction = format_description!(
        "[year]-[month]-[day][first [T][ ]][hour]:[minute]:[second].[subsecond]"
    );
    let whole = format_description!("[year]-[month]-[day][first [T][ ]][hour]:[minute]:[second]");
    let local = cell.strip_suffix('Z').unwrap_or(cell);
    PrimitiveDateTime::parse(local, &with_fraction)
        .or_else(|_| PrimitiveDateTime::parse(local, &whole))
        .ok()
        .map(|t| unix(t.assume_utc()))
}

/// A clock time, s since the day's start: `HH:MM:SS[.f]`, `HH:MM:SS:mmm` (milliseconds
/// after a third colon) or `MM:SS[.f]`.
fn parse_clock_s(cell: &str) -> Option<f64> {
    let parts: Vec<&str> = cell.split(':').collect();
    let int = |p: &str, max: u32| {
        (!p.is_empty() && p.len() <= 2 && p.bytes().all(|b| b.is_ascii_digit()))
            .then(|| p.parse::<u32>().ok())
            .flatten()
            .filter(|v| *v <= max)
            .map(f64::from)
    };
    let seconds = |p: &str| {
        let (whole, fraction) = p.split_once('.').unwrap_or((p, ""));
        let s = int(whole, 60)?;
        if fraction.is_empty() {
            return (!p.ends_with('.')).then_some(s);
        }
        if !fraction.bytes().all(|b| b.is_ascii_digit()) || fraction.len() > 9 {
            return None;
        }
        let f: f64 = format!("0.{fraction}").parse().ok()?;
        Some(s + f)
    };
    match parts.as_slice() {
        [m, s] => Some(int(m, 59)? * 60.0 + seconds(s)?),
        [h, m, s] => Some(int(h, 23)? * 3600.0 + int(m, 59)? * 60.0 + seconds(s)?),
        [h, m, s, ms] if ms.len() == 3 && ms.bytes().all(|b| b.is_ascii_digit()) => Some(
            int(h, 23)? * 3600.0
                + int(m, 59)? * 60.0
                + int(s, 60)?
                + f64::from(ms.parse::<u32>().ok()?) * 1e-3,
        ),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(unit: TimeUnit, cells: &[&str]) -> Vec<Option<f64>> {
        let mut clock = Clock::new(unit);
        cells.iter().map(|c| clock.seconds(c)).collect()
    }

    fn close(a: &[Option<f64>], b: &[f64]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            let x = x.unwrap_or_else(|| panic!("{a:?}"));
            assert!((x - y).abs() < 1e-9, "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn nanosecond_epochs_keep_their_nanoseconds() {
        // Sensor Logger's `time` column: ns since the Unix epoch.
        let t = times(
            TimeUnit::Ns,
            &[
                "1718030736872695300",
                "1718030736877695301",
                "1718030736882695299",
            ],
        );
        close(&t, &[0.0, 0.005000001, 0.009999999]);
        close(
            &times(TimeUnit::Us, &["5000000", "5000250"]),
            &[0.0, 0.00025],
        );
        close(&times(TimeUnit::Ms, &["2", "4"]), &[0.002, 0.004]);
    }

    #[test]
    fn text_times_in_the_forms_apps_write() {
        close(
            &times(
                TimeUnit::Text,
                &[
                    "2018-10-03 17:23:55.4640",
                    "2018-10-03 17:23:55.4650",
                    "2018-10-03T17:23:56",
                ],
            ),
            &[0.0, 0.001, 0.536],
        );
        close(
            &times(
                TimeUnit::Text,
                &["2024-06-10T14:45:36.872Z", "2024-06-10T16:45:36.882+02:00"],
            ),
            &[0.0, 0.010],
        );
        close(
            &times(
                TimeUnit::Text,
                &["23:59:59.990", "23:59:59:995", "00:00:00.005"],
            ),
            &[0.0, 0.005, 0.015],
        );
        close(
            &times(TimeUnit::Text, &["05:12.250", "05:12.300"]),
            &[0.0, 0.05],
        );
        for bad in ["12:61:00", "2018-13-03 17:23:55", "abc", "1.5", "12:00:00."] {
            assert_eq!(times(TimeUnit::Text, &[bad]), [None], "{bad}");
        }
    }
}
