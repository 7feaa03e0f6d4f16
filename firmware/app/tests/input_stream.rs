//! The input stream on the monitor's main loop (see `monitor.rs` for the rig): asked for,
//! the device sends the input its model got for every sample, and that is exactly the
//! input `supine_core::pipeline` reports for the same samples, through index gaps, a
//! non-finite sample (held), values beyond the input range (clipped) and a partial block;
//! the telemetry and alerts are unchanged by the stream; asked to stop, it stops.

mod support;

use supine_app::{IDLE_FLUSH_MS, ticks_in_ms};
use supine_core::input_resolution::to_m_s2;
use supine_core::pipeline::{BLOCK_LEN, PipelineState};
use supine_core::protocol::{DeviceToHost, HostToDevice, MAX_INPUT_SAMPLES_PER_FRAME};
use support::*;

/// The pipeline's own report of its input for these samples, from rest (the host's
/// reference reads it back block by block).
fn pipeline_inputs(
    params: &supine_core::blob::DeviceParams,
    indices: &[u32],
    samples: &[[f32; 3]],
) -> Streamed {
    let run = inputs_block_by_block(params, indices, samples);
    indices.iter().copied().zip(run).collect()
}

/// The model's inputs, a block per call as the device runs them.
fn inputs_block_by_block(
    params: &supine_core::blob::DeviceParams,
    indices: &[u32],
    samples: &[[f32; 3]],
) -> Vec<[i16; 3]> {
    let mut state = PipelineState::new();
    let mut out = Vec::new();
    for (i, x) in indices.chunks(BLOCK_LEN).zip(samples.chunks(BLOCK_LEN)) {
        params.process(&mut state, i, x, |_| {});
        let mut recent = vec![[0i16; 3]; i.len()];
        state.recent_inputs(&mut recent);
        out.extend(recent);
    }
    out
}

/// Streamed samples: (sample index, x, y, z counts).
type Streamed = Vec<(u32, [i16; 3])>;

/// The streamed samples, in order, the messages without the input frames, and how many
/// input frames there were.
fn split(messages: Vec<DeviceToHost>) -> (Streamed, Vec<DeviceToHost>, usize) {
    let (mut inputs, mut rest, mut frames) = (Vec::new(), Vec::new(), 0);
    for m in messages {
        match m {
            DeviceToHost::Input(batch) => {
                frames += 1;
                let samples = batch.samples().expect("a well-formed batch");
                assert!(samples.len() <= MAX_INPUT_SAMPLES_PER_FRAME);
                inputs.extend(samples);
            }
            other => rest.push(other),
        }
    }
    (inputs, rest, frames)
}

#[test]
fn the_stream_carries_exactly_the_pipelines_input_and_changes_nothing_else() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), false);
    rig.send(&HostToDevice::StreamInput { enabled: true });
    let mut input = samples(11, 1000);
    input[100][0] = f32::NAN;
    input[200] = [70.0, -1e30, 3.0];
    input[300][2] = 1e-3 / 3.0;
    // A gap of 7 indices inside what would be one block.
    let indices: Vec<u32> = (0..405).chain(412..1007).collect();
    let mut frames = sample_frames(0, &input[..405]);
    frames.extend(sample_frames(412, &input[405..]));
    rig.send_all(&frames);
    let (messages, status) = rig.status();
    assert_eq!(status.samples_processed, 1000);
    let (streamed, rest, input_frames) = split(messages);

    let expected = pipeline_inputs(&params, &indices, &input);
    assert_eq!(streamed.len(), 1000);
    assert_eq!(streamed, expected);
    // Held, clipped, rounded: the values the model got.
    assert_eq!(streamed[100].1, streamed[99].1);
    assert_eq!(streamed[200].1[..2], [i16::MAX, -i16::MAX]);
    assert_eq!(to_m_s2(streamed[300].1[2]), 0.0);
    // One frame per block, one more where the gap splits a block.
    assert_eq!(input_frames, 1000_usize.div_ceil(16) + 1);
    assert_same_messages(&rest, &pipeline_messages(&params, &indices, &input));
}

#[test]
fn a_partial_block_is_streamed_and_stopping_the_stream_stops_it() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), false);
    let input = samples(12, 40);
    rig.send(&HostToDevice::StreamInput { enabled: true });
    rig.send_all(&sample_frames(0, &input[..21]));
    let mut messages = rig.run();
    rig.advance_ticks(ticks_in_ms(DEFAULT_TICK_RATE_HZ, IDLE_FLUSH_MS));
    messages.extend(rig.run());
    let (streamed, _, frames) = split(messages);
    let expected = pipeline_inputs(&params, &(0..40).collect::<Vec<u32>>(), &input);
    assert_eq!(streamed, expected[..21]);
    assert_eq!(
        frames, 2,
        "a block of 16, then the 5 flushed after the pause"
    );

    rig.send(&HostToDevice::StreamInput { enabled: false });
    rig.send_all(&sample_frames(21, &input[21..]));
    let (messages, _) = rig.status();
    let (streamed, rest, _) = split(messages);
    assert!(streamed.is_empty(), "{streamed:?}");
    assert_eq!(count_telemetry(&rest), 19);
}
