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
