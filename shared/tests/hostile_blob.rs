//! The parameter blob under damage: every single-bit flip and every truncation of the
//! golden blob (`shared/fixtures/golden_blob.bin`) through the validator
//! (`DeviceParams::decode`), as a device meets it in a slot or an upload.
//!
//! Each damaged blob must be refused, or, if accepted, run bounded input to finite
//! outputs. Raw flips are all caught by the header checks or the CRC; flips with the CRC
//! made to match again (what a writer with a bug, or an attacker without the upload key
//! but with a programmer, produces) reach the payload's own checks.

use supine_core::blob::{BLOB_HEADER_LEN, BlobError, DeviceParams, crc32};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::protocol::golden::BLOB;
use supine_core::test_vector::TestVector;

/// Samples each accepted blob runs: past the 5 s warm-up at 500 Hz, so the exposure is
/// reported as valid.
const RUN_SAMPLES: usize = 3000;
/// Input bound, m/s^2: 16 g, the default full scale of the sensor checks.
const INPUT_BOUND_M_S2: f32 = 156.0;

/// Bounded input: the test vector scaled to use most of the range.
fn bounded_input() -> Vec<[f32; 3]> {
    TestVector::new(17)
        .take(RUN_SAMPLES)
        .map(|x| x.map(|v| (40.0 * v).clamp(-INPUT_BOUND_M_S2, INPUT_BOUND_M_S2)))
        .collect()
}

/// Whether `params` turn `input` into finite outputs only.
fn outputs_stay_finite(params: &DeviceParams, input: &[[f32; 3]]) -> bool {
    let indices: Vec<u32> = (0..input.len() as u32).collect();
    let mut finite = true;
    params.process(&mut PipelineState::new(), &indices, input, |o| {
        if let PipelineOutput::Telemetry(t) = o {
            finite &= t
                .head_acc_m_s2
                .iter()
                .chain(&t.running_rms_m_s2)
                .chain([&t.vector_running_rms_m_s2, &t.vdv_m_s175])
                .all(|v| v.is_finite());
        }
    });
    finite
}

/// The blob with bit `bit` flipped.
fn flipped(bit: usize) -> Vec<u8> {
    let mut blob = BLOB.to_vec();
    blob[bit / 8] ^= 1 << (bit % 8);
    blob
}

/// The blob with its header's CRC set to match its payload.
fn crc_repaired(mut blob: Vec<u8>) -> Vec<u8> {
    let crc = crc32(&blob[BLOB_HEADER_LEN..]);
    blob[12..16].copy_from_slice(&crc.to_le_bytes());
    blob
}

#[test]
fn the_golden_blob_is_accepted_and_runs_finite() {
    let params = DeviceParams::decode(BLOB).expect("the golden blob is valid");
    assert!(outputs_stay_finite(&params, &bounded_input()));
}

#[test]
fn every_single_bit_flip_of_the_golden_blob_is_refused() {
    // CRC-32 detects every single-bit error, and the header's own fields are checked
    // before the CRC: nothing flipped can pass.
    let mut reasons = std::collections::BTreeMap::<String, usize>::new();
    for bit in 0..BLOB.len() * 8 {
        match DeviceParams::decode(&flipped(bit)) {
            Ok(_) => panic!("bit {bit} flipped: accepted"),
            Err(e) => *reasons.entry(format!("{e:?}")).or_default() += 1,
        }
    }
    println!(
        "single-bit flips: {} tried, {} held, refused as {reasons:?}",
        BLOB.len() * 8,
        BLOB.len() * 8
    );
    // Every payload bit is the CRC's to catch.
    let payload_bits = (BLOB.len() - BLOB_HEADER_LEN) * 8;
    assert!(reasons.get("BadCrc").copied().unwrap_or(0) >= payload_bits);
}

#[test]
fn every_truncation_of_the_golden_blob_is_refused() {
    for len in 0..BLOB.len() {
        // Shorter than a header, or than the header announces.
        assert_eq!(
            DeviceParams::decode(&BLOB[..len]),
            Err(BlobError::Truncated),
            "cut to {len} bytes"
        );
    }
    // And in a slot, where the bytes after the cut are erased flash or zeros: the header
    // still announces the whole, and the payload's end is blank.
    for len in BLOB_HEADER_LEN..BLOB.len() {
        for fill in [0xFF, 0x00] {
            let mut slot = BLOB[..len].to_vec();
            slot.resize(BLOB.len() + 64, fill);
            assert!(
                DeviceParams::decode(&slot).is_err(),
                "cut to {len} bytes, then {fill:#04x}"
            );
        }
    }
    println!(
        "truncations: {} tried, {} held",
        BLOB.len() + 2 * (BLOB.len() - BLOB_HEADER_LEN),
        BLOB.len() + 2 * (BLOB.len() - BLOB_HEADER_LEN)
    );
}

/// Flips of payload bits with the CRC made to match: those the validator accepts must
/// run bounded input to finite outputs. Returns (tried, accepted, the bits that broke it).
fn crc_repaired_sweep(bits: impl Iterator<Item = usize>) -> (usize, usize, Vec<usize>) {
    let input = bounded_input();
    let (mut tried, mut accepted, mut broken) = (0, 0, Vec::new());
    for bit in bits {
        tried += 1;
        if let Ok(params) = DeviceParams::decode(&crc_repaired(flipped(bit))) {
            accepted += 1;
            if !outputs_stay_finite(&params, &input) {
                broken.push(bit);
            }
        }
    }
    (tried, accepted, broken)
}

/// Every payload bit with the CRC repaired: 9,000 cases, a few seconds.
// D6 (issue 17): before the validator bounded the realization's gain, five exponent flips
// in its coefficients were accepted and overflowed to non-finite outputs.
#[test]
fn every_payload_bit_flip_with_a_matching_crc_is_refused_or_runs_finite() {
    let (tried, accepted, broken) = crc_repaired_sweep(BLOB_HEADER_LEN * 8..BLOB.len() * 8);
    println!(
        "CRC-repaired payload flips: {tried} tried, {accepted} accepted, {} held",
        tried - broken.len()
    );
    assert_eq!(
        broken,
        Vec::<usize>::new(),
        "flipped bits giving non-finite outputs"
    );
}
