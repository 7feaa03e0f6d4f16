//! The WeAct STM32F411CE "Black Pill" (Cortex-M4F) with an ST LIS3DH on I2C1: the image
//! `src/bin/blackpill.rs`, feature `board-blackpill`.
//!
//! USART1 is the link to the host ([`Usart1Link`]); the parameter slots are flash sectors
//! 6 and 7, erased and programmed through the HAL ([`BoardFlash`]); a fault resets the
//! device, and nothing goes to semihosting, which would stop the core without a debugger
//! (the panic record carries the message to the next greeting).

use stm32f4xx_hal::flash::FlashExt;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::serial::{Error as SerialError, Rx, RxISR, Serial, Tx, TxISR};
use supine_core::upload::{FlashError, ParamFlash, SLOT_COUNT, SLOT_LEN};

use crate::param_flash::ParamRegion;

/// Core clock the image sets up, Hz (from the 25 MHz crystal). SysTick counts it, so the
/// monitor's ticks are CPU cycles here.
pub const SYSCLK_HZ: u32 = 64_000_000;

// The monitor's idle flush fits SysTick's 24-bit span at this clock.
const _: () = assert!(crate::cycles::measurable(supine_app::ticks_in_ms(
    SYSCLK_HZ,
    supine_app::IDLE_FLUSH_MS
)));

/// Distance between the two parameter slots' starts, bytes: one 128 KiB flash sector each,
/// so that either can be erased without touching the other.
pub const PARAM_SLOT_STRIDE: usize = 128 * 1024;

/// Flash sector of slot A; slot B is the next one.
const FIRST_SECTOR: u8 = 6;
/// Flash address of slot A (sector 6), as `blackpill-memory.x` places PARAMS.
const SLOT_A_ADDR: usize = 0x0804_0000;
/// IWDG prescaler /256 and the largest reload: about 32 s, longer than the worst
/// case of a 128 KiB sector erase (4 s at 8-bit parallelism, RM0383 / DS10314).
const IWDG_LONG: (u8, u16) = (0b110, 0x0FFF);

/// USART1 as the monitor's byte link, one byte at a time in each direction.
pub struct Usart1Link {
    tx: Tx<pac::USART1>,
    rx: Rx<pac::USART1>,
}

impl Usart1Link {
    /// The link over a configured USART1.
    pub fn new(serial: Serial<pac::USART1>) -> Self {
        let (tx, rx) = serial.split();
        Self { tx, rx }
    }
}

impl embedded_io::ErrorType for Usart1Link {
    type Error = SerialError;
}

impl embedded_io::ReadReady for Usart1Link {
    /// A byte or a receive error (which comes with one) is waiting.
    fn read_ready(&mut self) -> Result<bool, SerialError> {
        Ok(self.rx.is_rx_not_empty())
    }
}

impl embedded_io::Read for Usart1Link {
    /// Waits for one byte. Overrun and framing errors drop the byte and are returned: the
    /// frame's decode then fails and the frame is counted as bad.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, SerialError> {
        let Some(first) = buf.first_mut() else {
            return Ok(0);
        };
        *first = nb::block!(embedded_hal_nb::serial::Read::read(&mut self.rx))?;
        Ok(1)
    }
}

impl embedded_io::WriteReady for Usart1Link {
    fn write_ready(&mut self) -> Result<bool, SerialError> {
        Ok(self.tx.is_tx_empty())
    }
}

impl embedded_io::Write for Usart1Link {
    /// Waits until the transmitter takes the first byte; sends that one only.
    fn write(&mut self, buf: &[u8]) -> Result<usize, SerialError> {
        let Some(&first) = buf.first() else {
            return Ok(0);
        };
        nb::block!(embedded_hal_nb::serial::Write::write(&mut self.tx, first))?;
        Ok(1)
    }

    /// Waits until the last byte has left the shift register.
    fn flush(&mut self) -> Result<(), SerialError> {
        nb::block!(embedded_hal_nb::serial::Write::flush(&mut self.tx))
    }
}

