//! Rides from any logger, as `exposure` and `report` read them (`docs/exposure.md#rides-from-other-loggers`).
//!
//! Without `--columns` a file is the project's own (the recording format, or a ride's
//! `time_s,platform_x,platform_y,platform_z`, read by [`crate::io::recording`]). With
//! `--columns time=NAME,x=NAME,y=NAME,z=NAME` it is another logger's CSV: the four columns
//! are found by their exact header names (other columns are ignored), the delimiter is
//! `;` when the header line holds one (spreadsheets where the decimal comma is the custom)
//! and `,` otherwise, time is in `--time-unit` and acceleration in `--units`. A byte order
//! mark, CRLF line ends and blank lines are accepted, as in every CSV the host reads, and
//! the file is read line by line ([`CsvLines`]).
//!
//! Then the gravity check ([`check_gravity`]): a vertical column whose mean lies within
//! [`GRAVITY_MARGIN_M_S2`] of +-g is a raw accelerometer reading with gravity in it, which
//! the model would take for a steady 1 g push and report nonsense from. `--remove-gravity`
//! converts every sample as the device converts its sensor's readings
//! ([`SensorFrame::to_litter_m_s2`]: the parameters' `[device.calibration]` sensitivity
//! and offset, their `[device.mounting]` rotation, then
//! gravity off the vertical), in the device's f32.

use std::io::Write as _;
use std::path::Path;

use anyhow::{Result, anyhow, bail};
use supine_core::calibration::SensorFrame;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;

use crate::io::csv_lines::CsvLines;
use crate::io::excerpt::quoted_name;
use crate::io::output::write_atomically;
use crate::io::recording::{
    Layout, LineNumbers, PLATFORM_HEADER_LINE, PlatformStream, Recording, RecordingError,
};
pub use crate::io::ride_rows::{AccelUnit, ColumnNames, TimeUnit};
use crate::io::ride_rows::{ForeignFormat, ForeignRows, OpenRide, RideSource};

/// A vertical mean within this of +-g means gravity was left in, m/s^2: a kinematic
/// acceleration averages to about zero over any ride (the litter ends where it started,
/// vertically), and 2 m/s^2 leaves room for a sensor's offset and scale error.
pub const GRAVITY_MARGIN_M_S2: f64 = 2.0;

/// How to read a ride file: `--columns`, `--time-unit`, `--units`, `--remove-gravity`,
/// shared by every command that reads a ride.
#[derive(Clone, Debug, Default, PartialEq, clap::Args)]
pub struct RideInputArgs {
    /// Another logger's CSV: the header names of its time and litter x, y, z columns
    /// (exact; other columns are ignored; `,` or `;` delimited).
    #[arg(long, value_name = "time=NAME,x=NAME,y=NAME,z=NAME", value_parser = ColumnNames::parse)]
    pub columns: Option<ColumnNames>,
    /// Unit of the time column of a `--columns` file.
    #[arg(long, value_enum, value_name = "UNIT", requires = "columns")]
    pub time_unit: Option<TimeUnit>,
    /// Unit of the acceleration columns of a `--columns` file (g = 9.80665 m/s^2).
    #[arg(long, value_enum, value_name = "UNIT", requires = "columns")]
    pub units: Option<AccelUnit>,
    /// The file is a raw accelerometer's, with gravity: convert it as the device does
    /// (the parameters' [device.calibration] and [device.mounting], then gravity off the
    /// vertical).
    #[arg(long)]
    pub remove_gravity: bool,
}

impl RideInputArgs {
    /// How another logger's file is laid out (`--columns`, `--time-unit`, `--units`).
    fn foreign_format(&self) -> Option<ForeignFormat> {
        self.columns.as_ref().map(|columns| ForeignFormat {
            columns: columns.clone(),
            time_unit: self.time_unit.unwrap_or_default(),
            units: self.units.unwrap_or_default(),
        })
    }

    /// The vertical column's name in the file, as the gravity check names it.
    fn vertical(&self) -> &str {
        match &self.columns {
            Some(c) => c.names[3].as_str(),
            None => "platform_z",
        }
    }

    /// Reads the ride at `path` whole: the project's formats, or another logger's with
    /// `--columns`; then gravity removed (`frame`, with `--remove-gravity`) and checked.
    pub fn read(&self, path: &Path, frame: &SensorFrame) -> Result<(Recording, Layout)> {
        let (mut recording, layout) = match self.foreign_format() {
            Some(format) => (read_foreign(path, &format)?, Layout::PlatformOnly),
            None => read_own(path)?,
        };
        if self.remove_gravity {
            remove_gravity(&mut recording, frame);
        }
        check_gravity(&recording, self.vertical(), self.remove_gravity)?;
        Ok((recording, layout))
    }

