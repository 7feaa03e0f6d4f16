//! What the device starts with: its parameters and how it last stopped.

use heapless::String;
use supine_core::blob::DeviceParams;
use supine_core::protocol::{PANIC_MESSAGE_LEN, ParamsSource, ResetCause};

/// Where the running parameters came from and how the device last stopped.
pub struct Boot {
    /// Appended to the firmware version in the greeting (`+qemu`, `+blackpill`).
    pub build: &'static str,
    /// The parameters in use.
    pub params: DeviceParams,
    /// Flash slot or built-in default (with the reason the flash blob was refused).
    pub source: ParamsSource,
    /// How the device last stopped.
    pub reset_cause: ResetCause,
    /// The last panic's message (empty if none).
    pub last_panic: String<PANIC_MESSAGE_LEN>,
}
