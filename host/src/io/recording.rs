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
//! Files are read line by line ([`crate::io::csv_lines`]): a line is at most
//! [`MAX_LINE_BYTES`](crate::io::csv_lines::MAX_LINE_BYTES) long, a UTF-8 byte order mark
//! and CRLF line ends are accepted, blank lines are skipped. Accelerations must lie within
//! the f32 range ([`MAX_ACCELERATION_M_S2`]), where the device computes.
//!
//! Every error is one line naming the file, the line and column, and what was expected.

use std::io::{Read, Write as _};
use std::path::{Path, PathBuf};

use anyhow::Result;
use serde::Serialize;

use crate::io::csv_lines::{CsvLines, LineError, Row};
use crate::io::excerpt::{excerpt, number};
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

/// Why a recording could not be read. Each variant prints as one line; cells from the file
/// are quoted through [`excerpt`] (at most 80 characters, escaped).
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
    #[error("{path}: line 1: expected a recording's header, found an empty file")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// The header is not exactly [`HEADER_LINE`] (or [`PLATFORM_HEADER_LINE`] where a ride
    /// is accepted).
    #[error(
        "{path}: line 1, column {column}: expected the header field \"{expected}\", found {found}"
    )]
    Header {
        /// The file.
        path: PathBuf,
        /// 1-based position of the first differing field.
        column: usize,
        /// The field that should be there.
        expected: String,
        /// What is there, quoted ([`excerpt`]) or `end of line`.
        found: String,
    },
    /// A line is longer than any line of a recording can be.
    #[error("{path}: {source} (a recording's line holds 13 numbers)")]
    Line {
        /// The file.
        path: PathBuf,
        /// The line and the limit.
        source: LineError,
    },
    /// A data line has the wrong number of cells.
    #[error("{path}: line {line}: expected {expected} comma-separated cells, found {found}")]
    CellCount {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// How many cells the header has.
        expected: usize,
        /// How many cells the line has.
        found: usize,
    },
    /// A cell does not parse as a number.
    #[error("{path}: line {line}, column {column}: expected a number, found {found}")]
    NotANumber {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// The column's name.
        column: &'static str,
        /// The cell, quoted ([`excerpt`]).
        found: String,
    },
    /// A cell is NaN or infinite.
    #[error("{path}: line {line}, column {column}: expected a finite number, found {found}")]
    NotFinite {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// The column's name.
        column: &'static str,
        /// The cell, quoted ([`excerpt`]).
        found: String,
    },
    /// An acceleration is finite in f64 but beyond the f32 range the device and the host's
    /// device pipeline compute in, where it would become infinite.
    #[error(
        "{path}: line {line}, column {column}: expected an acceleration within the f32 range the device computes in (+-{MAX_ACCELERATION_M_S2:.1e} m/s^2), found {found}"
    )]
    OutOfRange {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// The column's name.
        column: &'static str,
        /// The cell, quoted ([`excerpt`]).
        found: String,
    },
    /// Time does not increase from one line to the next.
    #[error(
        "{path}: line {line}, column time_s: expected a time after {} s (strictly increasing), found {} s",
        number(*previous_s),
        number(*found_s)
    )]
    TimeNotIncreasing {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
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
        line: u64,
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

/// Largest acceleration magnitude a recording may hold, m/s^2: the largest finite f32, so
/// that every acceleration stays finite as the device's f32 sample (a sensor's full scale
/// is far below; the device's sensor check reports saturation from there).
pub const MAX_ACCELERATION_M_S2: f64 = f32::MAX as f64;

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

    /// Reads and checks a recording (all 13 columns), streaming: memory holds the samples,
    /// never more than one line of text.
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        read_layouts(path, &[Layout::Full]).map(|(recording, _)| recording)
    }

    /// Reads and checks a recording from `source` in one of the `accepted` layouts (the
    /// header decides which); `path` names it in errors.
    pub fn from_reader(
        source: impl Read,
        path: &Path,
        accepted: &[Layout],
    ) -> Result<(Self, Layout), RecordingError> {
        let p = || path.to_path_buf();
        let line_error = |source: LineError| match source {
            LineError::Read(reason) => RecordingError::Read { path: p(), reason },
            source => RecordingError::Line { path: p(), source },
        };
        let mut lines = CsvLines::new(source);
        let layout = match lines.next_row().map_err(line_error)? {
            Some(header) => check_header(&header, path, accepted)?,
            None => return Err(RecordingError::Empty { path: p() }),
        };
        let columns = layout.columns();
        let mut rec = Recording {
            path: p(),
            time_s: Vec::new(),
            platform_m_s2: Default::default(),
            sensors_m_s2: Default::default(),
        };
        let mut row = [0.0f64; 13];
        let mut lines_of = LineNumbers::default();
        while let Some(cells) = lines.next_row().map_err(line_error)? {
            let line = cells.line;
            if cells.len() != columns {
                return Err(RecordingError::CellCount {
                    path: p(),
                    line,
                    expected: columns,
                    found: cells.len(),
                });
            }
            for (c, cell) in cells.cells().enumerate() {
                row[c] = parse_cell(cell, COLUMNS[c]).map_err(|e| e.at(p(), line))?;
            }
            let previous_s = rec.time_s.last().copied().unwrap_or(f64::NEG_INFINITY);
            if row[0] <= previous_s {
                return Err(RecordingError::TimeNotIncreasing {
                    path: p(),
                    line,
                    previous_s,
                    found_s: row[0],
                });
            }
            lines_of.push(rec.time_s.len(), line);
            rec.push_row(&row);
        }
        rec.check_uniform(&lines_of)?;
        Ok((rec, layout))
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
    /// `lines_of` gives each sample's line in the file.
    fn check_uniform(&self, lines_of: &LineNumbers) -> Result<(), RecordingError> {
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
                    line: lines_of.line_of(k),
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

impl Layout {
    /// How many columns a line holds: the first this many of [`COLUMNS`].
    pub const fn columns(self) -> usize {
        match self {
            Layout::Full => COLUMNS.len(),
            Layout::PlatformOnly => 4,
        }
    }
}

/// Reads a recording in either layout: all 13 columns, or a ride's platform columns (the
/// sensor columns are then zeros).
pub fn read_input(path: &Path) -> Result<(Recording, Layout)> {
    Ok(read_layouts(path, &[Layout::Full, Layout::PlatformOnly])?)
}

fn read_layouts(path: &Path, accepted: &[Layout]) -> Result<(Recording, Layout), RecordingError> {
    let file = std::fs::File::open(path).map_err(|e| RecordingError::Read {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    Recording::from_reader(file, path, accepted)
}

/// Which of the `accepted` layouts the header names, or where it first differs from the
/// full header.
fn check_header(
    header: &Row<'_>,
    path: &Path,
    accepted: &[Layout],
) -> Result<Layout, RecordingError> {
    for layout in accepted {
        let names = &COLUMNS[..layout.columns()];
        if header.len() == names.len() && header.cells().zip(names).all(|(c, n)| c == n.as_bytes())
        {
            return Ok(*layout);
        }
    }
    let mismatch = |column: usize, expected: &str, found: String| RecordingError::Header {
        path: path.to_path_buf(),
        column,
        expected: expected.to_string(),
        found,
    };
    for (i, expected) in COLUMNS.iter().enumerate() {
        if i >= header.len() {
            return Err(mismatch(i + 1, expected, "end of line".to_string()));
        }
        if header.cell(i) != expected.as_bytes() {
            return Err(mismatch(i + 1, expected, excerpt(header.cell(i))));
        }
    }
    Err(mismatch(14, "end of line", excerpt(header.cell(13))))
}

/// What is wrong with one cell, before the line and the path are known.
enum CellError {
    NotANumber(&'static str, String),
    NotFinite(&'static str, String),
    OutOfRange(&'static str, String),
}

impl CellError {
    fn at(self, path: PathBuf, line: u64) -> RecordingError {
        match self {
            CellError::NotANumber(column, found) => RecordingError::NotANumber {
                path,
                line,
                column,
                found,
            },
            CellError::NotFinite(column, found) => RecordingError::NotFinite {
                path,
                line,
                column,
                found,
            },
            CellError::OutOfRange(column, found) => RecordingError::OutOfRange {
                path,
                line,
                column,
                found,
            },
        }
    }
}

/// One cell of `column` as a number: finite, and within the f32 range for accelerations.
fn parse_cell(cell: &[u8], column: &'static str) -> Result<f64, CellError> {
    let value: f64 = std::str::from_utf8(cell)
        .ok()
        .and_then(|text| text.trim().parse().ok())
        .ok_or_else(|| CellError::NotANumber(column, excerpt(cell)))?;
    if !value.is_finite() {
        return Err(CellError::NotFinite(column, excerpt(cell)));
    }
    if column != COLUMNS[0] && value.abs() > MAX_ACCELERATION_M_S2 {
        return Err(CellError::OutOfRange(column, excerpt(cell)));
    }
    Ok(value)
}

/// The line of each sample, held as the points where lines stop following samples one
/// to one (after blank lines), so that it costs nothing for a file without blank lines.
#[derive(Default)]
struct LineNumbers {
    /// (first sample, its line) of each run of consecutive lines.
    runs: Vec<(usize, u64)>,
}

impl LineNumbers {
    fn push(&mut self, sample: usize, line: u64) {
        if self
            .runs
            .last()
            .is_none_or(|&(k, l)| l + (sample - k) as u64 != line)
        {
            self.runs.push((sample, line));
        }
    }

    fn line_of(&self, sample: usize) -> u64 {
        let run = self.runs.partition_point(|&(k, _)| k <= sample);
        match run.checked_sub(1).map(|r| self.runs[r]) {
            Some((k, line)) => line + (sample - k) as u64,
            None => sample as u64 + 2,
        }
    }
}
