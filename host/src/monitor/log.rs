//! The monitor's CSV log: every telemetry record and every alert event, in the formats of
//! `supine replay` (two files: `LOG.csv` with [`telemetry_header`], `<stem>.events.csv`
//! with [`EVENTS_HEADER`]), so one reader serves both commands (the telemetry header's
//! joint columns are the ones the device's greeting announces, so it is written when the
//! first telemetry record comes, or at the end if none does); and, for a re-analysis
//! (`supine report --input LOG.csv`), the device's input stream as a ride
//! (`<stem>.input.csv`) and the session's facts (`<stem>.session.json`), see
//! [`crate::io::monitor_session`].
//!
//! The log is written while the session runs, into `<name>.partial` files flushed at least
//! every [`FLUSH_INTERVAL`] (a crash loses at most that much, and leaves files whose name
//! says they are incomplete); [`MonitorLog::finish`] flushes and renames them into place
//! and writes the session file.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use supine_core::protocol::{DeviceToHost, Greeting, InputBatch};

use crate::device::device_params::identity_hex;
use crate::device::link::LinkStats;
use crate::io::monitor_session::{
    PLATFORM_HEADER_LINE, SessionInfo, input_path, input_row, session_path,
};
use crate::io::telemetry_csv::{
    EVENTS_HEADER, event_row, events_path, telemetry_header, telemetry_row,
};
use crate::schema::shortest;

/// Longest time between flushes.
pub const FLUSH_INTERVAL: Duration = Duration::from_secs(1);

/// One CSV file being written under its `.partial` name.
struct LiveFile {
    path: PathBuf,
    partial: PathBuf,
    out: BufWriter<File>,
}

impl LiveFile {
    fn create(path: &Path, header: Option<&str>) -> Result<Self> {
        let name = path
            .file_name()
            .ok_or_else(|| anyhow!("{}: not a file name", path.display()))?
            .to_string_lossy();
        let partial = path.with_file_name(format!("{name}.partial"));
        let file = File::create(&partial)
            .map_err(|e| anyhow!("{}: cannot create: {e}", partial.display()))?;
        let mut live = Self {
            path: path.to_path_buf(),
            partial,
            out: BufWriter::new(file),
        };
        if let Some(header) = header {
            live.write(&format!("{header}\n"))?;
        }
        Ok(live)
    }

    fn write(&mut self, line: &str) -> Result<()> {
        self.out
            .write_all(line.as_bytes())
            .map_err(|e| anyhow!("{}: cannot write: {e}", self.partial.display()))
    }

    fn flush(&mut self) -> Result<()> {
        self.out
            .flush()
            .map_err(|e| anyhow!("{}: cannot write: {e}", self.partial.display()))
    }

    fn finish(mut self) -> Result<PathBuf> {
        self.flush()?;
        std::fs::rename(&self.partial, &self.path)
            .map_err(|e| anyhow!("{}: cannot write: {e}", self.path.display()))?;
        Ok(self.path)
    }
}

/// The telemetry, events and input files of one monitoring session.
pub struct MonitorLog {
    telemetry: LiveFile,
    events: LiveFile,
    input: LiveFile,
    session_path: PathBuf,
    /// Known from the first greeting on.
    session: Option<SessionInfo>,
    /// The index the next input sample must have to follow the file's last row.
    next_input: Option<u32>,
    last_flush: Instant,
    rows: u64,
    /// The joint outputs the last greeting announced (none before one).
    joint_mask: u16,
    /// Whether the telemetry file has its header yet.
    header_written: bool,
}

/// The files a finished log left.
#[derive(Clone, Debug, PartialEq)]
pub struct LogFiles {
    /// Telemetry CSV.
    pub telemetry: PathBuf,
    /// Alert events CSV.
    pub events: PathBuf,
    /// The input stream as a ride.
    pub input: PathBuf,
    /// The session file and what it says, when the device greeted.
    pub session: Option<(PathBuf, SessionInfo)>,
}

