//! The relative-coordinate state space and the modal decomposition both reproduce the
//! directly solved transmissibility.

use supine_core::model::modal::modulus;
use supine_core::model::{Model, ModelParams, Preset, Transmissibility};

fn max_error(a: &Transmissibility, b: &Transmissibility) -> f64 {
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| modulus(*x - *y))
        .fold(0.0, f64::max)
}

fn max_magnitude(a: &Transmissibility) -> f64 {
    a.iter().map(|x| modulus(*x)).fold(0.0, f64::max)
}

#[test]
fn continuous_state_space_reproduces_h_to_1e_9() {
    // From 0.25 Hz: at exactly 0 Hz the free whole-body roll makes A singular.
    for preset in Preset::ALL {
        let model = Model::new(&ModelParams::preset(preset)).unwrap();
        for i in 1..=80 {
            let freq_hz = 0.25 * i as f64;
            let direct = model.matrices.transmissibility(freq_hz).unwrap();
            let ss = model.state_space.frequency_response(freq_hz).unwrap();
            let err = max_error(&direct, &ss);
            assert!(
                err <= 1e-9 * max_magnitude(&direct).max(1.0),
                "{freq_hz} Hz: {err}"
            );
        }
    }
}

#[test]
fn modal_decomposition_reproduces_h_to_1e_9() {
    for preset in Preset::ALL {
        let model = Model::new(&ModelParams::preset(preset)).unwrap();
        for i in 1..=80 {
            let freq_hz = 0.25 * i as f64;
            let direct = model.matrices.transmissibility(freq_hz).unwrap();
            let modal = model.modes.frequency_response(freq_hz);
            let err = max_error(&direct, &modal);
            assert!(
                err <= 1e-9 * max_magnitude(&direct).max(1.0),
                "{freq_hz} Hz: {err}"
            );
        }
    }
}
