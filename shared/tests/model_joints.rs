//! The joint outputs (docs/model.md#joint-motion) against what they mean: the joint points'
//! relative displacement computed from the segments' motions with explicit cross products,
//! the static deflection under a constant support acceleration solved here from K and M,
//! the modal sum against the direct solution, and the realization against both.

use nalgebra::{DMatrix, DVector, SVector, Vector3};
use supine_core::model::assembly::{DOF_COUNT, rotation_dof, translation_dof};
use supine_core::model::geometry::Body;
use supine_core::model::modal::{argument, modulus};
use supine_core::model::params::JointId;
use supine_core::model::{
    Axis, JOINT_OUTPUT_COUNT, JointComponent, JointOutput, ModalState, Model, ModelParams, Preset,
    Segment,
};

fn models() -> Vec<Model> {
    Preset::ALL
        .iter()
        .map(|&p| Model::new(&ModelParams::preset(p)).unwrap())
        .collect()
}

fn vec3(q: &SVector<f64, DOF_COUNT>, dof: impl Fn(Axis) -> usize) -> Vector3<f64> {
    Vector3::new(q[dof(Axis::X)], q[dof(Axis::Y)], q[dof(Axis::Z)])
}

/// The ten joint outputs of the coordinates q, from the definitions: the upper segment's
/// joint point minus the lower one's (u + th x r), and th_upper - th_lower.
fn joint_motion_by_definition(body: &Body, q: &SVector<f64, DOF_COUNT>) -> [f64; 10] {
    let mut out = [0.0; 10];
    for (k, joint) in [JointId::HeadTorso, JointId::TorsoPelvis]
        .iter()
        .enumerate()
    {
        let (upper, lower) = (joint.head_side(), joint.feet_side());
        // The joint lies toward the feet (-x) of the upper centre, toward the head of the lower.
        let r_upper = Vector3::new(-body.segments[upper.index()].to_feet_joint_m, 0.0, 0.0);
        let r_lower = Vector3::new(body.segments[lower.index()].to_head_joint_m, 0.0, 0.0);
        let point = |s: Segment, r: &Vector3<f64>| {
            vec3(q, |a| translation_dof(s, a)) + vec3(q, |a| rotation_dof(s, a)).cross(r)
        };
        let d = point(upper, &r_upper) - point(lower, &r_lower);
        let rot = vec3(q, |a| rotation_dof(upper, a)) - vec3(q, |a| rotation_dof(lower, a));
        out[5 * k..5 * k + 5].copy_from_slice(&[d.x, d.y, d.z, rot.y, rot.z]);
    }
    out
}

#[test]
fn the_joint_outputs_are_the_joint_points_relative_displacement_and_the_relative_rotation() {
    for model in models() {
        let body = Body::dempster(&model.params.subject);
        let mut seed = 12345u64;
        for _ in 0..20 {
            let q = SVector::<f64, DOF_COUNT>::from_fn(|_, _| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            });
            let by_matrix = model.matrices.joint_output * q;
            let expected = joint_motion_by_definition(&body, &q);
            for o in 0..JOINT_OUTPUT_COUNT {
                assert!(
                    (by_matrix[o] - expected[o]).abs() < 1e-12,
                    "{}: {} against {}",
                    JointOutput::ALL[o],
                    by_matrix[o],
                    expected[o]
                );
            }
        }
    }
}

/// Solves K y = -M G a on the coordinates with stiffness (all but roll: no translation of
/// the support loads it, and whole-body roll is free).
fn static_deflection(model: &Model, a_m_s2: [f64; 3]) -> SVector<f64, DOF_COUNT> {
    let roll = [3, 9, 15];
    let kept: Vec<usize> = (0..DOF_COUNT).filter(|i| !roll.contains(i)).collect();
    let m = &model.matrices;
    let k = DMatrix::from_fn(kept.len(), kept.len(), |i, j| {
        m.stiffness[(kept[i], kept[j])]
    });
    let rhs = DVector::from_fn(kept.len(), |i, _| {
        let d = kept[i];
        -(0..3)
            .map(|axis| m.mass[(d, d)] * m.input[(d, axis)] * a_m_s2[axis])
            .sum::<f64>()
    });
    let y = k.lu().solve(&rhs).unwrap();
    let mut full = SVector::zeros();
    for (i, &d) in kept.iter().enumerate() {
        full[d] = y[i];
    }
    full
}

