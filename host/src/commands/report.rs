//! `supine report`: the mission report of one or more rides (each `--input` one leg, in
//! order) for a given patient: `DIR/report.html`, and with `--json` one JSON object on
//! standard output (see [`crate::report`]). `--compare` puts two rides side by side.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context as _, Result, anyhow, bail};

use crate::commands::band_args::{BandArgs, band_threads};
use crate::io::output::write_atomically;
use crate::io::params_file::{ModelSource, ParamFile};
use crate::io::ride_input::{RideInputArgs, TrackArgs};
use crate::io::stdout::stdout_error;
use crate::io::subject_args::SubjectArgs;
use crate::io::wording::count;
use crate::report::device_check::{CheckedReport, DeviceCheckRecord};
use crate::report::{self, monitor_log, page};

/// The rides of a mission and how to evaluate them: what `supine report` and
/// `supine archive add` both take.
#[derive(Debug, clap::Args)]
pub struct MissionArgs {
    /// A ride (one leg of the mission); give one per leg, in order. A log of
    /// `supine monitor --log` (recognized by its header) is re-analysed instead: its input
    /// stream is the ride, and the device's own values are shown beside the host's.
    #[arg(long, value_name = "RIDE.csv", required = true)]
    pub input: Vec<PathBuf>,
    /// How to read the rides (another logger's columns and units, gravity).
    #[command(flatten)]
    pub ride: RideInputArgs,
    /// Where each ride happened (a GPX or location file per ride).
    #[command(flatten)]
    pub track: TrackArgs,
    /// The model parameters (and optional `[device]` table).
    #[command(flatten)]
    pub model: ModelSource,
    /// The patient.
    #[command(flatten)]
    pub subject: SubjectArgs,
}

/// Arguments of `supine report`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The rides and how to evaluate them.
    #[command(flatten)]
    pub mission: MissionArgs,
    /// Output folder for report.html (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also print the report as one JSON object on standard output.
    #[arg(long)]
    pub json: bool,
    /// The head's prediction band (needs --params written by supine fit).
    #[command(flatten)]
    pub band: BandArgs,
    /// Two rides side by side (routes, vehicles, litters), with their differences,
    /// instead of the legs of one mission.
    #[arg(long)]
    pub compare: bool,
}

/// The rides a report evaluates: `inputs` themselves, or the ride inside a monitor log
/// given as the only input (with the log and its session, for the device's account).
pub struct ReportInputs {
    /// The monitor log and its session, when the input is one.
    pub logged: Option<(PathBuf, monitor_log::LoggedSession)>,
    /// The rides, one per leg.
    pub rides: Vec<PathBuf>,
}

impl ReportInputs {
    /// Recognizes a monitor log among `inputs` (it must be the only one).
    pub fn of(inputs: &[PathBuf], file: &ParamFile) -> Result<Self> {
        let logged = match inputs {
            [one] if monitor_log::is_monitor_log(one) => {
                Some((one.clone(), monitor_log::open(one, file)?))
            }
            inputs => {
                if let Some(log) = inputs.iter().find(|p| monitor_log::is_monitor_log(p)) {
                    bail!(
                        "{}: a monitor log is re-analysed on its own: give it as the only --input",
                        log.display()
                    );
                }
                None
            }
        };
        let rides = match &logged {
            Some((_, session)) => vec![session.ride.clone()],
            None => inputs.to_vec(),
        };
        Ok(Self { logged, rides })
    }
}

/// The parameters for the patient and the mission report of `args`' rides (the legs in
/// order), as `supine report` computes them; `supine archive add` stores this same report.
pub fn mission_report(
    args: &MissionArgs,
    compare: bool,
) -> Result<(ParamFile, ReportInputs, report::MissionReport)> {
    let MissionArgs {
        input: inputs,
        ride,
        track: tracks,
        model,
        subject,
    } = args;
    let mut file = model.load_for_ride()?;
    subject.apply(&mut file)?;
    let frame = file.device.unwrap_or_default().sensor_frame();
    let found = ReportInputs::of(inputs, &file)?;
    let mut built = report::build(
        &found.rides,
        ride.opener_with_tracks(frame, tracks, &found.rides)?,
        &file,
        &model.model_name(),
        compare,
    )?;
    if !ride.labels.is_empty() {
        if ride.labels.len() != built.legs.len() {
            bail!(
                "--label: expected one per --input ({}), found {}",
                built.legs.len(),
                ride.labels.len()
            );
        }
        for (index, (leg, label)) in built.legs.iter_mut().zip(&ride.labels).enumerate() {
            leg.label = report::mission::named_leg_label(index, label, compare);
        }
    }
    if let Some((_, session)) = &found.logged
        && let Some(calibration) = session_calibration(&session.session)?
    {
        built.calibration = calibration;
    }
    Ok((file, found, built))
}

