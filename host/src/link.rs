//! The host's end of the wire protocol: frames out, numbered frames in, with lost and bad
//! frames counted, over any byte stream (QEMU's UART socket or a serial port).

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, Greeting, HostToDevice, MAX_FRAME_LEN,
    PROTOCOL_VERSION, encode_frame,
};

/// Counters of what arrived from the device.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Frames decoded.
    pub frames: u64,
    /// Frames that failed COBS or postcard decoding, or were too long.
    pub bad_frames: u64,
    /// Frames missing from the sequence numbers (lost between device and host).
    pub lost_frames: u64,
    /// Frames that arrived with a sequence number at or below one already seen.
    pub reordered_frames: u64,
}

/// Receives and decodes the device's frames from a stream.
pub struct FrameReader<R> {
    stream: R,
    accumulator: FrameAccumulator,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    next_seq: Option<u32>,
    /// What has arrived so far.
    pub stats: LinkStats,
}

impl<R: Read> FrameReader<R> {
    /// Wraps a stream whose reads may time out (set a read timeout on it).
    pub fn new(stream: R) -> Self {
        Self {
            stream,
            accumulator: FrameAccumulator::new(),
            buf: vec![0; 64 * 1024],
            start: 0,
            end: 0,
            next_seq: None,
            stats: LinkStats::default(),
        }
    }

    /// The next message, or `None` if nothing complete arrived before `deadline`.
    ///
    /// Errors only when the stream ends or fails.
    pub fn next_before(&mut self, deadline: Instant) -> Result<Option<DeviceToHost>> {
        loop {
            while self.start < self.end {
                let byte = self.buf[self.start];
                self.start += 1;
                match self.accumulator.push::<DeviceFrame>(byte) {
                    FrameEvent::Pending => {}
                    FrameEvent::Dropped(_) => self.stats.bad_frames += 1,
                    FrameEvent::Message(frame) => {
                        self.count(frame.seq);
                        return Ok(Some(frame.message));
                    }
                }
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            match self.stream.read(&mut self.buf) {
                Ok(0) => bail!("the device closed the connection"),
                Ok(n) => (self.start, self.end) = (0, n),
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(anyhow!("reading from the device: {e}")),
            }
        }
    }

    fn count(&mut self, seq: u32) {
        self.stats.frames += 1;
        match self.next_seq {
            Some(expected) if seq > expected => self.stats.lost_frames += u64::from(seq - expected),
            Some(expected) if seq < expected => self.stats.reordered_frames += 1,
            _ => {}
        }
        self.next_seq = Some(seq.wrapping_add(1).max(self.next_seq.unwrap_or(0)));
    }

    /// Waits for the device's greeting, skipping anything before it, and refuses a
    /// protocol version other than this host's.
    pub fn greeting(&mut self, timeout: Duration) -> Result<Greeting> {
        let deadline = Instant::now() + timeout;
        loop {
            match self.next_before(deadline)? {
                Some(DeviceToHost::Greeting(g)) => {
                    check_protocol(g.protocol_version)?;
                    return Ok(g);
                }
                Some(_) => {}
                None => bail!(
                    "the device did not greet within {:.0} s",
                    timeout.as_secs_f64()
                ),
            }
        }
    }
}

/// Refuses a device that speaks another protocol version, saying what to do.
pub fn check_protocol(device_version: u16) -> Result<()> {
    if device_version != PROTOCOL_VERSION {
        bail!(
            "the device speaks protocol version {device_version}, this host speaks {PROTOCOL_VERSION}: \
             {}",
            if device_version < PROTOCOL_VERSION {
                "update the firmware (supine flash, or rebuild with `cargo fw`)"
            } else {
                "update this host tool to the firmware's release"
            }
        );
    }
    Ok(())
}

/// Sends host-to-device frames.
pub struct FrameWriter<W> {
    stream: W,
    buf: [u8; MAX_FRAME_LEN],
}

impl<W: Write> FrameWriter<W> {
    /// Wraps a stream.
    pub fn new(stream: W) -> Self {
        Self {
            stream,
            buf: [0; MAX_FRAME_LEN],
        }
    }

    /// Encodes and writes one message.
    pub fn send(&mut self, message: &HostToDevice) -> Result<()> {
        let frame = encode_frame(message, &mut self.buf).map_err(|e| anyhow!("encoding: {e}"))?;
        self.stream
            .write_all(frame)
            .map_err(|e| anyhow!("writing to the device: {e}"))
    }

    /// Writes raw bytes (for tests that send garbage).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<()> {
        self.stream
            .write_all(bytes)
            .map_err(|e| anyhow!("writing to the device: {e}"))
    }

    /// Flushes the stream.
    pub fn flush(&mut self) -> Result<()> {
        self.stream
            .flush()
            .map_err(|e| anyhow!("writing to the device: {e}"))
    }
}
