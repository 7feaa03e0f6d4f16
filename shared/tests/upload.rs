//! Authenticated A/B parameter updates against a simulated flash, power cuts included.

use heapless::Vec;
use supine_core::blob::{BLOB_HEADER_LEN, BlobError, DeviceParams, MAX_BLOB_LEN};
use supine_core::protocol::golden::{BLOB, blob_example};
use supine_core::protocol::{PARAM_CHUNK_LEN, ParamBegin, ParamChunk, UploadError};
use supine_core::upload::{
    COMMIT_LEN, FlashError, KEY_LEN, ParamFlash, SLOT_COUNT, SLOT_LEN, Upload, last_counter,
    select, update_mac,
};

const KEY: [u8; KEY_LEN] = [7; KEY_LEN];

/// RAM-backed slots; `budget` bytes may be written before the "power" fails, after which
/// nothing more happens to them (every later erase or write fails without effect).
struct SimFlash {
    slots: [std::vec::Vec<u8>; SLOT_COUNT],
    budget: Option<usize>,
    dead: bool,
}

impl SimFlash {
    fn erased() -> Self {
        Self {
            slots: [vec![0xFF; SLOT_LEN], vec![0xFF; SLOT_LEN]],
            budget: None,
            dead: false,
        }
    }

    fn with_plain_blob_in_slot0(blob: &[u8]) -> Self {
        let mut f = Self::erased();
        f.slots[0][..blob.len()].copy_from_slice(blob);
        f
    }

    /// Power back on: the bytes as they were left, no budget.
    fn restored(&self) -> Self {
        Self {
            slots: self.slots.clone(),
            budget: None,
            dead: false,
        }
    }
}

impl ParamFlash for SimFlash {
    fn slot(&self, slot: usize) -> &[u8] {
        &self.slots[slot]
    }
    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        if self.dead {
            return Err(FlashError);
        }
        self.slots[slot].fill(0xFF);
        Ok(())
    }
    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        if self.dead {
            return Err(FlashError);
        }
        let n = match self.budget {
            Some(b) if b < bytes.len() => b,
            _ => bytes.len(),
        };
        self.slots[slot][offset..offset + n].copy_from_slice(&bytes[..n]);
        if let Some(b) = self.budget.as_mut() {
            *b -= n;
            if n < bytes.len() {
                self.dead = true;
                return Err(FlashError);
            }
        }
        Ok(())
    }
}

fn blob_with(identity_byte: u8) -> std::vec::Vec<u8> {
    let mut p = blob_example().unwrap();
    p.identity = [identity_byte; 16];
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let len = p.encode(&mut buf).unwrap();
    buf.truncate(len);
    buf
}

/// Sends a whole update; returns the outcome of the commit.
fn upload(
    up: &mut Upload,
    flash: &mut SimFlash,
    running: Option<u8>,
    blob: &[u8],
    counter: u32,
    mac: [u8; 32],
) -> Result<u8, UploadError> {
    up.begin(
        &ParamBegin {
            length_bytes: blob.len() as u32,
            counter,
            hmac_sha256: mac,
        },
        last_counter(flash),
    )?;
    for (i, piece) in blob.chunks(PARAM_CHUNK_LEN).enumerate() {
        let bytes = Vec::from_slice(piece).unwrap();
        up.chunk(&ParamChunk {
            offset_bytes: (i * PARAM_CHUNK_LEN) as u32,
            bytes,
        })?;
    }
    commit(up, flash, running, blob)
}

/// Commits with running parameters unlike any blob's, and checks what `commit` promises
/// of them: replaced by exactly the blob's on success, untouched on any refusal.
fn commit(
    up: &mut Upload,
    flash: &mut SimFlash,
    running: Option<u8>,
    blob: &[u8],
) -> Result<u8, UploadError> {
    let mut params = blob_example().unwrap();
    params.identity = [0xEE; 16];
    let before = params;
    let outcome = up.commit(&KEY, flash, running, &mut params);
    match outcome {
        Ok(c) => {
            assert_eq!(params, DeviceParams::decode(blob).unwrap());
            assert_eq!(c.identity, params.identity);
        }
        Err(_) => assert_eq!(params, before, "a refused upload changed the parameters"),
    }
    outcome.map(|c| c.slot)
}

