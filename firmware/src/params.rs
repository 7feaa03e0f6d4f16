//! The model parameters the device runs with.
//!
//! Today: the realization baked into the image by `firmware/build.rs` (the paper's
//! litter-board preset, discretized at [`SAMPLE_RATE_HZ`] on the build machine and encoded
//! with postcard). Decoding checks it once at boot, so the hot path cannot fail. Later the
//! same step reads the full parameter blob from the PARAMS region of `memory.x`.

use core::fmt;

use supine_core::model::{DeviceRealization, RealizationError};

include!(concat!(env!("OUT_DIR"), "/realization.rs"));

/// The built-in realization, postcard-encoded.
static BUILTIN: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/realization.postcard"));

/// CRC-32 (ISO-HDLC, as zlib) used to name a parameter set in greetings and reports.
const IDENTITY_CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Why parameters were refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamsError {
    /// The bytes do not decode as a realization.
    Decode,
    /// The bytes decode but more follow: the producer and the device disagree on the format.
    TrailingBytes,
    /// The realization decodes but is unfit to run (not finite, unstable, bad rate).
    Invalid(RealizationError),
}

impl fmt::Display for ParamsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Decode => f.write_str("parameters do not decode as a realization"),
            Self::TrailingBytes => f.write_str("parameters have bytes after the realization"),
            Self::Invalid(err) => write!(f, "realization refused: {err}"),
        }
    }
}

impl core::error::Error for ParamsError {}

/// The built-in realization's encoded bytes.
pub fn builtin_bytes() -> &'static [u8] {
    BUILTIN
}

/// CRC-32 of encoded parameters: their identity.
pub fn identity(bytes: &[u8]) -> u32 {
    IDENTITY_CRC.checksum(bytes)
}

/// Decodes a realization and checks it (finite, stable, supported rate), refusing
/// anything but exactly one valid realization.
pub fn decode(bytes: &[u8]) -> Result<DeviceRealization, ParamsError> {
    let (realization, rest) =
        postcard::take_from_bytes::<DeviceRealization>(bytes).map_err(|_| ParamsError::Decode)?;
    if !rest.is_empty() {
        return Err(ParamsError::TrailingBytes);
    }
    realization.check().map_err(ParamsError::Invalid)?;
    Ok(realization)
}

/// Decodes the built-in realization.
pub fn load_builtin() -> Result<DeviceRealization, ParamsError> {
    decode(BUILTIN)
}
