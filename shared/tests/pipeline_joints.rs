//! The joint outputs through the device pipeline: the values telemetry reports are the
//! readout's at those samples, bit for bit; their running rms and largest excursion are
//! what an f64 computation from those values gives, the excursion from the end of the
//! head's warm-up; a ride that starts in motion leaves the model's start-up transient out
//! of the largest excursion and raises no excursion alert in it; and a sine through the
//! whole pipeline comes out as the continuous model predicts (within 1 % and 1 degree,
//! 0.5-20 Hz).

use core::f64::consts::TAU;

use supine_core::blob::DeviceParams;
use supine_core::input_resolution::quantize_m_s2;
use supine_core::joint_exposure::packed_order;
use supine_core::model::modal::{argument, modulus};
use supine_core::model::{JointOutput, ModalState, Model, ModelParams, Preset};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::protocol::Telemetry;
use supine_core::protocol::golden::blob_example;
use supine_core::test_vector::TestVector;

const FS_HZ: f64 = 500.0;

fn litter(decimation: u16, wanted: &[JointOutput]) -> (Model, DeviceParams) {
    let model = Model::new(&ModelParams::preset(Preset::PaperLitter)).unwrap();
    let mut params = blob_example().unwrap();
    params.realization = model.device_realization(FS_HZ).unwrap();
    params.joints = model
        .device_joint_readout(FS_HZ, &params.realization, wanted)
        .unwrap();
    params.telemetry.decimation = decimation;
    params.validate().unwrap();
    (model, params)
}

fn telemetry(params: &DeviceParams, input: &[[f32; 3]]) -> (Vec<Telemetry>, PipelineState) {
    let indices: Vec<u32> = (0..input.len() as u32).collect();
    let mut state = PipelineState::new();
    let mut out = Vec::new();
    params.process(&mut state, &indices, input, |o| {
        if let PipelineOutput::Telemetry(t) = o {
            out.push(t);
        }
    });
    (out, state)
}

#[test]
fn reported_joint_values_are_the_readouts_and_their_exposure_is_the_f64_one() {
    let some = [
        JointOutput::ALL[0],
        JointOutput::ALL[3],
        JointOutput::ALL[9],
    ];
    for (decimation, wanted) in [
        (1, &JointOutput::ALL[..]),
        (5, &JointOutput::ALL[..]),
        (7, &some[..]),
    ] {
        let (_, params) = litter(decimation, wanted);
        let mask = params.joints.mask();
        let order: Vec<JointOutput> = packed_order(mask).collect();
        assert_eq!(order.len(), wanted.len());
        let packed: Vec<u8> = params.joints.packed_outputs().collect();
        assert_eq!(
            packed,
            order.iter().map(|o| o.index() as u8).collect::<Vec<_>>()
        );

        let input: Vec<[f32; 3]> = TestVector::new(11).take(6_000).collect();
        let (records, state) = telemetry(&params, &input);
        assert_eq!(records.len(), input.len().div_ceil(usize::from(decimation)));

        // The readout alone, stepped beside the head realization, sample by sample.
        let mut model_state = ModalState::<f32>::default();
        let mut expected = Vec::new();
        let full_scale = params.sensor_checks.config.full_scale_m_s2;
        for (n, &x) in input.iter().enumerate() {
            // The model's input: the sample rounded to the input resolution.
            let u = quantize_m_s2(x, full_scale);
            if n % usize::from(decimation) == 0 {
                expected.push(params.joints.read(&params.realization, &model_state, u));
            }
            params.realization.step(&mut model_state, u);
        }
        // The running mean square in f64 over the reported values, with the gain of D
        // samples computed from tau directly.
        let tau_s = f64::from(params.exposure.config.running_tau_s);
        let gain = -(-f64::from(decimation) / (FS_HZ * tau_s)).exp_m1();
        let mut ms = vec![0.0f64; order.len()];
        let mut peak = vec![0.0f32; order.len()];
        let warmup = params.exposure.warmup_samples;
        assert!(warmup > 0 && (warmup as usize) < input.len() / 2);
        for (t, y) in records.iter().zip(&expected) {
            let reported = t.joints.as_slice();
            assert_eq!(reported.len(), order.len());
            for (k, output) in order.iter().enumerate() {
                let v = y[output.index()];
                assert_eq!(
                    reported[k].to_bits(),
                    v.to_bits(),
                    "{output} at {}",
                    t.sample_index
                );
                ms[k] += gain * (f64::from(v) * f64::from(v) - ms[k]);
                // The largest excursion counts from the end of the head's warm-up.
                if t.sample_index >= warmup {
                    peak[k] = peak[k].max(v.abs());
                }
            }
        }
        let count = order.len();
        let rms = state.joints().running_rms(count);
        let largest = state.joints().largest_excursion(count);
        for (k, output) in order.iter().enumerate() {
            let want = ms[k].sqrt();
            let got = f64::from(rms.as_slice()[k]);
            assert!(want > 0.0, "{output}");
            assert!(
                (got / want - 1.0).abs() < 1e-4,
                "{output}: running rms {got} against {want}"
            );
            assert_eq!(largest.as_slice()[k], peak[k], "{output}");
        }
    }
}

