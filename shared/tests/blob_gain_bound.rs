//! Issue 17, D6: the blob validator bounds what input within the sensor's full scale can
//! make of a realization's and a weighting's state and outputs, so no accepted blob turns
//! bounded input into non-finite values; and every blob the product itself builds, at any
//! supported rate, for any plausible subject, at the largest full scale, is still accepted.

use proptest::prelude::*;
use supine_core::alerts::SensorCheckConfig;
use supine_core::blob::{BlobError, DeviceParams, MAX_SIGNAL_M_S2, Patient};
use supine_core::exposure::{AxisMapping, AxisWeighting, ExposureConfig};
use supine_core::model::{JointReadout, ModelParams, ParamId, Preset, device_realization};
use supine_core::protocol::golden::blob_example;
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::WeightingKind;

const RATES_HZ: [f32; 5] = [100.0, 200.0, 500.0, 1000.0, 2000.0];

/// Parameters for `model` at `rate_hz` with the largest full scale and `kind` on every axis.
fn params_for(model: &ModelParams, rate_hz: f32, kind: WeightingKind) -> DeviceParams {
    let rate = SampleRate::new(rate_hz).expect("a supported rate");
    let realization = device_realization(model, f64::from(rate_hz)).expect("discretizes");
    let axis = AxisWeighting { kind, k: 1.4 };
    let exposure = ExposureConfig {
        axes: AxisMapping {
            x: axis,
            y: axis,
            z: axis,
        },
        ..ExposureConfig::DEFAULT
    };
    let checks = SensorCheckConfig {
        full_scale_m_s2: SensorCheckConfig::MAX_FULL_SCALE_M_S2,
        ..SensorCheckConfig::DEFAULT
    };
    let patient = Patient::of(&model.subject);
    let base = DeviceParams::with_defaults([0; 16], patient, rate, realization, JointReadout::NONE)
        .expect("defaults valid");
    DeviceParams::new(
        [0; 16],
        patient,
        rate,
        realization,
        exposure,
        base.alerts.config,
        checks,
        base.mounting,
        base.telemetry,
        JointReadout::NONE,
    )
    .expect("a blob the product builds is accepted")
}

/// The bound the validator checks, as a fraction of [`MAX_SIGNAL_M_S2`].
fn signal_margin(params: &DeviceParams) -> f32 {
    let full_scale = params.sensor_checks.config.full_scale_m_s2;
    let model = params.realization.amplification().expect("bounded");
    model
        .outputs
        .iter()
        .zip(&params.exposure.weighting)
        .map(|(head, w)| head * full_scale * w.amplification().expect("bounded").output)
        .fold(0.0, f32::max)
        / MAX_SIGNAL_M_S2
}