    /// Opens the ride at `path` to be read row by row, with the checks of
    /// [`read`](Self::read) and the same errors: every row checked (two passes), then the
    /// gravity check on the converted rows (one more). Memory holds a line.
    pub fn open(&self, path: &Path, frame: &SensorFrame) -> Result<RideSource> {
        let removal = self.remove_gravity.then_some(*frame);
        let source = match self.foreign_format() {
            Some(format) => RideSource::foreign(path, format, removal)?,
            None => RideSource::own(PlatformStream::open(path).map_err(own_error)?, removal),
        };
        let mut sum = 0.0f64;
        for row in source.rows()? {
            sum += row?[3];
        }
        if !source.is_empty() {
            let mean = sum / source.len() as f64;
            gravity_verdict(path, self.vertical(), mean, self.remove_gravity)?;
        }
        Ok(source)
    }

    /// The rides as `report` opens them: row by row, with these options and `frame`.
    pub fn opener(&self, frame: SensorFrame) -> RideOpener<'_> {
        RideOpener { args: self, frame }
    }
}

/// Opens each ride of a report row by row ([`RideInputArgs::open`]).
#[derive(Clone, Copy, Debug)]
pub struct RideOpener<'a> {
    args: &'a RideInputArgs,
    frame: SensorFrame,
}

impl OpenRide for RideOpener<'_> {
    fn open_ride(&self, path: &Path) -> Result<RideSource> {
        self.args.open(path, &self.frame)
    }
}