/// Complex amplitude of the sine at `f_hz` in `y` (sampled at [`FS_HZ`] from sample `n0`):
/// `y = |h| sin(w t + arg h)`.
fn sine_amplitude(y: &[(u32, f64)], f_hz: f64) -> nalgebra::Complex<f64> {
    let w = TAU * f_hz / FS_HZ;
    let (mut s, mut c) = (0.0, 0.0);
    for &(n, v) in y {
        s += v * (w * f64::from(n)).sin();
        c += v * (w * f64::from(n)).cos();
    }
    let scale = 2.0 / y.len() as f64;
    nalgebra::Complex::new(s * scale, c * scale)
}

#[test]
fn a_sine_through_the_pipeline_gives_the_continuous_models_joint_motion() {
    let (model, params) = litter(1, &JointOutput::ALL);
    let order: Vec<JointOutput> = packed_order(params.joints.mask()).collect();
    let (mut worst_mag, mut worst_deg) = (0.0f64, 0.0f64);
    for f_hz in [0.5, 1.0, 2.0, 3.5, 5.0, 8.0, 12.0, 20.0] {
        let h = model.matrices.joint_response(f_hz).unwrap();
        for axis in 0..3 {
            // 6 s to settle, then 10 s (a whole number of periods at every frequency).
            let (settle, fit) = (3_000u32, 5_000u32);
            let input: Vec<[f32; 3]> = (0..settle + fit)
                .map(|n| {
                    let mut u = [0.0f32; 3];
                    u[axis] = (TAU * f_hz * f64::from(n) / FS_HZ).sin() as f32;
                    u
                })
                .collect();
            let (records, _) = telemetry(&params, &input);
            for (k, output) in order.iter().enumerate() {
                if output.input_axis().index() != axis {
                    continue;
                }
                let y: Vec<(u32, f64)> = records
                    .iter()
                    .filter(|t| t.sample_index >= settle)
                    .map(|t| (t.sample_index, f64::from(t.joints.as_slice()[k])))
                    .collect();
                assert_eq!(y.len(), fit as usize);
                let got = sine_amplitude(&y, f_hz);
                assert!(got.re.is_finite() && got.im.is_finite() && modulus(got) > 0.0);
                let want = h[(output.index(), axis)];
                worst_mag = worst_mag.max((modulus(got) / modulus(want) - 1.0).abs());
                worst_deg = worst_deg.max(argument(got / want).to_degrees().abs());
            }
        }
    }
    println!("worst magnitude error {worst_mag:.2e}, phase error {worst_deg:.3} deg");
    assert!(worst_mag < 0.01, "magnitude error {worst_mag}");
    assert!(worst_deg < 1.0, "phase error {worst_deg} deg");
}

