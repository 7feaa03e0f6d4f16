//! The monitor on the host, shared by the test files: an in-memory link, a simulated clock
//! and a RAM flash (with injectable faults) stand in for the UART, SysTick and the PARAMS
//! slots. Every frame the monitor sends is decoded as the host decodes it, and the
//! expected output is computed with `supine_core::pipeline` directly.

// Each test file uses its own part of this module.
#![allow(dead_code)]

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

use supine_app::{App, Boot, StackGauge, TickCounter};
use supine_core::blob::{DeviceParams, MAX_BLOB_LEN, Patient, TelemetryConfig};
use supine_core::model::{ModelParams, Preset, Subject, device_model};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, Greeting, HostToDevice, MAX_FRAME_LEN,
    MAX_SAMPLES_PER_FRAME, PARAM_CHUNK_LEN, ParamAck, ParamBegin, ParamChunk, ParamsIdentity,
    ParamsSource, ResetCause, SampleBatch, Status, Telemetry, encode_frame,
};
use supine_core::sample_rate::SampleRate;
use supine_core::test_vector::TestVector;
use supine_core::upload::{
    FlashError, KEY_LEN, ParamFlash, SLOT_COUNT, SLOT_LEN, commit_record, parse_key, select,
    update_mac,
};

/// Sample rate of every parameter set here, Hz.
pub const SAMPLE_RATE_HZ: f64 = 500.0;
/// What the simulated stack gauge reports, bytes.
pub const STACK_BYTES: usize = 3_172;
/// Identity of the parameters the device boots with.
pub const BOOT_IDENTITY: ParamsIdentity = [0x11; 16];
/// Identity of the parameters uploaded.
pub const UPLOAD_IDENTITY: ParamsIdentity = [0x42; 16];
/// Identity of the parameters in slot B when a test boots from it.
pub const SLOT_B_IDENTITY: ParamsIdentity = [0x22; 16];
/// Identity of the built-in parameters (the firmware's is `builtin-litter`).
pub const BUILTIN_IDENTITY: ParamsIdentity = *b"builtin-test\0\0\0\0";
/// The build suffix of the greeting.
pub const BUILD: &str = "+host-test";

/// The bytes on the wire, both ways.
#[derive(Default)]
pub struct Wire {
    /// Host to device, not yet read.
    pub rx: VecDeque<u8>,
    /// Device to host, everything written.
    pub tx: Vec<u8>,
    /// A slow link takes a byte without waiting only at every other attempt, so the
    /// transmit ring fills, wraps and drains with waiting.
    pub slow: bool,
    ready_toggle: bool,
}

/// The monitor's end of the wire.
pub struct MemLink(Rc<RefCell<Wire>>);

impl embedded_io::ErrorType for MemLink {
    type Error = Infallible;
}

impl embedded_io::ReadReady for MemLink {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.borrow().rx.is_empty())
    }
}

impl embedded_io::Read for MemLink {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut wire = self.0.borrow_mut();
        let n = buf.len().min(wire.rx.len());
        for (dst, src) in buf.iter_mut().zip(wire.rx.drain(..n)) {
            *dst = src;
        }
        Ok(n)
    }
}

impl embedded_io::WriteReady for MemLink {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        let mut wire = self.0.borrow_mut();
        wire.ready_toggle = !wire.ready_toggle;
        Ok(!wire.slow || wire.ready_toggle)
    }
}

impl embedded_io::Write for MemLink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.0.borrow_mut().tx.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The tick rate of the rig's clock unless a test picks another: mps2-an386's SysTick.
pub const DEFAULT_TICK_RATE_HZ: u32 = 25_000_000;

/// A counter at `rate_hz` that moves when the test says, and by `ticks_per_read` each
/// time the monitor reads it (time passing while it works).
pub struct Clock {
    now: Rc<Cell<u32>>,
    rate_hz: u32,
    ticks_per_read: u32,
}

