//! The monitor's main loop: UART0 in, the pipeline, UART0 out.
//!
//! ```text
//! loop:
//!   poll UART0 RX -> FrameAccumulator -> HostToDevice
//!     Samples  -> sample buffer (index + litter-frame acceleration, m/s^2)
//!                 16 buffered -> DeviceParams::process -> DeviceFrame{seq, Telemetry|Alert}
//!     Hello    -> (flush the buffer) Greeting
//!     GetStatus-> (flush the buffer) Status
//!     Param*   -> Upload (RAM) -> HMAC, counter, blob checks -> the other flash slot
//!                 -> ParamAck(Committed) + Greeting, pipeline restarted on the new blob;
//!                 any refusal -> ParamNack(code), counted, nothing changed
//!   RX idle for 100 ms (IDLE_FLUSH_TICKS) -> process what is buffered
//!   drain the TX ring into UART0 TX
//! ```
//!
//! Frames are encoded into a RAM ring while the pipeline runs and written to the UART from
//! the loop, so [`Status::busy_ticks`] (SysTick around `process`, frame encoding included)
//! excludes waiting on the UART. Every byte of every input is handled without a panic
//! path: bad frames are counted and dropped, index gaps counted as dropped samples (and
//! raised by the pipeline's sensor checks as an index-gap fault).

use supine_core::blob::DeviceParams;
use supine_core::mounting::Mounting;
use supine_core::pipeline::{BLOCK_LEN, PipelineOutput, PipelineState};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, Greeting, HostToDevice, MAX_FRAME_LEN,
    MAX_SAMPLES_PER_FRAME, PANIC_MESSAGE_LEN, PROTOCOL_VERSION, ParamAck, ParamsSource, ResetCause,
    SampleBatch, Status, Telemetry, UploadError, encode_frame, telemetry_frame,
};
use supine_core::upload::{KEY_LEN, ParamFlash, Upload, last_counter};

use supine_sensor::{ReplaySource, SampleSource};

use crate::cycles::InstructionCounter;
use crate::stack;

/// Bytes of the transmit ring: more than one block's worst-case output. A power of two,
/// so `i & TX_MASK` indexes it without a bounds check.
const TX_RING_LEN: usize = 4096;
const TX_MASK: usize = TX_RING_LEN - 1;

/// Free ring space required before a block is processed, so the pipeline never waits on
/// the UART: 16 telemetry frames and a few alert frames need about 1 KiB.
const TX_HEADROOM: usize = 2048;

/// SysTick ticks (25 MHz: 100 ms) without a received byte after which a partial block
/// is processed: the host paused or the stream ended. Shorter waits would cut blocks
/// between two sample frames, and partial blocks run one sample at a time (about twice
/// the instructions per sample). Under QEMU -icount one tick is 40 instructions of
/// virtual time; an end of stream is flushed by `GetStatus` anyway.
const IDLE_FLUSH_TICKS: u32 = 2_500_000;

/// The byte link to the host: UART0 (CMSDK) under QEMU, USART1 on the board.
pub trait ByteLink {
    /// The received byte, if there is one.
    fn try_read_byte(&mut self) -> Option<u8>;
    /// Sends `byte` if the transmitter has room; returns whether it was sent.
    fn try_write_byte(&mut self, byte: u8) -> bool;
    /// Sends `byte`, waiting for room.
    fn write_byte(&mut self, byte: u8) {
        while !self.try_write_byte(byte) {}
    }
}

impl ByteLink for crate::cmsdk_uart::CmsdkUart {
    fn try_read_byte(&mut self) -> Option<u8> {
        crate::cmsdk_uart::CmsdkUart::try_read_byte(self)
    }
    fn try_write_byte(&mut self, byte: u8) -> bool {
        crate::cmsdk_uart::CmsdkUart::try_write_byte(self, byte)
    }
}

/// Where the running parameters came from and how the device last stopped.
pub struct Boot {
    /// Appended to the firmware version in the greeting (`+qemu`, `+blackpill`).
    pub build: &'static str,
    /// The parameters in use.
    pub params: DeviceParams,
    /// Flash slot or built-in default (with the reason the flash blob was refused).
    pub source: ParamsSource,
    /// How the device last stopped.
    pub reset_cause: ResetCause,
    /// The last panic's message (empty if none).
    pub last_panic: heapless::String<PANIC_MESSAGE_LEN>,
}

/// A byte ring for outgoing frames.
struct TxRing {
    buf: [u8; TX_RING_LEN],
    head: usize,
    len: usize,
}

impl TxRing {
    const fn new() -> Self {
        Self {
            buf: [0; TX_RING_LEN],
            head: 0,
            len: 0,
        }
    }

    fn free(&self) -> usize {
        TX_RING_LEN - self.len
    }

