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
use super::state::{Monitor, device_line, params_source_text};
use super::view::View;
use crate::device::device_params::{self, identity_hex};
use crate::device::link::{FrameReader, FrameWriter, check_protocol, format_duration};
use crate::device::qemu::{Qemu, QemuConfig};
use crate::device::replay::{Outgoing, sample_messages};
use crate::device::scratch::ScratchDir;
use crate::io::params_file::ParamFile;

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
        let message = reader.next_before(step);
        // A greeting in another protocol version may not decode at all: its version does
        // (checked first, in case the device then hung up).
        reader.check_foreign_greeting()?;
        match message? {
            Some(DeviceToHost::Greeting(g)) => {
                check_protocol(g.protocol_version)?;
                return Ok(g);
            }
            Some(_) => {}
            None if Instant::now() >= deadline => bail!(
                "no greeting from the device within {} (is it running supine firmware?)",
                format_duration(timeout)
            ),
            None => {}
        }
    }
}

/// Follows the device after its greeting: every message goes to `monitor`, then to `log`;
/// notices (alert events, greetings) to `view` at once; the view is refreshed at least
/// every 50 ms. With `until_status`, the first `Status` ends the session; past
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
                    "the device did not finish within {} ({} telemetry records so far)",
                    format_duration(deadline - started),
                    monitor.counters().telemetry
                );
            }
            let message = reader.next_before(Instant::now() + STEP);
            monitor.on_link(reader.stats);
            if let Some(log) = log.as_deref_mut() {
                log.on_link(reader.stats);
            }
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

/// The slowest the image in QEMU takes samples and still counts as running: a 20 s ride
/// with the input stream on took over 70 s (about 130 samples/s) while two test suites and
/// two builds shared the 2 cores; the same run takes a few seconds on an idle machine.
pub const SLOWEST_QEMU_SAMPLES_PER_S: f64 = 100.0;

/// A ride to stream through the image in QEMU.
#[derive(Clone, Debug)]
pub struct QemuRun {
    /// The product image (embedded, or `--firmware`).
    pub kernel: crate::device::image::ProductImage,
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
    /// The alert thresholds in the blob, shown beside the values.
    pub thresholds: supine_core::alerts::AlertConfig,
}

impl QemuRun {
    /// A run of the product image with `file`'s parameters at `sample_rate_hz` (built
    /// once: the blob and the identity the device must greet with come from one build),
    /// streaming `samples` through `kernel`.
    pub fn new(
        kernel: crate::device::image::ProductImage,
        file: &ParamFile,
        samples: Vec<[f32; 3]>,
        sample_rate_hz: f64,
        realtime: bool,
        greeting_timeout: Duration,
    ) -> Result<Self> {
        let params = device_params::build(file, sample_rate_hz)?;
        let blob = device_params::encode(&params)?;
        Ok(Self {
            kernel,
            blob,
            identity: params.identity,
            samples,
            sample_rate_hz,
            realtime,
            greeting_timeout,
            thresholds: params.alerts.config,
        })
    }

