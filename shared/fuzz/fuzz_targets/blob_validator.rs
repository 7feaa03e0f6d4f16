//! Any bytes into the blob validator, both raw and sealed with a valid header and CRC (so
//! the fuzzer reaches the payload checks behind the checksum): no panic, and whatever it
//! accepts is valid and re-encodes to a blob it accepts again.
#![no_main]

use libfuzzer_sys::fuzz_target;
use supine_core::blob::{
    BLOB_FORMAT_VERSION, BLOB_HEADER_LEN, BLOB_MAGIC, DeviceParams, MAX_BLOB_LEN, crc32,
};

fn check(bytes: &[u8]) {
    if let Ok(params) = DeviceParams::decode(bytes) {
        assert_eq!(params.validate(), Ok(()));
        let mut buf = [0u8; MAX_BLOB_LEN];
        let len = params.encode(&mut buf).expect("an accepted blob re-encodes");
        assert_eq!(DeviceParams::decode(&buf[..len]), Ok(params));
    }
}

fuzz_target!(|bytes: &[u8]| {
    check(bytes);
    // The same bytes as a payload behind a correct header.
    let payload = bytes.get(BLOB_HEADER_LEN..).unwrap_or(&[]);
    let mut sealed = Vec::with_capacity(BLOB_HEADER_LEN + payload.len());
    sealed.extend_from_slice(&BLOB_MAGIC);
    sealed.extend_from_slice(&BLOB_FORMAT_VERSION.to_le_bytes());
    sealed.extend_from_slice(&0u16.to_le_bytes());
    sealed.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    sealed.extend_from_slice(&crc32(payload).to_le_bytes());
    sealed.extend_from_slice(payload);
    check(&sealed);
});