/// A ride that starts in motion, as after an upload mid-ride or a replay cut from the
/// middle of a recording: a vertical sine that is at its crest at the first sample meets
/// the model at rest, and the model's start-up transient swings the joints further in the
/// first second than the ride ever does after it. The largest excursion counts from the
/// end of the head's warm-up, and an excursion threshold between the two raises nothing.
#[test]
fn a_ride_that_starts_in_motion_keeps_the_start_up_transient_out_of_the_excursion() {
    let decimation = 5;
    let (_, params) = litter(decimation, &JointOutput::ALL);
    let order: Vec<JointOutput> = packed_order(params.joints.mask()).collect();
    let warmup = params.exposure.warmup_samples;
    let second = FS_HZ as u32;
    // 2 m/s^2 at 1.5 Hz, from its crest: a step of 2 m/s^2 at the first sample.
    let input: Vec<[f32; 3]> = (0..3 * warmup)
        .map(|n| {
            let z = 2.0 * (TAU * 1.5 * f64::from(n) / FS_HZ).cos();
            [0.0, 0.0, z as f32]
        })
        .collect();
    let (records, state) = telemetry(&params, &input);
    let largest = |k: usize, from: u32, to: u32| {
        records
            .iter()
            .filter(|t| (from..to).contains(&t.sample_index))
            .map(|t| t.joints.as_slice()[k].abs())
            .fold(0.0f32, f32::max)
    };
    // The output the transient swings most beyond what the ride does after the warm-up.
    let (k, ratio) = (0..order.len())
        .map(|k| (k, largest(k, 0, second) / largest(k, warmup, u32::MAX)))
        .fold((0, 0.0f32), |a, b| if b.1 > a.1 { b } else { a });
    let output = order[k];
    println!("{output}: first second {ratio:.2} x the ride's largest after the warm-up");
    assert!(
        ratio > 1.2,
        "the start-up transient must stand out: {ratio}"
    );

    // The device's largest excursion: the ride's after the warm-up, for every output.
    let reported = state.joints().largest_excursion(order.len());
    for (k, o) in order.iter().enumerate() {
        assert_eq!(reported.as_slice()[k], largest(k, warmup, u32::MAX), "{o}");
    }

    // An excursion threshold above the ride, below the transient: no alert.
    let ride_peak = largest(k, warmup, u32::MAX);
    let transient_peak = largest(k, 0, second);
    let mut config = supine_core::alerts::JointAlertConfig::NONE;
    config.excursion_m_or_rad[k] = 0.5 * (ride_peak + transient_peak);
    let alerted = params.with_joint_alerts(config).unwrap();
    let indices: Vec<u32> = (0..input.len() as u32).collect();
    let mut events = Vec::new();
    alerted.process(&mut PipelineState::new(), &indices, &input, |o| {
        if let PipelineOutput::Alert(e @ supine_core::alerts::AlertEvent::Joint { .. }) = o {
            events.push(e);
        }
    });
    assert_eq!(
        events,
        [],
        "{output}: the transient raised an excursion alert"
    );
    // Below the ride's own peak it is raised, after the warm-up.
    config.excursion_m_or_rad[k] = 0.9 * ride_peak;
    let alerted = params.with_joint_alerts(config).unwrap();
    let mut raised_at = Vec::new();
    alerted.process(&mut PipelineState::new(), &indices, &input, |o| {
        if let PipelineOutput::Alert(e @ supine_core::alerts::AlertEvent::Joint { .. }) = o {
            raised_at.push(e.at_sample());
        }
    });
    assert_eq!(raised_at.len(), 1, "{output}");
    assert!(
        raised_at[0] >= warmup,
        "{output}: raised at {}",
        raised_at[0]
    );
}
