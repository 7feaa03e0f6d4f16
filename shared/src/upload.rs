//! Authenticated parameter updates into two flash slots (A/B), and choosing the slot to
//! run at boot.
//!
//! An update is received whole into RAM, then checked before flash is touched: length,
//! HMAC-SHA256 over the counter and the blob with the device's key, a counter above every
//! one accepted before (against replay), and the blob's own validation. Only then is the
//! slot that is not running erased and written: the blob, then a commit record (magic,
//! counter, CRC-32 of blob and counter), the blob's header last, then read back. A cut
//! transfer leaves flash as it was; a power cut mid-write leaves the new slot without a
//! valid blob or commit record, and the slot that ran before is chosen again at the next
//! boot. A write that fails its read-back is scrubbed, so a refused update never boots.
//!
//! Choosing at boot: the committed slot with the highest counter; else a plain blob
//! without a commit record in slot 0 (as placed by a programmer or QEMU's loader); else
//! nothing, and the device runs its built-in parameters.

use hmac::{Hmac, KeyInit, Mac};
use sha2::Sha256;

use crate::blob::{BLOB_HEADER_LEN, BlobError, DeviceParams, MAX_BLOB_LEN, announced_len};
use crate::protocol::{ParamAck, ParamBegin, ParamChunk, ParamsIdentity, UploadError};

/// Number of parameter slots.
pub const SLOT_COUNT: usize = 2;
/// Bytes per slot: half of the 64 KiB PARAMS region.
pub const SLOT_LEN: usize = 32 * 1024;
/// First bytes of a commit record.
pub const COMMIT_MAGIC: [u8; 4] = *b"CMIT";
/// Commit record: magic, counter (u32 LE), CRC-32 of blob followed by counter (u32 LE).
pub const COMMIT_LEN: usize = 12;
/// Length of the device key, bytes.
pub const KEY_LEN: usize = 32;

/// The PARAMS region as two slots the device can read, erase and write.
pub trait ParamFlash {
    /// The whole slot (`SLOT_LEN` bytes), as stored.
    fn slot(&self, slot: usize) -> &[u8];
    /// Erases a slot (to 0xFF).
    fn erase(&mut self, slot: usize) -> Result<(), FlashError>;
    /// Writes bytes at an offset within an erased slot.
    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError>;
}

/// A flash operation failed (or power was lost, in tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlashError;

/// The parameters chosen at boot and where they came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActiveParams {
    /// The validated parameters.
    pub params: DeviceParams,
    /// The slot they were read from.
    pub slot: u8,
    /// Their update counter (0 for a blob without a commit record).
    pub counter: u32,
}

/// The counter of a slot's commit record, if the record is sound (its magic and CRC
/// match); the blob itself is not checked here.
fn commit_counter(bytes: &[u8]) -> Option<u32> {
    let len = announced_len(bytes)?;
    let blob = bytes.get(..len)?;
    let record = bytes.get(len..len + COMMIT_LEN)?;
    let word =
        |i: usize| u32::from_le_bytes([record[i], record[i + 1], record[i + 2], record[i + 3]]);
    let counter = word(4);
    (record[..4] == COMMIT_MAGIC && word(8) == commit_crc(blob, counter)).then_some(counter)
}

/// The commit record that follows `blob` in its slot once it is committed with `counter`:
/// written by the device after an update, and by the host into a region image.
pub fn commit_record(blob: &[u8], counter: u32) -> [u8; COMMIT_LEN] {
    let mut record = [0u8; COMMIT_LEN];
    record[..4].copy_from_slice(&COMMIT_MAGIC);
    record[4..8].copy_from_slice(&counter.to_le_bytes());
    record[8..].copy_from_slice(&commit_crc(blob, counter).to_le_bytes());
    record
}

fn commit_crc(blob: &[u8], counter: u32) -> u32 {
    let mut digest = crate::blob::CRC32.digest();
    digest.update(blob);
    digest.update(&counter.to_le_bytes());
    digest.finalize()
}

