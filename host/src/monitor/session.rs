//! The monitoring loop and the links it follows.
//!
//! [`follow`] reads decoded messages from any [`FrameReader`] and drives a [`Monitor`], a
//! [`View`] and the optional [`MonitorLog`] until the device's final status (QEMU), a stop
//! request (Ctrl-C) or the end of the link. The sources:
//! - [`run_qemu`]: the product image in QEMU with a parameter blob; in QEMU the device has
//!   no sensor, so a writer thread streams a ride's samples over the UART (as fast as the
//!   device takes them, or paced in real time), then `GetStatus`, whose answer ends the
//!   session. The host only reads what comes back, exactly as on a real device.
//! - [`open_serial`]: a real device on a serial port, which reads its own accelerometer;
//!   the host sends only `Hello` (so a running device greets again) and listens.

use std::io::Read;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use supine_core::protocol::{DeviceToHost, Greeting, HostToDevice};

use super::log::MonitorLog;
use super::state::Monitor;
use super::view::View;
use crate::device_params::identity_hex;
use crate::link::{FrameReader, FrameWriter, check_protocol};
use crate::qemu::{Qemu, QemuConfig};
use crate::replay::{Outgoing, sample_messages};

/// Longest wait for a message before the loop checks the stop flag and redraws.
const STEP: Duration = Duration::from_millis(50);

/// How a followed session ended (errors aside).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    /// The device's status answered the final `GetStatus` (QEMU: the ride is done).
    Finished,
    /// The stop flag was set (Ctrl-C).
    Stopped,
}

/// Waits up to `timeout` for the device's greeting (skipping anything before it) and
/// refuses another protocol version; `stop` ends the wait early.
pub fn wait_greeting<R: Read>(
    reader: &mut FrameReader<R>,
    timeout: Duration,
    stop: &AtomicBool,
) -> Result<Greeting> {
    let deadline = Instant::now() + timeout;
    loop {
        if stop.load(Ordering::Relaxed) {
            bail!("interrupted while waiting for the device's greeting");
        }
        let step = (Instant::now() + STEP).min(deadline);
        match reader.next_before(step)? {
            Some(DeviceToHost::Greeting(g)) => {
                check_protocol(g.protocol_version)?;
                return Ok(g);
            }
            Some(_) => {}
            None if Instant::now() >= deadline => bail!(
                "no greeting from the device within {:.0} s (is it running supine firmware?)",
                timeout.as_secs_f64()
            ),
            None => {}
        }
    }
}

/// Follows the device after its greeting: every message goes to `monitor`, then to `log`;
/// notices (alert events, greetings) to `view` at once; the view is refreshed at least
/// every [`STEP`]. With `until_status`, the first `Status` ends the session; past
/// `deadline`, the session fails.
///
/// On any ending, the log is left as written so far (the caller finishes it) and the
/// view is closed (terminal restored) before returning, also on errors.
pub fn follow<R: Read>(
    reader: &mut FrameReader<R>,
    monitor: &mut Monitor,
    view: &mut dyn View,
    mut log: Option<&mut MonitorLog>,
    stop: &AtomicBool,
    until_status: bool,
    deadline: Option<Instant>,
) -> Result<Ending> {
    let started = Instant::now();
    let result = (|| -> Result<Ending> {
        loop {
            if stop.load(Ordering::Relaxed) {
                return Ok(Ending::Stopped);
            }
            if let Some(deadline) = deadline
                && Instant::now() >= deadline
            {
                bail!(
                    "the device did not finish within {:.0} s ({} telemetry records so far)",
                    (deadline - started).as_secs_f64(),
                    monitor.counters().telemetry
                );
            }
            let message = reader.next_before(Instant::now() + STEP);
            monitor.on_link(reader.stats);
            let message = match message {
                Ok(message) => message,
                // Ctrl-C on a terminal also reaches QEMU (same process group), whose link
                // may fail before the handler has set the flag: a failure then is a stop.
                Err(e) => {
                    thread::sleep(STEP);
                    if stop.load(Ordering::Relaxed) {
                        return Ok(Ending::Stopped);
                    }
                    return Err(e);
                }
            };
            if let Some(message) = message {
                let notice = monitor.on_message(&message)?;
                if let Some(log) = log.as_deref_mut() {
                    log.on_message(&message, monitor.sample_rate_hz())?;
                }
                if let Some(notice) = notice {
                    view.notice(monitor, &notice)?;
                }
                if until_status && matches!(message, DeviceToHost::Status(_)) {
                    return Ok(Ending::Finished);
                }
            } else if let Some(log) = log.as_deref_mut() {
                log.flush_if_due()?;
            }
            view.refresh(monitor)?;
        }
    })();
    let closed = view.close(monitor);
    let ending = result?;
    closed?;
    Ok(ending)
}

/// A ride to stream through the image in QEMU.
#[derive(Clone, Debug)]
pub struct QemuRun {
    /// The firmware ELF (the product image).
    pub kernel: std::path::PathBuf,
    /// The parameter blob placed in the PARAMS region.
    pub blob: Vec<u8>,
    /// The identity of the parameters in the blob (the device must greet with it).
    pub identity: supine_core::protocol::ParamsIdentity,
    /// The ride's samples, litter axes, gravity removed, m/s^2.
    pub samples: Vec<[f32; 3]>,
    /// The ride's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Pace the samples in real time (otherwise as fast as the device takes them).
    pub realtime: bool,
    /// Longest wait for the boot greeting.
    pub greeting_timeout: Duration,
}

