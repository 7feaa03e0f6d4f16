//! Rides read row by row, whatever their length: `exposure`, `report` and the converting
//! path of `replay` and `monitor --input` take a ride's samples from here one at a time,
//! so memory holds a line and the evaluation's state, never the ride
//! (`docs/architecture.md`, "Reading rides").
//!
//! A [`RideSource`] is a ride that has been checked (every cell, time increasing and
//! uniform; [`crate::io::ride_input`] adds the gravity check) and whose length, rate and
//! start are known, so that evaluations that need them before the first sample (the
//! warm-up check, the spectra's segment length, the charts' bucket width) have them.
//! Each [`RideSource::rows`] reads the file once more. A recording already in memory (the
//! demo's, tests') is a source too, so there is one evaluation code path.
//!
//! Another logger's file (`--columns`) is read by [`ForeignRows`]: the four named columns
//! of any `,`- or `;`-separated CSV, converted to s and m/s^2.

use std::io::Read as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use clap::ValueEnum;
use supine_core::calibration::SensorFrame;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;

use crate::io::csv_lines::{CsvLines, MAX_LINE_BYTES};
use crate::io::excerpt::{excerpt, number, quoted_name};
use crate::io::recording::{
    Layout, MAX_ACCELERATION_M_S2, PLATFORM_HEADER_LINE, PlatformStream, Recording, Uniform,
};

/// Most characters of header fields an error lists (a logger's header can be long, and an
/// error stays within about 200 characters).
const MAX_LISTED_CHARS: usize = 40;

/// Unit of the time column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum TimeUnit {
    /// Seconds.
    #[default]
    S,
    /// Milliseconds.
    Ms,
}

impl TimeUnit {
    /// Seconds per unit.
    pub const fn to_s(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e-3,
        }
    }

    fn name(self) -> &'static str {
        match self {
            TimeUnit::S => "s",
            TimeUnit::Ms => "ms",
        }
    }
}

/// Unit of the acceleration columns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AccelUnit {
    /// Metres per second squared.
    #[default]
    #[value(name = "m/s2")]
    MS2,
    /// Standard gravity, 9.80665 m/s^2.
    G,
}

impl AccelUnit {
    /// m/s^2 per unit.
    pub const fn to_m_s2(self) -> f64 {
        match self {
            AccelUnit::MS2 => 1.0,
            AccelUnit::G => STANDARD_GRAVITY_M_S2,
        }
    }

    fn name(self) -> &'static str {
        match self {
            AccelUnit::MS2 => "m/s^2",
            AccelUnit::G => "g",
        }
    }
}

/// The four header names of another logger's file (`--columns`), in the order time, x,
/// y, z of the litter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ColumnNames {
    /// Names of time, x, y, z.
    pub names: [String; 4],
}

/// The keys of `--columns`, in [`ColumnNames::names`] order.
pub const COLUMN_KEYS: [&str; 4] = ["time", "x", "y", "z"];

impl ColumnNames {
    /// Parses `time=NAME,x=NAME,y=NAME,z=NAME` (any order; names are exact, spaces kept).
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut names: [Option<String>; 4] = Default::default();
        for part in text.split(',') {
            let Some((key, name)) = part.split_once('=') else {
                return Err(format!(
                    "expected KEY=NAME pairs (time, x, y, z) separated by commas, found {}",
                    excerpt(part)
                ));
            };
            let Some(k) = COLUMN_KEYS.iter().position(|c| *c == key.trim()) else {
                return Err(format!(
                    "expected one of the keys time, x, y, z, found {}",
                    excerpt(key)
                ));
            };
            if name.is_empty() {
                return Err(format!("{key}=: expected a column name after ="));
            }
            if names[k].replace(name.to_string()).is_some() {
                return Err(format!("{key}= given twice: expected each key once"));
            }
        }
        let missing: Vec<&str> = (0..4)
            .filter(|&k| names[k].is_none())
            .map(|k| COLUMN_KEYS[k])
            .collect();
        if !missing.is_empty() {
            return Err(format!(
                "expected all of time, x, y, z, missing {}",
                missing.join(", ")
            ));
        }
        Ok(Self {
            names: names.map(Option::unwrap_or_default),
        })
    }
}

