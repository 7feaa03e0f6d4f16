//! `supine monitor --serial` against a fake device on a pseudo-terminal pair: the test holds
//! the master side and speaks the device's protocol; the binary opens the slave as a
//! serial port. Covers the protocol-mismatch refusal, a silent device, and a session with
//! lost and bad frames, events and Ctrl-C.

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::Duration;

use nix::pty::openpty;
use supine_core::alerts::{AlertEvent, Criterion, FaultFlags, Level, SensorFault};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, Greeting, HostToDevice, MAX_FRAME_LEN, PROTOCOL_VERSION,
    ParamsSource, ResetCause, Telemetry, encode_frame,
};
use supine_host::io::telemetry_csv::{EVENTS_HEADER, TELEMETRY_HEADER};

/// A fake device: the master side of a pty, and the slave's path for the binary.
struct FakeDevice {
    master: File,
    path: String,
    // Held open so the master does not see a hang-up before the binary opens the port.
    _slave: OwnedFd,
    bytes: mpsc::Receiver<u8>,
}

impl FakeDevice {
    fn new() -> Self {
        let pty = openpty(None, None).expect("openpty");
        let path = nix::unistd::ttyname(&pty.slave)
            .expect("slave name")
            .to_string_lossy()
            .into_owned();
        let master = File::from(pty.master);
        let mut reader = master.try_clone().expect("clone master");
        let (tx, bytes) = mpsc::channel();
        thread::spawn(move || {
            let mut buf = [0u8; 256];
            while let Ok(n) = reader.read(&mut buf) {
                if n == 0 || buf[..n].iter().any(|b| tx.send(*b).is_err()) {
                    return;
                }
            }
        });
        Self {
            master,
            path,
            _slave: pty.slave,
            bytes,
        }
    }

    /// Waits for the host's `Hello` (what the monitor sends when it opens the port).
    fn expect_hello(&self) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let hello = encode_frame(&HostToDevice::Hello, &mut buf)
            .expect("encodes")
            .to_vec();
        let mut got = Vec::new();
        while got.last() != Some(&0) {
            got.push(
                self.bytes
                    .recv_timeout(Duration::from_secs(30))
                    .expect("the monitor sends Hello"),
            );
        }
        assert_eq!(got, hello);
    }

    fn send(&mut self, seq: u32, message: DeviceToHost) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(&DeviceFrame { seq, message }, &mut buf).expect("encodes");
        self.master.write_all(frame).expect("write to the pty");
    }
}

fn greeting(protocol_version: u16) -> DeviceToHost {
    DeviceToHost::Greeting(Greeting {
        protocol_version,
        firmware_version: heapless::String::try_from("0.1.0+board").expect("fits"),
        params_identity: [0x5a; 16],
        params_source: ParamsSource::Flash { slot: 1 },
        sample_rate_hz: 200.0,
        height_m: 1.5,
        mass_kg: 47.5,
        reset_cause: ResetCause::PowerOn,
        last_panic: heapless::String::new(),
        joint_outputs: 0,
        calibration: supine_core::calibration::SensorCalibration::DATASHEET,
    })
}

fn telemetry(sample_index: u32, level: Level) -> DeviceToHost {
    DeviceToHost::Telemetry(Telemetry {
        sample_index,
        head_acc_m_s2: [0.125, -0.5, 1.5],
        running_rms_m_s2: [0.25, 0.25, 1.0],
        vector_running_rms_m_s2: 1.0625,
        vdv_m_s175: 2.5,
        alert_level: level,
        fault_flags: FaultFlags::empty(),
        valid: true,
        joints: supine_core::joint_exposure::JointValues::EMPTY,
    })
}

fn monitor(device: &FakeDevice, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["monitor", "--serial", &device.path])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("supine runs")
}

fn finish(child: Child) -> (Output, String, String) {
    let output = child.wait_with_output().expect("supine exits");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    println!("stdout:\n{stdout}\nstderr:\n{stderr}");
    (output, stdout, stderr)
}

#[test]
fn a_device_in_another_protocol_version_is_refused_with_what_to_do() {
    let mut device = FakeDevice::new();
    let child = monitor(&device, &["--timeout-s", "20"]);
    device.expect_hello();
    device.send(0, greeting(PROTOCOL_VERSION + 1));
    let (output, _, stderr) = finish(child);
    assert!(!output.status.success());
    assert_eq!(
        stderr.trim_end(),
        format!(
            "supine: {} at 921600 baud: the device speaks protocol version {}, this supine speaks {PROTOCOL_VERSION}: update this host tool to the firmware's release (`cargo install --path host` from the same checkout)",
            device.path,
            PROTOCOL_VERSION + 1
        )
    );
}

