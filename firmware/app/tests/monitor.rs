//! The monitor's main loop on the host: an in-memory link, a simulated clock and a RAM
//! flash stand in for the UART, SysTick and the PARAMS slots. Every frame the monitor
//! sends is decoded as the host decodes it, and every telemetry record and alert is
//! compared, bit for bit, with what `supine_core::pipeline` computes directly from the
//! same samples and parameters.

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

use supine_app::{App, Boot, IDLE_FLUSH_TICKS, StackGauge, TickCounter};
use supine_core::alerts::{AlertEvent, Level, SensorFault};
use supine_core::blob::{DeviceParams, MAX_BLOB_LEN, TelemetryConfig};
use supine_core::model::{ModelParams, Preset, device_realization};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::protocol::{
    DeviceFrame, DeviceToHost, FrameAccumulator, FrameEvent, Greeting, HostToDevice, MAX_FRAME_LEN,
    MAX_SAMPLES_PER_FRAME, PARAM_CHUNK_LEN, PROTOCOL_VERSION, ParamAck, ParamBegin, ParamChunk,
    ParamsIdentity, ParamsSource, ResetCause, SampleBatch, Status, Telemetry, UploadError,
    encode_frame,
};
use supine_core::sample_rate::SampleRate;
use supine_core::test_vector::TestVector;
use supine_core::upload::{
    FlashError, KEY_LEN, ParamFlash, SLOT_COUNT, SLOT_LEN, parse_key, select, update_mac,
};

/// Sample rate of every parameter set here, Hz.
const SAMPLE_RATE_HZ: f64 = 500.0;
/// What the simulated stack gauge reports, bytes.
const STACK_BYTES: usize = 3_172;
/// Identity of the parameters the device boots with.
const BOOT_IDENTITY: ParamsIdentity = [0x11; 16];
/// Identity of the parameters uploaded.
const UPLOAD_IDENTITY: ParamsIdentity = [0x42; 16];
/// The build suffix of the greeting.
const BUILD: &str = "+host-test";

/// The bytes on the wire, both ways.
#[derive(Default)]
struct Wire {
    /// Host to device, not yet read.
    rx: VecDeque<u8>,
    /// Device to host, everything written.
    tx: Vec<u8>,
    /// A slow link takes a byte without waiting only at every other attempt, so the
    /// transmit ring fills, wraps and drains with waiting.
    slow: bool,
    ready_toggle: bool,
}

/// The monitor's end of the wire.
struct MemLink(Rc<RefCell<Wire>>);

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

/// A counter that moves only when the test says.
struct Clock(Rc<Cell<u32>>);

impl TickCounter for Clock {
    fn now(&self) -> u32 {
        self.0.get()
    }
    fn ticks_since(&self, start: u32) -> u32 {
        self.0.get().wrapping_sub(start)
    }
}

struct Gauge;

impl StackGauge for Gauge {
    fn high_water_bytes(&self) -> usize {
        STACK_BYTES
    }
}

/// What the test sees of the flash the monitor owns: its bytes after every operation,
/// and how many erases and writes it took.
#[derive(Clone, Default)]
struct FlashView {
    slots: Vec<Vec<u8>>,
    operations: usize,
}

/// Two slots in RAM with NOR flash rules: erase to 0xFF, programming clears bits only.
struct RamFlash {
    slots: [Vec<u8>; SLOT_COUNT],
    view: Rc<RefCell<FlashView>>,
}

impl RamFlash {
    fn publish(&self) {
        let mut view = self.view.borrow_mut();
        view.slots = self.slots.to_vec();
        view.operations += 1;
    }
}

impl ParamFlash for RamFlash {
    fn slot(&self, slot: usize) -> &[u8] {
        self.slots.get(slot).map_or(&[], |s| s.as_slice())
    }
    fn erase(&mut self, slot: usize) -> Result<(), FlashError> {
        self.slots.get_mut(slot).ok_or(FlashError)?.fill(0xFF);
        self.publish();
        Ok(())
    }
    fn write(&mut self, slot: usize, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        let cells = self
            .slots
            .get_mut(slot)
            .and_then(|s| s.get_mut(offset..offset + bytes.len()))
            .ok_or(FlashError)?;
        for (cell, &b) in cells.iter_mut().zip(bytes) {
            *cell &= b;
        }
        self.publish();
        Ok(())
    }
}

