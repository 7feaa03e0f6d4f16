//! Rides from any logger, as every command that takes a ride reads them
//! (`docs/exposure.md#rides-from-phones-and-loggers`): `report`, `exposure`, `predict`,
//! `replay` and `monitor --input` share [`RideInputArgs`].
//!
//! A file is recognized from its header ([`crate::ride::formats`]: the project's ride,
//! phyphox, Sensor Logger, Physics Toolbox), or read by `--columns
//! time=NAME,x=NAME,y=NAME,z=NAME` (exact header names, other columns ignored; `;` or `,`
//! delimited; quoted fields read). Its clock may jitter, burst, repeat and stop: the
//! conditioning ([`crate::ride::conditioned`]) drops and counts what cannot be placed,
//! splits the ride at gaps and puts the samples on a uniform grid at `--fs` (default
//! [`DEFAULT_RATE_HZ`]; a uniform ride at a rate the device supports keeps its own), and
//! every such ride carries its data-quality account ([`crate::ride::quality`]).
//!
//! Units and gravity are checked on the magnitude of the ride's mean acceleration, which
//! does not depend on how the logger lay ([`check_units_and_gravity`]): near 9.81 m/s^2
//! is gravity, near 1 in a file read as m/s^2 is a file in g. `--remove-gravity` levels
//! the ride by its own gravity ([`crate::ride::level`]); `--mounting`, or a
//! `[device.mounting]` or `[device.calibration]` other than the default in the parameters,
//! converts it as the device does instead ([`SensorFrame::to_litter_m_s2`]: the sensor's
//! sensitivity and offset, then the mounting's rotation and gravity).
//!
//! The project's full recording (13 columns) is read as before ([`PlatformStream`]).

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use supine_core::calibration::SensorFrame;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;
use supine_core::sample_rate::SampleRate;

use crate::io::csv_lines::CsvLines;
use crate::io::excerpt::{name, number, quoted_name};
use crate::io::output::write_atomically;
use crate::io::recording::{
    Layout, PLATFORM_HEADER_LINE, PlatformStream, Recording, RecordingError, is_recording_header,
};
pub use crate::io::ride_rows::{AccelUnit, ColumnNames, TimeUnit};
use crate::io::ride_rows::{
    ForeignFormat, OpenRide, RideSource, WindowedRows, listed_fields, read_header,
};
use crate::io::track_file::{read_position_columns, read_track};
use crate::ride::conditioned::{Conditioned, Conditioning};
use crate::ride::formats::recognize;
use crate::ride::level::{Levelling, angles_rad, level_by_mean};
use crate::ride::regular::DEFAULT_MAX_GAP_S;
use crate::ride::scratch_rows::ScratchWriter;

/// A vertical mean within this of +-g means gravity was left in, m/s^2: a kinematic
/// acceleration averages to about zero over any ride (the litter ends where it started,
/// vertically), and 2 m/s^2 leaves room for a sensor's offset and scale error.
pub const GRAVITY_MARGIN_M_S2: f64 = 2.0;
/// A mean magnitude within this of 1 in a file read as m/s^2 is gravity in g.
pub const G_UNITS_MARGIN: f64 = 0.25;
/// Rows found earlier than a row whose time jumped ahead by more than a gap, at which
/// the jump is taken as a corrupt stamp and the ride refused: a logger that paused
/// goes on after the pause, and a few rows behind one stamp are a burst's reordering,
/// dropped and counted; this many are data the drop would lose.
pub const MAX_ROWS_BEHIND_A_JUMP: u64 = 10;
/// The rate a ride is evaluated at unless it is uniform at a rate the device supports,
/// or `--fs` says otherwise, Hz.
pub const DEFAULT_RATE_HZ: f64 = 500.0;

/// How to read a ride file, shared by every command that reads a ride.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct RideInputArgs {
    /// A logger's CSV whose header is not recognized: the header names of its time and
    /// litter x, y, z columns (exact; other columns are ignored; `,` or `;` delimited).
    #[arg(long, value_name = "time=NAME,x=NAME,y=NAME,z=NAME", value_parser = ColumnNames::parse)]
    pub columns: Option<ColumnNames>,
    /// Unit (or form) of the time column (else the recognized format's, or s).
    #[arg(long, value_enum, value_name = "UNIT")]
    pub time_unit: Option<TimeUnit>,
    /// Unit of the acceleration columns (else the recognized format's, or m/s2; g =
    /// 9.80665 m/s^2).
    #[arg(long, value_enum, value_name = "UNIT")]
    pub units: Option<AccelUnit>,
    /// The file is a raw accelerometer's, with gravity: level it by its own gravity and
    /// remove it (or as the parameters' [device.mounting] says, with --mounting).
    #[arg(long)]
    pub remove_gravity: bool,
    /// With --remove-gravity: convert as the parameters' [device.mounting] says (as the
    /// device does) instead of levelling by the ride's own gravity.
    #[arg(long, requires = "remove_gravity")]
    pub mounting: bool,
    /// Evaluate at this rate, Hz (default: a uniform ride's own rate if the device
    /// supports it, else 500 Hz).
    #[arg(long = "fs", value_name = "HZ")]
    pub fs_hz: Option<f64>,
    /// Longest step between samples bridged by interpolation, s; a longer one is a gap
    /// the exposure pauses across.
    #[arg(long, value_name = "S", default_value_t = DEFAULT_MAX_GAP_S)]
    pub max_gap_s: f64,
    /// Read the ride from this time on, s (the file's time; relative clocks count from
    /// the first row).
    #[arg(long, value_name = "S")]
    pub from_s: Option<f64>,
    /// Read the ride up to this time, s.
    #[arg(long, value_name = "S")]
    pub to_s: Option<f64>,
    /// A name for each ride (one per --input, in order), shown instead of its file name.
    #[arg(long = "label", value_name = "NAME")]
    pub labels: Vec<String>,
}

