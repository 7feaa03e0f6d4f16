//! `supine monitor --qemu` as a user runs it: a scripted rough-road ride with a shock from
//! `supine ride`, streamed to the firmware in QEMU; its log checked against the host's own
//! pipeline (`supine_host::exposure::reference`): same telemetry rows, same alert events at the same
//! samples, head acceleration within 1e-4 m/s^2.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use supine_core::alerts::AlertEvent;
use supine_core::model::Preset;
use supine_host::exposure::reference;
use supine_host::io::params_file::ParamFile;
use supine_host::io::recording::read_input;
use supine_host::io::telemetry_csv::{EVENTS_HEADER, TELEMETRY_HEADER};
use supine_qemu_tests::{
    firmware, monitor_to_log, qemu_cmdline, rough_ride, signal_and_wait, supine_binary,
    wait_for_qemu_child,
};

fn cells(line: &str) -> Vec<&str> {
    line.split(',').collect()
}

#[test]
fn monitor_logs_what_the_host_pipeline_predicts_for_a_scripted_ride() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = rough_ride(dir.path());
    let log = dir.path().join("log.csv");
    let (ok, stdout, stderr) = monitor_to_log(&ride, &log);
    println!("stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(ok, "monitor failed: {stderr}");

    // The host's reference on the same f32 samples the CLI sent.
    let (recording, _) = read_input(&ride).expect("ride reads");
    let fs = recording.sample_rate_hz();
    let samples: Vec<[f32; 3]> = (0..recording.len())
        .map(|k| recording.platform_m_s2.each_ref().map(|c| c[k] as f32))
        .collect();
    let indices: Vec<u32> = (0..samples.len() as u32).collect();
    let file = ParamFile::preset(Preset::PaperLitter);
    let params = supine_host::device::device_params::build(&file, fs).expect("device params");
    let expected = reference::pipeline(&params, &indices, &samples);
    let head_f64 = reference::head_f64(&file.params, fs, &samples).expect("f64 model");
    assert!(
        expected.events.iter().any(AlertEvent::is_raise),
        "the scripted ride must raise an alert: {:?}",
        expected.events
    );

    // Telemetry: one row per record, at the same samples, head within 1e-4 m/s^2.
    let text = std::fs::read_to_string(&log).expect("log written");
    let mut lines = text.lines();
    // The parameters read all ten joint outputs (the default): their columns follow.
    let header = supine_host::io::telemetry_csv::telemetry_header(0b11_1111_1111);
    assert!(header.starts_with(TELEMETRY_HEADER));
    assert_eq!(lines.next(), Some(header.as_str()));
    let rows: Vec<Vec<&str>> = lines.map(cells).collect();
    assert_eq!(rows.len(), expected.telemetry.len());
    let mut worst_pipeline = 0.0f64;
    let mut worst_f64 = 0.0f64;
    for (row, t) in rows.iter().zip(&expected.telemetry) {
        let sample: u32 = row[0].parse().expect("sample index");
        assert_eq!(sample, t.sample_index);
        for axis in 0..3 {
            // The log prints each f32 in its shortest round-trip form: parsed as f32 it
            // is the device's value exactly.
            let logged: f32 = row[2 + axis].parse().expect("head value");
            let logged = f64::from(logged);
            worst_pipeline = worst_pipeline.max((logged - f64::from(t.head_acc_m_s2[axis])).abs());
            worst_f64 = worst_f64.max((logged - head_f64[sample as usize][axis]).abs());
        }
        assert_eq!(row[10], t.alert_level.name(), "level at sample {sample}");
        assert_eq!(
            row[11],
            t.fault_flags.as_repr().to_string(),
            "faults at sample {sample}"
        );
    }
    println!(
        "head: max |log - pipeline| {worst_pipeline:.3e}, max |log - f64 model| {worst_f64:.3e} m/s^2"
    );
    assert!(worst_pipeline <= 1e-4, "{worst_pipeline}");
    assert!(worst_f64 <= 1e-4, "{worst_f64}");

    // Events: the same edges at the same samples.
    let events_text =
        std::fs::read_to_string(dir.path().join("log.events.csv")).expect("events written");
    let mut lines = events_text.lines();
    assert_eq!(lines.next(), Some(EVENTS_HEADER));
    let logged: Vec<(u32, String, String, bool)> = lines
        .clone()
        .map(|l| {
            let c = cells(l);
            (
                c[0].parse().expect("sample"),
                c[2].to_string(),
                c[3].to_string(),
                c[4] == "1",
            )
        })
        .collect();
    let wanted: Vec<(u32, String, String, bool)> = expected
        .events
        .iter()
        .map(|e| {
            let (kind, name) = match *e {
                AlertEvent::Level { to, .. } => ("level", to.name()),
                AlertEvent::Fault { fault, .. } => ("fault", fault.name()),
                AlertEvent::Joint { .. } => {
                    ("joint", e.joint_criterion().map_or("", |(o, _)| o.name()))
                }
            };
            (e.at_sample(), kind.into(), name.into(), e.is_raise())
        })
        .collect();
    assert_eq!(logged, wanted);
    // Each level change names what changed it, with the host's value to the bit.
    let criteria: Vec<(String, Option<f32>, String)> = lines
        .map(|l| {
            let c = cells(l);
            (c[5].to_string(), c[6].parse().ok(), c[7].to_string())
        })
        .collect();
    let wanted_criteria: Vec<(String, Option<f32>, String)> = expected
        .events
        .iter()
        .map(|e| match e.criterion() {
            Some(c) => (c.name().into(), Some(c.value()), c.unit().into()),
            None => (String::new(), None, String::new()),
        })
        .collect();
    assert_eq!(criteria, wanted_criteria);

    // The plain view: no escape codes, each event as a tagged line, a summary on stderr.
    assert!(!stdout.contains('\x1b'), "escape codes in piped output");
    for (sample, _, name, raised) in &wanted {
        let line = stdout
            .lines()
            .find(|l| l.contains(&format!("(sample {sample})")))
            .unwrap_or_else(|| panic!("no line for the event at sample {sample}"));
        if *raised {
            assert!(
                line.starts_with('[') && !line.starts_with("[INFO]"),
                "{line}"
            );
            assert!(line.contains(name.as_str()), "{line}");
        }
    }
    assert!(
        stderr.contains(&format!(
            "{} telemetry records, {} alert events",
            rows.len(),
            wanted.len()
        )),
        "{stderr}"
    );
    assert!(stderr.contains("lost 0, bad 0"), "{stderr}");
    assert!(!dir.path().join("log.csv.partial").exists());
}

