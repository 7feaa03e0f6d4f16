//! Replaying a recording through the device image in QEMU (`supine replay`).
//!
//! The parameter blob is built for the recording's sample rate and loaded into the PARAMS
//! region; QEMU (mps2-an386) runs the product image with UART0 on a private Unix socket.
//! A writer thread streams the recording's platform columns as [`HostToDevice::Samples`]
//! frames (8 samples each, with their indices) while this thread reads the device's
//! numbered frames. QEMU serves the socket with `wait=on` and the device's one-byte RX
//! flow-controls it, so samples go as fast as the device takes them (faster than real
//! time). A final `GetStatus` makes the device process what it has buffered and report
//! its counters; its `Status` ends the session.
//!
//! The [`Qemu`] guard kills QEMU and removes its folder on every exit path; a stop flag
//! (set by Ctrl-C in the CLI) ends the loops early with an error.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use supine_core::alerts::AlertEvent;
use supine_core::blob::TelemetryConfig;
use supine_core::protocol::{
    DeviceToHost, Greeting, HostToDevice, MAX_SAMPLES_PER_FRAME, SampleBatch, Status, Telemetry,
};

use crate::device_params;
use crate::firmware;
use crate::link::{FrameReader, FrameWriter, LinkStats};
use crate::params_file::ParamFile;
use crate::qemu::{Qemu, QemuConfig};
use crate::recording::Recording;

/// Instructions per SysTick tick under `-icount shift=0` on mps2 (25 MHz SysTick).
pub const INSTRUCTIONS_PER_TICK: f64 = 40.0;

/// Header of the telemetry CSV. The first five columns are named as issue 5 and the
/// recording format name them (`head_x`: predicted head acceleration, m/s^2, litter axes);
/// the rest carry their units.
pub const TELEMETRY_HEADER: &str = "sample,time_s,head_x,head_y,head_z,running_rms_x_m_s2,running_rms_y_m_s2,running_rms_z_m_s2,running_rms_vector_m_s2,vdv_m_s175,alert_level,fault_flags,valid";
/// Header of the alert events CSV.
pub const EVENTS_HEADER: &str = "sample,time_s,kind,name,raised";

/// One thing the host sends: a message, or raw bytes (for tests that send garbage).
#[derive(Clone, Debug, PartialEq)]
pub enum Outgoing {
    /// A framed message.
    Message(HostToDevice),
    /// Bytes written as they are.
    Raw(Vec<u8>),
}

/// How to run a session.
#[derive(Clone, Debug)]
pub struct SessionConfig {
    /// The firmware ELF.
    pub kernel: PathBuf,
    /// The parameter blob to place in the PARAMS region (`None`: leave it blank).
    pub blob: Option<Vec<u8>>,
    /// Count instructions (QEMU `-icount shift=0`).
    pub icount: bool,
    /// Longest the whole session may take.
    pub timeout: Duration,
}

/// Everything the device said during a session.
#[derive(Clone, Debug)]
pub struct Session {
    /// The greetings, in order (the first one at boot).
    pub greetings: Vec<Greeting>,
    /// Telemetry records, in arrival order.
    pub telemetry: Vec<Telemetry>,
    /// Alert events, in arrival order.
    pub events: Vec<AlertEvent>,
    /// Status reports, one per `GetStatus` sent; the last one ends the session.
    pub statuses: Vec<Status>,
    /// Every other message (parameter acks and nacks).
    pub other: Vec<DeviceToHost>,
    /// Frames decoded, bad, lost and reordered on the way to the host.
    pub link: LinkStats,
    /// Wall-clock time from QEMU's start to the last status.
    pub elapsed: Duration,
    /// What the image printed on semihosting (diagnostics), after QEMU stopped.
    pub diagnostics: String,
}

impl Session {
    /// The last status (the one that ended the session).
    pub fn status(&self) -> Status {
        self.statuses.last().copied().unwrap_or_default()
    }

    /// Mean instructions per processed sample of the pipeline (meaningful with `icount`).
    pub fn instructions_per_sample(&self) -> f64 {
        let s = self.status();
        s.busy_ticks as f64 * INSTRUCTIONS_PER_TICK / f64::from(s.samples_processed.max(1))
    }
}

/// Frames of `samples` (consecutive indices from `first_index`), 8 per frame.
pub fn sample_messages(first_index: u32, samples: &[[f32; 3]]) -> Vec<Outgoing> {
    samples
        .chunks(MAX_SAMPLES_PER_FRAME)
        .enumerate()
        .map(|(k, chunk)| {
            let mut accel_m_s2 = heapless::Vec::new();
            for &s in chunk {
                // A chunk has at most MAX_SAMPLES_PER_FRAME samples: this always fits.
                let _ = accel_m_s2.push(s);
            }
            Outgoing::Message(HostToDevice::Samples(SampleBatch {
                first_sample_index: first_index.wrapping_add((k * MAX_SAMPLES_PER_FRAME) as u32),
                accel_m_s2,
            }))
        })
        .collect()
}

