//! The clock of the main loop.

/// A free-running tick counter in the board's own clock: SysTick on the device, counting
/// the core clock (25 MHz on QEMU's mps2-an386, where a tick is
/// `supine_core::timing::INSTRUCTIONS_PER_TICK` instructions; 64 MHz on the Black Pill,
/// where a tick is a CPU cycle), a simulated one in tests. It times the pipeline
/// (`Status::busy_ticks`) and tells when the host has paused, in milliseconds on every
/// board through [`tick_rate_hz`](Self::tick_rate_hz).
pub trait TickCounter {
    /// Ticks per second.
    fn tick_rate_hz(&self) -> u32;
    /// The counter now, to pass to [`Self::ticks_since`].
    fn now(&self) -> u32;
    /// Ticks elapsed since `start` (a value of [`Self::now`]).
    fn ticks_since(&self, start: u32) -> u32;
}

/// `ms` milliseconds in ticks of a clock of `tick_rate_hz`, rounded up (a wait of this
/// many ticks is never shorter than `ms`), at most `u32::MAX`. A `const fn`, so a board
/// can check at build time that the waits fit its counter's span.
pub const fn ticks_in_ms(tick_rate_hz: u32, ms: u32) -> u32 {
    let ticks = (tick_rate_hz as u64 * ms as u64).div_ceil(1000);
    if ticks > u32::MAX as u64 {
        u32::MAX
    } else {
        ticks as u32
    }
}
