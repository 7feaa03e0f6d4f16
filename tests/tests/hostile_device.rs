//! A sample of the hostile-input suite on the device image in QEMU: garbage on the UART,
//! upload steps out of order or out of bounds, and damaged blobs at boot. The exhaustive
//! sweeps run on the host through the same code (`firmware/app/tests/hostile_*.rs`,
//! `shared/tests/hostile_blob.rs`); these check that the image behaves as those say.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use supine_core::blob::{BLOB_HEADER_LEN, DeviceParams};
use supine_core::model::Preset;
use supine_core::protocol::golden::BLOB;
use supine_core::protocol::{
    DeviceToHost, FrameAccumulator, FrameEvent, HostToDevice, MAX_FRAME_LEN, MAX_SAMPLES_PER_FRAME,
    PARAM_CHUNK_LEN, ParamAck, ParamBegin, ParamChunk, ParamsSource, SampleBatch, Telemetry,
    UploadError, encode_frame,
};
use supine_core::upload::update_mac;
use supine_host::device::firmware::PRODUCT_BINARY;
use supine_host::device::flash;
use supine_host::device::replay::{Outgoing, Session, SessionConfig, session};
use supine_host::exposure::reference;
use supine_host::io::params_file::ParamFile;
use supine_qemu_tests::firmware;

fn run(blob: Option<Vec<u8>>, script: Vec<Outgoing>) -> Session {
    let config = SessionConfig {
        kernel: firmware(PRODUCT_BINARY),
        blob,
        icount: false,
        timeout: Duration::from_secs(120),
    };
    session(&config, script, &Arc::new(AtomicBool::new(false))).unwrap_or_else(|e| panic!("{e:#}"))
}

fn framed(message: &HostToDevice) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode_frame(message, &mut buf)
        .expect("every message fits")
        .to_vec()
}

/// The longest index gap counted as lost, in seconds of samples, as `docs/protocol.md`
/// (Session) states it.
const MAX_LOST_SPAN_S: f32 = 60.0;

/// Axis values a sensor never reports.
const HOSTILE_VALUES: [f32; 6] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30, 0.0];

fn samples_frame(rng: &mut ChaCha8Rng, first: u32, hostile: bool) -> Vec<u8> {
    let samples: Vec<[f32; 3]> = (0..MAX_SAMPLES_PER_FRAME)
        .map(|_| {
            [0; 3].map(|_| {
                if hostile && rng.random_bool(0.3) {
                    HOSTILE_VALUES[rng.random_range(0..HOSTILE_VALUES.len())]
                } else {
                    rng.random_range(-20.0..20.0)
                }
            })
        })
        .collect();
    framed(&HostToDevice::Samples(SampleBatch {
        first_sample_index: first,
        accel_m_s2: samples.as_slice().try_into().expect("fits"),
    }))
}

/// Burst `k` of garbage, of kind `k % 7`; `next` is the index a host would send next.
fn garbage(rng: &mut ChaCha8Rng, k: usize, next: &mut u32) -> Vec<u8> {
    match k % 7 {
        0 => (0..rng.random_range(1..500))
            .map(|_| rng.random())
            .collect(),
        1 => vec![0; rng.random_range(1..1000)],
        2 => {
            let mut b: Vec<u8> = (0..rng.random_range(300..900))
                .map(|_| rng.random_range(1..=255u8))
                .collect();
            b.push(0);
            b
        }
        3 => {
            // A tag no message has; COBS of a zero-free body under 254 bytes.
            let mut body = vec![rng.random_range(6..=255u8)];
            body.extend((0..rng.random_range(0..30)).map(|_| rng.random_range(1..=255u8)));
            let mut b = vec![body.len() as u8 + 1];
            b.extend(body);
            b.push(0);
            b
        }
        4 => {
            let b = samples_frame(rng, *next, true);
            *next = next.wrapping_add(MAX_SAMPLES_PER_FRAME as u32);
            b
        }
        5 => {
            let first = match rng.random_range(0..3) {
                0 => next.wrapping_add(rng.random_range(1..50)),
                1 => next.wrapping_add(1 << 31),
                _ => rng.random(),
            };
            *next = first.wrapping_add(MAX_SAMPLES_PER_FRAME as u32);
            samples_frame(rng, first, false)
        }
        _ => {
            let mut b = Vec::new();
            for _ in 0..20 {
                b.extend(samples_frame(rng, *next, false));
                *next = next.wrapping_add(MAX_SAMPLES_PER_FRAME as u32);
            }
            b
        }
    }
}

