//! The device pipeline: batching never changes a bit, faults are reported and contained,
//! telemetry follows the decimation.

use supine_core::alerts::{AlertConfig, AlertEvent, AlertSettings, Criterion, SensorFault};
use supine_core::blob::DeviceParams;
use supine_core::model::{ModelParams, Preset, device_model};
use supine_core::pipeline::{BLOCK_LEN, PipelineOutput, PipelineState};
use supine_core::protocol::Telemetry;
use supine_core::protocol::golden::blob_example;
use supine_core::test_vector::TestVector;

fn litter_params(decimation: u16) -> DeviceParams {
    let mut params = blob_example().unwrap();
    (params.realization, params.joints) =
        device_model(&ModelParams::preset(Preset::PaperLitter), 500.0).unwrap();
    params.telemetry.decimation = decimation;
    params.validate().unwrap();
    params
}

fn run(
    params: &DeviceParams,
    input: &[[f32; 3]],
    indices: &[u32],
    batch: usize,
) -> Vec<PipelineOutput> {
    let mut state = PipelineState::new();
    let mut out = Vec::new();
    for (i, x) in indices.chunks(batch).zip(input.chunks(batch)) {
        params.process(&mut state, i, x, |o| out.push(o));
    }
    out
}

fn bits(outputs: &[PipelineOutput]) -> Vec<String> {
    // Compare through Debug of the bit patterns: NaN-safe and exact.
    outputs
        .iter()
        .map(|o| match o {
            PipelineOutput::Telemetry(t) => format!(
                "{} {:?} {:?} {} {} {:?} {} {}",
                t.sample_index,
                t.head_acc_m_s2.map(f32::to_bits),
                t.running_rms_m_s2.map(f32::to_bits),
                t.vector_running_rms_m_s2.to_bits(),
                t.vdv_m_s175.to_bits(),
                t.alert_level,
                t.fault_flags,
                t.valid
            ),
            PipelineOutput::Alert(e) => format!("{e:?}"),
        })
        .collect()
}

#[test]
fn cutting_the_stream_into_any_batches_gives_the_same_bits() {
    let params = litter_params(1);
    let input: Vec<[f32; 3]> = TestVector::new(3)
        .take(5000)
        .map(|x| x.map(|v| v * 6.0))
        .collect();
    let indices: Vec<u32> = (0..5000).collect();
    let reference = bits(&run(&params, &input, &indices, 1));
    assert_eq!(
        reference.len(),
        5000 + reference
            .iter()
            .filter(|l| l.starts_with("Level") || l.starts_with("Fault"))
            .count()
    );
    for batch in [7, 16, 64, 333] {
        assert_eq!(
            bits(&run(&params, &input, &indices, batch)),
            reference,
            "batch {batch}"
        );
    }
}

#[test]
fn a_non_finite_sample_raises_a_fault_and_never_reaches_the_filters() {
    let params = litter_params(1);
    let mut input: Vec<[f32; 3]> = TestVector::new(4).take(3000).collect();
    input[1000][1] = f32::NAN;
    input[1001][2] = f32::INFINITY;
    let indices: Vec<u32> = (0..3000).collect();
    let out = run(&params, &input, &indices, 16);
    assert!(out.contains(&PipelineOutput::Alert(AlertEvent::Fault {
        fault: SensorFault::NonFinite,
        active: true,
        at_sample: 1000
    })));
    let telemetry: Vec<_> = out
        .iter()
        .filter_map(|o| {
            if let PipelineOutput::Telemetry(t) = o {
                Some(*t)
            } else {
                None
            }
        })
        .collect();
    assert_eq!(telemetry.len(), 3000);
    assert!(
        telemetry
            .iter()
            .all(|t| t.head_acc_m_s2.iter().all(|v| v.is_finite()))
    );
    assert!(telemetry[1000].fault_flags.contains(SensorFault::NonFinite));
    assert!(!telemetry[999].fault_flags.contains(SensorFault::NonFinite));
    // The fault clears after a second of good samples.
    assert!(!telemetry[2999].fault_flags.contains(SensorFault::NonFinite));
}