impl MonitorLog {
    /// Creates `path` (telemetry), its `<stem>.events.csv` and `<stem>.input.csv` under
    /// `.partial` names.
    pub fn create(path: &Path) -> Result<Self> {
        let telemetry = LiveFile::create(path, None)?;
        let events = match LiveFile::create(&events_path(path), Some(EVENTS_HEADER)) {
            Ok(events) => events,
            Err(e) => {
                let _ = std::fs::remove_file(&telemetry.partial);
                return Err(e);
            }
        };
        let input = match LiveFile::create(&input_path(path), Some(PLATFORM_HEADER_LINE)) {
            Ok(input) => input,
            Err(e) => {
                let _ = std::fs::remove_file(&telemetry.partial);
                let _ = std::fs::remove_file(&events.partial);
                return Err(e);
            }
        };
        Ok(Self {
            telemetry,
            events,
            input,
            session_path: session_path(path),
            session: None,
            next_input: None,
            last_flush: Instant::now(),
            rows: 0,
            joint_mask: 0,
            header_written: false,
        })
    }

    /// Records the device from its greeting: the first one names the session's
    /// parameters and patient; a later one with other parameters or another rate marks
    /// the session as covering two parameter sets. Until the telemetry header is written,
    /// the greeting's joint outputs are taken as its joint columns.
    pub fn on_greeting(&mut self, g: &Greeting) {
        if !self.header_written {
            self.joint_mask = g.joint_outputs;
        }
        let identity = identity_hex(&g.params_identity);
        let rate_hz = f64::from(g.sample_rate_hz);
        match &mut self.session {
            Some(s) => {
                if s.params_identity != identity || s.sample_rate_hz != rate_hz {
                    s.params_changed = true;
                }
            }
            None => {
                self.session = Some(SessionInfo {
                    protocol_version: g.protocol_version,
                    firmware_version: g.firmware_version.to_string(),
                    params_identity: identity,
                    sample_rate_hz: rate_hz,
                    height_m: shortest(g.height_m),
                    mass_kg: shortest(g.mass_kg),
                    started_utc: Some(crate::io::calibration_section::today().to_string()),
                    calibration: Some(g.calibration.into()),
                    ..SessionInfo::default()
                });
            }
        }
    }

    /// Writes an input frame's samples. A sample that does not follow the file's last
    /// row is never written out of place: a jump forward counts the samples skipped as
    /// lost (the file then has a gap in time, which a ride reader refuses), a jump back
    /// (a restarted stream) counts the sample itself as lost.
    fn on_input(&mut self, batch: &InputBatch, sample_rate_hz: f64) -> Result<()> {
        let Some(session) = self.session.as_mut() else {
            return Ok(());
        };
        session.input_frames += 1;
        let Ok(samples) = batch.samples() else {
            session.input_frames_bad += 1;
            return Ok(());
        };
        for (index, counts) in samples {
            if let Some(expected) = self.next_input
                && index != expected
            {
                if index > expected {
                    session.input_samples_lost += u64::from(index - expected);
                } else {
                    session.input_samples_lost += 1;
                    continue;
                }
            }
            session.first_input_sample.get_or_insert(index);
            self.input
                .write(&input_row(index, counts, sample_rate_hz))?;
            session.input_samples += 1;
            self.next_input = index.checked_add(1);
        }
        Ok(())
    }

    /// Writes the telemetry header, with the joint columns announced so far, if not yet.
    fn ensure_header(&mut self) -> Result<()> {
        if !self.header_written {
            self.header_written = true;
            self.telemetry
                .write(&format!("{}\n", telemetry_header(self.joint_mask)))?;
        }
        Ok(())
    }

    /// Records the link's counters as they stand (the last call before `finish` is what
    /// the session file says).
    pub fn on_link(&mut self, stats: LinkStats) {
        if let Some(s) = self.session.as_mut() {
            s.link_frames = stats.frames;
            s.link_lost_frames = stats.lost_frames;
            s.link_bad_frames = stats.bad_frames;
            s.link_reordered_frames = stats.reordered_frames;
        }
    }

    /// What the session file will say (once the device greeted).
    pub fn session(&self) -> Option<&SessionInfo> {
        self.session.as_ref()
    }

    /// The final paths: telemetry, events.
    pub fn paths(&self) -> (&Path, &Path) {
        (&self.telemetry.path, &self.events.path)
    }