/// What the host side reads from the bytes sent: frame counts and decodable samples.
#[derive(Default)]
struct Reading {
    frames: u32,
    bad_frames: u32,
    hellos: usize,
    uploads: usize,
    indices: Vec<u32>,
    samples: Vec<[f32; 3]>,
}

impl Reading {
    fn read(&mut self, acc: &mut FrameAccumulator, bytes: &[u8]) {
        for &b in bytes {
            match acc.push::<HostToDevice>(b) {
                FrameEvent::Pending => {}
                FrameEvent::Dropped(_) => self.bad_frames += 1,
                FrameEvent::Message(m) => {
                    self.frames += 1;
                    match m {
                        HostToDevice::Hello => self.hellos += 1,
                        HostToDevice::GetStatus => {}
                        HostToDevice::Samples(batch) => {
                            for (k, s) in batch.accel_m_s2.iter().enumerate() {
                                self.indices
                                    .push(batch.first_sample_index.wrapping_add(k as u32));
                                self.samples.push(*s);
                            }
                        }
                        _ => self.uploads += 1,
                    }
                }
            }
        }
    }

    /// Lost samples by the device's rule: forward gaps of up to a minute of samples.
    fn samples_dropped(&self, sample_rate_hz: f32) -> u32 {
        let max_lost = (sample_rate_hz * MAX_LOST_SPAN_S) as u32;
        self.indices
            .windows(2)
            .map(|p| p[1].wrapping_sub(p[0].wrapping_add(1)))
            .filter(|gap| *gap <= max_lost)
            .fold(0u32, |sum, gap| sum.saturating_add(gap))
    }
}

/// Every field of a record, floats by their bits, every NaN as one (the Cortex-M4's
/// default NaN and x86's differ in sign).
fn telemetry_bits(t: &Telemetry) -> String {
    let bits = |v: f32| if v.is_nan() { f32::NAN } else { v }.to_bits();
    format!(
        "{} {:?} {:?} {} {} {:?} {} {}",
        t.sample_index,
        t.head_acc_m_s2.map(bits),
        t.running_rms_m_s2.map(bits),
        bits(t.vector_running_rms_m_s2),
        bits(t.vdv_m_s175),
        t.alert_level,
        t.fault_flags,
        t.valid
    )
}

#[test]
fn uart_garbage_is_counted_and_the_image_keeps_answering_on_its_parameters() {
    let params = DeviceParams::decode(BLOB).expect("the golden blob");
    let mut rng = ChaCha8Rng::seed_from_u64(0x0017_DE71);
    let bursts = 70;
    let mut script = Vec::new();
    let mut acc = FrameAccumulator::new();
    let mut reading = Reading::default();
    let mut after_burst = Vec::new();
    let mut next = 0u32;
    for k in 0..bursts {
        let mut bytes = garbage(&mut rng, k, &mut next);
        bytes.push(0);
        reading.read(&mut acc, &bytes);
        script.push(Outgoing::Raw(bytes));
        // Sent as messages: the session ends at the status of the last `GetStatus` sent.
        for m in [HostToDevice::Hello, HostToDevice::GetStatus] {
            reading.read(&mut acc, &framed(&m));
            script.push(Outgoing::Message(m));
        }
        after_burst.push((
            reading.frames,
            reading.bad_frames,
            reading.samples.len() as u32,
            reading.samples_dropped(params.sample_rate_hz()),
        ));
    }
    let s = run(Some(BLOB.to_vec()), script);
    println!(
        "{bursts} bursts: {} good and {} bad frames, {} samples; status {:?}",
        reading.frames,
        reading.bad_frames,
        reading.samples.len(),
        s.status()
    );
    // One greeting at boot and one per Hello, all alike; a status per burst, and one for
    // the session's own closing GetStatus.
    assert_eq!(s.greetings.len(), 1 + reading.hellos);
    assert!(s.greetings.iter().all(|g| *g == s.greetings[0]));
    assert_eq!(
        s.greetings[0].params_source,
        ParamsSource::Flash { slot: 0 }
    );
    assert_eq!(s.statuses.len(), bursts + 1);
    for (k, (status, expected)) in s.statuses.iter().zip(&after_burst).enumerate() {
        let got = (
            status.frames_received,
            status.bad_frames,
            status.samples_processed,
            status.samples_dropped,
        );
        assert_eq!(got, *expected, "after burst {k}");
    }
    // Garbage that decoded as upload steps was answered, and nothing was committed.
    assert_eq!(s.other.len(), reading.uploads);
    assert!(
        !s.other
            .iter()
            .any(|m| matches!(m, DeviceToHost::ParamAck(ParamAck::Committed { .. })))
    );
    // Still the same parameters: the host's pipeline over the decodable samples.
    // Compared by bits: NaN samples (and, until D1 is fixed, 1e30 ones) put NaN in both.
    let host = reference::pipeline(&params, &reading.indices, &reading.samples);
    assert_eq!(s.telemetry.len(), host.telemetry.len());
    for (k, (d, h)) in s.telemetry.iter().zip(&host.telemetry).enumerate() {
        assert_eq!(telemetry_bits(d), telemetry_bits(h), "telemetry record {k}");
    }
    assert_eq!(s.events, host.events);
    assert_eq!(s.link.bad_frames + s.link.lost_frames, 0);
}

