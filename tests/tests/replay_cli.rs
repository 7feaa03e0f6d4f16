//! `supine replay` as a user runs it: the binary, its CSV files, its instruction count,
//! and no QEMU process and no socket folder left behind: after a finished run, a failed
//! one, and Ctrl-C, SIGTERM or SIGHUP.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use supine_host::io::recording::Recording;
use supine_host::schema::names;
use supine_qemu_tests::{
    MONITOR_STACK_CEILING_BYTES, entries, firmware, qemu_cmdline, qemu_processes_mentioning,
    qemu_wrapper, signal_and_wait, supine_binary, wait_for_qemu_child,
};

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
/// printed (and checks that it printed the device's stack high-water mark beside it).
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
    let stack: u32 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("stack_used_bytes: "))
        .and_then(|n| n.parse().ok())
        .expect("a stack_used_bytes line");
    // Something was measured, and no more than the monitor's share of its RAM budget.
    assert!(
        stack > 0 && stack <= MONITOR_STACK_CEILING_BYTES,
        "stack_used_bytes {stack}"
    );
    (stderr, ips)
}

/// Issue 5's budget, 1,200 instructions per sample at 500 Hz for the whole pipeline with
/// its frame encoding, holds at the device's default telemetry rate (100 Hz: every 5th
/// sample); a frame for every sample (the replay default) costs about 300 more
/// (BENCHMARKS.md).
#[test]
fn the_pipeline_fits_1200_instructions_per_sample_at_the_default_telemetry_rate() {
    use supine_core::blob::TelemetryConfig;
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
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
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 4.0);
    let out = dir.path().join("device.csv");
    let (stderr, ips) = replay_with_icount(&["--preset", "paper-litter"], &ride, &out);
    assert!(ips > 500.0 && ips < 5000.0, "{ips}");
    assert!(stderr.contains("replayed 2000 samples"), "{stderr}");
    assert!(stderr.contains("frames lost 0, bad 0"), "{stderr}");
    // The patient as the device's status reports it: the preset's mean subject.
    assert!(stderr.contains("for a patient 1.82 m, 81 kg"), "{stderr}");
    let csv = std::fs::read_to_string(&out).expect("telemetry written");
    let mut lines = csv.lines();
    // The preset's blob reads all ten joint outputs (the default): their columns follow.
    let header = supine_host::io::telemetry_csv::telemetry_header(0b11_1111_1111);
    assert_eq!(lines.next(), Some(header.as_str()));
    assert_eq!(lines.count(), 2000);
    let events = std::fs::read_to_string(dir.path().join("device.events.csv")).expect("events");
    assert!(events.starts_with(supine_host::io::telemetry_csv::EVENTS_HEADER));
}

/// `supine predict` of a ride writes, row for row and byte for byte, the telemetry and the
/// events the firmware writes of the same ride in QEMU: the host's prediction of a ride
/// is the device's own f32 computation, not an approximation of it.
#[test]
fn predict_of_a_ride_writes_the_devices_telemetry_and_events_bit_for_bit() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = dir.path().join("rough.csv");
    let run = |args: &[&str]| {
        let output = Command::new(supine_binary())
            .args(args)
            .output()
            .expect("supine runs");
        assert!(
            output.status.success(),
            "supine {args:?}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
    };
    let path = |p: &Path| p.to_str().expect("utf-8 path").to_string();
    run(&[
        "ride",
        "--profile",
        "rough-road",
        "--duration-s",
        "8",
        "--seed",
        "3",
        "--out",
        &path(&ride),
    ]);
    let device = dir.path().join("device.csv");
    let host = dir.path().join("host.csv");
    run(&[
        "replay",
        "--qemu",
        "--preset",
        "paper-litter",
        "--input",
        &path(&ride),
        "--out",
        &path(&device),
    ]);
    run(&[
        "predict",
        "--preset",
        "paper-litter",
        "--input",
        &path(&ride),
        "--out",
        &path(&host),
    ]);
    let read = |p: PathBuf| std::fs::read_to_string(&p).expect("written");
    let (device_rows, host_rows) = (read(device), read(host));
    assert_eq!(host_rows.lines().count(), 1 + 4000, "every sample");
    assert_eq!(host_rows, device_rows);
    let (device_events, host_events) = (
        read(dir.path().join("device.events.csv")),
        read(dir.path().join("host.events.csv")),
    );
    assert!(
        host_events.lines().count() > 1,
        "the rough road raises an alert"
    );
    assert_eq!(host_events, device_events);
}