    /// Appends `bytes`, first writing the oldest bytes to `uart` (waiting) if room lacks.
    fn push(&mut self, bytes: &[u8], uart: &mut impl ByteLink) {
        while self.free() < bytes.len() && self.len > 0 {
            self.drain_blocking_one(uart);
        }
        if bytes.len() > self.free() {
            // Only if a frame were longer than the ring: send it straight through.
            bytes.iter().for_each(|&b| uart.write_byte(b));
            return;
        }
        let tail = (self.head + self.len) % TX_RING_LEN;
        // At most two contiguous pieces: up to the end of the buffer, then from its start.
        let first = bytes.len().min(TX_RING_LEN - tail);
        let (a, b) = bytes.split_at(first);
        if let Some(dst) = self.buf.get_mut(tail..tail + a.len()) {
            dst.copy_from_slice(a);
        }
        if let Some(dst) = self.buf.get_mut(..b.len()) {
            dst.copy_from_slice(b);
        }
        self.len += bytes.len();
    }

    /// Encodes a telemetry frame straight into the ring (the hot path: no copy), or,
    /// where the free space wraps around the ring's end (one frame in about 80), into a
    /// scratch frame copied in two pieces. Kept out of line: the pipeline's per-sample
    /// loop stays smaller.
    #[inline(never)]
    fn push_telemetry(&mut self, seq: u32, t: &Telemetry, uart: &mut impl ByteLink) {
        while self.free() < telemetry_frame::MAX_FRAME && self.len > 0 {
            self.drain_blocking_one(uart);
        }
        let tail = (self.head + self.len) & TX_MASK;
        let contiguous = self
            .buf
            .get_mut(tail..tail + telemetry_frame::MAX_FRAME)
            .and_then(|s| <&mut [u8; telemetry_frame::MAX_FRAME]>::try_from(s).ok());
        if let Some(frame) = contiguous {
            self.len += telemetry_frame::encode(seq, t, frame);
        } else {
            let mut frame = [0u8; telemetry_frame::MAX_FRAME];
            let len = telemetry_frame::encode(seq, t, &mut frame);
            self.push(frame.get(..len).unwrap_or(&[]), uart);
        }
    }

    fn drain_blocking_one(&mut self, uart: &mut impl ByteLink) {
        if let Some(&b) = self.buf.get(self.head) {
            uart.write_byte(b);
        }
        self.head = (self.head + 1) % TX_RING_LEN;
        self.len -= 1;
    }

    /// Writes to `uart` while it takes bytes without waiting.
    fn drain(&mut self, uart: &mut impl ByteLink) {
        while self.len > 0 {
            let Some(&b) = self.buf.get(self.head) else {
                return;
            };
            if !uart.try_write_byte(b) {
                return;
            }
            self.head = (self.head + 1) % TX_RING_LEN;
            self.len -= 1;
        }
    }
}

/// Parameter updates over the link: the slots, the update being received, the key.
struct Updates<F> {
    flash: F,
    upload: Upload,
    key: &'static [u8; KEY_LEN],
}

/// Stands for the flash of an image that takes no updates over the link.
pub struct NoUpdates;

impl ParamFlash for NoUpdates {
    fn slot(&self, _slot: usize) -> &[u8] {
        &[]
    }
    fn erase(&mut self, _slot: usize) -> Result<(), supine_core::upload::FlashError> {
        Err(supine_core::upload::FlashError)
    }
    fn write(
        &mut self,
        _slot: usize,
        _offset: usize,
        _bytes: &[u8],
    ) -> Result<(), supine_core::upload::FlashError> {
        Err(supine_core::upload::FlashError)
    }
}

/// The running monitor.
pub struct App<U: ByteLink, F: ParamFlash = NoUpdates> {
    uart: U,
    updates: Option<Updates<F>>,
    counter: InstructionCounter,
    boot: Boot,
    state: PipelineState,
    rx: FrameAccumulator,
    tx: TxRing,
    seq: u32,
    status: Status,
    indices: [u32; BLOCK_LEN],
    samples_m_s2: [[f32; 3]; BLOCK_LEN],
    buffered: usize,
    next_index: Option<u32>,
    last_byte: u32,
    replay: ReplaySource<MAX_SAMPLES_PER_FRAME>,
}

impl<U: ByteLink> App<U> {
    /// A monitor on `uart`, timing its pipeline with `counter`, running `boot.params`,
    /// that refuses parameter updates over the link (`UploadError::Flash`).
    pub fn new(uart: U, counter: InstructionCounter, boot: Boot) -> Self {
        App::build(uart, counter, boot, None)
    }
}