/// The slot to run at boot, or the reason (slot 0's) there is none.
pub fn select(flash: &impl ParamFlash) -> Result<ActiveParams, BlobError> {
    let mut decoded = Err(BlobError::Empty);
    let (slot, counter) = select_to(flash, &mut decoded);
    Ok(ActiveParams {
        params: decoded?,
        slot,
        counter,
    })
}

/// [`select`], with the parameters decoded into `out` (or slot 0's error, the reason no
/// slot runs); returns the slot and its counter. The slot is chosen by counters alone and
/// only it is decoded again, into the caller's place: the device boots with no second
/// copy of the parameters on its stack.
pub fn select_to(flash: &impl ParamFlash, out: &mut Result<DeviceParams, BlobError>) -> (u8, u32) {
    let mut best: Option<(usize, u32)> = None;
    for slot in 0..SLOT_COUNT {
        if let Some(counter) = committed_counter(flash.slot(slot), out)
            && best.is_none_or(|(_, c)| counter > c)
        {
            best = Some((slot, counter));
        }
    }
    // No committed slot: slot 0's blob, which then has no valid record (a plain blob), or
    // slot 0's error as the reason.
    let (slot, counter) = best.unwrap_or((0, 0));
    DeviceParams::decode_to(flash.slot(slot), out);
    (slot as u8, counter)
}

/// The highest counter any committed slot carries (0 if none): updates must exceed it.
// Out of line: the parameters it decodes each slot into (1.7 KB) then stay off the frame
// of its caller, the device's main loop, which an upload's commit builds on.
#[inline(never)]
pub fn last_counter(flash: &impl ParamFlash) -> u32 {
    highest_counter(flash, &mut Err(BlobError::Empty))
}

/// [`last_counter`], decoding each slot into `scratch` (left holding the last slot
/// decoded): a commit lends the place its new parameters are decoded into next.
fn highest_counter(flash: &impl ParamFlash, scratch: &mut Result<DeviceParams, BlobError>) -> u32 {
    (0..SLOT_COUNT)
        .filter_map(|slot| committed_counter(flash.slot(slot), scratch))
        .max()
        .unwrap_or(0)
}

/// The counter of a slot holding a valid committed blob (its parameters decoded into
/// `scratch`). The record is checked first, so a slot without one is not decoded.
fn committed_counter(bytes: &[u8], scratch: &mut Result<DeviceParams, BlobError>) -> Option<u32> {
    let counter = commit_counter(bytes)?;
    DeviceParams::decode_to(bytes, scratch);
    scratch.is_ok().then_some(counter)
}

/// A device key file that is not 64 hexadecimal digits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyFileError {
    /// Characters other than whitespace that the file holds.
    pub found_chars: usize,
}

impl core::fmt::Display for KeyFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "expected {} hexadecimal digits (a {KEY_LEN}-byte key), found {} characters",
            2 * KEY_LEN,
            self.found_chars
        )
    }
}

/// Parses a device key file: 64 hexadecimal digits, whitespace anywhere ignored. The host
/// (signing) and the firmware's build script (provisioning) read the same files with it.
pub fn parse_key(text: &str) -> Result<[u8; KEY_LEN], KeyFileError> {
    let mut key = [0u8; KEY_LEN];
    let mut found = 0usize;
    let mut all_hex = true;
    for c in text.chars().filter(|c| !c.is_whitespace()) {
        match (c.to_digit(16), key.get_mut(found / 2)) {
            (Some(d), Some(byte)) => *byte = (*byte << 4) | d as u8,
            _ => all_hex = false,
        }
        found += 1;
    }
    if !all_hex || found != 2 * KEY_LEN {
        return Err(KeyFileError { found_chars: found });
    }
    Ok(key)
}

