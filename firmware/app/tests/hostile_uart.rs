//! Garbage on the link, through the monitor: random bytes, zero floods, frames that never
//! end, frames of unknown messages, cut frames, and sample frames carrying NaN, +-inf,
//! 1e30 or indices that jump anywhere, mixed with good frames, from a seeded RNG.
//!
//! The device must never panic, must answer every `Hello` with the same greeting and every
//! `GetStatus` with a status, must count every frame it received as good or bad, and must
//! keep running the parameters it booted with: its telemetry and alerts are, bit for bit,
//! what `supine_core::pipeline` gives for the samples the host side can decode from the
//! same bytes. The counts are checked against an independent reading of the byte stream:
//! every non-empty run of bytes ending in a zero is exactly one frame, good or bad.

mod support;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use supine_core::protocol::{
    DeviceToHost, FrameAccumulator, FrameEvent, HostToDevice, MAX_FRAME_LEN, MAX_SAMPLES_PER_FRAME,
    SampleBatch, encode_frame,
};
use supine_core::protocol::{ParamsSource, Telemetry};
use support::*;

/// Cases per run: each a burst of garbage followed by `Hello` and `GetStatus`.
const CASES: usize = 4000;

/// Values a sample axis can carry that a sensor never reports.
const HOSTILE_VALUES: [f32; 9] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    1e30,
    -1e30,
    f32::MAX,
    f32::MIN_POSITIVE / 4.0,
    0.0,
    -0.0,
];

fn frame_bytes(message: &HostToDevice) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode_frame(message, &mut buf)
        .expect("every message fits a frame")
        .to_vec()
}

/// A sample frame of `n` samples from `first`, some axes hostile.
fn hostile_samples(rng: &mut ChaCha8Rng, first: u32) -> Vec<u8> {
    let n = rng.random_range(1..=MAX_SAMPLES_PER_FRAME);
    let samples = (0..n)
        .map(|_| {
            [0; 3].map(|_| {
                if rng.random_bool(0.3) {
                    HOSTILE_VALUES[rng.random_range(0..HOSTILE_VALUES.len())]
                } else {
                    rng.random_range(-20.0..20.0)
                }
            })
        })
        .collect::<Vec<_>>();
    frame_bytes(&HostToDevice::Samples(SampleBatch {
        first_sample_index: first,
        accel_m_s2: heapless::Vec::from_slice(&samples).expect("fits"),
    }))
}

/// One burst of garbage; `next_index` is the index a well-behaved host would send next.
fn garbage(rng: &mut ChaCha8Rng, next_index: &mut u32) -> (&'static str, Vec<u8>) {
    match rng.random_range(0..8) {
        0 => {
            let n = rng.random_range(1..600);
            ("random bytes", (0..n).map(|_| rng.random()).collect())
        }
        1 => ("a zero flood", vec![0; rng.random_range(1..2000)]),
        2 => {
            // Longer than any frame, no zero until the end.
            let n = rng.random_range(MAX_FRAME_LEN - 2..1500);
            let mut bytes: Vec<u8> = (0..n).map(|_| rng.random_range(1..=255)).collect();
            bytes.push(0);
            ("a frame without a zero", bytes)
        }
        3 => {
            // A frame whose postcard tag names no message (6 and up), with a body. With
            // no zero in it and under 254 bytes, COBS is one length byte in front.
            let mut body = vec![rng.random_range(6..=255u8)];
            body.extend((0..rng.random_range(0..40)).map(|_| rng.random_range(1..=255u8)));
            let mut buf = vec![body.len() as u8 + 1];
            buf.extend(&body);
            buf.push(0);
            ("an unknown tag", buf)
        }
        4 => {
            // A good frame cut anywhere, then the zero.
            let mut bytes = hostile_samples(rng, *next_index);
            let cut = rng.random_range(1..bytes.len() - 1);
            bytes.truncate(cut);
            bytes.push(0);
            ("a cut frame", bytes)
        }
        5 => {
            let bytes = hostile_samples(rng, *next_index);
            *next_index = next_index.wrapping_add(MAX_SAMPLES_PER_FRAME as u32);
            ("NaN, inf and 1e30 samples", bytes)
        }
        6 => {
            // Any index: forward a little or a lot, back, across u32::MAX.
            let first = match rng.random_range(0..4) {
                0 => next_index.wrapping_add(rng.random_range(1..100)),
                1 => next_index.wrapping_add(rng.random_range(29_000..31_000)),
                2 => u32::MAX - rng.random_range(0..4),
                _ => rng.random(),
            };
            *next_index = first.wrapping_add(MAX_SAMPLES_PER_FRAME as u32);
            ("an index jump", hostile_samples(rng, first))
        }
        _ => {
            // Good samples, as a host sends them.
            let input = samples(rng.random(), 160);
            let bytes = sample_frames(*next_index, &input)
                .iter()
                .flat_map(frame_bytes)
                .collect();
            *next_index = next_index.wrapping_add(160);
            ("good samples", bytes)
        }
    }
}

