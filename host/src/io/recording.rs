//! Recordings: the CSV files of support and sensor accelerations that datasets, `predict`,
//! `validate` and the ride tools read, as `docs/model.md#recording-format` defines them.
//!
//! The first line is [`HEADER_LINE`] ([`COLUMNS`], units in the names), or the same names
//! without their unit ([`OLD_COLUMNS`]) in files written before the columns carried it;
//! every following line holds 13 finite numbers:
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

use crate::io::csv_lines::{CsvLines, Line, LineError, Row};
use crate::io::excerpt::{excerpt, number};
use crate::io::output::write_atomically;

/// The first line of a recording, as the tools write it: [`COLUMNS`].
pub const HEADER_LINE: &str = "time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2,head_x_m_s2,head_y_m_s2,head_z_m_s2,torso_x_m_s2,torso_y_m_s2,torso_z_m_s2,pelvis_x_m_s2,pelvis_y_m_s2,pelvis_z_m_s2";

/// The 13 column names, in order, units in the names: time in s, accelerations in m/s^2.
pub const COLUMNS: [&str; 13] = [
    "time_s",
    "platform_x_m_s2",
    "platform_y_m_s2",
    "platform_z_m_s2",
    "head_x_m_s2",
    "head_y_m_s2",
    "head_z_m_s2",
    "torso_x_m_s2",
    "torso_y_m_s2",
    "torso_z_m_s2",
    "pelvis_x_m_s2",
    "pelvis_y_m_s2",
    "pelvis_z_m_s2",
];

/// The column names of files written before the accelerations' columns carried their unit
/// (`platform_x`, `head_x`, ...): the same columns in the same order, still read.
pub const OLD_COLUMNS: [&str; 13] = [
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

/// A naming of the 13 recording columns: [`COLUMNS`] or [`OLD_COLUMNS`].
type Naming = &'static [&'static str; 13];

/// The namings a recording's header may use: today's, then the one before units.
const NAMINGS: [Naming; 2] = [&COLUMNS, &OLD_COLUMNS];

/// Whether `header` names the 13 recording columns, in either naming ([`COLUMNS`],
/// [`OLD_COLUMNS`]).
pub fn is_recording_header<S: AsRef<[u8]>>(header: &[S]) -> bool {
    NAMINGS.iter().any(|naming| {
        header.len() == naming.len()
            && header
                .iter()
                .zip(naming.iter())
                .all(|(h, c)| h.as_ref() == c.as_bytes())
    })
}

/// The index (0-based, in [`COLUMNS`]) of the recording column called `name` in either
/// naming (`head_x_m_s2`, or `head_x` as before units).
pub fn column_index(name: &str) -> Option<usize> {
    NAMINGS
        .iter()
        .find_map(|naming| naming.iter().position(|c| *c == name))
}

/// The joint columns `supine predict` adds after the 13 recording columns: the predicted
/// neck and lower-back motion (`docs/model.md`, "Joint motion"), translations in mm and
/// rotations in degrees, in `JointOutput::ALL` order: each output's name and its
/// [`JointUnit::display`](supine_core::model::JointUnit::display) unit (a test holds them
/// to it).
pub const PREDICTED_JOINT_COLUMNS: [&str; 10] = [
    "neck_x_mm",
    "neck_y_mm",
    "neck_z_mm",
    "neck_ry_deg",
    "neck_rz_deg",
    "low_back_x_mm",
    "low_back_y_mm",
    "low_back_z_mm",
    "low_back_ry_deg",
    "low_back_rz_deg",
];

