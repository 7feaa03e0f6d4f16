//! A device session logged by `supine monitor --log FILE.csv` as the report's input: the
//! ride is the input the device's model got (`<stem>.input.csv`), recomputed on the host,
//! and the device's own telemetry and events (`FILE.csv`, `<stem>.events.csv`) are set
//! beside the host's as a [`DeviceLog`], which the report's device section checks
//! (largest difference, identical events), as for the demo.
//!
//! The host's run is only comparable when it is the device's: the same parameters and
//! patient (the identity in `<stem>.session.json` must be the one `--preset`/`--params`
//! and the patient build), the same rate, and every sample of the input stream. Anything
//! else is refused with one line saying which file and what was expected.

use std::io::BufRead as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use supine_core::blob::DeviceParams;

use crate::device::device_params::{self, identity_hex};
use crate::device::link::LinkStats;
use crate::io::excerpt::number as excerpt_number;
use crate::io::monitor_session::{SessionInfo, input_path, session_path};
use crate::io::params_file::ParamFile;
use crate::io::ride_rows::RideSource;
use crate::io::telemetry_csv::{event_records, events_path, joint_mask_of, telemetry_records};
use crate::report::device_check::{DeviceLog, DeviceRun};
use crate::report::device_pass::{self, Session};

/// Longest first line read to recognize a monitor log, bytes.
const MAX_HEADER_BYTES: u64 = 4096;

/// Whether `path` is a telemetry log (its first line a telemetry header, with any joint
/// columns: [`joint_mask_of`]); a file that cannot be read is not one (the ride reader
/// then says why).
pub fn is_monitor_log(path: &Path) -> bool {
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let mut line = String::new();
    let mut reader = std::io::BufReader::new(std::io::Read::take(file, MAX_HEADER_BYTES));
    if reader.read_line(&mut line).is_err() {
        return false;
    }
    let line = line.trim_start_matches('\u{feff}').trim_end();
    let cells: Vec<&str> = line.split(',').collect();
    joint_mask_of(&cells).is_some()
}

/// A monitor log, checked against the parameters given, and its ride.
pub struct LoggedSession {
    /// The input the device's model got, as a ride file: the report's one leg.
    pub ride: PathBuf,
    /// What the session file says.
    pub session: SessionInfo,
    /// The parameters the device ran (rebuilt from the ones given, identity checked).
    pub params: DeviceParams,
}

/// Checks the log at `log` against `file` (the parameters and patient given): the input
/// stream is there and complete, the parameters are the device's.
pub fn open(log: &Path, file: &ParamFile) -> Result<LoggedSession> {
    let ride = input_path(log);
    let session_file = session_path(log);
    if !ride.exists() || !session_file.exists() {
        bail!(
            "{}: a monitor log without {}: the session was logged without the input stream \
             (supine monitor --log from protocol 5 on writes it), so it cannot be re-analysed",
            log.display(),
            if ride.exists() {
                session_file.display()
            } else {
                ride.display()
            }
        );
    }
    let session = SessionInfo::read(&session_file)?;
    let params = device_params::build(file, session.sample_rate_hz)
        .map_err(|e| anyhow!("{}: {e}", session_file.display()))?;
    let ours = identity_hex(&params.identity);
    if ours != session.params_identity {
        bail!(
            "{}: params_identity {} (patient {} m, {} kg), but the parameters and patient \
             given build {ours} (patient {} m, {} kg): give the --preset or --params and \
             --height-m/--mass-kg the device ran",
            session_file.display(),
            session.params_identity,
            session.height_m,
            session.mass_kg,
            params.patient.height_m,
            params.patient.mass_kg,
        );
    }
    // The identity covers the parameters and the patient; the patient the session file
    // states is the one the report prints, so it must be the one the numbers are for.
    let same = |stated: f64, built: f32| stated.is_finite() && stated as f32 == built;
    if !same(session.height_m, params.patient.height_m)
        || !same(session.mass_kg, params.patient.mass_kg)
    {
        bail!(
            "{}: patient {} m, {} kg, but the device's parameters (identity {ours}) are for \
             {} m, {} kg: expected the patient of the device's greeting",
            session_file.display(),
            excerpt_number(session.height_m),
            excerpt_number(session.mass_kg),
            params.patient.height_m,
            params.patient.mass_kg,
        );
    }
    if session.params_changed {
        bail!(
            "{}: params_changed is true: the device switched parameters during the session, \
             expected one parameter set",
            session_file.display()
        );
    }
    if session.input_samples_lost > 0 || session.input_frames_bad > 0 {
        bail!(
            "{}: input_samples_lost {} (bad frames {}): the input stream has gaps, expected \
             every sample to re-analyse {}",
            session_file.display(),
            session.input_samples_lost,
            session.input_frames_bad,
            ride.display()
        );
    }
    if session.input_samples < 2 {
        bail!(
            "{}: input_samples {}: expected at least 2 samples in {}",
            session_file.display(),
            session.input_samples,
            ride.display()
        );
    }
    Ok(LoggedSession {
        ride,
        session,
        params,
    })
}

