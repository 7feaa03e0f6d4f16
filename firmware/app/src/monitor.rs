//! The monitor's main loop: the link in, the pipeline, the link out.
//!
//! ```text
//! loop:
//!   poll the link (UART0 under QEMU) -> FrameAccumulator -> HostToDevice
//!     Samples  -> sample buffer (index + litter-frame acceleration, m/s^2)
//!                 16 buffered -> DeviceParams::process -> DeviceFrame{seq, Telemetry|Alert}
//!     Hello    -> (flush the buffer) Greeting
//!                 (StreamInput on: + DeviceFrame{seq, Input} per block, the model's input)
//!     GetStatus-> (flush the buffer) Status
//!     StreamInput -> (flush the buffer) input stream on or off
//!     Param*   -> Upload (RAM) -> HMAC, counter, blob checks -> the other flash slot
//!                 -> ParamAck(Committed) + Greeting, pipeline restarted on the new blob;
//!                 any refusal -> ParamNack(code), counted, nothing changed
//!   RX idle for 100 ms (IDLE_FLUSH_MS) -> process what is buffered
//!   drain the TX ring into the link
//! ```
//!
//! Frames are encoded into a RAM ring while the pipeline runs and written to the link from
//! the loop, so [`Status::busy_ticks`] (the tick counter around `process`, frame encoding
//! included, in the board's clock: [`TickCounter`]) excludes waiting on the link. Every byte of every input is handled without a
//! panic path: bad frames are counted and dropped, index gaps of up to a minute of samples
//! counted as dropped samples, longer jumps and jumps back taken as a new stream (the
//! pipeline's sensor checks raise the index-gap fault for every one).

use supine_core::calibration::SensorFrame;
use supine_core::pipeline::{BLOCK_LEN, PipelineOutput, PipelineState};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, Greeting, HostToDevice, MAX_FRAME_LEN,
    MAX_SAMPLES_PER_FRAME, PROTOCOL_VERSION, ParamAck, ParamsSource, SampleBatch, Status,
    UploadError, encode_frame,
};
use supine_core::upload::{KEY_LEN, ParamFlash, Upload, last_counter};
use supine_sensor::{ReplaySource, SampleSource};

use crate::boot::Boot;
use crate::counter::{TickCounter, ticks_in_ms};
use crate::input_stream::InputStream;
use crate::link::{self, Link};
use crate::stack_gauge::StackGauge;
use crate::tx_ring::TxRing;
use crate::updates::{NoUpdates, Updates};

/// Free ring space required before a block is processed, so the pipeline never waits on
/// the link at the shipping telemetry rate: 4 telemetry frames of at most 89 bytes (ten
/// joint values) and a few alert frames. A block with more (telemetry every sample) drains
/// the ring as it fills: slower, never lost.
const TX_HEADROOM: usize = 1280;

/// The longest stretch of missing sample indices, in seconds of samples at the running
/// rate, counted as lost: longer than any stall of a running device (the Black Pill's
/// 1-4 s sector erase during an upload), far shorter than the 2^31-sample jumps that
/// would otherwise swamp `samples_dropped` when a stream restarts elsewhere.
pub const MAX_LOST_SPAN_S: f32 = 60.0;

/// Time without a received byte after which a partial block is processed, ms, in the
/// board's own clock ([`TickCounter::tick_rate_hz`]): the host paused or the stream
/// ended. Shorter waits would cut blocks between two sample frames, and partial blocks
/// run one sample at a time (about twice the instructions per sample). Under QEMU -icount
/// this is virtual time (100 ms is 100 million instructions); an end of stream is flushed
/// by `GetStatus` anyway.
pub const IDLE_FLUSH_MS: u32 = 100;