/// The name of column `c` (0-based) of a file in the prediction layout, the widest, in
/// `naming` ([`NAMINGS`]).
fn column_name(naming: Naming, c: usize) -> &'static str {
    match c.checked_sub(naming.len()) {
        None => naming[c],
        Some(j) => PREDICTED_JOINT_COLUMNS.get(j).copied().unwrap_or("(none)"),
    }
}

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

    /// Reads and checks a recording (all 13 columns; a prediction's joint columns after
    /// them are checked and left out), streaming: memory holds the samples, never more
    /// than one line of text.
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        read_layouts(path, &[Layout::Full, Layout::Prediction]).map(|(recording, _)| recording)
    }

    /// Reads and checks a recording from `source` in one of the `accepted` layouts (the
    /// header decides which); `path` names it in errors.
    pub fn from_reader(
        source: impl Read,
        path: &Path,
        accepted: &[Layout],
    ) -> Result<(Self, Layout), RecordingError> {
        let mut rows = RowReader::new(source, path, accepted)?;
        let mut rec = Recording {
            path: path.to_path_buf(),
            time_s: Vec::new(),
            platform_m_s2: Default::default(),
            sensors_m_s2: Default::default(),
        };
        let mut lines_of = LineNumbers::default();
        while let Some((line, row)) = rows.next_row()? {
            lines_of.push(rec.time_s.len(), line);
            rec.push_row(&row);
        }
        rec.check_uniform(&lines_of)?;
        Ok((rec, rows.layout))
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
    pub(crate) fn check_uniform(&self, lines_of: &LineNumbers) -> Result<(), RecordingError> {
        let n = self.time_s.len();
        let uniform = Uniform::new(&self.path, n, self.time_s.first(), self.time_s.last())?;
        for k in 1..n {
            uniform.check(lines_of.line_of(k), self.time_s[k] - self.time_s[k - 1])?;
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

/// The header of a recording that holds only the support (platform) accelerations: the
/// first four of [`COLUMNS`].
pub const PLATFORM_HEADER_LINE: &str = "time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2";

/// Which columns a recording file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Layout {
    /// All 13 columns of the recording format.
    Full,
    /// Time and the three platform columns only ([`PLATFORM_HEADER_LINE`]).
    PlatformOnly,
    /// What `supine predict` writes: the 13 columns, then [`PREDICTED_JOINT_COLUMNS`].
    Prediction,
}

impl Layout {
    /// How many columns a line holds: the first this many of [`COLUMNS`] followed by
    /// [`PREDICTED_JOINT_COLUMNS`].
    pub const fn columns(self) -> usize {
        match self {
            Layout::Full => COLUMNS.len(),
            Layout::PlatformOnly => 4,
            Layout::Prediction => COLUMNS.len() + PREDICTED_JOINT_COLUMNS.len(),
        }
    }
}

/// The uniform-sampling check: every step within [`UNIFORM_TOLERANCE`] of the mean step.
pub(crate) struct Uniform<'a> {
    path: &'a Path,
    mean_step_s: f64,
}

impl<'a> Uniform<'a> {
    /// The check for `samples` samples from `first_s` to `last_s`; at least two are needed.
    pub(crate) fn new(
        path: &'a Path,
        samples: usize,
        first_s: Option<&f64>,
        last_s: Option<&f64>,
    ) -> Result<Self, RecordingError> {
        match (first_s, last_s) {
            (Some(first_s), Some(last_s)) if samples >= 2 => Ok(Self {
                path,
                mean_step_s: (last_s - first_s) / (samples - 1) as f64,
            }),
            _ => Err(RecordingError::TooShort {
                path: path.to_path_buf(),
                found: samples,
            }),
        }
    }

    /// Checks the step that ends on `line`.
    pub(crate) fn check(&self, line: u64, step_s: f64) -> Result<(), RecordingError> {
        if (step_s - self.mean_step_s).abs() > UNIFORM_TOLERANCE * self.mean_step_s {
            return Err(RecordingError::NotUniform {
                path: self.path.to_path_buf(),
                line,
                expected_s: self.mean_step_s,
                found_s: step_s,
            });
        }
        Ok(())
    }
}

/// The data rows of a recording file, parsed and checked one line at a time: the header
/// decides the layout, every cell must be a number in range, time must increase.
struct RowReader<R: Read> {
    lines: CsvLines<R>,
    path: PathBuf,
    layout: Layout,
    /// The header's naming, which errors name a cell's column in.
    naming: Naming,
    previous_s: f64,
}

impl<R: Read> RowReader<R> {
    /// Reads the header of `source` (in one of the `accepted` layouts).
    fn new(source: R, path: &Path, accepted: &[Layout]) -> Result<Self, RecordingError> {
        let mut lines = CsvLines::new(source);
        let (layout, naming) = match lines.next_row().map_err(|e| line_error(path, e))? {
            Some(header) => check_header(&header, path, accepted)?,
            None => {
                return Err(RecordingError::Empty {
                    path: path.to_path_buf(),
                });
            }
        };
        Ok(Self {
            lines,
            path: path.to_path_buf(),
            layout,
            naming,
            previous_s: f64::NEG_INFINITY,
        })
    }

    /// The next row's line and its 13 numbers (the sensor columns zero in a ride).
    fn next_row(&mut self) -> Result<Option<(u64, [f64; 13])>, RecordingError> {
        let Some(text) = self
            .lines
            .next_line()
            .map_err(|e| line_error(&self.path, e))?
        else {
            return Ok(None);
        };
        let line = text.line;
        let columns = self.layout.columns();
        let row = match plain_row(&text, columns, self.naming) {
            Some(row) => row,
            None => split_row(&self.path, text.split(), columns, self.naming)?,
        };
        if row[0] <= self.previous_s {
            return Err(RecordingError::TimeNotIncreasing {
                path: self.path.clone(),
                line,
                previous_s: self.previous_s,
                found_s: row[0],
            });
        }
        self.previous_s = row[0];
        Ok(Some((line, row)))
    }
}

/// A line's 13 numbers, cell by cell, with every check and error of the format (naming
/// each cell's column as the header does).
fn split_row(
    path: &Path,
    cells: Row,
    columns: usize,
    naming: Naming,
) -> Result<[f64; 13], RecordingError> {
    let line = cells.line;
    if cells.len() != columns {
        return Err(RecordingError::CellCount {
            path: path.to_path_buf(),
            line,
            expected: columns,
            found: cells.len(),
        });
    }
    let mut row = [0.0f64; 13];
    for (c, cell) in cells.cells().enumerate() {
        let value =
            parse_cell(cell, column_name(naming, c)).map_err(|e| e.at(path.to_path_buf(), line))?;
        if let Some(slot) = row.get_mut(c) {
            *slot = value;
        }
    }
    Ok(row)
}

/// The fast path of [`split_row`] for the line every writer of the format writes: exactly
/// `columns` plain numbers, each followed by a comma (the last by the line end, or a CR
/// before it), in range. It parses each number where it starts and checks that a comma
/// follows, so the line is walked once instead of split first. Such a line gives the same
/// numbers either way: `fast-float2`'s whole-cell parse, the one [`parse_number`] tries
/// first, is this partial parse required to end where the cell does, and a cell that
/// begins and ends with a number's own characters is unchanged by trimming. Anything else
/// (white space around a number, infinity, a missing cell, a number out of range, a first
/// line's byte order mark) is None, and [`split_row`] reads the line and names what is
/// wrong.
fn plain_row(line: &Line, columns: usize, naming: Naming) -> Option<[f64; 13]> {
    if line.is_first() {
        return None;
    }
    let mut rest = line.text();
    let mut row = [0.0f64; 13];
    for c in 0..columns {
        let (value, used) = fast_float2::parse_partial::<f64, _>(rest).ok()?;
        let cell = &rest[..used];
        check_value(value, cell, column_name(naming, c)).ok()?;
        if let Some(slot) = row.get_mut(c) {
            *slot = value;
        }
        rest = match (&rest[used..], c + 1 == columns) {
            ([b',', tail @ ..], false) => tail,
            ([] | [b'\r'], true) => &[],
            _ => return None,
        };
    }
    Some(row)
}

fn line_error(path: &Path, error: LineError) -> RecordingError {
    match error {
        LineError::Read(reason) => RecordingError::Read {
            path: path.to_path_buf(),
            reason,
        },
        source => RecordingError::Line {
            path: path.to_path_buf(),
            source,
        },
    }
}

/// A recording's platform columns streamed from its file, for a ride of any length
/// (`supine replay`): memory holds a line, not the ride.
///
/// Opening reads the file twice, for every check [`read_input`] makes (the second pass
/// checks each step against the mean step the first found); each [`samples`](Self::samples)
/// reads it once more.
#[derive(Clone, Debug, PartialEq)]
pub struct PlatformStream {
    path: PathBuf,
    layout: Layout,
    samples: usize,
    first_s: f64,
    last_s: f64,
}

impl PlatformStream {
    /// Checks the file at `path` (either layout) and finds its length and rate.
    pub fn open(path: &Path) -> Result<Self, RecordingError> {
        let mut rows = open_rows(path)?;
        let (mut samples, mut first_s, mut last_s) = (0usize, None, None);
        while let Some((_, row)) = rows.next_row()? {
            samples += 1;
            first_s.get_or_insert(row[0]);
            last_s = Some(row[0]);
        }
        let uniform = Uniform::new(path, samples, first_s.as_ref(), last_s.as_ref())?;
        let mut rows = open_rows(path)?;
        let mut previous_s = None;
        while let Some((line, row)) = rows.next_row()? {
            if let Some(previous_s) = previous_s {
                uniform.check(line, row[0] - previous_s)?;
            }
            previous_s = Some(row[0]);
        }
        Ok(Self {
            path: path.to_path_buf(),
            layout: rows.layout,
            samples,
            first_s: first_s.unwrap_or_default(),
            last_s: last_s.unwrap_or_default(),
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Which columns the file holds.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples
    }

    /// Whether there are no samples (never, for a stream that opened).
    pub fn is_empty(&self) -> bool {
        self.samples == 0
    }

    /// The sample rate from the mean step, Hz, as [`Recording::sample_rate_hz`] gives it.
    pub fn sample_rate_hz(&self) -> f64 {
        (self.samples - 1) as f64 / (self.last_s - self.first_s)
    }

    /// Time of the first sample, s.
    pub fn start_s(&self) -> f64 {
        self.first_s
    }

    /// Every row's 13 numbers (time, platform, sensors; the sensors zero in a ride), read
    /// from the file as they are taken.
    pub fn rows(
        &self,
    ) -> Result<impl Iterator<Item = Result<[f64; 13], RecordingError>>, RecordingError> {
        let mut rows = open_rows(&self.path)?;
        Ok(std::iter::from_fn(move || {
            rows.next_row().transpose().map(|r| r.map(|(_, row)| row))
        }))
    }

    /// The platform samples as the device is streamed them ([`device_samples`]), read
    /// from the file as they are taken.
    pub fn samples(&self) -> Result<PlatformSamples, RecordingError> {
        Ok(PlatformSamples {
            rows: open_rows(&self.path)?,
        })
    }
}

/// The samples of a [`PlatformStream`], one f32 triple per line.
pub struct PlatformSamples {
    rows: RowReader<std::fs::File>,
}

impl Iterator for PlatformSamples {
    type Item = Result<[f32; 3], RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        let row = self.rows.next_row().transpose()?;
        Some(row.map(|(_, row)| [row[1] as f32, row[2] as f32, row[3] as f32]))
    }
}

fn open_rows(path: &Path) -> Result<RowReader<std::fs::File>, RecordingError> {
    let file = std::fs::File::open(path).map_err(|e| RecordingError::Read {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    RowReader::new(file, path, &[Layout::Full, Layout::PlatformOnly])
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

/// Which of the `accepted` layouts the header names and in which naming, or where it first
/// differs from the full header in the naming it follows further.
fn check_header(
    header: &Row<'_>,
    path: &Path,
    accepted: &[Layout],
) -> Result<(Layout, Naming), RecordingError> {
    for layout in accepted {
        let n = layout.columns();
        for naming in NAMINGS {
            if header.len() == n
                && header
                    .cells()
                    .enumerate()
                    .all(|(c, cell)| cell == column_name(naming, c).as_bytes())
            {
                return Ok((*layout, naming));
            }
        }
    }
    let agreeing = |naming: Naming| {
        (0..header.len().min(naming.len()))
            .take_while(|&i| header.cell(i) == naming[i].as_bytes())
            .count()
    };
    let naming = if agreeing(&OLD_COLUMNS) > agreeing(&COLUMNS) {
        &OLD_COLUMNS
    } else {
        &COLUMNS
    };
    let mismatch = |column: usize, expected: &str, found: String| RecordingError::Header {
        path: path.to_path_buf(),
        column,
        expected: expected.to_string(),
        found,
    };
    for (i, expected) in naming.iter().enumerate() {
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
    let value = parse_number(cell).ok_or_else(|| CellError::NotANumber(column, excerpt(cell)))?;
    check_value(value, cell, column)
}

/// `value`, read from `cell` of `column`, if it is finite and (accelerations) in range.
fn check_value(value: f64, cell: &[u8], column: &'static str) -> Result<f64, CellError> {
    if !value.is_finite() {
        return Err(CellError::NotFinite(column, excerpt(cell)));
    }
    if column != COLUMNS[0] && value.abs() > MAX_ACCELERATION_M_S2 {
        return Err(CellError::OutOfRange(column, excerpt(cell)));
    }
    Ok(value)
}

/// A cell as a number, as Rust's `f64` parser reads it after trimming white space. A
/// finite number in plain decimal notation without other white space than ASCII (every
/// cell `supine` and common loggers write) takes the fast path, `fast-float2`: parsing was
/// a fifth of the fit command's time with the standard parser. Both round correctly, so
/// they agree on every input the fast path accepts (tested); anything else (infinity,
/// NaN, Unicode white space, not a number) goes through the standard parser, so what is
/// refused and how is unchanged.
fn parse_number(cell: &[u8]) -> Option<f64> {
    match fast_float2::parse::<f64, _>(cell.trim_ascii()) {
        Ok(value) if value.is_finite() => Some(value),
        _ => std::str::from_utf8(cell)
            .ok()
            .and_then(|text| text.trim().parse().ok()),
    }
}

/// The line of each sample, held as the points where lines stop following samples one
/// to one (after blank lines), so that it costs nothing for a file without blank lines.
#[derive(Default)]
pub(crate) struct LineNumbers {
    /// (first sample, its line) of each run of consecutive lines.
    runs: Vec<(usize, u64)>,
}

impl LineNumbers {
    /// Records that `sample` sits on `line`.
    pub(crate) fn push(&mut self, sample: usize, line: u64) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn the_predicted_joint_columns_are_the_outputs_in_their_display_units() {
        for (column, output) in PREDICTED_JOINT_COLUMNS
            .iter()
            .zip(supine_core::model::JointOutput::ALL)
        {
            assert_eq!(
                *column,
                format!("{}_{}", output.name(), output.unit().display().0)
            );
        }
    }

    /// A ride of `n` samples at 100 Hz, with a blank line and CRLF ends thrown in.
    fn ride_text(n: usize) -> String {
        let mut text = format!("{PLATFORM_HEADER_LINE}\r\n");
        for k in 0..n {
            let t = k as f64 / 100.0;
            text.push_str(&format!(
                "{t},{},{},{}\r\n",
                0.1 * t,
                -0.2 * t,
                (7.0 * t).sin()
            ));
            if k == 3 {
                text.push_str("\r\n");
            }
        }
        text
    }

    /// The standard parser's reading of a cell.
    fn standard(cell: &[u8]) -> Option<f64> {
        std::str::from_utf8(cell)
            .ok()
            .and_then(|text| text.trim().parse().ok())
    }

    #[test]
    fn the_fast_number_parser_reads_every_cell_as_the_standard_parser_does() {
        let mut cells: Vec<String> = [
            "0",
            "-0",
            "+0",
            "1",
            "+1.5",
            "-1.5",
            "1.",
            ".5",
            "-.5",
            "1.e5",
            "1e5",
            "1E-5",
            "1e+5",
            "1e",
            "e5",
            ".",
            "-",
            "+",
            "",
            " ",
            " 1.25 ",
            "\t2\r",
            "\u{b}3",
            "4\u{a0}",
            "\u{2003}5",
            "1e308",
            "1e309",
            "-1e309",
            "2e-324",
            "5e-324",
            "4.9406564584124654e-324",
            "1.7976931348623157e308",
            "inf",
            "-inf",
            "+inf",
            "Infinity",
            "nan",
            "NaN",
            "-nan",
            "nan(1)",
            "0x10",
            "1_000",
            "1,5",
            "1.2.3",
            "--1",
            "1e5.5",
            "0.1000000000000000055511151231257827021181583404541015625",
            "9007199254740993",
            "123456789012345678901234567890",
            "00012",
            "1 2",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // Numbers as `supine synth` and `ride` write them, from a seeded generator.
        let mut rng = ChaCha8Rng::seed_from_u64(0x9e37_79b9_7f4a_7c15);
        for _ in 0..20_000 {
            let v = f64::from_bits(rng.random());
            if v.is_finite() {
                cells.push(format!("{v}"));
                cells.push(format!("{v:e}"));
                cells.push(format!("{}", v as f32));
            }
        }
        for cell in &cells {
            assert_eq!(
                parse_number(cell.as_bytes()).map(f64::to_bits),
                standard(cell.as_bytes()).map(f64::to_bits),
                "{cell:?}"
            );
        }
        // Bytes that are not UTF-8 are no number either way.
        assert_eq!(parse_number(b"1\xff"), None);
        assert_eq!(parse_number(b"\xff1"), None);
    }

    /// One line through the plain path (None: left to the other) and the split path.
    type BothPaths = (Option<[f64; 13]>, Result<[f64; 13], RecordingError>);

    /// Every data line of `text` (after its first line) through both paths: the plain
    /// path's row when it takes the line, and the split path's result.
    fn both_paths(text: &[u8], columns: usize) -> Vec<BothPaths> {
        let mut lines = CsvLines::new(text);
        lines.next_row().unwrap();
        let mut out = Vec::new();
        while let Some(line) = lines.next_line().unwrap() {
            let plain = plain_row(&line, columns, &COLUMNS);
            out.push((
                plain,
                split_row(Path::new("r.csv"), line.split(), columns, &COLUMNS),
            ));
        }
        out
    }

    #[test]
    fn the_plain_row_path_reads_what_the_split_path_reads_or_leaves_the_line_to_it() {
        let bits = |row: &[f64; 13]| row.map(f64::to_bits);
        let typical = "0.005,-0.3103853555041264,0.6351828879414806,-0.33694338988462247,\
                       0.12898576060760694,0.1915549112861066,-0.47268948950438106,\
                       0.077507434500577,0.25115283280613787,-0.3471950739479998,\
                       0.03779977928589595,0.19315472581235382,-0.22782856447920097";
        let odd_cells = [
            " 1.25", "1.25 ", "\t2", "inf", "-inf", "nan", "1e", "1e5", "+1.5", ".5", "1.", "0x10",
            "1 2", "", "1e309", "2e3", "-2e3", "99999", "1.5\r", "\u{a0}5",
        ];
        let mut text = format!("{HEADER_LINE}\n{typical}\n{typical}\r\n");
        let cells: Vec<&str> = typical.split(',').collect();
        for (k, odd) in odd_cells.iter().enumerate() {
            for position in [1, 5, 12] {
                let mut line = cells.clone();
                line[position] = odd;
                text.push_str(&line.join(","));
                text.push_str(["\n", "\r\n"][k % 2]);
            }
        }
        // A cell too few, a cell too many, an empty last cell, a trailing comma.
        text.push_str(&format!("{}\n", cells[..12].join(",")));
        text.push_str(&format!("{typical},1\n{typical},\n"));
        let rows = both_paths(text.as_bytes(), 13);
        assert_eq!(rows.len(), 2 + 3 * odd_cells.len() + 3);
        let mut taken = 0;
        for (k, (plain, split)) in rows.iter().enumerate() {
            if let Some(plain) = plain {
                taken += 1;
                let split = split.as_ref().unwrap_or_else(|e| panic!("line {k}: {e}"));
                assert_eq!(bits(plain), bits(split), "line {k}");
            }
        }
        // The typical lines (LF and CRLF) and those with plain odd numbers are taken.
        assert!(rows[0].0.is_some() && rows[1].0.is_some());
        assert!(taken >= 2 + 3 * 5, "{taken} lines taken");
        // Every line the split path refuses, the plain path leaves to it.
        assert!(
            rows.iter()
                .all(|(plain, split)| split.is_ok() || plain.is_none())
        );
        // The prediction layout's joint columns are read and left out the same way.
        let wide = format!("h\n{typical},1,2,3,4,5,6,7,8,9,10\n{typical},1,2,3,4,5,6,7,8,9\n");
        let rows = both_paths(wide.as_bytes(), 23);
        assert_eq!(
            rows[0].0.map(|r| bits(&r)),
            Some(bits(rows[0].1.as_ref().unwrap()))
        );
        assert!(rows[1].0.is_none() && rows[1].1.is_err());
    }

    #[test]
    fn a_platform_stream_gives_what_read_input_gives() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ride.csv");
        std::fs::write(&path, ride_text(50)).unwrap();
        let (recording, layout) = read_input(&path).unwrap();
        let stream = PlatformStream::open(&path).unwrap();
        assert_eq!(layout, Layout::PlatformOnly);
        assert_eq!(stream.layout(), layout);
        assert_eq!(stream.len(), 50);
        assert_eq!(stream.sample_rate_hz(), recording.sample_rate_hz());
        let samples: Vec<[f32; 3]> = stream.samples().unwrap().map(Result::unwrap).collect();
        assert_eq!(samples, recording.platform_samples());
    }

    #[test]
    fn a_platform_stream_refuses_what_read_input_refuses_in_the_same_words() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ride.csv");
        let valid = ride_text(50);
        // Line 12 holds sample 9 (the blank line after sample 3 is line 6): a late sample,
        // then a time going back, then a cell that is no number.
        let cases = [
            valid.replacen("\r\n0.09,", "\r\n0.0905,", 1),
            valid.replacen("\r\n0.09,", "\r\n0.07,", 1),
            valid.replacen("\r\n0.09,", "\r\n0.09x,", 1),
            valid.replacen("\r\n0.09,", "\r\n0.09,1e39,", 1),
            format!("{PLATFORM_HEADER_LINE}\n0,0,0,0\n"),
        ];
        for text in cases {
            std::fs::write(&path, &text).unwrap();
            let whole = read_input(&path).unwrap_err().to_string();
            let streamed = PlatformStream::open(&path).unwrap_err().to_string();
            assert_eq!(streamed, whole);
            assert!(
                whole.contains("line 12") || whole.contains("at least 2"),
                "{whole}"
            );
        }
    }

    #[test]
    fn a_bad_cell_is_named_as_the_files_header_names_its_column() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ride.csv");
        let bad = ride_text(50).replacen("\r\n0.09,0.009,", "\r\n0.09,x,", 1);
        let old = bad.replacen(PLATFORM_HEADER_LINE, &OLD_COLUMNS[..4].join(","), 1);
        for (text, column) in [(bad, "platform_x_m_s2"), (old, "platform_x")] {
            std::fs::write(&path, text).unwrap();
            let error = read_input(&path).unwrap_err().to_string();
            assert!(
                error.contains(&format!("line 12, column {column}:")),
                "{error}"
            );
        }
    }
}