    /// Logs a telemetry record, an alert event or input samples (times at
    /// `sample_rate_hz`), and records a greeting; other messages are not logged. Flushes
    /// when [`FLUSH_INTERVAL`] has passed.
    pub fn on_message(&mut self, message: &DeviceToHost, sample_rate_hz: f64) -> Result<()> {
        match message {
            DeviceToHost::Greeting(g) => self.on_greeting(g),
            DeviceToHost::Telemetry(t) => {
                self.ensure_header()?;
                self.telemetry.write(&telemetry_row(t, sample_rate_hz))?;
                self.rows += 1;
            }
            DeviceToHost::Alert(e) => self.events.write(&event_row(e, sample_rate_hz))?,
            DeviceToHost::Input(batch) => self.on_input(batch, sample_rate_hz)?,
            DeviceToHost::Status(status) => {
                if let Some(s) = self.session.as_mut() {
                    s.status = Some(*status);
                }
            }
            _ => {}
        }
        self.flush_if_due()
    }

    /// Flushes both files if [`FLUSH_INTERVAL`] has passed since the last flush (call it
    /// also when nothing arrives, so a quiet link does not hold rows back).
    pub fn flush_if_due(&mut self) -> Result<()> {
        if self.last_flush.elapsed() >= FLUSH_INTERVAL {
            self.telemetry.flush()?;
            self.events.flush()?;
            self.input.flush()?;
            self.last_flush = Instant::now();
        }
        Ok(())
    }

    /// Telemetry rows written.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes the files and renames them into place, then writes the session file (if
    /// the device greeted); returns the final paths.
    pub fn finish(mut self) -> Result<LogFiles> {
        self.ensure_header()?;
        let telemetry = self.telemetry.finish()?;
        let events = self.events.finish()?;
        let input = self.input.finish()?;
        let session = match self.session {
            Some(info) => {
                info.write(&self.session_path)?;
                Some((self.session_path, info))
            }
            None => None,
        };
        Ok(LogFiles {
            telemetry,
            events,
            input,
            session,
        })
    }

    /// Flushes the files and leaves them under their `.partial` names (the session
    /// failed); returns those names: telemetry, events, input.
    pub fn abandon(mut self) -> (PathBuf, PathBuf, PathBuf) {
        let _ = self.ensure_header();
        let _ = self.telemetry.flush();
        let _ = self.events.flush();
        let _ = self.input.flush();
        (
            self.telemetry.partial,
            self.events.partial,
            self.input.partial,
        )
    }

    /// Removes the files (the session failed and nothing in them is worth keeping).
    pub fn discard(self) {
        let (telemetry, events, input) = self.abandon();
        let _ = std::fs::remove_file(telemetry);
        let _ = std::fs::remove_file(events);
        let _ = std::fs::remove_file(input);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::{AlertEvent, Criterion, Level, SensorFault};
    use supine_core::protocol::Telemetry;

    use crate::io::telemetry_csv::TELEMETRY_HEADER;

    fn telemetry(sample_index: u32) -> Telemetry {
        Telemetry {
            sample_index,
            head_acc_m_s2: [0.25, -0.5, 1.0],
            running_rms_m_s2: [0.1, 0.2, 0.3],
            vector_running_rms_m_s2: 0.4,
            vdv_m_s175: 0.5,
            alert_level: Level::Advisory,
            fault_flags: SensorFault::IndexGap.into(),
            valid: true,
            joints: supine_core::joint_exposure::JointValues::EMPTY,
        }
    }

    #[test]
    fn rows_are_flushed_under_partial_names_and_renamed_on_finish() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("log.csv");
        let mut log = MonitorLog::create(&path).expect("create");
        log.on_message(&DeviceToHost::Telemetry(telemetry(250)), 500.0)
            .expect("row");
        let event = AlertEvent::Level {
            from: Level::Normal,
            to: Level::Advisory,
            criterion: Criterion::RunningRms { value_m_s2: 0.6 },
            at_sample: 240,
        };
        log.on_message(&DeviceToHost::Alert(event), 500.0)
            .expect("event");
        assert!(!path.exists(), "not in place before finish");
        // Past the flush interval, the next call writes the rows out.
        log.last_flush -= FLUSH_INTERVAL;
        log.flush_if_due().expect("flush");
        let partial = std::fs::read_to_string(dir.path().join("log.csv.partial")).expect("partial");
        assert_eq!(
            partial,
            format!("{TELEMETRY_HEADER}\n250,0.5,0.25,-0.5,1,0.1,0.2,0.3,0.4,0.5,advisory,8,1\n")
        );
        let files = log.finish().expect("finish");
        let (t, e) = (files.telemetry, files.events);
        assert_eq!(std::fs::read_to_string(&t).expect("telemetry"), partial);
        assert_eq!(
            std::fs::read_to_string(&e).expect("events"),
            format!("{EVENTS_HEADER}\n240,0.48,level,advisory,1,running-rms,0.6,m/s^2\n")
        );
        assert!(!dir.path().join("log.csv.partial").exists());
        assert!(!dir.path().join("log.events.csv.partial").exists());
    }

