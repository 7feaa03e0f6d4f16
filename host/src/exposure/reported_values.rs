//! The reported form of the core's ISO 2631-1 values: an axis's (or the vector sum's)
//! values and the alert thresholds, in f64 at the f32's shortest decimal.

use serde::Serialize;
use supine_core::alerts::AlertConfig;
use supine_core::exposure::AxisValues;

/// Rounds an f32 to the shortest decimal that reads back as the same f32, as f64
/// (so 0.3f32 reports as 0.3, not 0.30000001192092896).
pub fn tidy(x: f32) -> f64 {
    format!("{x}").parse().unwrap_or(x as f64)
}

/// Which ISO 2631-1 criteria call for methods beyond the basic rms.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct AdditionalMethodsReport {
    /// Crest factor above 9.
    pub crest_factor: bool,
    /// `MTVV / a_w` above 1.5.
    pub mtvv_ratio: bool,
    /// `VDV / (a_w T^(1/4))` above 1.75.
    pub vdv_ratio: bool,
}

/// The evaluation of one weighted signal (an axis or the vector sum), SI units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AxisReport {
    /// The weighting applied (`wk`, `wd`, `wj`), or `vector` for the vector sum.
    pub weighting: &'static str,
    /// Overall weighted rms after the warm-up, m/s^2.
    pub rms_m_s2: f64,
    /// Maximum transient vibration value (largest 1 s running rms), m/s^2.
    pub mtvv_m_s2: f64,
    /// Vibration dose value `(integral a_w^4 dt)^(1/4)`, m/s^1.75.
    pub vdv_m_s175: f64,
    /// Largest |weighted acceleration| after the warm-up, m/s^2.
    pub peak_m_s2: f64,
    /// `peak / rms`.
    pub crest_factor: f64,
    /// Running rms at the last sample, m/s^2.
    pub running_rms_m_s2: f64,
    /// `MTVV / rms`.
    pub mtvv_ratio: f64,
    /// `VDV / (rms T^(1/4))`.
    pub vdv_ratio: f64,
    /// Which criteria call for the additional methods.
    pub additional_methods: AdditionalMethodsReport,
}

impl AxisReport {
    /// The core's values, labelled with their weighting.
    pub fn new(weighting: &'static str, v: &AxisValues) -> Self {
        Self {
            weighting,
            rms_m_s2: tidy(v.rms_m_s2),
            mtvv_m_s2: tidy(v.mtvv_m_s2),
            vdv_m_s175: tidy(v.vdv_m_s175),
            peak_m_s2: tidy(v.peak_m_s2),
            crest_factor: tidy(v.crest_factor),
            running_rms_m_s2: tidy(v.running_rms_m_s2),
            mtvv_ratio: tidy(v.mtvv_ratio),
            vdv_ratio: tidy(v.vdv_ratio),
            additional_methods: AdditionalMethodsReport {
                crest_factor: v.additional.crest_factor,
                mtvv_ratio: v.additional.mtvv_ratio,
                vdv_ratio: v.additional.vdv_ratio,
            },
        }
    }
}

/// The alert thresholds in force (the parameter file's, or the documented defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ThresholdsReport {
    /// Running-rms thresholds of the vector sum: advisory, warning, alarm, m/s^2.
    pub running_rms_m_s2: [f64; 3],
    /// VDV thresholds of the vector sum: advisory, warning, alarm, m/s^1.75.
    pub vdv_m_s175: [f64; 3],
}

impl From<&AlertConfig> for ThresholdsReport {
    fn from(c: &AlertConfig) -> Self {
        Self {
            running_rms_m_s2: c.running_rms_m_s2.map(tidy),
            vdv_m_s175: c.vdv_m_s175.map(tidy),
        }
    }
}
