//! Upload attacks through the monitor, from every state a device can run in: a plain blob
//! in slot A (as QEMU's loader or a programmer places it), a committed slot A, a committed
//! slot B, and the built-in parameters over an erased flash.
//!
//! Every attack must be answered with its own code, counted in `uploads_rejected`, leave
//! the device greeting with the same parameters, and change nothing that boots: flash
//! untouched, or, when the flash itself fails, the slot written left unbootable. Each
//! starting state's device takes every attack in turn (as a device under a stream of
//! attacks would) and still takes a genuine upload afterwards.

mod support;

use supine_core::blob::{BlobError, MAX_BLOB_LEN};
use supine_core::protocol::{
    DeviceToHost, Greeting, HostToDevice, PARAM_CHUNK_LEN, ParamAck, ParamChunk, ParamsSource,
    UploadError,
};
use supine_core::upload::KEY_LEN;
use support::*;

/// Where a device starts.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Start {
    PlainSlotA,
    CommittedSlotA,
    SlotB,
    Defaults,
}

const STARTS: [Start; 4] = [
    Start::PlainSlotA,
    Start::CommittedSlotA,
    Start::SlotB,
    Start::Defaults,
];

/// Counter of the committed slot A; slot B's is one more.
const COUNTER_A: u32 = 1;
/// A counter above every one in the starting states.
const FRESH: u32 = 10;

impl Start {
    /// The flash of this state.
    fn slots(self) -> Vec<Vec<u8>> {
        let boot = encode(&boot_params());
        match self {
            Start::PlainSlotA => plain_slot_a(&boot),
            Start::CommittedSlotA => {
                let mut slots = plain_slot_a(&[]);
                commit_into(&mut slots, 0, &boot, COUNTER_A);
                slots
            }
            Start::SlotB => {
                let mut slots = plain_slot_a(&[]);
                commit_into(&mut slots, 0, &boot, COUNTER_A);
                commit_into(&mut slots, 1, &slot_b_blob(), COUNTER_A + 1);
                slots
            }
            Start::Defaults => plain_slot_a(&[]),
        }
    }

    /// The highest counter the device has accepted.
    fn last_counter(self) -> u32 {
        match self {
            Start::PlainSlotA | Start::Defaults => 0,
            Start::CommittedSlotA => COUNTER_A,
            Start::SlotB => COUNTER_A + 1,
        }
    }

    /// What a device in this state runs: identity and source.
    fn runs(self) -> (supine_core::protocol::ParamsIdentity, ParamsSource) {
        match self {
            Start::PlainSlotA | Start::CommittedSlotA => {
                (BOOT_IDENTITY, ParamsSource::Flash { slot: 0 })
            }
            Start::SlotB => (SLOT_B_IDENTITY, ParamsSource::Flash { slot: 1 }),
            Start::Defaults => (
                BUILTIN_IDENTITY,
                ParamsSource::BuiltInDefault {
                    reason: BlobError::Empty,
                },
            ),
        }
    }
}

fn slot_b_blob() -> Vec<u8> {
    let mut params = upload_params();
    params.identity = SLOT_B_IDENTITY;
    encode(&params)
}

fn upload_blob() -> Vec<u8> {
    encode(&upload_params())
}

/// The device's answers to upload steps among `messages`.
fn answers(messages: &[DeviceToHost]) -> Vec<Result<ParamAck, UploadError>> {
    messages
        .iter()
        .filter_map(|m| match m {
            DeviceToHost::ParamAck(a) => Some(Ok(*a)),
            DeviceToHost::ParamNack(e) => Some(Err(*e)),
            _ => None,
        })
        .collect()
}

/// One attack: the messages and the answers the device must give, step by step.
struct Attack {
    name: String,
    messages: Vec<HostToDevice>,
    answers: Vec<Result<ParamAck, UploadError>>,
}

/// The answers to a transfer of `blob` that goes through.
fn transfer_answers(blob: &[u8]) -> Vec<Result<ParamAck, UploadError>> {
    transfer_acks(blob)
        .into_iter()
        .map(|m| match m {
            DeviceToHost::ParamAck(a) => Ok(a),
            other => panic!("{other:?}"),
        })
        .collect()
}

