//! Rides read row by row, whatever their length: `exposure`, `report` and the converting
//! path of `replay` and `monitor --input` take a ride's samples from here one at a time,
//! so memory holds a line and the evaluation's state, never the ride
//! (`docs/architecture.md`, "Reading rides").
//!
//! A [`RideSource`] is a ride that has been checked (every cell, time increasing and
//! uniform; [`crate::io::ride_input`] adds the gravity check) and whose length, rate and
//! start are known, so that evaluations that need them before the first sample (the
//! warm-up check, the spectra's segment length, the charts' bucket width) have them.
//! Each [`RideSource::rows`] reads the rows once more (a logger's file: from the scan's
//! scratch copy, [`crate::ride::scratch_rows`]). A recording already in memory (the
//! demo's, tests') is a source too, so there is one evaluation code path.
//!
//! Another logger's file (`--columns`) is read by [`ForeignRows`]: the four named columns
//! of any `,`- or `;`-separated CSV, converted to s and m/s^2.

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Result, anyhow, bail};
use supine_core::calibration::SensorFrame;

use crate::io::csv_blocks::{BlockError, ParsedLines};
use crate::io::csv_lines::{CsvLines, MAX_LINE_BYTES};
use crate::io::decimal::{exact_decimal, leading_decimal, leading_integer, parse_f64};
use crate::io::excerpt::{excerpt, quoted_name};
use crate::io::recording::{
    Layout, MAX_ACCELERATION_M_S2, PLATFORM_HEADER_LINE, PlatformStream, Recording,
};
use crate::ride::clock::{CellTime, Clock};
use crate::ride::conditioned::{Conditioned, FileRows, RawRows};
use crate::ride::formats::PositionColumns;
use crate::ride::position::Track;
use crate::ride::quality::DataQuality;
use crate::ride::scratch_rows::ScratchRows;

/// Most characters of header fields an error lists (a logger's header can be long, and an
/// error stays within about 200 characters).
const MAX_LISTED_CHARS: usize = 40;

pub use crate::ride::clock::TimeUnit;

pub use crate::ride::units::AccelUnit;

/// The header names of another logger's file (`--columns`): time, x, y, z of the litter,
/// and where the file holds them, latitude and longitude (with speed and accuracy).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ColumnNames {
    /// Names of time, x, y, z.
    pub names: [String; 4],
    /// The position columns (`lat=`, `lon=`, `speed=`, `accuracy=`), on the same clock.
    pub positions: Option<PositionColumns>,
}

/// The keys of `--columns`, in [`ColumnNames::names`] order.
pub const COLUMN_KEYS: [&str; 4] = ["time", "x", "y", "z"];
/// The optional keys of `--columns` that name position columns.
pub const POSITION_KEYS: [&str; 4] = ["lat", "lon", "speed", "accuracy"];

