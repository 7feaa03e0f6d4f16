//! The device realization against the continuous model: frequency response, an exact
//! time-domain reference, f32 against f64, cost and checks.

use core::f64::consts::PI;

use nalgebra::Complex;
use supine_core::model::modal::{argument, modulus};
use supine_core::model::response::COUPLED_COMPONENTS;
use supine_core::model::{
    Axis, DeviceRealization, ModalState, Model, ModelError, ModelParams, Output, Preset,
    RealizationError,
};
use supine_core::test_vector::TestVector;

fn model(preset: Preset) -> Model {
    Model::new(&ModelParams::preset(preset)).unwrap()
}

/// The head components this geometry couples: (output index, input axis).
fn head_components() -> Vec<(usize, Axis)> {
    COUPLED_COMPONENTS
        .iter()
        .filter(|(o, _)| o.segment == supine_core::model::Segment::Head)
        .map(|(o, a)| (o.index(), *a))
        .collect()
}

/// Worst relative magnitude error and worst phase error (degrees) over 0.5-20 Hz.
fn worst_frequency_error(preset: Preset, sample_rate_hz: f64) -> (f64, f64) {
    let model = model(preset);
    let device = model.device_realization(sample_rate_hz).unwrap();
    let (mut mag, mut phase) = (0.0_f64, 0.0_f64);
    for i in 0..=390 {
        let freq_hz = 0.5 + 0.05 * i as f64;
        let h = model.matrices.transmissibility(freq_hz).unwrap();
        let hd = device.frequency_response(sample_rate_hz, freq_hz);
        for &(o, axis) in &head_components() {
            let (c, d) = (h[(o, axis.index())], hd[o][axis.index()]);
            mag = mag.max((modulus(d) / modulus(c) - 1.0).abs());
            phase = phase.max(argument(d / c).to_degrees().abs());
        }
    }
    (mag, phase)
}

#[test]
fn device_realization_at_500_hz_is_within_1_percent_and_1_degree_of_h_up_to_20_hz() {
    for preset in Preset::ALL {
        let (mag, phase) = worst_frequency_error(preset, 500.0);
        assert!(mag < 0.01, "{}: magnitude error {mag}", preset.name());
        assert!(phase < 1.0, "{}: phase error {phase} deg", preset.name());
    }
}

#[test]
fn device_realization_at_200_hz_is_within_3_5_percent_and_1_degree_up_to_20_hz() {
    // The triangle hold's attenuation is about (2 pi f / fs)^2 / 12: 3.3 % at 20 Hz.
    for preset in Preset::ALL {
        let (mag, phase) = worst_frequency_error(preset, 200.0);
        assert!(mag < 0.035, "{}: magnitude error {mag}", preset.name());
        assert!(phase < 1.0, "{}: phase error {phase} deg", preset.name());
        assert!(
            mag > 0.02,
            "the hold's known attenuation should show at 200 Hz: {mag}"
        );
    }
}

/// A band-limited input: a sum of sines over 0.5-16 Hz per axis, known in closed form.
struct Sines {
    /// (amplitude m/s^2, angular frequency rad/s, phase rad) per axis.
    terms: [Vec<(f64, f64, f64)>; 3],
}

impl Sines {
    fn new(seed: u64) -> Self {
        let mut state = seed;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let terms = core::array::from_fn(|_| {
            (0..40)
                .map(|_| {
                    let f = 0.5 + 15.5 * uniform();
                    (0.1 * (0.2 + uniform()), 2.0 * PI * f, 2.0 * PI * uniform())
                })
                .collect()
        });
        Self { terms }
    }

    fn at(&self, t: f64) -> [f64; 3] {
        core::array::from_fn(|a| {
            self.terms[a]
                .iter()
                .map(|(amp, w, ph)| amp * (w * t + ph).sin())
                .sum()
        })
    }

