//! `supine demo` as a user runs it: the binary, its report and the CSV files the report
//! was made from; the summary's numbers checked against those files.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use supine_host::schema::names;
use supine_qemu_tests::{
    firmware, qemu_cmdline, signal_and_wait, supine_binary, wait_for_qemu_child,
};

/// The number after `prefix` on the summary line that contains it.
fn number_after(text: &str, prefix: &str) -> f64 {
    let at = text
        .find(prefix)
        .unwrap_or_else(|| panic!("no \"{prefix}\" in:\n{text}"));
    text[at + prefix.len()..]
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after \"{prefix}\""))
}

fn word_after<'a>(text: &'a str, prefix: &str) -> &'a str {
    let at = text
        .find(prefix)
        .unwrap_or_else(|| panic!("no \"{prefix}\" in:\n{text}"));
    text[at + prefix.len()..]
        .split(|c: char| !c.is_ascii_alphabetic())
        .next()
        .unwrap_or("")
}

/// `supine demo ARGS --out OUT`, run to its end.
fn demo(args: &[&str], out: &Path) -> Output {
    Command::new(supine_binary())
        .arg("demo")
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .expect("supine runs")
}

const LEVELS: [&str; 4] = ["normal", "advisory", "warning", "alarm"];

#[test]
fn supine_demo_writes_a_self_contained_report_whose_summary_matches_its_csv_files() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("demo");
    let output = demo(&["--duration-s", "30"], &out);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(output.status.success());
    for step in 1..=7 {
        assert!(
            stdout.contains(&format!("[{step}/7] ")),
            "step {step} announced"
        );
    }
    let report_path = out.join("report.html");
    assert!(stdout.contains(&format!("report: {}", report_path.display())));

    // The report: one file, no script, nothing fetched from elsewhere, inline SVG.
    let html = std::fs::read_to_string(&report_path).expect("report.html written");
    let lower = html.to_lowercase();
    assert!(lower.starts_with("<!doctype html>"));
    assert!(!lower.contains("<script"), "a script in the report");
    for attr in ["src=\"", "href=\"", "src='", "href='", "url("] {
        for (at, _) in lower.match_indices(attr) {
            let target = &lower[at + attr.len()..(at + attr.len() + 12).min(lower.len())];
            assert!(
                !target.starts_with("http:")
                    && !target.starts_with("https:")
                    && !target.starts_with("//"),
                "external reference {attr}{target}"
            );
        }
    }
    assert!(
        !lower.contains("@import") && !lower.contains("<link"),
        "external style"
    );
    assert!(html.matches("<svg").count() >= 8, "the report's charts");
    assert!(html.len() < 2_000_000, "{} bytes", html.len());
    assert!(html.contains("recumbent"), "the standard's caveat");

    // The CSV files the report was made from.
    let telemetry = std::fs::read_to_string(out.join("device.csv")).expect("device.csv");
    let mut lines = telemetry.lines();
    // The demo's parameters read all ten joint outputs (the default): their columns follow.
    let header = supine_host::io::telemetry_csv::telemetry_header(0b11_1111_1111);
    assert_eq!(lines.next(), Some(header.as_str()));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 15_000, "one record per sample at 500 Hz");
    let cell = |r: &Vec<&str>, i: usize| -> f64 { r[i].parse().expect("a number") };
    let mtvv = rows
        .iter()
        .filter(|r| r[12] == "1")
        .map(|r| cell(r, 8))
        .fold(0.0, f64::max);
    let vdv = cell(rows.last().expect("rows"), 9);
    let highest = rows
        .iter()
        .map(|r| {
            LEVELS
                .iter()
                .position(|l| *l == r[10])
                .expect("a level name")
        })
        .max()
        .expect("rows");
    let final_level = rows.last().expect("rows")[10];
    let events = std::fs::read_to_string(out.join("device.events.csv")).expect("events");
    let host_events = std::fs::read_to_string(out.join("host.events.csv")).expect("host events");
    assert_eq!(events, host_events, "the device's alerts are the host's");
    let ride = std::fs::read_to_string(out.join("ride.csv")).expect("ride.csv");
    assert_eq!(ride.lines().count(), 15_001);

    // The summary says what the files say.
    let s = stdout.as_ref();
    let said_mtvv = number_after(s, "device, from its telemetry: MTVV ");
    let said_vdv = number_after(s, "m/s^2, VDV ");
    assert!(
        (said_mtvv - mtvv).abs() <= 5.1e-5,
        "MTVV {said_mtvv} vs {mtvv} in device.csv"
    );
    assert!(
        (said_vdv - vdv).abs() <= 5.1e-5,
        "VDV {said_vdv} vs {vdv} in device.csv"
    );
    assert_eq!(word_after(s, "highest alert level: "), LEVELS[highest]);
    assert_eq!(word_after(s, "; at the end: "), final_level);
    assert_eq!(
        number_after(s, "; device: ") as usize,
        rows.len(),
        "samples processed"
    );
    assert_eq!(number_after(s, "received, "), 0.0, "frames lost");
    // The default ride's story: an alert is raised on the rough road and cleared after it.
    assert!(highest >= 2, "the rough road warns");
    assert_eq!(final_level, "normal");
    let first_raise: f64 = events
        .lines()
        .nth(1)
        .and_then(|l| l.split(',').nth(1))
        .and_then(|t| t.parse().ok())
        .expect("an event");
    assert!(
        (6.0..18.0).contains(&first_raise),
        "raised on the rough road at {first_raise} s"
    );
    // The host's exposure table: the vector MTVV and VDV equal the device's.
    let vector = s
        .lines()
        .find(|l| l.trim_start().starts_with("vector sum"))
        .expect("vector row");
    let v: Vec<f64> = vector
        .split_whitespace()
        .skip(2)
        .map(|x| x.parse().expect("number"))
        .collect();
    assert!(
        (v[1] - said_mtvv).abs() < 2e-4 * said_mtvv.max(1.0),
        "{vector}"
    );
    assert!(
        (v[2] - said_vdv).abs() < 2e-4 * said_vdv.max(1.0),
        "{vector}"
    );
    assert!(
        s.contains("head max |diff| 0 (bit for bit)"),
        "device and host differ"
    );
    // `supine replay` of the demo's ride.csv (a platform-only ride file) is the same run:
    // the same telemetry and events, byte for byte.
    let replayed = dir.path().join("replay.csv");
    let output = Command::new(supine_binary())
        .args(["replay", "--qemu", "--preset", "paper-litter", "--input"])
        .arg(out.join("ride.csv"))
        .arg("--out")
        .arg(&replayed)
        .output()
        .expect("supine runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        std::fs::read_to_string(&replayed).expect("replay.csv") == telemetry,
        "replay differs from the demo"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("replay.events.csv")).expect("events"),
        events
    );
    // Nothing left half-written.
    // The demo undoes what an interrupted run added: the folder it made is gone, or (had it
    // been there before) holds no device file.
    let Ok(entries) = std::fs::read_dir(&out) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        assert!(!name.contains("partial"), "{name} left behind");
    }
}

