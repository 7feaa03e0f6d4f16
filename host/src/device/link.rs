//! The host's end of the wire protocol: frames out, numbered frames in, with lost and bad
//! frames counted, over any byte stream (QEMU's UART socket or a serial port).

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameError, FrameEvent, Greeting, HostToDevice,
    MAX_FRAME_LEN, PROTOCOL_VERSION, encode_frame,
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
    /// The encoded bytes of the frame being received (to read a dropped frame's version).
    raw: Vec<u8>,
    /// Protocol version of a greeting that did not decode in this host's protocol.
    foreign_greeting: Option<u16>,
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
            raw: Vec::with_capacity(MAX_FRAME_LEN),
            foreign_greeting: None,
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
                let event = self.accumulator.push::<DeviceFrame>(byte);
                if byte != 0 {
                    if self.raw.len() < MAX_FRAME_LEN {
                        self.raw.push(byte);
                    }
                } else {
                    if matches!(event, FrameEvent::Dropped(FrameError::Malformed)) {
                        self.foreign_greeting = greeting_version(&mut self.raw)
                            .filter(|&v| v != PROTOCOL_VERSION)
                            .or(self.foreign_greeting);
                    }
                    self.raw.clear();
                }
                match event {
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

    /// Refuses a device whose greeting was dropped because it speaks another protocol
    /// version (a greeting this host cannot decode, read only as far as its version).
    pub fn check_foreign_greeting(&self) -> Result<()> {
        self.foreign_greeting.map_or(Ok(()), check_protocol)
    }

    /// Waits for the device's greeting, skipping anything before it, and refuses a
    /// protocol version other than this host's.
    pub fn greeting(&mut self, timeout: Duration) -> Result<Greeting> {
        let deadline = Instant::now() + timeout;
        loop {
            // Checked first: a device that greets in another version and hangs up (or
            // says nothing more) is refused for its version, not for the silence.
            let message = self.next_before(deadline);
            self.check_foreign_greeting()?;
            match message? {
                Some(DeviceToHost::Greeting(g)) => {
                    check_protocol(g.protocol_version)?;
                    return Ok(g);
                }
                Some(_) => {}
                None => bail!(
                    "the device did not greet within {}",
                    format_duration(timeout)
                ),
            }
        }
    }
}

/// What every protocol version keeps at the start of a greeting frame: the frame's
/// sequence number, the message's variant index (a greeting is variant 0) and the
/// protocol version, all postcard varints. Whatever follows may change between versions.
#[derive(serde::Deserialize)]
struct GreetingPrefix {
    _seq: u32,
    variant: u32,
    protocol_version: u16,
}

/// The protocol version of a COBS-encoded frame (without its terminating zero) that
/// starts like a greeting, read without decoding the rest; `None` if it does not.
/// Decodes `frame` in place.
pub fn greeting_version(frame: &mut [u8]) -> Option<u16> {
    let (prefix, _) = postcard::take_from_bytes_cobs::<GreetingPrefix>(frame).ok()?;
    (prefix.variant == 0).then_some(prefix.protocol_version)
}

/// A duration for a message: seconds (to 0.1 s) from 1 s up, milliseconds below, so a
/// short timeout never reads "0 s".
pub fn format_duration(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s >= 1.0 {
        format!("{} s", (s * 10.0).round() / 10.0)
    } else {
        format!("{} ms", d.as_millis())
    }
}

