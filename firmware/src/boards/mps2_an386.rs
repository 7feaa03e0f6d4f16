//! QEMU's mps2-an386 (ARM MPS2 with an AN386 Cortex-M4F image): every image but the
//! Black Pill's.
//!
//! UART0 (CMSDK) is the link to the host, SysTick counts the 25 MHz core clock, the
//! PARAMS region of `memory.x` is SSRAM written as if it were NOR flash ([`SsramFlash`]),
//! and semihosting carries reports and the exit status.

use core::fmt::Write;

use cortex_m::peripheral::SYST;
use supine_core::upload::{FlashError, ParamFlash, SLOT_LEN};

use crate::cmsdk_uart::CmsdkUart;
use crate::exit;
use crate::param_flash::ParamRegion;

/// Core and peripheral clock, Hz. SysTick counts at this rate from the core clock.
pub const SYSCLK_HZ: u32 = supine_core::timing::MPS2_AN386_SYSCLK_HZ;

// The monitor's idle flush fits SysTick's 24-bit span at this clock.
const _: () = assert!(crate::cycles::measurable(supine_app::ticks_in_ms(
    SYSCLK_HZ,
    supine_app::IDLE_FLUSH_MS
)));

/// Base address of UART0, the one QEMU connects to its first `-serial`.
pub const UART0_BASE: usize = 0x4000_4000;

/// UART0 baud rate. QEMU ignores it, but a real MPS2 needs a valid divider.
pub const UART0_BAUD: u32 = 115_200;

/// Distance between the two parameter slots' starts, bytes: packed, as SSRAM has no
/// erase sectors.
pub const PARAM_SLOT_STRIDE: usize = SLOT_LEN;

/// The board's UART type.
pub type Uart = CmsdkUart;

/// The peripherals the images use, each with a single owner.
pub struct Board {
    /// UART0, the link to the host (QEMU's first serial port).
    pub uart0: Uart,
    /// The SysTick timer, counting the core clock ([`SYSCLK_HZ`], see [`crate::cycles`]).
    pub syst: SYST,
}

impl Board {
    /// Takes the board's peripherals; `None` on the second call, so each has one owner.
    pub fn take() -> Option<Self> {
        // cortex_m::Peripherals::take() is a once-only singleton; tying UART0 to it makes
        // UART0 a singleton too.
        let core = cortex_m::Peripherals::take()?;
        // SAFETY: UART0_BASE is the mps2-an386 UART0 register block, and this is the only
        // place that creates a driver for it (guarded by the singleton above).
        let uart0 = unsafe { CmsdkUart::new(UART0_BASE, SYSCLK_HZ, UART0_BAUD) };
        Some(Self {
            uart0,
            syst: core.SYST,
        })
    }
}

/// The parameter slots in SSRAM, written with plain volatile stores.
///
/// Flash semantics are modelled rather than assumed: erase sets every byte to 0xFF, and a
/// write can only clear bits (`old & new`, as NOR programming does), so a write over
/// unerased bytes stores something else and the read-back check after a commit catches it.
pub struct SsramFlash {
    region: ParamRegion,
}

impl SsramFlash {
    /// The slots of `region`.
    pub fn new(region: ParamRegion) -> Self {
        Self { region }
    }

    /// Erases only the first `len_bytes` of a slot: what a power cut in the middle of an
    /// erase leaves (for the `power_cut` test image).
    // Out of line: an update erases in two places (before writing, and again to scrub a
    // slot that failed its read-back); the second inlined copy cost 216 B of flash.
    #[inline(never)]
    pub fn erase_prefix(&mut self, slot: usize, len_bytes: usize) -> Result<(), FlashError> {
        let ptr = self.region.slot_ptr(slot).ok_or(FlashError)?;
        for i in 0..len_bytes.min(SLOT_LEN) {
            // SAFETY: in the slot (see `ParamRegion::slot_ptr`), exclusively owned through
            // `&mut self`.
            unsafe { ptr.add(i).write_volatile(0xFF) };
        }
        Ok(())
    }
}

impl ParamFlash for SsramFlash {
    fn slot(&self, slot: usize) -> &[u8] {
        self.region.slot(slot)
    }

    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        self.erase_prefix(slot, SLOT_LEN)
    }

    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        let ptr = self.region.slot_ptr(slot).ok_or(FlashError)?;
        let end = offset.checked_add(bytes.len()).ok_or(FlashError)?;
        if end > SLOT_LEN {
            return Err(FlashError);
        }
        for (i, &b) in (offset..end).zip(bytes) {
            // SAFETY: `offset..end` lies in the slot (checked above), exclusively owned
            // through `&mut self`. Programming clears bits only, as NOR flash does.
            unsafe {
                let cell = ptr.add(i);
                cell.write_volatile(cell.read_volatile() & b);
            }
        }
        Ok(())
    }
}

/// Writes a panic's or a fault's line on semihosting stderr, which QEMU prints.
pub fn report_fault(line: &core::fmt::Arguments<'_>) {
    if let Ok(mut stderr) = cortex_m_semihosting::hio::hstderr() {
        // Nothing more can be done if the debugger refuses the message; go on regardless.
        let _ = writeln!(stderr, "{line}");
    }
}

/// After a HardFault: end the run with [`exit::HARD_FAULT`], so a test sees it at once.
pub fn after_hard_fault() -> ! {
    exit::exit(exit::HARD_FAULT)
}
