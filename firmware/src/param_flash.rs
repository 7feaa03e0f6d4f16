//! The PARAMS region of `memory.x` as the two parameter slots of
//! [`supine_core::upload`]: slot A at its start, slot B [`SLOT_STRIDE`] further (32 KiB
//! under QEMU; on the board one 128 KiB flash sector each, so that either can be erased
//! without touching the other).
//!
//! Under QEMU (mps2-an386) the "flash" is SSRAM, written with plain volatile stores. Flash
//! semantics are modelled rather than assumed: erase sets every byte to 0xFF, and a write
//! can only clear bits (`old & new`, as NOR programming does), so a write over unerased
//! bytes stores something else and the read-back check after a commit catches it.
//!
//! On the board (`board-blackpill`) the slots are the STM32F411's flash sectors 6 and 7,
//! programmed through the HAL by [`board::BoardFlash`]; [`ParamRegion`] alone only reads
//! them there.

use core::sync::atomic::{AtomicBool, Ordering};

use supine_core::upload::{FlashError, ParamFlash, SLOT_COUNT, SLOT_LEN};

include!(concat!(env!("OUT_DIR"), "/device_key.rs"));

/// The key uploads must be signed with, provisioned by `firmware/build.rs`.
pub fn device_key() -> &'static [u8; supine_core::upload::KEY_LEN] {
    &DEVICE_KEY
}

unsafe extern "C" {
    /// First byte of the PARAMS region (from `memory.x`).
    static __params_start: u8;
    /// One past the last byte of the PARAMS region.
    static __params_end: u8;
}

/// Distance between the two slots' starts, bytes.
#[cfg(not(feature = "board-blackpill"))]
pub const SLOT_STRIDE: usize = SLOT_LEN;
/// Distance between the two slots' starts, bytes: one 128 KiB flash sector each.
#[cfg(feature = "board-blackpill")]
pub const SLOT_STRIDE: usize = 128 * 1024;

/// Bytes of the PARAMS region the slots occupy.
pub const REGION_USED: usize = SLOT_STRIDE * (SLOT_COUNT - 1) + SLOT_LEN;

/// Set once the region has been handed out: there is one owner.
static TAKEN: AtomicBool = AtomicBool::new(false);

/// Exclusive access to the PARAMS region.
pub struct ParamRegion {
    base: *mut u8,
}

impl ParamRegion {
    /// The region, the first time only (`None` afterwards, or if `memory.x` gives it less
    /// than [`REGION_USED`]).
    pub fn take() -> Option<Self> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // Only the symbols' addresses are used, never their values.
        let start = &raw const __params_start as usize;
        let end = &raw const __params_end as usize;
        (end.saturating_sub(start) >= REGION_USED).then_some(Self {
            base: start as *mut u8,
        })
    }

    /// Erases only the first `len_bytes` of a slot: what a power cut in the middle of an
    /// erase leaves (for the `power_cut` test image).
    #[cfg(not(feature = "board-blackpill"))]
    pub fn erase_prefix(&mut self, slot: usize, len_bytes: usize) -> Result<(), FlashError> {
        let ptr = self.slot_ptr(slot).ok_or(FlashError)?;
        for i in 0..len_bytes.min(SLOT_LEN) {
            // SAFETY: in the slot (see `slot`), exclusively owned through `&mut self`.
            unsafe { ptr.add(i).write_volatile(0xFF) };
        }
        Ok(())
    }

    fn slot_ptr(&self, slot: usize) -> Option<*mut u8> {
        // In bounds: `take` checked that the region holds REGION_USED bytes.
        (slot < SLOT_COUNT).then(|| self.base.wrapping_add(slot * SLOT_STRIDE))
    }
}

impl ParamFlash for ParamRegion {
    fn slot(&self, slot: usize) -> &[u8] {
        match self.slot_ptr(slot) {
            // SAFETY: the slot lies inside the PARAMS region (checked in `take`), which
            // memory.x reserves outside FLASH and RAM: readable memory holding no Rust
            // object. This is the region's only owner and writes need `&mut self`, so
            // nothing changes the bytes while the returned borrow lives.
            Some(ptr) => unsafe { core::slice::from_raw_parts(ptr, SLOT_LEN) },
            None => &[],
        }
    }

    #[cfg(not(feature = "board-blackpill"))]
    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        let ptr = self.slot_ptr(slot).ok_or(FlashError)?;
        for i in 0..SLOT_LEN {
            // SAFETY: in the slot (see `slot`), exclusively owned through `&mut self`.
            unsafe { ptr.add(i).write_volatile(0xFF) };
        }
        Ok(())
    }

    #[cfg(not(feature = "board-blackpill"))]
    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        let ptr = self.slot_ptr(slot).ok_or(FlashError)?;
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

    // Real flash is programmed through the flash controller: see `board::BoardFlash`.
    #[cfg(feature = "board-blackpill")]
    fn erase(&mut self, _slot: usize) -> Result<(), FlashError> {
        Err(FlashError)
    }

    #[cfg(feature = "board-blackpill")]
    fn write(&mut self, _slot: usize, _offset: usize, _bytes: &[u8]) -> Result<(), FlashError> {
        Err(FlashError)
    }
}

/// The slots in the STM32F411's flash sectors 6 and 7.
#[cfg(feature = "board-blackpill")]
pub mod board {
    use stm32f4xx_hal::flash::FlashExt;
    use stm32f4xx_hal::pac;
    use supine_core::upload::{FlashError, ParamFlash, SLOT_LEN};

    use super::{ParamRegion, SLOT_STRIDE};

    /// Flash sector of slot A; slot B is the next one.
    const FIRST_SECTOR: u8 = 6;
    /// Flash address of slot A (sector 6), as `blackpill-memory.x` places PARAMS.
    const SLOT_A_ADDR: usize = 0x0804_0000;
    /// IWDG prescaler /256 and the largest reload: about 32 s, longer than the worst
    /// case of a 128 KiB sector erase (4 s at 8-bit parallelism, RM0383 / DS10314).
    const IWDG_LONG: (u8, u16) = (0b110, 0x0FFF);

    /// The PARAMS slots, erased and programmed with the flash controller.
    pub struct BoardFlash {
        region: ParamRegion,
        flash: pac::FLASH,
    }

    impl BoardFlash {
        /// The slots, if the PARAMS region is where this module expects it.
        pub fn new(region: ParamRegion, flash: pac::FLASH) -> Option<Self> {
            (region.base as usize == SLOT_A_ADDR).then_some(Self { region, flash })
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
                .filter(|&s| usize::from(s) < supine_core::upload::SLOT_COUNT)
                .ok_or(FlashError)?;
            self.with_flash_unlocked(|f| f.erase(FIRST_SECTOR + sector).map_err(|_| FlashError))
        }

        fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
            let end = offset.checked_add(bytes.len()).ok_or(FlashError)?;
            if slot >= supine_core::upload::SLOT_COUNT || end > SLOT_LEN {
                return Err(FlashError);
            }
            let start = SLOT_A_ADDR + slot * SLOT_STRIDE + offset - self.flash.address();
            self.with_flash_unlocked(|f| f.program(start, bytes.iter()).map_err(|_| FlashError))
        }
    }
}
