//! The supine device image: the on-litter monitor, in its replay form under QEMU.
//!
//! At boot it reads the last panic's record, loads the parameter blob from the PARAMS
//! region's A/B slots (or the built-in default, with the reason), greets the host on UART0
//! and then serves it (see [`supine_app::App`]): replayed samples in, telemetry and
//! alerts out, authenticated parameter updates into the slot not running. Given
//! `--replay-input FILE` on the semihosting command line (`supine replay`), it reads the
//! frames in FILE before the UART's ([`supine_firmware::replay_link`]).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use heapless::String;
use supine_app::{App, Boot};
use supine_core::blob::{BlobError, DeviceParams};
use supine_core::protocol::{PANIC_MESSAGE_LEN, ParamsSource, ResetCause};
use supine_firmware::boards::mps2_an386::{Board, SYSCLK_HZ, SsramFlash, Uart};
use supine_firmware::cycles::SysTickCounter;
use supine_firmware::host_file::{self, HostFile};
use supine_firmware::param_flash::{self, ParamRegion};
use supine_firmware::replay_link::ReplayLink;
use supine_firmware::stack::PaintedStack;
use supine_firmware::{exit, panic_record, params};

#[entry]
fn main() -> ! {
    supine_firmware::reset_on_panic();
    // Before the monitor's frame: the command line's buffer then adds nothing to the
    // stack's peak, which boot's slot choice sets.
    let input = replay_input();
    monitor(input).run()
}

/// The monitor, with the parameters chosen at boot.
///
/// Out of line: choosing the slot decodes and validates every slot, and those temporaries
/// live in this frame, gone before the monitor runs. Inlined into `main`, whose frame
/// holds the monitor for good, they would add kilobytes to the device's RAM.
#[inline(never)]
fn monitor(
    replay_input: Option<HostFile>,
) -> App<ReplayLink<Uart>, SysTickCounter, PaintedStack, SsramFlash> {
    let Some(board) = Board::take() else {
        // Only reachable if something took the peripherals before main: a build error.
        exit::exit(exit::FAILURE)
    };
    let last_panic = panic_record::take();
    let Some(region) = ParamRegion::take() else {
        // Only reachable if memory.x gives PARAMS fewer than two slots: a build error.
        exit::exit(exit::FAILURE)
    };
    let flash = SsramFlash::new(region);
    let mut loaded = Err(BlobError::Empty);
    let source = params::load_to(&flash, &mut loaded);
    let counter = SysTickCounter::new(board.syst, SYSCLK_HZ);
    let link = ReplayLink::new(board.uart0, replay_input);
    start(link, counter, flash, &mut loaded, source, last_panic)
}

/// The monitor on the loaded parameters (`loaded`, from `source`), which it takes out of
/// their place. Out of line: the `Boot` that holds them then lives in this frame, not in
/// the boot's beside them while they are decoded (the stack's peak).
#[inline(never)]
fn start(
    link: ReplayLink<Uart>,
    counter: SysTickCounter,
    flash: SsramFlash,
    loaded: &mut Result<DeviceParams, BlobError>,
    source: ParamsSource,
    last_panic: Option<String<PANIC_MESSAGE_LEN>>,
) -> App<ReplayLink<Uart>, SysTickCounter, PaintedStack, SsramFlash> {
    let Ok(params) = core::mem::replace(loaded, Err(BlobError::Empty)) else {
        // The built-in default was validated when it was built: a broken build.
        exit::exit(exit::FAILURE)
    };
    let boot = Boot {
        build: "+qemu",
        params,
        source,
        reset_cause: if last_panic.is_some() {
            ResetCause::Panic
        } else {
            ResetCause::PowerOn
        },
        last_panic: last_panic.unwrap_or_default(),
    };
    App::with_updates(
        link,
        counter,
        PaintedStack,
        boot,
        flash,
        param_flash::device_key(),
    )
}

/// The host file named by `--replay-input FILE` on the semihosting command line, open; a
/// file named but not opened ends the run, so the host hears of it rather than waiting.
/// Out of line, so its buffer is gone before the monitor is built.
#[inline(never)]
fn replay_input() -> Option<HostFile> {
    let mut line = [0u8; host_file::COMMAND_LINE_LEN];
    let len = host_file::command_line(&mut line)?.len();
    let start = host_file::value_start(line.get(..len)?, b"--replay-input")?;
    // The path runs to the line's end; the host wants it NUL-terminated.
    *line.get_mut(len)? = 0;
    let path = line.get(start..=len)?;
    let file = HostFile::open(path);
    if file.is_none() {
        supine_firmware::boards::mps2_an386::report_fault(&format_args!(
            "cannot open the file given by --replay-input"
        ));
        exit::exit(exit::FAILURE)
    }
    file
}
