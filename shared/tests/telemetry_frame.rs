//! The hand-written telemetry frame (`protocol::telemetry_frame`, what the device sends
//! once per sample) against postcard + COBS (`protocol::encode_frame`, what the host's
//! decoder reads) for the same `DeviceFrame`: the same bytes, terminating zero included,
//! for many random records. Floats are drawn as raw bits, so NaNs with any payload,
//! subnormals, infinities, signed zeros and floats with zero bytes (which COBS must
//! escape) all occur; sequence numbers and sample indices cluster around the varint
//! length boundaries; every fault set, level and validity is drawn.

use proptest::prelude::*;
use supine_core::alerts::{FaultFlags, Level};
use supine_core::joint_exposure::JointValues;
use supine_core::protocol::telemetry_frame::{self, MAX_FRAME};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, MAX_FRAME_LEN, Telemetry, encode_frame,
};

/// postcard's frame of `DeviceFrame { seq, Telemetry(t) }`.
fn postcard_frame(seq: u32, t: &Telemetry) -> Vec<u8> {
    let frame = DeviceFrame {
        seq,
        message: DeviceToHost::Telemetry(*t),
    };
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode_frame(&frame, &mut buf).expect("fits").to_vec()
}

/// The hand-written frame of the same record.
fn hand_frame(seq: u32, t: &Telemetry) -> Vec<u8> {
    let mut frame = [0xAA; MAX_FRAME];
    let len = telemetry_frame::encode(seq, t, &mut frame);
    frame[..len].to_vec()
}

/// A u32 anywhere, or next to a varint length boundary (2^7, 2^14, 2^21, 2^28) or an end.
fn varint_u32() -> impl Strategy<Value = u32> {
    let boundary = prop::sample::select(vec![0u32, 1 << 7, 1 << 14, 1 << 21, 1 << 28, u32::MAX]);
    prop_oneof![
        any::<u32>(),
        (boundary, -2i64..=1)
            .prop_map(|(b, d)| (i64::from(b) + d).clamp(0, u32::MAX as i64) as u32),
    ]
}

/// An f32 from any bits, or from bits with some bytes cleared (zero bytes in the payload),
/// or one of the special values.
fn any_f32_bits() -> impl Strategy<Value = f32> {
    let special = prop::sample::select(vec![
        0.0f32,
        -0.0,
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7FC0_0001),
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::from_bits(0x8000_0100),
        f32::MAX,
        1.0,
        500.0,
    ]);
    prop_oneof![
        any::<u32>().prop_map(f32::from_bits),
        (any::<u32>(), any::<u8>()).prop_map(|(bits, keep)| {
            let mask = (0..4).fold(0u32, |m, i| {
                if keep & (1 << i) != 0 {
                    m | 0xFF << (8 * i)
                } else {
                    m
                }
            });
            f32::from_bits(bits & mask)
        }),
        special,
    ]
}

fn any_telemetry() -> impl Strategy<Value = Telemetry> {
    let level = prop::sample::select(vec![
        Level::Normal,
        Level::Advisory,
        Level::Warning,
        Level::Alarm,
    ]);
    let faults = (0..=FaultFlags::all().as_repr())
        .prop_map(|bits| FaultFlags::try_from_repr(bits).expect("known bits"));
    (
        varint_u32(),
        prop::array::uniform3(any_f32_bits()),
        prop::array::uniform3(any_f32_bits()),
        any_f32_bits(),
        any_f32_bits(),
        level,
        faults,
        any::<bool>(),
        prop::collection::vec(any_f32_bits(), 0..=10),
    )
        .prop_map(
            |(
                sample_index,
                head,
                running,
                vector,
                vdv,
                alert_level,
                fault_flags,
                valid,
                joints,
            )| {
                Telemetry {
                    sample_index,
                    head_acc_m_s2: head,
                    running_rms_m_s2: running,
                    vector_running_rms_m_s2: vector,
                    vdv_m_s175: vdv,
                    alert_level,
                    fault_flags,
                    valid,
                    joints: JointValues::from_slice(&joints).expect("at most ten"),
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn the_hand_written_frame_is_postcards_byte_for_byte(
        seq in varint_u32(),
        t in any_telemetry(),
    ) {
        let hand = hand_frame(seq, &t);
        prop_assert_eq!(&hand, &postcard_frame(seq, &t));
        prop_assert!(hand.len() <= MAX_FRAME);
        // One zero, at the end: the frame is delimited as on the wire.
        prop_assert_eq!(hand.iter().position(|b| *b == 0), Some(hand.len() - 1));
    }
}

#[test]
fn every_fault_set_and_level_at_every_varint_length_matches() {
    // Exhaustive over what is small: 16 fault sets, 4 levels, both validities, and the
    // sequence numbers at each varint length's ends (1 to 5 bytes).
    let lengths = [
        0,
        127,
        128,
        16_383,
        16_384,
        2_097_151,
        2_097_152,
        268_435_455,
        268_435_456,
        u32::MAX,
    ];
    let levels = [Level::Normal, Level::Advisory, Level::Warning, Level::Alarm];
    for bits in 0..=FaultFlags::all().as_repr() {
        for (level, valid) in levels.into_iter().flat_map(|l| [(l, false), (l, true)]) {
            for &seq in &lengths {
                let t = Telemetry {
                    sample_index: seq.rotate_left(bits.into()),
                    head_acc_m_s2: [0.0, f32::NAN, -1.0],
                    running_rms_m_s2: [f32::from_bits(1), f32::INFINITY, 0.5],
                    vector_running_rms_m_s2: 2.0,
                    vdv_m_s175: f32::from_bits(0x0000_FF00),
                    alert_level: level,
                    fault_flags: FaultFlags::try_from_repr(bits).expect("known bits"),
                    valid,
                    joints: JointValues::from_slice(
                        &[0.0, f32::NAN, 1e-3][..usize::from(bits % 4)],
                    )
                    .expect("at most ten"),
                };
                assert_eq!(
                    hand_frame(seq, &t),
                    postcard_frame(seq, &t),
                    "seq {seq} {t:?}"
                );
            }
        }
    }
}

#[test]
fn the_longest_frame_fills_max_frame_and_decodes_back() {
    // Both varints at 5 bytes and no zero byte anywhere: the longest a frame gets.
    let t = Telemetry {
        sample_index: u32::MAX,
        head_acc_m_s2: [1.5, -2.5, 3.5],
        running_rms_m_s2: [0.25, 0.75, 1.25],
        vector_running_rms_m_s2: 1.75,
        vdv_m_s175: 9.5,
        alert_level: Level::Alarm,
        fault_flags: FaultFlags::all(),
        valid: true,
        joints: JointValues::from_slice(&[1.5e-3; 10]).expect("ten"),
    };
    let frame = hand_frame(u32::MAX, &t);
    assert_eq!(frame.len(), MAX_FRAME);
    let mut acc = FrameAccumulator::new();
    let decoded: Vec<DeviceFrame> = frame
        .iter()
        .filter_map(|b| match acc.push::<DeviceFrame>(*b) {
            FrameEvent::Message(m) => Some(m),
            _ => None,
        })
        .collect();
    assert_eq!(
        decoded,
        [DeviceFrame {
            seq: u32::MAX,
            message: DeviceToHost::Telemetry(t)
        }]
    );
}
