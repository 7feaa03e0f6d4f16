//! The monitor image (`supine-firmware`) in QEMU against the host's reference: replayed
//! samples in, telemetry and alerts out, with the parameter blob, the link and the
//! pipeline's budget checked on the way.

use std::f64::consts::TAU;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use supine_core::alerts::{AlertConfig, AlertEvent, SensorCheckConfig, SensorFault};
use supine_core::blob::{BlobError, DeviceParams, Patient, TelemetryConfig};
use supine_core::exposure::ExposureConfig;
use supine_core::model::{ModelParams, Preset, device_model};
use supine_core::mounting::Mounting;
use supine_core::protocol::{
    FrameAccumulator, FrameEvent, HostToDevice, ParamBegin, ParamsSource, Status, Telemetry,
    UploadError, encode_frame,
};
use supine_core::sample_rate::SampleRate;
use supine_host::device::device_params;
use supine_host::device::firmware::PRODUCT_BINARY;
use supine_host::device::replay::{
    Outgoing, Session, SessionConfig, file_session, sample_messages, session,
};
use supine_host::exposure::reference;
use supine_host::io::params_file::{DeviceSection, ParamFile};
use supine_qemu_tests::{MONITOR_STACK_CEILING_BYTES, firmware};

/// Ceiling on the instructions per sample of the device's busy span (pipeline, telemetry
/// frame encoding and queueing) at 500 Hz with a frame for every sample: a regression
/// guard over the 2,336 measured with the default ten joint outputs (BENCHMARKS.md,
/// issue 16's third pass), with 6 % margin. The joints are read on every telemetry
/// sample, here every sample: about 790 instructions more than without them, so the
/// 1,450 of before issue 16 cannot hold in this debugging mode. The shipping budget,
/// 1,200 with telemetry every 5th sample, is `replay_cli.rs`'s.
const PIPELINE_CEILING_INSTRUCTIONS: f64 = 2480.0;

