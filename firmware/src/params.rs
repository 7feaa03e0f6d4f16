//! The model parameters the device runs with.
//!
//! Today: the realization baked into the image by `firmware/build.rs` (the paper's
//! litter-board preset, discretized at [`SAMPLE_RATE_HZ`] on the build machine and encoded
//! with postcard). Decoding checks it once at boot, so the hot path cannot fail.
//!
//! The full parameter blob (`supine_core::blob`) lives in one of the two slots of the
//! PARAMS region of `memory.x` ([`crate::param_flash`]); [`load_from`] picks the slot to run
//! at boot, or the built-in default blob, and the greeting says which and why.

use core::fmt;

use supine_core::blob::{BlobError, DeviceParams};
use supine_core::model::{DeviceRealization, RealizationError};
use supine_core::protocol::{ParamsIdentity, ParamsSource};
use supine_core::upload::{ParamFlash, select_to};

use crate::param_flash::ParamRegion;

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
    /// The realization decodes but is unfit to run (not finite, unstable, bad layout).
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

/// Decodes a realization and checks it (finite, stable, consistent layout), refusing
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

/// The built-in default's full parameter blob (see `firmware/build.rs`): the paper
/// litter-board preset at [`SAMPLE_RATE_HZ`] with the default exposure, alert and
/// sensor-check settings, level mounting and telemetry every sample.
static DEFAULT_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/default_blob.bin"));

/// Identity of the built-in default: a fixed name rather than a SHA-256, which the host
/// prints as "built-in".
pub const BUILTIN_IDENTITY: ParamsIdentity = *b"builtin-litter\0\0";

/// The built-in default's blob bytes.
pub fn default_blob() -> &'static [u8] {
    DEFAULT_BLOB
}

/// The parameters to run with and where they came from: the committed slot with the
/// highest counter, else a plain blob in slot A, else the built-in default with the reason
/// slot A was refused (`supine_core::upload::select`). Errs only if the built-in default
/// itself is refused, which `firmware/build.rs` has already ruled out when it built it.
pub fn load_from(flash: &impl ParamFlash) -> Result<(DeviceParams, ParamsSource), BlobError> {
    let mut decoded = Err(BlobError::Empty);
    let source = load_to(flash, &mut decoded);
    decoded.map(|params| (params, source))
}

/// [`load_from`], with the parameters decoded into `out`: the caller's place, so boot
/// holds no second copy of them on the stack.
pub fn load_to(flash: &impl ParamFlash, out: &mut Result<DeviceParams, BlobError>) -> ParamsSource {
    let (slot, _) = select_to(flash, out);
    match *out {
        Ok(_) => ParamsSource::Flash { slot },
        Err(reason) => {
            DeviceParams::decode_to(DEFAULT_BLOB, out);
            ParamsSource::BuiltInDefault { reason }
        }
    }
}

/// [`load_from`] the PARAMS region, for images that never write it (the region is taken
/// and released here; a second call, or a call after [`ParamRegion::take`], runs the
/// built-in default).
pub fn load() -> Result<(DeviceParams, ParamsSource), BlobError> {
    match ParamRegion::take() {
        Some(region) => load_from(&region),
        None => DeviceParams::decode(DEFAULT_BLOB).map(|p| {
            (
                p,
                ParamsSource::BuiltInDefault {
                    reason: BlobError::Empty,
                },
            )
        }),
    }
}