impl TickCounter for Clock {
    fn tick_rate_hz(&self) -> u32 {
        self.rate_hz
    }
    fn now(&self) -> u32 {
        let now = self.now.get();
        self.now.set(now.wrapping_add(self.ticks_per_read));
        now
    }
    fn ticks_since(&self, start: u32) -> u32 {
        self.now.get().wrapping_sub(start)
    }
}

pub struct Gauge;

impl StackGauge for Gauge {
    fn high_water_bytes(&self) -> usize {
        STACK_BYTES
    }
}

/// What the test sees of the flash the monitor owns: its bytes after every operation,
/// and how many erases and writes it took.
#[derive(Clone, Default)]
pub struct FlashView {
    pub slots: Vec<Vec<u8>>,
    pub operations: usize,
}

/// Faults of the RAM flash, by the index of the erase or write they hit (counted from 0
/// over the flash's life).
#[derive(Clone, Copy, Debug, Default)]
pub struct FlashFaults {
    /// This operation fails and changes nothing.
    pub fail_op: Option<usize>,
    /// This operation, a write, stores one bit cleared (the lowest of its first non-zero
    /// byte) and reports success: only the read-back can tell.
    pub corrupt_op: Option<usize>,
    /// Every erase from this operation on fails and changes nothing.
    pub erase_fails_from: Option<usize>,
}

/// Two slots in RAM with NOR flash rules: erase to 0xFF, programming clears bits only.
pub struct RamFlash {
    slots: [Vec<u8>; SLOT_COUNT],
    view: Rc<RefCell<FlashView>>,
    faults: FlashFaults,
    attempts: usize,
}

impl RamFlash {
    fn publish(&self) {
        let mut view = self.view.borrow_mut();
        view.slots = self.slots.to_vec();
        view.operations += 1;
    }

    /// Counts an operation; whether the injected faults let it through.
    fn attempt(&mut self) -> (usize, bool) {
        let op = self.attempts;
        self.attempts += 1;
        (op, self.faults.fail_op != Some(op))
    }
}

impl ParamFlash for RamFlash {
    fn slot(&self, slot: usize) -> &[u8] {
        self.slots.get(slot).map_or(&[], |s| s.as_slice())
    }
    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        let (op, ok) = self.attempt();
        if !ok || self.faults.erase_fails_from.is_some_and(|from| op >= from) {
            return Err(FlashError);
        }
        self.slots.get_mut(slot).ok_or(FlashError)?.fill(0xFF);
        self.publish();
        Ok(())
    }
    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        let (op, ok) = self.attempt();
        if !ok {
            return Err(FlashError);
        }
        // The first byte with a bit set loses its lowest one.
        let corrupt_at = (self.faults.corrupt_op == Some(op))
            .then(|| bytes.iter().position(|&b| b != 0))
            .flatten();
        let cells = self
            .slots
            .get_mut(slot)
            .and_then(|s| s.get_mut(offset..offset + bytes.len()))
            .ok_or(FlashError)?;
        for (k, (cell, &b)) in cells.iter_mut().zip(bytes).enumerate() {
            let b = if corrupt_at == Some(k) {
                b & (b - 1)
            } else {
                b
            };
            *cell &= b;
        }
        self.publish();
        Ok(())
    }
}

/// A read-only copy of flash as the test last saw it, for `select`.
pub struct Snapshot(pub Vec<Vec<u8>>);

impl ParamFlash for Snapshot {
    fn slot(&self, slot: usize) -> &[u8] {
        &self.0[slot]
    }
    fn erase(&mut self, _slot: usize) -> Result<(), FlashError> {
        Err(FlashError)
    }
    fn write(&mut self, _slot: usize, _offset: usize, _bytes: &[u8]) -> Result<(), FlashError> {
        Err(FlashError)
    }
}

