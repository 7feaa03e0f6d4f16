//! `supine verify --qemu`: ISO 8041-1's electrical verification of a whole-body meter,
//! run through the shipping firmware image in QEMU at each supported sample rate.
//!
//! How the test signals reach the weighting: a verification parameter set
//! ([`verification_params`]) whose model passes the litter input straight to the head
//! outputs (one direct term of 1 per axis, no modal block: no [`ModelParams`] can give
//! that, so no parameter file can, and only this module builds it; it is loaded into the
//! emulated device's flash region and never uploaded). Its weighting, exposure and
//! sensor checks are the shipping ones (Wk on x, Wd on y, Wj on z, so each signal tests
//! all three at once; tau 1 s; the LIS3DH's +-4 g full scale), with telemetry every
//! sample. Expected values and limits come from the standard
//! ([`reference`](mod@reference)), never from the product's output.
//!
//! - [`plan`]: the test signals and how each result is read from the telemetry.
//! - [`reference`](mod@reference): the definitions' values (analog weighting, running
//!   rms, MTVV, VDV).
//! - [`html`]: the conformance report.
//!
//! [`ModelParams`]: supine_core::model::ModelParams

pub mod html;
pub mod plan;
pub mod reference;

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use serde::Serialize;
use sha2::{Digest, Sha256};
use supine_core::alerts::{AlertConfig, SensorCheckConfig};
use supine_core::blob::{DeviceParams, Patient, TelemetryConfig};
use supine_core::exposure::{AxisMapping, AxisWeighting, ExposureConfig};
use supine_core::model::discrete::MAX_BLOCKS;
use supine_core::model::{DeviceRealization, JointReadout, ModalBlock, ModalGroup};
use supine_core::mounting::{Mounting, STANDARD_GRAVITY_M_S2};
use supine_core::protocol::{IDENTITY_LEN, Telemetry};
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::WeightingKind;

use crate::device::device_params::{encode, identity_hex};
use crate::device::image::ProductImage;
use crate::device::replay::{SessionConfig, file_session, sample_messages};

/// The rates the product documents as supported and the verification runs by default, Hz
/// (docs/exposure.md: 100 Hz to 2 kHz; 400 Hz is the LIS3DH board's).
pub const SUPPORTED_RATES_HZ: [f64; 6] = [100.0, 200.0, 400.0, 500.0, 1000.0, 2000.0];

/// The weighting on each axis of the verification set.
pub const AXIS_WEIGHTINGS: [WeightingKind; 3] =
    [WeightingKind::Wk, WeightingKind::Wd, WeightingKind::Wj];

/// Full scale of the verification set, m/s^2: the LIS3DH's +-4 g, as the board runs it.
pub const FULL_SCALE_M_S2: f32 = (4.0 * STANDARD_GRAVITY_M_S2) as f32;

/// The running rms's time constant the product ships, s.
pub const SHIPPING_TAU_S: f32 = 1.0;

/// What differs from the shipping parameter set, to show that the verification can fail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Variant {
    /// The shipping weighting and time constant.
    Shipping,
    /// Wk's transition section with its pole pair moved 5 % toward the origin of the
    /// z-plane (its numerator rescaled so that the set still validates).
    DetunedWk,
    /// A running rms with this time constant, s, in place of 1 s.
    RunningTau(f32),
}

/// The pass-through model: each litter axis to the same head axis, gain 1.
fn pass_through() -> DeviceRealization {
    let block = ModalBlock {
        transition_minus_identity: [[0.0; 2]; 2],
        output: [[0.0; 2]; 3],
    };
    let group = |axis: u8| ModalGroup {
        block_count: 0,
        output_count: 1,
        outputs: [axis, 0, 0],
        feedthrough: [1.0, 0.0, 0.0],
    };
    DeviceRealization {
        groups: [group(0), group(1), group(2)],
        blocks: [block; MAX_BLOCKS],
        block_count: 0,
    }
}

