//! Parameter validation names the field and the problem; nothing panics.

use supine_core::model::params::{ParamField, Problem};
use supine_core::model::{Axis, Model, ModelError, ModelParams, ParamId, Preset, Segment};

fn paper() -> ModelParams {
    ModelParams::preset(Preset::PaperLitter)
}

#[test]
fn every_stiffness_and_damping_that_is_negative_zero_or_not_finite_is_named() {
    for id in ParamId::ALL {
        for (value, problem) in [
            (-1.0, Problem::NotPositive),
            (0.0, Problem::NotPositive),
            (f64::NAN, Problem::NotFinite),
            (f64::INFINITY, Problem::NotFinite),
        ] {
            let mut p = paper();
            p.set(id, value);
            let err = p.validate().unwrap_err();
            assert_eq!((err.field, err.problem), (ParamField::Param(id), problem));
            assert_eq!(Model::new(&p).unwrap_err(), ModelError::Params(err));
        }
    }
}

#[test]
fn height_and_mass_must_be_positive_and_finite() {
    let mut p = paper();
    p.subject.height_m = 0.0;
    assert_eq!(p.validate().unwrap_err().field, ParamField::HeightM);
    let mut p = paper();
    p.subject.mass_kg = f64::NEG_INFINITY;
    let err = p.validate().unwrap_err();
    assert_eq!(
        (err.field, err.problem),
        (ParamField::MassKg, Problem::NotFinite)
    );
    assert_eq!(err.to_string(), "subject.mass_kg: must be a finite number");
}

/// A change that makes parameters invalid.
type Spoil = fn(&mut ModelParams);

/// Finite and positive is not enough: a subnormal mass or a 1e308 stiffness is a unit
/// mistake, and the modal analysis need not converge on it. Each is refused by name with
/// the range it must be in, and the range's own ends are accepted.
#[test]
fn implausible_magnitudes_are_refused_with_the_field_and_its_range() {
    let stiffness = ParamId::ALL[0];
    let cases: [(Spoil, ParamField, &str); 5] = [
        (
            |p| p.subject.mass_kg = 1e-310,
            ParamField::MassKg,
            "subject.mass_kg: must be within 2 to 300",
        ),
        (
            |p| p.subject.height_m = 0.3,
            ParamField::HeightM,
            "subject.height_m: must be within 0.5 to 2.5",
        ),
        (
            |p| p.subject.height_m = 18.2,
            ParamField::HeightM,
            "subject.height_m: must be within 0.5 to 2.5",
        ),
        (
            |p| p.set(ParamId::ALL[0], 1e308),
            ParamField::Param(ParamId::ALL[0]),
            "must be within 0.000001 to 1000000000",
        ),
        (
            |p| p.set(ParamId::ALL[41], 1e-9),
            ParamField::Param(ParamId::ALL[41]),
            "must be within 0.000001 to 1000000000",
        ),
    ];
    for (spoil, field, message) in cases {
        let mut p = paper();
        spoil(&mut p);
        let err = p.validate().unwrap_err();
        assert_eq!((err.field, err.problem), (field, Problem::OutOfRange));
        assert!(err.to_string().ends_with(message), "{err}");
        assert_eq!(Model::new(&p).unwrap_err(), ModelError::Params(err));
    }
    let mut p = paper();
    p.set(stiffness, 1e9);
    p.set(ParamId::ALL[41], 1e-6);
    p.subject.mass_kg = 300.0;
    p.subject.height_m = 0.5;
    assert_eq!(p.validate(), Ok(()));
}

#[test]
fn sensor_offsets_must_be_finite_and_within_half_a_metre() {
    let mut p = paper();
    p.set_sensor_offset_m(Segment::Torso, Axis::Z, 0.7);
    let err = p.validate().unwrap_err();
    assert_eq!(
        (err.field, err.problem),
        (
            ParamField::SensorOffsetM {
                segment: Segment::Torso,
                axis: Axis::Z
            },
            Problem::OutOfRange
        )
    );
    let mut p = paper();
    p.set_sensor_offset_m(Segment::Head, Axis::Y, f64::NAN);
    assert_eq!(p.validate().unwrap_err().problem, Problem::NotFinite);
}

#[test]
fn parameter_ids_are_42_distinct_and_round_trip_through_get_and_set() {
    let mut p = paper();
    for (i, id) in ParamId::ALL.into_iter().enumerate() {
        assert_eq!(id.index(), i);
        p.set(id, 1000.0 + i as f64);
    }
    for (i, id) in ParamId::ALL.into_iter().enumerate() {
        assert_eq!(p.get(id), 1000.0 + i as f64);
    }
    let names: std::collections::BTreeSet<String> =
        ParamId::ALL.iter().map(|id| id.to_string()).collect();
    assert_eq!(names.len(), 42);
    assert_eq!(
        p.joints.head_torso.rotational.stiffness_nm_per_rad.y,
        p.get(ParamId::ALL[7])
    );
}

#[test]
fn presets_carry_the_papers_tables() {
    let rigid = ModelParams::preset(Preset::PaperRigid);
    let litter = ModelParams::preset(Preset::PaperLitter);
    assert_eq!(rigid.joints, litter.joints);
    assert_eq!(
        rigid.joints.head_torso.translational.stiffness_n_per_m.z,
        122987.8
    );
    assert_eq!(
        rigid.joints.torso_pelvis.rotational.damping_nm_s_per_rad.z,
        4992.1
    );
    assert_eq!(litter.contacts.torso.stiffness_n_per_m.z, 0.8);
    assert_eq!(rigid.contacts.pelvis.damping_n_s_per_m.z, 0.156);
    assert!(rigid.validate().is_ok() && litter.validate().is_ok());
}