/// HMAC-SHA256 of the counter (u32 LE) followed by the blob, with the device key.
pub fn update_mac(key: &[u8; KEY_LEN], counter: u32, blob: &[u8]) -> [u8; 32] {
    let mut out = [0u8; 32];
    if let Some(mut mac) = new_mac(key, counter) {
        mac.update(blob);
        out.copy_from_slice(&mac.finalize().into_bytes());
    }
    out
}

/// HMAC keyed with the device key, primed with the counter. HMAC accepts keys of any
/// length, so `None` cannot happen; callers treat it as a failed signature regardless.
fn new_mac(key: &[u8; KEY_LEN], counter: u32) -> Option<Hmac<Sha256>> {
    let mut mac = <Hmac<Sha256> as KeyInit>::new_from_slice(key).ok()?;
    mac.update(&counter.to_le_bytes());
    Some(mac)
}

/// An update being received: the blob accumulates in RAM until it is committed.
#[derive(Clone, Debug)]
pub struct Upload {
    buf: [u8; MAX_BLOB_LEN],
    expected: usize,
    received: usize,
    counter: u32,
    mac: [u8; 32],
    open: bool,
}

impl Default for Upload {
    fn default() -> Self {
        Self::new()
    }
}

/// A committed update: where it went (the parameters are the caller's, see
/// [`Upload::commit`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Committed {
    /// The new parameters' identity.
    pub identity: ParamsIdentity,
    /// The slot they went to.
    pub slot: u8,
    /// Their counter.
    pub counter: u32,
}

impl Upload {
    /// No update in progress.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_BLOB_LEN],
            expected: 0,
            received: 0,
            counter: 0,
            mac: [0; 32],
            open: false,
        }
    }

    /// Drops a transfer in progress.
    pub fn abort(&mut self) {
        self.open = false;
        self.received = 0;
    }

    /// Opens an update (replacing any unfinished one).
    pub fn begin(
        &mut self,
        begin: &ParamBegin,
        last_counter: u32,
    ) -> Result<ParamAck, UploadError> {
        self.abort();
        let len = begin.length_bytes as usize;
        if len == 0 || len > MAX_BLOB_LEN {
            return Err(UploadError::BadLength);
        }
        if begin.counter <= last_counter {
            return Err(UploadError::Replayed);
        }
        self.expected = len;
        self.counter = begin.counter;
        self.mac = begin.hmac_sha256;
        self.open = true;
        Ok(ParamAck::Begun)
    }

    /// Appends a chunk, which must continue where the previous one ended; one that would
    /// pass the announced length aborts the upload.
    pub fn chunk(&mut self, chunk: &ParamChunk) -> Result<ParamAck, UploadError> {
        if !self.open {
            return Err(UploadError::NotStarted);
        }
        if chunk.offset_bytes as usize != self.received {
            return Err(UploadError::OutOfOrder);
        }
        let end = self.received + chunk.bytes.len();
        let Some(dst) = self
            .buf
            .get_mut(self.received..end)
            .filter(|_| end <= self.expected)
        else {
            self.abort();
            return Err(UploadError::ChunkPastEnd);
        };
        dst.copy_from_slice(&chunk.bytes);
        self.received = end;
        Ok(ParamAck::Received { bytes: end as u32 })
    }

    /// Verifies the received blob and, only if everything holds, writes it to the slot not
    /// running (`running_slot`, `None` for the built-in parameters), reads it back and
    /// replaces `params`, the running parameters, with it. Any refusal leaves `params`
    /// untouched. The new parameters are decoded once, beside the running ones, and
    /// copied over them: the device holds no other copy (its RAM budget, BENCHMARKS.md).
    ///
    /// Checks, each refused with its own code before flash is touched: all bytes arrived,
    /// the HMAC, the counter, the blob's own validation, and that its header announces
    /// the length `ParamBegin` did.
    pub fn commit(
        &mut self,
        key: &[u8; KEY_LEN],
        flash: &mut impl ParamFlash,
        running_slot: Option<u8>,
        params: &mut DeviceParams,
    ) -> Result<Committed, UploadError> {
        if !self.open {
            return Err(UploadError::NotStarted);
        }
        if self.received != self.expected {
            return Err(UploadError::Incomplete);
        }
        self.open = false;
        self.verify_mac(key)?;
        self.store(flash, running_slot, params)
    }

    /// The HMAC. Out of line: its state and the new parameters take turns on the stack.
    #[inline(never)]
    fn verify_mac(&self, key: &[u8; KEY_LEN]) -> Result<(), UploadError> {
        let mut mac = new_mac(key, self.counter).ok_or(UploadError::BadSignature)?;
        mac.update(self.blob());
        mac.verify_slice(&self.mac)
            .map_err(|_| UploadError::BadSignature)
    }

    /// The counter, the blob's validation and length, then the write and, last, `params`
    /// replaced. The slots' counters and the new parameters are decoded into one place.
    #[inline(never)]
    fn store(
        &self,
        flash: &mut impl ParamFlash,
        running_slot: Option<u8>,
        params: &mut DeviceParams,
    ) -> Result<Committed, UploadError> {
        let mut decoded = Err(BlobError::Empty);
        if self.counter <= highest_counter(flash, &mut decoded) {
            return Err(UploadError::Replayed);
        }
        let blob = self.blob();
        DeviceParams::decode_to(blob, &mut decoded);
        // A header that announces another length than `ParamBegin` did: a valid blob with
        // bytes after it, or one cut short (its only fault then is being truncated).
        let other_len = announced_len(blob).is_some_and(|len| len != blob.len());
        if other_len && matches!(decoded, Ok(_) | Err(BlobError::Truncated)) {
            return Err(UploadError::LengthMismatch);
        }
        // Borrowed, not moved: a move would be a second copy on the device's stack.
        let new = match &decoded {
            Ok(new) => new,
            Err(e) => return Err(UploadError::Blob(*e)),
        };
        let target = match running_slot {
            Some(0) => 1,
            _ => 0,
        };
        if write_committed(flash, target, blob, self.counter).is_err() {
            // Whatever reached the slot is refused, so it must not boot: on a device
            // running its built-in parameters the slot is A, whose plain blob would.
            scrub(flash, target);
            return Err(UploadError::Flash);
        }
        *params = *new;
        Ok(Committed {
            identity: params.identity,
            slot: target as u8,
            counter: self.counter,
        })
    }

    /// The bytes received.
    fn blob(&self) -> &[u8] {
        self.buf.get(..self.expected).unwrap_or(&[])
    }
}

