//! Converting the device's SysTick ticks to instructions under QEMU.
//!
//! The QEMU tests and `supine replay --icount` run the image with `-icount shift=0`: every
//! guest instruction advances virtual time by 2^0 = 1 ns. The mps2-an386's SysTick counts
//! its 25 MHz core clock, one tick per 40 ns of virtual time, so one tick is exactly 40
//! instructions, the same on every run. The firmware converts its own timings with this
//! and the host converts the device's `Status::busy_ticks`, so both must use this one value.

/// Core clock of QEMU's mps2-an386, Hz: SysTick counts it, and the UART's baud divider
/// derives from it.
pub const MPS2_AN386_SYSCLK_HZ: u32 = 25_000_000;

/// Nanoseconds of virtual time per guest instruction under `-icount shift=0` (2^0).
pub const ICOUNT_NS_PER_INSTRUCTION: u32 = 1;

/// Instructions per SysTick tick under `-icount shift=0` on mps2-an386: 40 ns per tick of
/// the 25 MHz clock, at one instruction per ns.
pub const INSTRUCTIONS_PER_TICK: u32 =
    1_000_000_000 / (MPS2_AN386_SYSCLK_HZ * ICOUNT_NS_PER_INSTRUCTION);

// The clock divides a second into whole ticks of whole instructions.
const _: () = assert!(1_000_000_000 % (MPS2_AN386_SYSCLK_HZ * ICOUNT_NS_PER_INSTRUCTION) == 0);
