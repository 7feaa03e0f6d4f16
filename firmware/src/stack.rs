//! The stack's high-water mark.
//!
//! cortex-m-rt (feature `paint-stack`) fills the stack, from `_stack_end` (just above the
//! statics) up to `_stack_start` (the top of RAM), with [`cortex_m_rt::STACK_PAINT_VALUE`]
//! before `main`. The deepest word the program has written is the first one, from the
//! bottom, that no longer holds the paint.

use cortex_m_rt::STACK_PAINT_VALUE;
use supine_app::StackGauge;

unsafe extern "C" {
    /// Lowest address of the stack region (from cortex-m-rt's `link.x`).
    static _stack_end: u32;
    /// Highest address (exclusive) of the stack region; the initial stack pointer.
    static _stack_start: u32;
}

fn bounds() -> (usize, usize) {
    // Only the symbols' addresses are used, never their values.
    let low = &raw const _stack_end as usize;
    let high = &raw const _stack_start as usize;
    (low, high)
}

/// Bytes reserved for the stack: all RAM above the statics.
pub fn size_bytes() -> usize {
    let (low, high) = bounds();
    high - low
}

/// Bytes of stack used so far (deepest point since reset), to 4 bytes.
///
/// A word the program wrote with the paint value itself counts as unused, so this can
/// read low by a few words; a full stack reads as [`size_bytes`].
pub fn high_water_bytes() -> usize {
    let (low, high) = bounds();
    let mut addr = low;
    while addr < high {
        // SAFETY: [low, high) is the stack region in RAM, 4-byte aligned (link.x asserts
        // it); a volatile read of a word there has no side effects.
        let word = unsafe { core::ptr::read_volatile(addr as *const u32) };
        if word != STACK_PAINT_VALUE {
            break;
        }
        addr += 4;
    }
    high - addr
}

/// The painted stack as the monitor's gauge (its status reports the high-water mark).
pub struct PaintedStack;

impl StackGauge for PaintedStack {
    fn high_water_bytes(&self) -> usize {
        high_water_bytes()
    }
}
