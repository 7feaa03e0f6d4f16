//! `supine monitor`'s refusals of incomplete or bad arguments: one line, non-zero exit,
//! before any QEMU or serial port is touched.

use std::process::Command;

fn refusal(args: &[&str]) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_supine"))
        .arg("monitor")
        .args(args)
        .output()
        .expect("supine runs");
    assert!(!output.status.success(), "{args:?} must fail");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.stdout.is_empty(), "{args:?}");
    stderr
}

#[test]
fn qemu_needs_parameters_and_a_ride() {
    assert_eq!(
        refusal(&["--qemu", "--profile", "lab"]),
        "supine: --qemu needs --preset NAME or --params FILE\n"
    );
    assert_eq!(
        refusal(&["--qemu", "--preset", "paper-litter"]),
        "supine: --qemu needs a ride: --input RIDE.csv or --profile NAME\n"
    );
}

#[test]
fn a_missing_ride_file_and_a_bad_duration_name_what_is_wrong() {
    let err = refusal(&[
        "--qemu",
        "--preset",
        "paper-litter",
        "--input",
        "/nonexistent/ride.csv",
    ]);
    assert!(
        err.starts_with("supine: /nonexistent/ride.csv: cannot read"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    let err = refusal(&[
        "--qemu",
        "--preset",
        "paper-litter",
        "--profile",
        "lab",
        "--duration-s",
        "0.01",
    ]);
    assert!(
        err.starts_with("supine: --duration-s 0.01: expected at least"),
        "{err}"
    );
}

#[test]
fn a_missing_port_and_conflicting_targets_are_refused() {
    let err = refusal(&["--serial", "/nonexistent/ttyUSB9"]);
    assert!(
        err.starts_with("supine: cannot open serial port /nonexistent/ttyUSB9"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    // clap's usage errors for a missing or doubled target.
    assert!(refusal(&[]).contains("--serial <PORT>|--qemu"));
    assert!(refusal(&["--qemu", "--serial", "/dev/null"]).contains("cannot be used with"));
    assert!(
        refusal(&["--serial", "/dev/null", "--preset", "paper-litter"])
            .contains("cannot be used with")
    );
}

#[test]
fn an_unwritable_log_is_refused_before_connecting() {
    let err = refusal(&[
        "--serial",
        "/nonexistent/ttyUSB9",
        "--log",
        "/nonexistent-dir/log.csv",
    ]);
    assert_eq!(
        err,
        "supine: /nonexistent-dir/log.csv.partial: cannot create: No such file or directory (os error 2)\n"
    );
}

/// `Duration::from_secs_f64` panics on huge, negative or NaN seconds: the timeouts of
/// `monitor` and `flash` are refused by clap first, naming the flag and the range.
#[test]
fn timeouts_out_of_range_are_refused_by_name_without_a_panic() {
    for (command, flag) in [
        (&["monitor", "--serial", "/dev/null"][..], "--timeout-s"),
        (
            &[
                "flash",
                "--preset",
                "paper-rigid",
                "--qemu-image",
                "/nonexistent/p.bin",
            ],
            "--timeout-s",
        ),
    ] {
        for bad in ["1e30", "NaN", "inf", "0", "86401"] {
            let output = Command::new(env!("CARGO_BIN_EXE_supine"))
                .args(command)
                .arg(format!("{flag}={bad}"))
                .output()
                .expect("supine runs");
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(2), "{flag}={bad}: {stderr}");
            assert!(!stderr.contains("panicked"), "{stderr}");
            assert!(
                stderr.contains(&format!("invalid value '{bad}' for '{flag} <"))
                    && stderr.contains("expected seconds above 0 and at most 86400 (one day)"),
                "{flag}={bad}: {stderr}"
            );
        }
    }
}
