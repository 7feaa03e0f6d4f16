//! The monitor, made to panic once before its first greeting.
//!
//! For the QEMU test of the panic record: at first boot no record exists, so it panics
//! (the product's panic handler records the message and resets); after the reset the
//! record is there, so it runs the monitor, which greets with `ResetCause::Panic` and the
//! message. The trigger is this image's boot path only, never the protocol.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use supine_app::{App, Boot};
use supine_core::protocol::ResetCause;
use supine_firmware::boards::mps2_an386::{Board, SYSCLK_HZ};
use supine_firmware::cycles::SysTickCounter;
use supine_firmware::stack::PaintedStack;
use supine_firmware::{exit, panic_record, params};

#[entry]
fn main() -> ! {
    supine_firmware::reset_on_panic();
    let Some(last_panic) = panic_record::take() else {
        let reason = core::hint::black_box("deliberate panic before the first greeting");
        panic!("{reason}")
    };
    let Some(board) = Board::take() else {
        exit::exit(exit::FAILURE)
    };
    let Ok((params, source)) = params::load() else {
        exit::exit(exit::FAILURE)
    };
    let boot = Boot {
        build: "+qemu",
        params,
        source,
        reset_cause: ResetCause::Panic,
        last_panic,
    };
    App::new(
        board.uart0,
        SysTickCounter::new(board.syst, SYSCLK_HZ),
        PaintedStack,
        boot,
    )
    .run()
}