#[test]
fn a_signed_update_goes_to_the_other_slot_and_wins_at_the_next_boot() {
    let mut flash = SimFlash::with_plain_blob_in_slot0(BLOB);
    let boot = select(&flash).unwrap();
    assert_eq!((boot.slot, boot.counter), (0, 0));
    let new = blob_with(0x42);
    let mut up = Upload::new();
    let slot = upload(
        &mut up,
        &mut flash,
        Some(0),
        &new,
        1,
        update_mac(&KEY, 1, &new),
    )
    .unwrap();
    assert_eq!(slot, 1);
    let boot = select(&flash).unwrap();
    assert_eq!(
        (boot.slot, boot.counter, boot.params.identity),
        (1, 1, [0x42; 16])
    );
    // The next update goes back to slot 0 and wins with its higher counter.
    let newer = blob_with(0x43);
    assert_eq!(
        upload(
            &mut up,
            &mut flash,
            Some(1),
            &newer,
            2,
            update_mac(&KEY, 2, &newer)
        ),
        Ok(0)
    );
    assert_eq!(select(&flash).unwrap().params.identity, [0x43; 16]);
}

#[test]
fn unsigned_replayed_truncated_and_corrupted_updates_change_nothing() {
    let mut flash = SimFlash::with_plain_blob_in_slot0(BLOB);
    let mut up = Upload::new();
    let new = blob_with(0x42);
    upload(
        &mut up,
        &mut flash,
        Some(0),
        &new,
        5,
        update_mac(&KEY, 5, &new),
    )
    .unwrap();
    let before = (flash.slots[0].clone(), flash.slots[1].clone());
    let unchanged = |f: &SimFlash| (f.slots[0].clone(), f.slots[1].clone()) == before;

    let other = blob_with(0x44);
    let wrong_key = update_mac(&[8; KEY_LEN], 6, &other);
    assert_eq!(
        upload(&mut up, &mut flash, Some(1), &other, 6, wrong_key),
        Err(UploadError::BadSignature)
    );
    assert!(unchanged(&flash));
    // Replaying the accepted update, or signing an old counter, is refused.
    assert_eq!(
        upload(
            &mut up,
            &mut flash,
            Some(1),
            &new,
            5,
            update_mac(&KEY, 5, &new)
        ),
        Err(UploadError::Replayed)
    );
    assert_eq!(
        upload(
            &mut up,
            &mut flash,
            Some(1),
            &other,
            3,
            update_mac(&KEY, 3, &other)
        ),
        Err(UploadError::Replayed)
    );
    assert!(unchanged(&flash));
    // A byte changed in transit breaks the signature.
    let mut corrupted = other.clone();
    corrupted[100] ^= 1;
    assert_eq!(
        upload(
            &mut up,
            &mut flash,
            Some(1),
            &corrupted,
            6,
            update_mac(&KEY, 6, &other)
        ),
        Err(UploadError::BadSignature)
    );
    // Commit before all bytes arrived.
    let mac = update_mac(&KEY, 6, &other);
    up.begin(
        &ParamBegin {
            length_bytes: other.len() as u32,
            counter: 6,
            hmac_sha256: mac,
        },
        last_counter(&flash),
    )
    .unwrap();
    up.chunk(&ParamChunk {
        offset_bytes: 0,
        bytes: Vec::from_slice(&other[..64]).unwrap(),
    })
    .unwrap();
    assert_eq!(
        commit(&mut up, &mut flash, Some(1), &other),
        Err(UploadError::Incomplete)
    );
    // Chunks out of order, and chunks without a begin.
    up.begin(
        &ParamBegin {
            length_bytes: other.len() as u32,
            counter: 6,
            hmac_sha256: mac,
        },
        last_counter(&flash),
    )
    .unwrap();
    let piece = Vec::from_slice(&other[..10]).unwrap();
    assert_eq!(
        up.chunk(&ParamChunk {
            offset_bytes: 10,
            bytes: piece.clone()
        }),
        Err(UploadError::OutOfOrder)
    );
    up.abort();
    assert_eq!(
        up.chunk(&ParamChunk {
            offset_bytes: 0,
            bytes: piece
        }),
        Err(UploadError::NotStarted)
    );
    assert!(unchanged(&flash));
    // A well-signed but invalid blob is refused with the blob's own reason.
    let mut bad = other.clone();
    bad[0] = b'X';
    assert_eq!(
        upload(
            &mut up,
            &mut flash,
            Some(1),
            &bad,
            6,
            update_mac(&KEY, 6, &bad)
        ),
        Err(UploadError::Blob(BlobError::BadMagic))
    );
    assert_eq!(
        up.begin(
            &ParamBegin {
                length_bytes: 0,
                counter: 9,
                hmac_sha256: mac
            },
            5
        ),
        Err(UploadError::BadLength)
    );
    assert!(unchanged(&flash));
}