#[test]
fn upload_steps_out_of_order_or_bounds_are_refused_with_their_codes() {
    let file = ParamFile::preset(Preset::PaperRigid);
    let (_, blob) = flash::device_blob(&file, 500.0).expect("blob");
    let key = flash::load_key(None).expect("the development key");
    let begin = |bytes: &[u8], length: usize| {
        HostToDevice::ParamBegin(ParamBegin {
            length_bytes: length as u32,
            counter: 50,
            hmac_sha256: update_mac(&key, 50, bytes),
        })
    };
    let chunk = |k: usize| {
        let end = ((k + 1) * PARAM_CHUNK_LEN).min(blob.len());
        HostToDevice::ParamChunk(ParamChunk {
            offset_bytes: (k * PARAM_CHUNK_LEN) as u32,
            bytes: blob[k * PARAM_CHUNK_LEN..end].try_into().expect("fits"),
        })
    };
    let n = blob.len().div_ceil(PARAM_CHUNK_LEN);
    let received = |k: usize| {
        Ok(ParamAck::Received {
            bytes: ((k + 1) * PARAM_CHUNK_LEN).min(blob.len()) as u32,
        })
    };
    let mut steps: Vec<(HostToDevice, Result<ParamAck, UploadError>)> = vec![
        (chunk(0), Err(UploadError::NotStarted)),
        (HostToDevice::ParamCommit, Err(UploadError::NotStarted)),
        (begin(&blob, 0), Err(UploadError::BadLength)),
        (begin(&blob, 4097), Err(UploadError::BadLength)),
        // A skipped chunk, then a commit before everything arrived.
        (begin(&blob, blob.len()), Ok(ParamAck::Begun)),
        (chunk(0), received(0)),
        (chunk(2), Err(UploadError::OutOfOrder)),
        (HostToDevice::ParamCommit, Err(UploadError::Incomplete)),
        // One byte fewer announced than sent: the last chunk passes the end.
        (begin(&blob, blob.len() - 1), Ok(ParamAck::Begun)),
    ];
    steps.extend((0..n - 1).map(|k| (chunk(k), received(k))));
    steps.push((chunk(n - 1), Err(UploadError::ChunkPastEnd)));
    steps.push((HostToDevice::ParamCommit, Err(UploadError::NotStarted)));
    let script = steps
        .iter()
        .map(|(m, _)| Outgoing::Message(m.clone()))
        .collect();
    let s = run(Some(BLOB.to_vec()), script);
    let answers: Vec<_> = s
        .other
        .iter()
        .map(|m| match m {
            DeviceToHost::ParamAck(a) => Ok(*a),
            DeviceToHost::ParamNack(e) => Err(*e),
            other => panic!("{other:?}"),
        })
        .collect();
    let expected: Vec<_> = steps.iter().map(|(_, a)| *a).collect();
    println!("upload steps: {} sent, answers {answers:?}", steps.len());
    assert_eq!(answers, expected);
    let refusals = expected.iter().filter(|a| a.is_err()).count() as u32;
    assert_eq!(s.status().uploads_rejected, refusals);
    assert_eq!(s.greetings.len(), 1);
}

#[test]
fn a_sample_of_bit_flips_in_the_blob_boots_the_built_in_parameters_with_the_reason() {
    // The host sweep (`shared/tests/hostile_blob.rs`) refuses every one of the 9,120
    // flips; here a spread of them, in every header field and across the payload, boots.
    let header_bits = [0, 13, 37, 50, 67, 90, 101, 127];
    let payload_bits = (0..6).map(|k| BLOB_HEADER_LEN * 8 + 3 + k * (BLOB.len() - 17) * 8 / 6);
    for bit in header_bits.into_iter().chain(payload_bits) {
        let mut blob = BLOB.to_vec();
        blob[bit / 8] ^= 1 << (bit % 8);
        let reason = DeviceParams::decode(&blob).expect_err("a flipped blob is refused");
        let s = run(Some(blob), Vec::new());
        println!("bit {bit}: {:?}", s.greetings[0].params_source);
        assert_eq!(
            s.greetings[0].params_source,
            ParamsSource::BuiltInDefault { reason },
            "bit {bit}"
        );
    }
}

