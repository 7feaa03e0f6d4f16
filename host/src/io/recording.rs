//! Recordings: the CSV files of support and sensor accelerations that datasets, `predict`,
//! `validate` and the ride tools read, as `docs/model.md#recording-format` defines them.
//!
//! The first line is exactly [`HEADER_LINE`]; every following line holds 13 finite numbers:
//! time in s, then accelerations in m/s^2 at the support (x, y, z) and at the head, torso and
//! pelvis sensors (x, y, z each). Time must increase strictly and uniformly: every step must
//! lie within [`UNIFORM_TOLERANCE`] (1 %) of the mean step. A 1 % timing jitter is a phase
//! error of at most 0.01 x 360 x f / fs degrees (0.3 degrees at 16 Hz and 200 Hz).
//!
//! A ride (what `supine ride` writes) holds only time and the platform columns
//! ([`PLATFORM_HEADER_LINE`]); [`read_input`] reads either kind through the same reader.
//!
//! Every error is one line naming the file, the line and column, and what was expected.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use serde::Serialize;

use crate::io::output::write_atomically;

/// The exact first line of a recording.
pub const HEADER_LINE: &str = "time_s,platform_x,platform_y,platform_z,head_x,head_y,head_z,torso_x,torso_y,torso_z,pelvis_x,pelvis_y,pelvis_z";

/// The 13 column names, in order.
pub const COLUMNS: [&str; 13] = [
    "time_s",
    "platform_x",
    "platform_y",
    "platform_z",
    "head_x",
    "head_y",
    "head_z",
    "torso_x",
    "torso_y",
    "torso_z",
    "pelvis_x",
    "pelvis_y",
    "pelvis_z",
];

/// Largest allowed deviation of one time step from the mean step, as a fraction of it.
pub const UNIFORM_TOLERANCE: f64 = 0.01;

/// Why a recording could not be read. Each variant prints as one line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RecordingError {
    /// The file is missing or unreadable.
    #[error("{path}: cannot read the recording: {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        reason: String,
    },
    /// The file has no header line.
    #[error("{path}: line 1: expected the header \"{HEADER_LINE}\", found an empty file")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// The header is not exactly [`HEADER_LINE`].
    #[error(
        "{path}: line 1, column {column}: expected the header field \"{expected}\", found \"{found}\" (the header must be exactly \"{HEADER_LINE}\")"
    )]
    Header {
        /// The file.
        path: PathBuf,
        /// 1-based position of the first differing field.
        column: usize,
        /// The field that should be there.
        expected: String,
        /// What is there.
        found: String,
    },
    /// A data line has the wrong number of cells.
    #[error("{path}: line {line}: expected 13 comma-separated cells, found {found}")]
    CellCount {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// How many cells the line has.
        found: usize,
    },
    /// A cell does not parse as a number.
    #[error("{path}: line {line}, column {column}: expected a number, found \"{found}\"")]
    NotANumber {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The column's name.
        column: &'static str,
        /// The cell's text.
        found: String,
    },
    /// A cell is NaN or infinite.
    #[error("{path}: line {line}, column {column}: expected a finite number, found \"{found}\"")]
    NotFinite {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The column's name.
        column: &'static str,
        /// The cell's text.
        found: String,
    },
    /// Time does not increase from one line to the next.
    #[error(
        "{path}: line {line}, column time_s: expected a time after {previous_s} s (strictly increasing), found {found_s} s"
    )]
    TimeNotIncreasing {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The time on the line before, s.
        previous_s: f64,
        /// The time on this line, s.
        found_s: f64,
    },
    /// One time step differs from the mean step by more than the tolerance.
    #[error(
        "{path}: line {line}, column time_s: expected uniform sampling, a step of {expected_s:.6e} s +- 1 %, found a step of {found_s:.6e} s"
    )]
    NotUniform {
        /// The file.
        path: PathBuf,
        /// 1-based line number of the step's second sample.
        line: usize,
        /// The mean step, s.
        expected_s: f64,
        /// This step, s.
        found_s: f64,
    },
    /// Fewer than two samples: no sample rate.
    #[error("{path}: expected at least 2 samples, found {found}")]
    TooShort {
        /// The file.
        path: PathBuf,
        /// How many samples there are.
        found: usize,
    },
}

