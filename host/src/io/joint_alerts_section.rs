//! The parameter file's optional `[device.joint_alerts]` table: thresholds on the neck's
//! and the lower back's motion, one sub-table per joint output, set by a medical director.
//! None is shipped (`docs/exposure.md`, "Joint-motion alerts"): no table, no joint alert.
//!
//! ```toml
//! [device.joint_alerts]
//! clear_dwell_s = 5.0          # optional: hysteresis, raise_dwell_s, clear_dwell_s
//! neck_x = { running_rms_m = 0.002, excursion_m = 0.005 }
//! neck_ry = { excursion_rad = 0.05 }
//! ```
//!
//! Keys carry the output's SI unit: `running_rms_m` and `excursion_m` for a translation,
//! `running_rms_rad` and `excursion_rad` for a rotation. This module finds the keys the
//! device would refuse and turns the table into the core's [`JointAlertConfig`], whose
//! thresholds are in the order the device reads the outputs.

use serde::{Deserialize, Serialize};
use supine_core::alerts::{AlertConfig, JointAlertConfig};
use supine_core::joint_exposure::packed_order;
use supine_core::model::{JOINT_OUTPUT_COUNT, JointOutput, JointUnit};

use crate::io::device_table::Refusal;

/// One output's keys as written (each optional; a key in the other unit is kept, to be
/// refused with its name).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputThresholds {
    /// Running-rms threshold of a translation, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub running_rms_m: Option<f32>,
    /// Largest-excursion threshold of a translation, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub excursion_m: Option<f32>,
    /// Running-rms threshold of a rotation, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub running_rms_rad: Option<f32>,
    /// Largest-excursion threshold of a rotation, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub excursion_rad: Option<f32>,
}

impl OutputThresholds {
    /// Every key written, with its name and unit.
    fn keys(&self) -> [(&'static str, JointUnit, Option<f32>); 4] {
        [
            ("running_rms_m", JointUnit::Metre, self.running_rms_m),
            ("excursion_m", JointUnit::Metre, self.excursion_m),
            ("running_rms_rad", JointUnit::Radian, self.running_rms_rad),
            ("excursion_rad", JointUnit::Radian, self.excursion_rad),
        ]
    }

    /// The running-rms and excursion thresholds in `unit` (0: none).
    fn in_unit(&self, unit: JointUnit) -> (f32, f32) {
        let (rms, excursion) = match unit {
            JointUnit::Metre => (self.running_rms_m, self.excursion_m),
            JointUnit::Radian => (self.running_rms_rad, self.excursion_rad),
        };
        (rms.unwrap_or(0.0), excursion.unwrap_or(0.0))
    }
}

/// `[device.joint_alerts]`: per joint output ([`JointOutput::ALL`] order) its thresholds,
/// and the running-rms alerts' hysteresis and dwell (the head's defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "JointAlertsTable", into = "JointAlertsTable")]
pub struct JointAlertsSection {
    /// Each output's keys.
    pub outputs: [OutputThresholds; JOINT_OUTPUT_COUNT],
    /// A running-rms alert clears below `(1 - hysteresis)` times its threshold.
    pub hysteresis: f32,
    /// How long the running rms must stay at or above its threshold, s.
    pub raise_dwell_s: f32,
    /// How long it must stay below the clear threshold, s.
    pub clear_dwell_s: f32,
}

impl Default for JointAlertsSection {
    /// No threshold: no joint alert.
    fn default() -> Self {
        let none = JointAlertConfig::NONE;
        Self {
            outputs: [OutputThresholds::default(); JOINT_OUTPUT_COUNT],
            hysteresis: none.hysteresis,
            raise_dwell_s: none.raise_dwell_s,
            clear_dwell_s: none.clear_dwell_s,
        }
    }
}

impl JointAlertsSection {
    /// Whether it is the default (nothing set): then the file leaves the table out.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The keys the device would refuse, for a device reading the outputs of `read_mask`
    /// (bit `i` for [`JointOutput::ALL`]`[i]`): a key in the other unit, a threshold that is
    /// not finite and above 0, or one for an output not read. Hysteresis and dwell are the
    /// core's to judge ([`config`](Self::config)).
    pub fn refusals(&self, read_mask: u16) -> Vec<Refusal> {
        let mut refusals = Vec::new();
        for (output, keys) in JointOutput::ALL.iter().zip(&self.outputs) {
            for (key, unit, value) in keys.keys() {
                let Some(value) = value else { continue };
                let (what, si) = match output.unit() {
                    JointUnit::Metre => ("a translation", "m"),
                    JointUnit::Radian => ("a rotation", "rad"),
                };
                let reason = if unit != output.unit() {
                    let stem = key.rsplit_once('_').map_or(key, |(s, _)| s);
                    format!("{output} is {what}: expected {stem}_{si}, in {si}")
                } else if !(value.is_finite() && value > 0.0) {
                    format!("expected a finite threshold above 0, in {si}")
                } else if read_mask & (1 << output.index()) == 0 {
                    format!(
                        "expected a threshold for an output the device reads: {output} is not in joint_outputs"
                    )
                } else {
                    continue;
                };
                refusals.push(Refusal {
                    key: format!("joint_alerts.{output}.{key}"),
                    reason,
                });
            }
        }
        refusals
    }

