//! `supine calibrate`: the mounting calibration from the accelerometer's reading at rest.
//!
//! With the litter level and still, the sensor reads gravity only; its direction fixes the
//! rotation from sensor to litter axes (and the sensor's x axis, projected on the
//! horizontal, is taken as the litter's x: toward the head). The result is the
//! `[device.mounting]` table of a parameter file, which `supine flash` puts in the blob.

use anyhow::{Result, anyhow};
use supine_core::mounting::Mounting;

use crate::io::params_file::mounting_toml;

/// Arguments of `supine calibrate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mean accelerometer reading at rest, sensor axes x,y,z in m/s^2 (e.g. the mean of a
    /// few seconds of samples with the litter level and still).
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        allow_negative_numbers = true,
        required = true
    )]
    pub at_rest_m_s2: Vec<f64>,
}

/// Prints the `[device.mounting]` table for the reading, or says why it cannot be one.
pub fn run(args: &Args) -> Result<()> {
    let [x, y, z] = args.at_rest_m_s2[..] else {
        return Err(anyhow!(
            "--at-rest-m-s2: expected three numbers X,Y,Z, found {}",
            args.at_rest_m_s2.len()
        ));
    };
    let mounting =
        Mounting::from_rest([x, y, z]).map_err(|e| anyhow!("--at-rest-m-s2 {x},{y},{z}: {e}"))?;
    print!(
        "# Mounting calibration from a reading at rest of ({x}, {y}, {z}) m/s^2 (sensor axes).\n\
         # Rows of sensor_to_litter: the litter's x (toward the head), y, z (up) in sensor axes.\n{}",
        mounting_toml(mounting)?
    );
    Ok(())
}