    /// Longest the whole run may take: the ride's duration if paced, plus a margin for a
    /// device that takes at least [`SLOWEST_QEMU_SAMPLES_PER_S`].
    pub fn timeout(&self) -> Duration {
        let ride_s = self.samples.len() as f64 / self.sample_rate_hz;
        let paced_s = if self.realtime { ride_s } else { 0.0 };
        Duration::from_secs_f64(
            60.0 + paced_s + self.samples.len() as f64 / SLOWEST_QEMU_SAMPLES_PER_S,
        )
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
    let blob_dir = ScratchDir::new("blob")?;
    let blob_path = blob_dir.path().join("params.bin");
    std::fs::write(&blob_path, &run.blob).context("writing the parameter blob")?;
    let config = QemuConfig::new(run.kernel.path())
        .uart()
        .params_blob(blob_path)
        .timeout(run.timeout());
    let mut qemu = Qemu::start(&config)?;
    let result = talk(&mut qemu, run, view, log, stop).map_err(|e| qemu.explain_failure(e));
    // Killing QEMU also ends a writer blocked on the socket.
    let _ = qemu.stop();
    result
}

fn talk(
    qemu: &mut Qemu,
    run: &QemuRun,
    view: &mut dyn View,
    mut log: Option<&mut MonitorLog>,
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
            "the device runs parameters {} instead of the blob sent: they come from {}",
            identity_hex(&greeting.params_identity),
            params_source_text(greeting.params_source)
        );
    }
    if let Some(log) = log.as_deref_mut() {
        log.on_greeting(&greeting);
    }
    let mut monitor = Monitor::new(&greeting)?;
    // A log asks for the input stream, so that the session can be re-analysed.
    let stream_input = log.is_some();
    let mut log = log;
    if let Some(log) = log.as_deref_mut() {
        log.on_greeting(&greeting);
    }
    monitor.set_ride_length_s(Some(run.samples.len() as f64 / run.sample_rate_hz));
    monitor.set_thresholds(Some(run.thresholds));
    // The writer stops on `stop`, at the end of the ride, or when the reader is done
    // (`done`); shutting the socket down unblocks it if the device stopped reading.
    let done = Arc::new(AtomicBool::new(false));
    let writer = {
        let stop = Arc::clone(stop);
        let done = Arc::clone(&done);
        let samples = run.samples.clone();
        let sample_rate_hz = run.sample_rate_hz;
        let realtime = run.realtime;
        thread::spawn(move || {
            stream_ride(
                tx,
                &samples,
                sample_rate_hz,
                realtime,
                stream_input,
                &stop,
                &done,
            )
        })
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
/// `realtime`: each frame leaves when its last sample is due. With `stream_input`, asks
/// for the device's input stream first.
fn stream_ride(
    tx: std::os::unix::net::UnixStream,
    samples: &[[f32; 3]],
    sample_rate_hz: f64,
    realtime: bool,
    stream_input: bool,
    stop: &AtomicBool,
    done: &AtomicBool,
) -> Result<()> {
    let mut writer = FrameWriter::new(std::io::BufWriter::with_capacity(4096, tx));
    let start = Instant::now();
    let mut sent = 0usize;
    let ask = stream_input.then_some(Outgoing::Message(HostToDevice::StreamInput {
        enabled: true,
    }));
    for item in ask
        .into_iter()
        .chain(sample_messages(0, samples))
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

/// Follows a device on a serial port (at `baud`) until Ctrl-C or the port fails: waits
/// for its greeting, names the device on standard error, then [`follow`]s it.
pub fn run_serial(
    port: &str,
    baud: u32,
    greeting_timeout: Duration,
    view: &mut dyn View,
    mut log: Option<&mut MonitorLog>,
    stop: &AtomicBool,
) -> Result<(Monitor, Ending)> {
    let serial = open_serial(port, baud, log.is_some())?;
    let mut reader = FrameReader::new(serial);
    let greeting = wait_greeting(&mut reader, greeting_timeout, stop)
        .with_context(|| format!("{port} at {baud} baud"))?;
    eprintln!("supine monitor: {}", device_line(&greeting));
    if let Some(log) = log.as_deref_mut() {
        log.on_greeting(&greeting);
    }
    let mut monitor = Monitor::new(&greeting)?;
    let mut log = log;
    if let Some(log) = log.as_deref_mut() {
        log.on_greeting(&greeting);
    }
    let ending = follow(&mut reader, &mut monitor, view, log, stop, false, None)?;
    Ok((monitor, ending))
}

/// Opens a real device on `port` at `baud` and asks it to greet (`Hello`), and with
/// `stream_input` to stream its input; the returned port reads with a short timeout, as
/// [`FrameReader`] expects.
pub fn open_serial(
    port: &str,
    baud: u32,
    stream_input: bool,
) -> Result<Box<dyn serialport::SerialPort>> {
    let mut serial = serialport::new(port, baud)
        .timeout(STEP)
        .open()
        .map_err(|e| anyhow!("cannot open serial port {port}: {e}"))?;
    let mut writer = FrameWriter::new(&mut serial);
    writer.send(&HostToDevice::Hello)?;
    if stream_input {
        writer.send(&HostToDevice::StreamInput { enabled: true })?;
    }
    writer.flush()?;
    Ok(serial)
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use super::*;
    use crate::monitor::view::PlainView;
    use supine_core::alerts::{AlertEvent, Criterion, FaultFlags, Level, SensorFault};
    use supine_core::protocol::{
        DeviceFrame, MAX_FRAME_LEN, PROTOCOL_VERSION, ParamsSource, ResetCause, Status, Telemetry,
        encode_frame,
    };

    fn frame(seq: u32, message: DeviceToHost) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        encode_frame(&DeviceFrame { seq, message }, &mut buf)
            .expect("encodes")
            .to_vec()
    }

    fn greeting(protocol_version: u16) -> DeviceToHost {
        DeviceToHost::Greeting(Greeting {
            protocol_version,
            firmware_version: heapless::String::try_from("0.1.0+test").expect("fits"),
            params_identity: [1; 16],
            params_source: ParamsSource::Flash { slot: 1 },
            sample_rate_hz: 250.0,
            height_m: 1.82,
            mass_kg: 81.0,
            reset_cause: ResetCause::PowerOn,
            last_panic: heapless::String::new(),
            joint_outputs: 0,
            calibration: supine_core::calibration::SensorCalibration::DATASHEET,
        })
    }

    fn telemetry(sample_index: u32) -> DeviceToHost {
        DeviceToHost::Telemetry(Telemetry {
            sample_index,
            head_acc_m_s2: [0.0, 0.0, 1.0],
            running_rms_m_s2: [0.1, 0.1, 0.9],
            vector_running_rms_m_s2: 0.95,
            vdv_m_s175: 2.0,
            alert_level: Level::Advisory,
            fault_flags: FaultFlags::empty(),
            valid: true,
            joints: supine_core::joint_exposure::JointValues::EMPTY,
        })
    }

    /// A hand-built stream: greeting, telemetry with 3 frames missing (seq 3..=5) and a
    /// corrupted frame, an alert event, telemetry, a fault event, then a status.
    fn stream() -> Vec<u8> {
        let mut bytes = frame(0, greeting(PROTOCOL_VERSION));
        bytes.extend(frame(1, telemetry(0)));
        bytes.extend(frame(2, telemetry(1)));
        bytes.extend(frame(6, telemetry(5)));
        // A frame whose payload was hit on the line: postcard cannot decode it.
        let mut hit = frame(7, telemetry(6));
        hit[3] ^= 0x5a;
        hit[4] = 0xff;
        bytes.extend(hit);
        bytes.extend(frame(
            8,
            DeviceToHost::Alert(AlertEvent::Level {
                from: Level::Normal,
                to: Level::Alarm,
                criterion: Criterion::Vdv {
                    value_m_s175: 21.25,
                },
                at_sample: 500,
            }),
        ));
        bytes.extend(frame(9, telemetry(510)));
        bytes.extend(frame(
            10,
            DeviceToHost::Alert(AlertEvent::Fault {
                fault: SensorFault::Saturated,
                active: true,
                at_sample: 510,
            }),
        ));
        bytes.extend(frame(11, DeviceToHost::Status(Status::default())));
        bytes
    }

    #[test]
    fn lost_and_bad_frames_are_counted_and_events_shown_as_they_come() {
        let mut reader = FrameReader::new(Cursor::new(stream()));
        let stop = AtomicBool::new(false);
        let g = wait_greeting(&mut reader, Duration::from_secs(1), &stop).expect("greeting");
        let mut monitor = Monitor::new(&g).expect("monitor");
        let mut view = PlainView::new(Vec::new());
        let ending = follow(
            &mut reader,
            &mut monitor,
            &mut view,
            None,
            &stop,
            true,
            None,
        )
        .expect("follows");
        assert_eq!(ending, Ending::Finished);
        let c = monitor.counters();
        assert_eq!(c.telemetry, 4);
        assert_eq!((c.events, c.raised, c.statuses), (2, 2, 1));
        // seq 3, 4, 5 never came; seq 7 came damaged (bad, and so also missing).
        assert_eq!(c.link.bad_frames, 1);
        assert_eq!(c.link.lost_frames, 4);
        assert_eq!(c.link.frames, 8);
        assert_eq!(monitor.fault_names(), ["saturated"]);
        let text = String::from_utf8(view.into_inner()).expect("utf-8");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[..2],
            [
                "[ALARM] t 2.000 s (sample 500): alert level raised normal -> alarm by vdv 21.250 m/s^1.75",
                "[FAULT] t 2.040 s (sample 510): sensor fault saturated raised",
            ]
        );
        // The closing status line, and no escape codes anywhere.
        assert!(lines[2].contains("frames 8 lost 4 bad 1"), "{text}");
        assert!(!text.contains('\x1b'), "{text}");
    }

    #[test]
    fn a_stream_that_ends_is_an_error_and_a_stop_is_not() {
        let mut bytes = frame(0, greeting(PROTOCOL_VERSION));
        bytes.extend(frame(1, telemetry(0)));
        let mut reader = FrameReader::new(Cursor::new(bytes.clone()));
        let stop = AtomicBool::new(false);
        let g = wait_greeting(&mut reader, Duration::from_secs(1), &stop).expect("greeting");
        let mut monitor = Monitor::new(&g).expect("monitor");
        let mut view = PlainView::new(Vec::new());
        let err = follow(
            &mut reader,
            &mut monitor,
            &mut view,
            None,
            &stop,
            false,
            None,
        )
        .expect_err("the stream ended");
        assert!(err.to_string().contains("closed the connection"), "{err}");
        let stop = AtomicBool::new(true);
        let mut reader = FrameReader::new(Cursor::new(bytes));
        let ending = follow(
            &mut reader,
            &mut monitor,
            &mut view,
            None,
            &stop,
            false,
            None,
        )
        .expect("a stop ends cleanly");
        assert_eq!(ending, Ending::Stopped);
    }

    #[test]
    fn no_greeting_and_a_greeting_in_another_version_are_one_line_each() {
        let stop = AtomicBool::new(false);
        // Telemetry but never a greeting: the wait times out.
        let (a, b) = std::os::unix::net::UnixStream::pair().expect("socket pair");
        a.set_read_timeout(Some(STEP)).expect("timeout");
        let mut reader = FrameReader::new(a);
        let mut device = b;
        std::io::Write::write_all(&mut device, &frame(4, telemetry(9))).expect("write");
        let err =
            wait_greeting(&mut reader, Duration::from_millis(300), &stop).expect_err("no greeting");
        assert_eq!(
            err.to_string(),
            "no greeting from the device within 300 ms (is it running supine firmware?)"
        );
        let bytes = frame(0, greeting(PROTOCOL_VERSION + 1));
        let mut reader = FrameReader::new(Cursor::new(bytes));
        let err = wait_greeting(&mut reader, Duration::from_secs(1), &stop).expect_err("mismatch");
        let text = err.to_string();
        assert!(!text.contains('\n'), "{text}");
        assert!(text.contains("update this host tool"), "{text}");
        // A newer device's greeting that this host cannot decode at all: refused by the
        // version it leads with, not reported as a decoding error or a silence.
        let mut bytes = crate::device::link::tests::other_greeting_frame(PROTOCOL_VERSION + 1);
        bytes.extend(frame(1, telemetry(0)));
        let mut reader = FrameReader::new(Cursor::new(bytes));
        let err = wait_greeting(&mut reader, Duration::from_secs(1), &stop).expect_err("mismatch");
        let text = err.to_string();
        assert!(
            text.starts_with(&format!(
                "the device speaks protocol version {}, this supine speaks {PROTOCOL_VERSION}: update",
                PROTOCOL_VERSION + 1
            )),
            "{text}"
        );
    }
}