#[test]
fn under_a_constant_support_acceleration_the_joints_deflect_as_k_y_equals_minus_m_g_a() {
    let a = [1.3, -0.7, 2.1];
    for model in models() {
        let body = Body::dempster(&model.params.subject);
        let expected = joint_motion_by_definition(&body, &static_deflection(&model, a));
        let direct = model.matrices.joint_response(0.0).unwrap();
        let modal = model.modes.joint_response(0.0);
        // The f64 realization, driven until settled (the slowest mode decays in seconds).
        let realization = model.realization(500.0, &JointOutput::ALL).unwrap();
        let mut state = ModalState::<f64>::default();
        let mut settled = [0.0; JOINT_OUTPUT_COUNT];
        for _ in 0..500 * 120 {
            settled = realization.step(&mut state, a);
        }
        let scale = expected.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(scale > 1e-6, "a deflection to compare: {scale}");
        for o in 0..JOINT_OUTPUT_COUNT {
            let direct_o: f64 = (0..3).map(|k| direct[(o, k)].re * a[k]).sum();
            let modal_o: f64 = (0..3).map(|k| modal[(o, k)].re * a[k]).sum();
            let name = JointOutput::ALL[o];
            assert!(
                (direct_o - expected[o]).abs() < 1e-9 * scale,
                "{name} direct"
            );
            assert!((modal_o - expected[o]).abs() < 1e-7 * scale, "{name} modal");
            assert!(
                (settled[o] - expected[o]).abs() < 1e-6 * scale,
                "{name} realization {} against {}",
                settled[o],
                expected[o]
            );
        }
    }
}

#[test]
fn the_modal_joint_response_equals_the_direct_solution_and_each_output_has_one_input_axis() {
    for model in models() {
        for i in 0..=40 {
            let f = 0.5 * i as f64;
            let direct = model.matrices.joint_response(f).unwrap();
            let modal = model.modes.joint_response(f);
            for output in JointOutput::ALL {
                let o = output.index();
                let own = direct[(o, output.input_axis().index())];
                assert!(modulus(own) > 0.0, "{output} at {f} Hz");
                for axis in Axis::ALL {
                    let (d, m) = (direct[(o, axis.index())], modal[(o, axis.index())]);
                    assert!(
                        modulus(d - m) <= 1e-7 * modulus(own),
                        "{output} {axis} {f} Hz"
                    );
                    if axis != output.input_axis() {
                        assert!(modulus(d) <= 1e-12 * modulus(own), "{output} from {axis}");
                    }
                }
            }
        }
    }
}

#[test]
fn the_joint_outputs_are_named_and_ordered_as_documented() {
    let names: Vec<&str> = JointOutput::ALL.iter().map(|o| o.name()).collect();
    assert_eq!(
        names,
        [
            "neck_x",
            "neck_y",
            "neck_z",
            "neck_ry",
            "neck_rz",
            "low_back_x",
            "low_back_y",
            "low_back_z",
            "low_back_ry",
            "low_back_rz"
        ]
    );
    for (k, o) in JointOutput::ALL.iter().enumerate() {
        assert_eq!(o.index(), k);
        assert_eq!(JointOutput::from_name(o.name()), Some(*o));
    }
    assert!(JointOutput::ALL[3].component == JointComponent::Ry);
}

#[test]
fn the_realization_of_the_joint_outputs_is_within_1_percent_and_1_degree_at_500_hz() {
    for model in models() {
        let realization = model.realization(500.0, &JointOutput::ALL).unwrap();
        for i in 0..=390 {
            let f = 0.5 + 0.05 * i as f64;
            let h = model.matrices.joint_response(f).unwrap();
            let hd = realization.frequency_response(500.0, f);
            for output in JointOutput::ALL {
                let (o, k) = (output.index(), output.input_axis().index());
                let (c, d) = (h[(o, k)], hd[o][k]);
                assert!(
                    (modulus(d) / modulus(c) - 1.0).abs() < 0.01,
                    "{output} {f} Hz"
                );
                assert!(argument(d / c).to_degrees().abs() < 1.0, "{output} {f} Hz");
            }
        }
    }
}