impl Default for RideInputArgs {
    fn default() -> Self {
        Self {
            columns: None,
            time_unit: None,
            units: None,
            remove_gravity: false,
            mounting: false,
            fs_hz: None,
            max_gap_s: DEFAULT_MAX_GAP_S,
            from_s: None,
            to_s: None,
            labels: Vec::new(),
        }
    }
}

impl RideInputArgs {
    /// Whether any option asks for more than reading the project's file as it is.
    fn converts(&self) -> bool {
        self.columns.is_some()
            || self.remove_gravity
            || self.fs_hz.is_some()
            || self.from_s.is_some()
            || self.to_s.is_some()
            || self.time_unit.is_some()
            || self.units.is_some()
    }

    /// Whether `path` is the project's full lab recording (its 13 columns, with the
    /// measured sensors) to be read as it is: `supine predict` then predicts the sensors
    /// with the continuous model, where it predicts a ride's telemetry otherwise.
    pub fn reads_lab_recording(&self, path: &Path) -> Result<bool> {
        Ok(!self.converts() && self.format(path)?.is_none())
    }

    /// How the file at `path` is laid out: `--columns`, or its recognized header;
    /// `None` for the project's full recording.
    fn format(&self, path: &Path) -> Result<Option<ForeignFormat>> {
        let units = |default: AccelUnit| self.units.unwrap_or(default);
        let time_unit = |default: TimeUnit| self.time_unit.unwrap_or(default);
        if let Some(columns) = &self.columns {
            return Ok(Some(ForeignFormat {
                name: "--columns".to_string(),
                columns: columns.clone(),
                time_unit: time_unit(TimeUnit::S),
                units: units(AccelUnit::MS2),
            }));
        }
        let (delimiter, header) = read_header(path)?;
        if is_recording_header(&header) {
            return Ok(None);
        }
        let Some(known) = recognize(&header) else {
            let guess = |k: usize| {
                header
                    .get(k)
                    .filter(|h| h.chars().count() <= 10 && !h.contains([',', '=']))
                    .map_or_else(|| "NAME".to_string(), String::clone)
            };
            bail!(
                "{}: line 1: header not recognized, found {} ({:?}-separated); give --columns time={},x={},y={},z={}",
                path.display(),
                listed_fields(header.iter().map(String::as_bytes), header.len()).join(", "),
                delimiter as char,
                guess(0),
                guess(1),
                guess(2),
                guess(3)
            );
        };
        Ok(Some(ForeignFormat {
            name: known.name.to_string(),
            columns: ColumnNames {
                names: known.columns.map(String::from),
                positions: None,
            },
            time_unit: time_unit(known.time_unit),
            units: units(known.units),
        }))
    }