/// A read-only copy of flash as the test last saw it, for `select`.
struct Snapshot(Vec<Vec<u8>>);

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

/// The monitor with everything it is connected to.
struct Rig {
    app: App<MemLink, Clock, Gauge, RamFlash>,
    wire: Rc<RefCell<Wire>>,
    clock: Rc<Cell<u32>>,
    flash: Rc<RefCell<FlashView>>,
    decoder: FrameAccumulator,
    decoded_bytes: usize,
    next_seq: u32,
}

impl Rig {
    /// A monitor booted, as the firmware boots, from slot A holding `boot_blob` as QEMU's
    /// loader places it (no commit record), taking updates signed with the development
    /// key. It has greeted; the greeting is returned.
    fn boot(boot_blob: &[u8], slow: bool) -> (Self, Greeting) {
        let mut slots = [vec![0xFF; SLOT_LEN], vec![0xFF; SLOT_LEN]];
        slots[0][..boot_blob.len()].copy_from_slice(boot_blob);
        let view = Rc::new(RefCell::new(FlashView {
            slots: slots.to_vec(),
            operations: 0,
        }));
        let flash = RamFlash {
            slots,
            view: Rc::clone(&view),
        };
        let active = select(&flash).expect("slot A holds a valid blob");
        let boot = Boot {
            build: BUILD,
            params: active.params,
            source: ParamsSource::Flash { slot: active.slot },
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
            Clock(Rc::clone(&clock)),
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
    fn send(&mut self, message: &HostToDevice) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(message, &mut buf).expect("every message fits a frame");
        self.wire.borrow_mut().rx.extend(frame.iter().copied());
    }

    fn send_all(&mut self, messages: &[HostToDevice]) {
        messages.iter().for_each(|m| self.send(m));
    }

    /// Runs the main loop until every byte sent is read and the transmit ring is empty;
    /// returns the messages sent since the last call, checking their sequence numbers.
    fn run(&mut self) -> Vec<DeviceToHost> {
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
    fn advance_ticks(&self, ticks: u32) {
        self.clock.set(self.clock.get().wrapping_add(ticks));
    }

    /// Asks for the status, which also processes what is buffered; returns what came
    /// before it and the status.
    fn status(&mut self) -> (Vec<DeviceToHost>, Status) {
        self.send(&HostToDevice::GetStatus);
        let mut messages = self.run();
        match messages.pop() {
            Some(DeviceToHost::Status(status)) => (messages, status),
            other => panic!("expected a status last, got {other:?}"),
        }
    }
}

/// The committed development key, the one `firmware/build.rs` provisions by default.
fn development_key() -> [u8; KEY_LEN] {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../keys/dev-device.key");
    let text = std::fs::read_to_string(path).expect("read the development key");
    parse_key(&text).expect("a valid key file")
}

/// Parameters from one of the paper's presets at 500 Hz, with the default settings.
fn preset_params(
    preset: Preset,
    identity: ParamsIdentity,
    telemetry: TelemetryConfig,
) -> DeviceParams {
    let realization = device_realization(&ModelParams::preset(preset), SAMPLE_RATE_HZ)
        .expect("the preset discretizes");
    let sample_rate = SampleRate::from_hz_f64(SAMPLE_RATE_HZ).expect("a supported rate");
    let mut params =
        DeviceParams::with_defaults(identity, sample_rate, realization).expect("valid defaults");
    params.telemetry = telemetry;
    params.validate().expect("valid parameters");
    params
}

fn encode(params: &DeviceParams) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let len = params.encode(&mut buf).expect("the blob encodes");
    buf.truncate(len);
    buf
}

/// The boot parameters: paper litter board, telemetry for every sample (as replay uses).
fn boot_params() -> DeviceParams {
    preset_params(
        Preset::PaperLitter,
        BOOT_IDENTITY,
        TelemetryConfig::EVERY_SAMPLE,
    )
}

/// The uploaded parameters differ in the model and the telemetry rate (every 5th sample).
fn upload_params() -> DeviceParams {
    preset_params(
        Preset::PaperRigid,
        UPLOAD_IDENTITY,
        TelemetryConfig::default_for(SAMPLE_RATE_HZ as f32),
    )
}

/// `n` samples of the test vector, scaled up so that exposure builds.
fn samples(seed: u32, n: usize) -> Vec<[f32; 3]> {
    TestVector::new(seed)
        .take(n)
        .map(|x| x.map(|v| 8.0 * v))
        .collect()
}

/// Sample frames for consecutive indices from `first_index`, as the host batches them.
fn sample_frames(first_index: u32, samples: &[[f32; 3]]) -> Vec<HostToDevice> {
    samples
        .chunks(MAX_SAMPLES_PER_FRAME)
        .enumerate()
        .map(|(k, chunk)| {
            HostToDevice::Samples(SampleBatch {
                first_sample_index: first_index + (k * MAX_SAMPLES_PER_FRAME) as u32,
                accel_m_s2: heapless::Vec::from_slice(chunk).expect("a chunk fits a frame"),
            })
        })
        .collect()
}

/// What the pipeline itself gives for these samples from a fresh state, as messages.
fn pipeline_messages(
    params: &DeviceParams,
    indices: &[u32],
    samples: &[[f32; 3]],
) -> Vec<DeviceToHost> {
    pipeline_messages_from(&mut PipelineState::new(), params, indices, samples)
}

/// What the pipeline gives for these samples from `state`, as messages.
fn pipeline_messages_from(
    state: &mut PipelineState,
    params: &DeviceParams,
    indices: &[u32],
    samples: &[[f32; 3]],
) -> Vec<DeviceToHost> {
    let mut out = Vec::new();
    params.process(state, indices, samples, |o| {
        out.push(match o {
            PipelineOutput::Telemetry(t) => DeviceToHost::Telemetry(t),
            PipelineOutput::Alert(e) => DeviceToHost::Alert(e),
        })
    });
    out
}

/// Every float by its bits: NaN-safe and exact (0.0 and -0.0 differ).
fn telemetry_bits(t: &Telemetry) -> String {
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

fn assert_same_messages(actual: &[DeviceToHost], expected: &[DeviceToHost]) {
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

fn count_telemetry(messages: &[DeviceToHost]) -> usize {
    messages
        .iter()
        .filter(|m| matches!(m, DeviceToHost::Telemetry(_)))
        .count()
}

/// The messages of a whole upload, signed with `key`.
fn upload_messages(blob: &[u8], counter: u32, key: &[u8; KEY_LEN]) -> Vec<HostToDevice> {
    let mut messages = vec![HostToDevice::ParamBegin(ParamBegin {
        length_bytes: blob.len() as u32,
        counter,
        hmac_sha256: update_mac(key, counter, blob),
    })];
    for (k, piece) in blob.chunks(PARAM_CHUNK_LEN).enumerate() {
        messages.push(HostToDevice::ParamChunk(ParamChunk {
            offset_bytes: (k * PARAM_CHUNK_LEN) as u32,
            bytes: heapless::Vec::from_slice(piece).expect("a chunk fits"),
        }));
    }
    messages.push(HostToDevice::ParamCommit);
    messages
}

/// The acknowledgements of every step of an upload of `blob` before its commit.
fn transfer_acks(blob: &[u8]) -> Vec<DeviceToHost> {
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

#[test]
fn greets_at_boot_and_again_on_hello() {
    let params = boot_params();
    let (mut rig, greeting) = Rig::boot(&encode(&params), false);
    let expected = Greeting {
        protocol_version: PROTOCOL_VERSION,
        firmware_version: heapless::String::try_from(
            format!("{}{BUILD}", env!("CARGO_PKG_VERSION")).as_str(),
        )
        .unwrap(),
        params_identity: BOOT_IDENTITY,
        params_source: ParamsSource::Flash { slot: 0 },
        sample_rate_hz: SAMPLE_RATE_HZ as f32,
        reset_cause: ResetCause::PowerOn,
        last_panic: heapless::String::new(),
    };
    assert_eq!(greeting, expected);
    rig.send(&HostToDevice::Hello);
    assert_eq!(rig.run(), [DeviceToHost::Greeting(expected)]);
}

#[test]
fn telemetry_and_alerts_are_the_pipelines_bit_for_bit_and_the_status_counts_them() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), false);
    // 1,500 samples, a gap of 13, then 1,800 more with one NaN: past the 5 s warm-up
    // and the dwell, so exposure levels rise, with index-gap and non-finite faults.
    let mut input = samples(7, 3300);
    input[2000][1] = f32::NAN;
    let indices: Vec<u32> = (0..1500).chain(1513..3313).collect();
    let mut frames = sample_frames(0, &input[..1500]);
    frames.extend(sample_frames(1513, &input[1500..]));
    rig.send_all(&frames);
    // A frame that decodes as COBS but not as a message.
    rig.wire.borrow_mut().rx.extend([0x02, 0x63, 0x00]);

    let (messages, status) = rig.status();

    let expected = pipeline_messages(&params, &indices, &input);
    assert_same_messages(&messages, &expected);
    assert_eq!(count_telemetry(&messages), 3300, "one record per sample");
    let alerts: Vec<AlertEvent> = messages
        .iter()
        .filter_map(|m| match m {
            DeviceToHost::Alert(e) => Some(*e),
            _ => None,
        })
        .collect();
    let raised = |fault| {
        alerts
            .iter()
            .any(|e| matches!(e, AlertEvent::Fault { fault: f, active: true, .. } if *f == fault))
    };
    assert!(raised(SensorFault::IndexGap), "{alerts:?}");
    assert!(raised(SensorFault::NonFinite), "{alerts:?}");
    assert!(
        alerts
            .iter()
            .any(|e| matches!(e, AlertEvent::Level { to, .. } if *to > Level::Normal)),
        "{alerts:?}"
    );
    assert_eq!(
        status,
        Status {
            frames_received: frames.len() as u32 + 1,
            bad_frames: 1,
            samples_processed: 3300,
            samples_dropped: 13,
            telemetry_sent: 3300,
            uploads_rejected: 0,
            // The simulated clock stood still.
            busy_ticks: 0,
            stack_used_bytes: STACK_BYTES as u32,
            params_source: ParamsSource::Flash { slot: 0 },
        }
    );
}

#[test]
fn a_pause_in_the_stream_processes_a_partial_block() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), false);
    let input = samples(3, 5);
    rig.send_all(&sample_frames(0, &input));
    assert_eq!(rig.run(), [], "a partial block waits for more samples");
    rig.advance_ticks(IDLE_FLUSH_TICKS - 1);
    assert_eq!(rig.run(), [], "not yet a pause");
    rig.advance_ticks(1);
    let messages = rig.run();
    assert_eq!(count_telemetry(&messages), 5);
    assert_same_messages(
        &messages,
        &pipeline_messages(&params, &[0, 1, 2, 3, 4], &input),
    );
}

