//! The board: QEMU's mps2-an386 (ARM MPS2 with an AN386 Cortex-M4F image).
//!
//! Everything board-specific is named here, so moving to another board means editing this
//! module (and `memory.x`) only.

use cortex_m::peripheral::SYST;

use crate::cmsdk_uart::CmsdkUart;

/// Core and peripheral clock, Hz. SysTick counts at this rate from the core clock.
pub const SYSCLK_HZ: u32 = supine_core::timing::MPS2_AN386_SYSCLK_HZ;

/// Base address of UART0, the one QEMU connects to its first `-serial`.
pub const UART0_BASE: usize = 0x4000_4000;

/// UART0 baud rate. QEMU ignores it, but a real MPS2 needs a valid divider.
pub const UART0_BAUD: u32 = 115_200;

/// The board's UART type.
pub type Uart = CmsdkUart;

/// The peripherals the images use, each with a single owner.
pub struct Board {
    /// UART0, the link to the host (QEMU's first serial port).
    pub uart0: Uart,
    /// The SysTick timer, used to count instructions (see [`crate::cycles`]).
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