#[test]
fn every_preset_rate_and_weighting_is_accepted_with_room_to_spare() {
    let mut worst = 0.0f32;
    for preset in Preset::ALL {
        for rate in RATES_HZ {
            for kind in [WeightingKind::Wk, WeightingKind::Wd, WeightingKind::Wj] {
                let margin = signal_margin(&params_for(&ModelParams::preset(preset), rate, kind));
                worst = worst.max(margin);
            }
        }
    }
    println!("largest bound: {worst:.4} of MAX_SIGNAL_M_S2");
    // The presets reach 0.019 of it; far-out subjects (below) up to 0.26.
    assert!(worst < 0.05, "{worst} of the limit: too little room");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Subjects far from the mean: every parameter scaled by up to e^(+-0.9) (three
    /// standard deviations of the widest spread the fit is tested on).
    #[test]
    fn subjects_far_from_the_mean_are_accepted(
        scales in proptest::collection::vec(-0.9f64..0.9, ParamId::COUNT),
        rate in proptest::sample::select(RATES_HZ.to_vec()),
    ) {
        let mut model = ModelParams::preset(Preset::PaperLitter);
        for (id, s) in ParamId::ALL.into_iter().zip(&scales) {
            model.set(id, model.get(id) * s.exp());
        }
        prop_assume!(model.validate().is_ok());
        // Accepted (`params_for` expects it), with half the limit to spare: 600 subjects
        // at and inside the box's corners, at 100, 500 and 2000 Hz and every weighting,
        // reached 0.26 of it (at 10^7, the limit before, CI found a subject at 100 Hz it
        // refused).
        for kind in [WeightingKind::Wk, WeightingKind::Wd, WeightingKind::Wj] {
            let margin = signal_margin(&params_for(&model, rate, kind));
            prop_assert!(margin < 0.5, "{margin} of MAX_SIGNAL_M_S2 with {kind:?}");
        }
    }
}

#[test]
fn the_subject_ci_found_refused_at_the_old_limit_is_accepted() {
    // Shrunk by proptest on CI: scales of e^(-0.59..0.83) on nine parameters, 100 Hz; the
    // bound reached 0.96 of the old 10^7 and, unshrunk, passed it.
    let scales = [
        (2, -0.431_414),
        (7, -0.179_549),
        (10, 0.660_296),
        (17, 0.729_357),
        (19, 0.587_518),
        (22, -0.586_475),
        (26, 0.400_355),
        (29, 0.827_964),
        (35, -0.459_417),
    ];
    let mut model = ModelParams::preset(Preset::PaperLitter);
    for (index, s) in scales {
        let id = ParamId::ALL[index];
        model.set(id, model.get(id) * f64::exp(s));
    }
    let margin = signal_margin(&params_for(&model, 100.0, WeightingKind::Wk));
    assert!((0.05..0.5).contains(&margin), "{margin} of MAX_SIGNAL_M_S2");
}

/// The golden blob with its first output coefficient set to `value`.
fn with_output_coefficient(value: f32) -> DeviceParams {
    let mut params = blob_example().expect("the golden blob decodes");
    params.realization.blocks[0].output[0][0] = value;
    params
}

#[test]
fn an_output_coefficient_of_1e30_is_refused() {
    // D6's reproduction: finite, stable, and accepted before the bound.
    assert_eq!(
        with_output_coefficient(1e30).validate(),
        Err(BlobError::Unstable)
    );
    assert_eq!(with_output_coefficient(0.5).validate(), Ok(()));
}

#[test]
fn a_pole_a_hair_inside_the_unit_circle_is_refused() {
    let mut params = blob_example().expect("the golden blob decodes");
    // Phi = I + D with a pole at 1 - 1e-7: inside the unit circle (the Jury test the
    // validator ran before passed it), but its gain is 1e7 per unit of input.
    params.realization.blocks[0].transition_minus_identity = [[-1e-7, 0.0], [0.0, -0.5]];
    assert_eq!(params.validate(), Err(BlobError::Unstable));
    // A pole 1e-3 inside is a legitimate (if slow) mode and stays accepted.
    params.realization.blocks[0].transition_minus_identity = [[-1e-3, 0.0], [0.0, -0.5]];
    assert_eq!(params.validate(), Ok(()));
}

#[test]
fn the_bound_holds_for_the_worst_input_of_a_real_realization() {
    // Input of the worst signs for head z (sign of its impulse response, read backwards)
    // at full scale: the output reaches its l1 gain, which the bound must not undercut.
    let params = params_for(
        &ModelParams::preset(Preset::PaperLitter),
        500.0,
        WeightingKind::Wk,
    );
    let realization = params.realization.cast::<f64>();
    let n = 20_000;
    let mut state = supine_core::model::ModalState::<f64>::default();
    let impulse: Vec<f64> = (0..n)
        .map(|k| {
            let u = if k == 0 { 1.0 } else { 0.0 };
            realization.step(&mut state, [0.0, 0.0, u])[2]
        })
        .collect();
    let l1: f64 = impulse.iter().map(|v| v.abs()).sum();
    let bound = f64::from(params.realization.amplification().expect("bounded").outputs[2]);
    assert!(
        bound >= l1 * (1.0 - 1e-9),
        "bound {bound} under the l1 gain {l1}"
    );
    assert!(
        bound < 10.0 * l1,
        "bound {bound} loose against the l1 gain {l1}"
    );
}