/// How another logger's file is laid out: its columns and units.
#[derive(Clone, Debug, PartialEq)]
pub struct ForeignFormat {
    /// The header names of time, x, y, z.
    pub columns: ColumnNames,
    /// The time column's unit.
    pub time_unit: TimeUnit,
    /// The acceleration columns' unit.
    pub units: AccelUnit,
}

/// The rows of another logger's file, parsed and checked one line at a time: each its
/// line and time (s), x, y, z (m/s^2).
pub struct ForeignRows {
    path: PathBuf,
    lines: CsvLines<std::fs::File>,
    delimiter: u8,
    width: usize,
    index: [usize; 4],
    names: [String; 4],
    scale: [f64; 4],
    what: [String; 4],
    previous_s: f64,
}

impl ForeignRows {
    /// Opens the file at `path` and finds the columns of `format` in its header.
    pub fn open(path: &Path, format: &ForeignFormat) -> Result<Self> {
        let shown = path.display();
        let delimiter = sniff_delimiter(path)?;
        let file =
            std::fs::File::open(path).map_err(|e| anyhow!("{shown}: cannot read the ride: {e}"))?;
        let mut lines = CsvLines::with_delimiter(file, MAX_LINE_BYTES, delimiter);
        let header = lines
            .next_row()
            .map_err(|e| anyhow!("{shown}: {e}"))?
            .ok_or_else(|| {
                anyhow!("{shown}: line 1: expected a header line, found an empty file")
            })?;
        let width = header.len();
        let mut index = [0usize; 4];
        for (k, wanted) in format.columns.names.iter().enumerate() {
            index[k] = header
                .cells()
                .position(|c| c == wanted.as_bytes())
                .ok_or_else(|| {
                    let fields = listed_fields(header.cells(), width);
                    anyhow!(
                        "{shown}: line 1: --columns {}=: expected a field {}, found {} ({:?}-separated; \
                         a ride: {PLATFORM_HEADER_LINE})",
                        COLUMN_KEYS[k],
                        quoted_name(wanted),
                        fields.join(", "),
                        delimiter as char
                    )
                })?;
        }
        let accel = format!("an acceleration in {}", format.units.name());
        Ok(Self {
            path: path.to_path_buf(),
            lines,
            delimiter,
            width,
            index,
            names: format.columns.names.clone(),
            scale: [
                format.time_unit.to_s(),
                format.units.to_m_s2(),
                format.units.to_m_s2(),
                format.units.to_m_s2(),
            ],
            what: [
                format!("a time in {}", format.time_unit.name()),
                accel.clone(),
                accel.clone(),
                accel,
            ],
            previous_s: f64::NEG_INFINITY,
        })
    }

    /// The next row: its line, and time (s), x, y, z (m/s^2).
    pub fn next_row(&mut self) -> Result<Option<(u64, [f64; 4])>> {
        let shown = self.path.display();
        let Some(row) = self.lines.next_row().map_err(|e| anyhow!("{shown}: {e}"))? else {
            return Ok(None);
        };
        let line = row.line;
        if row.len() != self.width {
            bail!(
                "{shown}: line {line}: expected {} {:?}-separated cells as in the header, found {}",
                self.width,
                self.delimiter as char,
                row.len()
            );
        }
        let mut value = [0.0f64; 4];
        for (k, slot) in value.iter_mut().enumerate() {
            let cell = row.cell(self.index[k]);
            let name = &self.names[k];
            let parsed: f64 = std::str::from_utf8(cell)
                .ok()
                .and_then(|t| t.trim().parse().ok())
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    anyhow!(
                        "{shown}: line {line}, column {name}: expected {} (a finite number), found {}",
                        self.what[k],
                        excerpt(cell)
                    )
                })?;
            *slot = parsed * self.scale[k];
            if k > 0 && slot.abs() > MAX_ACCELERATION_M_S2 {
                bail!(
                    "{shown}: line {line}, column {name}: expected an acceleration within the f32 \
                     range the device computes in, found {}",
                    excerpt(cell)
                );
            }
        }
        if value[0] <= self.previous_s {
            bail!(
                "{shown}: line {line}, column {}: expected a time after {} s (strictly increasing), found {} s",
                self.names[0],
                number(self.previous_s),
                number(value[0])
            );
        }
        self.previous_s = value[0];
        Ok(Some((line, value)))
    }
}

