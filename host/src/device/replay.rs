//! Replaying a recording through the device image in QEMU (`supine replay`).
//!
//! The parameter blob is built for the recording's sample rate and loaded into the PARAMS
//! region; QEMU (mps2-an386) runs the product image with UART0 on a private Unix socket.
//! The recording's platform columns become [`HostToDevice::Samples`] frames (8 samples
//! each, with their indices), read from the file as they are framed; this thread reads the
//! device's numbered frames and hands each telemetry record on as it arrives: memory does
//! not grow with the ride. A final `GetStatus` makes the device process what it has
//! buffered and report its counters; its `Status` ends the session.
//!
//! The frames take one of two routes (`ScriptRoute`). Sessions (the tests' scripts) send
//! them over UART0 from a writer thread: QEMU serves the socket with `wait=on` and the
//! device's one-byte RX flow-controls it. A replay writes them to a file in its scratch
//! folder first, which the image reads by semihosting ahead of the UART
//! (`--replay-input`): QEMU's UART takes about 40 us a byte, which held replay near 4
//! times real time; the file route reads a block per call (BENCHMARKS.md, "Replay
//! throughput"). Either way the device decodes the same frames and runs the same pipeline.
//!
//! The [`Qemu`] guard kills QEMU and removes its folder on every exit path; a stop flag
//! (set by Ctrl-C in the CLI) ends the loops early with an error.

use std::convert::Infallible;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use supine_core::alerts::AlertEvent;
use supine_core::blob::TelemetryConfig;
use supine_core::protocol::{DeviceToHost, Greeting, HostToDevice, SampleBatch, Status, Telemetry};
use supine_core::timing::INSTRUCTIONS_PER_TICK;

use crate::device::device_params;
use crate::device::image::ProductImage;
use crate::device::link::{FrameReader, FrameWriter, LinkStats};
use crate::device::qemu::{Qemu, QemuConfig};
use crate::device::scratch::ScratchDir;
use crate::io::params_file::ParamFile;
use crate::io::recording::PlatformStream;

/// One thing the host sends: a message, or raw bytes (for tests that send garbage).
#[derive(Clone, Debug, PartialEq)]
pub enum Outgoing {
    /// A framed message.
    Message(HostToDevice),
    /// Bytes written as they are.
    Raw(Vec<u8>),
}

impl Outgoing {
    /// Writes it to `writer`: the one way a script item goes out, by either route.
    fn send<W: std::io::Write>(&self, writer: &mut FrameWriter<W>) -> Result<()> {
        match self {
            Outgoing::Message(m) => writer.send(m),
            Outgoing::Raw(bytes) => writer.send_raw(bytes),
        }
    }
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
        s.busy_ticks as f64 * f64::from(INSTRUCTIONS_PER_TICK)
            / f64::from(s.samples_processed.max(1))
    }
}

/// Frames of `samples` (consecutive indices from `first_index`), 8 per frame.
pub fn sample_messages(first_index: u32, samples: &[[f32; 3]]) -> Vec<Outgoing> {
    sample_frames(first_index, samples.iter().map(|s| Ok::<_, Infallible>(*s)))
        .map(|frame| match frame {
            Ok(frame) => frame,
            Err(never) => match never {},
        })
        .collect()
}

/// Frames of `samples` (consecutive indices from `first_index`), 8 per frame, built as
/// the samples are taken; the first error ends them.
pub fn sample_frames<E>(
    first_index: u32,
    mut samples: impl Iterator<Item = Result<[f32; 3], E>>,
) -> impl Iterator<Item = Result<Outgoing, E>> {
    let mut next_index = first_index;
    let mut failed = false;
    std::iter::from_fn(move || {
        if failed {
            return None;
        }
        let mut accel_m_s2 = heapless::Vec::new();
        while !accel_m_s2.is_full() {
            match samples.next() {
                // Not full: this always fits.
                Some(Ok(s)) => {
                    let _ = accel_m_s2.push(s);
                }
                Some(Err(e)) => {
                    failed = true;
                    return Some(Err(e));
                }
                None => break,
            }
        }
        if accel_m_s2.is_empty() {
            return None;
        }
        let first_sample_index = next_index;
        next_index = next_index.wrapping_add(accel_m_s2.len() as u32);
        Some(Ok(Outgoing::Message(HostToDevice::Samples(SampleBatch {
            first_sample_index,
            accel_m_s2,
        }))))
    })
}

