//! `supine flash --serial` against the real firmware: the test bridges a pseudo-terminal
//! to QEMU's UART, so the binary opens a serial port (the pty's slave) and talks to the
//! monitor image through it, as it would to a board on a USB serial adapter.

use std::fs::File;
use std::io::{Read, Write};
use std::process::Command;
use std::thread;
use std::time::Duration;

use nix::pty::openpty;
use nix::sys::termios::{SetArg, cfmakeraw, tcgetattr, tcsetattr};
use supine_core::model::Preset;
use supine_host::device::device_params::{identity, identity_hex};
use supine_host::device::firmware::{PRODUCT_BINARY, build_binary};
use supine_host::device::flash::{device_blob, qemu_region_image};
use supine_host::device::qemu::{Qemu, QemuConfig};
use supine_host::io::params_file::ParamFile;

/// Copies bytes from `from` to `to` until either side ends.
fn pump(mut from: impl Read + Send + 'static, mut to: impl Write + Send + 'static) {
    thread::spawn(move || {
        let mut buf = [0u8; 512];
        while let Ok(n) = from.read(&mut buf) {
            if n == 0 || to.write_all(&buf[..n]).is_err() {
                return;
            }
        }
    });
}

/// `supine flash --serial PORT` with `--counter N` if given, else the default counter
/// (state kept in `state_dir`).
fn flash_with(
    port: &str,
    preset: &str,
    counter: Option<u32>,
    state_dir: &std::path::Path,
) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_supine"));
    cmd.args(["flash", "--preset", preset, "--serial", port])
        .args(["--timeout-s", "20"])
        .env(supine_host::device::flash::STATE_DIR_ENV, state_dir);
    if let Some(counter) = counter {
        cmd.arg("--counter").arg(counter.to_string());
    }
    let out = cmd.output().expect("supine runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    println!("stdout: {stdout}stderr: {stderr}");
    (out.status.success(), stdout, stderr)
}

#[test]
fn supine_flash_serial_uploads_to_the_firmware_and_names_a_refusal_code() {
    let kernel = build_binary(PRODUCT_BINARY).unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile::tempdir().expect("temp dir");
    let region = dir.path().join("params.bin");
    let litter = ParamFile::preset(Preset::PaperLitter);
    let (_, blob) = device_blob(&litter, 500.0).expect("blob");
    std::fs::write(&region, qemu_region_image(&blob).expect("image")).expect("write");
    let mut qemu = Qemu::start(
        &QemuConfig::new(kernel)
            .uart()
            .params_blob(&region)
            .timeout(Duration::from_secs(120)),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let uart = qemu.uart().expect("a UART");

    let pty = openpty(None, None).expect("openpty");
    // Raw from the start: no echo or line editing of the device's bytes before the
    // binary opens the port.
    let mut termios = tcgetattr(&pty.slave).expect("tcgetattr");
    cfmakeraw(&mut termios);
    tcsetattr(&pty.slave, SetArg::TCSANOW, &termios).expect("tcsetattr");
    let port = nix::unistd::ttyname(&pty.slave)
        .expect("slave name")
        .to_string_lossy()
        .into_owned();
    let master = File::from(pty.master);
    pump(
        uart.try_clone().expect("clone"),
        master.try_clone().expect("clone"),
    );
    pump(master, uart.try_clone().expect("clone"));

    let state_dir = dir.path().join("state");
    let flash = |port: &str, preset: &str, counter: u32| {
        flash_with(port, preset, Some(counter), &state_dir)
    };
    let rigid_hex = identity_hex(&identity(&ParamFile::preset(Preset::PaperRigid)).expect("id"));
    let (ok, stdout, stderr) = flash(&port, "paper-rigid", 1_000);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!(
            "parameters {rigid_hex} committed to slot 1 and running"
        )),
        "{stdout}"
    );

    // The same counter again is a replay: refused with its code, on one line (after the
    // notice that the public development key signs it).
    let (ok, _, stderr) = flash(&port, "paper-litter", 1_000);
    assert!(!ok);
    let lines: Vec<&str> = stderr.trim().lines().collect();
    assert_eq!(lines.len(), 2, "{stderr}");
    assert!(
        lines[0].starts_with("signing with the public development key"),
        "{stderr}"
    );
    assert!(stderr.contains("(code 5)"), "{stderr}");

    // A higher counter goes to the other slot.
    let litter_hex = identity_hex(&identity(&litter).expect("id"));
    let (ok, stdout, stderr) = flash(&port, "paper-litter", 1_001);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!("parameters {litter_hex} committed to slot 0")),
        "{stdout}"
    );

    // Default counters, back to back (well within a second of each other on the same
    // Unix second): both accepted, the second one above the first.
    let counter_of = |stdout: &str| -> u32 {
        stdout
            .trim()
            .rsplit_once("counter ")
            .and_then(|(_, n)| n.trim_end_matches(')').parse().ok())
            .unwrap_or_else(|| panic!("no counter in {stdout}"))
    };
    let mut counters = Vec::new();
    for preset in ["paper-rigid", "paper-litter", "paper-rigid"] {
        let (ok, stdout, stderr) = flash_with(&port, preset, None, &state_dir);
        assert!(ok, "{stderr}");
        counters.push(counter_of(&stdout));
    }
    assert!(counters.windows(2).all(|w| w[1] > w[0]), "{counters:?}");
    let now_s = supine_host::device::flash::unix_seconds().expect("clock");
    assert!(
        (now_s - 120..=now_s).contains(&counters[0]),
        "{counters:?} vs {now_s}"
    );
    drop(pty.slave);
}