/// Signed by the key holder, whole transfer, refused at the commit with `error`.
fn refused_at_commit(
    name: String,
    blob: &[u8],
    counter: u32,
    key: &[u8; KEY_LEN],
    error: UploadError,
) -> Attack {
    let mut answers = transfer_answers(blob);
    answers.push(Err(error));
    Attack {
        name,
        messages: upload_messages(blob, counter, key),
        answers,
    }
}

/// A begin refused with `error`: every chunk and the commit then find no upload.
fn refused_at_begin(name: String, begin: HostToDevice, blob: &[u8], error: UploadError) -> Attack {
    let mut messages = vec![begin];
    messages.extend(chunks(blob));
    messages.push(HostToDevice::ParamCommit);
    let mut answers = vec![Err(error)];
    answers.extend(std::iter::repeat_n(
        Err(UploadError::NotStarted),
        messages.len() - 1,
    ));
    Attack {
        name,
        messages,
        answers,
    }
}

/// Every attack that leaves flash untouched, for a device that has accepted counters up
/// to `last` (the counter of its slot B's upload, if any, is `last`).
fn attacks(start: Start) -> Vec<Attack> {
    let key = development_key();
    let blob = upload_blob();
    let n_chunks = blob.len().div_ceil(PARAM_CHUNK_LEN);
    let last = start.last_counter();
    let mut out = Vec::new();

    // Steps with no upload open (first: the attacks below may leave one open).
    out.push(Attack {
        name: "commit without begin".into(),
        messages: vec![HostToDevice::ParamCommit],
        answers: vec![Err(UploadError::NotStarted)],
    });
    out.push(Attack {
        name: "chunk without begin".into(),
        messages: chunks(&blob)[..1].to_vec(),
        answers: vec![Err(UploadError::NotStarted)],
    });
    // Wrong keys: every single-bit change of the device key.
    for bit in 0..KEY_LEN * 8 {
        let mut wrong = key;
        wrong[bit / 8] ^= 1 << (bit % 8);
        out.push(refused_at_commit(
            format!("key bit {bit} flipped"),
            &blob,
            FRESH,
            &wrong,
            UploadError::BadSignature,
        ));
    }
    // A MAC with one bit changed, and the MAC of another counter.
    let good = begin(&blob, FRESH, &key);
    for bit in 0..256 {
        let HostToDevice::ParamBegin(mut b) = good.clone() else {
            unreachable!()
        };
        b.hmac_sha256[bit / 8] ^= 1 << (bit % 8);
        let mut a = refused_at_commit(
            format!("MAC bit {bit} flipped"),
            &blob,
            FRESH,
            &key,
            UploadError::BadSignature,
        );
        a.messages[0] = HostToDevice::ParamBegin(b);
        out.push(a);
    }
    // A bit changed in transit: every bit of the blob.
    for bit in 0..blob.len() * 8 {
        let mut altered = blob.clone();
        altered[bit / 8] ^= 1 << (bit % 8);
        let mut a = refused_at_commit(
            format!("blob bit {bit} flipped in transit"),
            &altered,
            FRESH,
            &key,
            UploadError::BadSignature,
        );
        a.messages[0] = good.clone();
        out.push(a);
    }
    // Replays and rollbacks: counters not above the last accepted one, the genuine
    // upload that put slot B's blob there among them.
    for counter in [0, last.saturating_sub(1), last] {
        out.push(refused_at_begin(
            format!("counter {counter} (last {last})"),
            begin(&blob, counter, &key),
            &blob,
            UploadError::Replayed,
        ));
    }
    if start == Start::SlotB {
        let b = slot_b_blob();
        out.push(refused_at_begin(
            "slot B's own upload again".into(),
            begin(&b, last, &key),
            &b,
            UploadError::Replayed,
        ));
        let a = encode(&boot_params());
        out.push(refused_at_begin(
            "slot A's upload again (a rollback)".into(),
            begin(&a, COUNTER_A, &key),
            &a,
            UploadError::Replayed,
        ));
    }
    // Announced lengths out of range.
    for len in [0, MAX_BLOB_LEN as u32 + 1, u32::MAX] {
        let HostToDevice::ParamBegin(mut b) = good.clone() else {
            unreachable!()
        };
        b.length_bytes = len;
        out.push(refused_at_begin(
            format!("announced length {len}"),
            HostToDevice::ParamBegin(b),
            &blob,
            UploadError::BadLength,
        ));
    }
    // A transfer longer than announced: the chunk that passes the end aborts it.
    for short_by in [1, PARAM_CHUNK_LEN - 1, PARAM_CHUNK_LEN] {
        let announced = blob.len() - short_by;
        let mut messages = vec![begin(&blob[..announced], FRESH, &key)];
        messages.extend(chunks(&blob));
        messages.push(HostToDevice::ParamCommit);
        let fits = announced.div_ceil(PARAM_CHUNK_LEN);
        let fits = if fits * PARAM_CHUNK_LEN > announced {
            fits - 1
        } else {
            fits
        };
        let mut answers = vec![Ok(ParamAck::Begun)];
        answers.extend((1..=fits).map(|k| {
            Ok(ParamAck::Received {
                bytes: (k * PARAM_CHUNK_LEN) as u32,
            })
        }));
        answers.push(Err(UploadError::ChunkPastEnd));
        answers.extend(std::iter::repeat_n(
            Err(UploadError::NotStarted),
            messages.len() - answers.len(),
        ));
        out.push(Attack {
            name: format!("{short_by} bytes more than announced"),
            messages,
            answers,
        });
    }
    // Chunks out of order at every position: skipped, repeated, shifted by a byte.
    for k in 0..n_chunks {
        let all = chunks(&blob);
        let shifted = |delta: i64| {
            let HostToDevice::ParamChunk(c) = &all[k] else {
                unreachable!()
            };
            HostToDevice::ParamChunk(ParamChunk {
                offset_bytes: (i64::from(c.offset_bytes) + delta) as u32,
                bytes: c.bytes.clone(),
            })
        };
        let mut variants = vec![("shifted one byte on", shifted(1))];
        if k > 0 {
            variants.push(("repeated", all[k - 1].clone()));
            variants.push(("shifted one byte back", shifted(-1)));
        }
        if k + 1 < n_chunks {
            variants.push(("skipped", all[k + 1].clone()));
        }
        for (how, wrong) in variants {
            let mut messages = vec![good.clone()];
            messages.extend(all[..k].iter().cloned());
            messages.push(wrong);
            messages.push(HostToDevice::ParamCommit);
            let mut answers = vec![Ok(ParamAck::Begun)];
            answers.extend((1..=k).map(|j| {
                Ok(ParamAck::Received {
                    bytes: (j * PARAM_CHUNK_LEN) as u32,
                })
            }));
            answers.push(Err(UploadError::OutOfOrder));
            answers.push(Err(UploadError::Incomplete));
            assert_eq!(answers.len(), messages.len());
            out.push(Attack {
                name: format!("chunk {k} {how}"),
                messages,
                answers,
            });
        }
    }
    // Commits before the last chunk.
    for k in 0..n_chunks {
        let mut messages = vec![good.clone()];
        messages.extend(chunks(&blob)[..k].iter().cloned());
        messages.push(HostToDevice::ParamCommit);
        let mut answers = transfer_answers(&blob)[..=k].to_vec();
        answers.push(Err(UploadError::Incomplete));
        out.push(Attack {
            name: format!("commit after {k} chunks"),
            messages,
            answers,
        });
    }
    // D3: a valid blob with bytes after it, correctly signed, at every length up to the
    // largest upload; the padding zeros, erased-flash 0xFF or a pattern.
    for pad in 1..=MAX_BLOB_LEN - blob.len() {
        let mut padded = blob.clone();
        padded.extend((0..pad).map(|i| match pad % 3 {
            0 => 0,
            1 => 0xFF,
            _ => (i * 37 + 11) as u8,
        }));
        out.push(refused_at_commit(
            format!("{pad} bytes of padding"),
            &padded,
            FRESH,
            &key,
            UploadError::LengthMismatch,
        ));
    }
    // The other way: a blob cut short, signed; its header announces more.
    for len in 1..blob.len() {
        let error = if len < supine_core::blob::BLOB_HEADER_LEN {
            UploadError::Blob(BlobError::Truncated)
        } else {
            UploadError::LengthMismatch
        };
        out.push(refused_at_commit(
            format!("blob cut to {len} bytes"),
            &blob[..len],
            FRESH,
            &key,
            error,
        ));
    }
    // Signed by the key holder but invalid.
    let mut bad_magic = blob.clone();
    bad_magic[0] = b'X';
    out.push(refused_at_commit(
        "bad magic, signed".into(),
        &bad_magic,
        FRESH,
        &key,
        UploadError::Blob(BlobError::BadMagic),
    ));
    let mut bad_crc = blob.clone();
    bad_crc[40] ^= 4;
    out.push(refused_at_commit(
        "bad CRC, signed".into(),
        &bad_crc,
        FRESH,
        &key,
        UploadError::Blob(BlobError::BadCrc),
    ));
    // Signed, well formed, but with joint-motion thresholds the device refuses: the
    // validation on decode, as the head's alerts' (issue 16).
    type Spoil = fn(&mut supine_core::alerts::JointAlertSettings);
    let bad_joint_alerts: [(&str, Spoil); 4] = [
        ("a negative joint threshold", |s| {
            s.config.excursion_m_or_rad[0] = -0.001
        }),
        ("a NaN joint threshold", |s| {
            s.config.running_rms_m_or_rad[1] = f32::NAN
        }),
        ("a joint threshold without its watch bit", |s| {
            s.config.running_rms_m_or_rad[2] = 0.002
        }),
        ("a joint hysteresis of 2", |s| s.config.hysteresis = 2.0),
    ];
    for (name, spoil) in bad_joint_alerts {
        let mut params = upload_params();
        spoil(&mut params.joint_alerts);
        out.push(refused_at_commit(
            format!("{name}, signed"),
            &encode(&params),
            FRESH,
            &key,
            UploadError::Blob(BlobError::BadConfig),
        ));
    }
    out
}