/// How a session's script reaches the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ScriptRoute {
    /// Over UART0, as a host on the device's serial port would send it.
    Uart,
    /// Through a file the image reads ahead of UART0 (`--replay-input`, semihosting),
    /// written whole before QEMU starts: for replay's bulk samples.
    HostFile,
}

/// Starts the image, sends `script` (then `GetStatus`) over UART0, and collects what the
/// device says until the status that answers the final `GetStatus`. QEMU is stopped and
/// its folder removed before this returns, whatever happened. `stop` aborts the session.
pub fn session(
    config: &SessionConfig,
    script: Vec<Outgoing>,
    stop: &Arc<AtomicBool>,
) -> Result<Session> {
    collected_session(config, script, ScriptRoute::Uart, stop)
}

/// As [`session`], with the script read by the image from a file ahead of UART0, as
/// `supine replay` sends its samples: for long rides.
pub fn file_session(
    config: &SessionConfig,
    script: Vec<Outgoing>,
    stop: &Arc<AtomicBool>,
) -> Result<Session> {
    collected_session(config, script, ScriptRoute::HostFile, stop)
}

fn collected_session(
    config: &SessionConfig,
    script: Vec<Outgoing>,
    route: ScriptRoute,
    stop: &Arc<AtomicBool>,
) -> Result<Session> {
    let expected_statuses = script
        .iter()
        .filter(|o| matches!(o, Outgoing::Message(HostToDevice::GetStatus)))
        .count()
        + 1;
    let mut telemetry = Vec::new();
    let mut session = streamed_session(
        config,
        script.into_iter().map(Ok),
        expected_statuses,
        route,
        stop,
        &mut |t| {
            telemetry.push(*t);
            Ok(())
        },
    )?;
    session.telemetry = telemetry;
    Ok(session)
}

/// What a session does with each telemetry record as it arrives.
pub type TelemetrySink<'a> = dyn FnMut(&Telemetry) -> Result<()> + 'a;