/// A uniformly sampled recording of support and sensor accelerations, column-wise.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Where it was read from (names the file in later errors).
    pub path: PathBuf,
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// Support acceleration x, y, z, m/s^2.
    pub platform_m_s2: [Vec<f64>; 3],
    /// Sensor accelerations in H's output order (head x, y, z, torso ..., pelvis ...), m/s^2.
    pub sensors_m_s2: [Vec<f64>; 9],
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// The sample rate from the mean step, Hz (needs at least two samples).
    pub fn sample_rate_hz(&self) -> f64 {
        let n = self.time_s.len();
        if n < 2 {
            return f64::NAN;
        }
        (n - 1) as f64 / (self.time_s[n - 1] - self.time_s[0])
    }

    /// Duration from first to last sample plus one step, s.
    pub fn duration_s(&self) -> f64 {
        self.len() as f64 / self.sample_rate_hz()
    }

    /// The platform columns as the samples a device is streamed ([`device_samples`]).
    pub fn platform_samples(&self) -> Vec<[f32; 3]> {
        device_samples(&self.platform_m_s2)
    }

    /// Reads and checks a recording.
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        let text = std::fs::read_to_string(path).map_err(|e| RecordingError::Read {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        Self::parse(&text, path)
    }

    /// Parses a recording's text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, RecordingError> {
        let p = || path.to_path_buf();
        let mut lines = text.lines().enumerate();
        let header = match lines.next() {
            Some((_, h)) => h.trim_end_matches('\r'),
            None => return Err(RecordingError::Empty { path: p() }),
        };
        check_header(header, path)?;
        let mut rec = Recording {
            path: p(),
            time_s: Vec::new(),
            platform_m_s2: Default::default(),
            sensors_m_s2: Default::default(),
        };
        let mut row = [0.0f64; 13];
        let mut line_numbers = Vec::new();
        for (index, line) in lines {
            let line_no = index + 1;
            let line = line.trim_end_matches('\r');
            if line.trim().is_empty() {
                continue;
            }
            let mut count = 0;
            for (c, cell) in line.split(',').enumerate() {
                count += 1;
                if c >= 13 {
                    continue;
                }
                let cell = cell.trim();
                let value: f64 = cell.parse().map_err(|_| RecordingError::NotANumber {
                    path: p(),
                    line: line_no,
                    column: COLUMNS[c],
                    found: cell.to_string(),
                })?;
                if !value.is_finite() {
                    return Err(RecordingError::NotFinite {
                        path: p(),
                        line: line_no,
                        column: COLUMNS[c],
                        found: cell.to_string(),
                    });
                }
                row[c] = value;
            }
            if count != 13 {
                return Err(RecordingError::CellCount {
                    path: p(),
                    line: line_no,
                    found: count,
                });
            }
            let previous_s = rec.time_s.last().copied().unwrap_or(f64::NEG_INFINITY);
            if row[0] <= previous_s {
                return Err(RecordingError::TimeNotIncreasing {
                    path: p(),
                    line: line_no,
                    previous_s,
                    found_s: row[0],
                });
            }
            rec.push_row(&row);
            line_numbers.push(line_no);
        }
        rec.check_uniform(&line_numbers)?;
        Ok(rec)
    }

    fn push_row(&mut self, row: &[f64; 13]) {
        self.time_s.push(row[0]);
        for (axis, column) in self.platform_m_s2.iter_mut().enumerate() {
            column.push(row[1 + axis]);
        }
        for (output, column) in self.sensors_m_s2.iter_mut().enumerate() {
            column.push(row[4 + output]);
        }
    }

    /// Checks that every step is within [`UNIFORM_TOLERANCE`] of the mean step;
    /// `line_numbers` gives each sample's line in the file.
    fn check_uniform(&self, line_numbers: &[usize]) -> Result<(), RecordingError> {
        let n = self.time_s.len();
        if n < 2 {
            return Err(RecordingError::TooShort {
                path: self.path.clone(),
                found: n,
            });
        }
        let mean_step_s = (self.time_s[n - 1] - self.time_s[0]) / (n - 1) as f64;
        for k in 1..n {
            let step_s = self.time_s[k] - self.time_s[k - 1];
            if (step_s - mean_step_s).abs() > UNIFORM_TOLERANCE * mean_step_s {
                return Err(RecordingError::NotUniform {
                    path: self.path.clone(),
                    line: line_numbers.get(k).copied().unwrap_or(k + 2),
                    expected_s: mean_step_s,
                    found_s: step_s,
                });
            }
        }
        Ok(())
    }

    /// Builds a recording from uniformly sampled columns starting at t = 0.
    pub fn from_columns(
        path: PathBuf,
        sample_rate_hz: f64,
        platform_m_s2: [Vec<f64>; 3],
        sensors_m_s2: [Vec<f64>; 9],
    ) -> Self {
        let n = platform_m_s2[0].len();
        Self {
            path,
            time_s: (0..n).map(|k| k as f64 / sample_rate_hz).collect(),
            platform_m_s2,
            sensors_m_s2,
        }
    }

    /// Writes the recording as CSV through a temporary file (complete or not at all).
    ///
    /// Numbers are written in Rust's shortest round-trip form, so reading gives them back
    /// bit for bit.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomically(path, |w| {
            writeln!(w, "{HEADER_LINE}")?;
            let mut line = String::with_capacity(256);
            for k in 0..self.len() {
                line.clear();
                line.push_str(&format!("{}", self.time_s[k]));
                for column in self.platform_m_s2.iter().chain(self.sensors_m_s2.iter()) {
                    line.push(',');
                    line.push_str(&format!("{}", column[k]));
                }
                writeln!(w, "{line}")?;
            }
            Ok(())
        })
    }
}

