//! Bad blobs and bad frames are refused with a distinct error, never a panic.

use supine_core::blob::{
    BLOB_FORMAT_VERSION, BLOB_HEADER_LEN, BlobError, DeviceParams, MAX_BLOB_LEN, crc32,
};
use supine_core::model::params::{HEIGHT_RANGE_M, MASS_RANGE_KG};
use supine_core::model::{ModelParams, Preset, device_realization};
use supine_core::protocol::golden::{BLOB, HOST_TO_DEVICE, blob_example};
use supine_core::protocol::{
    FrameAccumulator, FrameError, FrameEvent, HostToDevice, MAX_FRAME_LEN,
};

/// Re-seals a payload edit with a correct CRC so the check behind the CRC is reached.
fn reseal(mut blob: Vec<u8>) -> Vec<u8> {
    let crc = crc32(&blob[BLOB_HEADER_LEN..]);
    blob[12..16].copy_from_slice(&crc.to_le_bytes());
    blob
}

fn encoded(params: &DeviceParams) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let len = params.encode(&mut buf).unwrap();
    buf.truncate(len);
    buf
}

#[test]
fn a_blob_of_the_paper_litter_model_round_trips() {
    let realization = device_realization(&ModelParams::preset(Preset::PaperLitter), 500.0).unwrap();
    let mut params = blob_example().unwrap();
    params.realization = realization;
    let bytes = encoded(&params);
    assert!(bytes.len() < 2048, "{} bytes", bytes.len());
    assert_eq!(DeviceParams::decode(&bytes).unwrap(), params);
    // A flash slot holds more than the blob: trailing bytes after the payload are ignored.
    let mut slot = bytes.clone();
    slot.resize(8192, 0xFF);
    assert_eq!(DeviceParams::decode(&slot).unwrap(), params);
}

#[test]
fn each_kind_of_bad_blob_gets_its_own_error() {
    let good = BLOB.to_vec();
    let mut cases: Vec<(&str, Vec<u8>, BlobError)> = Vec::new();
    cases.push(("erased", vec![0xFF; 64], BlobError::Empty));
    let mut magic = good.clone();
    magic[0] = b'X';
    cases.push(("magic", magic, BlobError::BadMagic));
    let mut version = good.clone();
    version[4..6].copy_from_slice(&(BLOB_FORMAT_VERSION + 1).to_le_bytes());
    cases.push(("version", version, BlobError::UnsupportedVersion));
    let mut length = good.clone();
    length[8..12].copy_from_slice(&(MAX_BLOB_LEN as u32).to_le_bytes());
    cases.push(("length", length, BlobError::BadLength));
    cases.push((
        "truncated",
        good[..good.len() - 3].to_vec(),
        BlobError::Truncated,
    ));
    cases.push(("header only", good[..10].to_vec(), BlobError::Truncated));
    let mut flipped = good.clone();
    flipped[BLOB_HEADER_LEN + 40] ^= 0x04;
    cases.push(("flipped bit", flipped, BlobError::BadCrc));
    // A write cut short in a flash slot: the announced length is there, its end erased.
    let mut cut = good[..good.len() / 2].to_vec();
    cut.resize(8192, 0xFF);
    cases.push(("cut write in a slot", cut, BlobError::Truncated));
    let mut cut_zeroed = good[..good.len() / 2].to_vec();
    cut_zeroed.resize(8192, 0);
    cases.push((
        "cut write in zeroed memory",
        cut_zeroed,
        BlobError::Truncated,
    ));
    // A flipped bit in the final byte stays a CRC error, not a truncation.
    let mut last = good.clone();
    *last.last_mut().unwrap() ^= 0x80;
    cases.push(("flipped last byte", last, BlobError::BadCrc));
    for (name, bytes, expected) in &cases {
        assert_eq!(
            DeviceParams::decode(bytes).unwrap_err(),
            *expected,
            "{name}"
        );
    }
    let codes: std::collections::BTreeSet<u8> = cases.iter().map(|c| c.2.code()).collect();
    assert_eq!(
        codes.len(),
        cases.len() - 4,
        "the four truncations share a code, as do the two CRC errors; the rest differ"
    );
}