impl QemuRun {
    /// Longest the whole run may take: the ride's duration if paced, plus a margin for a
    /// device that runs tens of thousands of samples per second.
    pub fn timeout(&self) -> Duration {
        let ride_s = self.samples.len() as f64 / self.sample_rate_hz;
        let paced_s = if self.realtime { ride_s } else { 0.0 };
        Duration::from_secs_f64(60.0 + paced_s + self.samples.len() as f64 / 1000.0)
    }
}

/// Starts the image in QEMU with `run`'s blob, streams its ride and follows the device
/// with `view` and `log` until the final status (or `stop`). QEMU is stopped and its
/// folder removed before this returns, whatever happened. Returns the final monitor and
/// how the session ended.
pub fn run_qemu(
    run: &QemuRun,
    view: &mut dyn View,
    log: Option<&mut MonitorLog>,
    stop: &Arc<AtomicBool>,
) -> Result<(Monitor, Ending)> {
    let blob_dir = tempfile::Builder::new().prefix("supine-blob-").tempdir()?;
    let blob_path = blob_dir.path().join("params.bin");
    std::fs::write(&blob_path, &run.blob).context("writing the parameter blob")?;
    let config = QemuConfig::new(&run.kernel)
        .uart()
        .params_blob(blob_path)
        .timeout(run.timeout());
    let mut qemu = Qemu::start(&config)?;
    let result = talk(&mut qemu, run, view, log, stop);
    // Killing QEMU also ends a writer blocked on the socket.
    let _ = qemu.stop();
    result
}

fn talk(
    qemu: &mut Qemu,
    run: &QemuRun,
    view: &mut dyn View,
    log: Option<&mut MonitorLog>,
    stop: &Arc<AtomicBool>,
) -> Result<(Monitor, Ending)> {
    let deadline = Instant::now() + qemu.remaining();
    let uart = qemu.uart().ok_or_else(|| anyhow!("QEMU has no UART"))?;
    uart.set_read_timeout(Some(STEP))?;
    let rx = uart.try_clone()?;
    let tx = uart.try_clone()?;
    let shutdown = uart.try_clone()?;
    let mut reader = FrameReader::new(rx);
    let greeting = wait_greeting(&mut reader, run.greeting_timeout, stop)
        .context("the firmware in QEMU did not start")?;
    if greeting.params_identity != run.identity {
        bail!(
            "the device runs parameters {} instead of the blob sent ({:?})",
            identity_hex(&greeting.params_identity),
            greeting.params_source
        );
    }
    let mut monitor = Monitor::new(&greeting)?;
    // The writer stops on `stop`, at the end of the ride, or when the reader is done
    // (`done`); shutting the socket down unblocks it if the device stopped reading.
    let done = Arc::new(AtomicBool::new(false));
    let writer = {
        let stop = Arc::clone(stop);
        let done = Arc::clone(&done);
        let samples = run.samples.clone();
        let sample_rate_hz = run.sample_rate_hz;
        let realtime = run.realtime;
        thread::spawn(move || stream_ride(tx, &samples, sample_rate_hz, realtime, &stop, &done))
    };
    let ending = follow(
        &mut reader,
        &mut monitor,
        view,
        log,
        stop,
        true,
        Some(deadline),
    );
    done.store(true, Ordering::Relaxed);
    if !matches!(ending, Ok(Ending::Finished)) {
        let _ = shutdown.shutdown(std::net::Shutdown::Both);
    }
    let written = writer
        .join()
        .map_err(|_| anyhow!("the sample writer panicked"))?;
    let ending = ending?;
    if ending == Ending::Finished {
        written?;
    }
    Ok((monitor, ending))
}

/// Streams `samples` as `Samples` frames (then `GetStatus`), paced at `sample_rate_hz` if
/// `realtime`: each frame leaves when its last sample is due.
fn stream_ride(
    tx: std::os::unix::net::UnixStream,
    samples: &[[f32; 3]],
    sample_rate_hz: f64,
    realtime: bool,
    stop: &AtomicBool,
    done: &AtomicBool,
) -> Result<()> {
    let mut writer = FrameWriter::new(std::io::BufWriter::with_capacity(4096, tx));
    let start = Instant::now();
    let mut sent = 0usize;
    for item in sample_messages(0, samples)
        .into_iter()
        .chain([Outgoing::Message(HostToDevice::GetStatus)])
    {
        if let Outgoing::Message(HostToDevice::Samples(batch)) = &item {
            sent += batch.accel_m_s2.len();
            if realtime {
                writer.flush()?;
                let due = start + Duration::from_secs_f64(sent as f64 / sample_rate_hz);
                while Instant::now() < due {
                    if stop.load(Ordering::Relaxed) || done.load(Ordering::Relaxed) {
                        return Ok(());
                    }
                    thread::sleep((due - Instant::now()).min(STEP));
                }
            }
        }
        if stop.load(Ordering::Relaxed) || done.load(Ordering::Relaxed) {
            return Ok(());
        }
        match item {
            Outgoing::Message(m) => writer.send(&m)?,
            Outgoing::Raw(bytes) => writer.send_raw(&bytes)?,
        }
    }
    writer.flush()
}

/// Opens a real device on `port` at `baud` and asks it to greet (`Hello`); the returned
/// port reads with a short timeout, as [`FrameReader`] expects.
pub fn open_serial(port: &str, baud: u32) -> Result<Box<dyn serialport::SerialPort>> {
    let mut serial = serialport::new(port, baud)
        .timeout(STEP)
        .open()
        .map_err(|e| anyhow!("cannot open serial port {port}: {e}"))?;
    let mut writer = FrameWriter::new(&mut serial);
    writer.send(&HostToDevice::Hello)?;
    writer.flush()?;
    Ok(serial)
}