    fn greeting(identity: u8) -> Greeting {
        Greeting {
            protocol_version: supine_core::protocol::PROTOCOL_VERSION,
            firmware_version: heapless::String::try_from("0.1.0+test").expect("fits"),
            params_identity: [identity; 16],
            params_source: supine_core::protocol::ParamsSource::Flash { slot: 0 },
            sample_rate_hz: 500.0,
            height_m: 1.6,
            mass_kg: 52.0,
            reset_cause: supine_core::protocol::ResetCause::PowerOn,
            last_panic: heapless::String::new(),
            joint_outputs: 0,
            calibration: supine_core::calibration::SensorCalibration::DATASHEET,
        }
    }

    fn input(first: u32, counts: &[[i16; 3]]) -> DeviceToHost {
        DeviceToHost::Input(InputBatch::from_counts(first, counts))
    }

    #[test]
    fn the_input_stream_becomes_a_ride_and_gaps_are_counted_not_closed() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("s.csv");
        let mut log = MonitorLog::create(&path).expect("create");
        log.on_greeting(&greeting(7));
        log.on_message(&input(0, &[[512, -1, 0], [1024, 2, 3]]), 500.0)
            .expect("frame");
        // Two samples lost (a frame of 2), then one back in time (a restarted stream).
        log.on_message(&input(4, &[[0, 0, 1]]), 500.0)
            .expect("frame");
        log.on_message(&input(1, &[[9, 9, 9]]), 500.0)
            .expect("frame");
        let files = log.finish().expect("finish");
        assert_eq!(files.input, dir.path().join("s.input.csv"));
        assert_eq!(
            std::fs::read_to_string(&files.input).expect("input"),
            format!(
                "{PLATFORM_HEADER_LINE}\n0,1,-0.001953125,0\n0.002,2,0.00390625,0.005859375\n\
                 0.008,0,0,0.001953125\n"
            )
        );
        let (session_file, info) = files.session.expect("the device greeted");
        assert_eq!(SessionInfo::read(&session_file).expect("reads"), info);
        assert_eq!(info.params_identity, "07".repeat(16));
        assert_eq!((info.height_m, info.mass_kg), (1.6, 52.0));
        assert_eq!(info.sample_rate_hz, 500.0);
        assert_eq!(info.input_frames, 3);
        assert_eq!(info.input_samples, 3);
        assert_eq!(info.input_samples_lost, 2 + 1);
        assert_eq!(info.first_input_sample, Some(0));
        assert!(!info.params_changed);
    }

    #[test]
    fn a_greeting_with_other_parameters_marks_the_session() {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut log = MonitorLog::create(&dir.path().join("s.csv")).expect("create");
        log.on_greeting(&greeting(1));
        log.on_message(&DeviceToHost::Greeting(greeting(1)), 500.0)
            .expect("same");
        assert!(!log.session().expect("greeted").params_changed);
        log.on_message(&DeviceToHost::Greeting(greeting(2)), 500.0)
            .expect("other");
        assert!(log.session().expect("greeted").params_changed);
    }

    #[test]
    fn an_unwritable_folder_is_one_clear_error() {
        let err = MonitorLog::create(Path::new("/nonexistent-dir/log.csv"))
            .err()
            .expect("refused");
        let text = err.to_string();
        assert!(
            text.contains("/nonexistent-dir/log.csv.partial: cannot create"),
            "{text}"
        );
    }
}