#[test]
fn the_device_readout_of_the_joints_is_within_1_percent_and_1_degree_of_the_model_at_500_hz() {
    for model in models() {
        let head = model.device_realization(500.0).unwrap();
        let readout = model
            .device_joint_readout(500.0, &head, &JointOutput::ALL)
            .unwrap();
        let (mut worst_mag, mut worst_deg) = (0.0_f64, 0.0_f64);
        for i in 0..=390 {
            let f = 0.5 + 0.05 * i as f64;
            let h = model.matrices.joint_response(f).unwrap();
            let hd = readout.frequency_response(&head, 500.0, f);
            for output in JointOutput::ALL {
                let (o, k) = (output.index(), output.input_axis().index());
                let (c, d) = (h[(o, k)], hd[o][k]);
                worst_mag = worst_mag.max((modulus(d) / modulus(c) - 1.0).abs());
                worst_deg = worst_deg.max(argument(d / c).to_degrees().abs());
                for other in Axis::ALL.into_iter().filter(|a| a.index() != k) {
                    assert_eq!(modulus(hd[o][other.index()]), 0.0, "{output} {other}");
                }
            }
        }
        assert!(worst_mag < 0.01, "magnitude error {worst_mag}");
        assert!(worst_deg < 1.0, "phase error {worst_deg} deg");
    }
}

#[test]
fn the_readout_reads_in_time_what_the_f64_realization_of_the_joints_gives() {
    // The f32 readout, read from the head realization's state before each step, against
    // the f64 realization of the ten joint outputs alone.
    use supine_core::test_vector::TestVector;
    for model in models() {
        let head = model.device_realization(500.0).unwrap();
        let readout = model
            .device_joint_readout(500.0, &head, &JointOutput::ALL)
            .unwrap();
        let reference = model.realization(500.0, &JointOutput::ALL).unwrap();
        let (mut s32, mut s64) = (ModalState::<f32>::default(), ModalState::<f64>::default());
        let mut peak = [0.0_f64; JOINT_OUTPUT_COUNT];
        let mut worst = [0.0_f64; JOINT_OUTPUT_COUNT];
        for u in TestVector::new(3).take(30_000) {
            let joints = readout.read(&head, &s32, u);
            head.step(&mut s32, u);
            let expected = reference.step(&mut s64, u.map(f64::from));
            for o in 0..JOINT_OUTPUT_COUNT {
                peak[o] = peak[o].max(expected[o].abs());
                worst[o] = worst[o].max((f64::from(joints[o]) - expected[o]).abs());
            }
        }
        for o in 0..JOINT_OUTPUT_COUNT {
            assert!(peak[o] > 0.0);
            assert!(
                worst[o] < 1e-4 * peak[o],
                "{}: {} of a peak {}",
                JointOutput::ALL[o],
                worst[o],
                peak[o]
            );
        }
    }
}

#[test]
fn a_readout_reads_only_the_joint_outputs_asked_for_and_a_bad_one_is_refused() {
    let model = &models()[0];
    let head = model.device_realization(500.0).unwrap();
    let wanted = [JointOutput::ALL[2], JointOutput::ALL[8]];
    let readout = model.device_joint_readout(500.0, &head, &wanted).unwrap();
    for output in JointOutput::ALL {
        assert_eq!(readout.reads(output), wanted.contains(&output), "{output}");
    }
    let y = readout.read(&head, &ModalState::default(), [0.0, 0.0, 1.0]);
    for output in JointOutput::ALL {
        assert_eq!(
            y[output.index()] != 0.0,
            wanted.contains(&output),
            "{output}"
        );
    }
    let all = model
        .device_joint_readout(500.0, &head, &JointOutput::ALL)
        .unwrap();
    assert_eq!(all.check(), Ok(()));
    let mut unread = all;
    unread.rows[15][0][0] = 1.0; // past the 15 blocks in use: never read
    assert_eq!(unread.check(), Ok(()));
    let mut bad = all;
    bad.rows[3][1][0] = f32::INFINITY; // a coefficient in use
    assert!(bad.check().is_err());
    let mut bad = all;
    bad.groups[1].outputs.swap(0, 1); // out of order within its axis
    assert!(bad.check().is_err());
    let mut bad = all;
    bad.groups[0].outputs[1] = bad.groups[1].outputs[0]; // a y output in the x group
    assert!(bad.check().is_err());
    let mut bad = all;
    bad.groups[2].feedthrough[0] = f32::NAN;
    assert!(bad.check().is_err());
}

