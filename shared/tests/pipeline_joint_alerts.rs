//! Joint-motion alerts through the device pipeline: a sine of known amplitude raises the
//! excursion alert at the first reading after the head's warm-up whose value, computed
//! from the readout alone, passes the threshold; stamped with that sample, sent once, in
//! sample order.

use core::f64::consts::TAU;

use supine_core::alerts::{AlertEvent, JointAlertConfig, JointCriterion};
use supine_core::blob::DeviceParams;
use supine_core::input_resolution::quantize_m_s2;
use supine_core::joint_exposure::packed_order;
use supine_core::model::modal::modulus;
use supine_core::model::{JointOutput, ModalState, Model, ModelParams, Preset};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::protocol::golden::blob_example;

const FS_HZ: f64 = 500.0;
const DECIMATION: u16 = 5;

fn litter() -> (Model, DeviceParams) {
    let model = Model::new(&ModelParams::preset(Preset::PaperLitter)).unwrap();
    let mut params = blob_example().unwrap();
    params.realization = model.device_realization(FS_HZ).unwrap();
    params.joints = model
        .device_joint_readout(FS_HZ, &params.realization, &JointOutput::ALL)
        .unwrap();
    params.telemetry.decimation = DECIMATION;
    let params = params.with_joint_alerts(JointAlertConfig::NONE).unwrap();
    (model, params)
}

/// Every output of the pipeline, in order.
fn run(params: &DeviceParams, input: &[[f32; 3]]) -> Vec<PipelineOutput> {
    let indices: Vec<u32> = (0..input.len() as u32).collect();
    let mut out = Vec::new();
    params.process(&mut PipelineState::new(), &indices, input, |o| out.push(o));
    out
}

#[test]
fn a_sine_raises_the_excursion_alert_at_the_first_reading_past_its_threshold() {
    let (model, params) = litter();
    let neck_z = JointOutput::from_name("neck_z").unwrap();
    let slot = packed_order(params.joints.mask())
        .position(|o| o == neck_z)
        .unwrap();
    // 2 Hz vertical sine of 1 m/s^2 for 8 s (the first 5 the warm-up).
    let (f_hz, amplitude_m_s2) = (2.0, 1.0);
    let warmup = params.exposure.warmup_samples as usize;
    assert_eq!(warmup, 2_500);
    let input: Vec<[f32; 3]> = (0..4_000u32)
        .map(|n| {
            let s = amplitude_m_s2 * (TAU * f_hz * f64::from(n) / FS_HZ).sin();
            [0.0, 0.0, s as f32]
        })
        .collect();
    // The threshold: 90 % of the continuous model's steady amplitude of neck_z.
    let h = model.matrices.joint_response(f_hz).unwrap();
    let steady_m = modulus(h[(neck_z.index(), 2)]) * amplitude_m_s2;
    let threshold_m = (0.9 * steady_m) as f32;
    assert!(threshold_m > 1e-5, "neck_z moves: {steady_m} m");

    // Where it must fire: the readout alone, stepped beside the realization.
    let full_scale = params.sensor_checks.config.full_scale_m_s2;
    let mut state = ModalState::<f32>::default();
    let mut first = None;
    for (n, &x) in input.iter().enumerate() {
        let u = quantize_m_s2(x, full_scale);
        if n % usize::from(DECIMATION) == 0 && n >= warmup {
            let v = params.joints.read(&params.realization, &state, u)[neck_z.index()];
            if first.is_none() && v.abs() > threshold_m {
                first = Some((n as u32, v.abs()));
            }
        }
        params.realization.step(&mut state, u);
    }
    let (at, value) = first.expect("the sine passes 90 % of its amplitude");

    let mut config = JointAlertConfig::NONE;
    config.excursion_m_or_rad[slot] = threshold_m;
    let alerted = params.with_joint_alerts(config).unwrap();
    let outputs = run(&alerted, &input);
    let joint: Vec<AlertEvent> = outputs
        .iter()
        .filter_map(|o| match o {
            PipelineOutput::Alert(e @ AlertEvent::Joint { .. }) => Some(*e),
            _ => None,
        })
        .collect();
    assert_eq!(
        joint,
        [AlertEvent::Joint {
            output: neck_z.index() as u8,
            criterion: JointCriterion::Excursion {
                value_m_or_rad: value
            },
            raised: true,
            at_sample: at,
        }]
    );
    // Sent before that sample's telemetry record, after the one before it.
    let position = |pred: &dyn Fn(&PipelineOutput) -> bool| outputs.iter().position(pred);
    let alert_at = position(&|o| matches!(o, PipelineOutput::Alert(AlertEvent::Joint { .. })));
    let record_at =
        position(&|o| matches!(o, PipelineOutput::Telemetry(t) if t.sample_index == at));
    assert_eq!(alert_at.map(|i| i + 1), record_at);

    // A threshold at the largest value read after the warm-up: never passed, no alert.
    let largest = outputs
        .iter()
        .filter_map(|o| match o {
            PipelineOutput::Telemetry(t) if t.sample_index as usize >= warmup => {
                Some(t.joints.as_slice()[slot].abs())
            }
            _ => None,
        })
        .fold(0.0f32, f32::max);
    config.excursion_m_or_rad[slot] = largest;
    let quiet = params.with_joint_alerts(config).unwrap();
    assert!(
        !run(&quiet, &input)
            .iter()
            .any(|o| matches!(o, PipelineOutput::Alert(AlertEvent::Joint { .. })))
    );
}

#[test]
fn thresholds_for_outputs_not_read_are_refused() {
    let model = Model::new(&ModelParams::preset(Preset::PaperLitter)).unwrap();
    let mut params = blob_example().unwrap();
    params.realization = model.device_realization(FS_HZ).unwrap();
    params.joints = model
        .device_joint_readout(FS_HZ, &params.realization, &JointOutput::ALL[..2])
        .unwrap();
    let params = params.with_joint_alerts(JointAlertConfig::NONE).unwrap();
    let mut config = JointAlertConfig::NONE;
    config.running_rms_m_or_rad[1] = 0.001;
    assert!(params.with_joint_alerts(config).is_ok());
    config.running_rms_m_or_rad[2] = 0.001;
    assert_eq!(
        params.with_joint_alerts(config),
        Err(supine_core::blob::BlobError::BadConfig)
    );
}
