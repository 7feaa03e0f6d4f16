//! The monitor's main loop on the host: an in-memory link, a simulated clock and a RAM
//! flash stand in for the UART, SysTick and the PARAMS slots. Every frame the monitor
//! sends is decoded as the host decodes it, and every telemetry record and alert is
//! compared, bit for bit, with what `supine_core::pipeline` computes directly from the
//! same samples and parameters.

mod support;

use supine_app::{IDLE_FLUSH_MS, ticks_in_ms};
use supine_core::alerts::{AlertEvent, Level, SensorFault};
use supine_core::pipeline::PipelineState;
use supine_core::protocol::{
    DeviceToHost, Greeting, HostToDevice, PROTOCOL_VERSION, ParamAck, ParamsSource, ResetCause,
    Status, UploadError,
};
use supine_core::upload::select;
use support::*;

#[test]
fn greets_at_boot_and_again_on_hello() {
    let params = boot_params();
    let (mut rig, greeting) = Rig::boot(&encode(&params), false);
    let expected = Greeting {
        protocol_version: PROTOCOL_VERSION,
        firmware_version: heapless::String::try_from(
            format!("{}{BUILD}", env!("CARGO_PKG_VERSION")).as_str(),
        )
        .unwrap(),
        params_identity: BOOT_IDENTITY,
        params_source: ParamsSource::Flash { slot: 0 },
        sample_rate_hz: SAMPLE_RATE_HZ as f32,
        height_m: 1.82,
        mass_kg: 81.0,
        reset_cause: ResetCause::PowerOn,
        last_panic: heapless::String::new(),
        // The default: all ten joint outputs.
        joint_outputs: 0b11_1111_1111,
        calibration: params.calibration,
    };
    assert_eq!(greeting, expected);
    rig.send(&HostToDevice::Hello);
    assert_eq!(rig.run(), [DeviceToHost::Greeting(expected)]);
}

#[test]
fn telemetry_and_alerts_are_the_pipelines_bit_for_bit_and_the_status_counts_them() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), false);
    // 1,500 samples, a gap of 13, then 1,800 more with one NaN: past the 5 s warm-up
    // and the dwell, so exposure levels rise, with index-gap and non-finite faults.
    let mut input = samples(7, 3300);
    input[2000][1] = f32::NAN;
    let indices: Vec<u32> = (0..1500).chain(1513..3313).collect();
    let mut frames = sample_frames(0, &input[..1500]);
    frames.extend(sample_frames(1513, &input[1500..]));
    rig.send_all(&frames);
    // A frame that decodes as COBS but not as a message.
    rig.wire.borrow_mut().rx.extend([0x02, 0x63, 0x00]);

    let (messages, status) = rig.status();

    let expected = pipeline_messages(&params, &indices, &input);
    assert_same_messages(&messages, &expected);
    // The joints' exposure the status reports is the pipeline's own, at the same point.
    let mut state = PipelineState::new();
    params.process(&mut state, &indices, &input, |_| {});
    let joint_count = params.joints.packed_outputs().count();
    assert_eq!(joint_count, 10);
    assert_eq!(count_telemetry(&messages), 3300, "one record per sample");
    let alerts: Vec<AlertEvent> = messages
        .iter()
        .filter_map(|m| match m {
            DeviceToHost::Alert(e) => Some(*e),
            _ => None,
        })
        .collect();
    let raised = |fault| {
        alerts
            .iter()
            .any(|e| matches!(e, AlertEvent::Fault { fault: f, active: true, .. } if *f == fault))
    };
    assert!(raised(SensorFault::IndexGap), "{alerts:?}");
    assert!(raised(SensorFault::NonFinite), "{alerts:?}");
    assert!(
        alerts
            .iter()
            .any(|e| matches!(e, AlertEvent::Level { to, .. } if *to > Level::Normal)),
        "{alerts:?}"
    );
    assert_eq!(
        status,
        Status {
            frames_received: frames.len() as u32 + 1,
            bad_frames: 1,
            samples_processed: 3300,
            samples_dropped: 13,
            telemetry_sent: 3300,
            uploads_rejected: 0,
            // The simulated clock stood still.
            busy_ticks: 0,
            stack_used_bytes: STACK_BYTES as u32,
            params_source: ParamsSource::Flash { slot: 0 },
            height_m: params.patient.height_m,
            mass_kg: params.patient.mass_kg,
            joint_running_rms: state.joints().running_rms(joint_count),
            joint_largest_excursion: state.joints().largest_excursion(joint_count),
            calibration: params.calibration,
        }
    );
    assert!(
        status
            .joint_largest_excursion
            .as_slice()
            .iter()
            .all(|&v| v > 0.0)
    );
}

