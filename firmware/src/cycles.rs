//! Counting time and instructions with SysTick.
//!
//! SysTick counts the core clock: each board passes its own rate, which the monitor's
//! idle flush (`supine_app::IDLE_FLUSH_MS`) and `Status::busy_ticks` are counted in.
//!
//! Under QEMU with `-icount shift=0,align=off,sleep=off` every guest instruction takes
//! 1 ns of virtual time and the mps2 SysTick (25 MHz core clock) advances exactly one tick
//! per [`INSTRUCTIONS_PER_TICK`] instructions (`supine_core::timing`), identically from run
//! to run. These are instruction counts, not Cortex-M cycles. Without `-icount` the counts
//! follow the host's wall clock and mean nothing.

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use supine_app::TickCounter;
use supine_core::timing::INSTRUCTIONS_PER_TICK;

/// SysTick is a 24-bit down-counter.
const RELOAD: u32 = 0x00FF_FFFF;

/// Whether a span of `ticks` can be measured: it must stay under 2^24 ticks (about 671 ms
/// at 25 MHz, 262 ms at 64 MHz), or it wraps. For the boards' build-time checks of their
/// waits.
pub const fn measurable(ticks: u32) -> bool {
    ticks < RELOAD
}

/// A free-running SysTick on the core clock. One measured span must stay under 2^24
/// ticks ([`measurable`]), or it wraps.
pub struct SysTickCounter {
    _syst: SYST,
    core_clock_hz: u32,
}

impl SysTickCounter {
    /// Starts SysTick free-running from the core clock, `core_clock_hz`, without
    /// interrupts.
    pub fn new(mut syst: SYST, core_clock_hz: u32) -> Self {
        syst.disable_interrupt();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_counter();
        Self {
            _syst: syst,
            core_clock_hz,
        }
    }

    /// The counter now, to pass to [`Self::ticks_since`].
    pub fn now(&self) -> u32 {
        SYST::get_current()
    }

    /// Ticks elapsed since `start` (a value of [`Self::now`]).
    pub fn ticks_since(&self, start: u32) -> u32 {
        start.wrapping_sub(SYST::get_current()) & RELOAD
    }

    /// Ticks that `f` takes.
    pub fn ticks<R>(&self, f: impl FnOnce() -> R) -> (u32, R) {
        let start = self.now();
        let result = f();
        (self.ticks_since(start), result)
    }
}

/// The monitor's clock: times its pipeline and its idle flush.
impl TickCounter for SysTickCounter {
    fn tick_rate_hz(&self) -> u32 {
        self.core_clock_hz
    }
    fn now(&self) -> u32 {
        SysTickCounter::now(self)
    }
    fn ticks_since(&self, start: u32) -> u32 {
        SysTickCounter::ticks_since(self, start)
    }
}

/// Instructions in `ticks` ticks of the mps2-an386's SysTick under QEMU -icount.
pub fn instructions(ticks: u32) -> u64 {
    u64::from(ticks) * u64::from(INSTRUCTIONS_PER_TICK)
}