/// The identity of the verification set of `variant`: the start of the SHA-256 of its
/// description (no parameter file describes it).
pub fn verification_identity(variant: Variant) -> [u8; IDENTITY_LEN] {
    let text = format!(
        "supine ISO 8041-1 verification parameter set 1: pass-through model, Wk x, Wd y, \
         Wj z, full scale 4 g, telemetry every sample; {variant:?}"
    );
    let digest = Sha256::digest(text.as_bytes());
    let mut id = [0; IDENTITY_LEN];
    id.copy_from_slice(&digest[..IDENTITY_LEN]);
    id
}

/// The verification parameter set at `rate_hz`.
pub fn verification_params(rate_hz: f64, variant: Variant) -> Result<DeviceParams> {
    let sample_rate = SampleRate::from_hz_f64(rate_hz).map_err(|e| anyhow!("{e}"))?;
    let axis = |kind| AxisWeighting { kind, k: 1.0 };
    let tau = match variant {
        Variant::RunningTau(tau) => tau,
        _ => SHIPPING_TAU_S,
    };
    let exposure = ExposureConfig {
        axes: AxisMapping {
            x: axis(AXIS_WEIGHTINGS[0]),
            y: axis(AXIS_WEIGHTINGS[1]),
            z: axis(AXIS_WEIGHTINGS[2]),
        },
        running_tau_s: tau,
        ..ExposureConfig::DEFAULT
    };
    let checks = SensorCheckConfig {
        full_scale_m_s2: FULL_SCALE_M_S2,
        ..SensorCheckConfig::DEFAULT
    };
    let mut params = DeviceParams::new(
        verification_identity(variant),
        Patient {
            height_m: 1.75,
            mass_kg: 75.0,
        },
        sample_rate,
        pass_through(),
        exposure,
        AlertConfig::DEFAULT,
        checks,
        Mounting::LEVEL,
        TelemetryConfig::EVERY_SAMPLE,
        JointReadout::NONE,
    )
    .map_err(|e| anyhow!("the verification parameter set at {rate_hz} Hz: {e}"))?;
    if variant == Variant::DetunedWk {
        let section = &mut params.exposure.weighting[0].shaping[0];
        let (b, a) = (section.b, section.a);
        let dc = (b[0] + b[1] + b[2]) / (1.0 + a[0] + a[1]);
        // Poles r e^(+-j theta): a1 = -2 r cos(theta), a2 = r^2; r to 0.95 r.
        section.a = [a[0] * 0.95, a[1] * 0.95 * 0.95];
        let scale = dc * (1.0 + section.a[0] + section.a[1]) / (b[0] + b[1] + b[2]);
        section.b = b.map(|v| v * scale);
        params
            .validate()
            .map_err(|e| anyhow!("the detuned verification set: {e}"))?;
    }
    Ok(params)
}

/// One verification test's result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TestResult {
    /// The clause of ISO 8041-1 (and the table) it follows.
    pub clause: String,
    /// What was tested.
    pub name: String,
    /// `Wk`, `Wd`, `Wj`, or `vector` (the three combined), or `none`.
    pub weighting: String,
    /// The sample rate, Hz.
    pub fs_hz: f64,
    /// The test frequency, Hz, where one applies.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frequency_hz: Option<f64>,
    /// The value the standard's definition gives.
    pub expected: f64,
    /// What the device indicated.
    pub measured: f64,
    /// The tolerance's lower limit.
    pub lower_limit: f64,
    /// The tolerance's upper limit.
    pub upper_limit: f64,
    /// Of the four numbers above.
    pub unit: String,
    /// `lower_limit <= measured <= upper_limit`.
    pub pass: bool,
}

impl TestResult {
    /// The measured deviation from expected, percent (none when expected is 0).
    pub fn deviation_percent(&self) -> Option<f64> {
        (self.expected != 0.0).then(|| 100.0 * (self.measured / self.expected - 1.0))
    }
}

/// The verification's outcome: what ran, and every test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conformance {
    /// SHA-256 of the firmware image (ELF) that ran, hex.
    pub firmware_sha256: String,
    /// The device's firmware version, from its greeting.
    pub version: String,
    /// The verification parameter set's identity, hex.
    pub params_identity: String,
    /// When it ran (UTC, RFC 3339).
    pub date: String,
    /// Every test passed.
    pub pass: bool,
    /// The tests, by rate then group.
    pub tests: Vec<TestResult>,
    /// Wall-clock time the QEMU sessions took, s.
    #[serde(skip)]
    pub elapsed_s: f64,
}