#[test]
fn a_cut_transfer_followed_by_a_reset_keeps_the_running_parameters() {
    let mut flash = SimFlash::with_plain_blob_in_slot0(BLOB);
    let new = blob_with(0x42);
    let mut up = Upload::new();
    let mac = update_mac(&KEY, 1, &new);
    up.begin(
        &ParamBegin {
            length_bytes: new.len() as u32,
            counter: 1,
            hmac_sha256: mac,
        },
        0,
    )
    .unwrap();
    up.chunk(&ParamChunk {
        offset_bytes: 0,
        bytes: Vec::from_slice(&new[..128]).unwrap(),
    })
    .unwrap();
    // Reset: the RAM session is gone (a fresh one starts empty), flash untouched.
    let mut up = Upload::new();
    assert_eq!(
        commit(&mut up, &mut flash, Some(0), &new),
        Err(UploadError::NotStarted)
    );
    let boot = select(&flash).unwrap();
    assert_eq!(
        (boot.slot, boot.params.identity),
        (0, blob_example().unwrap().identity)
    );
}

#[test]
fn an_empty_region_reports_why_and_a_garbled_slot0_names_its_error() {
    assert_eq!(select(&SimFlash::erased()), Err(BlobError::Empty));
    let mut flipped = BLOB.to_vec();
    flipped[40] ^= 0x10;
    assert_eq!(
        select(&SimFlash::with_plain_blob_in_slot0(&flipped)),
        Err(BlobError::BadCrc)
    );
    let params: DeviceParams = select(&SimFlash::with_plain_blob_in_slot0(BLOB))
        .unwrap()
        .params;
    assert_eq!(params, blob_example().unwrap());
}

/// The three states a device can run in: slot A (plain, as a programmer places it),
/// slot B (committed after an update from slot A), and the built-in parameters over an
/// erased flash. Returns the flash and the slot running (`None` for the built-in ones).
fn starting_states() -> [(&'static str, SimFlash, Option<u8>); 3] {
    let mut from_b = SimFlash::with_plain_blob_in_slot0(BLOB);
    let first = blob_with(0x41);
    upload(
        &mut Upload::new(),
        &mut from_b,
        Some(0),
        &first,
        1,
        update_mac(&KEY, 1, &first),
    )
    .unwrap();
    [
        ("slot A", SimFlash::with_plain_blob_in_slot0(BLOB), Some(0)),
        ("slot B", from_b, Some(1)),
        ("built-in", SimFlash::erased(), None),
    ]
}

/// What boots from `flash`: the identity and slot, or the reason nothing does.
fn boots(flash: &SimFlash) -> Result<([u8; 16], u8), BlobError> {
    select(flash).map(|a| (a.params.identity, a.slot))
}

#[test]
fn power_lost_at_every_byte_of_an_update_boots_what_ran_before_from_every_state() {
    // The header goes last: a cut anywhere before its last byte leaves no valid blob in
    // the slot written, not even one that boot would take as slot A's plain blob.
    let new = blob_with(0x42);
    let total = new.len() + COMMIT_LEN;
    let mut tried = 0;
    for (name, flash, running) in starting_states() {
        let before = boots(&flash);
        for budget in 0..=total {
            let mut f = flash.restored();
            f.budget = Some(budget);
            let result = upload(
                &mut Upload::new(),
                &mut f,
                running,
                &new,
                5,
                update_mac(&KEY, 5, &new),
            );
            let after = boots(&f.restored());
            if budget < total {
                assert_eq!(result, Err(UploadError::Flash), "{name}, budget {budget}");
                // The same parameters run; with the built-in ones the reason they give for
                // slot A may now name the partial blob there.
                assert_eq!(after.ok(), before.ok(), "{name}, budget {budget}");
            } else {
                assert!(result.is_ok(), "{name}");
                assert_eq!(after.map(|(id, _)| id), Ok([0x42; 16]), "{name}");
            }
            tried += 1;
        }
    }
    println!("power cuts at every byte of an update: {tried} tried, {tried} held");
}

#[test]
fn an_announced_length_other_than_the_headers_is_refused_before_flash_is_touched() {
    // Every upload length from 1 byte to the largest: a prefix of the blob, the blob, or
    // the blob followed by padding, each signed by the key holder.
    let blob = blob_with(0x42);
    for (name, flash, running) in starting_states() {
        for len in 1..=MAX_BLOB_LEN {
            let mut sent = blob.clone();
            sent.resize(len, if len % 2 == 0 { 0 } else { 0xFF });
            let mut f = flash.restored();
            // No budget at all: any write fails and shows as `Flash`.
            f.budget = Some(0);
            let result = upload(
                &mut Upload::new(),
                &mut f,
                running,
                &sent,
                9,
                update_mac(&KEY, 9, &sent),
            );
            let expected = match len {
                l if l < BLOB_HEADER_LEN => Err(UploadError::Blob(BlobError::Truncated)),
                l if l == blob.len() => Err(UploadError::Flash),
                _ => Err(UploadError::LengthMismatch),
            };
            assert_eq!(result, expected, "{name}, {len} bytes");
            assert!(
                f.slots == flash.slots || len == blob.len(),
                "{name}, {len} bytes"
            );
        }
    }
}