/// Erases `slot` and writes `blob` and its commit record, then reads both back.
///
/// The header goes last: until its final byte is written the slot holds no valid blob,
/// so a power cut at any point leaves nothing that boots (slot A's plain blob included,
/// which boot would otherwise accept without a commit record).
fn write_committed(
    flash: &mut impl ParamFlash,
    slot: usize,
    blob: &[u8],
    counter: u32,
) -> Result<(), FlashError> {
    let (header, payload) = blob.split_at(BLOB_HEADER_LEN.min(blob.len()));
    let record = commit_record(blob, counter);
    flash.erase(slot)?;
    flash.write(slot, header.len(), payload)?;
    flash.write(slot, blob.len(), &record)?;
    flash.write(slot, 0, header)?;
    let stored = flash.slot(slot);
    if stored.get(..blob.len()) != Some(blob) || commit_counter(stored) != Some(counter) {
        return Err(FlashError);
    }
    Ok(())
}

/// Makes `slot` unbootable after a failed write: erased again, or, if the erase fails
/// too, its header programmed to zeros (programming only clears bits, so that works on
/// a slot that cannot be erased), which reads as a blank slot.
fn scrub(flash: &mut impl ParamFlash, slot: usize) {
    if flash.erase(slot).is_err() {
        // If this fails too, the flash takes neither erase nor write and nothing more can
        // be done from here; boot validates every slot again anyway.
        let _ = flash.write(slot, 0, &[0; BLOB_HEADER_LEN]);
    }
}
