//! Authenticated parameter uploads into the monitor image in QEMU: a good upload switches
//! the parameters (and the telemetry follows them), every kind of bad upload is refused
//! with its code and changes nothing, and a power cut keeps the last good parameters.
//!
//! Power cuts are simulated faithfully: flash survives, RAM does not. The test stops the
//! machine through QEMU's monitor, saves the PARAMS region (`pmemsave`, the "flash"), ends
//! QEMU, and boots a fresh QEMU with the saved bytes as the region's loader file. A
//! `system_reset` in the same QEMU would not do: `-device loader` files are ROM blobs that
//! QEMU copies again at every reset, undoing what the device wrote (checked below).
//!
//! Cuts during the device's own erase and write come from the `power_cut` image: the
//! product's monitor whose flash stops after a byte budget given on QEMU's command line,
//! mid-erase, mid-blob or mid-record, exactly where the test asks.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use supine_core::alerts::{AlertConfig, SensorCheckConfig};
use supine_core::blob::{BlobError, DeviceParams};
use supine_core::exposure::ExposureConfig;
use supine_core::model::{ModelParams, Preset, Subject};
use supine_core::mounting::Mounting;
use supine_core::protocol::{
    DeviceToHost, Greeting, HostToDevice, PARAM_CHUNK_LEN, ParamAck, ParamBegin, ParamChunk,
    ParamsSource, UploadError,
};
use supine_core::upload::{KEY_LEN, update_mac};
use supine_host::device::firmware::PRODUCT_BINARY;
use supine_host::device::flash::{self, REGION_IMAGE_COUNTER, REGION_LEN};
use supine_host::device::link::{FrameReader, FrameWriter};
use supine_host::device::qemu::{PARAMS_ADDR, Qemu, QemuConfig};
use supine_host::device::replay::{Outgoing, Session, SessionConfig, sample_messages, session};
use supine_host::exposure::reference;
use supine_host::io::params_file::{DeviceSection, ParamFile};
use supine_qemu_tests::{MONITOR_STACK_CEILING_BYTES, firmware, run_to_end};

const FS_HZ: f64 = 500.0;
const STEP: Duration = Duration::from_secs(20);

/// A parameter file from a preset, with alert thresholds low enough for the test ride.
fn file(preset: Preset) -> ParamFile {
    ParamFile {
        params: ModelParams::preset(preset),
        fit: None,
        device: Some(DeviceSection {
            exposure: ExposureConfig::DEFAULT,
            alerts: AlertConfig {
                running_rms_m_s2: [0.1, 0.3, 0.6],
                vdv_m_s175: [2.0, 4.0, 8.0],
                hysteresis: 0.2,
                raise_dwell_s: 0.5,
                clear_dwell_s: 1.0,
            },
            sensor_checks: SensorCheckConfig::DEFAULT,
            mounting: Mounting::LEVEL,
            joint_outputs: supine_host::io::device_table::JointSelection::ALL,
            joint_alerts: Default::default(),
            telemetry_decimation: Some(1),
            calibration: Default::default(),
        }),
    }
}

/// Parameters A (litter board, in slot A at boot) and B (rigid platform, uploaded).
fn params_and_blob(preset: Preset) -> (DeviceParams, Vec<u8>) {
    flash::device_blob(&file(preset), FS_HZ).expect("blob builds")
}

fn key() -> [u8; KEY_LEN] {
    flash::load_key(None).expect("the development key")
}

/// Litter-axis accelerations, m/s^2: a few sines per axis, strong enough to raise alerts.
fn ride(samples: usize) -> Vec<[f32; 3]> {
    (0..samples)
        .map(|k| {
            let t = k as f64 / FS_HZ;
            let s = |f: f64, phase: f64| (std::f64::consts::TAU * f * t + phase).sin();
            [
                0.4 * s(1.5, 0.0) + 0.2 * s(6.0, 1.0),
                0.3 * s(2.5, 0.5) + 0.1 * s(9.0, 2.0),
                1.2 * s(4.5, 0.3) + 0.5 * s(7.5, 1.7),
            ]
            .map(|v| v as f32)
        })
        .collect()
}

/// The messages of an upload: begin (length, counter, `mac`), `chunks` of the blob, commit.
fn upload_messages(blob: &[u8], counter: u32, mac: [u8; 32], chunks: usize) -> Vec<Outgoing> {
    let mut out = vec![Outgoing::Message(HostToDevice::ParamBegin(ParamBegin {
        length_bytes: blob.len() as u32,
        counter,
        hmac_sha256: mac,
    }))];
    for (i, piece) in blob.chunks(PARAM_CHUNK_LEN).enumerate().take(chunks) {
        out.push(Outgoing::Message(HostToDevice::ParamChunk(ParamChunk {
            offset_bytes: (i * PARAM_CHUNK_LEN) as u32,
            bytes: piece.try_into().expect("chunk fits"),
        })));
    }
    out.push(Outgoing::Message(HostToDevice::ParamCommit));
    out
}

fn signed(blob: &[u8], counter: u32) -> Vec<Outgoing> {
    upload_messages(blob, counter, update_mac(&key(), counter, blob), usize::MAX)
}

