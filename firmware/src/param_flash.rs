//! The PARAMS region of `memory.x` as the two parameter slots of
//! [`supine_core::upload`]: slot A at its start, slot B the board's
//! `PARAM_SLOT_STRIDE` further (see [`crate::boards`]).
//!
//! [`ParamRegion`] owns the region and reads the slots; writing them is the board's job
//! (SSRAM stores under QEMU, the flash controller on the Black Pill), each board's flash
//! type wrapping the region.

use core::sync::atomic::{AtomicBool, Ordering};

use supine_core::upload::{FlashError, ParamFlash, SLOT_COUNT, SLOT_LEN};

use crate::boards::active::PARAM_SLOT_STRIDE;

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

/// Bytes of the PARAMS region the slots occupy.
pub const REGION_USED: usize = PARAM_SLOT_STRIDE * (SLOT_COUNT - 1) + SLOT_LEN;

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

    /// Address of the region's first byte (slot A).
    pub fn base_address(&self) -> usize {
        self.base as usize
    }

    /// The first byte of a slot, for the board's flash type to write through while it
    /// owns the region; `None` for a slot that does not exist.
    pub(crate) fn slot_ptr(&self, slot: usize) -> Option<*mut u8> {
        // In bounds: `take` checked that the region holds REGION_USED bytes.
        (slot < SLOT_COUNT).then(|| self.base.wrapping_add(slot * PARAM_SLOT_STRIDE))
    }
}

/// The region alone only reads: images that never write it (and boot's slot choice)
/// use it as it is; erase and write are refused, as for a write-protected flash.
impl ParamFlash for ParamRegion {
    fn slot(&self, slot: usize) -> &[u8] {
        match self.slot_ptr(slot) {
            // SAFETY: the slot lies inside the PARAMS region (checked in `take`), which
            // memory.x reserves outside FLASH and RAM: readable memory holding no Rust
            // object. This is the region's only owner and writes need `&mut` of it or of
            // the board's flash type that owns it, so nothing changes the bytes while the
            // returned borrow lives.
            Some(ptr) => unsafe { core::slice::from_raw_parts(ptr, SLOT_LEN) },
            None => &[],
        }
    }

    fn erase(&mut self, _slot: usize) -> Result<(), FlashError> {
        Err(FlashError)
    }

    fn write(&mut self, _slot: usize, _offset: usize, _bytes: &[u8]) -> Result<(), FlashError> {
        Err(FlashError)
    }
}
