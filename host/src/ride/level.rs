//! Levelling a ride by its own gravity: the smallest rotation that takes the ride's mean
//! acceleration (gravity, in whatever direction the logger lay) to the litter's +z.
//!
//! The mean over the whole ride is used, not the quietest window: a vehicle's own
//! accelerations average to about zero over a ride (it ends where it started, at rest),
//! while a quiet window can be a stop on a slope. The smallest rotation (about the axis
//! perpendicular to both gravity and +z, Rodrigues' formula) tilts the horizontal axes no
//! more than gravity asks, so their heading stays as recorded: a phone upright in a holder
//! (gravity on its y) keeps its x across the vehicle. The result is a [`Mounting`], so the
//! conversion is the device's own ([`Mounting::to_litter_m_s2`]).

use serde::Serialize;
use supine_core::mounting::Mounting;

/// How a ride was levelled, for the data-quality account.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Levelling {
    /// `ride-mean` (the ride's own gravity) or `mounting` (`[device.mounting]`).
    pub method: &'static str,
    /// Magnitude of the ride's mean acceleration, m/s^2 (gravity, as the sensor read it).
    pub gravity_m_s2: f64,
    /// Angle between the sensor's z and the vertical, rad.
    pub tilt_rad: f64,
    /// Rotation about the sensor's x that levels its y (roll), rad.
    pub roll_rad: f64,
    /// Rotation about the sensor's y that levels its x (pitch), rad.
    pub pitch_rad: f64,
}

/// Tilt, roll and pitch of a sensor whose mean reading is `g`, rad.
pub fn angles_rad(g: [f64; 3]) -> (f64, f64, f64) {
    let n = norm(g);
    let tilt = (g[2] / n).clamp(-1.0, 1.0).acos();
    let roll = g[1].atan2(g[2]);
    let pitch = (-g[0]).atan2((g[1] * g[1] + g[2] * g[2]).sqrt());
    (tilt, roll, pitch)
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The rotation (rows: litter x, y, z in sensor axes) taking unit vector `u` to +z by the
/// smallest angle; for `u` straight down, the half turn about x.
pub fn rotation_to_up(u: [f64; 3]) -> [[f64; 3]; 3] {
    let [x, y, z] = u;
    if z <= -1.0 + 1e-12 {
        return [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]];
    }
    // Rodrigues for axis u x z = (y, -x, 0), cos = z: R = I + K + K^2 / (1 + z).
    let k = 1.0 / (1.0 + z);
    [
        [1.0 - x * x * k, -x * y * k, -x],
        [-x * y * k, 1.0 - y * y * k, -y],
        [x, y, z],
    ]
}

/// The mounting that levels a ride whose mean acceleration is `mean_m_s2` (litter axes
/// out, gravity's measured magnitude removed), and how.
pub fn level_by_mean(mean_m_s2: [f64; 3]) -> (Mounting, Levelling) {
    let g = norm(mean_m_s2);
    let rotation = rotation_to_up(mean_m_s2.map(|v| v / g));
    let (tilt_rad, roll_rad, pitch_rad) = angles_rad(mean_m_s2);
    let mounting = Mounting {
        sensor_to_litter: rotation.map(|row| row.map(|v| v as f32)),
        gravity_m_s2: g as f32,
    };
    (
        mounting,
        Levelling {
            method: "ride-mean",
            gravity_m_s2: g,
            tilt_rad,
            roll_rad,
            pitch_rad,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
        r.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
    }

    #[test]
    fn gravity_goes_to_up_by_a_rotation_that_keeps_the_heading() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        for u in [
            [0.0, 1.0, 0.0],
            [s, 0.0, s],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.3, -0.5, 0.8124],
        ] {
            let n = norm(u);
            let u = u.map(|v| v / n);
            let r = rotation_to_up(u);
            let up = apply(&r, u);
            assert!(
                (up[2] - 1.0).abs() < 1e-12 && up[0].abs() < 1e-12,
                "{u:?}: {up:?}"
            );
            for i in 0..3 {
                for j in 0..3 {
                    let dot: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
                    assert!((dot - f64::from(u8::from(i == j))).abs() < 1e-12);
                }
            }
        }
        // Upright in a holder (gravity on y): x, across, stays x.
        let r = rotation_to_up([0.0, 1.0, 0.0]);
        assert_eq!(apply(&r, [1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]);
        let (tilt, roll, _) = angles_rad([0.0, 9.81, 0.0]);
        assert!((tilt - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((roll - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
