//! The PARAMS region of `memory.x` as the two parameter slots of
//! [`supine_core::upload`]: slot A at its start, slot B 32 KiB further.
//!
//! Under QEMU (mps2-an386) the "flash" is SSRAM, written with plain volatile stores. Flash
//! semantics are modelled rather than assumed: erase sets every byte to 0xFF, and a write
//! can only clear bits (`old & new`, as NOR programming does), so a write over unerased
//! bytes stores something else and the read-back check after a commit catches it.
//!
//! On the board (`board-blackpill`) the region is the STM32F411's flash sector 7, which
//! this image reads but does not program: erase and write fail, and the monitor refuses
//! uploads over the UART (new parameters go in with `supine flash --probe`).

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

/// Set once the region has been handed out: there is one owner.
static TAKEN: AtomicBool = AtomicBool::new(false);

/// Exclusive access to the PARAMS region.
pub struct ParamRegion {
    base: *mut u8,
}

impl ParamRegion {
    /// The region, the first time only (`None` afterwards, or if `memory.x` gives it fewer
    /// than two slots).
    pub fn take() -> Option<Self> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // Only the symbols' addresses are used, never their values.
        let start = &raw const __params_start as usize;
        let end = &raw const __params_end as usize;
        (end.saturating_sub(start) >= SLOT_COUNT * SLOT_LEN).then_some(Self {
            base: start as *mut u8,
        })
    }

    fn slot_ptr(&self, slot: usize) -> Option<*mut u8> {
        // In bounds: `take` checked that the region holds SLOT_COUNT slots.
        (slot < SLOT_COUNT).then(|| self.base.wrapping_add(slot * SLOT_LEN))
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

    #[cfg(feature = "board-blackpill")]
    fn erase(&mut self, _slot: usize) -> Result<(), FlashError> {
        Err(FlashError)
    }

    #[cfg(feature = "board-blackpill")]
    fn write(&mut self, _slot: usize, _offset: usize, _bytes: &[u8]) -> Result<(), FlashError> {
        Err(FlashError)
    }
}