/// Builds the report, writes `report.html`, and the JSON to `out` with `--json`.
pub fn run_to(args: &Args, out: &mut impl Write) -> Result<()> {
    let (file, found, mut report) = mission_report(&args.mission, args.compare)?;
    let MissionArgs {
        ride, track, model, ..
    } = &args.mission;
    let band = args.band.request(model, &file)?;
    let frame = file.device.unwrap_or_default().sensor_frame();
    let ReportInputs {
        logged,
        rides: inputs,
    } = found;
    let rides = ride.opener_with_tracks(frame, track, &inputs)?;
    let device = match &logged {
        Some((log, session)) => {
            let ride = ride.open(&session.ride, &frame)?;
            Some(monitor_log::device_log(log, session, &file, &ride)?)
        }
        None => None,
    };
    if let Some(request) = &band {
        report.band = Some(report::prediction_band::build(
            &inputs,
            rides,
            &file,
            &report.legs,
            &report.mission,
            request,
            band_threads(),
        )?);
    }
    let page = page::render(&report, device.as_ref())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let path = args.out.join("report.html");
    write_atomically(&path, |w| Ok(w.write_all(page.as_bytes())?))?;
    if args.json {
        // Through a `Value`: every object's keys in alphabetical order, as `json_output`.
        let json = serde_json::to_value(CheckedReport {
            report: &report,
            device_check: device.as_ref().map(DeviceCheckRecord::new),
        })?;
        let text = serde_json::to_string(&json)? + "\n";
        out.write_all(text.as_bytes())
            .and_then(|()| out.flush())
            .map_err(stdout_error)?;
    }
    let summary = if args.compare {
        let [a, b] = [&report.legs[0], &report.legs[1]];
        format!(
            "2 rides compared: VDV A {:.3}, B {:.3} m/s^1.75; highest level A {}, B {}",
            a.vector.vdv_m_s175, b.vector.vdv_m_s175, a.max_level, b.max_level
        )
    } else {
        format!(
            "{}, {:.1} s, mission VDV {:.3} m/s^1.75, highest level {}",
            count(report.legs.len(), "leg"),
            report.mission.duration_s,
            report.mission.vector.vdv_m_s175,
            report.mission.max_level
        )
    };
    eprintln!("wrote {}: {summary}", path.display());
    Ok(())
}

/// The calibration a monitor session's device ran on, with its age on the day the session
/// started, if the session file recorded both (a log written before they were recorded
/// has neither: the report then states the parameter file's as of the report's date).
fn session_calibration(
    session: &crate::io::monitor_session::SessionInfo,
) -> Result<Option<report::calibration::CalibrationReport>> {
    let (Some(started), Some(table)) = (&session.started_utc, session.calibration) else {
        return Ok(None);
    };
    let date = crate::io::calibration_section::parse_date(started)
        .map_err(|e| anyhow!("the session file's started_utc: {e}"))?;
    let started = report::calibration::calendar(date)
        .ok_or_else(|| anyhow!("the session file's started_utc: {started} is not a date"))?;
    Ok(Some(report::calibration::CalibrationReport::new(
        &table.into(),
        started,
        "the session's start",
    )))
}

/// Builds and writes the report; the JSON goes to standard output.
pub fn run(args: &Args) -> Result<()> {
    run_to(args, &mut std::io::stdout().lock())
}

#[cfg(test)]
mod calibration_tests {
    use super::*;
    use crate::io::monitor_session::SessionInfo;
    use supine_core::calibration::{CalibrationDate, CalibrationMethod, SensorCalibration};

    fn session(started: Option<&str>, calibration: Option<SensorCalibration>) -> SessionInfo {
        SessionInfo {
            protocol_version: 7,
            firmware_version: "0.1.0".into(),
            params_identity: "00".into(),
            sample_rate_hz: 500.0,
            height_m: 1.75,
            mass_kg: 70.0,
            started_utc: started.map(str::to_string),
            calibration: calibration.map(Into::into),
            ..SessionInfo::default()
        }
    }

    /// A session whose device ran on a calibration 13 months old: its report says so,
    /// counted to the session's start, not to the day the report is made.
    #[test]
    fn a_session_with_a_13_month_old_calibration_is_reported_overdue() {
        let calibration = SensorCalibration {
            method: CalibrationMethod::Shaker,
            date: CalibrationDate {
                year: 2024,
                month: 5,
                day: 2,
            },
            by: SensorCalibration::by_field("Lab 3").unwrap(),
            ..SensorCalibration::DATASHEET
        };
        let info = session(Some("2025-06-10"), Some(calibration));
        // Through JSON, as the session file is read back.
        let text = serde_json::to_string(&info).unwrap();
        let info: SessionInfo = serde_json::from_str(&text).unwrap();
        let report = session_calibration(&info).unwrap().expect("a calibration");
        assert_eq!(report.age_months, Some(13));
        assert!(report.overdue && report.flagged);
        assert!(
            report
                .statement
                .contains("13 months old on 2025-06-10 (the session's start)")
                && report.statement.contains("OVERDUE"),
            "{}",
            report.statement
        );
        let mut h = String::new();
        report::calibration_section::section(&mut h, &report);
        assert!(h.contains("OVERDUE"), "{h}");
        // A log from before the record was kept: none from the session.
        assert_eq!(session_calibration(&session(None, None)).unwrap(), None);
    }
}
