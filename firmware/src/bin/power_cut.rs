//! The monitor whose power fails during its next parameter update.
//!
//! For the QEMU test of the A/B slots under real cuts: the image runs the product's
//! monitor, but its flash allows only `N` bytes of erasing and programming (`N` is the
//! first word of the semihosting command line after the program name). The byte that
//! would exceed it is not written, the image prints `power cut` and stops the CPU for
//! good, as a power loss does: flash keeps what was written, and the test saves it and
//! boots it in a fresh QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use supine_app::{App, Boot};
use supine_core::protocol::ResetCause;
use supine_core::upload::{FlashError, ParamFlash, SLOT_LEN};
use supine_firmware::boards::mps2_an386::{Board, SYSCLK_HZ, SsramFlash};
use supine_firmware::cycles::SysTickCounter;
use supine_firmware::param_flash::{self, ParamRegion};
use supine_firmware::stack::PaintedStack;
use supine_firmware::{console, exit, host_file, params};

/// The PARAMS slots with a budget of bytes erased or programmed before the power fails.
struct PowerCut {
    slots: SsramFlash,
    budget_bytes: usize,
}

impl PowerCut {
    /// Takes `n` bytes from the budget; the bytes that fit it, and whether power remains.
    fn spend(&mut self, n: usize) -> (usize, bool) {
        let allowed = n.min(self.budget_bytes);
        self.budget_bytes -= allowed;
        (allowed, allowed == n)
    }
}

/// The power is gone: nothing more runs.
fn power_lost() -> ! {
    say("power cut\n");
    loop {
        cortex_m::asm::wfi();
    }
}

impl ParamFlash for PowerCut {
    fn slot(&self, slot: usize) -> &[u8] {
        self.slots.slot(slot)
    }

    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        match self.spend(SLOT_LEN) {
            (_, true) => self.slots.erase(slot),
            (done, false) => {
                let _ = self.slots.erase_prefix(slot, done);
                power_lost()
            }
        }
    }

    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        match self.spend(bytes.len()) {
            (_, true) => self.slots.write(slot, offset, bytes),
            (done, false) => {
                let _ = self
                    .slots
                    .write(slot, offset, bytes.get(..done).unwrap_or(&[]));
                power_lost()
            }
        }
    }
}

/// A line to QEMU's stdout (semihosting), for the test's diagnostics.
fn say(line: &str) {
    if let Ok(mut out) = console::Console::stdout() {
        let _ = core::fmt::Write::write_str(&mut out, line);
    }
}

/// The budget from the semihosting command line (`power_cut N`).
fn budget_bytes() -> Option<usize> {
    let mut line = [0u8; host_file::COMMAND_LINE_LEN];
    core::str::from_utf8(host_file::command_line(&mut line)?)
        .ok()?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

#[entry]
fn main() -> ! {
    supine_firmware::reset_on_panic();
    let (Some(board), Some(region), Some(budget_bytes)) =
        (Board::take(), ParamRegion::take(), budget_bytes())
    else {
        say("power_cut: give the byte budget on the semihosting command line\n");
        exit::exit(exit::FAILURE)
    };
    let slots = SsramFlash::new(region);
    let Ok((params, source)) = params::load_from(&slots) else {
        exit::exit(exit::FAILURE)
    };
    let boot = Boot {
        build: "+power-cut",
        params,
        source,
        reset_cause: ResetCause::PowerOn,
        last_panic: Default::default(),
    };
    let flash = PowerCut {
        slots,
        budget_bytes,
    };
    let counter = SysTickCounter::new(board.syst, SYSCLK_HZ);
    App::with_updates(
        board.uart0,
        counter,
        PaintedStack,
        boot,
        flash,
        param_flash::device_key(),
    )
    .run()
}
