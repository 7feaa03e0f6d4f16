//! Issue 17, D1: no finite input, however absurd, can drive the device's f32 state to
//! overflow. A sample of 1e30 m/s^2 used to make the running rms NaN and the VDV infinite
//! for good, with `valid` set. Every sample is now clipped to the sensor's full scale
//! before the model (and raises the saturation fault), so the state stays finite and
//! recovers once the samples are clean.

use proptest::prelude::*;
use supine_core::alerts::{AlertEvent, SensorCheckConfig, SensorFault};
use supine_core::blob::DeviceParams;
use supine_core::model::{ModelParams, Preset, device_realization};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::protocol::Telemetry;
use supine_core::protocol::golden::blob_example;
use supine_core::test_vector::TestVector;

fn litter_params() -> DeviceParams {
    let mut params = blob_example().expect("the golden blob decodes");
    params.realization =
        device_realization(&ModelParams::preset(Preset::PaperLitter), 500.0).expect("discretizes");
    params.telemetry.decimation = 1;
    params.validate().expect("valid parameters");
    params
}

/// Runs `input` (indices 0..) through the pipeline; returns telemetry and events.
fn run(params: &DeviceParams, input: &[[f32; 3]]) -> (Vec<Telemetry>, Vec<AlertEvent>) {
    let mut state = PipelineState::new();
    let indices: Vec<u32> = (0..input.len() as u32).collect();
    let (mut telemetry, mut events) = (Vec::new(), Vec::new());
    params.process(&mut state, &indices, input, |o| match o {
        PipelineOutput::Telemetry(t) => telemetry.push(t),
        PipelineOutput::Alert(e) => events.push(e),
    });
    (telemetry, events)
}

fn all_finite(t: &Telemetry) -> bool {
    t.head_acc_m_s2
        .iter()
        .chain(&t.running_rms_m_s2)
        .chain([&t.vector_running_rms_m_s2, &t.vdv_m_s175])
        .all(|v| v.is_finite())
}

/// Ten seconds of a rough ride at 500 Hz, as the device would see it.
fn ride() -> Vec<[f32; 3]> {
    TestVector::new(7)
        .take(5000)
        .map(|x| x.map(|v| v * 3.0))
        .collect()
}

#[test]
fn one_sample_of_1e30_raises_saturation_and_leaves_everything_finite() {
    let params = litter_params();
    let mut input = ride();
    input[1000][2] = 1e30;
    let (telemetry, events) = run(&params, &input);
    assert!(telemetry.iter().all(all_finite), "a non-finite value");
    assert!(events.iter().any(|e| matches!(
        e,
        AlertEvent::Fault {
            fault: SensorFault::Saturated,
            active: true,
            at_sample: 1000
        }
    )));
    // Clipped at the full scale, the spike is a large but ordinary shock: the last second's
    // running rms is back to what the clean ride gives once the shock has left its window.
    let (clean, _) = run(&params, &ride());
    let last = telemetry.last().expect("telemetry");
    let clean_last = clean.last().expect("telemetry");
    assert!(last.valid);
    assert!(
        (last.vector_running_rms_m_s2 - clean_last.vector_running_rms_m_s2).abs()
            < 0.05 * clean_last.vector_running_rms_m_s2,
        "running rms {} against {} without the spike",
        last.vector_running_rms_m_s2,
        clean_last.vector_running_rms_m_s2
    );
}

#[test]
fn the_largest_finite_samples_for_an_hour_leave_everything_finite() {
    // The worst a sensor can do: the largest full scale accepted, on every axis, with the
    // sign alternating at the model's resonance, for an hour at 2 kHz, VDV's fourth powers
    // adding up all the while. f32::MAX as input is clipped to the same.
    let mut params = litter_params();
    params.sensor_checks.config.full_scale_m_s2 = SensorCheckConfig::MAX_FULL_SCALE_M_S2;
    let mut state = PipelineState::new();
    let mut last = None;
    let block: Vec<[f32; 3]> = (0..2000)
        .map(|k| [f32::MAX, -f32::MAX, f32::MAX].map(|v| if (k / 100) % 2 == 0 { v } else { -v }))
        .collect();
    for second in 0..3600u32 {
        let indices: Vec<u32> = (second * 2000..(second + 1) * 2000).collect();
        params.process(&mut state, &indices, &block, |o| {
            if let PipelineOutput::Telemetry(t) = o {
                last = Some(t);
            }
        });
    }
    let t = last.expect("telemetry");
    assert!(all_finite(&t), "{t:?}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any finite value at any place of a ride: every telemetry record stays finite, and a
    /// record is valid only if all its values are finite.
    #[test]
    fn any_finite_spikes_leave_the_state_finite(
        spikes in proptest::collection::vec(
            (0usize..5000, 0usize..3, any::<f32>().prop_filter("finite", |v| v.is_finite())),
            1..20,
        )
    ) {
        let params = litter_params();
        let mut input = ride();
        for &(at, axis, value) in &spikes {
            input[at][axis] = value;
        }
        let (telemetry, _) = run(&params, &input);
        for t in &telemetry {
            prop_assert!(all_finite(t), "{t:?}");
        }
    }
}

#[test]
fn a_full_scale_beyond_400_g_is_refused() {
    let mut params = litter_params();
    params.sensor_checks.config.full_scale_m_s2 = 1e30;
    assert!(params.validate().is_err());
}