/// What the firmware boots from these slots: the identity of the parameters and where
/// they came from (the built-in ones, with the reason, if no slot is usable).
pub fn boots(slots: &[Vec<u8>]) -> (ParamsIdentity, ParamsSource) {
    match select(&Snapshot(slots.to_vec())) {
        Ok(active) => (
            active.params.identity,
            ParamsSource::Flash { slot: active.slot },
        ),
        Err(reason) => (BUILTIN_IDENTITY, ParamsSource::BuiltInDefault { reason }),
    }
}

/// The monitor with everything it is connected to.
pub struct Rig {
    pub app: App<MemLink, Clock, Gauge, RamFlash>,
    pub wire: Rc<RefCell<Wire>>,
    pub clock: Rc<Cell<u32>>,
    pub flash: Rc<RefCell<FlashView>>,
    decoder: FrameAccumulator,
    decoded_bytes: usize,
    next_seq: u32,
}

impl Rig {
    /// A monitor booted, as the firmware boots, from slot A holding `boot_blob` as QEMU's
    /// loader places it (no commit record), taking updates signed with the development
    /// key. It has greeted; the greeting is returned.
    pub fn boot(boot_blob: &[u8], slow: bool) -> (Self, Greeting) {
        Self::boot_flash(&plain_slot_a(boot_blob), FlashFaults::default(), slow)
    }

    /// A monitor booted from these slots as the firmware boots (the built-in parameters
    /// if no slot is usable), its flash failing as `faults` say. It has greeted.
    pub fn boot_flash(slots: &[Vec<u8>], faults: FlashFaults, slow: bool) -> (Self, Greeting) {
        Self::boot_clocked(slots, faults, slow, (DEFAULT_TICK_RATE_HZ, 0))
    }

    /// [`boot`](Self::boot) on a board whose clock ticks at `tick_rate_hz`, moving on by
    /// `ticks_per_read` each time the monitor reads it.
    pub fn boot_at_rate(
        boot_blob: &[u8],
        tick_rate_hz: u32,
        ticks_per_read: u32,
    ) -> (Self, Greeting) {
        Self::boot_clocked(
            &plain_slot_a(boot_blob),
            FlashFaults::default(),
            false,
            (tick_rate_hz, ticks_per_read),
        )
    }

    /// [`boot_flash`](Self::boot_flash) with a clock of `tick_rate_hz`, moving on by
    /// `ticks_per_read` each time it is read.
    fn boot_clocked(
        slots: &[Vec<u8>],
        faults: FlashFaults,
        slow: bool,
        (tick_rate_hz, ticks_per_read): (u32, u32),
    ) -> (Self, Greeting) {
        let slots: [Vec<u8>; SLOT_COUNT] = [slots[0].clone(), slots[1].clone()];
        let view = Rc::new(RefCell::new(FlashView {
            slots: slots.to_vec(),
            operations: 0,
        }));
        let flash = RamFlash {
            slots,
            view: Rc::clone(&view),
            faults,
            attempts: 0,
        };
        let (params, source) = match select(&flash) {
            Ok(active) => (active.params, ParamsSource::Flash { slot: active.slot }),
            Err(reason) => (builtin_params(), ParamsSource::BuiltInDefault { reason }),
        };
        let boot = Boot {
            build: BUILD,
            params,
            source,
            reset_cause: ResetCause::PowerOn,
            last_panic: heapless::String::new(),
        };
        let wire = Rc::new(RefCell::new(Wire {
            slow,
            ..Wire::default()
        }));
        let clock = Rc::new(Cell::new(0x00FF_FF00));
        let key: &'static [u8; KEY_LEN] = Box::leak(Box::new(development_key()));
        let app = App::with_updates(
            MemLink(Rc::clone(&wire)),
            Clock {
                now: Rc::clone(&clock),
                rate_hz: tick_rate_hz,
                ticks_per_read,
            },
            Gauge,
            boot,
            flash,
            key,
        );
        let mut rig = Self {
            app,
            wire,
            clock,
            flash: view,
            decoder: FrameAccumulator::new(),
            decoded_bytes: 0,
            next_seq: 0,
        };
        rig.app.greet();
        let greeting = match rig.run().as_slice() {
            [DeviceToHost::Greeting(g)] => g.clone(),
            other => panic!("expected one greeting at boot, got {other:?}"),
        };
        (rig, greeting)
    }

