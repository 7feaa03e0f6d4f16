//! An image that executes an undefined instruction at once.
//!
//! It exists for the QEMU tests: the fault escalates to HardFault (UsageFault is not
//! enabled), whose handler must end the run with `exit::HARD_FAULT` and the faulting
//! address on stderr, so a crashing device test can never pass or hang.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use supine_firmware as _;

#[entry]
fn main() -> ! {
    cortex_m::asm::udf()
}