#[test]
fn a_sealed_blob_with_a_nan_or_an_unstable_pole_is_refused_behind_the_crc() {
    let example = blob_example().unwrap();
    let mut nan = example;
    nan.realization.blocks[0].output[0][0] = f32::NAN;
    // In a block past `block_count`, which never runs: still a NaN in the blob.
    let mut unused_nan = example;
    unused_nan.realization.blocks[15].output[1][1] = f32::NAN;
    let mut unstable = example;
    unstable.realization.blocks[0].transition_minus_identity[0][0] = 0.5;
    let mut bad_decimation = example;
    bad_decimation.telemetry.decimation = 0;
    // The band-limiting high-pass with plausible positive values that recur unstably.
    let mut unstable_weighting = example;
    for w in unstable_weighting.exposure.weighting.iter_mut() {
        w.band.high_pass.d = 400.0;
    }
    let mut nan_config = example;
    nan_config.alerts.config.hysteresis = f32::NAN;
    let mut nan_factor = example;
    nan_factor.exposure.config.axes.z.k = f32::NAN;
    let mut nan_tau = example;
    nan_tau.exposure.config.running_tau_s = f32::NAN;
    // A weighting whose gain is not its axis factor's (k = 1.4 on x, filters for k = 1).
    let mut wrong_gain = example;
    wrong_gain.exposure.config.axes.x.k *= 1.5;
    for (name, params, expected) in [
        ("nan", nan, BlobError::NonFinite),
        ("nan in an unused block", unused_nan, BlobError::NonFinite),
        ("unstable model", unstable, BlobError::Unstable),
        ("bad decimation", bad_decimation, BlobError::BadConfig),
        (
            "unstable weighting",
            unstable_weighting,
            BlobError::Unstable,
        ),
        ("nan hysteresis", nan_config, BlobError::NonFinite),
        ("nan axis factor", nan_factor, BlobError::NonFinite),
        ("nan time constant", nan_tau, BlobError::NonFinite),
        ("wrong weighting gain", wrong_gain, BlobError::BadConfig),
    ] {
        // Encode bypasses validation on purpose: the validator must catch it on load.
        let mut buf = vec![0u8; MAX_BLOB_LEN];
        let len = params.encode(&mut buf).unwrap();
        assert_eq!(
            DeviceParams::decode(&reseal(buf[..len].to_vec())).unwrap_err(),
            expected,
            "{name}"
        );
    }
    // The one stored rate, right after the 16-byte identity and the patient (two f32):
    // out of range, not a number, or in range but not the rate the stages were built for.
    let rate_at = BLOB_HEADER_LEN + 16 + 8;
    assert_eq!(BLOB[rate_at..rate_at + 4], 500f32.to_le_bytes());
    for (hz, expected) in [
        (5000.0f32, BlobError::SampleRate),
        (99.0, BlobError::SampleRate),
        (f32::NAN, BlobError::SampleRate),
        (1000.0, BlobError::BadConfig),
    ] {
        let mut bytes = BLOB.to_vec();
        bytes[rate_at..rate_at + 4].copy_from_slice(&hz.to_le_bytes());
        assert_eq!(
            DeviceParams::decode(&reseal(bytes)).unwrap_err(),
            expected,
            "rate {hz} Hz"
        );
    }
    let mut trailing = BLOB.to_vec();
    trailing.push(0);
    let payload_len = (trailing.len() - BLOB_HEADER_LEN) as u32;
    trailing[8..12].copy_from_slice(&payload_len.to_le_bytes());
    assert_eq!(
        DeviceParams::decode(&reseal(trailing)).unwrap_err(),
        BlobError::Malformed
    );
}