#[test]
fn a_gap_in_sample_indices_is_a_fault_stamped_at_the_first_sample_after_it() {
    let params = litter_params(1);
    let input: Vec<[f32; 3]> = TestVector::new(5).take(100).collect();
    let indices: Vec<u32> = (0..50).chain(60..110).collect();
    let out = run(&params, &input, &indices, 16);
    assert!(out.contains(&PipelineOutput::Alert(AlertEvent::Fault {
        fault: SensorFault::IndexGap,
        active: true,
        at_sample: 60
    })));
}

#[test]
fn telemetry_comes_every_decimation_samples() {
    let params = litter_params(10);
    let input: Vec<[f32; 3]> = TestVector::new(6).take(1000).collect();
    let indices: Vec<u32> = (0..1000).collect();
    let sent: Vec<u32> = run(&params, &input, &indices, 16)
        .iter()
        .filter_map(|o| {
            if let PipelineOutput::Telemetry(t) = o {
                Some(t.sample_index)
            } else {
                None
            }
        })
        .collect();
    assert_eq!(sent, (0..100).map(|i| 10 * i).collect::<Vec<_>>());
}

/// Runs a 4 Hz sine of `amplitude_m_s2` on z for `seconds` through `params` with the alert
/// thresholds of `alerts` (telemetry every sample); returns the level-change events and the
/// telemetry, indexed by sample.
fn sine_levels(
    alerts: AlertConfig,
    amplitude_m_s2: f32,
    seconds: f32,
) -> (Vec<AlertEvent>, Vec<Telemetry>) {
    let mut params = litter_params(1);
    params.alerts = AlertSettings::new(alerts, params.sample_rate).unwrap();
    params.validate().unwrap();
    let n = (seconds * params.sample_rate_hz()) as u32;
    let input: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let t = f64::from(i) / f64::from(params.sample_rate_hz());
            [
                0.0,
                0.0,
                amplitude_m_s2 * (8.0 * std::f64::consts::PI * t).sin() as f32,
            ]
        })
        .collect();
    let indices: Vec<u32> = (0..n).collect();
    let (mut events, mut telemetry) = (Vec::new(), Vec::new());
    for o in run(&params, &input, &indices, 32) {
        match o {
            PipelineOutput::Alert(e @ AlertEvent::Level { .. }) => events.push(e),
            PipelineOutput::Telemetry(t) => telemetry.push(t),
            PipelineOutput::Alert(_) => {}
        }
    }
    assert!(
        telemetry
            .iter()
            .enumerate()
            .all(|(i, t)| t.sample_index == i as u32)
    );
    (events, telemetry)
}

/// Issue 15, item 3: a raise by the VDV names the VDV, with the value the telemetry of the
/// same sample reports, bit for bit (running-rms thresholds out of reach).
#[test]
fn a_level_raised_by_the_vdv_names_the_vdv_with_the_telemetrys_value() {
    let vdv_only = AlertConfig {
        running_rms_m_s2: [100.0, 200.0, 300.0],
        vdv_m_s175: [1.0, 2.0, 3.0],
        ..AlertConfig::DEFAULT
    };
    let (events, telemetry) = sine_levels(vdv_only, 2.0, 20.0);
    assert!(!events.is_empty(), "the sine raises no level");
    for e in &events {
        let t = &telemetry[e.at_sample() as usize];
        assert_eq!(
            e.criterion(),
            Some(Criterion::Vdv {
                value_m_s175: t.vdv_m_s175
            }),
            "{e:?}"
        );
        assert!(t.vdv_m_s175 >= 1.0 && t.vector_running_rms_m_s2 < 100.0);
    }
}

