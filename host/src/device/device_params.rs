//! Turning a parameter file into what the device runs: the blob for one sample rate.
//!
//! The identity of a parameter set is the first 16 bytes of the SHA-256 of its parameter
//! file as rendered by [`ParamFile::to_toml`], so the same parameters always have the same
//! identity whether they came from a preset or a file.

use anyhow::{Result, anyhow};
use sha2::{Digest, Sha256};
use supine_core::blob::{BlobError, DeviceParams, MAX_BLOB_LEN, Patient};
use supine_core::model::Model;
use supine_core::protocol::{IDENTITY_LEN, ParamsIdentity, ParamsSource};
use supine_core::sample_rate::SampleRate;

use crate::io::device_table::check;
use crate::io::params_file::ParamFile;

/// The identity the device reports for these parameters.
pub fn identity(file: &ParamFile) -> Result<ParamsIdentity> {
    let digest = Sha256::digest(file.to_toml()?.as_bytes());
    let mut id = [0u8; IDENTITY_LEN];
    id.copy_from_slice(&digest[..IDENTITY_LEN]);
    Ok(id)
}

/// Hex form of an identity, as the tools print it.
pub fn identity_hex(id: &ParamsIdentity) -> String {
    id.iter().map(|b| format!("{b:02x}")).collect()
}

/// Everything the device needs at `sample_rate_hz`, validated as the device will.
///
/// A `[device]` value refused at this rate (a file's values were checked at load, see
/// [`crate::io::params_file`], but a running-rms time constant can be too short for a lower
/// rate) is named by its key.
pub fn build(file: &ParamFile, sample_rate_hz: f64) -> Result<DeviceParams> {
    let device = file.device.unwrap_or_default();
    let sample_rate = SampleRate::from_hz_f64(sample_rate_hz)
        .map_err(|e| anyhow!("{e}, found {sample_rate_hz} Hz"))?;
    // Discretized at the rate as given, the blob's stages at its f32 value (as before the
    // rate was stored once: the same bytes for the same file and rate).
    let model = Model::new(&file.params).map_err(|e| anyhow!("{e}"))?;
    let realization = model
        .device_realization(sample_rate_hz)
        .map_err(|e| anyhow!("{e}"))?;
    let joints = model
        .device_joint_readout(
            sample_rate_hz,
            &realization,
            &device.joint_outputs.outputs(),
        )
        .map_err(|e| anyhow!("the joint outputs' readout: {e}"))?;
    DeviceParams::new(
        identity(file)?,
        Patient::of(&file.params.subject),
        sample_rate,
        realization,
        device.exposure,
        device.alerts,
        device.sensor_checks,
        device.mounting,
        device.telemetry(sample_rate.hz()),
        joints,
    )
    .and_then(|p| p.with_joint_alerts(device.joint_alerts.config(device.joint_outputs.mask)))
    .and_then(|p| p.with_calibration(device.calibration))
    .map_err(|e| {
        let refused = check(&device, sample_rate, Some(&realization)).err();
        match refused
            .as_ref()
            .and_then(|r| r.first())
            .filter(|r| !r.key.is_empty())
        {
            Some(r) => anyhow!(
                "device configuration at {}: device.{}: {}",
                sample_rate,
                r.key,
                r.reason
            ),
            None => anyhow!("device configuration: {e}"),
        }
    })
}

/// The blob's bytes.
pub fn encode(params: &DeviceParams) -> Result<Vec<u8>> {
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let len = params
        .encode(&mut buf)
        .map_err(|e| anyhow!("encoding the blob: {e}"))?;
    buf.truncate(len);
    Ok(buf)
}

/// Where the parameters came from, in words a medic reading the panel can act on: the
/// flash slot as the README names it (A, B), or why the device fell back to its built-in
/// parameters and what to do (the blob error's code last, for the technician).
pub fn params_source_text(source: ParamsSource) -> String {
    match source {
        ParamsSource::Flash { slot: 0 } => "flash slot A".to_string(),
        ParamsSource::Flash { slot: 1 } => "flash slot B".to_string(),
        ParamsSource::Flash { slot } => format!("flash slot {slot}"),
        ParamsSource::BuiltInDefault { reason } => {
            let why = match reason {
                BlobError::Empty => "no parameters were ever put on this device",
                BlobError::Truncated | BlobError::BadCrc => {
                    "the last parameter update did not finish (power lost while writing?)"
                }
                _ => "the parameters in flash are not ones this firmware accepts",
            };
            format!(
                "the built-in parameters, which may not be this patient's: {why}; alerts \
                 still work; put the patient's parameters on again (blob error {})",
                reason.code()
            )
        }
    }
}