/// Replaces, in the telemetry CSV at `log`, the cell of `column` in the data row `row`
/// (from 0) with `value`.
fn edit_cell(log: &std::path::Path, row: usize, column: &str, value: &str) {
    let text = std::fs::read_to_string(log).expect("log");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let at = lines[0]
        .split(',')
        .position(|c| c == column)
        .unwrap_or_else(|| panic!("no column {column}"));
    let mut cells: Vec<String> = lines[row + 1].split(',').map(str::to_string).collect();
    cells[at] = value.to_string();
    lines[row + 1] = cells.join(",");
    std::fs::write(log, lines.join("\n") + "\n").expect("write");
}

#[test]
fn a_tampered_monitor_log_is_caught_by_the_device_check() {
    use supine_qemu_tests::{monitor_to_log, rough_ride, run_supine};
    firmware(PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let s = |p: &std::path::Path| p.to_str().expect("utf-8").to_owned();
    let ride = rough_ride(dir.path());
    let log = dir.path().join("log.csv");
    let (ok, _, stderr) = monitor_to_log(&ride, &log);
    assert!(ok, "monitor: {stderr}");
    let pristine = std::fs::read_to_string(&log).expect("log");
    let report = |out: &str| {
        run_supine(&[
            "report",
            "--input",
            &s(&log),
            "--preset",
            "paper-litter",
            "--json",
            "--out",
            &s(&dir.path().join(out)),
        ])
    };
    let (ok, stdout, stderr) = report("clean");
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
    assert_eq!(
        json["device_check"]["agree"], true,
        "{}",
        json["device_check"]
    );
    // Each value the device reports, changed in one record late in the ride: the check
    // says they differ and names what (the battery changed VDV, rms and level).
    let rows = pristine.lines().count() - 1;
    let (mut tried, mut held) = (0, 0);
    for (column, value, name) in [
        ("vdv_m_s175", "99", "vdv_m_s175"),
        ("vector_running_rms_m_s2", "3.5", "vector_running_rms_m_s2"),
        ("running_rms_z_m_s2", "2.5", "running_rms_z_m_s2"),
        // The rough ride ends at alarm (a VDV level never clears): a late record says normal.
        ("alert_level", "normal", "alert_level"),
    ] {
        std::fs::write(&log, &pristine).expect("restore");
        edit_cell(&log, rows - 10, column, value);
        let (ok, stdout, stderr) = report(column);
        tried += 1;
        let json: serde_json::Value = serde_json::from_str(&stdout).unwrap_or_default();
        let check = &json["device_check"];
        let caught = ok
            && check["agree"] == false
            && check["differing_values"]
                .as_array()
                .is_some_and(|d| d.iter().any(|v| v == name));
        println!(
            "tampered log | {column} = {value} | {} | {check}",
            if caught { "held" } else { "BROKE" }
        );
        held += usize::from(caught);
        assert!(caught, "{column}: {check} {stderr}");
        let page = std::fs::read_to_string(dir.path().join(column).join("report.html"))
            .expect("report.html");
        assert!(page.contains("the device and the host DIFFER") && page.contains(name));
    }
    // The session file's patient edited: refused, naming the file and the patient.
    std::fs::write(&log, &pristine).expect("restore");
    let session = dir.path().join("log.session.json");
    let text = std::fs::read_to_string(&session).expect("session");
    let mut value: serde_json::Value = serde_json::from_str(&text).expect("session JSON");
    for (height_m, mass_kg) in [(1.6, 52.0), (1e9, 81.0)] {
        value["height_m"] = serde_json::json!(height_m);
        value["mass_kg"] = serde_json::json!(mass_kg);
        std::fs::write(&session, value.to_string()).expect("write");
        let (ok, _, stderr) = report("patient");
        tried += 1;
        let caught = !ok
            && stderr.contains("log.session.json: patient")
            && stderr.trim().lines().count() == 1;
        println!(
            "tampered log | patient {height_m} m, {mass_kg} kg | {} | {}",
            if caught { "held" } else { "BROKE" },
            stderr.trim()
        );
        held += usize::from(caught);
        assert!(caught, "{stderr}");
    }
    println!("tampered monitor logs: tried {tried}, held {held}");
}