/// The running monitor, on the link `L`, timed by `C`, its stack measured by `S`,
/// storing parameter updates in `F`.
pub struct App<L: Link, C: TickCounter, S: StackGauge, F: ParamFlash = NoUpdates> {
    link: L,
    updates: Option<Updates<F>>,
    counter: C,
    stack: S,
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
    /// [`IDLE_FLUSH_MS`] in the counter's ticks.
    idle_flush_ticks: u32,
    replay: ReplaySource<MAX_SAMPLES_PER_FRAME>,
    input_stream: InputStream,
}

impl<L: Link, C: TickCounter, S: StackGauge> App<L, C, S> {
    /// A monitor on `link`, timing its pipeline with `counter`, reporting `stack`'s depth,
    /// running `boot.params`, that refuses parameter updates over the link
    /// (`UploadError::UpdatesUnsupported`).
    pub fn new(link: L, counter: C, stack: S, boot: Boot) -> Self {
        App::build(link, counter, stack, boot, None)
    }
}

impl<L: Link, C: TickCounter, S: StackGauge, F: ParamFlash> App<L, C, S, F> {
    /// A monitor that accepts updates signed with `key` into `flash`'s slots (the ones
    /// `boot` was chosen from).
    pub fn with_updates(
        link: L,
        counter: C,
        stack: S,
        boot: Boot,
        flash: F,
        key: &'static [u8; KEY_LEN],
    ) -> Self {
        Self::build(link, counter, stack, boot, Some((flash, key)))
    }

