//! Any bytes into the blob validator, both raw and sealed with a valid header and CRC (so
//! the fuzzer reaches the payload checks behind the checksum): no panic; whatever it
//! accepts is valid, re-encodes to a blob it accepts again, and (issue 17, D6) turns input
//! within the sensor's full scale into finite outputs: the accepted blob runs samples of
//! full-scale magnitude with signs from the fuzzer's bytes, the input a gain bound is
//! tightest against.
#![no_main]

use libfuzzer_sys::fuzz_target;
use supine_core::blob::{
    BLOB_FORMAT_VERSION, BLOB_HEADER_LEN, DeviceParams, MAX_BLOB_LEN, BLOB_MAGIC, crc32,
};
use supine_core::pipeline::{PipelineOutput, PipelineState};

/// Samples each accepted blob runs: long enough for slow modes to build up, short enough
/// to keep the fuzzer fast (accepted blobs are a small share of its inputs).
const RUN_SAMPLES: usize = 2048;

/// Full-scale samples whose signs (and which axes are driven) follow `bytes`, repeated.
fn worst_signs(bytes: &[u8], full_scale_m_s2: f32) -> Vec<[f32; 3]> {
    let pattern = if bytes.is_empty() { &[0x5a][..] } else { bytes };
    (0..RUN_SAMPLES)
        .map(|n| {
            // Runs of one sign, as long as the byte says, excite slow modes too.
            let byte = pattern[(n / 16) % pattern.len()];
            let sign = |bit: u8| if byte >> bit & 1 == 1 { 1.0 } else { -1.0 };
            [sign(0), sign(1), sign(2)].map(|s| s * full_scale_m_s2)
        })
        .collect()
}

fn check(bytes: &[u8], signs: &[u8]) {
    if let Ok(params) = DeviceParams::decode(bytes) {
        assert_eq!(params.validate(), Ok(()));
        let mut buf = [0u8; MAX_BLOB_LEN];
        let len = params.encode(&mut buf).expect("an accepted blob re-encodes");
        assert_eq!(DeviceParams::decode(&buf[..len]), Ok(params));
        let input = worst_signs(signs, params.sensor_checks.config.full_scale_m_s2);
        let indices: Vec<u32> = (0..input.len() as u32).collect();
        params.process(&mut PipelineState::new(), &indices, &input, |o| {
            if let PipelineOutput::Telemetry(t) = o {
                let values = t
                    .head_acc_m_s2
                    .iter()
                    .chain(&t.running_rms_m_s2)
                    .chain([&t.vector_running_rms_m_s2, &t.vdv_m_s175]);
                for v in values {
                    assert!(v.is_finite(), "an accepted blob gave {v} from bounded input");
                }
            }
        });
    }
}

fuzz_target!(|bytes: &[u8]| {
    check(bytes, bytes);
    // The same bytes as a payload behind a correct header.
    let payload = bytes.get(BLOB_HEADER_LEN..).unwrap_or(&[]);
    let mut sealed = Vec::with_capacity(BLOB_HEADER_LEN + payload.len());
    sealed.extend_from_slice(&BLOB_MAGIC);
    sealed.extend_from_slice(&BLOB_FORMAT_VERSION.to_le_bytes());
    sealed.extend_from_slice(&0u16.to_le_bytes());
    sealed.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    sealed.extend_from_slice(&crc32(payload).to_le_bytes());
    sealed.extend_from_slice(payload);
    check(&sealed, bytes);
});