    /// The continuous model's exact head response from rest: per mode, the particular
    /// solution for each sine minus its value at t = 0 carried by e^(lambda t).
    fn exact_head_response(&self, model: &Model, t: f64) -> [f64; 3] {
        let mut y = [0.0; 3];
        for m in model.modes.components.iter().filter(|m| m.reachable) {
            let axis = m.subsystem.input_axis().unwrap().index();
            let decay = (m.eigenvalue * t).exp();
            let mut z = Complex::new(0.0, 0.0);
            for &(amp, w, ph) in &self.terms[axis] {
                let particular = |t: f64| {
                    let jw = Complex::new(0.0, w);
                    (Complex::new(0.0, w * t + ph).exp() / (jw - m.eigenvalue)
                        - Complex::new(0.0, -(w * t + ph)).exp() / (-jw - m.eigenvalue))
                        / Complex::new(0.0, 2.0)
                };
                z += m.input_gain * amp * (particular(t) - particular(0.0) * decay);
            }
            let weight = if m.is_pair { 2.0 } else { 1.0 };
            for (o, out) in Output::HEAD.iter().enumerate() {
                y[o] += weight * (m.output_gain[out.index()] * z).re;
            }
        }
        y
    }
}

/// rms error over rms signal of the f32 device realization against the exact response.
fn time_domain_relative_error(preset: Preset, sample_rate_hz: f64, duration_s: f64) -> f64 {
    let model = model(preset);
    let device = model.device_realization(sample_rate_hz).unwrap();
    let input = Sines::new(7);
    let mut state = ModalState::default();
    let (mut err2, mut sig2) = (0.0, 0.0);
    let n = (duration_s * sample_rate_hz) as usize;
    for k in 0..n {
        let t = k as f64 / sample_rate_hz;
        let u = input.at(t).map(|v| v as f32);
        let y = device.step(&mut state, u);
        let exact = input.exact_head_response(&model, t);
        for o in 0..3 {
            err2 += (f64::from(y[o]) - exact[o]).powi(2);
            sig2 += exact[o].powi(2);
        }
    }
    (err2 / sig2).sqrt()
}

#[test]
fn a_band_limited_random_input_through_the_500_hz_device_matches_the_exact_continuous_response() {
    for preset in Preset::ALL {
        let err = time_domain_relative_error(preset, 500.0, 8.0);
        assert!(err < 0.005, "{}: rms error {err}", preset.name());
    }
}

#[test]
fn the_200_hz_device_tracks_the_exact_response_within_2_percent_rms() {
    let err = time_domain_relative_error(Preset::PaperLitter, 200.0, 8.0);
    assert!(err < 0.02, "rms error {err}");
}

#[test]
fn f32_device_stays_within_1e_4_m_s2_of_the_f64_reference_over_60_s_at_500_hz() {
    for preset in Preset::ALL {
        let model = model(preset);
        let reference = model.realization(500.0, &Output::HEAD).unwrap();
        let device: DeviceRealization = reference.cast();
        let (mut s64, mut s32) = (ModalState::<f64>::default(), ModalState::<f32>::default());
        let mut worst = 0.0_f64;
        for u in TestVector::new(1).take(30_000) {
            let y64 = reference.step(&mut s64, u.map(f64::from));
            let y32 = device.step(&mut s32, u);
            for o in 0..3 {
                worst = worst.max((f64::from(y32[o]) - y64[o]).abs());
            }
        }
        assert!(worst < 1e-4, "{}: {worst} m/s^2", preset.name());
    }
}

#[test]
fn the_device_realization_keeps_15_blocks_in_three_axis_groups_for_106_multiply_adds() {
    for preset in Preset::ALL {
        let device = model(preset).device_realization(500.0).unwrap();
        assert_eq!(device.block_count, 15);
        // x drives the 3 longitudinal modes, seen at head x only; y the 6 lateral ones,
        // seen at head y only; z the 6 vertical-pitch ones, seen at head x and z (the
        // sensor sits off the pitch axis).
        let layout: Vec<(u8, Vec<u8>)> = device
            .groups
            .iter()
            .map(|g| (g.block_count, g.outputs().to_vec()))
            .collect();
        assert_eq!(
            layout,
            vec![(3, vec![0]), (6, vec![1]), (6, vec![0, 2])],
            "{}",
            preset.name()
        );
        // Per group: one direct term per row, per block 4 for the state, 2 per row.
        let expected = (1 + 3 * (4 + 2)) + (1 + 6 * (4 + 2)) + (2 + 6 * (4 + 4));
        assert_eq!(device.multiply_adds_per_sample(), expected);
        assert_eq!(expected, 106);
        assert!(device.check().is_ok());
    }
}