/// `supine replay --qemu --preset paper-litter --input RIDE --out DIR/device.csv` with its
/// own TMPDIR (where QEMU's socket folder goes), so that leftovers can be listed.
fn replay_command(dir: &Path, ride: &Path, tmp: &Path) -> Command {
    std::fs::create_dir_all(tmp).expect("private TMPDIR");
    let mut cmd = Command::new(supine_binary());
    cmd.args(["replay", "--qemu", "--preset", "paper-litter", "--input"])
        .arg(ride)
        .arg("--out")
        .arg(dir.join("device.csv"))
        .env("TMPDIR", tmp);
    cmd
}

/// Nothing of a finished `supine` run is left: no QEMU, no socket folder.
fn assert_nothing_left(tmp: &Path, what: &str) {
    assert_eq!(
        qemu_processes_mentioning(tmp),
        Vec::<u32>::new(),
        "{what}: QEMU still running"
    );
    assert_eq!(entries(tmp), Vec::<String>::new(), "{what}: left in TMPDIR");
}

#[test]
fn ctrl_c_sigterm_and_sighup_during_replay_leave_no_qemu_and_no_socket_folder() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 120.0);
    for signal in ["INT", "TERM", "HUP"] {
        let tmp = dir.path().join(format!("tmp-{signal}"));
        let child = replay_command(dir.path(), &ride, &tmp)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("supine runs");
        // Wait until QEMU runs under it, then a little longer so samples are streaming.
        let (qemu_pid, cmdline) = wait_for_qemu_child(child.id());
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
        assert!(socket_dir.starts_with(&tmp), "{}", socket_dir.display());
        assert!(socket_dir.exists());
        let output = signal_and_wait(child, signal);
        let stderr = String::from_utf8_lossy(&output.stderr);
        println!("SIG{signal}: {stderr}");
        assert!(
            !output.status.success(),
            "SIG{signal}: an interrupted replay must fail"
        );
        // How far the device had got, of the ride's 60,000 samples: some, not all.
        let done: u64 = stderr
            .split("interrupted after ")
            .nth(1)
            .and_then(|rest| rest.strip_suffix(" of 60000 samples\n"))
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| {
                panic!("SIG{signal}: no \"interrupted after N of 60000 samples\": {stderr}")
            });
        assert!(done > 0 && done < 60_000, "SIG{signal}: {done}");
        assert!(
            !Path::new(&format!("/proc/{qemu_pid}")).exists() || qemu_cmdline(qemu_pid).is_none(),
            "SIG{signal}: QEMU {qemu_pid} still running"
        );
        assert!(!socket_dir.exists(), "{} left behind", socket_dir.display());
        assert_nothing_left(&tmp, &format!("SIG{signal}"));
        assert!(!dir.path().join("device.csv").exists(), "no partial output");
    }
}