/// The litter preset with alert thresholds low enough for the test rides to cross them.
fn test_params_file() -> ParamFile {
    ParamFile {
        params: ModelParams::preset(Preset::PaperLitter),
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

/// A ride: a few sines per axis (1.5 to 9 Hz) under an envelope that rises, falls and
/// rises again, so exposure alerts are raised and cleared. Litter axes, m/s^2.
fn ride(sample_rate_hz: f64, samples: usize) -> Vec<[f32; 3]> {
    (0..samples)
        .map(|k| {
            let t = k as f64 / sample_rate_hz;
            let cycle = t % 60.0;
            let envelope = if cycle < 5.0 {
                0.05
            } else if cycle < 25.0 {
                1.0
            } else if cycle < 40.0 {
                0.02
            } else {
                0.5
            };
            let s = |f: f64, phase: f64| (TAU * f * t + phase).sin();
            [
                envelope * (0.4 * s(1.5, 0.0) + 0.2 * s(6.0, 1.0)),
                envelope * (0.3 * s(2.5, 0.5) + 0.1 * s(9.0, 2.0)),
                envelope * (1.2 * s(4.5, 0.3) + 0.5 * s(7.5, 1.7) + 0.3 * s(2.0, 0.9)),
            ]
            .map(|v| v as f32)
        })
        .collect()
}

/// How a test's script reaches the device: over UART0, or from a file read ahead of it
/// (`supine replay`'s route).
#[derive(Clone, Copy, PartialEq)]
enum Route {
    Uart,
    File,
}

fn run(blob: Option<Vec<u8>>, icount: bool, script: Vec<Outgoing>, timeout_s: u64) -> Session {
    run_via(Route::Uart, blob, icount, script, timeout_s)
}

fn run_via(
    route: Route,
    blob: Option<Vec<u8>>,
    icount: bool,
    script: Vec<Outgoing>,
    timeout_s: u64,
) -> Session {
    let config = SessionConfig {
        kernel: firmware(PRODUCT_BINARY),
        blob,
        icount,
        timeout: Duration::from_secs(timeout_s),
    };
    let stop = Arc::new(AtomicBool::new(false));
    match route {
        Route::Uart => session(&config, script, &stop),
        Route::File => file_session(&config, script, &stop),
    }
    .unwrap_or_else(|e| panic!("{e:#}"))
}

/// Largest difference of the device's head acceleration from `reference`'s at the same
/// sample, m/s^2.
fn max_abs_diff(device: &[Telemetry], reference: &[[f64; 3]]) -> f64 {
    device
        .iter()
        .flat_map(|t| {
            let r = reference[t.sample_index as usize];
            (0..3).map(move |i| (f64::from(t.head_acc_m_s2[i]) - r[i]).abs())
        })
        .fold(0.0, f64::max)
}

fn relative(a: f32, b: f32) -> f64 {
    let (a, b) = (f64::from(a), f64::from(b));
    (a - b).abs() / b.abs().max(1e-9)
}

/// Replays `seconds` of the test ride at `sample_rate_hz` over UART0 with a record per
/// sample and checks the device against the host: head within 1e-4 m/s^2 of f64, exposure
/// within 1e-3, identical events, no frame lost or reordered. Returns the session.
fn device_matches_host(sample_rate_hz: f64, seconds: f64, icount: bool) -> Session {
    device_matches_host_via(Route::Uart, 1, sample_rate_hz, seconds, icount)
}

/// As [`device_matches_host`], by `route`, with telemetry every `decimation`-th sample.
fn device_matches_host_via(
    route: Route,
    decimation: u16,
    sample_rate_hz: f64,
    seconds: f64,
    icount: bool,
) -> Session {
    let mut file = test_params_file();
    if let Some(device) = &mut file.device {
        device.telemetry_decimation = Some(decimation);
    }
    let params = device_params::build(&file, sample_rate_hz).expect("params build");
    let blob = device_params::encode(&params).expect("blob encodes");
    let n = (seconds * sample_rate_hz).round() as usize;
    let input = ride(sample_rate_hz, n);
    let indices: Vec<u32> = (0..n as u32).collect();
    let host = reference::pipeline(&params, &indices, &input);
    let head = reference::head_f64(&file.params, sample_rate_hz, &input).expect("f64 model");

    let s = run_via(
        route,
        Some(blob),
        icount,
        sample_messages(0, &input),
        120 + n as u64 / 500,
    );
    let status = s.status();
    println!(
        "{sample_rate_hz} Hz, {n} samples in {:.1} s ({:.0} samples/s): {:?}, link {:?}",
        s.elapsed.as_secs_f64(),
        n as f64 / s.elapsed.as_secs_f64(),
        status,
        s.link
    );
    assert_eq!(s.greetings.len(), 1);
    assert_eq!(
        s.greetings[0].params_source,
        ParamsSource::Flash { slot: 0 }
    );
    assert_eq!(s.greetings[0].params_identity, params.identity);
    assert_eq!(s.link.lost_frames, 0, "frames lost");
    assert_eq!(s.link.reordered_frames, 0, "frames reordered");
    assert_eq!(s.link.bad_frames, 0, "bad frames from the device");
    assert_eq!(status.samples_processed, n as u32);
    assert_eq!(status.samples_dropped, 0);
    assert_eq!(status.bad_frames, 0);
    let records = n.div_ceil(usize::from(decimation));
    assert_eq!(status.telemetry_sent, records as u32);
    assert_eq!(s.telemetry.len(), records);
    assert_eq!(host.telemetry.len(), records);
    let in_order = s
        .telemetry
        .iter()
        .zip(&host.telemetry)
        .all(|(d, h)| d.sample_index == h.sample_index);
    assert!(in_order, "telemetry out of sample order");

    let worst = max_abs_diff(&s.telemetry, &head);
    println!("head max abs vs f64: {worst:.3e} m/s^2");
    assert!(
        worst <= 1e-4,
        "head differs from the f64 model by {worst:e} m/s^2"
    );
    let mut worst_rel = 0.0f64;
    for (d, h) in s.telemetry.iter().zip(&host.telemetry) {
        for i in 0..3 {
            worst_rel = worst_rel.max(relative(d.running_rms_m_s2[i], h.running_rms_m_s2[i]));
        }
        worst_rel = worst_rel.max(relative(
            d.vector_running_rms_m_s2,
            h.vector_running_rms_m_s2,
        ));
        worst_rel = worst_rel.max(relative(d.vdv_m_s175, h.vdv_m_s175));
        assert_eq!(
            (d.alert_level, d.fault_flags, d.valid),
            (h.alert_level, h.fault_flags, h.valid)
        );
    }
    println!("exposure max relative vs host: {worst_rel:.3e}");
    assert!(
        worst_rel <= 1e-3,
        "exposure differs by {worst_rel:e} relative"
    );
    assert_eq!(s.events, host.events, "alert events differ");
    s
}

#[test]
fn device_matches_the_host_reference_over_60_s_at_500_hz_within_its_instruction_ceiling() {
    let s = device_matches_host(500.0, 60.0, true);
    let raised = s.events.iter().filter(|e| e.is_raise()).count();
    let cleared = s.events.len() - raised;
    println!("events: {:?}", s.events);
    assert!(
        raised >= 2 && cleared >= 1,
        "the ride must raise and clear alerts"
    );
    let ips = s.instructions_per_sample();
    let status = s.status();
    println!("instructions_per_sample: {ips:.0}");
    println!("stack_used_bytes: {}", status.stack_used_bytes);
    assert!(ips > 100.0, "the count looks wrong: {ips}");
    assert!(
        ips <= PIPELINE_CEILING_INSTRUCTIONS,
        "{ips:.0} instructions per sample"
    );
    assert!(status.stack_used_bytes > 0);
    assert!(
        status.stack_used_bytes <= MONITOR_STACK_CEILING_BYTES,
        "stack_used_bytes {}",
        status.stack_used_bytes
    );
}

#[test]
fn no_frame_is_lost_or_reordered_at_2_khz() {
    let s = device_matches_host(2000.0, 10.0, true);
    println!(
        "instructions_per_sample at 2 kHz: {:.0}",
        s.instructions_per_sample()
    );
}

/// One hour at 500 Hz (1.8 million samples) as `supine replay` sends it, with the shipping
/// telemetry rate (100 Hz): no drift from the host's reference, counters consistent, stack
/// constant. About 30 s on an idle machine (BENCHMARKS.md, replay throughput).
#[test]
fn one_hour_at_500_hz_does_not_drift() {
    let decimation = TelemetryConfig::default_for(500.0).decimation;
    // Memory constant: after the hour, the stack's high-water mark is the one a minute
    // leaves (the device has no heap; its statics are fixed at link time).
    let minute = device_matches_host_via(Route::File, decimation, 500.0, 60.0, false)
        .status()
        .stack_used_bytes;
    let s = device_matches_host_via(Route::File, decimation, 500.0, 3600.0, false);
    let hour = s.status().stack_used_bytes;
    println!("stack_used_bytes after a minute {minute}, after the hour {hour}");
    assert_eq!(hour, minute, "the stack grew over the hour");
    assert!(hour <= MONITOR_STACK_CEILING_BYTES);
    assert_eq!(s.statuses.len(), 1);
}

/// The built-in default as the firmware builds it (`firmware/build.rs`).
fn builtin_params() -> DeviceParams {
    let model = ModelParams::preset(Preset::PaperLitter);
    let (realization, joints) = device_model(&model, 500.0).expect("preset discretizes");
    DeviceParams::new(
        *b"builtin-litter\0\0",
        Patient::of(&model.subject),
        SampleRate::new(500.0).expect("supported"),
        realization,
        ExposureConfig::DEFAULT,
        AlertConfig::DEFAULT,
        SensorCheckConfig::DEFAULT,
        Mounting::LEVEL,
        TelemetryConfig::default_for(500.0),
        joints,
    )
    .expect("defaults valid")
}

/// Deterministic pseudo-random bytes (xorshift32).
fn garbage(seed: u32, n: usize) -> Vec<u8> {
    let mut x = seed;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 24) as u8
        })
        .collect()
}