#[test]
fn realtime_pacing_and_ctrl_c_keep_the_log_and_leave_no_qemu() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let log = dir.path().join("live.csv");
    let child = Command::new(supine_binary())
        .args([
            "monitor",
            "--qemu",
            "--preset",
            "paper-litter",
            "--profile",
            "ambulance",
            "--duration-s",
            "60",
            "--realtime",
            "--log",
        ])
        .arg(&log)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("supine runs");
    let (qemu_pid, _) = wait_for_qemu_child(child.id());
    let qemu_started = std::time::Instant::now();
    std::thread::sleep(Duration::from_secs(3));
    let output = signal_and_wait(child, "INT");
    let streamed_s = qemu_started.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stderr}");
    assert!(!output.status.success(), "an interrupted ride fails");
    assert!(stderr.contains("interrupted after"), "{stderr}");
    assert!(stderr.contains("of 30000 samples"), "{stderr}");
    assert!(
        !Path::new(&format!("/proc/{qemu_pid}")).exists() || qemu_cmdline(qemu_pid).is_none(),
        "QEMU {qemu_pid} still running"
    );
    // The log holds what arrived, renamed into place; real time means at most the
    // streamed seconds' worth of telemetry (the device's default 100 Hz at 500 Hz), not
    // the whole ride.
    let decimation = supine_core::blob::TelemetryConfig::default_for(500.0).decimation;
    let rate_hz = 500.0 / f64::from(decimation);
    let text = std::fs::read_to_string(&log).expect("log kept on Ctrl-C");
    let rows = text.lines().count() - 1;
    println!("{rows} rows in {streamed_s:.2} s");
    assert!(rows as f64 > rate_hz, "{rows} rows: samples were streaming");
    assert!(
        (rows as f64) <= rate_hz * streamed_s + 8.0,
        "{rows} rows in {streamed_s:.2} s: faster than real time"
    );
    assert!(!dir.path().join("live.csv.partial").exists());
}