impl ColumnNames {
    /// Parses `time=NAME,x=NAME,y=NAME,z=NAME[,lat=NAME,lon=NAME[,speed=NAME,accuracy=NAME]]`
    /// (any order; names are exact, spaces kept).
    pub fn parse(text: &str) -> Result<Self, String> {
        let keys: Vec<&str> = COLUMN_KEYS.iter().chain(&POSITION_KEYS).copied().collect();
        let mut names: [Option<String>; 8] = Default::default();
        for part in text.split(',') {
            let Some((key, name)) = part.split_once('=') else {
                return Err(format!(
                    "expected KEY=NAME pairs (time, x, y, z; lat, lon, speed, accuracy) separated by commas, found {}",
                    excerpt(part)
                ));
            };
            let Some(k) = keys.iter().position(|c| *c == key.trim()) else {
                return Err(format!(
                    "expected one of the keys time, x, y, z, lat, lon, speed, accuracy, found {}",
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
        for a in 0..names.len() {
            for b in a + 1..names.len() {
                if let (Some(first), Some(second)) = (&names[a], &names[b])
                    && first == second
                {
                    return Err(format!(
                        "{}= and {}= name the same column {}: expected a column of its own for each",
                        keys[a],
                        keys[b],
                        excerpt(first)
                    ));
                }
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
        let [time, x, y, z, lat, lon, speed, accuracy] = names;
        let positions = match (lat, lon) {
            (Some(lat), Some(lon)) => Some(PositionColumns {
                time: time.clone().unwrap_or_default(),
                lat,
                lon,
                speed: speed.into_iter().collect(),
                accuracy: accuracy.into_iter().collect(),
            }),
            (None, None) if speed.is_none() && accuracy.is_none() => None,
            _ => {
                return Err(
                    "lat=, lon=: expected both (speed= and accuracy= only with them)".to_string(),
                );
            }
        };
        Ok(Self {
            names: [time, x, y, z].map(Option::unwrap_or_default),
            positions,
        })
    }
}

/// How another logger's file is laid out: its columns and units.
#[derive(Clone, Debug, PartialEq)]
pub struct ForeignFormat {
    /// What the file is, as the data-quality account names it (an app's name, or
    /// `--columns`).
    pub name: String,
    /// The header names of time, x, y, z.
    pub columns: ColumnNames,
    /// The time column's unit.
    pub time_unit: TimeUnit,
    /// The acceleration columns' unit.
    pub units: AccelUnit,
}

/// The rows of another logger's file: each its line and time (s), x, y, z (m/s^2). Every
/// cell is checked; time may go backwards or repeat (the conditioning drops and counts
/// such rows, [`crate::ride::regular`]). The lines are parsed on every core
/// ([`crate::io::csv_blocks`]) and placed on the clock in the file's order. Quoted cells
/// (RFC 4180, as apps and spreadsheets write them) are read by the `csv` crate, a line
/// at a time; a line without a quote is split directly.
pub struct ForeignRows {
    path: PathBuf,
    lines: ParsedLines<std::fs::File, (CellTime, [f64; 3]), ReadLine>,
    clock: Clock,
}

/// A [`LineReader`]'s reading, as [`ParsedLines`] takes it.
type ReadLine = Box<dyn Fn(&[u8]) -> Result<(CellTime, [f64; 3]), String> + Send + Sync>;

/// How a data line of another logger's file is read: which cells, in which units.
/// It depends on the line alone, so that lines can be read on several threads.
struct LineReader {
    delimiter: u8,
    width: usize,
    index: [usize; 4],
    names: [String; 4],
    scale: f64,
    time_unit: TimeUnit,
    /// What each column holds, as errors say it.
    what: [String; 4],
    /// For each of the line's cells, which of time, x, y, z it is (`None`: not read).
    roles: Vec<Option<usize>>,
}

impl LineReader {
    /// The time and x, y, z (m/s^2) of the line `text` (without its LF); an error says
    /// what is wrong after the line's number (`, column time: expected ...`).
    fn read(&self, text: &[u8]) -> Result<(CellTime, [f64; 3]), String> {
        let text = text.strip_suffix(b"\r").unwrap_or(text);
        match self.read_plain(text) {
            Some(row) => Ok(row),
            None => self.read_any(text),
        }
    }

    /// The fast path of [`read_any`](Self::read_any) for the line a logger writes: no
    /// quote, `width` cells, the wanted ones plain decimals ([`leading_decimal`]; a time
    /// in us or ns an integer) in range. Each is read where it starts and must end at a
    /// delimiter or the line's end, so the line is walked once instead of split first.
    /// Such a line gives the same values either way: `read_any` reads the same cells
    /// (trimming changes none of them) with [`exact_decimal`] first, which is
    /// `leading_decimal` taking the whole cell, and reads an integer time as an i128,
    /// which a run of at most 19 digits is exactly. Anything else is `None`, and
    /// `read_any` reads the line and names what is wrong.
    fn read_plain(&self, text: &[u8]) -> Option<(CellTime, [f64; 3])> {
        let mut time = None;
        let mut value = [0.0f64; 3];
        let mut at = 0usize;
        for (c, role) in self.roles.iter().enumerate() {
            let rest = &text[at..];
            let used = match role {
                None => {
                    let end = rest
                        .iter()
                        .position(|&b| b == self.delimiter || b == b'"')
                        .unwrap_or(rest.len());
                    if rest.get(end) == Some(&b'"') {
                        return None;
                    }
                    end
                }
                Some(0) => {
                    let (cell_time, used) = match self.time_unit {
                        TimeUnit::S | TimeUnit::Ms => leading_decimal(rest)
                            .map(|(v, used)| (CellTime::Seconds(v * self.time_unit.to_s()), used)),
                        TimeUnit::Us | TimeUnit::Ns => leading_integer(rest)
                            .map(|(i, used)| (CellTime::Count(i128::from(i)), used)),
                        TimeUnit::Text => None,
                    }?;
                    time = Some(cell_time);
                    used
                }
                Some(k) => {
                    let (v, used) = leading_decimal(rest)?;
                    let v = v * self.scale;
                    if v.abs() > MAX_ACCELERATION_M_S2 {
                        return None;
                    }
                    value[k - 1] = v;
                    used
                }
            };
            at += used;
            let last = c + 1 == self.roles.len();
            match text.get(at) {
                Some(&b) if b == self.delimiter && !last => at += 1,
                None if last => {}
                _ => return None,
            }
        }
        Some((time?, value))
    }

    /// Any line: quoted cells, white space around numbers, every form of number and
    /// time, and the error that names what is wrong.
    fn read_any(&self, text: &[u8]) -> Result<(CellTime, [f64; 3]), String> {
        let mut cells: [&[u8]; 4] = [&[]; 4];
        // One walk over the line: each wanted cell picked, every cell counted, a quote
        // sending the line to the `csv` crate.
        let (mut start, mut found, mut has_quote) = (0usize, 0usize, false);
        let mut pick = |found: usize, start: usize, end: usize| {
            for (cell, &i) in cells.iter_mut().zip(&self.index) {
                if i == found {
                    *cell = &text[start..end];
                }
            }
        };
        for (end, &b) in text.iter().enumerate() {
            if b == self.delimiter {
                pick(found, start, end);
                found += 1;
                start = end + 1;
            } else if b == b'"' {
                has_quote = true;
                break;
            }
        }
        if !has_quote {
            pick(found, start, text.len());
            found += 1;
        }
        let quoted;
        if has_quote {
            quoted = unquoted_cells(text, self.delimiter)
                .ok_or(": expected RFC 4180 quoting, found an unclosed quote")?;
            found = quoted.len();
            if found == self.width {
                for (cell, &i) in cells.iter_mut().zip(&self.index) {
                    let raw = quoted[i].as_slice();
                    *cell = raw.strip_suffix(b"\r").unwrap_or(raw);
                }
            }
        }
        if found != self.width {
            return Err(format!(
                ": expected {} {:?}-separated cells as in the header, found {found}",
                self.width, self.delimiter as char,
            ));
        }
        let bad = |k: usize, expected: String| {
            format!(
                ", column {}: expected {expected}, found {}",
                self.names[k],
                excerpt(cells[k])
            )
        };
        // A plain decimal in s or ms read directly; any other cell as the clock reads it.
        let time = match self.time_unit {
            TimeUnit::S | TimeUnit::Ms => exact_decimal(cells[0].trim_ascii())
                .map(|v| CellTime::Seconds(v * self.time_unit.to_s())),
            _ => None,
        }
        .or_else(|| {
            std::str::from_utf8(cells[0])
                .ok()
                .and_then(|t| CellTime::read(self.time_unit, t))
        })
        .ok_or_else(|| bad(0, self.what[0].clone()))?;
        let mut value = [0.0f64; 3];
        for (k, slot) in (1..4).zip(value.iter_mut()) {
            *slot = parse_f64(cells[k].trim_ascii())
                .filter(|v| v.is_finite())
                .map(|v| v * self.scale)
                .ok_or_else(|| bad(k, format!("{} (a finite number)", self.what[k])))?;
            if slot.abs() > MAX_ACCELERATION_M_S2 {
                return Err(bad(
                    k,
                    "an acceleration within the f32 range the device computes in".to_string(),
                ));
            }
        }
        Ok((time, value))
    }
}

/// For each of a line's `width` cells, which of time, x, y, z (`index`: their cells) it is.
fn roles(index: &[usize; 4], width: usize) -> Vec<Option<usize>> {
    (0..width)
        .map(|c| index.iter().position(|&i| i == c))
        .collect()
}

/// The cells of a line that holds a quote, unquoted (RFC 4180) by the `csv` crate.
pub fn unquoted_cells(text: &[u8], delimiter: u8) -> Option<Vec<Vec<u8>>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .from_reader(text);
    let mut record = csv::ByteRecord::new();
    match reader.read_byte_record(&mut record) {
        Ok(true) => Some(record.iter().map(<[u8]>::to_vec).collect()),
        _ => None,
    }
}

impl ForeignRows {
    /// Opens the file at `path` and finds the columns of `format` in its header.
    pub fn open(path: &Path, format: &ForeignFormat) -> Result<Self> {
        let shown = path.display();
        let (delimiter, header) = read_header(path)?;
        let width = header.len();
        let mut index = [0usize; 4];
        for (k, wanted) in format.columns.names.iter().enumerate() {
            let mut same_name = header
                .iter()
                .enumerate()
                .filter(|(_, c)| *c == wanted)
                .map(|(i, _)| i + 1);
            if let (Some(first), Some(second)) = (same_name.next(), same_name.next()) {
                bail!(
                    "{shown}: line 1: --columns {}=: the header has fields {first} and {second} \
                     both named {}: expected a name that appears once (rename one in the file)",
                    COLUMN_KEYS[k],
                    quoted_name(wanted),
                );
            }
            index[k] = header.iter().position(|c| c == wanted).ok_or_else(|| {
                let fields = listed_fields(header.iter().map(String::as_bytes), width);
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
        let file =
            std::fs::File::open(path).map_err(|e| anyhow!("{shown}: cannot read the ride: {e}"))?;
        let mut header_lines = CsvLines::with_delimiter(file, MAX_LINE_BYTES, delimiter);
        header_lines
            .next_line()
            .map_err(|e| anyhow!("{shown}: {e}"))?;
        let (file, pending, line) = header_lines.into_rest();
        let accel = format!("an acceleration in {}", format.units.name());
        let reader = LineReader {
            delimiter,
            width,
            index,
            names: format.columns.names.clone(),
            scale: format.units.to_m_s2(),
            time_unit: format.time_unit,
            roles: roles(&index, width),
            what: [
                format.time_unit.expected().to_string(),
                accel.clone(),
                accel.clone(),
                accel,
            ],
        };
        Ok(Self {
            path: path.to_path_buf(),
            lines: ParsedLines::new(
                file,
                pending,
                line,
                delimiter,
                MAX_LINE_BYTES,
                Box::new(move |text| reader.read(text)),
            ),
            clock: Clock::new(format.time_unit),
        })
    }

    /// The next row: its line, and time (s), x, y, z (m/s^2).
    pub fn next_row(&mut self) -> Result<Option<(u64, [f64; 4])>> {
        let shown = self.path.display();
        match self.lines.next_row() {
            None => Ok(None),
            Some(Ok((line, (time, [x, y, z])))) => {
                Ok(Some((line, [self.clock.place(time), x, y, z])))
            }
            Some(Err(BlockError::Line(e))) => Err(anyhow!("{shown}: {e}")),
            Some(Err(BlockError::Parse { line, message })) => {
                Err(anyhow!("{shown}: line {line}{message}"))
            }
        }
    }
}

/// The delimiter (`;` when the first line holds one, else `,`) and the header's fields,
/// unquoted, of the file at `path`.
pub fn read_header(path: &Path) -> Result<(u8, Vec<String>)> {
    let shown = path.display();
    let delimiter = sniff_delimiter(path)?;
    let file =
        std::fs::File::open(path).map_err(|e| anyhow!("{shown}: cannot read the ride: {e}"))?;
    let mut lines = CsvLines::with_delimiter(file, MAX_LINE_BYTES, delimiter);
    let line = lines
        .next_line()
        .map_err(|e| anyhow!("{shown}: {e}"))?
        .ok_or_else(|| anyhow!("{shown}: line 1: expected a header line, found an empty file"))?;
    let text = line.text();
    let text = text
        .strip_prefix(crate::io::small_file::UTF8_BOM)
        .unwrap_or(text);
    let text = text.strip_suffix(b"\r").unwrap_or(text);
    let cells = unquoted_cells(text, delimiter).ok_or_else(|| {
        anyhow!("{shown}: line 1: expected RFC 4180 quoting, found an unclosed quote")
    })?;
    Ok((
        delimiter,
        cells
            .into_iter()
            .map(|c| String::from_utf8_lossy(&c).into_owned())
            .collect(),
    ))
}

/// The header's fields as an error lists them: quoted, within `MAX_LISTED_CHARS`
/// including the `... (N fields)` that ends a list cut short.
pub fn listed_fields<'a>(cells: impl Iterator<Item = &'a [u8]>, width: usize) -> Vec<String> {
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
    /// A logger's file on any clock, conditioned onto a uniform grid.
    Conditioned(Box<(WindowedRows, Conditioned)>),
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
    quality: Option<DataQuality>,
    track: Option<Arc<Track>>,
}

/// The rows of a logger's file within a time window (`--from-s`, `--to-s`), raw: time
/// (s), x, y, z (m/s^2, the file's axes); parsed from the text, or read from the scan's
/// scratch copy once there is one.
#[derive(Clone, Debug)]
pub struct WindowedRows {
    /// The file.
    pub path: PathBuf,
    /// Its layout.
    pub format: ForeignFormat,
    /// Rows before this time are skipped, s.
    pub from_s: f64,
    /// Rows after this time are skipped, s.
    pub to_s: f64,
    /// The rows in the window as the scan parsed them.
    pub parsed: Option<ScratchRows>,
}

impl RawRows for WindowedRows {
    fn open_rows(&self) -> Result<FileRows<'_>> {
        if let Some(parsed) = &self.parsed {
            return parsed.open_rows();
        }
        let mut rows = ForeignRows::open(&self.path, &self.format)?;
        let (from_s, to_s) = (self.from_s, self.to_s);
        Ok(Box::new(std::iter::from_fn(move || {
            loop {
                match rows.next_row() {
                    Err(e) => return Some(Err(e)),
                    Ok(None) => return None,
                    Ok(Some((line, [t, x, y, z]))) if t >= from_s && t <= to_s => {
                        return Some(Ok((line, t, [x, y, z])));
                    }
                    Ok(Some(_)) => {}
                }
            }
        })))
    }
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
            quality: None,
            track: None,
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
            quality: None,
            track: None,
        }
    }

    /// A logger's file, its rows in `rows`' window, conditioned as `plan` says (see
    /// [`crate::ride::conditioned`]), with its data-quality account.
    pub fn conditioned(rows: WindowedRows, plan: Conditioned, quality: DataQuality) -> Self {
        Self {
            path: rows.path.clone(),
            layout: Layout::PlatformOnly,
            samples: plan.len(),
            sample_rate_hz: plan.rate_hz(),
            start_s: plan.start_s(),
            origin: Origin::Conditioned(Box::new((rows, plan))),
            gravity_removal: None,
            quality: Some(quality),
            track: None,
        }
    }

    /// The sensor's own rate when the rows are converted to another, Hz.
    pub fn converted_from_hz(&self) -> Option<f64> {
        match &self.origin {
            Origin::Conditioned(both) => both.1.converted_from_hz(),
            _ => None,
        }
    }

    /// The ride with the track of where it happened, on its clock: refused when the
    /// track does not overlap the ride in time.
    pub fn with_track(mut self, track: Track) -> Result<Self> {
        let (first, last) = track.span_s();
        let end_s = self.start_s + self.samples as f64 / self.sample_rate_hz;
        if !track.overlaps(self.start_s, end_s) {
            bail!(
                "{}: the track {} covers {first:.1}..{last:.1} s, the ride {:.1}..{end_s:.1} s: \
                 expected them to overlap in time (--track-offset-s moves the track)",
                self.path.display(),
                track.account().source,
                self.start_s
            );
        }
        self.track = Some(Arc::new(track));
        Ok(self)
    }

    /// Where the ride happened, when known.
    pub fn track(&self) -> Option<&Track> {
        self.track.as_deref()
    }

    /// The data-quality account (a logger's file; `None` for a recording).
    pub fn quality(&self) -> Option<&DataQuality> {
        self.quality.as_ref()
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
            Origin::Conditioned(both) => {
                let (rows, plan) = both.as_ref();
                Box::new(plan.samples(rows)?.map(|r| {
                    r.map(|(t, [x, y, z])| {
                        let mut row = [0.0; 13];
                        row[..4].copy_from_slice(&[t, x, y, z]);
                        row
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A reader of time, x, y, z in cells 1, 3, 0, 4 of five (cell 2 not read).
    fn reader(time_unit: TimeUnit, units: AccelUnit, delimiter: u8) -> LineReader {
        let index = [1, 3, 0, 4];
        LineReader {
            delimiter,
            width: 5,
            index,
            names: ["t", "x", "y", "z"].map(String::from),
            scale: units.to_m_s2(),
            time_unit,
            what: ["a time", "x", "y", "z"].map(String::from),
            roles: roles(&index, 5),
        }
    }

    #[test]
    fn a_line_read_in_one_walk_reads_as_the_general_reader_reads_it() {
        // Cells of every kind, plain and not, joined into lines of four to six cells.
        let cells = [
            "-0.255448",
            "3599.998",
            "0",
            "12",
            "1.",
            ".5",
            "-0.0",
            "9.80665",
            "1718030736872718943",
            "17180307368727189430",
            "1e3",
            " 1.5",
            "1.5 ",
            "\"2.5\"",
            "",
            "inf",
            "nan",
            "+5",
            "1e39",
            "x",
            "2024-06-10T14:45:36Z",
            "12345678901234567890.5",
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(0x853c_49e6_748f_ea9b);
        let mut next = move || rng.random::<u64>();
        let mut plain = 0;
        for k in 0..100_000 {
            let delimiter = if k % 2 == 0 { b',' } else { b';' };
            let time_unit = [TimeUnit::S, TimeUnit::Ms, TimeUnit::Ns, TimeUnit::Text][k % 4];
            let units = if k % 3 == 0 {
                AccelUnit::G
            } else {
                AccelUnit::MS2
            };
            let r = reader(time_unit, units, delimiter);
            let count = 4 + (next() % 3) as usize;
            let line: Vec<u8> = (0..count)
                .map(|_| {
                    // Mostly plain decimals, as a logger writes.
                    let pick = next() as usize % (3 * cells.len());
                    cells[if pick < cells.len() { pick } else { pick % 9 }].as_bytes()
                })
                .collect::<Vec<_>>()
                .join(&delimiter);
            let general = r.read_any(&line);
            if let Some(fast) = r.read_plain(&line) {
                plain += 1;
                assert_eq!(
                    Ok(format!("{fast:?}")),
                    general.map(|v| format!("{v:?}")),
                    "{}",
                    String::from_utf8_lossy(&line)
                );
            }
            // Whatever path it takes, the reader gives the general reader's value or error.
            assert_eq!(r.read(&line), r.read_any(&line));
        }
        assert!(plain > 5_000, "the one walk read only {plain} lines");
    }
}