fn framed(message: &HostToDevice) -> Vec<u8> {
    let mut buf = [0u8; 256];
    encode_frame(message, &mut buf).expect("encodes").to_vec()
}

#[test]
fn garbage_sensor_faults_and_uploads_are_counted_and_the_device_keeps_running() {
    let params = builtin_params();
    let fs = 500.0;
    let n = 5000usize;
    let mut input = ride(fs, n);
    input[1000][0] = f32::NAN;
    input[1001][2] = f32::INFINITY;
    input[1500][2] = 200.0; // above the 16 g full scale
    for x in &mut input[2000..2800] {
        *x = [0.01, -0.02, 0.03]; // stuck for 1.6 s
    }
    // Samples 3500..3510 are never sent: an index gap.
    let sent: Vec<(u32, [f32; 3])> = (0..n as u32)
        .zip(input.iter().copied())
        .filter(|(k, _)| !(3500..3510).contains(k))
        .collect();
    let (indices, samples): (Vec<u32>, Vec<[f32; 3]>) = sent.iter().copied().unzip();
    let host = reference::pipeline(&params, &indices, &samples);

    let mut script = vec![
        Outgoing::Raw(garbage(0x1234_5678, 2000)),
        Outgoing::Raw(vec![0]),
        Outgoing::Raw(vec![0x55; 600]), // oversize: no zero for 600 bytes
        Outgoing::Raw(vec![0]),
        Outgoing::Message(HostToDevice::ParamBegin(ParamBegin {
            length_bytes: 100,
            counter: 1,
            hmac_sha256: [0; 32],
        })),
        Outgoing::Message(HostToDevice::ParamCommit),
    ];
    script.extend(sample_messages(0, &samples[..3500]));
    script.push(Outgoing::Raw(garbage(0x0BAD_F00D, 300)));
    script.push(Outgoing::Raw(vec![0]));
    script.push(Outgoing::Message(HostToDevice::GetStatus));
    script.extend(sample_messages(3510, &samples[3500..]));
    script.push(Outgoing::Message(HostToDevice::Hello));

    // What the device should count: feed the same bytes through the same accumulator.
    let mut acc = FrameAccumulator::new();
    let (mut good, mut bad) = (0u32, 0u32);
    for item in &script {
        let bytes = match item {
            Outgoing::Message(m) => framed(m),
            Outgoing::Raw(b) => b.clone(),
        };
        for b in bytes {
            match acc.push::<HostToDevice>(b) {
                FrameEvent::Pending => {}
                FrameEvent::Message(_) => good += 1,
                FrameEvent::Dropped(_) => bad += 1,
            }
        }
    }
    let script_messages = script
        .iter()
        .filter(|o| matches!(o, Outgoing::Message(_)))
        .count() as u32;
    assert_eq!(
        good, script_messages,
        "garbage must not decode as a message here"
    );
    assert!(bad >= 3, "the garbage must contain bad frames");

    let s = run(None, false, script, 120);
    let status = s.status();
    println!(
        "status {status:?}, link {:?}, events {:?}",
        s.link, s.events
    );
    // Built-in default, because the PARAMS region is blank.
    assert_eq!(
        s.greetings[0].params_source,
        ParamsSource::BuiltInDefault {
            reason: BlobError::Empty
        }
    );
    assert_eq!(&s.greetings[0].params_identity, b"builtin-litter\0\0");
    assert_eq!(s.greetings.len(), 2, "a greeting at boot and one for Hello");
    assert_eq!(
        s.link.lost_frames + s.link.bad_frames + s.link.reordered_frames,
        0
    );
    // The begin opens an upload (its MAC is only checked at commit); the commit comes
    // before the announced 100 bytes and is refused.
    assert_eq!(
        s.other,
        vec![
            supine_core::protocol::DeviceToHost::ParamAck(supine_core::protocol::ParamAck::Begun),
            supine_core::protocol::DeviceToHost::ParamNack(UploadError::Incomplete),
        ]
    );
    assert_eq!(
        status,
        Status {
            frames_received: good + 1, // the final GetStatus
            bad_frames: bad,
            samples_processed: (n - 10) as u32,
            samples_dropped: 10,
            telemetry_sent: host.telemetry.len() as u32,
            uploads_rejected: 1,
            busy_ticks: status.busy_ticks,
            stack_used_bytes: status.stack_used_bytes,
            params_source: ParamsSource::BuiltInDefault {
                reason: BlobError::Empty
            },
            // The built-in default's patient: the paper's mean subject.
            height_m: 1.82,
            mass_kg: 81.0,
            // The built-in default reads all ten joint outputs.
            joint_running_rms: status.joint_running_rms,
            joint_largest_excursion: status.joint_largest_excursion,
            // The built-in default's: the datasheet's nominal values.
            calibration: supine_core::calibration::SensorCalibration::DATASHEET,
        }
    );
    assert_eq!(status.joint_running_rms.as_slice().len(), 10);
    assert_eq!(status.joint_largest_excursion.as_slice().len(), 10);
    assert_eq!(
        s.statuses[0].samples_processed, 3500,
        "status after the first part"
    );
    assert_eq!(
        s.telemetry, host.telemetry,
        "telemetry differs from the host's pipeline"
    );
    assert_eq!(
        s.events, host.events,
        "events differ from the host's pipeline"
    );
    for fault in [
        SensorFault::NonFinite,
        SensorFault::Saturated,
        SensorFault::Stuck,
        SensorFault::IndexGap,
    ] {
        let raised = s
            .events
            .iter()
            .any(|e| matches!(*e, AlertEvent::Fault { fault: f, active: true, .. } if f == fault));
        assert!(raised, "{fault} not raised");
    }
    // It kept running: telemetry (every 5th sample, the built-in default's 100 Hz) up to
    // the last samples arrived and is finite.
    let last = s.telemetry.last().expect("telemetry");
    let decimation = u32::from(params.telemetry.decimation);
    assert_eq!(decimation, 5);
    assert!(
        last.sample_index >= n as u32 - decimation,
        "{}",
        last.sample_index
    );
    assert!(last.head_acc_m_s2.iter().all(|v| v.is_finite()));
}