/// Checks that `rig`, started in `start`, still runs what it ran, greets as it did, and
/// that its flash boots the same.
fn assert_unchanged(rig: &mut Rig, start: Start, greeting: &Greeting, name: &str) {
    assert_eq!(
        &rig.hello(),
        greeting,
        "{start:?}, {name}: greeting changed"
    );
    let view = rig.flash_now();
    assert_eq!(
        boots(&view.slots),
        start.runs(),
        "{start:?}, {name}: next boot"
    );
}

#[test]
fn every_upload_attack_from_every_state_is_refused_with_its_code_and_changes_nothing() {
    let mut tried = 0;
    for start in STARTS {
        let (mut rig, greeting) = Rig::boot_flash(&start.slots(), FlashFaults::default(), false);
        assert_eq!(
            (greeting.params_identity, greeting.params_source),
            start.runs()
        );
        let flash_before = rig.flash_now();
        let mut rejected = 0;
        for attack in attacks(start) {
            rig.send_all(&attack.messages);
            let got = answers(&rig.run());
            assert_eq!(got, attack.answers, "{start:?}, {}", attack.name);
            rejected += got.iter().filter(|a| a.is_err()).count() as u32;
            let flash = rig.flash_now();
            assert_eq!(
                flash.operations, 0,
                "{start:?}, {}: flash touched",
                attack.name
            );
            assert!(
                flash.slots == flash_before.slots,
                "{start:?}, {}",
                attack.name
            );
            tried += 1;
        }
        assert_unchanged(&mut rig, start, &greeting, "after every attack");
        let (_, status) = rig.status();
        assert_eq!(status.uploads_rejected, rejected, "{start:?}");
        assert_eq!(status.params_source, start.runs().1, "{start:?}");

        // Not locked out: a genuine upload still goes through.
        let blob = upload_blob();
        rig.send_all(&upload_messages(&blob, FRESH, &development_key()));
        let got = answers(&rig.run());
        let target = if start.runs().1 == (ParamsSource::Flash { slot: 0 }) {
            1
        } else {
            0
        };
        assert_eq!(
            got.last(),
            Some(&Ok(ParamAck::Committed {
                identity: UPLOAD_IDENTITY,
                slot: target
            })),
            "{start:?}"
        );
        assert_eq!(
            boots(&rig.flash_now().slots),
            (UPLOAD_IDENTITY, ParamsSource::Flash { slot: target })
        );
    }
    println!("upload attacks through the monitor: {tried} tried, {tried} held");
}

