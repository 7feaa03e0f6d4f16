//! Parameter updates over the link: the flash slots, the update being received, the key.

use supine_core::upload::{FlashError, KEY_LEN, ParamFlash, Upload};

/// What a monitor that takes updates holds for them.
pub(crate) struct Updates<F> {
    /// The A/B parameter slots the device booted from.
    pub(crate) flash: F,
    /// The update being received.
    pub(crate) upload: Upload,
    /// The key updates must be signed with.
    pub(crate) key: &'static [u8; KEY_LEN],
}

/// Stands for the flash of an image that takes no updates over the link.
pub struct NoUpdates;

impl ParamFlash for NoUpdates {
    fn slot(&self, _slot: usize) -> &[u8] {
        &[]
    }
    fn erase(&mut self, _slot: usize) -> Result<(), FlashError> {
        Err(FlashError)
    }
    fn write(&mut self, _slot: usize, _offset: usize, _bytes: &[u8]) -> Result<(), FlashError> {
        Err(FlashError)
    }
}