/// The pause is 100 ms of each board's own clock: its ticks at mps2-an386's 25 MHz
/// SysTick, the Black Pill's 64 MHz core clock and a slow 32.768 kHz one, each written
/// out here from 0.1 s times the rate (rounded up: never a shorter wait).
#[test]
fn a_pause_of_100_ms_in_each_boards_clock_processes_a_partial_block() {
    assert_eq!(IDLE_FLUSH_MS, 100);
    let params = boot_params();
    for (rate_hz, pause_ticks) in [
        (25_000_000, 2_500_000),
        (64_000_000, 6_400_000),
        (32_768, 3_277),
    ] {
        assert_eq!(ticks_in_ms(rate_hz, IDLE_FLUSH_MS), pause_ticks);
        let (mut rig, _) = Rig::boot_at_rate(&encode(&params), rate_hz, 0);
        let input = samples(3, 5);
        rig.send_all(&sample_frames(0, &input));
        assert_eq!(rig.run(), [], "a partial block waits for more samples");
        rig.advance_ticks(pause_ticks - 1);
        assert_eq!(rig.run(), [], "not yet a pause at {rate_hz} Hz");
        rig.advance_ticks(1);
        let messages = rig.run();
        assert_eq!(count_telemetry(&messages), 5, "{rate_hz} Hz");
        assert_same_messages(
            &messages,
            &pipeline_messages(&params, &[0, 1, 2, 3, 4], &input),
        );
    }
}

/// `Status::busy_ticks` counts the board's ticks around the pipeline only: on a clock
/// that moves a tick each time it is read, and a host that pauses a second of that clock
/// between frames, the busy time is a few ticks a block, never the pauses.
#[test]
fn busy_ticks_count_the_pipelines_ticks_and_never_the_wait_for_the_link() {
    let params = boot_params();
    let rate_hz = 64_000_000;
    let (mut rig, _) = Rig::boot_at_rate(&encode(&params), rate_hz, 1);
    let input = samples(4, 64);
    let frames = sample_frames(0, &input);
    for frame in &frames {
        rig.send_all(std::slice::from_ref(frame));
        rig.run();
        rig.advance_ticks(rate_hz);
    }
    let (_, status) = rig.status();
    assert_eq!(status.samples_processed, 64);
    let waited = u64::from(rate_hz) * frames.len() as u64;
    println!("busy_ticks {} while waiting {waited}", status.busy_ticks);
    assert!(
        status.busy_ticks > 0,
        "the pipeline's own ticks are counted"
    );
    assert!(status.busy_ticks < 1_000, "{}", status.busy_ticks);
}

#[test]
fn a_slow_link_gets_every_frame_in_order() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), true);
    let input = samples(11, 800);
    rig.send_all(&sample_frames(1000, &input));
    let (messages, status) = rig.status();
    let indices: Vec<u32> = (1000..1800).collect();
    assert_same_messages(&messages, &pipeline_messages(&params, &indices, &input));
    assert_eq!(
        (status.samples_processed, status.telemetry_sent),
        (800, 800)
    );
}

#[test]
fn refused_uploads_are_answered_counted_and_change_nothing() {
    let params = boot_params();
    let boot_blob = encode(&params);
    let (mut rig, greeting) = Rig::boot(&boot_blob, false);
    let flash_before = rig.flash.borrow().clone();
    let new_blob = encode(&upload_params());

    // Signed with another key: every step is taken, the commit is refused.
    let mut wrong_key = development_key();
    wrong_key[0] ^= 1;
    rig.send_all(&upload_messages(&new_blob, 1, &wrong_key));
    let mut expected = transfer_acks(&new_blob);
    expected.push(DeviceToHost::ParamNack(UploadError::BadSignature));
    assert_eq!(rig.run(), expected);

    // Properly signed, but its counter is not above the running blob's (0): a replay.
    rig.send_all(&upload_messages(&new_blob, 0, &development_key())[..1]);
    assert_eq!(rig.run(), [DeviceToHost::ParamNack(UploadError::Replayed)]);

    let flash_after = rig.flash.borrow().clone();
    assert_eq!(
        flash_after.operations, flash_before.operations,
        "flash touched"
    );
    assert!(flash_after.slots == flash_before.slots);
    rig.send(&HostToDevice::Hello);
    assert_eq!(rig.run(), [DeviceToHost::Greeting(greeting)]);
    // Still the boot parameters, on the state they had.
    let input = samples(5, 40);
    rig.send_all(&sample_frames(0, &input));
    let (messages, status) = rig.status();
    let indices: Vec<u32> = (0..40).collect();
    assert_same_messages(&messages, &pipeline_messages(&params, &indices, &input));
    assert_eq!(status.uploads_rejected, 2);
    assert_eq!(status.params_source, ParamsSource::Flash { slot: 0 });
}

