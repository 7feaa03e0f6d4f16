//! Mounting calibration: the rotation from the accelerometer's axes to the litter's, found
//! from gravity at rest, and the removal of gravity from every reading.
//!
//! An accelerometer measures specific force: at rest it reads +g along the litter's up
//! axis. The model's input is the support's kinematic acceleration in litter axes
//! (x toward the head, y lateral, z up), so each reading becomes a = R f - (0, 0, g).
//! Gravity fixes two of the three rotation angles; the third is a mounting convention: the
//! sensor's x axis, projected on the horizontal plane, points toward the patient's head.
//! The litter's own tilt during transport is not tracked: a tilt of theta leaks about
//! g theta into the horizontal axes, which the high-pass of the weighting removes when slow.

use core::fmt;

use serde::{Deserialize, Serialize};

/// Standard gravity, m/s^2.
pub const STANDARD_GRAVITY_M_S2: f64 = 9.806_65;

/// Sensor-to-litter rotation and the gravity to remove; a parameter file's
/// `[device.mounting]`, where a key left out keeps its value in [`LEVEL`](Self::LEVEL).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "file-form", serde(default, deny_unknown_fields))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mounting {
    /// Rows are the litter's x, y, z axes in sensor coordinates.
    pub sensor_to_litter: [[f32; 3]; 3],
    /// Gravity as this sensor measured it at rest, m/s^2 (absorbs the sensor's scale error).
    pub gravity_m_s2: f32,
}

/// Why a mounting calibration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MountingError {
    /// A number is NaN or infinite.
    NotFinite,
    /// The rotation is not orthonormal and right-handed within 1e-3.
    NotARotation,
    /// The gravity magnitude is outside 7-12 m/s^2: the sensor was moving or misread.
    Gravity,
    /// The sensor's x axis is within 25 degrees of vertical: the convention cannot fix yaw.
    AmbiguousHeading,
}

impl fmt::Display for MountingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MountingError::NotFinite => "mounting: a number is not finite",
            MountingError::NotARotation => "mounting: the matrix is not a rotation",
            MountingError::Gravity => "mounting: gravity at rest must read 7-12 m/s^2",
            MountingError::AmbiguousHeading => {
                "mounting: the sensor's x axis is too close to vertical to fix the heading"
            }
        })
    }
}

impl core::error::Error for MountingError {}

impl Default for Mounting {
    fn default() -> Self {
        Self::LEVEL
    }
}

impl Mounting {
    /// A sensor mounted level with its axes along the litter's.
    pub const LEVEL: Self = Self {
        sensor_to_litter: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        gravity_m_s2: STANDARD_GRAVITY_M_S2 as f32,
    };

    /// Calibrates from the mean reading at rest (sensor axes, m/s^2).
    pub fn from_rest(mean_sensor_m_s2: [f64; 3]) -> Result<Self, MountingError> {
        if !mean_sensor_m_s2.iter().all(|v| v.is_finite()) {
            return Err(MountingError::NotFinite);
        }
        let g = norm(mean_sensor_m_s2);
        if !(7.0..=12.0).contains(&g) {
            return Err(MountingError::Gravity);
        }
        let up = mean_sensor_m_s2.map(|v| v / g);
        // Sensor x minus its vertical part, normalized: the litter's x.
        let along = up[0];
        if along.abs() > libm::cos(25f64.to_radians()) {
            return Err(MountingError::AmbiguousHeading);
        }
        let x_raw = [1.0 - along * up[0], -along * up[1], -along * up[2]];
        let x_norm = norm(x_raw);
        let x = x_raw.map(|v| v / x_norm);
        let y = cross(up, x);
        let to_f32 = |v: [f64; 3]| v.map(|c| c as f32);
        let mounting = Self {
            sensor_to_litter: [to_f32(x), to_f32(y), to_f32(up)],
            gravity_m_s2: g as f32,
        };
        mounting.validate()?;
        Ok(mounting)
    }

    /// Checks a stored calibration.
    pub fn validate(&self) -> Result<(), MountingError> {
        let r = self.sensor_to_litter;
        if !r
            .iter()
            .flatten()
            .chain([&self.gravity_m_s2])
            .all(|v| v.is_finite())
        {
            return Err(MountingError::NotFinite);
        }
        if !(7.0..=12.0).contains(&self.gravity_m_s2) {
            return Err(MountingError::Gravity);
        }
        // In f32, on the FPU: a 1e-3 tolerance needs no more, and f64 in software would
        // cost the device's flash.
        let rows = r;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f32 = (0..3).map(|k| rows[i][k] * rows[j][k]).sum();
                let expected = if i == j { 1.0 } else { 0.0 };
                if (dot - expected).abs() > 1e-3 {
                    return Err(MountingError::NotARotation);
                }
            }
        }
        let [a, b] = [rows[0], rows[1]];
        let handed = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        if (0..3).any(|k| (handed[k] - rows[2][k]).abs() > 1e-3) {
            return Err(MountingError::NotARotation);
        }
        Ok(())
    }

    /// One reading (sensor axes, m/s^2) to the model's input (litter axes, gravity removed).
    #[inline]
    pub fn to_litter_m_s2(&self, sensor_m_s2: [f32; 3]) -> [f32; 3] {
        let r = &self.sensor_to_litter;
        let f = sensor_m_s2;
        [
            r[0][0] * f[0] + r[0][1] * f[1] + r[0][2] * f[2],
            r[1][0] * f[0] + r[1][1] * f[1] + r[1][2] * f[2],
            r[2][0] * f[0] + r[2][1] * f[1] + r[2][2] * f[2] - self.gravity_m_s2,
        ]
    }
}

fn norm(v: [f64; 3]) -> f64 {
    libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