/// Where the device says its parameters came from, in its greeting and in its status.
fn source_for(blob: Option<Vec<u8>>) -> ParamsSource {
    // The session ends with a GetStatus, which the device answers.
    let s = run(blob, false, Vec::new(), 60);
    assert_eq!(s.greetings.len(), 1);
    let source = s.greetings[0].params_source;
    assert_eq!(s.statuses.len(), 1);
    assert_eq!(
        s.status().params_source,
        source,
        "status and greeting differ"
    );
    source
}

#[test]
fn a_corrupted_blob_in_flash_runs_the_default_and_names_the_reason() {
    let good = supine_core::protocol::golden::BLOB.to_vec();
    assert_eq!(
        source_for(Some(good.clone())),
        ParamsSource::Flash { slot: 0 }
    );

    let mut flipped = good.clone();
    flipped[40] ^= 0x04;
    let mut truncated = good.clone();
    truncated.truncate(good.len() / 2);
    let mut version = good.clone();
    version[4] = version[4].wrapping_add(1);
    let mut magic = good.clone();
    magic[0] = b'X';
    for (name, blob, reason) in [
        ("a flipped bit", flipped, BlobError::BadCrc),
        // The rest of the 64 KiB slot reads as erased: the payload's end is blank.
        ("a truncated blob", truncated, BlobError::Truncated),
        ("a wrong version", version, BlobError::UnsupportedVersion),
        ("a wrong magic", magic, BlobError::BadMagic),
    ] {
        let source = source_for(Some(blob));
        println!("{name}: {source:?}");
        assert_eq!(source, ParamsSource::BuiltInDefault { reason }, "{name}");
    }
    assert_eq!(
        source_for(None),
        ParamsSource::BuiltInDefault {
            reason: BlobError::Empty
        }
    );
}

