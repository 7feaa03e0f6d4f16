//! The QEMU harness itself: exit statuses, the UART, the deadline and the cleanup.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::time::Duration;

use supine_host::firmware::PRODUCT_BINARY;
use supine_host::qemu::{self, Qemu, QemuConfig, QemuError};
use supine_qemu_tests::{builtin_realization, firmware, identity};

fn process_exists(pid: u32) -> bool {
    PathBuf::from(format!("/proc/{pid}")).exists()
}

#[test]
fn a_panic_ends_the_run_with_status_101_and_its_message() {
    let elf = firmware("panics");
    let output = qemu::run(&QemuConfig::new(&elf).timeout(Duration::from_secs(60)))
        .unwrap_or_else(|err| panic!("{err}"));
    println!(
        "exit status {:?}, stderr {:?}",
        output.code(),
        output.stderr
    );
    assert_eq!(output.code(), Some(101));
    assert!(
        output.stderr.contains("deliberate panic"),
        "{}",
        output.stderr
    );
}

#[test]
fn a_hard_fault_ends_the_run_with_status_102_and_the_faulting_address() {
    let elf = firmware("hardfault");
    let output = qemu::run(&QemuConfig::new(&elf).timeout(Duration::from_secs(60)))
        .unwrap_or_else(|err| panic!("{err}"));
    println!(
        "exit status {:?}, stderr {:?}",
        output.code(),
        output.stderr
    );
    assert_eq!(output.code(), Some(102));
    assert!(
        output.stderr.contains("hard fault at pc 0x"),
        "{}",
        output.stderr
    );
}

/// Runs the product image (with `blob` in the PARAMS region, if given), reads its
/// greeting, stops it and checks that the run's folder is gone.
fn greeting(blob: Option<&[u8]>) -> String {
    let elf = firmware(PRODUCT_BINARY);
    let blob_dir = tempfile::tempdir().expect("temp dir");
    let mut config = QemuConfig::new(&elf)
        .uart()
        .timeout(Duration::from_secs(60));
    if let Some(bytes) = blob {
        let path = blob_dir.path().join("params.bin");
        std::fs::write(&path, bytes).expect("write the blob");
        config = config.params_blob(path);
    }
    let mut qemu = Qemu::start(&config).unwrap_or_else(|err| panic!("{err}"));
    let dir = qemu.dir().to_path_buf();
    let remaining = qemu.remaining();
    let uart = qemu.uart().expect("a UART was asked for");
    uart.set_read_timeout(Some(remaining))
        .expect("set a read timeout");
    let mut line = String::new();
    BufReader::new(uart)
        .read_line(&mut line)
        .expect("a greeting line before the deadline");
    println!("greeting: {line:?}");

    // The image never exits on its own: stopping it kills QEMU and removes its folder.
    let output = qemu.stop().unwrap_or_else(|err| panic!("{err}"));
    assert_eq!(output.code(), None, "killed by a signal, not exited");
    assert!(!dir.exists(), "{} left behind", dir.display());
    line
}

/// The greeting's fixed start: version and the built-in realization's identity.
fn greeting_start() -> String {
    let (_, crc) = identity(&builtin_realization());
    format!(
        "supine-firmware {} params builtin crc32 {crc:08x} ok fs_hz {} blob ",
        env!("CARGO_PKG_VERSION"),
        supine_qemu_tests::BUILTIN_SAMPLE_RATE_HZ
    )
}

#[test]
fn the_product_image_greets_on_the_uart_and_reports_an_empty_params_region() {
    let line = greeting(None);
    let expected = format!(
        "{}refused: no parameter blob (erased slot) (blob error 1)\n",
        greeting_start()
    );
    assert_eq!(line, expected);
}

#[test]
fn the_product_image_accepts_a_valid_blob_loaded_into_the_params_region() {
    let line = greeting(Some(supine_core::protocol::golden::BLOB));
    assert_eq!(line, format!("{}ok\n", greeting_start()));
}

#[test]
fn the_product_image_refuses_a_corrupted_blob() {
    let mut bytes = supine_core::protocol::golden::BLOB.to_vec();
    // Flip one bit in the payload: the header's CRC-32 no longer matches.
    let last = bytes.len() - 1;
    bytes[last] ^= 0x01;
    let line = greeting(Some(&bytes));
    assert_eq!(
        line,
        format!(
            "{}refused: CRC-32 mismatch (blob error 6)\n",
            greeting_start()
        )
    );
}

#[test]
fn a_run_past_its_deadline_is_killed_and_cleaned_up() {
    let elf = firmware(PRODUCT_BINARY);
    let config = QemuConfig::new(&elf).timeout(Duration::from_millis(500));
    let qemu = Qemu::start(&config).unwrap_or_else(|err| panic!("{err}"));
    let dir = qemu.dir().to_path_buf();
    let pid = qemu.id();
    let err = qemu.wait().expect_err("the product image never exits");
    println!("{err}");
    assert!(matches!(err, QemuError::Timeout { .. }), "{err}");
    assert!(!dir.exists(), "{} left behind", dir.display());
    assert!(!process_exists(pid), "QEMU {pid} still running");
}

#[test]
fn a_panic_in_the_caller_still_kills_qemu_and_removes_its_folder() {
    let elf = firmware(PRODUCT_BINARY);
    let config = QemuConfig::new(&elf)
        .uart()
        .timeout(Duration::from_secs(60));
    let mut seen = None;
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let qemu = Qemu::start(&config).unwrap_or_else(|err| panic!("{err}"));
        seen = Some((qemu.dir().to_path_buf(), qemu.id()));
        panic!("the test body fails while QEMU runs");
    }));
    assert!(result.is_err());
    let (dir, pid) = seen.expect("QEMU started");
    assert!(!dir.exists(), "{} left behind", dir.display());
    assert!(!process_exists(pid), "QEMU {pid} still running");
}