/// A greeting as an older firmware might have sent it: the sequence number, variant 0 and
/// the protocol version lead as in every version, then fields this host has never known.
#[derive(serde::Serialize)]
struct OldGreeting {
    seq: u32,
    variant: u32,
    protocol_version: u16,
    uptime_ms: u64,
    board: [u8; 4],
}

#[test]
fn a_greeting_that_does_not_decode_is_refused_for_its_version_not_as_garbage() {
    let mut device = FakeDevice::new();
    let child = monitor(&device, &["--timeout-s", "20"]);
    device.expect_hello();
    let mut buf = [0u8; MAX_FRAME_LEN];
    let old = OldGreeting {
        seq: 0,
        variant: 0,
        protocol_version: 0,
        uptime_ms: u64::MAX,
        board: *b"bp41",
    };
    let frame = postcard::to_slice_cobs(&old, &mut buf).expect("encodes");
    device.master.write_all(frame).expect("write to the pty");
    let (output, _, stderr) = finish(child);
    assert!(!output.status.success());
    assert_eq!(
        stderr.trim_end(),
        format!(
            "supine: {} at 921600 baud: the device speaks protocol version 0, this supine speaks {PROTOCOL_VERSION}: reflash the device with this release's firmware (`cargo fw-board` and probe-rs, see the README; `cargo fw` for QEMU)",
            device.path,
        )
    );
}

#[test]
fn a_silent_device_is_one_line_after_the_timeout() {
    let device = FakeDevice::new();
    let child = monitor(&device, &["--timeout-s", "1", "--baud", "57600"]);
    device.expect_hello();
    let (output, stdout, stderr) = finish(child);
    assert!(!output.status.success());
    assert!(stdout.is_empty());
    assert_eq!(
        stderr.trim_end(),
        format!(
            "supine: {} at 57600 baud: no greeting from the device within 1 s (is it running supine firmware?)",
            device.path
        )
    );
}

#[test]
fn a_session_counts_lost_and_bad_frames_logs_everything_and_ends_on_ctrl_c() {
    let dir = tempfile::tempdir().expect("temp dir");
    let log = dir.path().join("board.csv");
    let mut device = FakeDevice::new();
    let child = monitor(
        &device,
        &["--log", log.to_str().expect("utf-8"), "--timeout-s", "20"],
    );
    device.expect_hello();
    device.send(0, greeting(PROTOCOL_VERSION));
    device.send(1, telemetry(0, Level::Normal));
    device.send(2, telemetry(1, Level::Normal));
    // seq 3 and 4 are lost on the line; then a frame arrives damaged.
    device.send(5, telemetry(4, Level::Normal));
    device
        .master
        .write_all(&[0x07, 0x01, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00])
        .expect("garbage");
    device.send(
        7,
        DeviceToHost::Alert(AlertEvent::Level {
            from: Level::Normal,
            to: Level::Warning,
            criterion: Criterion::RunningRms { value_m_s2: 0.6 },
            at_sample: 5,
        }),
    );
    device.send(8, telemetry(6, Level::Warning));
    device.send(
        9,
        DeviceToHost::Alert(AlertEvent::Fault {
            fault: SensorFault::Stuck,
            active: true,
            at_sample: 6,
        }),
    );
    // Let the monitor read it all, then Ctrl-C.
    thread::sleep(Duration::from_millis(1500));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    let (output, stdout, stderr) = finish(child);
    assert!(
        output.status.success(),
        "Ctrl-C ends a serial monitor normally"
    );
    assert!(
        stderr.contains(&format!(
            "supine monitor: firmware 0.1.0+board, protocol {PROTOCOL_VERSION}, parameters {} from flash slot B, 200 Hz",
            "5a".repeat(16)
        )),
        "{stderr}"
    );
    // seq 3, 4 and 6 missing (6 is the damaged one); one frame failed to decode.
    assert!(
        stderr.contains("4 telemetry records, 2 alert events (2 raised), highest level warning"),
        "{stderr}"
    );
    assert!(stderr.contains("frames 7, lost 3, bad 1"), "{stderr}");
    assert!(
        stdout.contains("[WARNING] t 0.025 s (sample 5): alert level raised normal -> warning"),
        "{stdout}"
    );
    assert!(
        stdout.contains("[FAULT] t 0.030 s (sample 6): sensor fault stuck raised"),
        "{stdout}"
    );
    assert!(stdout.contains("faults stuck"), "{stdout}");
    assert!(!stdout.contains('\x1b'), "{stdout}");
    let rows = std::fs::read_to_string(&log).expect("log");
    assert_eq!(
        rows,
        format!(
            "{TELEMETRY_HEADER}\n\
             0,0,0.125,-0.5,1.5,0.25,0.25,1,1.0625,2.5,normal,0,1\n\
             1,0.005,0.125,-0.5,1.5,0.25,0.25,1,1.0625,2.5,normal,0,1\n\
             4,0.02,0.125,-0.5,1.5,0.25,0.25,1,1.0625,2.5,normal,0,1\n\
             6,0.03,0.125,-0.5,1.5,0.25,0.25,1,1.0625,2.5,warning,0,1\n"
        )
    );
    let events = std::fs::read_to_string(dir.path().join("board.events.csv")).expect("events");
    assert_eq!(
        events,
        format!(
            "{EVENTS_HEADER}\n5,0.025,level,warning,1,running-rms,0.6,m/s^2\n6,0.03,fault,stuck,1,,,\n"
        )
    );
}

