//! An image that panics at once.
//!
//! It exists for the QEMU tests: they check that a panic ends the run with
//! `exit::PANIC` and its message on stderr, so a failing device test can never pass or hang.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use supine_firmware as _;

#[entry]
fn main() -> ! {
    // black_box keeps the compiler from proving the panic at build time.
    let reason = core::hint::black_box("deliberate panic to test the panic handler");
    panic!("{reason}")
}
