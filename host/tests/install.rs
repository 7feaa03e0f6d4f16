//! The installed tool needs no source tree and no cargo: its binary alone in a temporary
//! install root (`ROOT/bin/supine`, what `cargo install --path host --root ROOT` puts
//! there) runs `supine demo` from an empty folder with `PATH` reduced to that root and the
//! system (`qemu-system-arm` in `/usr/bin`), with no `SUPINE_*` or `CARGO*` variable set.
//!
//! The first test copies this build's binary into the root (the same file `cargo install`
//! copies); the second runs `cargo install` itself, with `--debug` into this build's own
//! target folder, so that it reuses the suite's build instead of a release build from
//! scratch (3.5 minutes): the README's `cargo install --path host --locked` is the same
//! command in release. It checks that it compiled nothing but the tool itself.

use std::os::unix::fs::PermissionsExt as _;
use std::path::Path;
use std::process::Command;
use std::sync::Mutex;

/// Held by each test for its whole run: `cargo install` may relink this build's
/// `supine` while the other test copies it.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// A stand-in `cargo` first on the `PATH`: if the tool ran cargo, the marker would exist.
fn trap_cargo(bin: &Path, marker: &Path) {
    let script = bin.join("cargo");
    std::fs::write(
        &script,
        format!("#!/bin/sh\ntouch '{}'\nexit 1\n", marker.display()),
    )
    .expect("write the cargo trap");
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).expect("chmod");
}

#[test]
fn the_installed_binary_runs_the_demo_from_an_empty_folder_without_the_source_tree() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let root = tempfile::tempdir().expect("install root");
    let bin = root.path().join("bin");
    std::fs::create_dir(&bin).expect("mkdir bin");
    std::fs::copy(env!("CARGO_BIN_EXE_supine"), bin.join("supine")).expect("install the binary");
    demo_runs_from_an_empty_folder(root.path());
}

#[test]
fn cargo_install_into_a_temporary_root_gives_a_tool_that_runs_the_demo() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let root = tempfile::tempdir().expect("install root");
    let host = Path::new(env!("CARGO_MANIFEST_DIR"));
    // This test binary is TARGET/debug/deps/install-HASH.
    let exe = std::env::current_exe().expect("the test's path");
    let target = exe
        .ancestors()
        .nth(3)
        .expect("the test runs from TARGET/debug/deps");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let output = Command::new(cargo)
        .args(["install", "--locked", "--offline", "--debug", "--path"])
        .arg(host)
        .arg("--root")
        .arg(root.path())
        .arg("--target-dir")
        .arg(target)
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .expect("cargo runs");
    let log = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "cargo install failed:\n{log}");
    // The tool's dependencies are the test build's, features and all (host/Cargo.toml
    // declares the features the dev-dependencies add): a crate compiled again here is a
    // feature that differs, and costs CI a second build of everything above it.
    let compiled_again: Vec<&str> = log
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("Compiling "))
        .filter(|krate| !krate.starts_with("supine-host "))
        .collect();
    assert!(
        compiled_again.is_empty(),
        "cargo install compiled again: {compiled_again:?}"
    );
    demo_runs_from_an_empty_folder(root.path());
}

/// Runs `command`, whose program was just written. Another test of this binary that
/// starts a child while the program's file is still open for writing hands that child a
/// copy of the descriptor until the child's own exec closes it; an exec meanwhile fails
/// with "text file busy" (ETXTBSY), so that one error is retried, for a second at most.
fn run_fresh_executable(command: &mut Command) -> std::process::Output {
    let mut tries = 0;
    loop {
        match command.output() {
            Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy && tries < 100 => {
                tries += 1;
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            result => return result.expect("supine runs"),
        }
    }
}

/// Runs `ROOT/bin/supine demo` from an empty folder as described above and checks what it
/// wrote.
fn demo_runs_from_an_empty_folder(root: &Path) {
    let bin = root.join("bin");
    let supine = bin.join("supine");
    let marker = root.join("cargo-was-run");
    trap_cargo(&bin, &marker);
    let work = tempfile::tempdir().expect("empty folder");
    let home = tempfile::tempdir().expect("home");

    let mut demo = Command::new(&supine);
    demo.args(["demo", "--duration-s", "10", "--out", "out"])
        .current_dir(work.path())
        .env_clear()
        .env("PATH", format!("{}:/usr/bin:/bin", bin.display()))
        .env("HOME", home.path());
    let output = run_fresh_executable(&mut demo);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "stdout:\n{stdout}\nstderr:\n{stderr}"
    );
    assert!(!marker.exists(), "the tool ran cargo");
    assert!(
        stdout.contains("the device image built into supine"),
        "{stdout}"
    );

    // The device ran the whole ride: one telemetry record per sample (10 s at 500 Hz),
    // numbered 0 to 4999, and the report names the CSV files it was made from.
    let out = work.path().join("out");
    let telemetry = std::fs::read_to_string(out.join("device.csv")).expect("device.csv");
    let samples: Vec<u64> = telemetry
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .next()
                .and_then(|c| c.parse().ok())
                .expect("sample")
        })
        .collect();
    assert_eq!(samples, (0..5000).collect::<Vec<u64>>());
    let ride_rows = std::fs::read_to_string(out.join("ride.csv"))
        .expect("ride.csv")
        .lines()
        .count();
    assert_eq!(ride_rows, 5001, "header and 5000 samples");
    let html = std::fs::read_to_string(out.join("report.html")).expect("report.html");
    assert!(html.contains("device.csv"), "the report names its data");
    assert!(stdout.contains("report: out/report.html"), "{stdout}");
}