/// And a raise by the running rms names it, with the telemetry's vector running rms (VDV
/// thresholds out of reach).
#[test]
fn a_level_raised_by_the_running_rms_names_it_with_the_telemetrys_value() {
    let rms_only = AlertConfig {
        vdv_m_s175: [1000.0, 2000.0, 3000.0],
        ..AlertConfig::DEFAULT
    };
    let (events, telemetry) = sine_levels(rms_only, 1.0, 20.0);
    assert!(!events.is_empty(), "the sine raises no level");
    for e in &events {
        let t = &telemetry[e.at_sample() as usize];
        assert_eq!(
            e.criterion(),
            Some(Criterion::RunningRms {
                value_m_s2: t.vector_running_rms_m_s2
            }),
            "{e:?}"
        );
        assert!(t.vector_running_rms_m_s2 >= 0.5);
    }
}

/// Runs `input` in calls of one block each, as the device does, and collects the model's
/// input after each call (`PipelineState::recent_inputs`): (sample index, counts).
fn inputs_of(params: &DeviceParams, input: &[[f32; 3]], indices: &[u32]) -> Vec<(u32, [i16; 3])> {
    let mut state = PipelineState::new();
    let mut out = Vec::new();
    for (i, x) in indices.chunks(BLOCK_LEN).zip(input.chunks(BLOCK_LEN)) {
        params.process(&mut state, i, x, |_| {});
        let mut recent = vec![[0i16; 3]; i.len()];
        state.recent_inputs(&mut recent);
        out.extend(i.iter().copied().zip(recent));
    }
    out
}

#[test]
fn the_model_computes_on_the_input_rounded_to_the_input_resolution_and_reports_it() {
    let params = litter_params(1);
    let raw: Vec<[f32; 3]> = TestVector::new(6)
        .take(3000)
        .map(|x| x.map(|v| v * 3.0))
        .collect();
    // Rounded independently of the core, in f64.
    let rounded: Vec<[f32; 3]> = raw
        .iter()
        .map(|x| x.map(|v| ((f64::from(v) * 512.0).round_ties_even() / 512.0) as f32))
        .collect();
    assert!(raw != rounded, "the test data is not already on the grid");
    let indices: Vec<u32> = (0..3000).collect();
    let from_raw = run(&params, &raw, &indices, 16);
    // Only the rounded input matters: feeding it directly gives the same bits everywhere.
    assert_eq!(bits(&from_raw), bits(&run(&params, &rounded, &indices, 16)));
    let expected: Vec<(u32, [i16; 3])> = rounded
        .iter()
        .zip(0..)
        .map(|(x, i)| (i, x.map(|v| (v * 512.0) as i16)))
        .collect();
    assert_eq!(inputs_of(&params, &raw, &indices), expected);
}

#[test]
fn an_input_beyond_the_input_range_is_clipped_and_raises_saturation() {
    let params = litter_params(1);
    // Inside the default 16 g full scale, beyond the 64 m/s^2 the counts hold.
    assert!(params.sensor_checks.config.full_scale_m_s2 > 100.0);
    let mut input: Vec<[f32; 3]> = TestVector::new(7).take(1000).collect();
    input[500] = [70.0, -80.0, 63.0];
    let indices: Vec<u32> = (0..1000).collect();
    let out = run(&params, &input, &indices, 16);
    assert!(out.contains(&PipelineOutput::Alert(AlertEvent::Fault {
        fault: SensorFault::Saturated,
        active: true,
        at_sample: 500
    })));
    assert_eq!(
        inputs_of(&params, &input, &indices)[500],
        (500, [i16::MAX, -i16::MAX, 63 * 512]),
        "clipped to the range, the in-range axis kept"
    );
}

#[test]
fn a_non_finite_sample_is_reported_as_the_held_input_the_model_got() {
    let params = litter_params(1);
    let mut input: Vec<[f32; 3]> = TestVector::new(8).take(100).collect();
    input[40] = [f32::NAN, 1.0, 1.0];
    let indices: Vec<u32> = (0..100).collect();
    let reported = inputs_of(&params, &input, &indices);
    assert_eq!(reported[40].1, reported[39].1);
}
