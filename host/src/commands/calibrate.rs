//! `supine calibrate`: the mounting calibration from the accelerometer's reading at rest,
//! or the sensor's own calibration from a static tumble test.
//!
//! With the litter level and still, the sensor reads gravity only; its direction fixes the
//! rotation from sensor to litter axes (and the sensor's x axis, projected on the
//! horizontal, is taken as the litter's x: toward the head). The result is the
//! `[device.mounting]` table of a parameter file, which `supine flash` puts in the blob.
//!
//! With `--tumble FILE.csv`: the sensor held still in six orientations (each axis up, then
//! down) gives each axis's sensitivity and offset ([`tumble_axis`]); the result is the
//! `[device.calibration]` table, dated and signed.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use supine_core::calibration::{CalibrationMethod, SensorCalibration, tumble_axis};
use supine_core::mounting::{Mounting, STANDARD_GRAVITY_M_S2};

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::device::device_records::{MountingSummary, TumbleCalibrationSummary};
use crate::io::calibration_section::{calibration_toml, parse_date, today};
use crate::io::params_file::mounting_toml;
use crate::io::stdout::print_text;
use crate::io::tumble_csv::{self, ORIENTATIONS, TumbleReadings};

/// Arguments of `supine calibrate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mean accelerometer reading at rest, sensor axes x,y,z in m/s^2 (e.g. the mean of a
    /// few seconds of samples with the litter level and still; spaces after the commas
    /// are fine).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        required_unless_present = "tumble",
        conflicts_with = "tumble"
    )]
    pub at_rest_m_s2: Option<String>,
    /// A static tumble test's readings (CSV `orientation,x_m_s2,y_m_s2,z_m_s2`, the sensor
    /// still with +x, -x, +y, -y, +z, -z up in turn): prints the `[device.calibration]`
    /// table, each axis's sensitivity and offset.
    #[arg(long, value_name = "FILE.csv")]
    pub tumble: Option<PathBuf>,
    /// With --tumble: who did the test (name or initials, at most 16 bytes).
    #[arg(long, value_name = "NAME", requires = "tumble")]
    pub by: Option<String>,
    /// With --tumble: the day of the test, YYYY-MM-DD (default: today, UTC).
    #[arg(long, value_name = "YYYY-MM-DD", requires = "tumble")]
    pub date: Option<String>,
    /// With --tumble: months until the sensor is due again (reports flag it after).
    #[arg(long, value_name = "MONTHS", requires = "tumble",
          default_value_t = SensorCalibration::DEFAULT_INTERVAL_MONTHS)]
    pub interval_months: u8,
    /// Print the mounting as JSON instead of the TOML table.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// The three numbers of `--at-rest-m-s2`.
fn reading(text: &str) -> Result<[f64; 3]> {
    let items = values::comma_list("--at-rest-m-s2", &[text.to_string()])?;
    let numbers = items
        .iter()
        .map(|item| {
            item.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    anyhow!("--at-rest-m-s2: expected a number in m/s^2, found {item:?}")
                })
        })
        .collect::<Result<Vec<f64>>>()?;
    <[f64; 3]>::try_from(numbers.as_slice()).map_err(|_| {
        anyhow!(
            "--at-rest-m-s2: expected three numbers X,Y,Z, found {}",
            numbers.len()
        )
    })
}

/// `value` with the round-off of an exact zero or one removed (a computed rotation holds
/// entries like -8.7e-19 where the exact answer is 0): rounded to 12 decimals, far below
/// any accelerometer's resolution, and never -0.
fn tidy(value: f32) -> f32 {
    let rounded = (f64::from(value) * 1e12).round() / 1e12;
    if rounded == 0.0 { 0.0 } else { rounded as f32 }
}

/// Each axis's sensitivity and offset from the six orientations' mean readings, with
/// `g_m_s2` the true acceleration of 1 g.
pub fn tumble_calibration(readings: &TumbleReadings, g_m_s2: f64) -> ([f64; 3], [f64; 3]) {
    let m = &readings.mean_m_s2;
    let mut sensitivity = [0.0; 3];
    let mut offset = [0.0; 3];
    for axis in 0..3 {
        let (up, down) = (m[2 * axis][axis], m[2 * axis + 1][axis]);
        let others: Vec<f64> = (0..6)
            .filter(|k| k / 2 != axis)
            .map(|k| m[k][axis])
            .collect();
        let level = [others[0], others[1], others[2], others[3]];
        (sensitivity[axis], offset[axis]) = tumble_axis(up, down, level, g_m_s2);
    }
    (sensitivity, offset)
}