/// What the host side reads from a byte stream: the frames, good and bad, and the
/// samples of the good ones.
#[derive(Default)]
struct Reading {
    frames: u32,
    bad_frames: u32,
    hellos: usize,
    statuses: usize,
    uploads: usize,
    indices: Vec<u32>,
    samples: Vec<[f32; 3]>,
}

impl Reading {
    fn read(&mut self, decoder: &mut FrameAccumulator, bytes: &[u8]) {
        for &b in bytes {
            match decoder.push::<HostToDevice>(b) {
                FrameEvent::Pending => {}
                FrameEvent::Dropped(_) => self.bad_frames += 1,
                FrameEvent::Message(m) => {
                    self.frames += 1;
                    match m {
                        HostToDevice::Hello => self.hellos += 1,
                        HostToDevice::GetStatus => self.statuses += 1,
                        HostToDevice::Samples(batch) => {
                            for (k, s) in batch.accel_m_s2.iter().enumerate() {
                                self.indices
                                    .push(batch.first_sample_index.wrapping_add(k as u32));
                                self.samples.push(*s);
                            }
                        }
                        _ => self.uploads += 1,
                    }
                }
            }
        }
    }

    /// Samples lost by the device's documented rule: a jump forward of up to a minute of
    /// samples counts, anything else is a new stream.
    fn samples_dropped(&self) -> u32 {
        let max_lost = (SAMPLE_RATE_HZ * f64::from(supine_app::MAX_LOST_SPAN_S)) as u32;
        let mut dropped = 0u32;
        for pair in self.indices.windows(2) {
            let gap = pair[1].wrapping_sub(pair[0].wrapping_add(1));
            if gap <= max_lost {
                dropped = dropped.saturating_add(gap);
            }
        }
        dropped
    }
}

/// Non-empty runs of bytes that end in a zero: frames, whatever they hold.
fn zero_terminated_runs(bytes: &[u8]) -> u32 {
    bytes
        .split(|&b| b == 0)
        .rev()
        .skip(1) // after the last zero: not yet a frame
        .filter(|run| !run.is_empty())
        .count() as u32
}