/// As [`session`], with the script taken as it is sent (an error in it ends the session
/// with that error), `expected_statuses` the number of `GetStatus` it holds plus one, and
/// each telemetry record handed to `on_telemetry` instead of kept: the session's
/// `telemetry` stays empty, so its memory does not grow with the ride. `route` says how
/// the script travels.
fn streamed_session(
    config: &SessionConfig,
    script: impl Iterator<Item = Result<Outgoing>> + Send + 'static,
    expected_statuses: usize,
    route: ScriptRoute,
    stop: &Arc<AtomicBool>,
    on_telemetry: &mut TelemetrySink<'_>,
) -> Result<Session> {
    // The blob, and for the file route the frames: both read by QEMU, removed with it.
    let scratch = ScratchDir::new("blob")?;
    let mut qemu_config = QemuConfig::new(&config.kernel)
        .uart()
        .timeout(config.timeout);
    let script = script.chain([Ok(Outgoing::Message(HostToDevice::GetStatus))]);
    let uart_script: Box<dyn Iterator<Item = Result<Outgoing>> + Send> = match route {
        ScriptRoute::Uart => Box::new(script),
        ScriptRoute::HostFile => {
            let path = scratch.path().join("input.bin");
            write_script_file(&path, script, stop)?;
            let path = path.to_str().ok_or_else(|| {
                anyhow!(
                    "the scratch folder {} is not UTF-8: QEMU cannot pass it to the device",
                    scratch.path().display()
                )
            })?;
            qemu_config = qemu_config
                .semihosting_arg("supine-firmware")
                .semihosting_arg("--replay-input")
                .semihosting_arg(path);
            Box::new(std::iter::empty())
        }
    };
    if config.icount {
        qemu_config = qemu_config.icount();
    }
    if let Some(blob) = &config.blob {
        let path = scratch.path().join("params.bin");
        std::fs::write(&path, blob).context("writing the parameter blob")?;
        qemu_config = qemu_config.params_blob(path);
    }
    let started = Instant::now();
    let mut qemu = Qemu::start(&qemu_config)?;
    let result = talk(
        &mut qemu,
        uart_script,
        expected_statuses,
        stop,
        started,
        on_telemetry,
    )
    .map_err(|e| {
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

/// Writes `script`'s frames to `path` as they are made (the ride is read once, memory
/// stays flat); the script's first error, or `stop`, ends it with an error.
fn write_script_file(
    path: &std::path::Path,
    script: impl Iterator<Item = Result<Outgoing>>,
    stop: &Arc<AtomicBool>,
) -> Result<()> {
    let file = std::fs::File::create(path)
        .with_context(|| format!("creating the replay input {}", path.display()))?;
    let mut writer = FrameWriter::new(std::io::BufWriter::with_capacity(1 << 16, file));
    for item in script {
        if stop.load(Ordering::Relaxed) {
            bail!("interrupted");
        }
        item?.send(&mut writer)?;
    }
    writer
        .flush()
        .with_context(|| format!("writing the replay input {}", path.display()))
}

fn talk(
    qemu: &mut Qemu,
    script: impl Iterator<Item = Result<Outgoing>> + Send + 'static,
    expected_statuses: usize,
    stop: &Arc<AtomicBool>,
    started: Instant,
    on_telemetry: &mut TelemetrySink<'_>,
) -> Result<Session> {
    let deadline = Instant::now() + qemu.remaining();
    let uart = qemu.uart().ok_or_else(|| anyhow!("QEMU has no UART"))?;
    uart.set_read_timeout(Some(Duration::from_millis(50)))?;
    let tx = uart.try_clone()?;
    let rx = uart.try_clone()?;
    // The writer's own flag: a failed session stops it without touching `stop`, which
    // is the caller's (the process's signal flag for `supine replay`).
    let writer_done = Arc::new(AtomicBool::new(false));
    let (writer_stop, done) = (Arc::clone(stop), Arc::clone(&writer_done));
    // Set when the script itself fails (a ride unreadable midway): its error is the cause.
    let script_failed = Arc::new(AtomicBool::new(false));
    let failed = Arc::clone(&script_failed);
    let writer = thread::spawn(move || -> Result<()> {
        let mut writer = FrameWriter::new(std::io::BufWriter::with_capacity(4096, tx));
        for item in script {
            if writer_stop.load(Ordering::Relaxed) || done.load(Ordering::Relaxed) {
                return Ok(());
            }
            match item {
                Ok(outgoing) => outgoing.send(&mut writer)?,
                Err(e) => {
                    failed.store(true, Ordering::Relaxed);
                    return Err(e);
                }
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
    let mut telemetry_records = 0usize;
    let result = loop {
        if stop.load(Ordering::Relaxed) {
            break Err(anyhow!("interrupted"));
        }
        if script_failed.load(Ordering::Relaxed) {
            break Err(anyhow!("the samples stopped"));
        }
        if Instant::now() >= deadline {
            break Err(anyhow!(
                "the device did not finish within {} ({telemetry_records} telemetry records so far)",
                crate::device::link::format_duration(deadline - started),
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
                if let Err(e) = crate::device::link::check_protocol(g.protocol_version) {
                    break Err(e);
                }
                s.greetings.push(g);
            }
            Ok(Some(DeviceToHost::Telemetry(t))) => {
                telemetry_records += 1;
                if let Err(e) = on_telemetry(&t) {
                    break Err(e);
                }
            }
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
    if script_failed.load(Ordering::Relaxed) {
        // The script's own error (the ride) is the cause; the session's follows from it.
        written.and(result)?;
        return Ok(s);
    }
    result?;
    written?;
    Ok(s)
}

/// What `supine replay` produced.
#[derive(Clone, Debug)]
pub struct ReplayResult {
    /// The session with the device (its `telemetry` is empty: the records went to the
    /// caller as they arrived).
    pub session: Session,
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Samples sent.
    pub samples: usize,
}

/// Builds the blob of `file` for the ride's rate, streams the ride's platform columns
/// through the product image in QEMU (by the host-file route), and hands each telemetry
/// record to `on_telemetry` as it arrives: memory does not grow with the ride's length.
pub fn replay(
    kernel: &ProductImage,
    file: &ParamFile,
    ride: &PlatformStream,
    telemetry: TelemetryConfig,
    icount: bool,
    stop: &Arc<AtomicBool>,
    on_telemetry: &mut TelemetrySink<'_>,
) -> Result<ReplayResult> {
    if ride.len() < 2 {
        bail!("{} has fewer than two samples", ride.path().display());
    }
    let sample_rate_hz = ride.sample_rate_hz();
    // The telemetry rate is the replay's (a transport setting), not the file's: the
    // identity stays the parameter file's, as `supine flash` would report it.
    let params = device_params::build(file, sample_rate_hz)?
        .with_telemetry(telemetry)
        .map_err(|e| anyhow!("telemetry every {} samples: {e}", telemetry.decimation))?;
    let blob = device_params::encode(&params)?;
    // Generous: the device runs at tens of thousands of samples per second.
    let timeout = Duration::from_secs(60 + ride.len() as u64 / 1000);
    let config = SessionConfig {
        kernel: kernel.path().to_path_buf(),
        blob: Some(blob),
        icount,
        timeout,
    };
    let frames = sample_frames(0, ride.samples()?).map(|f| f.map_err(anyhow::Error::from));
    let session = streamed_session(
        &config,
        frames,
        1,
        ScriptRoute::HostFile,
        stop,
        on_telemetry,
    )?;
    if let Some(g) = session.greetings.first()
        && g.params_identity != params.identity
    {
        bail!(
            "the device runs parameters {} instead of the blob sent: they come from {}",
            device_params::identity_hex(&g.params_identity),
            device_params::params_source_text(g.params_source)
        );
    }
    Ok(ReplayResult {
        session,
        sample_rate_hz,
        samples: ride.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(outgoing: &[Outgoing]) -> Vec<(u32, usize)> {
        outgoing
            .iter()
            .map(|o| match o {
                Outgoing::Message(HostToDevice::Samples(b)) => {
                    (b.first_sample_index, b.accel_m_s2.len())
                }
                other => panic!("not a sample frame: {other:?}"),
            })
            .collect()
    }

    #[test]
    fn samples_go_eight_to_a_frame_with_their_indices() {
        let samples: Vec<[f32; 3]> = (0..17).map(|k| [k as f32, 0.0, 0.0]).collect();
        let messages = sample_messages(100, &samples);
        assert_eq!(frames(&messages), [(100, 8), (108, 8), (116, 1)]);
        let Outgoing::Message(HostToDevice::Samples(last)) = &messages[2] else {
            unreachable!("checked above");
        };
        assert_eq!(last.accel_m_s2[0], [16.0, 0.0, 0.0]);
    }

    #[test]
    fn a_failing_sample_source_ends_the_frames_with_its_error() {
        let source = (0..20).map(|k| if k == 10 { Err(k) } else { Ok([0.0f32; 3]) });
        let out: Vec<Result<Outgoing, i32>> = sample_frames(0, source).collect();
        assert_eq!(out.len(), 2);
        assert!(out[0].is_ok());
        assert_eq!(out[1].as_ref().err(), Some(&10));
    }
}
