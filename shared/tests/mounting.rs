//! Mounting calibration against rotations built independently: a sensor turned by known
//! roll and pitch reads gravity at rest as R^T (0, 0, g); the calibration must recover R and
//! then turn any reading back into the litter's kinematic acceleration.

use supine_core::mounting::{Mounting, MountingError};

/// Litter-from-sensor rotation for a sensor rolled by `roll` about its own x, then pitched
/// by `pitch` about the litter's y: R = Ry(pitch) Rx(roll). No yaw: the sensor's x axis
/// (R's first column) stays in the litter's x-z plane, the calibration's convention.
fn rotation(roll: f64, pitch: f64) -> [[f64; 3]; 3] {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    [
        [cp, sp * sr, sp * cr],
        [0.0, cr, -sr],
        [-sp, cp * sr, cp * cr],
    ]
}

fn transpose_times(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    core::array::from_fn(|j| (0..3).map(|i| r[i][j] * v[i]).sum())
}

#[test]
fn a_tilted_sensor_at_rest_is_calibrated_back_to_its_rotation() {
    let g = 9.79;
    for (roll_deg, pitch_deg) in [
        (0.0, 0.0),
        (30.0, 0.0),
        (0.0, -20.0),
        (-45.0, 15.0),
        (90.0, 10.0),
    ] {
        let r = rotation(f64::to_radians(roll_deg), f64::to_radians(pitch_deg));
        let at_rest = transpose_times(&r, [0.0, 0.0, g]);
        let m = Mounting::from_rest(at_rest).expect("a valid calibration");
        for (got, want) in m.sensor_to_litter.iter().flatten().zip(r.iter().flatten()) {
            assert!(
                (f64::from(*got) - want).abs() < 1e-6,
                "roll {roll_deg}, pitch {pitch_deg}: {:?} vs {r:?}",
                m.sensor_to_litter
            );
        }
        assert!((f64::from(m.gravity_m_s2) - g).abs() < 1e-5);
        // At rest the model's input is zero; moving, it is the litter's acceleration.
        let rest = m.to_litter_m_s2(at_rest.map(|v| v as f32));
        assert!(rest.iter().all(|v| v.abs() < 1e-5), "{rest:?}");
        let a = [0.3, -1.2, 2.5];
        let reading = transpose_times(&r, [a[0], a[1], a[2] + g]);
        let back = m.to_litter_m_s2(reading.map(|v| v as f32));
        for k in 0..3 {
            assert!(
                (f64::from(back[k]) - a[k]).abs() < 1e-5,
                "{back:?} vs {a:?}"
            );
        }
    }
}

#[test]
fn readings_that_cannot_be_gravity_at_rest_are_refused_with_their_reason() {
    assert_eq!(
        Mounting::from_rest([f64::NAN, 0.0, 9.8]),
        Err(MountingError::NotFinite)
    );
    assert_eq!(
        Mounting::from_rest([0.0, 0.0, 3.0]),
        Err(MountingError::Gravity)
    );
    assert_eq!(
        Mounting::from_rest([0.0, 0.0, 0.0]),
        Err(MountingError::Gravity)
    );
    assert_eq!(
        Mounting::from_rest([0.0, 0.0, 15.0]),
        Err(MountingError::Gravity)
    );
    // Sensor x nearly vertical: its horizontal projection cannot fix the heading.
    assert_eq!(
        Mounting::from_rest([9.7, 0.5, 0.5]),
        Err(MountingError::AmbiguousHeading)
    );
}