    /// Queues a message for the monitor, framed as the host frames it.
    pub fn send(&mut self, message: &HostToDevice) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(message, &mut buf).expect("every message fits a frame");
        self.wire.borrow_mut().rx.extend(frame.iter().copied());
    }

    pub fn send_all(&mut self, messages: &[HostToDevice]) {
        messages.iter().for_each(|m| self.send(m));
    }

    /// Queues raw bytes for the monitor.
    pub fn send_bytes(&mut self, bytes: &[u8]) {
        self.wire.borrow_mut().rx.extend(bytes.iter().copied());
    }

    /// Runs the main loop until every byte sent is read and the transmit ring is empty;
    /// returns the messages sent since the last call, checking their sequence numbers.
    pub fn run(&mut self) -> Vec<DeviceToHost> {
        let mut quiet_passes = 0;
        for _ in 0..10_000_000 {
            let before = self.wire.borrow().tx.len();
            self.app.poll();
            let wire = self.wire.borrow();
            if wire.rx.is_empty() && wire.tx.len() == before {
                quiet_passes += 1;
                // A slow link refuses every other attempt: two quiet passes mean empty.
                if quiet_passes == 2 {
                    drop(wire);
                    return self.decode_new();
                }
            } else {
                quiet_passes = 0;
            }
        }
        panic!("the monitor never went quiet");
    }

    fn decode_new(&mut self) -> Vec<DeviceToHost> {
        let wire = self.wire.borrow();
        let mut messages = Vec::new();
        for &byte in &wire.tx[self.decoded_bytes..] {
            match self.decoder.push::<DeviceFrame>(byte) {
                FrameEvent::Pending => {}
                FrameEvent::Message(frame) => {
                    assert_eq!(frame.seq, self.next_seq, "a frame lost or out of order");
                    self.next_seq += 1;
                    messages.push(frame.message);
                }
                FrameEvent::Dropped(e) => panic!("the monitor sent a bad frame: {e}"),
            }
        }
        self.decoded_bytes = wire.tx.len();
        messages
    }

    /// Moves the simulated clock on.
    pub fn advance_ticks(&self, ticks: u32) {
        self.clock.set(self.clock.get().wrapping_add(ticks));
    }

    /// Asks for the status, which also processes what is buffered; returns what came
    /// before it and the status.
    pub fn status(&mut self) -> (Vec<DeviceToHost>, Status) {
        self.send(&HostToDevice::GetStatus);
        let mut messages = self.run();
        match messages.pop() {
            Some(DeviceToHost::Status(status)) => (messages, status),
            other => panic!("expected a status last, got {other:?}"),
        }
    }

    /// Sends `Hello`; returns the greeting that answers it.
    pub fn hello(&mut self) -> Greeting {
        self.send(&HostToDevice::Hello);
        match self.run().pop() {
            Some(DeviceToHost::Greeting(g)) => g,
            other => panic!("expected a greeting last, got {other:?}"),
        }
    }

    /// The flash as it is now.
    pub fn flash_now(&self) -> FlashView {
        self.flash.borrow().clone()
    }
}

/// Slots A and B: `blob` in slot A as QEMU's loader places it (no commit record), slot B
/// erased.
pub fn plain_slot_a(blob: &[u8]) -> Vec<Vec<u8>> {
    let mut slots = vec![vec![0xFF; SLOT_LEN], vec![0xFF; SLOT_LEN]];
    slots[0][..blob.len()].copy_from_slice(blob);
    slots
}