#[test]
fn a_transfer_cut_at_any_chunk_then_a_reset_boots_what_ran_before() {
    let key = development_key();
    let blob = upload_blob();
    let all = upload_messages(&blob, FRESH, &key);
    let mut tried = 0;
    for start in STARTS {
        for cut in 1..all.len() {
            let (mut rig, greeting) =
                Rig::boot_flash(&start.slots(), FlashFaults::default(), false);
            rig.send_all(&all[..cut]);
            let _ = rig.run();
            assert_eq!(rig.flash_now().operations, 0, "{start:?}, cut at {cut}");
            // The reset: RAM is gone, flash stays.
            let slots = rig.flash_now().slots;
            let (mut rig, after) = Rig::boot_flash(&slots, FlashFaults::default(), false);
            assert_eq!(after, greeting, "{start:?}, cut at {cut}");
            // What the host still sends finds no upload open.
            rig.send_all(&all[cut..]);
            let got = answers(&rig.run());
            assert!(
                got.iter().all(|a| *a == Err(UploadError::NotStarted)),
                "{start:?}, cut at {cut}: {got:?}"
            );
            assert_eq!(boots(&rig.flash_now().slots), start.runs());
            tried += 1;
        }
    }
    println!("cut transfers then reset: {tried} tried, {tried} held");
}