    /// Opens the ride at `path` to be read row by row (see the module's description):
    /// one pass for the scan and the checks, which keeps the rows it parsed
    /// ([`crate::ride::scratch_rows`]); each of the source's passes reads them again.
    /// `frame` is the parameters' `[device.calibration]` and `[device.mounting]`, used with
    /// `--mounting` or when either is not the default.
    pub fn open(&self, path: &Path, frame: &SensorFrame) -> Result<RideSource> {
        let Some(format) = self.format(path)? else {
            return self.open_recording(path, frame);
        };
        if !(self.max_gap_s.is_finite() && self.max_gap_s > 0.0) {
            bail!(
                "--max-gap-s {}: expected a positive number of seconds",
                self.max_gap_s
            );
        }
        if let Some(fs) = self.fs_hz
            && !SampleRate::supports_hz(fs)
        {
            bail!(
                "--fs {fs}: expected a rate the device supports, {}..={} Hz",
                SampleRate::MIN_HZ,
                SampleRate::MAX_HZ
            );
        }
        let mut rows = WindowedRows {
            path: path.to_path_buf(),
            format: format.clone(),
            from_s: self.from_s.unwrap_or(f64::NEG_INFINITY),
            to_s: self.to_s.unwrap_or(f64::INFINITY),
            parsed: None,
        };
        let mut keep = ScratchWriter::new();
        let scan = Conditioned::scan_keeping(&rows, self.max_gap_s, &mut keep)?;
        rows.parsed = keep.finish();
        let shown = path.display();
        let behind = scan.longest_run_behind();
        if behind.rows >= MAX_ROWS_BEHIND_A_JUMP && behind.step_s > self.max_gap_s {
            bail!(
                "{shown}: line {}, column {}: time {} s jumps {} s ahead and the next {} rows \
                 are earlier than it, expected time to increase: a corrupt time stamp (correct or \
                 delete that row)",
                behind.line,
                name(&format.columns.names[0]),
                number(behind.time_s),
                number(behind.step_s),
                behind.rows
            );
        }
        if scan.kept < 2 {
            bail!(
                "{shown}: expected at least 2 samples{}, found {}",
                if self.from_s.is_some() || self.to_s.is_some() {
                    " in --from-s..--to-s"
                } else {
                    ""
                },
                scan.kept
            );
        }
        let mean = scan.mean_m_s2();
        check_units_and_gravity(path, mean, format.units, self.remove_gravity)?;
        let (levelling, account) = if !self.remove_gravity {
            (None, None)
        } else if self.mounting || *frame != SensorFrame::LEVEL {
            let (tilt_rad, roll_rad, pitch_rad) = angles_rad(mean);
            let z = f64::from(frame.to_litter_m_s2(mean.map(|v| v as f32))[2]);
            if z.abs() > GRAVITY_MARGIN_M_S2 {
                bail!(
                    "{shown}: mean vertical {z:.2} m/s^2 after --remove-gravity with [device.mounting], \
                     expected within {GRAVITY_MARGIN_M_S2} of 0: the mounting does not fit this \
                     sensor (see supine calibrate; or level by the ride's gravity without --mounting)"
                );
            }
            let account = Levelling {
                method: "mounting",
                gravity_m_s2: norm(mean),
                tilt_rad,
                roll_rad,
                pitch_rad,
            };
            (Some(*frame), Some(account))
        } else {
            let (m, account) = level_by_mean(mean);
            (Some(SensorFrame::from(m)), Some(account))
        };
        let effective = scan.effective_rate_hz();
        let draft = scan.account(String::new(), effective, self.max_gap_s, None);
        let uniform = draft.dropped_samples == 0
            && draft.repeated_samples == 0
            && draft.gaps == 0
            && draft.step_p99_s <= 1.01 * draft.step_median_s;
        let rate_hz = match self.fs_hz {
            Some(fs) => fs,
            None if uniform && SampleRate::supports_hz(effective) => effective,
            None => DEFAULT_RATE_HZ,
        };
        let plan = Conditioned::new(
            &scan,
            Conditioning {
                rate_hz,
                max_gap_s: self.max_gap_s,
                levelling,
            },
        )?;
        let quality = plan.account(&scan, format.name.clone(), account);
        Ok(RideSource::conditioned(rows, plan, quality))
    }

    /// The project's full recording, checked as before (uniform time, gravity on the
    /// vertical), converted with `frame` on `--remove-gravity`.
    fn open_recording(&self, path: &Path, frame: &SensorFrame) -> Result<RideSource> {
        let removal = self.remove_gravity.then_some(*frame);
        let source = RideSource::own(PlatformStream::open(path).map_err(own_error)?, removal);
        let mut sum = [0.0f64; 3];
        for row in source.rows()? {
            let row = row?;
            for (s, v) in sum.iter_mut().zip(&row[1..4]) {
                *s += v;
            }
        }
        if !source.is_empty() {
            let mean = sum.map(|s| s / source.len() as f64);
            if self.remove_gravity {
                check_removed(path, mean[2])?;
            } else {
                check_units_and_gravity(path, mean, AccelUnit::MS2, false)?;
            }
        }
        Ok(source)
    }

    /// Reads the ride at `path` whole (tests; the commands stream).
    pub fn read(&self, path: &Path, frame: &SensorFrame) -> Result<(Recording, Layout)> {
        let source = self.open(path, frame)?;
        let mut recording = Recording {
            path: path.to_path_buf(),
            time_s: Vec::new(),
            platform_m_s2: Default::default(),
            sensors_m_s2: Default::default(),
        };
        for row in source.rows()? {
            let row = row?;
            recording.time_s.push(row[0]);
            for (axis, column) in recording.platform_m_s2.iter_mut().enumerate() {
                column.push(row[1 + axis]);
            }
            for (axis, column) in recording.sensors_m_s2.iter_mut().enumerate() {
                column.push(row[4 + axis]);
            }
        }
        Ok((recording, source.layout()))
    }