impl<U: ByteLink, F: ParamFlash> App<U, F> {
    /// A monitor that accepts updates signed with `key` into `flash`'s slots (the ones
    /// `boot` was chosen from).
    pub fn with_updates(
        uart: U,
        counter: InstructionCounter,
        boot: Boot,
        flash: F,
        key: &'static [u8; KEY_LEN],
    ) -> Self {
        let updates = Updates {
            flash,
            upload: Upload::new(),
            key,
        };
        Self::build(uart, counter, boot, Some(updates))
    }

    fn build(
        uart: U,
        counter: InstructionCounter,
        boot: Boot,
        updates: Option<Updates<F>>,
    ) -> Self {
        Self {
            uart,
            updates,
            counter,
            boot,
            state: PipelineState::new(),
            rx: FrameAccumulator::new(),
            tx: TxRing::new(),
            seq: 0,
            status: Status::default(),
            indices: [0; BLOCK_LEN],
            samples_m_s2: [[0.0; 3]; BLOCK_LEN],
            buffered: 0,
            next_index: None,
            last_byte: 0,
            replay: ReplaySource::new(),
        }
    }

    /// The running parameters' mounting calibration (it changes with an upload), for a
    /// sample source that converts sensor readings itself.
    pub fn mounting(&self) -> Mounting {
        self.boot.params.mounting
    }

    /// Greets, then serves the host forever (replay: samples arrive over the link).
    pub fn run(mut self) -> ! {
        self.greet();
        loop {
            self.poll();
        }
    }

    /// Sends the greeting (at boot; again on `Hello`).
    pub fn greet(&mut self) {
        self.last_byte = self.counter.now();
        self.send_greeting();
    }

    /// One pass of the main loop: take a received byte (or process a partial block after
    /// a pause), then send what the link takes without waiting.
    pub fn poll(&mut self) {
        match self.uart.try_read_byte() {
            Some(byte) => {
                self.last_byte = self.counter.now();
                self.on_byte(byte);
            }
            None => {
                if self.buffered > 0 && self.counter.ticks_since(self.last_byte) >= IDLE_FLUSH_TICKS
                {
                    self.process_buffered();
                }
            }
        }
        self.tx.drain(&mut self.uart);
    }

    /// A sample from a local sensor (litter axes, gravity removed, m/s^2), as if the host
    /// had sent it: buffered and processed in blocks.
    pub fn push_sample(&mut self, index: u32, accel_m_s2: [f32; 3]) {
        self.last_byte = self.counter.now();
        self.accept_sample(index, accel_m_s2);
    }

    fn on_byte(&mut self, byte: u8) {
        match self.rx.push::<HostToDevice>(byte) {
            FrameEvent::Pending => {}
            FrameEvent::Dropped(_) => {
                self.status.bad_frames = self.status.bad_frames.wrapping_add(1);
            }
            FrameEvent::Message(message) => {
                self.status.frames_received = self.status.frames_received.wrapping_add(1);
                self.on_message(message);
            }
        }
    }

    fn on_message(&mut self, message: HostToDevice) {
        match message {
            HostToDevice::Hello => {
                self.process_buffered();
                self.send_greeting();
            }
            HostToDevice::Samples(batch) => self.on_samples(&batch),
            HostToDevice::GetStatus => {
                self.process_buffered();
                let mut status = self.status;
                status.stack_used_bytes = stack::high_water_bytes() as u32;
                status.params_source = self.boot.source;
                self.send(DeviceToHost::Status(status));
            }
            HostToDevice::ParamBegin(begin) => {
                let answer = match self.updates.as_mut() {
                    Some(u) => u.upload.begin(&begin, last_counter(&u.flash)),
                    None => Err(UploadError::Flash),
                };
                self.answer_upload(answer);
            }
            HostToDevice::ParamChunk(chunk) => {
                let answer = match self.updates.as_mut() {
                    Some(u) => u.upload.chunk(&chunk),
                    None => Err(UploadError::Flash),
                };
                self.answer_upload(answer);
            }
            HostToDevice::ParamCommit => self.commit_upload(),
        }
    }

    /// Verifies and stores a received update; on success runs it from the next sample on
    /// (the samples already buffered finish on the old parameters) and greets again.
    // Out of line: inlined into the main loop it costs 300 B more flash.
    #[inline(never)]
    fn commit_upload(&mut self) {
        self.process_buffered();
        let running = match self.boot.source {
            ParamsSource::Flash { slot } => Some(slot),
            ParamsSource::BuiltInDefault { .. } => None,
        };
        let result = match self.updates.as_mut() {
            Some(u) => u.upload.commit(u.key, &mut u.flash, running),
            None => Err(UploadError::Flash),
        };
        let committed = match result {
            Ok(c) => c,
            Err(e) => return self.answer_upload(Err(e)),
        };
        self.boot.params = committed.params;
        self.boot.source = ParamsSource::Flash {
            slot: committed.slot,
        };
        // A new filter, exposure and alert history: the old state belongs to other
        // parameters (and possibly another sample rate).
        self.state = PipelineState::new();
        self.next_index = None;
        self.answer_upload(Ok(ParamAck::Committed {
            identity: committed.identity,
            slot: committed.slot,
        }));
        self.send_greeting();
    }

