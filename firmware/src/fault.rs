//! The panic handler and the HardFault handler.
//!
//! A panic is recorded ([`crate::panic_record`]) and reported the board's way
//! ([`crate::boards`]: semihosting stderr under QEMU, nothing on the Black Pill). The
//! product image ([`reset_on_panic`]) then resets, so the device keeps running and names
//! the panic in its next greeting; the test images instead end QEMU with [`exit::PANIC`]
//! so a test sees the failure at once instead of a hang. A HardFault is reported and then
//! handled by the board: the end of the run with [`exit::HARD_FAULT`] under QEMU, a reset
//! on the Black Pill.

use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_rt::{ExceptionFrame, exception};

use crate::boards::active;
use crate::{exit, panic_record};

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
    active::report_fault(&format_args!("{info}"));
    if RESET_ON_PANIC.load(Ordering::Relaxed) {
        cortex_m::peripheral::SCB::sys_reset()
    }
    exit::exit(exit::PANIC)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    active::report_fault(&format_args!("hard fault at pc {:#010x}", frame.pc()));
    active::after_hard_fault()
}