#[test]
fn garbage_on_the_link_is_counted_and_the_device_keeps_answering_on_its_parameters() {
    let params = boot_params();
    let (mut rig, greeting) = Rig::boot(&encode(&params), false);
    let mut rng = ChaCha8Rng::seed_from_u64(0x5EED_0017);
    let mut decoder = FrameAccumulator::new();
    let mut reading = Reading::default();
    let (mut total_bytes, mut frames_in_bytes) = (0, 0);
    let mut device_output = Vec::new();
    let mut next_index = 0u32;
    let mut kinds = std::collections::BTreeMap::<&str, usize>::new();
    for case in 0..CASES {
        let (kind, mut bytes) = garbage(&mut rng, &mut next_index);
        *kinds.entry(kind).or_default() += 1;
        // A zero ends whatever is pending, then the host asks who and how it is.
        bytes.push(0);
        bytes.extend(frame_bytes(&HostToDevice::Hello));
        bytes.extend(frame_bytes(&HostToDevice::GetStatus));
        reading.read(&mut decoder, &bytes);
        // Every burst ends with a zero, so frames never span two.
        frames_in_bytes += zero_terminated_runs(&bytes);
        total_bytes += bytes.len();
        rig.send_bytes(&bytes);
        let mut out = rig.run();
        let Some(DeviceToHost::Status(status)) = out.pop() else {
            panic!("case {case} ({kind}): no status last: {out:?}")
        };
        let Some(DeviceToHost::Greeting(g)) = out.pop() else {
            panic!("case {case} ({kind}): no greeting before the status")
        };
        assert_eq!(g, greeting, "case {case} ({kind}): greeting changed");
        assert_eq!(
            status.frames_received + status.bad_frames,
            frames_in_bytes,
            "case {case} ({kind}): frames unaccounted for"
        );
        assert_eq!(
            (status.frames_received, status.bad_frames),
            (reading.frames, reading.bad_frames),
            "case {case} ({kind})"
        );
        assert_eq!(status.samples_processed as usize, reading.samples.len());
        assert_eq!(
            status.samples_dropped,
            reading.samples_dropped(),
            "case {case} ({kind})"
        );
        assert_eq!(status.params_source, ParamsSource::Flash { slot: 0 });
        device_output.extend(out);
    }
    // Garbage that decoded as upload steps was answered (and refused: nothing is signed).
    let upload_answers = device_output
        .iter()
        .filter(|m| matches!(m, DeviceToHost::ParamAck(_) | DeviceToHost::ParamNack(_)))
        .count();
    assert_eq!(upload_answers, reading.uploads);
    assert!(
        !device_output.iter().any(|m| matches!(
            m,
            DeviceToHost::ParamAck(supine_core::protocol::ParamAck::Committed { .. })
        )),
        "garbage committed an upload"
    );
    // The pipeline's own output for the samples the host could read, bit for bit.
    let pipeline_output: Vec<DeviceToHost> =
        pipeline_messages(&params, &reading.indices, &reading.samples);
    let device_pipeline_output: Vec<DeviceToHost> = device_output
        .into_iter()
        .filter(|m| matches!(m, DeviceToHost::Telemetry(_) | DeviceToHost::Alert(_)))
        .collect();
    assert_same_messages(&device_pipeline_output, &pipeline_output);
    assert!(reading.bad_frames > CASES as u32 / 4, "too little garbage");
    assert!(reading.samples.len() > 10_000, "too few samples");
    println!(
        "UART garbage: {CASES} cases ({kinds:?}), {} bytes, {} good and {} bad frames, {} samples: all held",
        total_bytes,
        reading.frames,
        reading.bad_frames,
        reading.samples.len()
    );
}

/// Whether a telemetry record that says `valid` holds only finite numbers.
fn valid_and_finite(t: &Telemetry) -> bool {
    let values = t
        .head_acc_m_s2
        .iter()
        .chain(&t.running_rms_m_s2)
        .chain([&t.vector_running_rms_m_s2, &t.vdv_m_s175]);
    !t.valid || values.into_iter().all(|v| v.is_finite())
}

/// The values among `values` that, on any axis of one sample after the warm-up followed
/// by clean samples, make the device report a non-finite value as valid.
fn values_that_poison(values: &[f32]) -> Vec<String> {
    let params = boot_params();
    let mut broken = Vec::new();
    for &value in values {
        for axis in 0..3 {
            let (mut rig, _) = Rig::boot(&encode(&params), false);
            let mut input = samples(31, 4000);
            input[3000][axis] = value;
            rig.send_all(&sample_frames(0, &input));
            let (out, _) = rig.status();
            let bad = out.iter().any(|m| match m {
                DeviceToHost::Telemetry(t) => !valid_and_finite(t),
                _ => false,
            });
            if bad {
                broken.push(format!("{value:e} on axis {axis}"));
            }
        }
    }
    broken
}

#[test]
fn no_nan_or_infinite_sample_makes_valid_telemetry_non_finite() {
    let non_finite = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    assert_eq!(values_that_poison(&non_finite), Vec::<String>::new());
}

// D1 (issue 17): one absurd but finite sample (from about 1e20 m/s^2) overflowed the f32
// exposure state, and the device then streamed NaN running rms with `valid` set. The
// pipeline now clips every sample to the full scale before the model.
#[test]
fn no_extreme_finite_sample_makes_valid_telemetry_non_finite() {
    let extreme = [1e20, -1e20, 1e30, -1e30, f32::MAX, f32::MIN];
    assert_eq!(values_that_poison(&extreme), Vec::<String>::new());
}
