//! The monitor's CSV log: every telemetry record and every alert event, in the formats of
//! `supine replay` (two files: `LOG.csv` with [`telemetry_header`], `<stem>.events.csv`
//! with [`EVENTS_HEADER`]), so one reader serves both commands. The telemetry header's
//! joint columns are the ones the device's greeting announces, so it is written when the
//! first telemetry record comes (or at the end, if none does).
//!
//! The log is written while the session runs, into `<name>.partial` files flushed at least
//! every [`FLUSH_INTERVAL`] (a crash loses at most that much, and leaves files whose name
//! says they are incomplete); [`MonitorLog::finish`] flushes and renames them into place.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use supine_core::protocol::{DeviceToHost, Greeting};

use crate::io::telemetry_csv::{
    EVENTS_HEADER, event_row, events_path, telemetry_header, telemetry_row,
};

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

/// The telemetry and events files of one monitoring session.
pub struct MonitorLog {
    telemetry: LiveFile,
    events: LiveFile,
    last_flush: Instant,
    rows: u64,
    /// The joint outputs the last greeting announced (none before one).
    joint_mask: u16,
    /// Whether the telemetry file has its header yet.
    header_written: bool,
}

impl MonitorLog {
    /// Creates `path` (telemetry) and its `<stem>.events.csv` under `.partial` names.
    pub fn create(path: &Path) -> Result<Self> {
        let telemetry = LiveFile::create(path, None)?;
        let events = match LiveFile::create(&events_path(path), Some(EVENTS_HEADER)) {
            Ok(events) => events,
            Err(e) => {
                let _ = std::fs::remove_file(&telemetry.partial);
                return Err(e);
            }
        };
        Ok(Self {
            telemetry,
            events,
            last_flush: Instant::now(),
            rows: 0,
            joint_mask: 0,
            header_written: false,
        })
    }

    /// Takes the joint outputs a greeting announces as the telemetry file's joint columns,
    /// unless its header is already written.
    pub fn on_greeting(&mut self, greeting: &Greeting) {
        if !self.header_written {
            self.joint_mask = greeting.joint_outputs;
        }
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

    /// The final paths: telemetry, events.
    pub fn paths(&self) -> (&Path, &Path) {
        (&self.telemetry.path, &self.events.path)
    }

    /// Logs a telemetry record or an alert event (times at `sample_rate_hz`); other
    /// messages are not logged. Flushes when [`FLUSH_INTERVAL`] has passed.
    pub fn on_message(&mut self, message: &DeviceToHost, sample_rate_hz: f64) -> Result<()> {
        match message {
            DeviceToHost::Greeting(g) => self.on_greeting(g),
            DeviceToHost::Telemetry(t) => {
                self.ensure_header()?;
                self.telemetry.write(&telemetry_row(t, sample_rate_hz))?;
                self.rows += 1;
            }
            DeviceToHost::Alert(e) => self.events.write(&event_row(e, sample_rate_hz))?,
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
            self.last_flush = Instant::now();
        }
        Ok(())
    }

    /// Telemetry rows written.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes both files and renames them into place; returns their final paths.
    pub fn finish(mut self) -> Result<(PathBuf, PathBuf)> {
        self.ensure_header()?;
        let telemetry = self.telemetry.finish()?;
        let events = self.events.finish()?;
        Ok((telemetry, events))
    }

    /// Flushes both files and leaves them under their `.partial` names (the session
    /// failed); returns those names.
    pub fn abandon(mut self) -> (PathBuf, PathBuf) {
        let _ = self.ensure_header();
        let _ = self.telemetry.flush();
        let _ = self.events.flush();
        (self.telemetry.partial, self.events.partial)
    }

    /// Removes both files (the session failed and nothing in them is worth keeping).
    pub fn discard(self) {
        let (telemetry, events) = self.abandon();
        let _ = std::fs::remove_file(telemetry);
        let _ = std::fs::remove_file(events);
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
        let (t, e) = log.finish().expect("finish");
        assert_eq!(std::fs::read_to_string(&t).expect("telemetry"), partial);
        assert_eq!(
            std::fs::read_to_string(&e).expect("events"),
            format!("{EVENTS_HEADER}\n240,0.48,level,advisory,1,running-rms,0.6,m/s^2\n")
        );
        assert!(!dir.path().join("log.csv.partial").exists());
        assert!(!dir.path().join("log.events.csv.partial").exists());
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