    /// The rides as they are opened row by row, with these options and `frame`, each
    /// with the track of its own position columns, if any.
    pub fn opener(&self, frame: SensorFrame) -> RideOpener<'_> {
        static NO_TRACKS: TrackArgs = TrackArgs {
            tracks: Vec::new(),
            track_offset_s: 0.0,
        };
        RideOpener {
            args: self,
            frame,
            tracks: &NO_TRACKS,
            inputs: &[],
        }
    }

    /// The rides `inputs` as `report` opens them: [`opener`](Self::opener), each with
    /// its track from `tracks` (one per input) or its own position columns.
    pub fn opener_with_tracks<'a>(
        &'a self,
        frame: SensorFrame,
        tracks: &'a TrackArgs,
        inputs: &'a [PathBuf],
    ) -> Result<RideOpener<'a>> {
        if !tracks.tracks.is_empty() && tracks.tracks.len() != inputs.len() {
            bail!(
                "--track: expected one per --input ({}), found {}",
                inputs.len(),
                tracks.tracks.len()
            );
        }
        Ok(RideOpener {
            args: self,
            frame,
            tracks,
            inputs,
        })
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Refuses a ride whose units or gravity disagree with what was given, from the
/// magnitude of its mean acceleration `mean_m_s2` (read in `units`), whatever the
/// logger's orientation: near 1 in a file read as m/s^2 is a file in g; near 9.81 in
/// a file read as g is one in m/s^2; near 9.81 m/s^2 is gravity, which
/// `--remove-gravity` (`remove`) must be given for, and without which it must not.
pub fn check_units_and_gravity(
    path: &Path,
    mean_m_s2: [f64; 3],
    units: AccelUnit,
    remove: bool,
) -> Result<()> {
    let shown = path.display();
    let g = STANDARD_GRAVITY_M_S2;
    let m = norm(mean_m_s2);
    let raw = m / units.to_m_s2();
    let [x, y, z] = mean_m_s2.map(|v| v / units.to_m_s2());
    let means = format!("mean x {x:.3}, y {y:.3}, z {z:.3}, magnitude {raw:.3}");
    if units == AccelUnit::MS2 && (raw - 1.0).abs() <= G_UNITS_MARGIN {
        bail!(
            "{shown}: {means}, near 1: gravity in g read as m/s^2? Give --units g (with \
             --remove-gravity)"
        );
    }
    if units == AccelUnit::G && (raw - g).abs() <= GRAVITY_MARGIN_M_S2 {
        bail!("{shown}: {means} g, near 9.81: a file in m/s^2 read as g? Give --units m/s2");
    }
    let gravity = (m - g).abs() <= GRAVITY_MARGIN_M_S2;
    if gravity && !remove {
        bail!(
            "{shown}: {means} m/s^2, near 9.81: gravity left in a raw accelerometer? Give \
             --remove-gravity"
        );
    }
    if remove && !gravity {
        bail!(
            "{shown}: --remove-gravity: {means} {}, expected a magnitude near 9.81 m/s^2 \
             (gravity): no gravity to remove here, or other units (--units)",
            units.name()
        );
    }
    Ok(())
}

/// Where each ride of a report happened (`docs/exposure.md#positions-and-road-segments`).
#[derive(Clone, Debug, Default, PartialEq, clap::Args)]
pub struct TrackArgs {
    /// The track of where a ride happened, one per --input in order: a GPX 1.1 file
    /// (`.gpx`), or a phone app's location file (Sensor Logger's or phyphox's
    /// Location.csv). A ride whose own file has lat= and lon= --columns needs none.
    #[arg(long = "track", visible_aliases = ["gpx", "positions"], value_name = "FILE")]
    pub tracks: Vec<PathBuf>,
    /// The ride's time of the track's time zero (the first GPX point, or the location
    /// file's clock zero), s: the track is moved by this.
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub track_offset_s: f64,
}

/// Opens each ride of a report row by row ([`RideInputArgs::open`]), with its track.
#[derive(Clone, Copy, Debug)]
pub struct RideOpener<'a> {
    args: &'a RideInputArgs,
    frame: SensorFrame,
    tracks: &'a TrackArgs,
    inputs: &'a [PathBuf],
}

impl OpenRide for RideOpener<'_> {
    fn open_ride(&self, path: &Path) -> Result<RideSource> {
        let source = self.args.open(path, &self.frame)?;
        let offset = self.tracks.track_offset_s;
        if !offset.is_finite() {
            bail!("--track-offset-s {offset}: expected a finite number of seconds");
        }
        let given = self
            .inputs
            .iter()
            .position(|p| p == path)
            .and_then(|i| self.tracks.tracks.get(i));
        let track = match (
            given,
            self.args
                .columns
                .as_ref()
                .and_then(|c| c.positions.as_ref()),
        ) {
            (Some(file), _) => read_track(file)?,
            (None, Some(columns)) => {
                let format = self.args.format(path)?.map_or(TimeUnit::S, |f| f.time_unit);
                read_position_columns(path, columns, format, "--columns")?
            }
            (None, None) => return Ok(source),
        };
        source.with_track(track.shifted(offset))
    }
}