#[test]
fn a_panic_resets_the_device_and_the_next_greeting_names_it() {
    let config = SessionConfig {
        kernel: firmware("panic_reset"),
        blob: None,
        icount: false,
        timeout: Duration::from_secs(60),
    };
    let s = session(&config, Vec::new(), &Arc::new(AtomicBool::new(false)))
        .unwrap_or_else(|e| panic!("{e:#}"));
    println!(
        "greetings {:?}\ndiagnostics {:?}",
        s.greetings, s.diagnostics
    );
    assert_eq!(s.greetings.len(), 1);
    let g = &s.greetings[0];
    assert_eq!(g.reset_cause, supine_core::protocol::ResetCause::Panic);
    assert_eq!(
        g.last_panic.as_str(),
        "deliberate panic before the first greeting"
    );
    assert!(
        s.diagnostics.contains("deliberate panic"),
        "{}",
        s.diagnostics
    );
}

/// Issue 16: a minute of a rough ride (`supine ride --profile rough-road`'s generator) by
/// the replay's file route at the shipping telemetry rate (every 5th sample): every
/// joint value the device reports is the host's f32 pipeline's, bit for bit, and within
/// 1e-6 of that output's peak of the f64 model at the same sample; with a joint-motion
/// threshold on every output (`[device.joint_alerts]`), the device's joint alerts are the
/// host pipeline's, bit for bit.
#[test]
fn the_devices_joint_outputs_match_the_f64_model_over_a_minute_of_a_rough_ride() {
    use supine_core::joint_exposure::packed_order;
    use supine_core::model::{JointOutput, JointUnit};
    use supine_host::demo::demo_ride::{DemoProfile, make};
    let fs = 500.0;
    let input = make(DemoProfile::RoughRoad, 60.0, fs, 7)
        .expect("a rough ride")
        .samples();
    let joints = reference::joints_f64(&ModelParams::preset(Preset::PaperLitter), fs, &input)
        .expect("f64 model");
    let mut peak = [0.0f64; 10];
    for y in &joints {
        for (p, v) in peak.iter_mut().zip(y) {
            *p = p.max(v.abs());
        }
    }
    // Thresholds every output passes at some time: its excursion at half its peak, its
    // running rms at a fifth of it.
    let mut file = test_params_file();
    if let Some(device) = &mut file.device {
        device.telemetry_decimation = Some(5);
        for (keys, output) in device.joint_alerts.outputs.iter_mut().zip(JointOutput::ALL) {
            let (rms, excursion) = (
                Some((0.2 * peak[output.index()]) as f32),
                Some((0.5 * peak[output.index()]) as f32),
            );
            match output.unit() {
                JointUnit::Metre => (keys.running_rms_m, keys.excursion_m) = (rms, excursion),
                JointUnit::Radian => (keys.running_rms_rad, keys.excursion_rad) = (rms, excursion),
            }
        }
    }
    let params = device_params::build(&file, fs).expect("params build");
    let blob = device_params::encode(&params).expect("blob encodes");
    let indices: Vec<u32> = (0..input.len() as u32).collect();
    let host = reference::pipeline(&params, &indices, &input);
    let s = run_via(
        Route::File,
        Some(blob),
        false,
        sample_messages(0, &input),
        240,
    );
    assert_eq!(
        s.telemetry, host.telemetry,
        "the device is the host's pipeline"
    );
    assert_eq!(s.events, host.events, "the device's alerts are the host's");
    let joint_alerts = |raised: bool| {
        s.events
            .iter()
            .filter(|e| matches!(e, AlertEvent::Joint { .. }) && e.is_raise() == raised)
            .count()
    };
    println!(
        "joint alerts: {} raised, {} cleared",
        joint_alerts(true),
        joint_alerts(false)
    );
    // Every output's excursion alert, once, and running-rms alerts besides.
    assert!(joint_alerts(true) > 10, "{:?}", s.events);
    let order: Vec<_> = packed_order(params.joints.mask()).collect();
    assert_eq!(order.len(), 10, "all ten by default");
    let mut worst = [0.0f64; 10];
    for t in &s.telemetry {
        let reference = joints[t.sample_index as usize];
        for (k, output) in order.iter().enumerate() {
            let o = output.index();
            let d = (f64::from(t.joints.as_slice()[k]) - reference[o]).abs();
            worst[o] = worst[o].max(d);
        }
    }
    for output in &order {
        let o = output.index();
        println!("{output}: worst {:.3e} of a peak {:.3e}", worst[o], peak[o]);
    }
    for output in &order {
        let o = output.index();
        assert!(peak[o] > 0.0, "{output}");
        assert!(
            worst[o] <= 1e-6 * peak[o],
            "{output}: {} of a peak {}",
            worst[o],
            peak[o]
        );
    }
}