/// The device's account and the host's for the logged session, in one pass
/// ([`device_pass`]): the host runs the device's pipeline (f32) and the f64 model on the
/// ride as read back from the input file, row by row.
pub fn device_log(
    log: &Path,
    logged: &LoggedSession,
    file: &ParamFile,
    ride: &RideSource,
) -> Result<DeviceLog> {
    let s = &logged.session;
    let fs = s.sample_rate_hz;
    if ride.len() as u64 != s.input_samples {
        bail!(
            "{}: {} samples, expected input_samples {} from {}",
            logged.ride.display(),
            ride.len(),
            s.input_samples,
            session_path(log).display()
        );
    }
    let first = s.first_input_sample.unwrap_or(0);
    let mut device_records = 0;
    for record in telemetry_records(log)? {
        record?;
        device_records += 1;
    }
    let session = Session {
        params: &logged.params,
        model: &file.params,
        sample_rate_hz: fs,
        first_sample: first,
        samples: ride.len(),
        device_records,
    };
    let input = ride.platform()?.map(|r| r.map(|x| x.map(|v| v as f32)));
    let pass = device_pass::run(
        &session,
        input,
        telemetry_records(log)?,
        event_records(&events_path(log), fs)?,
    )?;
    let name = |p: &Path| {
        p.file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
    };
    let run = DeviceRun {
        account: format!(
            "The device's session as supine monitor logged it ({}): its telemetry and alert \
                 events, and the input its model got ({}), which the host ran through the same \
                 f32 pipeline with the same parameters and through the f64 model.",
            log.display(),
            logged.ride.display()
        ),
        device_line: format!(
            "firmware {}, protocol {}, parameters {}, {} Hz, patient {} m, {} kg",
            s.firmware_version,
            s.protocol_version,
            s.params_identity,
            s.sample_rate_hz,
            s.height_m,
            s.mass_kg
        ),
        firmware_version: s.firmware_version.clone(),
        status: s.status,
        link: LinkStats {
            frames: s.link_frames,
            bad_frames: s.link_bad_frames,
            lost_frames: s.link_lost_frames,
            reordered_frames: s.link_reordered_frames,
        },
        step_times: Vec::new(),
        notes: vec![(
            "input stream".to_string(),
            format!(
                "{} samples from sample {first}, {} frames, none lost",
                s.input_samples, s.input_frames
            ),
        )],
        files: [
            (name(log), "the device's telemetry"),
            (name(&events_path(log)), "the device's alert events"),
            (name(&logged.ride), "the input the device's model got"),
            (name(&session_path(log)), "the session's facts"),
        ]
        .map(|(f, what)| (f, what.to_string()))
        .to_vec(),
    };
    Ok(pass.into_log(run, &session, Vec::new(), Vec::new()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::model::Preset;

    /// A session file for the preset's parameters at 500 Hz, stating `height_m`, `mass_kg`.
    fn session_stating(dir: &Path, height_m: f64, mass_kg: f64) -> PathBuf {
        let file = ParamFile::preset(Preset::PaperLitter);
        let params = device_params::build(&file, 500.0).unwrap();
        let log = dir.join("log.csv");
        std::fs::write(input_path(&log), "").unwrap();
        SessionInfo {
            protocol_version: 6,
            firmware_version: "test".into(),
            params_identity: identity_hex(&params.identity),
            sample_rate_hz: 500.0,
            height_m,
            mass_kg,
            input_frames: 10,
            input_samples: 1000,
            first_input_sample: Some(0),
            link_frames: 10,
            ..SessionInfo::default()
        }
        .write(&session_path(&log))
        .unwrap();
        log
    }

    #[test]
    fn the_session_files_patient_must_be_the_one_the_parameters_are_for() {
        let dir = tempfile::tempdir().unwrap();
        let file = ParamFile::preset(Preset::PaperLitter);
        let own = file.params.subject;
        let log = session_stating(
            dir.path(),
            f64::from(own.height_m as f32),
            f64::from(own.mass_kg as f32),
        );
        open(&log, &file).unwrap();
        for (height_m, mass_kg, shown) in [
            (1.6, own.mass_kg, "patient 1.6 m"),
            (own.height_m, 52.0, "kg"),
            (1e9, own.mass_kg, "patient 1000000000 m"),
        ] {
            let log = session_stating(dir.path(), height_m, mass_kg);
            let err = open(&log, &file).err().expect("refused").to_string();
            assert!(err.contains("log.session.json: patient"), "{err}");
            assert!(err.contains(shown), "{err}");
            assert!(
                err.contains("expected the patient of the device's greeting"),
                "{err}"
            );
        }
    }
}