#[test]
fn an_accepted_upload_is_stored_in_the_other_slot_and_runs_from_the_next_sample() {
    let old = boot_params();
    let old_blob = encode(&old);
    let (mut rig, boot_greeting) = Rig::boot(&old_blob, false);
    let new = upload_params();
    let new_blob = encode(&new);

    // 20 samples: one block runs at once, the last 4 wait in the buffer; the commit
    // finishes them on the old parameters before it switches.
    let before = samples(21, 20);
    rig.send_all(&sample_frames(0, &before));
    rig.send_all(&upload_messages(&new_blob, 1, &development_key()));
    let messages = rig.run();

    // The first block's output, the acks of the transfer as the chunks arrive, then at
    // the commit the buffered samples' output.
    let old_indices: Vec<u32> = (0..20).collect();
    let mut state = PipelineState::new();
    let mut expected = pipeline_messages_from(&mut state, &old, &old_indices[..16], &before[..16]);
    expected.extend(transfer_acks(&new_blob));
    expected.extend(pipeline_messages_from(
        &mut state,
        &old,
        &old_indices[16..],
        &before[16..],
    ));
    expected.push(DeviceToHost::ParamAck(ParamAck::Committed {
        identity: UPLOAD_IDENTITY,
        slot: 1,
    }));
    expected.push(DeviceToHost::Greeting(Greeting {
        params_identity: UPLOAD_IDENTITY,
        params_source: ParamsSource::Flash { slot: 1 },
        height_m: UPLOAD_SUBJECT.height_m as f32,
        mass_kg: UPLOAD_SUBJECT.mass_kg as f32,
        // The upload's calibration, the datasheet's, replaces the boot blob's.
        calibration: supine_core::calibration::SensorCalibration::DATASHEET,
        ..boot_greeting
    }));
    // The boot blob's patient was the paper's mean subject.
    assert_eq!(
        (boot_greeting.height_m, boot_greeting.mass_kg),
        (1.82, 81.0)
    );
    assert_same_messages(&messages, &expected);

    // In flash: slot B holds the new blob with its commit record and wins at the next
    // boot; slot A is as it was.
    let view = rig.flash.borrow().clone();
    assert!(view.operations > 0);
    assert_eq!(&view.slots[0][..old_blob.len()], old_blob.as_slice());
    assert_eq!(&view.slots[1][..new_blob.len()], new_blob.as_slice());
    let next_boot = select(&Snapshot(view.slots)).expect("a valid slot");
    assert_eq!((next_boot.slot, next_boot.counter), (1, 1));
    assert_eq!(next_boot.params, new);

    // The new parameters from a fresh state: another model, every 5th sample reported.
    let after = samples(22, 100);
    rig.send_all(&sample_frames(20, &after));
    let (messages, status) = rig.status();
    let new_indices: Vec<u32> = (20..120).collect();
    assert_same_messages(&messages, &pipeline_messages(&new, &new_indices, &after));
    assert_eq!(count_telemetry(&messages), 20);
    assert_eq!(status.params_source, ParamsSource::Flash { slot: 1 });
    assert_eq!((status.height_m, status.mass_kg), (1.6, 52.0));
    assert_eq!(status.uploads_rejected, 0);
    assert_eq!(status.samples_processed, 120);
}

/// The index-gap faults raised while `frames` are processed, and the samples counted as
/// dropped.
fn gaps_after(frames: &[HostToDevice]) -> (usize, u32) {
    let (mut rig, _) = Rig::boot(&encode(&boot_params()), false);
    rig.send_all(frames);
    let (messages, status) = rig.status();
    let raised = messages
        .iter()
        .filter(|m| {
            matches!(
                m,
                DeviceToHost::Alert(AlertEvent::Fault {
                    fault: SensorFault::IndexGap,
                    active: true,
                    ..
                })
            )
        })
        .count();
    (raised, status.samples_dropped)
}

#[test]
fn a_gap_of_up_to_a_minute_of_samples_is_counted_as_lost_and_a_longer_jump_as_a_new_stream() {
    let max_lost = (SAMPLE_RATE_HZ * f64::from(supine_app::MAX_LOST_SPAN_S)) as u32;
    assert_eq!(max_lost, 30_000);
    let input = samples(9, 16);
    // Eight samples, then eight more `jump` indices further on than the next expected.
    let after = |start: u32, jump: u32| {
        let mut frames = sample_frames(start, &input[..8]);
        frames.extend(sample_frames(
            start.wrapping_add(8).wrapping_add(jump),
            &input[8..],
        ));
        frames
    };
    for (name, frames, dropped) in [
        ("no gap", after(0, 0), 0),
        ("one sample", after(100, 1), 1),
        ("a minute of samples", after(100, max_lost), max_lost),
        ("across u32::MAX", after(u32::MAX - 10, 5), 5),
        ("a minute and a sample", after(100, max_lost + 1), 0),
        ("2^31 samples", after(100, 1 << 31), 0),
        ("back to 0", after(1000, 0u32.wrapping_sub(1008)), 0),
        ("one back (a repeat)", after(1000, u32::MAX), 0),
    ] {
        let (raised, counted) = gaps_after(&frames);
        assert_eq!(counted, dropped, "{name}: samples_dropped");
        assert_eq!(
            raised,
            usize::from(name != "no gap"),
            "{name}: index-gap fault"
        );
    }
}
