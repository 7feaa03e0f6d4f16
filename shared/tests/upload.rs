//! Authenticated A/B parameter updates against a simulated flash, power cuts included.

use heapless::Vec;
use supine_core::blob::{BlobError, DeviceParams, MAX_BLOB_LEN};
use supine_core::protocol::golden::{BLOB, blob_example};
use supine_core::protocol::{PARAM_CHUNK_LEN, ParamBegin, ParamChunk, UploadError};
use supine_core::upload::{
    FlashError, KEY_LEN, ParamFlash, SLOT_COUNT, SLOT_LEN, Upload, last_counter, select, update_mac,
};

const KEY: [u8; KEY_LEN] = [7; KEY_LEN];

/// RAM-backed slots; `budget` bytes may be written before the "power" fails.
struct SimFlash {
    slots: [std::vec::Vec<u8>; SLOT_COUNT],
    budget: Option<usize>,
}

impl SimFlash {
    fn erased() -> Self {
        Self {
            slots: [vec![0xFF; SLOT_LEN], vec![0xFF; SLOT_LEN]],
            budget: None,
        }
    }

    fn with_plain_blob_in_slot0(blob: &[u8]) -> Self {
        let mut f = Self::erased();
        f.slots[0][..blob.len()].copy_from_slice(blob);
        f
    }
}

impl ParamFlash for SimFlash {
    fn slot(&self, slot: usize) -> &[u8] {
        &self.slots[slot]
    }
    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        self.slots[slot].fill(0xFF);
        Ok(())
    }
    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        let n = match self.budget {
            Some(b) if b < bytes.len() => b,
            _ => bytes.len(),
        };
        self.slots[slot][offset..offset + n].copy_from_slice(&bytes[..n]);
        if let Some(b) = self.budget.as_mut() {
            *b -= n;
            if n < bytes.len() {
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
    up.commit(&KEY, flash, running).map(|c| c.slot)
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
        up.commit(&KEY, &mut flash, Some(1)).map(|c| c.slot),
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
        up.commit(&KEY, &mut flash, Some(0)).map(|c| c.slot),
        Err(UploadError::NotStarted)
    );
    let boot = select(&flash).unwrap();
    assert_eq!(
        (boot.slot, boot.params.identity),
        (0, blob_example().unwrap().identity)
    );
}

#[test]
fn power_lost_at_any_point_of_the_write_leaves_a_bootable_device() {
    let new = blob_with(0x42);
    let old = blob_example().unwrap().identity;
    for budget in (0..new.len() + 12)
        .step_by(97)
        .chain([new.len(), new.len() + 11])
    {
        let mut flash = SimFlash::with_plain_blob_in_slot0(BLOB);
        // A committed update first, so the device runs slot 1 with counter 1.
        let first = blob_with(0x41);
        let mut up = Upload::new();
        upload(
            &mut up,
            &mut flash,
            Some(0),
            &first,
            1,
            update_mac(&KEY, 1, &first),
        )
        .unwrap();
        flash.budget = Some(budget);
        let result = upload(
            &mut up,
            &mut flash,
            Some(1),
            &new,
            2,
            update_mac(&KEY, 2, &new),
        );
        assert_eq!(result, Err(UploadError::Flash), "budget {budget}");
        flash.budget = None;
        let boot = select(&flash).unwrap();
        assert_eq!(
            (boot.slot, boot.params.identity),
            (1, [0x41; 16]),
            "budget {budget}"
        );
        assert_ne!(boot.params.identity, old);
    }
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