/// The header's fields as an error lists them: quoted, within [`MAX_LISTED_CHARS`]
/// including the `... (N fields)` that ends a list cut short.
fn listed_fields<'a>(cells: impl Iterator<Item = &'a [u8]>, width: usize) -> Vec<String> {
    let length = |fields: &[String]| fields.iter().map(|f| f.chars().count() + 2).sum::<usize>();
    let mut fields: Vec<String> = Vec::new();
    for cell in cells {
        fields.push(quoted_name(cell));
        if length(&fields) > MAX_LISTED_CHARS {
            let more = format!("... ({width} fields)");
            while !fields.is_empty() && length(&fields) + more.chars().count() > MAX_LISTED_CHARS {
                fields.pop();
            }
            fields.push(more);
            break;
        }
    }
    fields
}

/// `b';'` when the first line holds a semicolon, else `b','`.
fn sniff_delimiter(path: &Path) -> Result<u8> {
    let mut head = Vec::with_capacity(MAX_LINE_BYTES);
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_LINE_BYTES as u64 + 4).read_to_end(&mut head))
        .map_err(|e| anyhow!("{}: cannot read the ride: {e}", path.display()))?;
    let first_line = head.split(|b| *b == b'\n').next().unwrap_or_default();
    Ok(if first_line.contains(&b';') {
        b';'
    } else {
        b','
    })
}

/// Where a [`RideSource`]'s rows come from.
#[derive(Clone, Debug)]
enum Origin {
    /// A file in the project's formats.
    Own(PlatformStream),
    /// Another logger's file.
    Foreign(ForeignFormat),
    /// A recording read whole before (the demo's ride, tests).
    Memory(Box<Recording>),
}

/// A checked ride whose rows are read again on each pass.
#[derive(Clone, Debug)]
pub struct RideSource {
    path: PathBuf,
    layout: Layout,
    samples: usize,
    sample_rate_hz: f64,
    start_s: f64,
    origin: Origin,
    gravity_removal: Option<SensorFrame>,
}

/// One row of a ride: time, s, then the 12 acceleration columns of the recording format,
/// m/s^2 (the sensor columns zero when the file holds only the platform's).
pub type Row = [f64; 13];

impl RideSource {
    /// A recording in memory, in `layout`.
    pub fn from_recording(recording: Recording, layout: Layout) -> Self {
        let time = &recording.time_s;
        Self {
            path: recording.path.clone(),
            layout,
            samples: recording.len(),
            sample_rate_hz: recording.sample_rate_hz(),
            start_s: time.first().copied().unwrap_or(0.0),
            origin: Origin::Memory(Box::new(recording)),
            gravity_removal: None,
        }
    }

    /// A file in the project's formats, checked by [`PlatformStream::open`]; with
    /// `gravity_removal`, every platform sample converted as the device converts its
    /// sensor's readings ([`SensorFrame::to_litter_m_s2`], f32).
    pub fn own(stream: PlatformStream, gravity_removal: Option<SensorFrame>) -> Self {
        Self {
            path: stream.path().to_path_buf(),
            layout: stream.layout(),
            samples: stream.len(),
            sample_rate_hz: stream.sample_rate_hz(),
            start_s: stream.start_s(),
            origin: Origin::Own(stream),
            gravity_removal,
        }
    }