#[test]
fn jsonl_streams_each_record_and_event_and_json_summarises() {
    for mode in ["--jsonl", "--json"] {
        let mut device = FakeDevice::new();
        let child = monitor(&device, &[mode, "--timeout-s", "20"]);
        device.expect_hello();
        device.send(0, greeting(PROTOCOL_VERSION));
        device.send(1, telemetry(0, Level::Normal));
        device.send(
            2,
            DeviceToHost::Alert(AlertEvent::Level {
                from: Level::Normal,
                to: Level::Advisory,
                criterion: Criterion::RunningRms { value_m_s2: 0.6 },
                at_sample: 1,
            }),
        );
        device.send(3, telemetry(2, Level::Advisory));
        thread::sleep(Duration::from_millis(1500));
        let status = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .expect("kill runs");
        assert!(status.success());
        let (output, stdout, stderr) = finish(child);
        assert!(output.status.success(), "{stderr}");
        assert!(stderr.contains("patient 1.5 m, 47.5 kg"), "{stderr}");
        let objects: Vec<serde_json::Value> = stdout
            .lines()
            .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
            .collect();
        if mode == "--json" {
            assert_eq!(objects.len(), 1, "{stdout}");
            let s = &objects[0];
            assert_eq!(s["telemetry_records"], 2);
            assert_eq!(s["alert_events"], 1);
            assert_eq!(s["highest_level"], "advisory");
            assert_eq!(s["peak_vector_running_rms_m_s2"], 1.0625);
            assert_eq!(s["ride_s"], serde_json::Value::Null);
            // The patient the device said it predicts for.
            assert_eq!(s["subject"]["height_m"], 1.5);
            assert_eq!(s["subject"]["mass_kg"], 47.5);
            continue;
        }
        let kinds: Vec<&str> = objects
            .iter()
            .map(|o| o["type"].as_str().expect("type"))
            .filter(|t| *t != "notice")
            .collect();
        assert_eq!(kinds, ["telemetry", "event", "telemetry"], "{stdout}");
        let records: Vec<&serde_json::Value> = objects
            .iter()
            .filter(|o| o["type"] == "telemetry")
            .collect();
        // 200 Hz: sample 2 is at 0.01 s; the values are the device's.
        assert_eq!(records[1]["sample"], 2);
        assert_eq!(records[1]["time_s"], 0.01);
        assert_eq!(records[1]["vector_running_rms_m_s2"], 1.0625);
        assert_eq!(records[1]["head_m_s2"][2], 1.5);
        assert_eq!(records[1]["level"], "advisory");
        let event = objects
            .iter()
            .find(|o| o["type"] == "event")
            .expect("event");
        assert_eq!(event["to"], "advisory");
        assert_eq!(event["time_s"], 0.005);
        assert_eq!(event["criterion"], "running-rms");
        // f32 in its shortest form, as the CSV writes it.
        assert_eq!(event["value_m_s2"], 0.6);
    }
}