/// The telemetry of one signal through the device at `rate_hz`, one record per sample.
fn run_signal(
    image: &ProductImage,
    blob: &[u8],
    samples: &[[f32; 3]],
    stop: &Arc<AtomicBool>,
) -> Result<(Vec<Telemetry>, String)> {
    let config = SessionConfig {
        kernel: image.path().to_path_buf(),
        blob: Some(blob.to_vec()),
        icount: false,
        timeout: Duration::from_secs(120 + samples.len() as u64 / 100),
    };
    let session = file_session(&config, sample_messages(0, samples), stop)?;
    let version = session
        .greetings
        .first()
        .map(|g| g.firmware_version.to_string())
        .ok_or_else(|| anyhow!("the device did not greet"))?;
    let mut telemetry = session.telemetry;
    telemetry.sort_by_key(|t| t.sample_index);
    if telemetry.len() != samples.len() {
        return Err(anyhow!(
            "expected telemetry for each of {} samples, found {} records (lost frames: {})",
            samples.len(),
            telemetry.len(),
            session.link.lost_frames
        ));
    }
    Ok((telemetry, version))
}

/// Runs `groups` of the verification at each of `rates_hz` on `image` with `variant`'s
/// parameter set; `progress` hears of each group as it starts.
pub fn run(
    image: &ProductImage,
    rates_hz: &[f64],
    variant: Variant,
    groups: &[plan::Group],
    stop: &Arc<AtomicBool>,
    progress: &mut dyn FnMut(&str),
) -> Result<Conformance> {
    let elf = std::fs::read(image.path())
        .map_err(|e| anyhow!("{}: cannot read the image: {e}", image.path().display()))?;
    let firmware_sha256: String = Sha256::digest(&elf)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    let started = Instant::now();
    let mut tests = Vec::new();
    let mut version = String::new();
    for &rate in rates_hz {
        let params = verification_params(rate, variant)?;
        let blob = encode(&params)?;
        for group in groups {
            progress(&format!("{} at {rate} Hz", group.name()));
            let signal = group.signal(rate);
            let (telemetry, v) = run_signal(image, &blob, &signal.samples, stop)
                .map_err(|e| anyhow!("{} at {rate} Hz: {e}", group.name()))?;
            version = v;
            tests.extend(group.evaluate(rate, &params, &signal, &telemetry));
        }
    }
    Ok(Conformance {
        firmware_sha256,
        version,
        params_identity: identity_hex(&verification_identity(variant)),
        date: {
            let t = time::OffsetDateTime::now_utc();
            format!(
                "{}T{:02}:{:02}:{:02}Z",
                t.date(),
                t.hour(),
                t.minute(),
                t.second()
            )
        },
        pass: !tests.is_empty() && tests.iter().all(|t| t.pass),
        tests,
        elapsed_s: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_verification_sets_validate_at_every_supported_rate() {
        for rate in SUPPORTED_RATES_HZ {
            for variant in [
                Variant::Shipping,
                Variant::DetunedWk,
                Variant::RunningTau(1.25),
            ] {
                let p = verification_params(rate, variant).unwrap();
                assert!(DeviceParams::decode(&encode(&p).unwrap()).is_ok());
            }
        }
        let a = verification_identity(Variant::Shipping);
        assert_ne!(a, verification_identity(Variant::DetunedWk));
    }

    /// The pass-through model gives the head exactly the litter input.
    #[test]
    fn the_model_passes_the_input_through() {
        let p = verification_params(500.0, Variant::Shipping).unwrap();
        let mut state = supine_core::pipeline::PipelineState::new();
        let input: Vec<[f32; 3]> = (0..40).map(|i| [i as f32 * 0.5, -1.0, 2.5]).collect();
        let indices: Vec<u32> = (0..40).collect();
        let mut head = Vec::new();
        p.process(&mut state, &indices, &input, |o| {
            if let supine_core::pipeline::PipelineOutput::Telemetry(t) = o {
                head.push(t.head_acc_m_s2);
            }
        });
        assert_eq!(head, input);
    }
}