    /// The core's configuration for a device reading the outputs of `read_mask`: the
    /// thresholds in the order it reads them ([`packed_order`]). Keys in the wrong unit or
    /// for outputs not read are left out ([`refusals`](Self::refusals) names them).
    pub fn config(&self, read_mask: u16) -> JointAlertConfig {
        let mut config = JointAlertConfig {
            hysteresis: self.hysteresis,
            raise_dwell_s: self.raise_dwell_s,
            clear_dwell_s: self.clear_dwell_s,
            ..JointAlertConfig::NONE
        };
        for (k, output) in packed_order(read_mask).enumerate() {
            let (rms, excursion) = self.outputs[output.index()].in_unit(output.unit());
            config.running_rms_m_or_rad[k] = rms;
            config.excursion_m_or_rad[k] = excursion;
        }
        config
    }
}

/// The table as a file holds it: every key optional, an unknown output refused by name.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct JointAlertsTable {
    hysteresis: f32,
    raise_dwell_s: f32,
    clear_dwell_s: f32,
    #[serde(skip_serializing_if = "Option::is_none")]
    neck_x: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    neck_y: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    neck_z: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    neck_ry: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    neck_rz: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    low_back_x: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    low_back_y: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    low_back_z: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    low_back_ry: Option<OutputThresholds>,
    #[serde(skip_serializing_if = "Option::is_none")]
    low_back_rz: Option<OutputThresholds>,
}

impl Default for JointAlertsTable {
    fn default() -> Self {
        JointAlertsSection::default().into()
    }
}

impl JointAlertsTable {
    /// The outputs' sub-tables in [`JointOutput::ALL`] order (the names of its fields).
    fn outputs(&self) -> [Option<OutputThresholds>; JOINT_OUTPUT_COUNT] {
        [
            self.neck_x,
            self.neck_y,
            self.neck_z,
            self.neck_ry,
            self.neck_rz,
            self.low_back_x,
            self.low_back_y,
            self.low_back_z,
            self.low_back_ry,
            self.low_back_rz,
        ]
    }
}

impl From<JointAlertsTable> for JointAlertsSection {
    fn from(t: JointAlertsTable) -> Self {
        Self {
            outputs: t.outputs().map(Option::unwrap_or_default),
            hysteresis: t.hysteresis,
            raise_dwell_s: t.raise_dwell_s,
            clear_dwell_s: t.clear_dwell_s,
        }
    }
}

impl From<JointAlertsSection> for JointAlertsTable {
    fn from(s: JointAlertsSection) -> Self {
        let written = s
            .outputs
            .map(|o| (o != OutputThresholds::default()).then_some(o));
        let [
            neck_x,
            neck_y,
            neck_z,
            neck_ry,
            neck_rz,
            low_back_x,
            low_back_y,
            low_back_z,
            low_back_ry,
            low_back_rz,
        ] = written;
        Self {
            hysteresis: s.hysteresis,
            raise_dwell_s: s.raise_dwell_s,
            clear_dwell_s: s.clear_dwell_s,
            neck_x,
            neck_y,
            neck_z,
            neck_ry,
            neck_rz,
            low_back_x,
            low_back_y,
            low_back_z,
            low_back_ry,
            low_back_rz,
        }
    }
}

