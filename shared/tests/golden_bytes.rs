//! Every message and the example blob encode to exactly the golden bytes, and decode back.
//! The firmware's self-test checks the same table on the device.

use supine_core::blob::{BLOB_HEADER_LEN, DeviceParams, MAX_BLOB_LEN};
use supine_core::protocol::golden::{
    BLOB, DEVICE_TO_HOST, HOST_TO_DEVICE, blob_example, device_to_host_examples,
    host_to_device_examples,
};
use supine_core::protocol::{
    DeviceFrame, FrameAccumulator, FrameEvent, HostToDevice, MAX_FRAME_LEN, encode_frame,
};

fn rust_bytes(bytes: &[u8]) -> String {
    let hex: Vec<String> = bytes.iter().map(|b| format!("0x{b:02x}")).collect();
    format!("&[{}]", hex.join(", "))
}

fn decode_all<T: serde::de::DeserializeOwned>(frame: &[u8]) -> Vec<T> {
    let mut acc = FrameAccumulator::new();
    frame
        .iter()
        .filter_map(|b| match acc.push::<T>(*b) {
            FrameEvent::Message(m) => Some(m),
            FrameEvent::Pending => None,
            FrameEvent::Dropped(e) => panic!("golden frame dropped: {e}"),
        })
        .collect()
}

#[test]
fn every_host_to_device_message_encodes_to_its_golden_bytes_and_back() {
    let mut mismatches = Vec::new();
    for (i, (message, golden)) in host_to_device_examples()
        .iter()
        .zip(HOST_TO_DEVICE)
        .enumerate()
    {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(message, &mut buf).unwrap();
        if frame != golden {
            mismatches.push(format!("host_to_device[{i}]: {}", rust_bytes(frame)));
        }
        assert_eq!(decode_all::<HostToDevice>(frame), vec![message.clone()]);
    }
    assert!(
        mismatches.is_empty(),
        "encodings changed without a version bump:\n{}",
        mismatches.join("\n")
    );
}

#[test]
fn every_device_to_host_message_encodes_to_its_golden_bytes_and_back() {
    let mut mismatches = Vec::new();
    for (i, (message, golden)) in device_to_host_examples()
        .iter()
        .zip(DEVICE_TO_HOST)
        .enumerate()
    {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(message, &mut buf).unwrap();
        if frame != golden {
            mismatches.push(format!("device_to_host[{i}]: {}", rust_bytes(frame)));
        }
        assert_eq!(decode_all::<DeviceFrame>(frame), vec![message.clone()]);
    }
    assert!(
        mismatches.is_empty(),
        "encodings changed without a version bump:\n{}",
        mismatches.join("\n")
    );
}

#[test]
fn the_example_blob_encodes_to_its_golden_bytes_and_decodes_back() {
    let example = blob_example().unwrap();
    let mut buf = [0u8; MAX_BLOB_LEN];
    let len = example.encode(&mut buf).unwrap();
    assert!(len > BLOB_HEADER_LEN);
    assert_eq!(DeviceParams::decode(&buf[..len]).unwrap(), example);
    if std::env::var_os("SUPINE_RECORD_GOLDEN").is_some() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/golden_blob.bin");
        std::fs::write(path, &buf[..len]).unwrap();
    }
    assert!(
        &buf[..len] == BLOB,
        "blob encoding changed without a version bump ({len} bytes now, {} golden)",
        BLOB.len()
    );
}