#[test]
fn a_finished_replay_leaves_no_qemu_and_no_socket_folder() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 2.0);
    let tmp = dir.path().join("tmp");
    let output = replay_command(dir.path(), &ride, &tmp)
        .output()
        .expect("supine runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("replayed 1000 samples"), "{stderr}");
    assert_nothing_left(&tmp, "a finished replay");

    // --json: one object on stdout, its counts those of the files written.
    let output = replay_command(dir.path(), &ride, &tmp)
        .args(["--json", "--telemetry-decimation", "5"])
        .output()
        .expect("supine runs");
    assert!(output.status.success());
    let report: serde_json::Value =
        serde_json::from_slice(&output.stdout).expect("one JSON object");
    let rows = std::fs::read_to_string(dir.path().join("device.csv"))
        .expect("device.csv")
        .lines()
        .count()
        - 1;
    assert_eq!(report["samples"], 1000);
    assert_eq!(report["sample_rate_hz"], 500.0);
    assert_eq!(report["ride_duration_s"], 2.0);
    assert_eq!(report["telemetry_records"], rows as u64);
    assert_eq!(rows, 200, "every 5th of 1,000 samples");
    let elapsed_s = report["elapsed_s"].as_f64().expect("elapsed_s");
    let factor = report["real_time_factor"]
        .as_f64()
        .expect("real_time_factor");
    assert!((factor * elapsed_s - 2.0).abs() < 1e-9, "{report}");
    assert_nothing_left(&tmp, "a finished replay with --json");
    // Its names, and the telemetry CSV's, follow the output vocabulary.
    let mut problems = names::json_problems(&report, "replay");
    let telemetry = std::fs::read_to_string(dir.path().join("device.csv")).expect("device.csv");
    problems.extend(names::csv_problems(&telemetry, "device.csv"));
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn a_replay_whose_qemu_dies_midway_fails_on_one_line_and_leaves_nothing() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 120.0);
    let tmp = dir.path().join("tmp");
    // The device "loses power" 3 s in: QEMU killed under the running replay.
    let qemu = qemu_wrapper(
        dir.path(),
        "dying-qemu",
        "exec timeout -s KILL 3 qemu-system-arm \"$@\"",
    );
    let output = replay_command(dir.path(), &ride, &tmp)
        .env(supine_host::device::qemu::QEMU_ENV, &qemu)
        .output()
        .expect("supine runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stderr}");
    assert!(!output.status.success(), "a replay cut short must fail");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("supine: QEMU exited during the run (signal: 9 (SIGKILL))"),
        "{stderr}"
    );
    assert_nothing_left(&tmp, "a replay whose QEMU died");
    assert!(!dir.path().join("device.csv").exists(), "no partial output");
}

#[test]
fn a_bad_row_midway_in_the_ride_is_named_and_leaves_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 2.0);
    let text = std::fs::read_to_string(&ride).expect("ride");
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    lines[500] = lines[500].replacen(',', ",oops", 1);
    std::fs::write(&ride, lines.join("\n")).expect("damaged ride");
    let tmp = dir.path().join("tmp");
    let output = replay_command(dir.path(), &ride, &tmp)
        .output()
        .expect("supine runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(&format!("{}: line 501", ride.display())),
        "{stderr}"
    );
    assert_nothing_left(&tmp, "a refused ride");
    assert!(!dir.path().join("device.csv").exists(), "no partial output");
}

/// Issue 17, D2: `kill -9` (or an out-of-memory kill) runs no destructor, yet QEMU must not
/// outlive `supine`, and the folders it leaves are swept by the next run.
#[test]
fn sigkill_of_replay_takes_qemu_with_it_and_the_next_run_sweeps_its_folders() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = write_ride(dir.path(), 60.0);
    let tmp = dir.path().join("tmp-KILL");
    let child = replay_command(dir.path(), &ride, &tmp)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("supine runs");
    let (qemu_pid, _) = wait_for_qemu_child(child.id());
    std::thread::sleep(Duration::from_secs(2));
    let output = signal_and_wait(child, "KILL");
    assert!(!output.status.success());
    // The kernel delivers QEMU's parent-death signal at once; allow it a moment to exit.
    let start = std::time::Instant::now();
    while qemu_cmdline(qemu_pid).is_some() && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(
        qemu_cmdline(qemu_pid).is_none(),
        "QEMU {qemu_pid} outlived supine"
    );
    let left = entries(&tmp);
    assert!(
        !left.is_empty() && left.iter().all(|n| n.starts_with("supine-")),
        "a killed run leaves its folders (no destructor ran): {left:?}"
    );
    // The next run, in the same TMPDIR, removes them and then cleans up after itself.
    let short = write_ride(dir.path(), 2.0);
    let status = replay_command(dir.path(), &short, &tmp)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .expect("supine runs");
    assert!(status.success());
    assert_nothing_left(&tmp, "the run after a SIGKILL");
}