#[test]
fn a_slow_link_gets_every_frame_in_order() {
    let params = boot_params();
    let (mut rig, _) = Rig::boot(&encode(&params), true);
    let input = samples(11, 800);
    rig.send_all(&sample_frames(1000, &input));
    let (messages, status) = rig.status();
    let indices: Vec<u32> = (1000..1800).collect();
    assert_same_messages(&messages, &pipeline_messages(&params, &indices, &input));
    assert_eq!(
        (status.samples_processed, status.telemetry_sent),
        (800, 800)
    );
}

#[test]
fn refused_uploads_are_answered_counted_and_change_nothing() {
    let params = boot_params();
    let boot_blob = encode(&params);
    let (mut rig, greeting) = Rig::boot(&boot_blob, false);
    let flash_before = rig.flash.borrow().clone();
    let new_blob = encode(&upload_params());

    // Signed with another key: every step is taken, the commit is refused.
    let mut wrong_key = development_key();
    wrong_key[0] ^= 1;
    rig.send_all(&upload_messages(&new_blob, 1, &wrong_key));
    let mut expected = transfer_acks(&new_blob);
    expected.push(DeviceToHost::ParamNack(UploadError::BadSignature));
    assert_eq!(rig.run(), expected);

    // Properly signed, but its counter is not above the running blob's (0): a replay.
    rig.send_all(&upload_messages(&new_blob, 0, &development_key())[..1]);
    assert_eq!(rig.run(), [DeviceToHost::ParamNack(UploadError::Replayed)]);

    let flash_after = rig.flash.borrow().clone();
    assert_eq!(
        flash_after.operations, flash_before.operations,
        "flash touched"
    );
    assert!(flash_after.slots == flash_before.slots);
    rig.send(&HostToDevice::Hello);
    assert_eq!(rig.run(), [DeviceToHost::Greeting(greeting)]);
    // Still the boot parameters, on the state they had.
    let input = samples(5, 40);
    rig.send_all(&sample_frames(0, &input));
    let (messages, status) = rig.status();
    let indices: Vec<u32> = (0..40).collect();
    assert_same_messages(&messages, &pipeline_messages(&params, &indices, &input));
    assert_eq!(status.uploads_rejected, 2);
    assert_eq!(status.params_source, ParamsSource::Flash { slot: 0 });
}