/// The ride at `path` as a [`PlatformStream`] for the commands that stream it
/// (`replay`, `monitor --input`): the file itself when it is the project's (a full
/// recording, or a uniform ride at a rate the device supports) and no option converts it
/// (gravity checked in one more pass), else the conditioned ride written to `scratch`
/// first, row by row, whose samples are the conditioned ones bit for bit.
pub fn open_stream(
    args: &RideInputArgs,
    path: &Path,
    frame: &SensorFrame,
    scratch: &Path,
) -> Result<PlatformStream> {
    if !args.converts()
        && let Ok(stream) = PlatformStream::open(path)
    {
        check_gravity_streamed(&stream)?;
        return Ok(stream);
    }
    let source = args.open(path, frame)?;
    let converted = scratch.join("ride.csv");
    write_atomically(&converted, |w| {
        writeln!(w, "{PLATFORM_HEADER_LINE}")?;
        for row in source.rows()? {
            let [t, x, y, z, ..] = row?;
            // Shortest round-trip form: the same numbers read back.
            writeln!(w, "{t},{x},{y},{z}")?;
        }
        Ok(())
    })?;
    Ok(PlatformStream::open(&converted)?)
}

/// A recording error of a file read as a ride: a header error within the 200 characters
/// of an error (the field quoted shorter, the ride's header and the way to other loggers'
/// files added); others as they are.
fn own_error(e: RecordingError) -> anyhow::Error {
    match e {
        RecordingError::Header {
            path,
            column,
            expected,
            ..
        } => anyhow!(
            "{}: line 1, column {column}: expected \"{expected}\" (a ride: \
             {PLATFORM_HEADER_LINE}; else --columns), found {}",
            path.display(),
            header_field(&path, column)
        ),
        other => other.into(),
    }
}

/// Header field `column` (1-based) of the file at `path`, as a name is quoted in errors.
fn header_field(path: &Path, column: usize) -> String {
    let Ok(file) = std::fs::File::open(path) else {
        return "an unreadable header".to_string();
    };
    let mut lines = CsvLines::new(file);
    match lines.next_row() {
        Ok(Some(row)) if column <= row.len() => quoted_name(row.cell(column - 1)),
        _ => "end of line".to_string(),
    }
}

/// The gravity check of the project's recording streamed from its file (`replay`, `monitor --input`): one
/// more pass over the file, memory for a line.
pub fn check_gravity_streamed(ride: &PlatformStream) -> Result<()> {
    let mut sum = [0.0f64; 3];
    let mut n = 0usize;
    for sample in ride.samples()? {
        for (s, v) in sum.iter_mut().zip(sample?) {
            *s += f64::from(v);
        }
        n += 1;
    }
    if n == 0 {
        return Ok(());
    }
    check_units_and_gravity(
        ride.path(),
        sum.map(|s| s / n as f64),
        AccelUnit::MS2,
        false,
    )
}