/// `demo --json` and every CSV file the demo writes follow the output vocabulary, as
/// `host/tests/output_names.rs` holds every command that runs without QEMU to it.
#[test]
fn the_demos_json_and_files_follow_the_naming_rules() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("demo");
    let output = demo(&["--duration-s", "10", "--json"], &out);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    // The steps go to stderr; stdout is the one JSON object.
    assert!(stderr.contains("[1/7] "), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_slice(&output.stdout).expect("stdout is one JSON object");
    assert!(json.get("report").is_some(), "{json}");
    let mut problems = names::json_problems(&json, "demo --json");
    let mut csv_files = 0;
    for entry in std::fs::read_dir(&out)
        .expect("the demo's folder")
        .flatten()
    {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "csv") {
            let text = std::fs::read_to_string(&path).expect("a CSV file");
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            problems.extend(names::csv_problems(&text, &name));
            csv_files += 1;
        }
    }
    assert!(csv_files >= 3, "{csv_files} CSV files");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn a_bad_duration_is_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("demo");
    let output = demo(&["--duration-s", "2"], &out);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--duration-s 2"), "{stderr}");
    assert!(!out.join("report.html").exists());
}

#[test]
fn ctrl_c_during_the_demo_leaves_no_qemu_and_no_report() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("demo");
    let child = Command::new(supine_binary())
        .args(["demo", "--duration-s", "600", "--out"])
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("supine runs");
    let (qemu, _) = wait_for_qemu_child(child.id());
    std::thread::sleep(Duration::from_secs(2));
    let output = signal_and_wait(child, "INT");
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stderr}");
    assert!(!output.status.success(), "an interrupted demo must fail");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(qemu_cmdline(qemu).is_none(), "QEMU {qemu} still running");
    assert!(
        !out.join("report.html").exists(),
        "no report from an interrupted run"
    );
    // The demo undoes what an interrupted run added: the folder it made is gone, or (had it
    // been there before) holds no device file.
    let Ok(entries) = std::fs::read_dir(&out) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with("device"), "{name} left behind");
    }
}
