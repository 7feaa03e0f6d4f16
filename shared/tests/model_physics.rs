//! Physics invariants of the assembled model (docs/model.md#equations-of-motion): symmetry,
//! contact-only forcing, static transmissibility, the decoupling of this geometry, and energy decay.

use nalgebra::{Complex, SMatrix, SymmetricEigen};
use supine_core::model::assembly::{DOF_COUNT, input_matrix};
use supine_core::model::modal::modulus;
use supine_core::model::params::{Element, Quantity};
use supine_core::model::{Axis, Model, ModelParams, Output, ParamId, Preset, SystemMatrices};

fn presets() -> [ModelParams; 2] {
    [
        ModelParams::preset(Preset::PaperRigid),
        ModelParams::preset(Preset::PaperLitter),
    ]
}

/// A parameter set with every joint element zeroed: only contacts remain.
fn contacts_only(params: &ModelParams) -> SystemMatrices {
    let mut p = *params;
    for id in ParamId::ALL.into_iter().filter(|id| !id.is_contact()) {
        p.set(id, 0.0);
    }
    SystemMatrices::assemble(&p)
}

#[test]
fn mass_damping_and_stiffness_matrices_are_symmetric() {
    for params in presets() {
        let m = SystemMatrices::assemble(&params);
        for matrix in [&m.mass, &m.damping, &m.stiffness] {
            let scale = matrix.amax();
            assert!((matrix - matrix.transpose()).amax() <= 1e-12 * scale);
        }
    }
}

#[test]
fn stiffness_and_damping_times_g_hold_only_the_contact_terms() {
    for params in presets() {
        let full = SystemMatrices::assemble(&params);
        let contacts = contacts_only(&params);
        let g = input_matrix();
        let kg = full.stiffness * g;
        let cg = full.damping * g;
        assert!((kg - contacts.stiffness * g).amax() <= 1e-9 * kg.amax());
        assert!((cg - contacts.damping * g).amax() <= 1e-9 * cg.amax());
        // And the contact terms are exactly the diagonal contact values.
        for id in ParamId::ALL.into_iter().filter(|id| id.is_contact()) {
            let Element::Contact { segment } = id.element else {
                unreachable!()
            };
            let row = 6 * segment.index() + id.axis.index();
            let value = match id.quantity {
                Quantity::Stiffness => kg[(row, id.axis.index())],
                Quantity::Damping => cg[(row, id.axis.index())],
            };
            assert!((value - params.get(id)).abs() <= 1e-9 * params.get(id).abs().max(1.0));
        }
    }
}

#[test]
fn transmissibility_tends_to_one_on_matching_axes_and_zero_elsewhere_as_frequency_falls() {
    for params in presets() {
        let h = SystemMatrices::assemble(&params)
            .transmissibility(1e-4)
            .unwrap();
        for output in Output::ALL {
            for input in Axis::ALL {
                let expected = if output.axis == input { 1.0 } else { 0.0 };
                let got = h[(output.index(), input.index())];
                assert!(
                    modulus(got - Complex::new(expected, 0.0)) < 1e-4,
                    "{output} from {input}: {got}"
                );
            }
        }
    }
}

#[test]
fn the_fifteen_components_this_geometry_decouples_are_zero_and_the_twelve_are_not() {
    use supine_core::model::response::COUPLED_COMPONENTS;
    for params in presets() {
        let m = SystemMatrices::assemble(&params);
        for freq_hz in [0.5, 2.0, 4.7, 8.0, 16.0] {
            let h = m.transmissibility(freq_hz).unwrap();
            let mut zero = 0;
            for output in Output::ALL {
                for input in Axis::ALL {
                    let value = modulus(h[(output.index(), input.index())]);
                    if COUPLED_COMPONENTS.contains(&(output, input)) {
                        assert!(value > 1e-4, "{output}/{input} at {freq_hz} Hz: {value}");
                    } else {
                        assert!(value < 1e-12, "{output}/{input} at {freq_hz} Hz: {value}");
                        zero += 1;
                    }
                }
            }
            assert_eq!(zero, 15);
        }
    }
}