/// Writes `blob` and its commit record with `counter` into `slot` of `slots`.
pub fn commit_into(slots: &mut [Vec<u8>], slot: usize, blob: &[u8], counter: u32) {
    slots[slot].fill(0xFF);
    slots[slot][..blob.len()].copy_from_slice(blob);
    let record = commit_record(blob, counter);
    slots[slot][blob.len()..blob.len() + record.len()].copy_from_slice(&record);
}

/// The committed development key, the one `firmware/build.rs` provisions by default.
pub fn development_key() -> [u8; KEY_LEN] {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../keys/dev-device.key");
    let text = std::fs::read_to_string(path).expect("read the development key");
    parse_key(&text).expect("a valid key file")
}

/// Parameters from one of the paper's presets scaled to `subject` at 500 Hz, with the
/// default settings.
pub fn preset_params(
    preset: Preset,
    subject: Subject,
    identity: ParamsIdentity,
    telemetry: TelemetryConfig,
) -> DeviceParams {
    let mut model = ModelParams::preset(preset);
    model.subject = subject;
    let (realization, joints) =
        device_model(&model, SAMPLE_RATE_HZ).expect("the preset discretizes");
    let sample_rate = SampleRate::from_hz_f64(SAMPLE_RATE_HZ).expect("a supported rate");
    let patient = Patient::of(&subject);
    DeviceParams::with_defaults(identity, patient, sample_rate, realization, joints)
        .and_then(|p| p.with_telemetry(telemetry))
        .expect("valid parameters")
}

pub fn encode(params: &DeviceParams) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let len = params.encode(&mut buf).expect("the blob encodes");
    buf.truncate(len);
    buf
}

/// The boot parameters: paper litter board, telemetry for every sample (as replay uses),
/// and a tumble-test calibration (the greeting and status must carry it).
pub fn boot_params() -> DeviceParams {
    preset_params(
        Preset::PaperLitter,
        Subject::PAPER_MEAN,
        BOOT_IDENTITY,
        TelemetryConfig::EVERY_SAMPLE,
    )
    .with_calibration(supine_core::protocol::golden::calibration_example())
    .expect("valid calibration")
}

/// The patient the uploaded parameters are scaled to.
pub const UPLOAD_SUBJECT: Subject = Subject {
    height_m: 1.6,
    mass_kg: 52.0,
};

/// The uploaded parameters differ in the model, the patient ([`UPLOAD_SUBJECT`]) and the
/// telemetry rate (every 5th sample).
pub fn upload_params() -> DeviceParams {
    preset_params(
        Preset::PaperRigid,
        UPLOAD_SUBJECT,
        UPLOAD_IDENTITY,
        TelemetryConfig::default_for(SAMPLE_RATE_HZ as f32),
    )
}

/// The built-in parameters of the simulated device: the litter board, as the firmware's.
pub fn builtin_params() -> DeviceParams {
    preset_params(
        Preset::PaperLitter,
        Subject::PAPER_MEAN,
        BUILTIN_IDENTITY,
        TelemetryConfig::EVERY_SAMPLE,
    )
}

/// `n` samples of the test vector, scaled up so that exposure builds.
pub fn samples(seed: u32, n: usize) -> Vec<[f32; 3]> {
    TestVector::new(seed)
        .take(n)
        .map(|x| x.map(|v| 8.0 * v))
        .collect()
}

/// Sample frames for consecutive indices from `first_index`, as the host batches them.
pub fn sample_frames(first_index: u32, samples: &[[f32; 3]]) -> Vec<HostToDevice> {
    samples
        .chunks(MAX_SAMPLES_PER_FRAME)
        .enumerate()
        .map(|(k, chunk)| {
            HostToDevice::Samples(SampleBatch {
                first_sample_index: first_index.wrapping_add((k * MAX_SAMPLES_PER_FRAME) as u32),
                accel_m_s2: heapless::Vec::from_slice(chunk).expect("a chunk fits a frame"),
            })
        })
        .collect()
}