fn run(region: &[u8], script: Vec<Outgoing>) -> Session {
    let config = SessionConfig {
        kernel: firmware(PRODUCT_BINARY),
        blob: Some(region.to_vec()),
        icount: false,
        timeout: Duration::from_secs(120),
    };
    session(&config, script, &Arc::new(AtomicBool::new(false))).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The region image slot A of which holds parameters A (counter 1).
fn region_a() -> Vec<u8> {
    let (_, blob) = flash::device_blob(&file(Preset::PaperLitter), FS_HZ).expect("blob");
    flash::qemu_region_image(&blob).expect("region image")
}

fn acks(s: &Session) -> Vec<Result<ParamAck, UploadError>> {
    s.other
        .iter()
        .filter_map(|m| match m {
            DeviceToHost::ParamAck(a) => Some(Ok(*a)),
            DeviceToHost::ParamNack(e) => Some(Err(*e)),
            _ => None,
        })
        .collect()
}

fn committed(s: &Session) -> Vec<ParamAck> {
    acks(s)
        .into_iter()
        .filter_map(|a| a.ok().filter(|a| matches!(a, ParamAck::Committed { .. })))
        .collect()
}

#[test]
fn a_signed_upload_switches_the_parameters_and_a_replay_of_it_is_refused() {
    let (a, _) = params_and_blob(Preset::PaperLitter);
    // B is scaled to another patient than A's mean subject (issue 15, item 2).
    let mut file_b = file(Preset::PaperRigid);
    file_b.params.subject = Subject {
        height_m: 1.6,
        mass_kg: 52.0,
    };
    let (b, blob_b) = flash::device_blob(&file_b, FS_HZ).expect("blob builds");
    assert_ne!(a.identity, b.identity);
    let n = 3000;
    let input = ride(n);
    let counter = 1_000;
    let mut script = signed(&blob_b, counter);
    // The very same messages again: a replay.
    script.extend(signed(&blob_b, counter));
    script.extend(sample_messages(0, &input));
    script.push(Outgoing::Message(HostToDevice::Hello));
    let s = run(&region_a(), script);
    println!("acks {:?}\nstatus {:?}", acks(&s), s.status());

    let chunks = blob_b.len().div_ceil(PARAM_CHUNK_LEN);
    let mut expected = vec![Ok(ParamAck::Begun)];
    expected.extend((1..=chunks).map(|i| {
        Ok(ParamAck::Received {
            bytes: (i * PARAM_CHUNK_LEN).min(blob_b.len()) as u32,
        })
    }));
    expected.push(Ok(ParamAck::Committed {
        identity: b.identity,
        slot: 1,
    }));
    expected.push(Err(UploadError::Replayed));
    // The replay's chunks and commit find no open upload.
    expected.extend(std::iter::repeat_n(
        Err(UploadError::NotStarted),
        chunks + 1,
    ));
    assert_eq!(acks(&s), expected);
    assert_eq!(s.status().uploads_rejected, chunks as u32 + 2);

    // Booted on A from slot A; greeted with B from slot B after the commit and on Hello.
    let ids: Vec<_> = s
        .greetings
        .iter()
        .map(|g| (g.params_identity, g.params_source))
        .collect();
    let from = |slot| ParamsSource::Flash { slot };
    assert_eq!(
        ids,
        vec![
            (a.identity, from(0)),
            (b.identity, from(1)),
            (b.identity, from(1))
        ]
    );
    // Each greeting names the patient of the parameters it runs, and so does the status.
    let patients: Vec<_> = s
        .greetings
        .iter()
        .map(|g| (g.height_m, g.mass_kg))
        .collect();
    assert_eq!(patients, vec![(1.82, 81.0), (1.6, 52.0), (1.6, 52.0)]);
    assert_eq!((s.status().height_m, s.status().mass_kg), (1.6, 52.0));

    // The telemetry is B's pipeline from a fresh state, exactly, and not A's.
    let indices: Vec<u32> = (0..n as u32).collect();
    let host_b = reference::pipeline(&b, &indices, &input);
    let host_a = reference::pipeline(&a, &indices, &input);
    assert_eq!(s.telemetry.len(), n);
    assert_eq!(s.telemetry, host_b.telemetry, "telemetry is not B's");
    // The deepest path the monitor has: boot, a committed upload, a refused one, a ride.
    let stack = s.status().stack_used_bytes;
    println!("stack_used_bytes: {stack}");
    assert!(
        stack > 0 && stack <= MONITOR_STACK_CEILING_BYTES,
        "stack_used_bytes {stack}"
    );
    // Events bit for bit, each level change's criterion and value included.
    assert_eq!(s.events, host_b.events, "events are not B's");
    assert!(
        s.events.iter().any(|e| e.criterion().is_some()),
        "B's thresholds raise a level on this ride"
    );
    assert_ne!(host_a.telemetry, host_b.telemetry, "A and B must differ");
}

#[test]
fn unauthenticated_replayed_truncated_and_corrupted_uploads_are_refused_and_change_nothing() {
    let (a, _) = params_and_blob(Preset::PaperLitter);
    let (_, blob_b) = params_and_blob(Preset::PaperRigid);
    let counter = 2_000;
    let good_mac = update_mac(&key(), counter, &blob_b);
    let chunks = blob_b.len().div_ceil(PARAM_CHUNK_LEN);

    let mut wrong_key = key();
    wrong_key[0] ^= 0x01;
    let mut flipped_mac = good_mac;
    flipped_mac[31] ^= 0x80;
    // A blob whose payload CRC is wrong, signed by the key holder.
    let mut bad_crc = blob_b.clone();
    bad_crc[40] ^= 0x04;
    // A blob cut in half (the header still announces the whole), signed: its header and
    // the upload disagree on the length.
    let cut = blob_b[..blob_b.len() / 2].to_vec();
    let expect_decode = |blob: &[u8]| DeviceParams::decode(blob).expect_err("refused");
    assert_eq!(expect_decode(&bad_crc), BlobError::BadCrc);
    assert_eq!(expect_decode(&cut), BlobError::Truncated);
    // A bit flipped in transit in the second chunk of a well-signed blob.
    let mut in_transit = blob_b.clone();
    in_transit[PARAM_CHUNK_LEN + 5] ^= 0x10;

    let cases: Vec<(&str, Vec<Outgoing>, UploadError)> = vec![
        (
            "signed with another key",
            upload_messages(
                &blob_b,
                counter,
                update_mac(&wrong_key, counter, &blob_b),
                usize::MAX,
            ),
            UploadError::BadSignature,
        ),
        (
            "a flipped MAC bit",
            upload_messages(&blob_b, counter, flipped_mac, usize::MAX),
            UploadError::BadSignature,
        ),
        (
            "the MAC of another counter",
            upload_messages(
                &blob_b,
                counter,
                update_mac(&key(), counter + 1, &blob_b),
                usize::MAX,
            ),
            UploadError::BadSignature,
        ),
        (
            "a bit flipped in a chunk",
            upload_messages(&in_transit, counter, good_mac, usize::MAX),
            UploadError::BadSignature,
        ),
        (
            "the region image's counter again (a replay)",
            signed(&blob_b, REGION_IMAGE_COUNTER),
            UploadError::Replayed,
        ),
        (
            "commit before the last chunk (a truncated transfer)",
            upload_messages(&blob_b, counter, good_mac, chunks - 1),
            UploadError::Incomplete,
        ),
        (
            "a truncated blob, signed",
            signed(&cut, counter),
            UploadError::LengthMismatch,
        ),
        (
            "a bad CRC inside a signed blob",
            signed(&bad_crc, counter),
            UploadError::Blob(BlobError::BadCrc),
        ),
    ];
    let n = 2000;
    let input = ride(n);
    let mut script = Vec::new();
    for (_, messages, _) in &cases {
        script.extend(messages.iter().cloned());
    }
    script.extend(sample_messages(0, &input));
    script.push(Outgoing::Message(HostToDevice::Hello));
    let s = run(&region_a(), script);
    let answers = acks(&s);
    println!("answers {answers:?}\nstatus {:?}", s.status());

    // Each case ends in one refusal, the one expected; replayed is refused at begin, so
    // its chunks and commit find no upload open.
    let refusals: Vec<UploadError> = answers
        .iter()
        .filter_map(|a| a.err())
        .filter(|e| *e != UploadError::NotStarted)
        .collect();
    let expected: Vec<UploadError> = cases.iter().map(|(_, _, e)| *e).collect();
    for ((name, _, want), got) in cases.iter().zip(&refusals) {
        println!("{name}: {got} (code {})", got.code());
        assert_eq!(got, want, "{name}");
    }
    assert_eq!(refusals, expected);
    assert!(committed(&s).is_empty(), "something was committed");
    let not_started = answers
        .iter()
        .filter(|a| **a == Err(UploadError::NotStarted))
        .count();
    assert_eq!(not_started, chunks + 1, "the replay's chunks and commit");
    assert_eq!(
        s.status().uploads_rejected as usize,
        expected.len() + not_started
    );

    // Nothing changed: still A from slot A, and the telemetry is A's from sample 0.
    assert_eq!(
        s.greetings.len(),
        2,
        "the boot greeting and the Hello answer"
    );
    for g in &s.greetings {
        assert_eq!(g.params_identity, a.identity);
        assert_eq!(g.params_source, ParamsSource::Flash { slot: 0 });
    }
    let indices: Vec<u32> = (0..n as u32).collect();
    let host_a = reference::pipeline(&a, &indices, &input);
    assert_eq!(s.telemetry, host_a.telemetry, "telemetry is not A's");
}

/// A running QEMU with the monitor and a connected protocol link.
struct Device {
    qemu: Qemu,
    reader: FrameReader<std::os::unix::net::UnixStream>,
    writer: FrameWriter<std::os::unix::net::UnixStream>,
}

impl Device {
    /// Boots the monitor with `region` as the PARAMS region's contents; returns its greeting.
    fn boot(region: &Path) -> (Self, Greeting) {
        Self::boot_image(QemuConfig::new(firmware(PRODUCT_BINARY)), region)
    }

    /// Boots `config`'s image with `region` as the PARAMS region's contents.
    fn boot_image(config: QemuConfig, region: &Path) -> (Self, Greeting) {
        let config = config
            .uart()
            .monitor()
            .params_blob(region)
            .timeout(Duration::from_secs(120));
        let mut qemu = Qemu::start(&config).unwrap_or_else(|e| panic!("{e}"));
        let uart = qemu.uart().expect("a UART");
        uart.set_read_timeout(Some(Duration::from_millis(50)))
            .expect("timeout");
        let reader = FrameReader::new(uart.try_clone().expect("clone"));
        let writer = FrameWriter::new(uart.try_clone().expect("clone"));
        let mut device = Self {
            qemu,
            reader,
            writer,
        };
        let greeting = device
            .reader
            .greeting(STEP)
            .unwrap_or_else(|e| panic!("{e}"));
        (device, greeting)
    }

    /// Sends `message` and returns the upload answer that follows.
    fn step(&mut self, message: &HostToDevice) -> Result<ParamAck, UploadError> {
        self.step_within(message, STEP)
            .unwrap_or_else(|| panic!("no answer to {message:?}"))
    }

    /// Sends `message` and returns the upload answer that follows within `wait`, if any.
    fn step_within(
        &mut self,
        message: &HostToDevice,
        wait: Duration,
    ) -> Option<Result<ParamAck, UploadError>> {
        self.writer.send(message).expect("send");
        self.writer.flush().expect("flush");
        let deadline = std::time::Instant::now() + wait;
        loop {
            match self.reader.next_before(deadline).expect("link") {
                Some(DeviceToHost::ParamAck(a)) => return Some(Ok(a)),
                Some(DeviceToHost::ParamNack(e)) => return Some(Err(e)),
                Some(_) => {}
                None => return None,
            }
        }
    }

    /// Power cut: stops the CPU, keeps the PARAMS region (flash) in `out`, ends QEMU.
    fn cut_power(mut self, out: &Path) {
        self.qemu.monitor("stop").unwrap_or_else(|e| panic!("{e}"));
        self.qemu
            .save_memory(PARAMS_ADDR, REGION_LEN, out)
            .unwrap_or_else(|e| panic!("{e}"));
        self.qemu.stop().expect("QEMU ends");
    }
}

#[test]
fn a_cut_mid_upload_boots_the_last_good_parameters_and_a_good_upload_survives_a_reset() {
    let (a, _) = params_and_blob(Preset::PaperLitter);
    let (b, blob_b) = params_and_blob(Preset::PaperRigid);
    let dir = tempfile::tempdir().expect("temp dir");
    let flash0 = dir.path().join("flash0.bin");
    std::fs::write(&flash0, region_a()).expect("region");

    // Boot 1: A. Half of B's upload arrives, then the power fails.
    let (mut device, greeting) = Device::boot(&flash0);
    assert_eq!(greeting.params_identity, a.identity);
    let counter = 3_000;
    let mac = update_mac(&key(), counter, &blob_b);
    let messages = upload_messages(&blob_b, counter, mac, blob_b.len() / PARAM_CHUNK_LEN / 2);
    for m in &messages[..messages.len() - 1] {
        let Outgoing::Message(m) = m else {
            unreachable!()
        };
        assert!(device.step(m).is_ok(), "{m:?}");
    }
    let flash1 = dir.path().join("flash1.bin");
    device.cut_power(&flash1);
    assert_eq!(
        std::fs::read(&flash1).expect("read"),
        std::fs::read(&flash0).expect("read"),
        "a cut transfer must leave flash untouched"
    );

    // Boot 2: the last good parameters, A from slot A. The whole upload now succeeds.
    let (mut device, greeting) = Device::boot(&flash1);
    assert_eq!(
        (greeting.params_identity, greeting.params_source),
        (a.identity, ParamsSource::Flash { slot: 0 })
    );
    let outcome = flash::upload_over_link(
        &mut device.reader,
        &mut device.writer,
        &b,
        &blob_b,
        &key(),
        counter,
        STEP,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(outcome.uploaded.slot, 1);
    assert_eq!(outcome.greeting.params_identity, b.identity);

    let flash2 = dir.path().join("flash2.bin");
    device.cut_power(&flash2);

    // Boot 3: B from slot B, and its counter holds: the same upload is now a replay.
    let (mut device, greeting) = Device::boot(&flash2);
    assert_eq!(
        (greeting.params_identity, greeting.params_source),
        (b.identity, ParamsSource::Flash { slot: 1 })
    );
    let begin = &signed(&blob_b, counter)[0];
    let Outgoing::Message(begin) = begin else {
        unreachable!()
    };
    assert_eq!(device.step(begin), Err(UploadError::Replayed));
    drop(device);

    // Why a reset in the same QEMU is no power cut: after a good upload from the flash
    // image with A only, `system_reset` copies that image in again and the device boots A.
    let (mut device, _) = Device::boot(&flash1);
    flash::upload_over_link(
        &mut device.reader,
        &mut device.writer,
        &b,
        &blob_b,
        &key(),
        counter,
        STEP,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    device.qemu.monitor("system_reset").expect("reset");
    let after_reset = device.reader.greeting(STEP).expect("greets after reset");
    println!("after system_reset: {:?}", after_reset.params_source);
    assert_eq!(after_reset.params_identity, a.identity);
}

/// The region in which slot A holds A (counter 1) and slot B holds B (counter 2): the
/// device runs B.
fn region_a_then_b() -> Vec<u8> {
    let (_, blob_b) = params_and_blob(Preset::PaperRigid);
    let mut region = region_a();
    let slot_b = supine_core::upload::SLOT_LEN;
    region[slot_b..slot_b + blob_b.len()].copy_from_slice(&blob_b);
    let record = supine_core::upload::commit_record(&blob_b, REGION_IMAGE_COUNTER + 1);
    let at = slot_b + blob_b.len();
    region[at..at + record.len()].copy_from_slice(&record);
    region
}

/// Sends every message of an upload; returns the answer to the last one (the commit).
fn answer_to_upload(device: &mut Device, messages: &[Outgoing]) -> Result<ParamAck, UploadError> {
    let mut last = None;
    for m in messages {
        let Outgoing::Message(m) = m else {
            unreachable!()
        };
        last = Some(device.step(m));
    }
    last.expect("an upload has messages")
}

#[test]
fn an_upload_whose_length_differs_from_its_header_is_refused_before_flash_from_every_state() {
    // D3: a correctly signed valid blob followed by padding (and a blob cut short) used to
    // pass decoding; the device wrote the idle slot, failed the read-back and answered
    // "flash", and from the built-in parameters the next boot ran the refused blob.
    let (a, blob_a) = params_and_blob(Preset::PaperLitter);
    let (b, blob_b) = params_and_blob(Preset::PaperRigid);
    let builtin = ParamsSource::BuiltInDefault {
        reason: BlobError::Empty,
    };
    let states: Vec<(&str, Vec<u8>, ParamsSource, &[u8])> = vec![
        (
            "slot A",
            region_a(),
            ParamsSource::Flash { slot: 0 },
            &blob_b,
        ),
        (
            "slot B",
            region_a_then_b(),
            ParamsSource::Flash { slot: 1 },
            &blob_a,
        ),
        ("built-in", vec![0xFF; REGION_LEN], builtin, &blob_b),
    ];
    let dir = tempfile::tempdir().expect("temp dir");
    for (name, region, source, upload) in states {
        let before = dir.path().join("before.bin");
        std::fs::write(&before, &region).expect("write");
        let (mut device, greeting) = Device::boot(&before);
        assert_eq!(greeting.params_source, source, "{name}");
        // Padded up to at most 300 bytes, and within the largest blob the device takes
        // (beyond it the begin itself is refused, with another code).
        let pad = 300.min(supine_core::blob::MAX_BLOB_LEN - upload.len());
        assert!(pad > 0, "a blob of {} bytes leaves no room", upload.len());
        let mut padded = upload.to_vec();
        padded.extend(std::iter::repeat_n(0u8, pad));
        let cut = &upload[..upload.len() - 100];
        for (what, blob) in [("padded", &padded[..]), ("cut short", cut)] {
            assert_eq!(
                answer_to_upload(&mut device, &signed(blob, 7_000)),
                Err(UploadError::LengthMismatch),
                "{name}, {what}"
            );
        }
        let after = dir.path().join("after.bin");
        device.cut_power(&after);
        assert!(
            std::fs::read(&after).expect("read") == region,
            "{name}: flash touched"
        );
        let (_, rebooted) = Device::boot(&after);
        println!("{name}: boots {:?} again", rebooted.params_source);
        assert_eq!(
            (rebooted.params_identity, rebooted.params_source),
            (greeting.params_identity, greeting.params_source),
            "{name}"
        );
    }
    assert_ne!(a.identity, b.identity);
}

#[test]
fn a_cut_while_the_new_slot_is_written_boots_the_running_slot() {
    // The device erases the slot not running, writes the payload, the commit record and
    // the header last. Power lost anywhere before the header is complete leaves that slot
    // without a valid blob; these states, and the ones of the older order (blob first,
    // then the record) that a programmer may leave, are booted for real.
    let (a, blob_a) = params_and_blob(Preset::PaperLitter);
    let (_, blob_b) = params_and_blob(Preset::PaperRigid);
    let region = region_a();
    let slot_b = supine_core::upload::SLOT_LEN;
    let record = supine_core::upload::commit_record(&blob_b, 5_000);
    let dir = tempfile::tempdir().expect("temp dir");
    let states: Vec<(&str, Vec<u8>)> = vec![
        ("slot B erased", region.clone()),
        ("the payload and record without the header", {
            let mut r = region.clone();
            let h = supine_core::blob::BLOB_HEADER_LEN;
            r[slot_b + h..slot_b + blob_b.len()].copy_from_slice(&blob_b[h..]);
            let at = slot_b + blob_b.len();
            r[at..at + record.len()].copy_from_slice(&record);
            r
        }),
        ("half the blob written", {
            let mut r = region.clone();
            let half = blob_b.len() / 2;
            r[slot_b..slot_b + half].copy_from_slice(&blob_b[..half]);
            r
        }),
        ("the blob without its record", {
            let mut r = region.clone();
            r[slot_b..slot_b + blob_b.len()].copy_from_slice(&blob_b);
            r
        }),
        ("the record cut after its counter", {
            let mut r = region.clone();
            r[slot_b..slot_b + blob_b.len()].copy_from_slice(&blob_b);
            let at = slot_b + blob_b.len();
            r[at..at + 8].copy_from_slice(&record[..8]);
            r
        }),
    ];
    for (name, state) in states {
        let path = dir.path().join("flash.bin");
        std::fs::write(&path, &state).expect("write");
        let (device, greeting) = Device::boot(&path);
        drop(device);
        println!("{name}: {:?}", greeting.params_source);
        assert_eq!(
            (greeting.params_identity, greeting.params_source),
            (a.identity, ParamsSource::Flash { slot: 0 }),
            "{name}"
        );
    }
    // And with the whole record, slot B wins: the states above differ only in the cut.
    let mut whole = region;
    whole[slot_b..slot_b + blob_b.len()].copy_from_slice(&blob_b);
    let at = slot_b + blob_b.len();
    whole[at..at + record.len()].copy_from_slice(&record);
    let path = dir.path().join("whole.bin");
    std::fs::write(&path, &whole).expect("write");
    let (_device, greeting) = Device::boot(&path);
    assert_eq!(greeting.params_source, ParamsSource::Flash { slot: 1 });
    assert_ne!(blob_a, blob_b);
}

/// The `supine` binary of this test's target dir, built (or found up to date) first.
fn supine() -> std::process::Command {
    std::process::Command::new(supine_qemu_tests::supine_binary())
}

#[test]
fn supine_flash_writes_a_bootable_qemu_image_uploads_into_qemu_and_explains_failures() {
    let dir = tempfile::tempdir().expect("temp dir");
    let rigid = ParamFile::preset(Preset::PaperRigid);
    let rigid_id = supine_host::device::device_params::identity(&rigid).expect("identity");
    let rigid_hex = supine_host::device::device_params::identity_hex(&rigid_id);

    // --qemu-image: the device boots it from slot A at the rate asked for.
    let image = dir.path().join("params.bin");
    let (ok, stdout, stderr) = run_to_end(
        supine()
            .args([
                "flash",
                "--preset",
                "paper-rigid",
                "--fs",
                "400",
                "--qemu-image",
            ])
            .arg(&image),
    );
    assert!(ok, "{stderr}");
    assert!(stdout.contains(&rigid_hex), "{stdout}");
    let (device, greeting) = Device::boot(&image);
    drop(device);
    assert_eq!(greeting.params_identity, rigid_id);
    assert_eq!(greeting.params_source, ParamsSource::Flash { slot: 0 });
    assert_eq!(greeting.sample_rate_hz, 400.0);

    // --qemu: uploaded into a running device (built-in parameters, so slot A).
    let (ok, stdout, stderr) =
        run_to_end(supine().args(["flash", "--preset", "paper-rigid", "--qemu"]));
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!("parameters {rigid_hex} committed to slot 0")),
        "{stdout}"
    );
    assert!(stderr.contains("public development key"), "{stderr}");

    assert!(stdout.contains("patient 1.82 m, 81 kg"), "{stdout}");

    // --json, for a 1.6 m, 52 kg patient: one object on stdout saying what the device
    // acknowledged, and the patient it greets with after the commit.
    let (ok, stdout, stderr) = run_to_end(supine().args([
        "flash",
        "--preset",
        "paper-rigid",
        "--height-m",
        "1.6",
        "--mass-kg",
        "52",
        "--qemu",
        "--json",
    ]));
    assert!(ok, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let mut patient = rigid.clone();
    patient.params.subject = Subject {
        height_m: 1.6,
        mass_kg: 52.0,
    };
    let patient_id = supine_host::device::device_params::identity(&patient).expect("identity");
    assert_eq!(report["target"], "qemu");
    assert_eq!(
        report["params_identity"],
        supine_host::device::device_params::identity_hex(&patient_id).as_str()
    );
    assert_eq!(report["greeting_subject"]["height_m"], 1.6);
    assert_eq!(report["greeting_subject"]["mass_kg"], 52.0);
    assert_eq!(report["slot"], 0);
    assert_eq!(report["greeting_sample_rate_hz"], 500.0);
    assert_eq!(report["development_key"], true);
    let problems = supine_host::schema::names::json_problems(&report, "flash");
    assert!(problems.is_empty(), "{}", problems.join("\n"));

    // The wrong key: the device's code, on one line, and a failing status.
    let wrong = dir.path().join("wrong.key");
    std::fs::write(&wrong, "11".repeat(KEY_LEN)).expect("key");
    let (ok, _, stderr) = run_to_end(
        supine()
            .args(["flash", "--preset", "paper-rigid", "--qemu", "--key"])
            .arg(&wrong),
    );
    assert!(!ok);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("HMAC does not match (code 6)"), "{stderr}");

    // A key file that is not a key names the file and what it should hold.
    let short = dir.path().join("short.key");
    std::fs::write(&short, "abcd\n").expect("key");
    let (ok, _, stderr) = run_to_end(
        supine()
            .args(["flash", "--preset", "paper-rigid", "--qemu", "--key"])
            .arg(&short),
    );
    assert!(!ok);
    assert!(
        stderr.contains("short.key") && stderr.contains("64 hexadecimal digits"),
        "{stderr}"
    );

    // A bad rate: named, and no image left behind.
    let bad = dir.path().join("bad.bin");
    let (ok, _, stderr) = run_to_end(
        supine()
            .args([
                "flash",
                "--preset",
                "paper-rigid",
                "--fs",
                "0",
                "--qemu-image",
            ])
            .arg(&bad),
    );
    assert!(!ok);
    assert!(stderr.contains("--fs"), "{stderr}");
    assert!(!bad.exists());

    // No probe-rs on the PATH: how to install it.
    let (ok, _, stderr) = run_to_end(
        supine()
            .args([
                "flash",
                "--preset",
                "paper-rigid",
                "--probe",
                "STM32F411CEUx",
            ])
            .env("PATH", dir.path()),
    );
    assert!(!ok);
    assert!(stderr.contains("cargo install probe-rs-tools"), "{stderr}");
}

/// Boots the `power_cut` image (the monitor whose power fails after `budget_bytes` of
/// flash erasing and programming) on the flash in `region`, uploads `blob` signed with
/// `counter`, and keeps the flash in `out` once the power is gone (or, with budget to
/// spare, after the commit). Returns whether the device acknowledged the commit.
fn upload_with_power_cut(
    region: &Path,
    budget_bytes: usize,
    blob: &[u8],
    counter: u32,
    out: &Path,
) -> bool {
    let config = QemuConfig::new(firmware("power_cut"))
        .semihosting_arg("power_cut")
        .semihosting_arg(budget_bytes.to_string());
    let (mut device, _) = Device::boot_image(config, region);
    let messages = signed(blob, counter);
    let (commit, transfer) = messages.split_last().expect("messages");
    for m in transfer {
        let Outgoing::Message(m) = m else {
            unreachable!()
        };
        assert!(device.step(m).is_ok(), "{m:?}");
    }
    let Outgoing::Message(commit) = commit else {
        unreachable!()
    };
    // Erasing and writing a slot takes the device milliseconds; a cut device never answers.
    let answer = device.step_within(commit, Duration::from_secs(2));
    device.cut_power(out);
    match answer {
        None => false,
        Some(Ok(ParamAck::Committed { .. })) => true,
        Some(other) => panic!("unexpected answer to the commit: {other:?}"),
    }
}

/// What the product image boots from the flash in `region`.
fn boots(region: &Path) -> (supine_core::protocol::ParamsIdentity, ParamsSource) {
    let (device, greeting) = Device::boot(region);
    drop(device);
    (greeting.params_identity, greeting.params_source)
}

#[test]
fn power_cuts_during_the_device_own_flash_update_boot_the_last_committed_slot() {
    use supine_core::upload::{COMMIT_LEN, SLOT_LEN};
    let (a, _) = params_and_blob(Preset::PaperLitter);
    let (b, blob_b) = params_and_blob(Preset::PaperRigid);
    // C: the litter preset with telemetry every other sample, another identity.
    let mut file_c = file(Preset::PaperLitter);
    if let Some(d) = file_c.device.as_mut() {
        d.telemetry_decimation = Some(2);
    }
    let (c, blob_c) = flash::device_blob(&file_c, FS_HZ).expect("blob builds");
    assert_ne!(c.identity, a.identity);

    let dir = tempfile::tempdir().expect("temp dir");
    let flash0 = dir.path().join("flash0.bin");
    std::fs::write(&flash0, region_a()).expect("region");
    let original = std::fs::read(&flash0).expect("read");
    let cut = dir.path().join("cut.bin");
    let slot = |image: &[u8], i: usize| image[i * SLOT_LEN..(i + 1) * SLOT_LEN].to_vec();

    // Running A (slot A, counter 1): B goes to slot B, payload first, then the commit
    // record, then the header. Every cut before the header's last byte boots A again.
    let need_b = SLOT_LEN + blob_b.len() + COMMIT_LEN;
    let header = supine_core::blob::BLOB_HEADER_LEN;
    for (name, budget) in [
        ("while erasing slot B", 10_000),
        ("halfway through the payload", SLOT_LEN + blob_b.len() / 2),
        ("in the commit record", SLOT_LEN + blob_b.len() - header + 6),
        (
            "in the header",
            SLOT_LEN + blob_b.len() + COMMIT_LEN - header + 8,
        ),
        ("one byte short", need_b - 1),
    ] {
        assert!(
            !upload_with_power_cut(&flash0, budget, &blob_b, 100, &cut),
            "{name}"
        );
        let saved = std::fs::read(&cut).expect("read");
        assert_eq!(
            slot(&saved, 0),
            slot(&original, 0),
            "{name}: slot A touched"
        );
        if budget > SLOT_LEN {
            assert_ne!(
                slot(&saved, 1),
                slot(&original, 1),
                "{name}: nothing written"
            );
        }
        println!("cut {name} ({budget} B): boots {:?}", boots(&cut).1);
        assert_eq!(
            boots(&cut),
            (a.identity, ParamsSource::Flash { slot: 0 }),
            "{name}"
        );
    }
    let flash_b = dir.path().join("flash_b.bin");
    assert!(upload_with_power_cut(
        &flash0, need_b, &blob_b, 100, &flash_b
    ));
    assert_eq!(
        boots(&flash_b),
        (b.identity, ParamsSource::Flash { slot: 1 })
    );

    // Running B (slot B, counter 100): C goes to slot A, whose erase destroys A. A cut
    // there leaves A unusable and B in charge.
    let need_c = SLOT_LEN + blob_c.len() + COMMIT_LEN;
    for (name, budget) in [
        ("while erasing slot A", 1_000),
        ("halfway through the payload", SLOT_LEN + blob_c.len() / 2),
        ("one byte short", need_c - 1),
    ] {
        assert!(
            !upload_with_power_cut(&flash_b, budget, &blob_c, 200, &cut),
            "{name}"
        );
        let saved = std::fs::read(&cut).expect("read");
        assert!(
            DeviceParams::decode(&slot(&saved, 0)).is_err() || budget == need_c - 1,
            "{name}: slot A should be damaged"
        );
        println!("cut {name} ({budget} B): boots {:?}", boots(&cut).1);
        assert_eq!(
            boots(&cut),
            (b.identity, ParamsSource::Flash { slot: 1 }),
            "{name}"
        );
    }
    let flash_c = dir.path().join("flash_c.bin");
    assert!(upload_with_power_cut(
        &flash_b, need_c, &blob_c, 200, &flash_c
    ));
    assert_eq!(
        boots(&flash_c),
        (c.identity, ParamsSource::Flash { slot: 0 })
    );

    // Running the built-in parameters: B goes to slot A, whose blob boot takes even
    // without a commit record. Before the header is whole nothing there may look valid.
    let blank = dir.path().join("blank.bin");
    std::fs::write(&blank, vec![0xFF; REGION_LEN]).expect("region");
    for (name, budget) in [
        (
            "before the header",
            SLOT_LEN + blob_b.len() + COMMIT_LEN - header,
        ),
        ("one byte short", need_b - 1),
    ] {
        assert!(
            !upload_with_power_cut(&blank, budget, &blob_b, 300, &cut),
            "{name}"
        );
        let (_, source) = boots(&cut);
        println!("cut from the built-in parameters {name} ({budget} B): boots {source:?}");
        assert!(
            matches!(source, ParamsSource::BuiltInDefault { .. }),
            "{name}: boots {source:?}"
        );
    }
}

/// `supine flash --qemu` blocks on the device's answers rather than polling: SIGTERM must
/// still stop QEMU and remove its socket folder. The guest is never started (`-S`), so
/// the command is certainly still waiting for the greeting when the signal arrives.
#[test]
fn sigterm_during_supine_flash_qemu_leaves_no_qemu_and_no_socket_folder() {
    use supine_qemu_tests::{
        entries, qemu_processes_mentioning, signal_and_wait, wait_for_qemu_child,
    };
    supine_qemu_tests::firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).expect("private TMPDIR");
    let paused = supine_qemu_tests::qemu_wrapper(
        dir.path(),
        "paused-qemu",
        "exec qemu-system-arm -S \"$@\"",
    );
    let child = supine()
        .args([
            "flash",
            "--preset",
            "paper-rigid",
            "--qemu",
            "--timeout-s",
            "60",
        ])
        .env("TMPDIR", &tmp)
        .env(supine_host::device::qemu::QEMU_ENV, &paused)
        .env(supine_host::device::flash::STATE_DIR_ENV, dir.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("supine runs");
    wait_for_qemu_child(child.id());
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(qemu_processes_mentioning(&tmp).len(), 1);
    let signalled = std::time::Instant::now();
    let output = signal_and_wait(child, "TERM");
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stderr}");
    assert!(
        signalled.elapsed() < Duration::from_secs(10),
        "took {:?} to stop",
        signalled.elapsed()
    );
    assert!(!output.status.success());
    // No --key: the tool says it signs with the public development key, then the error.
    assert_eq!(
        stderr.trim().lines().collect::<Vec<_>>(),
        [
            supine_host::device::image::DEVELOPMENT_KEY_NOTICE,
            "supine: interrupted: QEMU stopped and its folder removed"
        ]
    );
    assert_eq!(qemu_processes_mentioning(&tmp), Vec::<u32>::new());
    assert_eq!(entries(&tmp), Vec::<String>::new());
}
