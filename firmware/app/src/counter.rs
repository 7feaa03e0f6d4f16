//! The clock of the main loop.

/// A free-running tick counter: SysTick on the device (25 MHz under QEMU, where a tick is
/// `supine_core::timing::INSTRUCTIONS_PER_TICK` instructions), a simulated one in tests.
/// It times the pipeline (`Status::busy_ticks`) and tells when the host has paused.
pub trait TickCounter {
    /// The counter now, to pass to [`Self::ticks_since`].
    fn now(&self) -> u32;
    /// Ticks elapsed since `start` (a value of [`Self::now`]).
    fn ticks_since(&self, start: u32) -> u32;
}