/// The parameter slots in the STM32F411's flash sectors 6 and 7, erased and programmed
/// with the flash controller.
pub struct BoardFlash {
    region: ParamRegion,
    flash: pac::FLASH,
}

impl BoardFlash {
    /// The slots, if the PARAMS region is where this module expects it.
    pub fn new(region: ParamRegion, flash: pac::FLASH) -> Option<Self> {
        (region.base_address() == SLOT_A_ADDR).then_some(Self { region, flash })
    }

    /// Runs `f` (an erase or a program, during which the CPU stalls on flash and
    /// cannot feed the watchdog) with the IWDG period stretched, then restores it and
    /// empties the flash caches, which do not see erases and writes.
    fn with_flash_unlocked(
        &mut self,
        f: impl FnOnce(&mut stm32f4xx_hal::flash::UnlockedFlash<'_>) -> Result<(), FlashError>,
    ) -> Result<(), FlashError> {
        // SAFETY: the IWDG registers are written only here and by the main loop's
        // `IndependentWatchdog::feed` (a reload key), both from thread mode without
        // interrupts touching it; the period set at start is restored before return.
        let iwdg = unsafe { &*pac::IWDG::ptr() };
        let set_period = |(pr, rl): (u8, u16)| {
            while iwdg.sr().read().bits() != 0 {}
            iwdg.kr().write(|w| unsafe { w.key().bits(0x5555) });
            iwdg.pr().write(|w| unsafe { w.pr().bits(pr) });
            iwdg.rlr().write(|w| w.rl().set(rl));
            while iwdg.sr().read().bits() != 0 {}
            iwdg.kr().write(|w| unsafe { w.key().bits(0xAAAA) });
        };
        while iwdg.sr().read().bits() != 0 {}
        let saved = (iwdg.pr().read().pr().bits(), iwdg.rlr().read().rl().bits());
        set_period(IWDG_LONG);
        // Clear error flags left by an earlier operation (or a debugger): the HAL reads
        // them after each step but never clears them.
        self.flash.sr().write(|w| {
            w.operr().clear();
            w.wrperr().clear();
            w.pgaerr().clear();
            w.pgperr().clear();
            w.pgserr().clear()
        });
        let result = f(&mut self.flash.unlocked());
        self.flash
            .acr()
            .modify(|_, w| w.dcen().clear_bit().icen().clear_bit());
        self.flash
            .acr()
            .modify(|_, w| w.dcrst().set_bit().icrst().set_bit());
        self.flash
            .acr()
            .modify(|_, w| w.dcrst().clear_bit().icrst().clear_bit());
        self.flash
            .acr()
            .modify(|_, w| w.dcen().set_bit().icen().set_bit());
        set_period(saved);
        result
    }
}

impl ParamFlash for BoardFlash {
    fn slot(&self, slot: usize) -> &[u8] {
        self.region.slot(slot)
    }

    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        let sector = u8::try_from(slot)
            .ok()
            .filter(|&s| usize::from(s) < SLOT_COUNT)
            .ok_or(FlashError)?;
        self.with_flash_unlocked(|f| f.erase(FIRST_SECTOR + sector).map_err(|_| FlashError))
    }

    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        let end = offset.checked_add(bytes.len()).ok_or(FlashError)?;
        if slot >= SLOT_COUNT || end > SLOT_LEN {
            return Err(FlashError);
        }
        let start = SLOT_A_ADDR + slot * PARAM_SLOT_STRIDE + offset - self.flash.address();
        self.with_flash_unlocked(|f| f.program(start, bytes.iter()).map_err(|_| FlashError))
    }
}

/// Nothing: semihosting without a debugger would stop the core, and the panic record
/// carries a panic's message to the next greeting.
pub fn report_fault(_line: &core::fmt::Arguments<'_>) {}

/// After a HardFault: reset, so the device keeps monitoring.
pub fn after_hard_fault() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}