/// What the pipeline itself gives for these samples from a fresh state, as messages.
pub fn pipeline_messages(
    params: &DeviceParams,
    indices: &[u32],
    samples: &[[f32; 3]],
) -> Vec<DeviceToHost> {
    pipeline_messages_from(&mut PipelineState::new(), params, indices, samples)
}

/// What the pipeline gives for these samples from `state`, as messages.
pub fn pipeline_messages_from(
    state: &mut PipelineState,
    params: &DeviceParams,
    indices: &[u32],
    samples: &[[f32; 3]],
) -> Vec<DeviceToHost> {
    let mut out = Vec::new();
    params.process(state, indices, samples, |o| match o {
        PipelineOutput::Telemetry(t) => out.push(DeviceToHost::Telemetry(t)),
        PipelineOutput::Alert(e) => out.push(DeviceToHost::Alert(e)),
    });
    out
}

/// Every float by its bits: NaN-safe and exact (0.0 and -0.0 differ).
pub fn telemetry_bits(t: &Telemetry) -> String {
    format!(
        "{} {:?} {:?} {} {} {:?} {} {}",
        t.sample_index,
        t.head_acc_m_s2.map(f32::to_bits),
        t.running_rms_m_s2.map(f32::to_bits),
        t.vector_running_rms_m_s2.to_bits(),
        t.vdv_m_s175.to_bits(),
        t.alert_level,
        t.fault_flags,
        t.valid
    )
}

pub fn assert_same_messages(actual: &[DeviceToHost], expected: &[DeviceToHost]) {
    assert_eq!(actual.len(), expected.len(), "number of messages");
    for (k, (a, e)) in actual.iter().zip(expected).enumerate() {
        match (a, e) {
            (DeviceToHost::Telemetry(a), DeviceToHost::Telemetry(e)) => {
                assert_eq!(telemetry_bits(a), telemetry_bits(e), "telemetry {k}")
            }
            _ => assert_eq!(a, e, "message {k}"),
        }
    }
}

pub fn count_telemetry(messages: &[DeviceToHost]) -> usize {
    messages
        .iter()
        .filter(|m| matches!(m, DeviceToHost::Telemetry(_)))
        .count()
}

/// The `ParamBegin` of an upload of `blob` with `counter`, signed with `key`.
pub fn begin(blob: &[u8], counter: u32, key: &[u8; KEY_LEN]) -> HostToDevice {
    HostToDevice::ParamBegin(ParamBegin {
        length_bytes: blob.len() as u32,
        counter,
        hmac_sha256: update_mac(key, counter, blob),
    })
}

/// The chunks of `blob`, in order, as the host sends them.
pub fn chunks(blob: &[u8]) -> Vec<HostToDevice> {
    blob.chunks(PARAM_CHUNK_LEN)
        .enumerate()
        .map(|(k, piece)| {
            HostToDevice::ParamChunk(ParamChunk {
                offset_bytes: (k * PARAM_CHUNK_LEN) as u32,
                bytes: heapless::Vec::from_slice(piece).expect("a chunk fits"),
            })
        })
        .collect()
}

/// The messages of a whole upload, signed with `key`.
pub fn upload_messages(blob: &[u8], counter: u32, key: &[u8; KEY_LEN]) -> Vec<HostToDevice> {
    let mut messages = vec![begin(blob, counter, key)];
    messages.extend(chunks(blob));
    messages.push(HostToDevice::ParamCommit);
    messages
}

/// The acknowledgements of every step of an upload of `blob` before its commit.
pub fn transfer_acks(blob: &[u8]) -> Vec<DeviceToHost> {
    let mut acks = vec![DeviceToHost::ParamAck(ParamAck::Begun)];
    for end in (PARAM_CHUNK_LEN..blob.len()).step_by(PARAM_CHUNK_LEN) {
        acks.push(DeviceToHost::ParamAck(ParamAck::Received {
            bytes: end as u32,
        }));
    }
    acks.push(DeviceToHost::ParamAck(ParamAck::Received {
        bytes: blob.len() as u32,
    }));
    acks
}
