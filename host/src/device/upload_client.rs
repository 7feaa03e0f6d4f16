//! The host side of an authenticated parameter update over the wire protocol.
//!
//! Sends `ParamBegin` (length, counter, HMAC), the blob in chunks, then `ParamCommit`, and
//! reports success only when the device acknowledges the new parameters' identity.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use heapless::Vec as HVec;
use supine_core::protocol::{
    DeviceToHost, HostToDevice, PARAM_CHUNK_LEN, ParamAck, ParamBegin, ParamChunk, ParamsIdentity,
    UploadError,
};
use supine_core::upload::{KEY_LEN, update_mac};

use crate::device::device_params::identity_hex;
use crate::device::link::{FrameReader, FrameWriter};

/// Where a committed update landed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Uploaded {
    /// The identity the device acknowledged.
    pub identity: ParamsIdentity,
    /// The flash slot it went to.
    pub slot: u8,
}

/// Uploads `blob` with `counter`, signed with `key`; waits up to `timeout` per step.
pub fn upload<R: Read, W: Write>(
    reader: &mut FrameReader<R>,
    writer: &mut FrameWriter<W>,
    blob: &[u8],
    expected_identity: ParamsIdentity,
    key: &[u8; KEY_LEN],
    counter: u32,
    timeout: Duration,
) -> Result<Uploaded> {
    let begin = ParamBegin {
        length_bytes: u32::try_from(blob.len()).map_err(|_| anyhow!("blob too long"))?,
        counter,
        hmac_sha256: update_mac(key, counter, blob),
    };
    writer.send(&HostToDevice::ParamBegin(begin))?;
    expect_ack(reader, timeout, |a| matches!(a, ParamAck::Begun)).map_err(|e| {
        // Refused before any byte arrived: this device cannot write its own flash.
        match e.downcast_ref::<Refused>() {
            Some(Refused(UploadError::UpdatesUnsupported)) => {
                e.context("write its parameters with `supine flash --probe` instead")
            }
            _ => e,
        }
    })?;
    for (i, piece) in blob.chunks(PARAM_CHUNK_LEN).enumerate() {
        let bytes = HVec::from_slice(piece).map_err(|_| anyhow!("chunk too long"))?;
        let offset_bytes = (i * PARAM_CHUNK_LEN) as u32;
        writer.send(&HostToDevice::ParamChunk(ParamChunk {
            offset_bytes,
            bytes,
        }))?;
        let end = offset_bytes + piece.len() as u32;
        expect_ack(reader, timeout, |a| *a == ParamAck::Received { bytes: end })?;
    }
    writer.send(&HostToDevice::ParamCommit)?;
    let ack = expect_ack(reader, timeout, |a| matches!(a, ParamAck::Committed { .. }))?;
    let ParamAck::Committed { identity, slot } = ack else {
        bail!("the device acknowledged something other than the commit");
    };
    if identity != expected_identity {
        bail!(
            "the device committed parameters {} but {} were sent",
            identity_hex(&identity),
            identity_hex(&expected_identity)
        );
    }
    Ok(Uploaded { identity, slot })
}

/// The device refused an upload step with this code.
#[derive(Debug, thiserror::Error)]
#[error("the device refused the update: {0}")]
pub struct Refused(pub UploadError);

/// Waits for the acknowledgement `want` accepts, skipping telemetry; a refusal is an error.
fn expect_ack<R: Read>(
    reader: &mut FrameReader<R>,
    timeout: Duration,
    want: impl Fn(&ParamAck) -> bool,
) -> Result<ParamAck> {
    let deadline = Instant::now() + timeout;
    loop {
        match reader.next_before(deadline)? {
            Some(DeviceToHost::ParamAck(ack)) if want(&ack) => return Ok(ack),
            Some(DeviceToHost::ParamAck(ack)) => {
                bail!("unexpected acknowledgement from the device: {ack:?}")
            }
            Some(DeviceToHost::ParamNack(e)) => return Err(Refused(e).into()),
            Some(_) => {}
            None => bail!(
                "no answer from the device within {}",
                crate::device::link::format_duration(timeout)
            ),
        }
    }
}

/// Longest device key file read, bytes: 64 hexadecimal digits leave room for any
/// whitespace a person adds, and a wrong file (a recording, a device) is refused unread.
pub const MAX_KEY_FILE_BYTES: u64 = 1024;

/// Reads a device key file: 64 hexadecimal digits (whitespace ignored).
pub fn read_key(path: &std::path::Path) -> Result<[u8; KEY_LEN]> {
    let text = crate::io::small_file::read_text(path, "device key", MAX_KEY_FILE_BYTES)?;
    parse_key(&text).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Parses 64 hexadecimal digits into a key (see [`supine_core::upload::parse_key`]).
pub fn parse_key(text: &str) -> Result<[u8; KEY_LEN]> {
    supine_core::upload::parse_key(text).map_err(|e| anyhow!("{e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_file_holds_64_hex_digits_with_any_whitespace() {
        let text = "00112233445566778899aabbccddeeff\n00112233445566778899AABBCCDDEEFF\n";
        let key = parse_key(text).unwrap();
        assert_eq!(key[0], 0x00);
        assert_eq!(key[15], 0xff);
        assert_eq!(key[31], 0xff);
        assert!(
            parse_key("abc")
                .unwrap_err()
                .to_string()
                .contains("found 3 characters")
        );
        assert!(parse_key(&"zz".repeat(32)).is_err());
    }
}