/// Refuses a device that speaks another protocol version, saying what to do.
pub fn check_protocol(device_version: u16) -> Result<()> {
    if device_version != PROTOCOL_VERSION {
        bail!(
            "the device speaks protocol version {device_version}, this supine speaks {PROTOCOL_VERSION}: {}",
            if device_version < PROTOCOL_VERSION {
                "reflash the device with this release's firmware (`cargo fw-board` and probe-rs, \
                 see the README; `cargo fw` for QEMU)"
            } else {
                "update this host tool to the firmware's release (`cargo install --path host` \
                 from the same checkout)"
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

#[cfg(test)]
pub(crate) mod tests {
    use std::io::Cursor;

    use super::*;

    /// A greeting as a later protocol might send it: the common prefix, then a body this
    /// host cannot decode (a firmware version string far longer than its capacity).
    #[derive(serde::Serialize)]
    struct OtherGreeting {
        seq: u32,
        variant: u32,
        protocol_version: u16,
        firmware_version_len: u32,
        new_field: [u8; 3],
    }

    pub(crate) fn other_greeting_frame(protocol_version: u16) -> Vec<u8> {
        let message = OtherGreeting {
            seq: 0,
            variant: 0,
            protocol_version,
            firmware_version_len: 10_000,
            new_field: [1, 2, 3],
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        postcard::to_slice_cobs(&message, &mut buf)
            .expect("encodes")
            .to_vec()
    }

    fn greeting_frame(protocol_version: u16) -> Vec<u8> {
        let message = DeviceFrame {
            seq: 0,
            message: DeviceToHost::Greeting(Greeting {
                protocol_version,
                firmware_version: heapless::String::try_from("0.1.0+test").expect("fits"),
                params_identity: [7; 16],
                params_source: supine_core::protocol::ParamsSource::Flash { slot: 0 },
                sample_rate_hz: 500.0,
                height_m: 1.82,
                mass_kg: 81.0,
                reset_cause: supine_core::protocol::ResetCause::PowerOn,
                last_panic: heapless::String::new(),
                joint_outputs: 0,
                calibration: supine_core::calibration::SensorCalibration::DATASHEET,
            }),
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        encode_frame(&message, &mut buf).expect("encodes").to_vec()
    }

    #[test]
    fn a_greeting_that_does_not_decode_is_refused_for_its_version_with_what_to_do() {
        let newer = other_greeting_frame(PROTOCOL_VERSION + 1);
        // The whole frame really does not decode in this host's protocol.
        let mut accumulator = FrameAccumulator::new();
        let last = newer
            .iter()
            .map(|&b| accumulator.push::<DeviceFrame>(b))
            .last();
        assert!(matches!(
            last,
            Some(FrameEvent::Dropped(FrameError::Malformed))
        ));
        let mut reader = FrameReader::new(Cursor::new(newer));
        let err = reader
            .greeting(Duration::from_secs(1))
            .expect_err("refused")
            .to_string();
        assert_eq!(
            err,
            format!(
                "the device speaks protocol version {}, this supine speaks {PROTOCOL_VERSION}: \
                 update this host tool to the firmware's release (`cargo install --path host` \
                 from the same checkout)",
                PROTOCOL_VERSION + 1
            )
        );
        let mut reader = FrameReader::new(Cursor::new(other_greeting_frame(PROTOCOL_VERSION - 1)));
        let err = reader
            .greeting(Duration::from_secs(1))
            .expect_err("refused");
        assert!(err.to_string().contains("reflash the device"), "{err}");
    }

    #[test]
    fn a_damaged_frame_in_this_version_is_only_a_bad_frame() {
        let mut bytes = other_greeting_frame(PROTOCOL_VERSION);
        bytes.extend(greeting_frame(PROTOCOL_VERSION));
        let mut reader = FrameReader::new(Cursor::new(bytes));
        let g = reader
            .greeting(Duration::from_secs(1))
            .expect("the good greeting");
        assert_eq!(g.protocol_version, PROTOCOL_VERSION);
        assert_eq!(reader.stats.bad_frames, 1);
    }

    #[test]
    fn the_version_is_read_from_a_decodable_greeting_too_and_not_from_other_messages() {
        let mut frame = greeting_frame(PROTOCOL_VERSION + 3);
        frame.pop(); // the terminating zero
        assert_eq!(greeting_version(&mut frame), Some(PROTOCOL_VERSION + 3));
        let mut buf = [0u8; MAX_FRAME_LEN];
        let status = DeviceFrame {
            seq: 5,
            message: DeviceToHost::ParamNack(supine_core::protocol::UploadError::Replayed),
        };
        let mut frame = encode_frame(&status, &mut buf).expect("encodes").to_vec();
        frame.pop();
        assert_eq!(greeting_version(&mut frame), None);
    }

    #[test]
    fn durations_below_a_second_read_in_milliseconds() {
        assert_eq!(format_duration(Duration::from_millis(300)), "300 ms");
        assert_eq!(format_duration(Duration::from_secs(10)), "10 s");
        assert_eq!(format_duration(Duration::from_millis(1250)), "1.3 s");
    }
}
