//! The QEMU harness itself: exit statuses, the UART, the deadline and the cleanup.

use std::path::PathBuf;
use std::time::Duration;

use supine_host::device::firmware::PRODUCT_BINARY;
use supine_host::device::qemu::{self, Qemu, QemuConfig, QemuError};
use supine_qemu_tests::firmware;

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
