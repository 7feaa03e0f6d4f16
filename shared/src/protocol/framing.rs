//! COBS framing: encoding one message into a zero-terminated frame, and accumulating a
//! byte stream into messages while counting what had to be dropped.

use serde::Serialize;
use serde::de::DeserializeOwned;

use super::MAX_FRAME_LEN;

/// Why a frame was dropped (or could not be built).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Longer than [`MAX_FRAME_LEN`] before its terminating zero.
    Oversize,
    /// COBS decoding or postcard deserialization failed.
    Malformed,
    /// The output buffer was too small to encode into.
    BufferTooSmall,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FrameError::Oversize => "frame longer than the maximum",
            FrameError::Malformed => "frame failed COBS or postcard decoding",
            FrameError::BufferTooSmall => "buffer too small for the frame",
        })
    }
}

impl core::error::Error for FrameError {}

/// Encodes `message` as postcard + COBS with the terminating zero; returns the frame.
pub fn encode_frame<'b, T: Serialize>(
    message: &T,
    buf: &'b mut [u8],
) -> Result<&'b mut [u8], FrameError> {
    postcard::to_slice_cobs(message, buf).map_err(|_| FrameError::BufferTooSmall)
}

/// What one byte did to the accumulator.
#[derive(Debug, PartialEq)]
pub enum FrameEvent<T> {
    /// Nothing complete yet.
    Pending,
    /// A frame decoded to a message.
    Message(T),
    /// A frame was dropped.
    Dropped(FrameError),
}

/// Collects bytes until a zero, then decodes; oversize frames are discarded whole (to the
/// next zero) and reported once.
#[derive(Clone, Debug)]
pub struct FrameAccumulator {
    buf: [u8; MAX_FRAME_LEN],
    len: usize,
    discarding: bool,
}

impl Default for FrameAccumulator {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameAccumulator {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME_LEN],
            len: 0,
            discarding: false,
        }
    }

    /// Feeds one received byte.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> FrameEvent<T> {
        if byte != 0 {
            if self.discarding {
                return FrameEvent::Pending;
            }
            if self.len == MAX_FRAME_LEN {
                self.discarding = true;
                self.len = 0;
                return FrameEvent::Dropped(FrameError::Oversize);
            }
            self.buf[self.len] = byte;
            self.len += 1;
            return FrameEvent::Pending;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.discarding) || len == 0 {
            // End of a discarded frame, or an idle zero between frames.
            return FrameEvent::Pending;
        }
        // Every byte must belong to the message: trailing bytes are a malformed frame.
        let Ok(decoded_len) = cobs::decode_in_place(&mut self.buf[..len]) else {
            return FrameEvent::Dropped(FrameError::Malformed);
        };
        match postcard::take_from_bytes::<T>(&self.buf[..decoded_len]) {
            Ok((message, [])) => FrameEvent::Message(message),
            _ => FrameEvent::Dropped(FrameError::Malformed),
        }
    }
}