/// The head's alert defaults, which the joint alerts' hysteresis and dwell take.
const _: () = assert!(
    JointAlertConfig::NONE.hysteresis == AlertConfig::DEFAULT.hysteresis
        && JointAlertConfig::NONE.raise_dwell_s == AlertConfig::DEFAULT.raise_dwell_s
        && JointAlertConfig::NONE.clear_dwell_s == AlertConfig::DEFAULT.clear_dwell_s
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_fields_are_the_outputs_names_in_order() {
        let mut s = JointAlertsSection::default();
        for (k, o) in s.outputs.iter_mut().enumerate() {
            o.excursion_m = Some(k as f32 + 1.0);
        }
        let text = toml::to_string(&s).unwrap();
        for (k, output) in JointOutput::ALL.iter().enumerate() {
            let table = format!("[{output}]\nexcursion_m = {}.0\n", k + 1);
            assert!(text.contains(&table), "{table} in {text}");
        }
        assert_eq!(toml::from_str::<JointAlertsSection>(&text).unwrap(), s);
    }

    #[test]
    fn thresholds_go_in_the_order_the_device_reads_the_outputs() {
        let s: JointAlertsSection = toml::from_str(
            "neck_ry = { excursion_rad = 0.05 }\nneck_x = { running_rms_m = 0.002 }\n\
             low_back_z = { running_rms_m = 0.001, excursion_m = 0.004 }\n",
        )
        .unwrap();
        let all = (1 << JOINT_OUTPUT_COUNT) - 1;
        assert!(s.refusals(all).is_empty());
        let order: Vec<JointOutput> = packed_order(all).collect();
        let c = s.config(all);
        for (k, output) in order.iter().enumerate() {
            let (rms, excursion) = match output.name() {
                "neck_x" => (0.002, 0.0),
                "neck_ry" => (0.0, 0.05),
                "low_back_z" => (0.001, 0.004),
                _ => (0.0, 0.0),
            };
            assert_eq!(c.running_rms_m_or_rad[k], rms, "{output}");
            assert_eq!(c.excursion_m_or_rad[k], excursion, "{output}");
        }
        assert_eq!(c.hysteresis, AlertConfig::DEFAULT.hysteresis);
    }

    #[test]
    fn each_bad_threshold_is_refused_by_its_key() {
        let s: JointAlertsSection = toml::from_str(
            "neck_x = { excursion_rad = 0.1 }\nneck_ry = { running_rms_rad = 0.0 }\n\
             low_back_y = { excursion_m = nan }\nlow_back_rz = { excursion_rad = 0.1 }\n",
        )
        .unwrap();
        let mask = (1 << JOINT_OUTPUT_COUNT) - 1 - (1 << 9);
        let refusals: Vec<(String, String)> = s
            .refusals(mask)
            .into_iter()
            .map(|r| (r.key, r.reason))
            .collect();
        assert_eq!(
            refusals,
            [
                (
                    "joint_alerts.neck_x.excursion_rad".to_string(),
                    "neck_x is a translation: expected excursion_m, in m".to_string()
                ),
                (
                    "joint_alerts.neck_ry.running_rms_rad".to_string(),
                    "expected a finite threshold above 0, in rad".to_string()
                ),
                (
                    "joint_alerts.low_back_y.excursion_m".to_string(),
                    "expected a finite threshold above 0, in m".to_string()
                ),
                (
                    "joint_alerts.low_back_rz.excursion_rad".to_string(),
                    "expected a threshold for an output the device reads: low_back_rz is not in joint_outputs".to_string()
                ),
            ]
        );
        let err = toml::from_str::<JointAlertsSection>("neck_w = { excursion_m = 0.1 }\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("unknown field `neck_w`"), "{err}");
        let err = toml::from_str::<JointAlertsSection>("neck_x = { excursion_mm = 5 }\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("unknown field `excursion_mm`"), "{err}");
    }
}