/// Refuses a recording whose vertical (`platform_z`) still averages away from zero
/// (`mean`, m/s^2) after `[device.mounting]` removed gravity.
fn check_removed(path: &Path, mean: f64) -> Result<()> {
    if mean.abs() > GRAVITY_MARGIN_M_S2 {
        bail!(
            "{}: column platform_z: mean {mean:.2} m/s^2 after --remove-gravity, expected \
             within {GRAVITY_MARGIN_M_S2} of 0: [device.mounting] does not fit this sensor \
             (see supine calibrate)",
            path.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exposure::model_exposure::evaluate_model;
    use crate::exposure::ride::{Profile, generate, write_ride};
    use crate::io::params_file::ParamFile;
    use supine_core::model::Preset;

    /// A 12 s helicopter ride at 500 Hz, in the project's format and as a spreadsheet
    /// export of another logger: BOM, `;`, CRLF, time in ms, acceleration in g, an extra
    /// column first and the axes in another order.
    fn two_files(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
        let ride = generate(Profile::Helicopter, 12.0, 500.0, 7).unwrap();
        let own = dir.join("ride.csv");
        write_ride(&own, &ride).unwrap();
        let mut text = String::from("\u{feff}Temp (C);Time (ms);Acc Z [g];Acc X [g];Acc Y [g]\r\n");
        let g = STANDARD_GRAVITY_M_S2;
        let [x, y, z] = &ride.platform_m_s2;
        for k in 0..ride.len() {
            text.push_str(&format!(
                "21.5;{};{:.9e};{:.9e};{:.9e}\r\n",
                2 * k,
                z[k] / g,
                x[k] / g,
                y[k] / g
            ));
        }
        let foreign = dir.join("logger.csv");
        std::fs::write(&foreign, text).unwrap();
        (own, foreign)
    }

    fn foreign_args() -> RideInputArgs {
        RideInputArgs {
            columns: Some(
                ColumnNames::parse("time=Time (ms),x=Acc X [g],y=Acc Y [g],z=Acc Z [g]").unwrap(),
            ),
            time_unit: Some(TimeUnit::Ms),
            units: Some(AccelUnit::G),
            ..RideInputArgs::default()
        }
    }

    /// The error of `result`, without printing a ride when there is none.
    fn error<T>(result: Result<T>) -> String {
        match result {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn another_loggers_file_gives_the_values_of_the_same_ride_in_the_projects_format() {
        let dir = tempfile::tempdir().unwrap();
        let (own, foreign) = two_files(dir.path());
        let level = SensorFrame::LEVEL;
        let (a, _) = RideInputArgs::default().read(&own, &level).unwrap();
        let (b, layout) = foreign_args().read(&foreign, &level).unwrap();
        assert_eq!(layout, Layout::PlatformOnly);
        assert_eq!(a.len(), b.len());
        assert!((a.sample_rate_hz() - b.sample_rate_hz()).abs() < 1e-9);
        for axis in 0..3 {
            for (p, q) in a.platform_m_s2[axis].iter().zip(&b.platform_m_s2[axis]) {
                // The project file holds 1e-6 m/s^2; the g file 10 significant digits.
                assert!((p - q).abs() <= 1e-6 + 1e-7 * p.abs(), "{p} vs {q}");
            }
        }
        let file = ParamFile::preset(Preset::PaperLitter);
        let ea = evaluate_model(
            &foreign_args().open(&foreign, &level).unwrap(),
            &file,
            "m".into(),
            None,
        )
        .unwrap();
        let from_memory = RideSource::from_recording(a, Layout::PlatformOnly);
        let eb = evaluate_model(&from_memory, &file, "m".into(), None).unwrap();
        for (va, vb) in [
            (ea.vector.rms_m_s2, eb.vector.rms_m_s2),
            (ea.vector.vdv_m_s175, eb.vector.vdv_m_s175),
            (ea.vector.mtvv_m_s2, eb.vector.mtvv_m_s2),
            (ea.head[2].peak_m_s2, eb.head[2].peak_m_s2),
        ] {
            assert!((va - vb).abs() <= 1e-5 * va.abs(), "{va} vs {vb}");
        }
    }

    #[test]
    fn gravity_left_in_is_refused_and_removed_as_the_device_removes_it() {
        let dir = tempfile::tempdir().unwrap();
        let (own, _) = two_files(dir.path());
        let (clean, _) = RideInputArgs::default()
            .read(&own, &SensorFrame::LEVEL)
            .unwrap();
        // The same ride from a sensor mounted upside down about x: z reads -(a_z + g).
        let mut text = format!("{PLATFORM_HEADER_LINE}\n");
        let g = STANDARD_GRAVITY_M_S2;
        for k in 0..clean.len() {
            text.push_str(&format!(
                "{},{},{},{}\n",
                clean.time_s[k],
                clean.platform_m_s2[0][k],
                -clean.platform_m_s2[1][k],
                -(clean.platform_m_s2[2][k] + g)
            ));
        }
        let raw = dir.path().join("raw.csv");
        std::fs::write(&raw, text).unwrap();
        let err = error(RideInputArgs::default().read(&raw, &SensorFrame::LEVEL));
        assert!(
            err.contains("raw.csv: mean x ") && err.contains("z -9.8"),
            "{err}"
        );
        assert!(
            err.contains("near 9.81") && err.contains("--remove-gravity"),
            "{err}"
        );
        assert!(!err.contains('\n'));
        let upside_down = SensorFrame::from(supine_core::mounting::Mounting {
            sensor_to_litter: [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
            gravity_m_s2: g as f32,
        });
        let removing = RideInputArgs {
            remove_gravity: true,
            ..RideInputArgs::default()
        };
        // With the level calibration asked for (--mounting), -2 g stay in z: refused, with
        // what to check.
        let by_mounting = RideInputArgs {
            mounting: true,
            ..removing.clone()
        };
        let err = error(by_mounting.read(&raw, &SensorFrame::LEVEL));
        assert!(
            err.contains("mean vertical -19.6") && err.contains("after --remove-gravity"),
            "{err}"
        );
        // Levelled by its own gravity, the ride is the clean one, less the ride's own mean
        // z (gravity is measured, not assumed: its magnitude is the mean's).
        let (levelled, _) = removing.read(&raw, &SensorFrame::LEVEL).unwrap();
        let mean_z = clean.platform_m_s2[2].iter().sum::<f64>() / clean.len() as f64;
        for axis in 0..3 {
            for (p, q) in clean.platform_m_s2[axis]
                .iter()
                .zip(&levelled.platform_m_s2[axis])
            {
                let offset = if axis == 2 { mean_z } else { 0.0 };
                assert!((p - offset - q).abs() <= 1e-4, "{p} vs {q}");
            }
        }
        let (fixed, _) = removing.read(&raw, &upside_down).unwrap();
        for axis in 0..3 {
            for (p, q) in clean.platform_m_s2[axis]
                .iter()
                .zip(&fixed.platform_m_s2[axis])
            {
                // f32 arithmetic around 9.8 m/s^2: a few ulp of g.
                assert!((p - q).abs() <= 4e-6, "{p} vs {q}");
            }
        }
    }

    #[test]
    fn gravity_in_g_read_as_m_s2_is_refused_with_the_units_to_give() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.csv");
        let mut text = String::from("t;ax;ay;az\n");
        for k in 0..100 {
            text.push_str(&format!(
                "{};0.01;0;{}\n",
                k as f64 * 0.01,
                1.0 + 0.01 * (k % 3) as f64
            ));
        }
        std::fs::write(&path, text).unwrap();
        let args = RideInputArgs {
            columns: Some(ColumnNames::parse("time=t,x=ax,y=ay,z=az").unwrap()),
            ..RideInputArgs::default()
        };
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert!(
            err.contains("g.csv: mean x 0.010, y 0.000, z 1.010, magnitude 1.010, near 1")
                && err.contains("--units g"),
            "{err}"
        );
    }

    #[test]
    fn a_header_without_the_named_column_names_file_line_field_and_the_ride_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("logger.csv");
        std::fs::write(&path, "\u{feff}Time (ms);AccX;AccY;AccZ\r\n0;0;0;0\r\n").unwrap();
        let args = RideInputArgs {
            columns: Some(ColumnNames::parse("time=Time (ms),x=Acc X,y=AccY,z=AccZ").unwrap()),
            ..RideInputArgs::default()
        };
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert_eq!(
            err,
            format!(
                "{}: line 1: --columns x=: expected a field \"Acc X\", found \"Time (ms)\", \
                 \"AccX\", \"AccY\", \"AccZ\" (';'-separated; a ride: \
                 time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2)",
                path.display()
            )
        );
        // A header with two fields of the named column's name: refused, not the first taken.
        std::fs::write(&path, "Time (ms);AccX;AccY;AccZ;AccX\n0;0;0;0;1\n").unwrap();
        let args = RideInputArgs {
            columns: Some(ColumnNames::parse("time=Time (ms),x=AccX,y=AccY,z=AccZ").unwrap()),
            ..RideInputArgs::default()
        };
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert_eq!(
            err,
            format!(
                "{}: line 1: --columns x=: the header has fields 2 and 5 both named \"AccX\": \
                 expected a name that appears once (rename one in the file)",
                path.display()
            )
        );
        // An unrecognized header: the columns found and the --columns to give.
        std::fs::write(&path, "time,x,y,z\n0,0,0,0\n").unwrap();
        let err = error(RideInputArgs::default().read(&path, &SensorFrame::LEVEL));
        assert!(
            err.contains("line 1: header not recognized")
                && err.ends_with(
                    "found \"time\", \"x\", \"y\", \"z\" (','-separated); give --columns \
                     time=time,x=x,y=y,z=z"
                ),
            "{err}"
        );
        // A header field of 3000 bytes: the error stays short, the field cut.
        std::fs::write(&path, format!("{},b\n0,0\n", "A".repeat(3000))).unwrap();
        let err = error(RideInputArgs::default().read(&path, &SensorFrame::LEVEL));
        let own = err.strip_prefix(&format!("{}: ", path.display())).unwrap();
        assert!(own.chars().count() <= 200, "{}: {own}", own.chars().count());
        assert!(
            own.contains("(2 fields)") && own.contains("time=NAME,x=b,"),
            "{own}"
        );
    }

    #[test]
    fn a_bad_cell_names_file_line_column_and_the_unit_expected() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("logger.csv");
        std::fs::write(&path, "t,a x,a y,a z\n0,0,0,0\n2,0,0,0\n4,0,0,0,5\n").unwrap();
        let mut args = RideInputArgs {
            columns: Some(ColumnNames::parse("time=t,x=a x,y=a y,z=a z").unwrap()),
            time_unit: Some(TimeUnit::Ms),
            units: Some(AccelUnit::G),
            ..RideInputArgs::default()
        };
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert!(
            err.ends_with("line 4: expected 4 ','-separated cells as in the header, found 5"),
            "{err}"
        );
        std::fs::write(&path, "t,a x,a y,a z\n0,0,0,0\n2,0,0\u{1b}x,0\n").unwrap();
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert!(
            err.ends_with("line 3, column a y: expected an acceleration in g (a finite number), found \"0\\u{1b}x\""),
            "{err}"
        );
        std::fs::write(&path, "t,a x,a y,a z\n0,0,0,0\n2,0,0,x\n").unwrap();
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert!(
            err.ends_with(
                "line 3, column a z: expected an acceleration in g (a finite number), found \"x\""
            ),
            "{err}"
        );
        args.time_unit = Some(TimeUnit::Text);
        std::fs::write(&path, "t,a x,a y,a z\n12:00:00.000,0,0,0\n12:00:61,0,0,0\n").unwrap();
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert!(
            err.ends_with("line 3, column t: expected a date-time (ISO 8601) or clock time (HH:MM:SS.f), found \"12:00:61\""),
            "{err}"
        );
    }

    #[test]
    fn a_streamed_ride_gives_the_samples_of_the_read_one_and_the_same_gravity_check() {
        let dir = tempfile::tempdir().unwrap();
        let (own, foreign) = two_files(dir.path());
        let scratch = tempfile::tempdir().unwrap();
        let level = SensorFrame::LEVEL;
        let stream = open_stream(&foreign_args(), &foreign, &level, scratch.path()).unwrap();
        let (read, _) = foreign_args().read(&foreign, &level).unwrap();
        let samples: Vec<[f32; 3]> = stream.samples().unwrap().map(Result::unwrap).collect();
        assert_eq!(samples, read.platform_samples());
        assert_eq!(stream.sample_rate_hz(), read.sample_rate_hz());
        // The project's own file is streamed as it is, after the gravity check.
        let plain = open_stream(&RideInputArgs::default(), &own, &level, scratch.path()).unwrap();
        assert_eq!(plain.path(), own.as_path());
        let raw = dir.path().join("raw.csv");
        let text = std::fs::read_to_string(&own).unwrap();
        let mut shifted = String::from(PLATFORM_HEADER_LINE);
        for line in text.lines().skip(1) {
            let cells: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
            shifted.push_str(&format!(
                "\n{},{},{},{}",
                cells[0],
                cells[1],
                cells[2],
                cells[3] + STANDARD_GRAVITY_M_S2
            ));
        }
        std::fs::write(&raw, shifted).unwrap();
        let streamed = error(open_stream(
            &RideInputArgs::default(),
            &raw,
            &level,
            scratch.path(),
        ));
        let read = error(RideInputArgs::default().read(&raw, &level));
        assert_eq!(streamed, read);
    }

    #[test]
    fn a_ride_opened_row_by_row_gives_the_read_rides_rows_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let (own, foreign) = two_files(dir.path());
        let level = SensorFrame::LEVEL;
        let upside_down = SensorFrame::from(supine_core::mounting::Mounting {
            sensor_to_litter: [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
            gravity_m_s2: STANDARD_GRAVITY_M_S2 as f32,
        });
        let removing = RideInputArgs {
            remove_gravity: true,
            ..foreign_args()
        };
        for (args, path, mounting) in [
            (RideInputArgs::default(), &own, &level),
            (foreign_args(), &foreign, &level),
            (removing, &foreign, &upside_down),
        ] {
            // Upside down, the level ride reads -2 g in z after the removal: refused alike.
            let (read, layout) = match args.read(path, mounting) {
                Ok(read) => read,
                Err(e) => {
                    assert_eq!(error(args.open(path, mounting)), e.to_string());
                    continue;
                }
            };
            let source = args.open(path, mounting).unwrap();
            assert_eq!(source.layout(), layout);
            assert_eq!(source.len(), read.len());
            assert_eq!(source.sample_rate_hz(), read.sample_rate_hz());
            assert_eq!(source.start_s(), read.time_s[0]);
            let rows: Vec<[f64; 3]> = source.platform().unwrap().map(Result::unwrap).collect();
            let whole: Vec<[f64; 3]> = (0..read.len())
                .map(|k| read.platform_m_s2.each_ref().map(|c| c[k]))
                .collect();
            assert_eq!(rows, whole);
        }
        // Every refusal of a file in the same words.
        let path = dir.path().join("logger.csv");
        let args = RideInputArgs {
            columns: Some(ColumnNames::parse("time=t,x=a x,y=a y,z=a z").unwrap()),
            ..RideInputArgs::default()
        };
        for text in [
            "t,a x,a y,a z\n0,0,0,0\n2,0,0,0\n4,0,0,0,5\n",
            "t,a x,a y,a z\n0,0,0,0\n2,0,0\u{1b}x,0\n",
            "t,a x,a y,a z\n0,0,0,0\n2,0,0,0\n2,0,0,0\n",
            "t,a x,a y,a z\n0,0,0,0\n2,0,0,0\n4.1,0,0,0\n6,0,0,0\n",
            "t,b x,a y,a z\n0,0,0,0\n",
            "t,a x,a y,a z\n0,0,0,9.8\n1,0,0,9.8\n",
        ] {
            std::fs::write(&path, text).unwrap();
            let read = error(args.read(&path, &level));
            assert_eq!(error(args.open(&path, &level)), read, "{text}");
        }
    }

    #[test]
    fn columns_are_parsed_strictly() {
        let ok = ColumnNames::parse("z=Z axis,time=t,y=Y,x=X").unwrap();
        assert_eq!(ok.names, ["t", "X", "Y", "Z axis"].map(String::from));
        for (bad, says) in [
            ("time=t,x=X,y=Y", "missing z"),
            ("time=t,x=X,y=Y,z=Z,x=X2", "x= given twice"),
            ("time=t,x=X,y=Y,w=Z", "expected one of the keys"),
            ("time=t,x,y=Y,z=Z", "expected KEY=NAME"),
            ("time=,x=X,y=Y,z=Z", "expected a column name"),
            ("time=t,x=A,y=A,z=Z", "x= and y= name the same column \"A\""),
        ] {
            let err = ColumnNames::parse(bad).unwrap_err();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }
}