/// Prints the `[device.calibration]` table of a tumble test, or says why it cannot be one.
fn run_tumble(args: &Args, path: &std::path::Path) -> Result<()> {
    let readings = tumble_csv::read(path)?;
    // Each orientation must read about 1 g in all: else the sensor moved, or the row's
    // orientation is not the one written.
    for (k, mean) in readings.mean_m_s2.iter().enumerate() {
        let g = mean.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(7.0..=12.0).contains(&g) {
            return Err(anyhow!(
                "{}: orientation {}: expected a still reading of about 1 g (7-12 m/s^2), \
                 found {g:.3} m/s^2",
                path.display(),
                ORIENTATIONS[k]
            ));
        }
    }
    let date = match &args.date {
        Some(text) => parse_date(text).map_err(|e| anyhow!("--date: {e}"))?,
        None => {
            let d = today();
            supine_core::calibration::CalibrationDate {
                year: d.year() as u16,
                month: u8::from(d.month()),
                day: d.day(),
            }
        }
    };
    let by = args.by.as_deref().unwrap_or("").trim();
    let by = SensorCalibration::by_field(by)
        .ok_or_else(|| anyhow!("--by: expected a name of at most 16 bytes, found {by:?}"))?;
    let (sensitivity, offset) = tumble_calibration(&readings, STANDARD_GRAVITY_M_S2);
    let calibration = SensorCalibration {
        sensitivity: sensitivity.map(|v| v as f32),
        offset_m_s2: offset.map(|v| v as f32),
        date,
        method: CalibrationMethod::Tumble,
        by,
        interval_months: args.interval_months,
    };
    calibration
        .validate()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    if args.json.json {
        return json_output::print(&TumbleCalibrationSummary::new(
            path.display().to_string(),
            readings.rows,
            &calibration,
        ));
    }
    print_text(&format!(
        "# Sensor calibration from a static tumble test ({}, {} rows), 1 g = {} m/s^2.\n\
         # Each axis reads sensitivity * true + offset; the device corrects every reading\n\
         # before the mounting rotation.\n{}",
        path.display(),
        readings.rows.iter().sum::<usize>(),
        STANDARD_GRAVITY_M_S2,
        calibration_toml(calibration)?
    ))
}

/// Prints the `[device.mounting]` table for the reading (or, with `--tumble`, the
/// `[device.calibration]` table), or says why it cannot be one.
pub fn run(args: &Args) -> Result<()> {
    if let Some(path) = &args.tumble {
        return run_tumble(args, path);
    }
    let [x, y, z] = reading(args.at_rest_m_s2.as_deref().unwrap_or_default())?;
    let mut mounting =
        Mounting::from_rest([x, y, z]).map_err(|e| anyhow!("--at-rest-m-s2 {x},{y},{z}: {e}"))?;
    for row in &mut mounting.sensor_to_litter {
        for entry in row.iter_mut() {
            *entry = tidy(*entry);
        }
    }
    if args.json.json {
        return json_output::print(&MountingSummary {
            at_rest_m_s2: [x, y, z],
            mounting,
        });
    }
    print_text(&format!(
        "# Mounting calibration from a reading at rest of ({x}, {y}, {z}) m/s^2 (sensor axes).\n\
         # Rows of sensor_to_litter: the litter's x (toward the head), y, z (up) in sensor axes.\n{}",
        mounting_toml(mounting)?
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Synthetic readings with known sensitivity, offset and cross-axis misalignment of
    /// 1 %, with noise of about 1 mg: recovered within 0.2 % and 0.02 m/s^2.
    #[test]
    fn a_tumble_test_on_synthetic_readings_recovers_sensitivity_and_offset() {
        let g = STANDARD_GRAVITY_M_S2;
        let sensitivity = [1.021, 0.987, 1.004];
        let offset = [0.31, -0.18, 0.52];
        let noise = [0.008, -0.01, 0.004, 0.009, -0.006, 0.002];
        let mut mean_m_s2 = [[0.0; 3]; 6];
        for (k, reading) in mean_m_s2.iter_mut().enumerate() {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let mut truth = [0.0; 3];
            truth[k / 2] = sign * g;
            for axis in 0..3 {
                // 1 % of the other axes leaks in (a slightly misaligned die).
                let leak: f64 = (0..3).filter(|&a| a != axis).map(|a| 0.01 * truth[a]).sum();
                reading[axis] =
                    sensitivity[axis] * truth[axis] + offset[axis] + leak + noise[(k + axis) % 6];
            }
        }
        let readings = TumbleReadings {
            mean_m_s2,
            rows: [1; 6],
        };
        let (s, o) = tumble_calibration(&readings, g);
        for axis in 0..3 {
            assert!(
                (s[axis] / sensitivity[axis] - 1.0).abs() < 2e-3,
                "{s:?} vs {sensitivity:?}"
            );
            assert!((o[axis] - offset[axis]).abs() < 0.02, "{o:?} vs {offset:?}");
        }
    }
}