    /// Acknowledges an upload step, or refuses it with its code and counts the refusal.
    fn answer_upload(&mut self, answer: Result<ParamAck, UploadError>) {
        match answer {
            Ok(ack) => self.send(DeviceToHost::ParamAck(ack)),
            Err(e) => {
                self.status.uploads_rejected = self.status.uploads_rejected.wrapping_add(1);
                self.send(DeviceToHost::ParamNack(e));
            }
        }
    }

    /// Replay: the batch goes through the same [`SampleSource`] interface as the board's
    /// accelerometer, drained at once.
    fn on_samples(&mut self, batch: &SampleBatch) {
        let dropped = self
            .replay
            .push_batch(batch.first_sample_index, &batch.accel_m_s2);
        self.status.samples_dropped = self.status.samples_dropped.saturating_add(dropped as u32);
        while let Ok(Some((index, sample))) = self.replay.poll() {
            self.accept_sample(index, sample);
        }
    }

    fn accept_sample(&mut self, index: u32, sample: [f32; 3]) {
        if let Some(expected) = self.next_index
            && index > expected
        {
            let missing = index - expected;
            self.status.samples_dropped = self.status.samples_dropped.saturating_add(missing);
        }
        self.next_index = Some(index.wrapping_add(1));
        if let (Some(i), Some(x)) = (
            self.indices.get_mut(self.buffered),
            self.samples_m_s2.get_mut(self.buffered),
        ) {
            *i = index;
            *x = sample;
            self.buffered += 1;
        } else {
            // Unreachable (full blocks are processed at once), but counted if ever hit.
            self.status.samples_dropped = self.status.samples_dropped.saturating_add(1);
        }
        if self.buffered == BLOCK_LEN {
            self.process_buffered();
        }
    }

    /// Runs the buffered samples through the pipeline, queueing their frames.
    fn process_buffered(&mut self) {
        let n = self.buffered;
        if n == 0 {
            return;
        }
        self.buffered = 0;
        // Make room first, so the timed span never waits on the UART.
        while self.tx.free() < TX_HEADROOM {
            self.tx.drain_blocking_one(&mut self.uart);
        }
        let Self {
            uart,
            counter,
            boot,
            state,
            tx,
            seq,
            status,
            indices,
            samples_m_s2,
            ..
        } = self;
        let (indices, samples) = (
            indices.get(..n).unwrap_or(&[]),
            samples_m_s2.get(..n).unwrap_or(&[]),
        );
        let start = counter.now();
        boot.params
            .process(state, indices, samples, |output| match output {
                PipelineOutput::Telemetry(t) => {
                    status.telemetry_sent = status.telemetry_sent.wrapping_add(1);
                    tx.push_telemetry(*seq, &t, uart);
                    *seq = seq.wrapping_add(1);
                }
                PipelineOutput::Alert(e) => queue_frame(tx, uart, seq, DeviceToHost::Alert(e)),
            });
        status.busy_ticks = status
            .busy_ticks
            .wrapping_add(u64::from(counter.ticks_since(start)));
        status.samples_processed = status.samples_processed.wrapping_add(n as u32);
    }

    // Out of line: boot, `Hello` and a commit greet; inlined twice it costs 430 B of flash.
    #[inline(never)]
    fn send_greeting(&mut self) {
        let mut firmware_version = heapless::String::new();
        let _ = firmware_version.push_str(crate::VERSION);
        let _ = firmware_version.push_str(self.boot.build);
        let greeting = Greeting {
            protocol_version: PROTOCOL_VERSION,
            firmware_version,
            params_identity: self.boot.params.identity,
            params_source: self.boot.source,
            sample_rate_hz: self.boot.params.sample_rate_hz(),
            reset_cause: self.boot.reset_cause,
            last_panic: self.boot.last_panic.clone(),
        };
        self.send(DeviceToHost::Greeting(greeting));
    }

    fn send(&mut self, message: DeviceToHost) {
        queue_frame(&mut self.tx, &mut self.uart, &mut self.seq, message);
    }
}

/// Encodes `message` with the next sequence number into the TX ring. A message that does
/// not encode (none can: every one fits [`MAX_FRAME_LEN`]) is skipped, its number kept, so
/// the host counts it as lost rather than the device stopping.
fn queue_frame(tx: &mut TxRing, uart: &mut impl ByteLink, seq: &mut u32, message: DeviceToHost) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = DeviceFrame { seq: *seq, message };
    *seq = seq.wrapping_add(1);
    if let Ok(bytes) = encode_frame(&frame, &mut buf) {
        tx.push(bytes, uart);
    }
}