#[test]
fn a_readout_encodes_as_its_fields_in_order_and_decodes_back() {
    let model = &models()[1];
    let head = model.device_realization(500.0).unwrap();
    let readout = model
        .device_joint_readout(500.0, &head, &JointOutput::ALL)
        .unwrap();
    let mut buf = [0u8; 4096];
    let bytes = postcard::to_slice(&readout, &mut buf).unwrap().to_vec();
    // The same bytes as the fields encoded one after the other with serde's own code.
    let mut expected = Vec::new();
    let mut field = [0u8; 4096];
    for g in &readout.groups {
        expected.extend_from_slice(postcard::to_slice(&g.row_count, &mut field).unwrap());
        expected.extend_from_slice(postcard::to_slice(&g.outputs, &mut field).unwrap());
        expected.extend_from_slice(postcard::to_slice(&g.feedthrough, &mut field).unwrap());
    }
    expected.extend_from_slice(postcard::to_slice(&readout.rows, &mut field).unwrap());
    assert_eq!(bytes, expected);
    let back: supine_core::model::JointReadout = postcard::from_bytes(&bytes).unwrap();
    assert_eq!(back, readout);
    // One number short is refused, not read past.
    assert!(
        postcard::from_bytes::<supine_core::model::JointReadout>(&bytes[..bytes.len() - 4])
            .is_err()
    );
}

/// Every selection of the joint outputs (all 1,024 masks) taken from the readout of all
/// ten is, bit for bit, the readout built for that selection from the modal analysis;
/// and its Rust definition reads what the device's loops read (here the same code; on the
/// device the self-test compares it with the assembly for every mask).
#[test]
fn every_selection_taken_from_the_full_readout_is_the_readout_built_for_it() {
    use supine_core::test_vector::TestVector;
    for model in models() {
        let head = model.device_realization(500.0).unwrap();
        let all = model
            .device_joint_readout(500.0, &head, &JointOutput::ALL)
            .unwrap();
        let mut states = Vec::new();
        let mut s = ModalState::<f32>::default();
        for u in TestVector::new(5).take(40) {
            states.push((s, u));
            head.step(&mut s, u);
        }
        let mut shapes = std::collections::BTreeSet::new();
        for mask in 0..1u16 << JOINT_OUTPUT_COUNT {
            let wanted: Vec<JointOutput> = JointOutput::ALL
                .into_iter()
                .filter(|o| mask & (1 << o.index()) != 0)
                .collect();
            let built = model.device_joint_readout(500.0, &head, &wanted).unwrap();
            let selected = all.select(&head, mask);
            assert_eq!(selected, built, "mask {mask:#05x}");
            assert_eq!(selected.mask(), mask);
            shapes.insert(selected.groups.map(|g| g.row_count));
            for (state, u) in &states {
                let (mut a, mut b) = ([0.0; JOINT_OUTPUT_COUNT], [0.0; JOINT_OUTPUT_COUNT]);
                let n = selected.read_packed(&head, state, *u, &mut a);
                assert_eq!(selected.read_packed_by::<true>(&head, state, *u, &mut b), n);
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
            }
        }
        // x reads 0-2 rows, y and z 0-4 each: every combination occurs.
        assert_eq!(shapes.len(), 3 * 5 * 5);
    }
}