/// Platform accelerations x, y, z (m/s^2, one column each) as the device's samples: one
/// f32 triple per instant, as the wire protocol carries them.
pub fn device_samples(platform_m_s2: &[Vec<f64>; 3]) -> Vec<[f32; 3]> {
    let n = platform_m_s2.iter().map(Vec::len).min().unwrap_or(0);
    (0..n)
        .map(|k| platform_m_s2.each_ref().map(|c| c[k] as f32))
        .collect()
}

/// The header of a recording that holds only the support (platform) accelerations.
pub const PLATFORM_HEADER_LINE: &str = "time_s,platform_x,platform_y,platform_z";

/// Which columns a recording file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Layout {
    /// All 13 columns of the recording format.
    Full,
    /// Time and the three platform columns only ([`PLATFORM_HEADER_LINE`]).
    PlatformOnly,
}

/// Reads a recording through [`Recording::parse`], accepting also a platform-only file.
///
/// A platform-only file is handed to the reader line for line with nine zero cells appended
/// to every data line, so line numbers, column names and every check (numbers, finiteness,
/// strictly increasing and uniform time) are the reader's own; only the cell count is
/// restated for four columns.
pub fn read_input(path: &Path) -> Result<(Recording, Layout)> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow!("{}: cannot read the recording: {e}", path.display()))?;
    let first = text.lines().next().map(|l| l.trim_end_matches('\r'));
    if first != Some(PLATFORM_HEADER_LINE) {
        return Ok((Recording::parse(&text, path)?, Layout::Full));
    }
    let mut padded = String::with_capacity(text.len() * 2);
    padded.push_str(HEADER_LINE);
    padded.push('\n');
    for line in text.lines().skip(1) {
        let line = line.trim_end_matches('\r');
        padded.push_str(line);
        if !line.trim().is_empty() {
            padded.push_str(",0,0,0,0,0,0,0,0,0");
        }
        padded.push('\n');
    }
    match Recording::parse(&padded, path) {
        Ok(rec) => Ok((rec, Layout::PlatformOnly)),
        Err(RecordingError::CellCount { path, line, found }) => Err(anyhow!(
            "{}: line {line}: expected 4 comma-separated cells (header \"{PLATFORM_HEADER_LINE}\"), found {}",
            path.display(),
            found.saturating_sub(9)
        )),
        Err(e) => Err(e.into()),
    }
}

fn check_header(header: &str, path: &Path) -> Result<(), RecordingError> {
    if header == HEADER_LINE {
        return Ok(());
    }
    let found: Vec<&str> = header.split(',').collect();
    for (i, expected) in COLUMNS.iter().enumerate() {
        let cell = found.get(i).copied().unwrap_or("");
        if cell != *expected {
            return Err(RecordingError::Header {
                path: path.to_path_buf(),
                column: i + 1,
                expected: (*expected).to_string(),
                found: if found.get(i).is_some() {
                    cell.to_string()
                } else {
                    "end of line".to_string()
                },
            });
        }
    }
    Err(RecordingError::Header {
        path: path.to_path_buf(),
        column: 14,
        expected: "end of line".to_string(),
        found: found[13..].join(","),
    })
}