#[test]
fn damping_is_positive_semidefinite_and_stiffness_positive_definite() {
    for params in presets() {
        let m = SystemMatrices::assemble(&params);
        let c = SymmetricEigen::new(m.damping).eigenvalues;
        assert!(c.min() >= -1e-9 * c.max(), "damping eigenvalues {c}");
        // Roll has no contact: K is singular there, positive elsewhere.
        let k = SymmetricEigen::new(m.stiffness).eigenvalues;
        assert!(k.min() >= -1e-9 * k.max());
        assert_eq!(
            k.iter().filter(|v| **v < 1e-9 * k.max()).count(),
            1,
            "one free roll"
        );
    }
}

#[test]
fn free_response_energy_never_grows_and_decays() {
    // E = 1/2 v^T M v + 1/2 y^T K y with y' = v, M v' = -C v - K y; classical RK4.
    let params = ModelParams::preset(Preset::PaperLitter);
    let m = SystemMatrices::assemble(&params);
    let inv_m =
        SMatrix::<f64, DOF_COUNT, DOF_COUNT>::from_diagonal(&m.mass.diagonal().map(|v| 1.0 / v));
    let energy = |y: &SMatrix<f64, DOF_COUNT, 1>, v: &SMatrix<f64, DOF_COUNT, 1>| {
        0.5 * (v.transpose() * m.mass * v)[0] + 0.5 * (y.transpose() * m.stiffness * y)[0]
    };
    let accel = |y: &SMatrix<f64, DOF_COUNT, 1>, v: &SMatrix<f64, DOF_COUNT, 1>| {
        -(inv_m * (m.damping * v + m.stiffness * y))
    };
    let mut y = SMatrix::<f64, DOF_COUNT, 1>::from_fn(|i, _| if i % 6 < 3 { 0.01 } else { 0.02 });
    let mut v = SMatrix::<f64, DOF_COUNT, 1>::from_fn(|i, _| 0.05 * ((i % 5) as f64 - 2.0));
    let e0 = energy(&y, &v);
    let dt = 2e-5;
    let mut previous = e0;
    for step in 0..100_000 {
        let (k1y, k1v) = (v, accel(&y, &v));
        let (k2y, k2v) = (
            v + k1v * (dt / 2.0),
            accel(&(y + k1y * (dt / 2.0)), &(v + k1v * (dt / 2.0))),
        );
        let (k3y, k3v) = (
            v + k2v * (dt / 2.0),
            accel(&(y + k2y * (dt / 2.0)), &(v + k2v * (dt / 2.0))),
        );
        let (k4y, k4v) = (v + k3v * dt, accel(&(y + k3y * dt), &(v + k3v * dt)));
        y += (k1y + k2y * 2.0 + k3y * 2.0 + k4y) * (dt / 6.0);
        v += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (dt / 6.0);
        if step % 1000 == 999 {
            let e = energy(&y, &v);
            assert!(
                e <= previous * (1.0 + 1e-9),
                "energy grew at step {step}: {previous} -> {e}"
            );
            previous = e;
        }
    }
    assert!(
        previous < 0.5 * e0,
        "after 2 s the energy should have at least halved: {e0} -> {previous}"
    );
}

#[test]
fn every_reachable_mode_is_stable_and_only_roll_is_unreachable() {
    for params in presets() {
        let model = Model::new(&params).unwrap();
        for mode in &model.modes.components {
            if mode.reachable {
                assert!(mode.eigenvalue.re < 0.0, "{mode:?}");
            } else {
                assert_eq!(mode.subsystem, supine_core::model::Subsystem::Roll);
            }
        }
        let reachable = model
            .modes
            .components
            .iter()
            .filter(|m| m.reachable)
            .count();
        assert!(reachable >= 15, "{reachable}");
    }
}