#[test]
fn every_rate_from_100_hz_to_2_khz_gives_a_stable_realization_and_others_are_refused() {
    let model = model(Preset::PaperLitter);
    for fs in [100.0, 200.0, 250.0, 500.0, 1000.0, 2000.0] {
        let device = model.device_realization(fs).unwrap();
        assert_eq!(device.check(), Ok(()));
    }
    assert_eq!(
        model.device_realization(99.0).unwrap_err(),
        ModelError::SampleRate
    );
    assert_eq!(
        model.device_realization(2001.0).unwrap_err(),
        ModelError::SampleRate
    );
}

#[test]
fn the_realization_check_rejects_unstable_and_non_finite_coefficients() {
    let good = model(Preset::PaperRigid).device_realization(500.0).unwrap();
    let mut unstable = good;
    unstable.blocks[3].transition_minus_identity[0][0] = 0.01;
    assert_eq!(unstable.check(), Err(RealizationError::Unstable));
    let mut nan = good;
    nan.blocks[0].output[1][0] = f32::NAN;
    assert_eq!(nan.check(), Err(RealizationError::NotFinite));
    let mut too_many = good;
    too_many.block_count = 17;
    assert_eq!(too_many.check(), Err(RealizationError::TooManyBlocks));
    // Layout: groups that do not add up, an output named twice or out of range, a
    // coefficient in a row the group does not use.
    let mut miscounted = good;
    miscounted.groups[1].block_count -= 1;
    assert_eq!(miscounted.check(), Err(RealizationError::Layout));
    let mut twice = good;
    twice.groups[2].outputs[1] = twice.groups[2].outputs[0];
    assert_eq!(twice.check(), Err(RealizationError::Layout));
    let mut out_of_range = good;
    out_of_range.groups[0].outputs[0] = 3;
    assert_eq!(out_of_range.check(), Err(RealizationError::Layout));
    let mut stray_row = good;
    stray_row.blocks[0].output[2][1] = 1e-3;
    assert_eq!(stray_row.check(), Err(RealizationError::Layout));
    let mut stray_direct = good;
    stray_direct.groups[1].feedthrough[1] = 1e-3;
    assert_eq!(stray_direct.check(), Err(RealizationError::Layout));
}

#[test]
fn hold_integrals_match_their_defining_integrals_on_both_sides_of_the_series_switch() {
    // E1(z) = int_0^1 e^(z s) ds and E2(z) = int_0^1 (1 - s) e^(z s) ds, by Simpson's rule.
    use supine_core::model::discrete::hold_integrals;
    let simpson = |z: Complex<f64>, weight: &dyn Fn(f64) -> f64| {
        let n = 2000;
        let h = 1.0 / n as f64;
        let f = |s: f64| (z * s).exp() * weight(s);
        let mut acc = f(0.0) + f(1.0);
        for i in 1..n {
            acc += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        acc * (h / 3.0)
    };
    for radius in [1e-6, 0.009_999, 0.010_001, 0.3, 2.5] {
        for angle in [0.0, 0.7, 1.9, 3.0] {
            let z = Complex::new(f64::cos(angle), f64::sin(angle)) * radius;
            let (phi, e1, e2) = hold_integrals(z);
            assert!(modulus(phi - z.exp()) < 1e-14);
            assert!(modulus(e1 - simpson(z, &|_| 1.0)) < 1e-12, "E1 at {z}");
            assert!(modulus(e2 - simpson(z, &|s| 1.0 - s)) < 1e-12, "E2 at {z}");
        }
    }
}
