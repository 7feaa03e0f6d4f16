//! Single bytes over the link to the host, on the `embedded-io` traits.
//!
//! The main loop must never wait for input and waits for output only when its transmit
//! ring is full, so it reads only after `read_ready` and writes without waiting only after
//! `write_ready`; each call moves one byte, as the UARTs do.

use embedded_io::{Read, ReadReady, Write, WriteReady};

/// The byte link to the host: UART0 (CMSDK) under QEMU, USART1 on the board, buffers in
/// host tests.
pub trait Link: Read + ReadReady + Write + WriteReady {}

impl<T: Read + ReadReady + Write + WriteReady> Link for T {}

/// The received byte, if one has arrived. A receive error (overrun, framing) loses the
/// byte: the frame it belonged to then fails to decode and is counted as bad.
pub(crate) fn try_read_byte(link: &mut impl Link) -> Option<u8> {
    if !matches!(link.read_ready(), Ok(true)) {
        return None;
    }
    let mut byte = [0u8];
    match link.read(&mut byte) {
        Ok(1) => Some(byte[0]),
        _ => None,
    }
}

/// Sends `byte` if the link takes it without waiting; returns whether it was sent.
pub(crate) fn try_write_byte(link: &mut impl Link, byte: u8) -> bool {
    matches!(link.write_ready(), Ok(true)) && matches!(link.write(&[byte]), Ok(1))
}

/// Sends `byte`, waiting for room (`write` blocks until it takes a byte). A link that
/// fails the write loses the byte, and the host counts the frame as bad, rather than the
/// loop hanging on it.
pub(crate) fn write_byte(link: &mut impl Link, byte: u8) {
    let _ = link.write(&[byte]);
}
