//! `supine replay` as a user runs it: the binary, its CSV files, its instruction count,
//! and Ctrl-C leaving no QEMU process and no socket folder behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use supine_host::recording::Recording;
use supine_qemu_tests::{child_pids, firmware, qemu_cmdline, supine_binary};

/// A recording of `seconds` at 500 Hz with a few sines on the platform columns.
fn write_ride(dir: &Path, seconds: f64) -> PathBuf {
    let fs = 500.0;
    let n = (seconds * fs) as usize;
    let column = |f: f64, a: f64| -> Vec<f64> {
        (0..n)
            .map(|k| a * (std::f64::consts::TAU * f * k as f64 / fs).sin())
            .collect()
    };
    let platform = [column(1.5, 0.3), column(2.5, 0.2), column(4.5, 1.0)];
    let sensors: [Vec<f64>; 9] = std::array::from_fn(|_| vec![0.0; n]);
    let path = dir.join("ride.csv");
    Recording::from_columns(path.clone(), fs, platform, sensors)
        .write(&path)
        .expect("write the ride");
    path
}

/// Runs `supine replay --qemu --icount ARGS --input RIDE --out OUT` (ARGS: `--preset N`
/// or `--params F`, and options); returns its stderr and the instructions per sample it
/// printed.
fn replay_with_icount(args: &[&str], ride: &Path, out: &Path) -> (String, f64) {
    let output = Command::new(supine_binary())
        .args(["replay", "--qemu", "--icount"])
        .args(args)
        .arg("--input")
        .arg(ride)
        .arg("--out")
        .arg(out)
        .output()
        .expect("supine runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    println!("stdout: {stdout}\nstderr: {stderr}");
    assert!(output.status.success());
    let ips: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("instructions_per_sample: "))
        .and_then(|n| n.parse().ok())
        .expect("an instructions_per_sample line");
    (stderr, ips)
}

/// Issue 5's budget, 1,200 instructions per sample at 500 Hz for the whole pipeline with
/// its frame encoding, holds at the device's default telemetry rate (100 Hz: every 5th
/// sample); a frame for every sample (the replay default) costs about 300 more
/// (BENCHMARKS.md).
#[test]
fn the_pipeline_fits_1200_instructions_per_sample_at_the_default_telemetry_rate() {
    use supine_core::blob::TelemetryConfig;
    firmware(supine_host::firmware::PRODUCT_BINARY);
    let decimation = TelemetryConfig::default_for(500.0).decimation;
    assert_eq!(decimation, 5, "100 Hz at 500 Hz");
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 4.0);
    let out = dir.path().join("device.csv");
    let (_, ips) = replay_with_icount(
        &["--preset", "paper-litter", "--telemetry-decimation", "5"],
        &ride,
        &out,
    );
    assert!(
        ips > 500.0 && ips <= 1200.0,
        "{ips} instructions per sample"
    );
    let csv = std::fs::read_to_string(&out).expect("telemetry written");
    assert_eq!(csv.lines().count(), 1 + 400, "one record per 5 samples");
}

#[test]
fn supine_replay_writes_telemetry_and_events_and_counts_instructions() {
    firmware(supine_host::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 4.0);
    let out = dir.path().join("device.csv");
    let (stderr, ips) = replay_with_icount(&["--preset", "paper-litter"], &ride, &out);
    assert!(ips > 500.0 && ips < 5000.0, "{ips}");
    assert!(stderr.contains("replayed 2000 samples"), "{stderr}");
    assert!(stderr.contains("frames lost 0, bad 0"), "{stderr}");
    let csv = std::fs::read_to_string(&out).expect("telemetry written");
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(supine_host::replay::TELEMETRY_HEADER));
    assert_eq!(lines.count(), 2000);
    let events = std::fs::read_to_string(dir.path().join("device.events.csv")).expect("events");
    assert!(events.starts_with(supine_host::replay::EVENTS_HEADER));
}

#[test]
fn ctrl_c_during_replay_leaves_no_qemu_and_no_socket_folder() {
    firmware(supine_host::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 120.0);
    let child = Command::new(supine_binary())
        .args(["replay", "--qemu", "--preset", "paper-litter", "--input"])
        .arg(&ride)
        .arg("--out")
        .arg(dir.path().join("device.csv"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("supine runs");
    // Wait until QEMU runs under it, then a little longer so samples are streaming.
    let start = Instant::now();
    let (qemu_pid, cmdline) = loop {
        if let Some(found) = child_pids(child.id())
            .into_iter()
            .find_map(|p| qemu_cmdline(p).map(|c| (p, c)))
        {
            break found;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no QEMU started"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    std::thread::sleep(Duration::from_secs(2));
    let socket_dir = cmdline
        .split(['=', ','])
        .find(|p| p.ends_with("uart.sock"))
        .map(|p| {
            PathBuf::from(p)
                .parent()
                .expect("socket in a folder")
                .to_path_buf()
        })
        .expect("QEMU's UART socket path");
    assert!(socket_dir.exists());
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    let output = child.wait_with_output().expect("supine exits");
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stderr}");
    assert!(!output.status.success(), "an interrupted replay must fail");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(
        !Path::new(&format!("/proc/{qemu_pid}")).exists() || qemu_cmdline(qemu_pid).is_none(),
        "QEMU {qemu_pid} still running"
    );
    assert!(!socket_dir.exists(), "{} left behind", socket_dir.display());
    assert!(!dir.path().join("device.csv").exists(), "no partial output");
}
