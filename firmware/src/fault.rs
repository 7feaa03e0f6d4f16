//! The panic handler and the HardFault handler: report on stderr, exit with a failing status.
//!
//! On the emulated board this ends QEMU with [`exit::PANIC`] or [`exit::HARD_FAULT`] so a
//! test sees the failure at once instead of a hang.

use core::fmt::Write;
use core::panic::PanicInfo;

use cortex_m_rt::{ExceptionFrame, exception};
use cortex_m_semihosting::hio;

use crate::exit;

#[panic_handler]
fn panic(info: &PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    if let Ok(mut stderr) = hio::hstderr() {
        // Nothing more can be done if the debugger refuses the message; exit regardless.
        let _ = writeln!(stderr, "{info}");
    }
    exit::exit(exit::PANIC)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    if let Ok(mut stderr) = hio::hstderr() {
        let _ = writeln!(stderr, "hard fault at pc {:#010x}", frame.pc());
    }
    exit::exit(exit::HARD_FAULT)
}
