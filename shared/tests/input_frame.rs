//! The hand-written input frame (`protocol::input_frame`, what the device sends per block
//! while the input stream is on) against postcard + COBS (`protocol::encode_frame`, what
//! the host's decoder reads) for the same batch: the same bytes for many random batches
//! (counts anywhere in the i16 range, so every zigzag-varint length and wrapping
//! differences occur; sequence numbers and indices around varint length boundaries), and
//! the decoded batch gives back the counts.

use proptest::prelude::*;
use supine_core::protocol::input_frame::{self, MAX_FRAME, PackError};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, InputBatch,
    MAX_INPUT_SAMPLES_PER_FRAME, encode_frame,
};

fn varint_u32() -> impl Strategy<Value = u32> {
    let boundary = prop::sample::select(vec![0u32, 1 << 7, 1 << 14, 1 << 21, 1 << 28, u32::MAX]);
    prop_oneof![
        any::<u32>(),
        (boundary, -2i64..=1)
            .prop_map(|(b, d)| (i64::from(b) + d).clamp(0, u32::MAX as i64) as u32),
    ]
}

/// Counts of a quiet ride (small differences), or anywhere, or at the ends of the range.
fn counts() -> impl Strategy<Value = [i16; 3]> {
    let one = prop_oneof![
        -200i16..200,
        any::<i16>(),
        prop::sample::select(vec![i16::MIN + 1, i16::MAX, 0, -1, 63, 64, -64, -65]),
    ];
    [one.clone(), one.clone(), one]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn the_hand_frame_is_postcards_and_decodes_to_the_counts(
        seq in varint_u32(),
        first in varint_u32(),
        samples in prop::collection::vec(counts(), 0..=MAX_INPUT_SAMPLES_PER_FRAME),
    ) {
        let frame = DeviceFrame {
            seq,
            message: DeviceToHost::Input(InputBatch::from_counts(first, &samples)),
        };
        let mut buf = [0u8; 512];
        let postcard = encode_frame(&frame, &mut buf).expect("fits").to_vec();
        let mut buf = [0xAA; MAX_FRAME];
        let at = input_frame::encode(seq, first, &samples, &mut buf);
        let hand = &buf[at];
        prop_assert_eq!(hand, &postcard[..]);

        let mut acc = FrameAccumulator::new();
        let decoded: Vec<DeviceFrame> = hand
            .iter()
            .filter_map(|&b| match acc.push::<DeviceFrame>(b) {
                FrameEvent::Message(m) => Some(m),
                _ => None,
            })
            .collect();
        prop_assert_eq!(decoded.len(), 1);
        let DeviceToHost::Input(batch) = &decoded[0].message else {
            panic!("not an input frame: {:?}", decoded[0]);
        };
        let expected: Vec<(u32, [i16; 3])> = samples
            .iter()
            .enumerate()
            .map(|(n, &c)| (first.wrapping_add(n as u32), c))
            .collect();
        prop_assert_eq!(batch.samples().expect("decodes").to_vec(), expected);
    }
}

#[test]
fn a_full_frame_of_the_widest_differences_fits_the_link_limit() {
    let samples: Vec<[i16; 3]> = (0..MAX_INPUT_SAMPLES_PER_FRAME)
        // Differences of +-10,000 counts: three varint bytes each, none zero; wider ones
        // wrap to small ones.
        .map(|n| if n % 2 == 0 { [10_000; 3] } else { [0; 3] })
        .collect();
    let mut buf = [0u8; MAX_FRAME];
    let at = input_frame::encode(u32::MAX, u32::MAX, &samples, &mut buf);
    assert!(at.len() <= supine_core::protocol::MAX_FRAME_LEN, "{at:?}");
    assert_eq!(
        at,
        0..MAX_FRAME,
        "the bound is reached, so it is the right one"
    );
}

#[test]
fn packed_bytes_that_do_not_make_whole_samples_are_refused() {
    let mut batch = InputBatch::from_counts(7, &[[1, 2, 3], [4, 5, 6]]);
    assert_eq!(
        batch.samples().expect("decodes").to_vec(),
        vec![(7, [1, 2, 3]), (8, [4, 5, 6])]
    );
    // Cut inside the second sample.
    batch.packed.truncate(4);
    assert_eq!(batch.samples(), Err(PackError::Malformed));
    // A varint longer than an i16's (four bytes).
    batch.packed.clear();
    batch
        .packed
        .extend_from_slice(&[0x80, 0x80, 0x80, 0x01, 0, 0])
        .unwrap();
    assert_eq!(batch.samples(), Err(PackError::Malformed));
    // Three bytes, but above u16.
    batch.packed.clear();
    batch
        .packed
        .extend_from_slice(&[0xFF, 0xFF, 0x7F, 0, 0])
        .unwrap();
    assert_eq!(batch.samples(), Err(PackError::Malformed));
    // More samples than a frame carries (17 samples of zeros).
    batch.packed.clear();
    batch.packed.extend_from_slice(&[0; 51]).unwrap();
    assert_eq!(batch.samples(), Err(PackError::TooLong));
}