/// The patient (height, mass as f32, right after the 16-byte identity) must lie within the
/// model's range, the one the host's `--height-m`/`--mass-kg` use: a sealed blob with a
/// 3 m patient is refused with `BadConfig` (code 11), not run.
#[test]
fn a_sealed_blob_with_a_patient_outside_the_models_range_is_refused() {
    let height_at = BLOB_HEADER_LEN + 16;
    let mass_at = height_at + 4;
    assert_eq!(BLOB[height_at..height_at + 4], 1.6f32.to_le_bytes());
    assert_eq!(BLOB[mass_at..mass_at + 4], 52f32.to_le_bytes());
    let (lo_m, hi_m) = HEIGHT_RANGE_M;
    let (lo_kg, hi_kg) = MASS_RANGE_KG;
    let with = |at: usize, value: f32| {
        let mut bytes = BLOB.to_vec();
        bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        DeviceParams::decode(&reseal(bytes))
    };
    for (name, at, value, expected) in [
        ("3 m tall", height_at, 3.0f32, BlobError::BadConfig),
        (
            "below the lowest height",
            height_at,
            0.49,
            BlobError::BadConfig,
        ),
        ("negative mass", mass_at, -52.0, BlobError::BadConfig),
        (
            "above the highest mass",
            mass_at,
            301.0,
            BlobError::BadConfig,
        ),
        ("NaN height", height_at, f32::NAN, BlobError::NonFinite),
        (
            "infinite mass",
            mass_at,
            f32::INFINITY,
            BlobError::NonFinite,
        ),
    ] {
        assert_eq!(with(at, value).unwrap_err(), expected, "{name}");
    }
    assert_eq!(BlobError::BadConfig.code(), 11);
    // The range's ends are accepted, and read back as written.
    for (at, value) in [
        (height_at, lo_m),
        (height_at, hi_m),
        (mass_at, lo_kg),
        (mass_at, hi_kg),
    ] {
        let params = with(at, value as f32).expect("the range's ends are accepted");
        let read = if at == height_at {
            params.patient.height_m
        } else {
            params.patient.mass_kg
        };
        assert_eq!(f64::from(read), value);
    }
}

fn feed(acc: &mut FrameAccumulator, bytes: &[u8]) -> (Vec<HostToDevice>, Vec<FrameError>) {
    let (mut ok, mut bad) = (Vec::new(), Vec::new());
    for b in bytes {
        match acc.push::<HostToDevice>(*b) {
            FrameEvent::Message(m) => ok.push(m),
            FrameEvent::Dropped(e) => bad.push(e),
            FrameEvent::Pending => {}
        }
    }
    (ok, bad)
}

#[test]
fn garbage_and_oversize_frames_are_counted_once_and_later_frames_still_decode() {
    let mut acc = FrameAccumulator::new();
    let mut stream = Vec::new();
    stream.extend_from_slice(&[0x13, 0x37, 0xFF, 0x00]); // garbage
    stream.extend(std::iter::repeat_n(0x42, 3 * MAX_FRAME_LEN));
    stream.push(0); // one oversize frame
    stream.extend_from_slice(&[0, 0]); // idle zeros
    stream.extend_from_slice(HOST_TO_DEVICE[1]);
    let mut trailing = HOST_TO_DEVICE[0].to_vec();
    trailing.pop();
    trailing.extend_from_slice(&[0x01, 0x00]); // a valid message plus an extra byte
    let (ok, bad) = feed(&mut acc, &stream);
    assert_eq!(bad, vec![FrameError::Malformed, FrameError::Oversize]);
    assert_eq!(ok.len(), 1);
    assert!(matches!(ok[0], HostToDevice::Samples(_)));
    let (ok, bad) = feed(&mut acc, &trailing);
    assert!(ok.is_empty());
    assert_eq!(bad.len(), 1);
}

#[test]
fn random_bytes_never_panic_the_decoders() {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut acc = FrameAccumulator::new();
    let mut bytes = vec![0u8; 200_000];
    for b in bytes.iter_mut() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        *b = if state % 17 == 0 { 0 } else { state as u8 };
    }
    let (_, bad) = feed(&mut acc, &bytes);
    assert!(!bad.is_empty());
    for window in bytes.chunks(300) {
        let _ = DeviceParams::decode(window);
    }
}
