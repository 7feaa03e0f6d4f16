//! The model parameters the device runs with.
//!
//! Today: the realization baked into the image by `firmware/build.rs` (the paper's
//! litter-board preset, discretized at [`SAMPLE_RATE_HZ`] on the build machine and encoded
//! with postcard). Decoding checks it once at boot, so the hot path cannot fail.
//!
//! The full parameter blob (`supine_core::blob`) lives in the PARAMS region of `memory.x`
//! ([`region`]); [`stored_blob`] validates it. The product image reports its state in the
//! greeting; running from it is the next step.

use core::fmt;

use supine_core::blob::{BlobError, DeviceParams};
use supine_core::model::{DeviceRealization, RealizationError};
use supine_core::protocol::{ParamsIdentity, ParamsSource};

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

unsafe extern "C" {
    /// First byte of the PARAMS region (from `memory.x`).
    static __params_start: u8;
    /// One past the last byte of the PARAMS region.
    static __params_end: u8;
}

/// The PARAMS region of `memory.x`, where a parameter blob is stored (under QEMU:
/// `-device loader,file=<blob>,addr=0x70000`). An erased or blank region reads as
/// [`BlobError::Empty`] through [`stored_blob`].
pub fn region() -> &'static [u8] {
    // Only the symbols' addresses are used, never their values.
    let start = &raw const __params_start as usize;
    let end = &raw const __params_end as usize;
    // SAFETY: [start, end) is the PARAMS region that memory.x reserves outside FLASH and
    // RAM: readable memory that holds no Rust object. Nothing writes it while the firmware
    // runs (the loader or the programmer fills it before reset), so a shared `'static`
    // slice of it is sound. A future in-field update must not hold this slice while it
    // writes the region.
    unsafe { core::slice::from_raw_parts(start as *const u8, end.saturating_sub(start)) }
}

/// Reads and validates the parameter blob in the PARAMS region.
pub fn stored_blob() -> Result<DeviceParams, BlobError> {
    DeviceParams::decode(region())
}

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

/// The parameters to run with and where they came from: the blob at the start of the
/// PARAMS region if it is valid (slot 0), else the built-in default with the reason the
/// flash blob was refused. Errs only if the built-in default itself is refused, which
/// `firmware/build.rs` has already ruled out when it built it.
///
/// Issue 6 (A/B slots, authenticated upload) replaces the slot choice here only.
pub fn load() -> Result<(DeviceParams, ParamsSource), BlobError> {
    match stored_blob() {
        Ok(params) => Ok((params, ParamsSource::Flash { slot: 0 })),
        Err(reason) => {
            DeviceParams::decode(DEFAULT_BLOB).map(|p| (p, ParamsSource::BuiltInDefault { reason }))
        }
    }
}
