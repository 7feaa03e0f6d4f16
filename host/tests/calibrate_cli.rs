//! `supine calibrate` as a user runs it: its table loads as a parameter file's
//! `[device.mounting]` and equals the core's calibration; bad readings fail in one line.

use std::process::Command;

use supine_core::mounting::Mounting;
use supine_host::io::params_file::DeviceSection;

fn calibrate(reading: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["calibrate", "--at-rest-m-s2", reading])
        .output()
        .expect("supine runs")
}

#[derive(serde::Deserialize)]
struct Table {
    device: DeviceSection,
}

#[test]
fn the_printed_table_is_the_calibration_a_parameter_file_reads() {
    let out = calibrate("0.5,-4.9,8.47");
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.contains("[device.mounting]"), "{text}");
    let table: Table = toml::from_str(&text).expect("a [device] table");
    let expected = Mounting::from_rest([0.5, -4.9, 8.47]).expect("valid");
    assert_eq!(table.device.mounting, expected);
}

#[test]
fn a_reading_that_is_not_gravity_at_rest_fails_in_one_line() {
    for (reading, says) in [
        ("0,0,3", "gravity at rest must read 7-12 m/s^2"),
        ("9.7,0.5,0.5", "too close to vertical"),
        ("0,9.8", "expected three numbers X,Y,Z, found 2"),
    ] {
        let out = calibrate(reading);
        assert_eq!(out.status.code(), Some(1), "{reading}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(says), "{reading}: {stderr}");
    }
}

#[test]
fn a_level_reading_prints_exact_zeros_and_lists_may_have_spaces() {
    // Separate shell words with spaces after the commas, as a user types them.
    let out = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["calibrate", "--at-rest-m-s2", "0.12,", "-0.05,", "9.80"])
        .output()
        .expect("supine runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("utf-8");
    // Round-off such as -0.00000000000000000086736174 is printed as 0.
    assert!(!text.contains("0000000000"), "{text}");
    let table: Table = toml::from_str(&text).expect("a [device] table");
    let expected = Mounting::from_rest([0.12, -0.05, 9.80]).expect("valid");
    for (row, want) in table
        .device
        .mounting
        .sensor_to_litter
        .iter()
        .zip(expected.sensor_to_litter)
    {
        for (got, want) in row.iter().zip(want) {
            assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        }
    }
    let out = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["calibrate", "--at-rest-m-s2", "0,0,9.81", "--json"])
        .output()
        .expect("supine runs");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(json["mounting"]["sensor_to_litter"][0][1], 0.0);
    assert_eq!(json["mounting"]["sensor_to_litter"][2][2], 1.0);
    assert_eq!(json["at_rest_m_s2"][2], 9.81);
}