/// Starts the image, sends `script` (then `GetStatus`), and collects what the device says
/// until the status that answers the final `GetStatus`. QEMU is stopped and its folder
/// removed before this returns, whatever happened. `stop` aborts the session.
pub fn session(
    config: &SessionConfig,
    script: Vec<Outgoing>,
    stop: &Arc<AtomicBool>,
) -> Result<Session> {
    let blob_dir = tempfile::Builder::new().prefix("supine-blob-").tempdir()?;
    let mut qemu_config = QemuConfig::new(&config.kernel)
        .uart()
        .timeout(config.timeout);
    if config.icount {
        qemu_config = qemu_config.icount();
    }
    if let Some(blob) = &config.blob {
        let path = blob_dir.path().join("params.bin");
        std::fs::write(&path, blob).context("writing the parameter blob")?;
        qemu_config = qemu_config.params_blob(path);
    }
    let started = Instant::now();
    let mut qemu = Qemu::start(&qemu_config)?;
    let result = talk(&mut qemu, script, stop, started).map_err(|e| {
        if stop.load(Ordering::Relaxed) {
            e
        } else {
            qemu.explain_failure(e)
        }
    });
    let output = qemu.stop();
    let mut session = result?;
    if let Ok(output) = output {
        session.diagnostics = output.stdout + &output.stderr;
    }
    Ok(session)
}

fn talk(
    qemu: &mut Qemu,
    script: Vec<Outgoing>,
    stop: &Arc<AtomicBool>,
    started: Instant,
) -> Result<Session> {
    let deadline = Instant::now() + qemu.remaining();
    let uart = qemu.uart().ok_or_else(|| anyhow!("QEMU has no UART"))?;
    uart.set_read_timeout(Some(Duration::from_millis(50)))?;
    let tx = uart.try_clone()?;
    let rx = uart.try_clone()?;
    let expected_statuses = script
        .iter()
        .filter(|o| matches!(o, Outgoing::Message(HostToDevice::GetStatus)))
        .count()
        + 1;
    // The writer's own flag: a failed session stops it without touching `stop`, which
    // is the caller's (the process's signal flag for `supine replay`).
    let writer_done = Arc::new(AtomicBool::new(false));
    let (writer_stop, done) = (Arc::clone(stop), Arc::clone(&writer_done));
    let writer = thread::spawn(move || -> Result<()> {
        let mut writer = FrameWriter::new(std::io::BufWriter::with_capacity(4096, tx));
        for item in script
            .into_iter()
            .chain([Outgoing::Message(HostToDevice::GetStatus)])
        {
            if writer_stop.load(Ordering::Relaxed) || done.load(Ordering::Relaxed) {
                return Ok(());
            }
            match item {
                Outgoing::Message(m) => writer.send(&m)?,
                Outgoing::Raw(bytes) => writer.send_raw(&bytes)?,
            }
        }
        writer.flush()
    });
    let mut reader = FrameReader::new(rx);
    let mut s = Session {
        greetings: Vec::new(),
        telemetry: Vec::new(),
        events: Vec::new(),
        statuses: Vec::new(),
        other: Vec::new(),
        link: LinkStats::default(),
        elapsed: Duration::ZERO,
        diagnostics: String::new(),
    };
    let result = loop {
        if stop.load(Ordering::Relaxed) {
            break Err(anyhow!("interrupted"));
        }
        if Instant::now() >= deadline {
            break Err(anyhow!(
                "the device did not finish within {} ({} telemetry records so far)",
                crate::link::format_duration(deadline - started),
                s.telemetry.len()
            ));
        }
        let step = (Instant::now() + Duration::from_millis(100)).min(deadline);
        let message = reader.next_before(step);
        if s.greetings.is_empty()
            && let Err(e) = reader.check_foreign_greeting()
        {
            break Err(e);
        }
        match message {
            Ok(Some(DeviceToHost::Greeting(g))) => {
                if let Err(e) = crate::link::check_protocol(g.protocol_version) {
                    break Err(e);
                }
                s.greetings.push(g);
            }
            Ok(Some(DeviceToHost::Telemetry(t))) => s.telemetry.push(t),
            Ok(Some(DeviceToHost::Alert(e))) => s.events.push(e),
            Ok(Some(DeviceToHost::Status(st))) => {
                s.statuses.push(st);
                if s.statuses.len() == expected_statuses {
                    break Ok(());
                }
            }
            Ok(Some(other)) => s.other.push(other),
            Ok(None) => {}
            Err(e) => break Err(e),
        }
    };
    s.link = reader.stats;
    s.elapsed = started.elapsed();
    if result.is_err() {
        // Unblock the writer: it may wait on a socket the device no longer drains.
        writer_done.store(true, Ordering::Relaxed);
        let _ = uart.shutdown(std::net::Shutdown::Both);
    }
    let written = writer
        .join()
        .map_err(|_| anyhow!("the writer thread panicked"))?;
    result?;
    written?;
    Ok(s)
}

