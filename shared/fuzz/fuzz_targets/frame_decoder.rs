//! Any byte stream into both directions' frame decoders: no panic, and every decoded
//! message re-encodes to a frame that decodes and re-encodes to the same bytes (bytes, not
//! values: a NaN is not equal to itself).
#![no_main]

use libfuzzer_sys::fuzz_target;
use supine_core::protocol::{
    DeviceFrame, FrameAccumulator, FrameEvent, HostToDevice, MAX_FRAME_LEN, encode_frame,
};

fn roundtrip<T>(bytes: &[u8])
where
    T: serde::Serialize + serde::de::DeserializeOwned + core::fmt::Debug,
{
    let mut acc = FrameAccumulator::new();
    for &b in bytes {
        if let FrameEvent::Message(m) = acc.push::<T>(b) {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode_frame(&m, &mut buf).expect("a decoded message fits a frame");
            let mut again = FrameAccumulator::new();
            let decoded: Vec<T> = frame
                .iter()
                .filter_map(|b| match again.push::<T>(*b) {
                    FrameEvent::Message(m) => Some(m),
                    _ => None,
                })
                .collect();
            assert_eq!(decoded.len(), 1);
            let mut buf2 = [0u8; MAX_FRAME_LEN];
            let frame2 = encode_frame(&decoded[0], &mut buf2).expect("re-encodes");
            assert_eq!(frame2, &buf[..frame2.len()]);
        }
    }
}

fuzz_target!(|bytes: &[u8]| {
    roundtrip::<HostToDevice>(bytes);
    roundtrip::<DeviceFrame>(bytes);
});