    /// Another logger's file at `path`: two passes, every cell and the time's order in the
    /// first, each step against the mean step in the second (the checks, in the order and
    /// words, of the whole-file reader).
    pub fn foreign(
        path: &Path,
        format: ForeignFormat,
        gravity_removal: Option<SensorFrame>,
    ) -> Result<Self> {
        let mut rows = ForeignRows::open(path, &format)?;
        let (mut samples, mut first_s, mut last_s) = (0usize, None, None);
        while let Some((_, row)) = rows.next_row()? {
            samples += 1;
            first_s.get_or_insert(row[0]);
            last_s = Some(row[0]);
        }
        let uniform = Uniform::new(path, samples, first_s.as_ref(), last_s.as_ref())?;
        let mut rows = ForeignRows::open(path, &format)?;
        let mut previous_s = None;
        while let Some((line, row)) = rows.next_row()? {
            if let Some(previous_s) = previous_s {
                uniform.check(line, row[0] - previous_s)?;
            }
            previous_s = Some(row[0]);
        }
        let (first_s, last_s) = (first_s.unwrap_or_default(), last_s.unwrap_or_default());
        Ok(Self {
            path: path.to_path_buf(),
            layout: Layout::PlatformOnly,
            samples,
            sample_rate_hz: (samples - 1) as f64 / (last_s - first_s),
            start_s: first_s,
            origin: Origin::Foreign(format),
            gravity_removal,
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Which columns the file holds (another logger's: the platform's).
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples
    }

    /// Whether there are no samples (never, for a checked ride).
    pub fn is_empty(&self) -> bool {
        self.samples == 0
    }

    /// The sample rate from the mean step, Hz (as [`Recording::sample_rate_hz`]).
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// Time of the first sample, s.
    pub fn start_s(&self) -> f64 {
        self.start_s
    }

    /// Every row, read as it is taken, with gravity removed when asked.
    pub fn rows(&self) -> Result<Box<dyn Iterator<Item = Result<Row>> + '_>> {
        let rows: Box<dyn Iterator<Item = Result<Row>>> = match &self.origin {
            Origin::Own(stream) => Box::new(stream.rows()?.map(|r| r.map_err(Into::into))),
            Origin::Foreign(format) => {
                let mut rows = ForeignRows::open(&self.path, format)?;
                Box::new(std::iter::from_fn(move || {
                    rows.next_row().transpose().map(|r| {
                        r.map(|(_, [t, x, y, z])| {
                            let mut row = [0.0; 13];
                            row[..4].copy_from_slice(&[t, x, y, z]);
                            row
                        })
                    })
                }))
            }
            Origin::Memory(recording) => Box::new((0..recording.len()).map(|k| {
                let mut row = [0.0; 13];
                row[0] = recording.time_s[k];
                for (cell, column) in row[1..].iter_mut().zip(
                    recording
                        .platform_m_s2
                        .iter()
                        .chain(&recording.sensors_m_s2),
                ) {
                    *cell = column[k];
                }
                Ok(row)
            })),
        };
        Ok(match self.gravity_removal {
            None => rows,
            Some(frame) => Box::new(rows.map(move |r| {
                r.map(|mut row| {
                    let litter = frame.to_litter_m_s2([row[1], row[2], row[3]].map(|v| v as f32));
                    for (cell, v) in row[1..4].iter_mut().zip(litter) {
                        *cell = f64::from(v);
                    }
                    row
                })
            })),
        })
    }

    /// The platform x, y, z of every row (m/s^2), as [`rows`](Self::rows) reads them.
    pub fn platform(&self) -> Result<impl Iterator<Item = Result<[f64; 3]>> + '_> {
        Ok(self.rows()?.map(|r| r.map(|row| [row[1], row[2], row[3]])))
    }
}

/// How a command opens each of its rides: row by row from the file
/// ([`crate::io::ride_input::RideOpener`]), or a reader that gives the recording whole
/// (the demo's ride, tests: any `Fn(&Path) -> Result<(Recording, Layout)>`).
pub trait OpenRide {
    /// The ride at `path`, checked.
    fn open_ride(&self, path: &Path) -> Result<RideSource>;
}

impl<F: Fn(&Path) -> Result<(Recording, Layout)>> OpenRide for F {
    fn open_ride(&self, path: &Path) -> Result<RideSource> {
        let (recording, layout) = self(path)?;
        Ok(RideSource::from_recording(recording, layout))
    }
}