/// What `supine replay` produced.
#[derive(Clone, Debug)]
pub struct ReplayResult {
    /// The session with the device.
    pub session: Session,
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Samples sent.
    pub samples: usize,
}

/// Builds the blob of `file` for `recording`'s rate, replays the recording's platform
/// columns through the product image in QEMU and returns what the device said.
pub fn replay(
    file: &ParamFile,
    recording: &Recording,
    telemetry: TelemetryConfig,
    icount: bool,
    stop: &Arc<AtomicBool>,
) -> Result<ReplayResult> {
    if recording.len() < 2 {
        bail!("{} has fewer than two samples", recording.path.display());
    }
    let sample_rate_hz = recording.sample_rate_hz();
    // The telemetry rate is the replay's (a transport setting), not the file's: the
    // identity stays the parameter file's, as `supine flash` would report it.
    let mut params = device_params::build(file, sample_rate_hz)?;
    params.telemetry = telemetry;
    let blob = device_params::encode(&params)?;
    let samples: Vec<[f32; 3]> = (0..recording.len())
        .map(|k| recording.platform_m_s2.each_ref().map(|c| c[k] as f32))
        .collect();
    let kernel = firmware::build_binary(firmware::PRODUCT_BINARY)?;
    // Generous: the device runs at tens of thousands of samples per second.
    let timeout = Duration::from_secs(60 + samples.len() as u64 / 1000);
    let config = SessionConfig {
        kernel,
        blob: Some(blob),
        icount,
        timeout,
    };
    let session = session(&config, sample_messages(0, &samples), stop)?;
    if let Some(g) = session.greetings.first()
        && g.params_identity != params.identity
    {
        bail!(
            "the device runs parameters {} instead of the blob sent ({:?})",
            device_params::identity_hex(&g.params_identity),
            g.params_source
        );
    }
    Ok(ReplayResult {
        session,
        sample_rate_hz,
        samples: samples.len(),
    })
}

/// Writes the telemetry CSV ([`TELEMETRY_HEADER`]) through a temporary file.
pub fn write_telemetry(path: &Path, telemetry: &[Telemetry], sample_rate_hz: f64) -> Result<()> {
    let mut text = String::with_capacity(telemetry.len() * 120 + 200);
    text.push_str(TELEMETRY_HEADER);
    text.push('\n');
    for t in telemetry {
        text.push_str(&telemetry_row(t, sample_rate_hz));
    }
    write_atomically(path, &text)
}

/// One line of the telemetry CSV ([`TELEMETRY_HEADER`]), newline included; shared with
/// `supine monitor`'s live log so both write the same format.
pub fn telemetry_row(t: &Telemetry, sample_rate_hz: f64) -> String {
    let [hx, hy, hz] = t.head_acc_m_s2;
    let [rx, ry, rz] = t.running_rms_m_s2;
    format!(
        "{},{},{hx},{hy},{hz},{rx},{ry},{rz},{},{},{},{},{}\n",
        t.sample_index,
        f64::from(t.sample_index) / sample_rate_hz,
        t.vector_running_rms_m_s2,
        t.vdv_m_s175,
        t.alert_level.name(),
        t.fault_flags.as_repr(),
        u8::from(t.valid),
    )
}

/// Writes the alert events CSV ([`EVENTS_HEADER`]) through a temporary file.
pub fn write_events(path: &Path, events: &[AlertEvent], sample_rate_hz: f64) -> Result<()> {
    let mut text = String::from(EVENTS_HEADER);
    text.push('\n');
    for e in events {
        text.push_str(&event_row(e, sample_rate_hz));
    }
    write_atomically(path, &text)
}

/// One line of the events CSV ([`EVENTS_HEADER`]), newline included.
pub fn event_row(e: &AlertEvent, sample_rate_hz: f64) -> String {
    let (kind, name) = match *e {
        AlertEvent::Level { to, .. } => ("level", to.name()),
        AlertEvent::Fault { fault, .. } => ("fault", fault.name()),
    };
    format!(
        "{},{},{kind},{name},{}\n",
        e.at_sample(),
        f64::from(e.at_sample()) / sample_rate_hz,
        u8::from(e.is_raise())
    )
}

/// `<stem>.events.csv` next to `out`.
pub fn events_path(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    out.with_file_name(format!("{stem}.events.csv"))
}

fn write_atomically(path: &Path, text: &str) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    // Readable like any file the user creates (a temporary file is private by default).
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("cannot write in {}", dir.display()))?;
    tmp.write_all(text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    tmp.persist(path)
        .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
    Ok(())
}