#[test]
fn a_flash_that_fails_or_reads_back_wrong_leaves_nothing_bootable_and_says_flash() {
    // An update is an erase (operation 0) then three writes: payload (1), commit record
    // (2), header (3); a scrub after a failure is operation 4 (erase) and, if that
    // fails, 5 (a header of zeros).
    let faults: Vec<(&str, FlashFaults)> = vec![
        (
            "the erase fails",
            FlashFaults {
                fail_op: Some(0),
                ..FlashFaults::default()
            },
        ),
        (
            "the payload write fails",
            FlashFaults {
                fail_op: Some(1),
                ..FlashFaults::default()
            },
        ),
        (
            "the record write fails",
            FlashFaults {
                fail_op: Some(2),
                ..FlashFaults::default()
            },
        ),
        (
            "the header write fails",
            FlashFaults {
                fail_op: Some(3),
                ..FlashFaults::default()
            },
        ),
        (
            "the payload reads back wrong",
            FlashFaults {
                corrupt_op: Some(1),
                ..FlashFaults::default()
            },
        ),
        (
            "the record reads back wrong",
            FlashFaults {
                corrupt_op: Some(2),
                ..FlashFaults::default()
            },
        ),
        (
            "the header reads back wrong",
            FlashFaults {
                corrupt_op: Some(3),
                ..FlashFaults::default()
            },
        ),
        (
            "the record reads back wrong and the slot cannot be erased again",
            FlashFaults {
                corrupt_op: Some(2),
                erase_fails_from: Some(4),
                ..FlashFaults::default()
            },
        ),
        (
            "the payload reads back wrong and the slot cannot be erased again",
            FlashFaults {
                corrupt_op: Some(1),
                erase_fails_from: Some(4),
                ..FlashFaults::default()
            },
        ),
    ];
    let blob = upload_blob();
    let mut tried = 0;
    for start in STARTS {
        for (name, fault) in &faults {
            let (mut rig, greeting) = Rig::boot_flash(&start.slots(), *fault, false);
            rig.send_all(&upload_messages(&blob, FRESH, &development_key()));
            let got = answers(&rig.run());
            assert_eq!(
                got.last(),
                Some(&Err(UploadError::Flash)),
                "{start:?}, {name}"
            );
            assert_unchanged(&mut rig, start, &greeting, name);
            // And after a power cycle.
            let (_, after) = Rig::boot_flash(&rig.flash_now().slots, FlashFaults::default(), false);
            assert_eq!(after, greeting, "{start:?}, {name}: after a reset");
            tried += 1;
        }
    }
    println!("flash faults during an update: {tried} tried, {tried} held");
}
