//! Ending a run with an exit status the host can read (semihosting `SYS_EXIT_EXTENDED`).
//!
//! Under QEMU (`-semihosting-config enable=on,target=native`) the status becomes QEMU's
//! own exit status, which is how a QEMU test passes or fails.

use cortex_m_semihosting::syscall;

/// Semihosting operation `SYS_EXIT_EXTENDED`: an exit reason and a status code.
const SYS_EXIT_EXTENDED: usize = 0x20;

/// Exit reason `ADP_Stopped_ApplicationExit`: QEMU then exits with the status code.
const ADP_STOPPED_APPLICATION_EXIT: usize = 0x2_0026;

/// The run did what it was asked and every check passed.
pub const SUCCESS: u8 = 0;
/// A check failed (the image says which on stdout or stderr).
pub const FAILURE: u8 = 1;
/// The image panicked (the message is on stderr). Same number as a Rust test's panic.
pub const PANIC: u8 = 101;
/// The processor took a HardFault (the faulting address is on stderr).
pub const HARD_FAULT: u8 = 102;

/// Ends the run with `status`. Does not return: if a debugger resumes, it spins.
pub fn exit(status: u8) -> ! {
    let block = [ADP_STOPPED_APPLICATION_EXIT, usize::from(status)];
    // SAFETY: SYS_EXIT_EXTENDED reads a two-word parameter block (reason, status) from the
    // address in r1; `block` is such a block and outlives the call.
    unsafe {
        syscall(SYS_EXIT_EXTENDED, &block);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