    /// The monitor; `updates` are the slots and key if it takes updates. The upload
    /// buffer is made here, in place: passed in, its 4 KiB would be copied on the stack.
    fn build(
        link: L,
        counter: C,
        stack: S,
        boot: Boot,
        updates: Option<(F, &'static [u8; KEY_LEN])>,
    ) -> Self {
        let idle_flush_ticks = ticks_in_ms(counter.tick_rate_hz(), IDLE_FLUSH_MS);
        Self {
            link,
            updates: updates.map(|(flash, key)| Updates {
                flash,
                upload: Upload::new(),
                key,
            }),
            counter,
            stack,
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
            idle_flush_ticks,
            replay: ReplaySource::new(),
            input_stream: InputStream::new(),
        }
    }

    /// The running parameters' sensor calibration and mounting (they change with an
    /// upload), for a sample source that converts sensor readings itself.
    pub fn sensor_frame(&self) -> SensorFrame {
        self.boot.params.sensor_frame()
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
        match link::try_read_byte(&mut self.link) {
            Some(byte) => {
                self.last_byte = self.counter.now();
                self.on_byte(byte);
            }
            None => {
                if self.buffered > 0
                    && self.counter.ticks_since(self.last_byte) >= self.idle_flush_ticks
                {
                    self.process_buffered();
                }
            }
        }
        self.tx.drain(&mut self.link);
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
                self.send_status();
            }
            HostToDevice::ParamBegin(begin) => {
                let answer = match self.updates.as_mut() {
                    Some(u) => u.upload.begin(&begin, last_counter(&u.flash)),
                    None => Err(UploadError::UpdatesUnsupported),
                };
                self.answer_upload(answer);
            }
            HostToDevice::ParamChunk(chunk) => {
                let answer = match self.updates.as_mut() {
                    Some(u) => u.upload.chunk(&chunk),
                    None => Err(UploadError::UpdatesUnsupported),
                };
                self.answer_upload(answer);
            }
            HostToDevice::ParamCommit => self.commit_upload(),
            HostToDevice::StreamInput { enabled } => {
                // The buffered samples go out under the old setting.
                self.process_buffered();
                self.input_stream.set_enabled(enabled);
            }
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
            Some(u) => u
                .upload
                .commit(u.key, &mut u.flash, running, &mut self.boot.params),
            None => Err(UploadError::UpdatesUnsupported),
        };
        let committed = match result {
            Ok(c) => c,
            Err(e) => return self.answer_upload(Err(e)),
        };
        self.boot.source = ParamsSource::Flash {
            slot: committed.slot,
        };
        // A new filter, exposure and alert history: the old state belongs to other
        // parameters (and possibly another sample rate).
        self.state = PipelineState::new();
        self.next_index = None;
        // A stream of inputs to other parameters is another session: the host asks again.
        self.input_stream.set_enabled(false);
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
            && index != expected
        {
            self.count_lost(index.wrapping_sub(expected));
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

    /// Counts the samples a jump of `gap` indices past the expected one skipped (wrapping:
    /// the index runs on past `u32::MAX` to 0). A jump forward of at most
    /// [`MAX_LOST_SPAN_S`] of samples is a loss and counted in `samples_dropped`; a longer
    /// one, or a jump back, is a new stream (a restarted replay, another source), not a
    /// loss, and counts nothing. The pipeline raises the index-gap fault for both.
    // Out of line: off the per-sample path, which only compares the index.
    #[inline(never)]
    fn count_lost(&mut self, gap: u32) {
        let max_lost = (self.boot.params.sample_rate_hz() * MAX_LOST_SPAN_S) as u32;
        if gap <= max_lost {
            self.status.samples_dropped = self.status.samples_dropped.saturating_add(gap);
        }
    }

    /// Runs the buffered samples through the pipeline, queueing their frames.
    fn process_buffered(&mut self) {
        let n = self.buffered;
        if n == 0 {
            return;
        }
        self.buffered = 0;
        // Make room first, so the timed span never waits on the link.
        while self.tx.free() < TX_HEADROOM {
            self.tx.drain_blocking_one(&mut self.link);
        }
        let Self {
            link,
            counter,
            boot,
            state,
            tx,
            seq,
            status,
            indices,
            samples_m_s2,
            input_stream,
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
                    tx.push_telemetry(*seq, &t, link);
                    *seq = seq.wrapping_add(1);
                }
                PipelineOutput::Alert(e) => queue_frame(tx, link, seq, DeviceToHost::Alert(e)),
            });
        input_stream.send(indices, state, tx, link, seq);
        status.busy_ticks = status
            .busy_ticks
            .wrapping_add(u64::from(counter.ticks_since(start)));
        status.samples_processed = status.samples_processed.wrapping_add(n as u32);
    }

    /// The counters, the running parameters' patient and the joints' exposure.
    // Out of line: the status (about 140 B) then stays off the main loop's frame, which
    // an upload's commit builds on (the device's stack peak, BENCHMARKS.md).
    #[inline(never)]
    fn send_status(&mut self) {
        let mut status = self.status;
        status.stack_used_bytes = self.stack.high_water_bytes() as u32;
        status.params_source = self.boot.source;
        status.height_m = self.boot.params.patient.height_m;
        status.mass_kg = self.boot.params.patient.mass_kg;
        status.calibration = self.boot.params.calibration;
        let count = self.boot.params.joints.packed_outputs().count();
        status.joint_running_rms = self.state.joints().running_rms(count);
        status.joint_largest_excursion = self.state.joints().largest_excursion(count);
        self.send(DeviceToHost::Status(status));
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
            height_m: self.boot.params.patient.height_m,
            mass_kg: self.boot.params.patient.mass_kg,
            reset_cause: self.boot.reset_cause,
            last_panic: self.boot.last_panic.clone(),
            joint_outputs: self.boot.params.joints.mask(),
            calibration: self.boot.params.calibration,
        };
        self.send(DeviceToHost::Greeting(greeting));
    }

    fn send(&mut self, message: DeviceToHost) {
        queue_frame(&mut self.tx, &mut self.link, &mut self.seq, message);
    }
}

/// Encodes `message` with the next sequence number into the TX ring. A message that does
/// not encode (none can: every one fits [`MAX_FRAME_LEN`]) is skipped, its number kept, so
/// the host counts it as lost rather than the device stopping.
fn queue_frame(tx: &mut TxRing, link: &mut impl Link, seq: &mut u32, message: DeviceToHost) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = DeviceFrame { seq: *seq, message };
    *seq = seq.wrapping_add(1);
    if let Ok(bytes) = encode_frame(&frame, &mut buf) {
        tx.push(bytes, link);
    }
}