/// The ride at `path` as a [`PlatformStream`] for the commands that stream it
/// (`replay`): the file itself when it is in the project's format and needs no
/// conversion (gravity checked in one more pass), else the converted ride written to
/// `scratch` first, row by row (another logger's file, or `--remove-gravity`), whose
/// samples are the converted ones bit for bit.
pub fn open_stream(
    args: &RideInputArgs,
    path: &Path,
    frame: &SensorFrame,
    scratch: &Path,
) -> Result<PlatformStream> {
    if args.columns.is_none() && !args.remove_gravity {
        let stream = PlatformStream::open(path)?;
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

/// A file in the project's formats, with the header error extended by what other files
/// need.
fn read_own(path: &Path) -> Result<(Recording, Layout)> {
    let file = std::fs::File::open(path).map_err(|e| RecordingError::Read {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    Recording::from_reader(file, path, &[Layout::Full, Layout::PlatformOnly]).map_err(own_error)
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

/// Reads another logger's file whole: the four named columns, converted to s and m/s^2.
fn read_foreign(path: &Path, format: &ForeignFormat) -> Result<Recording> {
    let mut rows = ForeignRows::open(path, format)?;
    let mut recording = Recording {
        path: path.to_path_buf(),
        time_s: Vec::new(),
        platform_m_s2: Default::default(),
        sensors_m_s2: Default::default(),
    };
    let mut lines_of = LineNumbers::default();
    while let Some((line, value)) = rows.next_row()? {
        lines_of.push(recording.time_s.len(), line);
        recording.time_s.push(value[0]);
        for (axis, column) in recording.platform_m_s2.iter_mut().enumerate() {
            column.push(value[1 + axis]);
        }
    }
    recording.check_uniform(&lines_of)?;
    // The sensor columns of a ride are zeros, as the recording reader fills them.
    let n = recording.len();
    recording.sensors_m_s2 = std::array::from_fn(|_| vec![0.0; n]);
    Ok(recording)
}

/// Converts every platform sample from sensor axes with gravity to litter axes without,
/// calibration applied, as the device converts its sensor's readings (the same f32 calls).
pub fn remove_gravity(recording: &mut Recording, frame: &SensorFrame) {
    let [x, y, z] = &mut recording.platform_m_s2;
    for k in 0..z.len() {
        let litter = frame.to_litter_m_s2([x[k] as f32, y[k] as f32, z[k] as f32]);
        x[k] = f64::from(litter[0]);
        y[k] = f64::from(litter[1]);
        z[k] = f64::from(litter[2]);
    }
}

/// Refuses a ride whose vertical column (named `vertical` in the file) averages within
/// [`GRAVITY_MARGIN_M_S2`] of +-g, or of +-1 (gravity in g read as m/s^2); after
/// `--remove-gravity` (`removed`), one whose mean is not within the margin of zero.
pub fn check_gravity(recording: &Recording, vertical: &str, removed: bool) -> Result<()> {
    let z = &recording.platform_m_s2[2];
    if z.is_empty() {
        return Ok(());
    }
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    gravity_verdict(&recording.path, vertical, mean, removed)
}

/// [`check_gravity`] on a ride streamed from its file (`replay`, `monitor --input`): one
/// more pass over the file, memory for a line.
pub fn check_gravity_streamed(ride: &PlatformStream) -> Result<()> {
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for sample in ride.samples()? {
        sum += f64::from(sample?[2]);
        n += 1;
    }
    if n == 0 {
        return Ok(());
    }
    gravity_verdict(ride.path(), "platform_z", sum / n as f64, false)
}

fn gravity_verdict(path: &Path, vertical: &str, mean: f64, removed: bool) -> Result<()> {
    let g = STANDARD_GRAVITY_M_S2;
    let shown = path.display();
    let sign = if mean < 0.0 { "-" } else { "+" };
    if removed {
        if mean.abs() > GRAVITY_MARGIN_M_S2 {
            bail!(
                "{shown}: column {vertical}: mean {mean:.2} m/s^2 after --remove-gravity, expected \
                 within {GRAVITY_MARGIN_M_S2} of 0: [device.mounting] does not fit this sensor \
                 (see supine calibrate)"
            );
        }
        return Ok(());
    }
    if (mean.abs() - g).abs() <= GRAVITY_MARGIN_M_S2 {
        bail!(
            "{shown}: column {vertical}: mean {mean:.2} m/s^2, within {GRAVITY_MARGIN_M_S2} of \
             {sign}9.81: gravity left in a raw accelerometer? Give --remove-gravity \
             ([device.mounting] removes it as on the device)"
        );
    }
    if (mean.abs() - 1.0).abs() <= GRAVITY_MARGIN_M_S2 / g {
        bail!(
            "{shown}: column {vertical}: mean {mean:.2}, within {:.1} of {sign}1: gravity in g \
             read as m/s^2? Give --units g --remove-gravity (with --columns)",
            GRAVITY_MARGIN_M_S2 / g
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exposure::report::evaluate_model;
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
            remove_gravity: false,
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
        let mut text = String::from("time_s,platform_x,platform_y,platform_z\n");
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
            err.contains("raw.csv: column platform_z: mean -9.8"),
            "{err}"
        );
        assert!(
            err.contains("of -9.81") && err.contains("--remove-gravity"),
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
        // The level calibration leaves -2 g in z: still refused, with what to check.
        let err = error(removing.read(&raw, &SensorFrame::LEVEL));
        assert!(
            err.contains("mean -19.6") && err.contains("after --remove-gravity"),
            "{err}"
        );
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
            err.contains("column az: mean 1.01,") && err.contains("--units g"),
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
                 time_s,platform_x,platform_y,platform_z)",
                path.display()
            )
        );
        // The project's format with a wrong header says what other files need.
        std::fs::write(&path, "time,x,y,z\n0,0,0,0\n").unwrap();
        let err = error(RideInputArgs::default().read(&path, &SensorFrame::LEVEL));
        assert!(
            err.contains("line 1, column 1: expected \"time_s\"")
                && err.ends_with("found \"time\""),
            "{err}"
        );
        assert!(
            err.contains("(a ride: time_s,platform_x,platform_y,platform_z; else --columns)"),
            "{err}"
        );
        // A header field of 3000 bytes: the error stays short, the field cut.
        std::fs::write(&path, format!("{},b\n0,0\n", "A".repeat(3000))).unwrap();
        let err = error(RideInputArgs::default().read(&path, &SensorFrame::LEVEL));
        let own = err.strip_prefix(&format!("{}: ", path.display())).unwrap();
        assert!(own.chars().count() <= 160, "{}: {own}", own.chars().count());
        assert!(own.ends_with("(3000 bytes)"), "{own}");
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
            remove_gravity: false,
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
        args.units = None;
        std::fs::write(&path, "t,a x,a y,a z\n0,0,0,0\n2,0,0,0\n2,0,0,0\n").unwrap();
        let err = error(args.read(&path, &SensorFrame::LEVEL));
        assert!(err.ends_with("line 4, column t: expected a time after 0.002 s (strictly increasing), found 0.002 s"), "{err}");
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
        ] {
            let err = ColumnNames::parse(bad).unwrap_err();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }
}
