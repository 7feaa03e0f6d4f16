//! `supine calibrate`: the mounting calibration from the accelerometer's reading at rest.
//!
//! With the litter level and still, the sensor reads gravity only; its direction fixes the
//! rotation from sensor to litter axes (and the sensor's x axis, projected on the
//! horizontal, is taken as the litter's x: toward the head). The result is the
//! `[device.mounting]` table of a parameter file, which `supine flash` puts in the blob.

use anyhow::{Result, anyhow};
use supine_core::mounting::Mounting;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::io::params_file::mounting_toml;
use crate::io::stdout::print_text;

/// Arguments of `supine calibrate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mean accelerometer reading at rest, sensor axes x,y,z in m/s^2 (e.g. the mean of a
    /// few seconds of samples with the litter level and still; spaces after the commas
    /// are fine).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub at_rest_m_s2: String,
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

/// Prints the `[device.mounting]` table for the reading, or says why it cannot be one.
pub fn run(args: &Args) -> Result<()> {
    let [x, y, z] = reading(&args.at_rest_m_s2)?;
    let mut mounting =
        Mounting::from_rest([x, y, z]).map_err(|e| anyhow!("--at-rest-m-s2 {x},{y},{z}: {e}"))?;
    for row in &mut mounting.sensor_to_litter {
        for entry in row.iter_mut() {
            *entry = tidy(*entry);
        }
    }
    if args.json.json {
        return json_output::print(&serde_json::json!({
            "at_rest_m_s2": [x, y, z],
            "mounting": mounting,
        }));
    }
    print_text(&format!(
        "# Mounting calibration from a reading at rest of ({x}, {y}, {z}) m/s^2 (sensor axes).\n\
         # Rows of sensor_to_litter: the litter's x (toward the head), y, z (up) in sensor axes.\n{}",
        mounting_toml(mounting)?
    ))
}