#[test]
fn an_accepted_upload_is_stored_in_the_other_slot_and_runs_from_the_next_sample() {
    let old = boot_params();
    let old_blob = encode(&old);
    let (mut rig, boot_greeting) = Rig::boot(&old_blob, false);
    let new = upload_params();
    let new_blob = encode(&new);

    // 20 samples: one block runs at once, the last 4 wait in the buffer; the commit
    // finishes them on the old parameters before it switches.
    let before = samples(21, 20);
    rig.send_all(&sample_frames(0, &before));
    rig.send_all(&upload_messages(&new_blob, 1, &development_key()));
    let messages = rig.run();

    // The first block's output, the acks of the transfer as the chunks arrive, then at
    // the commit the buffered samples' output.
    let old_indices: Vec<u32> = (0..20).collect();
    let mut state = PipelineState::new();
    let mut expected = pipeline_messages_from(&mut state, &old, &old_indices[..16], &before[..16]);
    expected.extend(transfer_acks(&new_blob));
    expected.extend(pipeline_messages_from(
        &mut state,
        &old,
        &old_indices[16..],
        &before[16..],
    ));
    expected.push(DeviceToHost::ParamAck(ParamAck::Committed {
        identity: UPLOAD_IDENTITY,
        slot: 1,
    }));
    expected.push(DeviceToHost::Greeting(Greeting {
        params_identity: UPLOAD_IDENTITY,
        params_source: ParamsSource::Flash { slot: 1 },
        ..boot_greeting
    }));
    assert_same_messages(&messages, &expected);

    // In flash: slot B holds the new blob with its commit record and wins at the next
    // boot; slot A is as it was.
    let view = rig.flash.borrow().clone();
    assert!(view.operations > 0);
    assert_eq!(&view.slots[0][..old_blob.len()], old_blob.as_slice());
    assert_eq!(&view.slots[1][..new_blob.len()], new_blob.as_slice());
    let next_boot = select(&Snapshot(view.slots)).expect("a valid slot");
    assert_eq!((next_boot.slot, next_boot.counter), (1, 1));
    assert_eq!(next_boot.params, new);

    // The new parameters from a fresh state: another model, every 5th sample reported.
    let after = samples(22, 100);
    rig.send_all(&sample_frames(20, &after));
    let (messages, status) = rig.status();
    let new_indices: Vec<u32> = (20..120).collect();
    assert_same_messages(&messages, &pipeline_messages(&new, &new_indices, &after));
    assert_eq!(count_telemetry(&messages), 20);
    assert_eq!(status.params_source, ParamsSource::Flash { slot: 1 });
    assert_eq!(status.uploads_rejected, 0);
    assert_eq!(status.samples_processed, 120);
}
