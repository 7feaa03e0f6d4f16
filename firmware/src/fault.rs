//! The panic handler and the HardFault handler.
//!
//! A panic is recorded ([`crate::panic_record`]) and reported on semihosting stderr. The
//! product image ([`reset_on_panic`]) then resets, so the device keeps running and names
//! the panic in its next greeting; the test images instead end QEMU with [`exit::PANIC`]
//! so a test sees the failure at once instead of a hang. A HardFault ends the run
//! with [`exit::HARD_FAULT`] under QEMU. On the real board (feature `board-blackpill`)
//! both reset the device and nothing goes to semihosting.

#[cfg(not(feature = "board-blackpill"))]
use core::fmt::Write;
use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use crate::{exit, panic_record};
use cortex_m_rt::{ExceptionFrame, exception};

/// Set by the product image: a panic resets instead of ending the run.
static RESET_ON_PANIC: AtomicBool = AtomicBool::new(false);

/// Makes a later panic record its message and reset the device (the product's behaviour).
pub fn reset_on_panic() {
    RESET_ON_PANIC.store(true, Ordering::Relaxed);
}

#[panic_handler]
fn panic(info: &PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    panic_record::store(&format_args!("{}", info.message()));
    report(&format_args!("{info}"));
    if RESET_ON_PANIC.load(Ordering::Relaxed) {
        cortex_m::peripheral::SCB::sys_reset()
    }
    exit::exit(exit::PANIC)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    report(&format_args!("hard fault at pc {:#010x}", frame.pc()));
    #[cfg(feature = "board-blackpill")]
    cortex_m::peripheral::SCB::sys_reset();
    #[cfg(not(feature = "board-blackpill"))]
    exit::exit(exit::HARD_FAULT)
}

/// Writes a line on semihosting stderr (QEMU). On the real board nothing: semihosting
/// without a debugger would stop the core, and the panic record carries the message.
fn report(line: &core::fmt::Arguments<'_>) {
    #[cfg(not(feature = "board-blackpill"))]
    if let Ok(mut stderr) = cortex_m_semihosting::hio::hstderr() {
        // Nothing more can be done if the debugger refuses the message; go on regardless.
        let _ = writeln!(stderr, "{line}");
    }
    #[cfg(feature = "board-blackpill")]
    let _ = line;
}
