//! The parameter file's optional `[device]` table, and which of its keys the device would
//! refuse.
//!
//! The rules are `supine-core`'s (the stage constructors `ExposureSettings::new`,
//! `AlertSettings::new`, `SensorCheckSettings::new`, `Mounting::validate`, and the blob's
//! own `DeviceParams::new`); this module only finds the key to blame. It tries each key of
//! the table alone, every other key at its default, through those checks: a key refused
//! alone is the one to name, with the core's words for what it must be. The file's text
//! then gives the key's line and column ([`locate`]).
//!
//! The table is written by hand, so every key may be left out (a partial
//! `[device.alerts]` with only the thresholds takes the other alert defaults) and a
//! weighting is spelled as on the command line, in either case (`wd`, `Wd`). The core's
//! configurations read themselves so (its `file-form` feature: their own defaults, unknown
//! keys refused); this module adds the keys that are the host's: telemetry, the joint
//! outputs and their alerts, and the calibration record's written form.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use supine_core::alerts::{
    AlertConfig, AlertSettings, JointAlertSettings, SensorCheckConfig, SensorCheckSettings,
};
use supine_core::blob::{DeviceParams, Patient, TelemetryConfig};
use supine_core::calibration::{SensorCalibration, SensorFrame};
use supine_core::exposure::{ExposureConfig, ExposureSettings};
use supine_core::model::{
    DeviceRealization, JOINT_OUTPUT_COUNT, JointOutput, JointReadout, Subject,
};
use supine_core::mounting::Mounting;
use supine_core::sample_rate::SampleRate;

use crate::io::calibration_section;
use crate::io::excerpt::value;
use crate::io::joint_alerts_section::JointAlertsSection;
use crate::io::text_position::line_column;

/// The optional `[device]` table: what goes into the parameter blob besides the model.
/// Every key may be left out; a key the file form does not know is refused.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeviceSection {
    /// Weighting per head axis, running-rms time constant, warm-up.
    pub exposure: ExposureConfig,
    /// Alert thresholds on running rms and VDV, hysteresis, dwell.
    pub alerts: AlertConfig,
    /// Sensor full scale, stuck time, fault clear time.
    pub sensor_checks: SensorCheckConfig,
    /// Sensor-to-litter rotation and gravity (`supine calibrate` prints this table), level
    /// by default.
    pub mounting: Mounting,
    /// Telemetry every this many samples; absent, about 100 Hz at the blob's sample rate
    /// ([`TelemetryConfig::default_for`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub telemetry_decimation: Option<u16>,
    /// The joint outputs the device reads and reports (`joint_outputs = ["neck_x", ...]`;
    /// all ten by default, `[]` for none).
    #[serde(skip_serializing_if = "JointSelection::is_all")]
    pub joint_outputs: JointSelection,
    /// Thresholds on the joint outputs (`[device.joint_alerts]`): none by default.
    #[serde(skip_serializing_if = "JointAlertsSection::is_default")]
    pub joint_alerts: JointAlertsSection,
    /// The sensor's calibration record (`[device.calibration]`): the datasheet's nominal
    /// values, undated, by default. Written in the file's form ([`calibration_section`]).
    #[serde(with = "calibration_section::as_table")]
    #[serde(skip_serializing_if = "calibration_section::is_datasheet")]
    pub calibration: SensorCalibration,
}

/// A set of joint outputs, written in the file as a list of their names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointSelection {
    /// Bit `i` for [`JointOutput::ALL`]`[i]`.
    pub mask: u16,
}

impl JointSelection {
    /// All ten outputs: the default.
    pub const ALL: Self = Self {
        mask: (1 << JOINT_OUTPUT_COUNT) - 1,
    };

    /// The outputs, in [`JointOutput::ALL`] order.
    pub fn outputs(&self) -> Vec<JointOutput> {
        JointOutput::ALL
            .into_iter()
            .filter(|o| self.mask & (1 << o.index()) != 0)
            .collect()
    }

    fn is_all(&self) -> bool {
        *self == Self::ALL
    }
}

impl Default for JointSelection {
    fn default() -> Self {
        Self::ALL
    }
}

impl Serialize for JointSelection {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.outputs().iter().map(|o| o.name()))
    }
}

impl<'de> Deserialize<'de> for JointSelection {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let names = Vec::<String>::deserialize(d)?;
        let mut mask = 0u16;
        for name in &names {
            let Some(output) = JointOutput::from_name(name.trim()) else {
                let all: Vec<&str> = JointOutput::ALL.iter().map(|o| o.name()).collect();
                return Err(serde::de::Error::custom(format!(
                    "expected joint outputs among {}, found {}",
                    all.join(", "),
                    value(name)
                )));
            };
            let bit = 1 << output.index();
            if mask & bit != 0 {
                return Err(serde::de::Error::custom(format!(
                    "expected each joint output once, found {} twice",
                    output.name()
                )));
            }
            mask |= bit;
        }
        Ok(Self { mask })
    }
}

/// The `[device]` table with every default, commented out, for `supine params` to show
/// what can be set (uncommented, it reads back as the defaults).
pub fn commented_defaults() -> String {
    #[derive(Serialize)]
    struct Wrapper {
        device: DeviceSection,
    }
    let body = toml::to_string(&Wrapper {
        device: DeviceSection::default(),
    })
    .unwrap_or_default();
    let outputs: Vec<String> = JointOutput::ALL
        .iter()
        .map(|o| format!("\"{}\"", o.name()))
        .collect();
    let mut text = format!(
        "# The device's configuration (docs/exposure.md), every key at its default. Uncomment\n\
         # what you change; a key left out keeps its default. Weightings: wk, wd, wj.\n\
         # telemetry_decimation (telemetry every N samples) defaults to about 100 Hz.\n\
         # joint_outputs (the neck and lower-back outputs read and reported) defaults to all\n\
         # ten, [] for none:\n\
         #   {},\n\
         #   {}.\n\
         # [device.joint_alerts] has no defaults: no joint-motion alert unless one is set\n\
         # there (README, docs/exposure.md). [device.calibration] (the sensor's sensitivity,\n\
         # offset, date, method = datasheet, shaker or tumble, by, interval_months) defaults\n\
         # to the datasheet's nominal values, undated; `supine calibrate tumble` writes it.\n\n",
        outputs[..5].join(", "),
        outputs[5..].join(", ")
    );
    for line in body.lines() {
        if line.is_empty() {
            text.push('\n');
        } else {
            text.push_str("# ");
            text.push_str(line);
            text.push('\n');
        }
    }
    text
}

impl Default for DeviceSection {
    fn default() -> Self {
        Self {
            exposure: ExposureConfig::DEFAULT,
            alerts: AlertConfig::DEFAULT,
            sensor_checks: SensorCheckConfig::DEFAULT,
            mounting: Mounting::LEVEL,
            telemetry_decimation: None,
            joint_outputs: JointSelection::ALL,
            joint_alerts: JointAlertsSection::default(),
            calibration: SensorCalibration::DATASHEET,
        }
    }
}

impl DeviceSection {
    /// The sensor's calibration, then its mounting: what turns its readings into the
    /// model's input.
    pub fn sensor_frame(&self) -> SensorFrame {
        SensorFrame {
            calibration: self.calibration,
            mounting: self.mounting,
        }
    }

    /// The telemetry setting at `sample_rate_hz`: the table's decimation, else the default
    /// rate's.
    pub fn telemetry(&self, sample_rate_hz: f32) -> TelemetryConfig {
        self.telemetry_decimation
            .map(|decimation| TelemetryConfig { decimation })
            .unwrap_or_else(|| TelemetryConfig::default_for(sample_rate_hz))
    }
}

/// A key of the `[device]` table the device refuses.
#[derive(Clone, Debug, PartialEq)]
pub struct Refusal {
    /// The key's path under `[device]`, dotted (`alerts.hysteresis`).
    pub key: String,
    /// What the value must be, in the core's words.
    pub reason: String,
}

/// The core's verdict on `section` at `sample_rate`: each stage's own check (whose error
/// says what is expected), then, given a realization at that rate, the whole blob's.
pub fn core_check(
    section: &DeviceSection,
    sample_rate: SampleRate,
    realization: Option<&DeviceRealization>,
) -> Result<(), String> {
    ExposureSettings::new(section.exposure, sample_rate).map_err(|e| e.to_string())?;
    AlertSettings::new(section.alerts, sample_rate).map_err(|e| e.to_string())?;
    SensorCheckSettings::new(section.sensor_checks, sample_rate).map_err(|e| e.to_string())?;
    section.mounting.validate().map_err(|e| e.to_string())?;
    section.calibration.validate().map_err(|e| e.to_string())?;
    let read_mask = section.joint_outputs.mask;
    if let Some(r) = section.joint_alerts.refusals(read_mask).first() {
        return Err(r.reason.clone());
    }
    JointAlertSettings::new(
        section.joint_alerts.config(read_mask),
        sample_rate,
        section.telemetry(sample_rate.hz()).decimation,
        read_mask.count_ones() as usize,
    )
    .map_err(|e| e.to_string())?;
    if let Some(realization) = realization {
        // The patient is the model's, checked with the model (`ModelParams::validate`, the
        // same range): any valid one does here, where only `[device]` keys are judged.
        DeviceParams::new(
            [0; supine_core::protocol::IDENTITY_LEN],
            Patient::of(&Subject::PAPER_MEAN),
            sample_rate,
            *realization,
            section.exposure,
            section.alerts,
            section.sensor_checks,
            section.mounting,
            section.telemetry(sample_rate.hz()),
            JointReadout::NONE,
        )
        .map_err(|e| match section.telemetry(sample_rate.hz()).decimation {
            // The blob's only rule without a stage of its own (its error says only "out of
            // range"): say what it expects.
            0 => "expected telemetry every 1 or more samples".to_string(),
            _ => e.to_string(),
        })?;
    }
    Ok(())
}

/// Whether the core accepts `section` at `sample_rate`; if not, the keys it refuses
/// alone (every other key at its default, in key order), or, when no key is refused
/// alone, one refusal of the whole table (an empty `key`). A realization that the default
/// table fails with is not used: the fault is then the model's, not a key's.
pub fn check(
    section: &DeviceSection,
    sample_rate: SampleRate,
    realization: Option<&DeviceRealization>,
) -> Result<(), Vec<Refusal>> {
    // A joint threshold's refusal depends on the outputs read (another key): named here.
    let joint = section.joint_alerts.refusals(section.joint_outputs.mask);
    if !joint.is_empty() {
        return Err(joint);
    }
    let defaults = DeviceSection::default();
    let realization = realization.filter(|r| core_check(&defaults, sample_rate, Some(r)).is_ok());
    let Err(whole) = core_check(section, sample_rate, realization) else {
        return Ok(());
    };
    let mut refusals = Vec::new();
    if let (Ok(toml::Value::Table(mine)), Ok(toml::Value::Table(base))) = (
        toml::Value::try_from(section),
        toml::Value::try_from(defaults),
    ) {
        for (path, value) in leaves(&mine, Vec::new()) {
            let mut candidate = base.clone();
            set(&mut candidate, &path, value);
            let Ok(alone) = toml::Value::Table(candidate).try_into::<DeviceSection>() else {
                continue;
            };
            if let Err(reason) = core_check(&alone, sample_rate, realization) {
                refusals.push(Refusal {
                    key: path.join("."),
                    reason,
                });
            }
        }
    }
    if refusals.is_empty() {
        refusals.push(Refusal {
            key: String::new(),
            reason: whole,
        });
    }
    Err(refusals)
}

/// Every value of `table` that is not itself a table, with its path (arrays are values:
/// a threshold triple or a matrix is one key).
fn leaves(table: &toml::Table, prefix: Vec<String>) -> Vec<(Vec<String>, toml::Value)> {
    let mut out = Vec::new();
    for (key, value) in table {
        let mut path = prefix.clone();
        path.push(key.clone());
        match value {
            toml::Value::Table(inner) => out.extend(leaves(inner, path)),
            other => out.push((path, other.clone())),
        }
    }
    out
}

fn set(table: &mut toml::Table, path: &[String], value: toml::Value) {
    match path {
        [] => {}
        [last] => {
            table.insert(last.clone(), value);
        }
        [first, rest @ ..] => {
            let inner = table
                .entry(first.clone())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if let toml::Value::Table(inner) = inner {
                set(inner, rest, value);
            }
        }
    }
}

/// Where `device.KEY` (`key` dotted under `[device]`; empty: the table itself) is written
/// in the TOML `text`: the 1-based line and column of the key, and its value's text as a
/// message shows it.
pub fn locate(text: &str, key: &str) -> Option<(usize, usize, String)> {
    let document = toml::de::DeTable::parse(text).ok()?;
    let mut table = document.get_ref();
    let mut found = None;
    for part in std::iter::once("device").chain(key.split('.').filter(|p| !p.is_empty())) {
        let (k, v) = table.iter().find(|(k, _)| k.get_ref() == part)?;
        found = Some((k.span(), v.span()));
        if let toml::de::DeValue::Table(inner) = v.get_ref() {
            table = inner;
        }
    }
    let (key_span, value_span) = found?;
    let (line, column) = line_column(text, key_span.start);
    let written = text.get(value_span).unwrap_or_default().trim();
    Some((line, column, value(written).into_owned()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::exposure::AxisMapping;
    use supine_core::model::{ModelParams, Preset, device_realization};
    use supine_core::weighting::WeightingKind;

    fn rate(hz: f32) -> SampleRate {
        SampleRate::new(hz).unwrap()
    }

    fn realization() -> DeviceRealization {
        device_realization(&ModelParams::preset(Preset::PaperLitter), 500.0).unwrap()
    }

    fn refused(section: &DeviceSection) -> Vec<String> {
        let mut keys: Vec<String> = match check(section, rate(500.0), Some(&realization())) {
            Ok(()) => Vec::new(),
            Err(refusals) => refusals.into_iter().map(|r| r.key).collect(),
        };
        keys.sort();
        keys
    }

    #[test]
    fn the_defaults_pass_and_each_bad_value_is_blamed_on_its_own_key() {
        assert!(core_check(&DeviceSection::default(), rate(500.0), Some(&realization())).is_ok());
        assert!(refused(&DeviceSection::default()).is_empty());
        let mut s = DeviceSection::default();
        s.alerts.hysteresis = 2.0;
        s.sensor_checks.full_scale_m_s2 = -1.0;
        s.telemetry_decimation = Some(0);
        s.mounting.sensor_to_litter[0][0] = 2.0;
        s.alerts.vdv_m_s175 = [8.5, f32::NAN, 21.0];
        assert_eq!(
            refused(&s),
            [
                "alerts.hysteresis",
                "alerts.vdv_m_s175",
                "mounting.sensor_to_litter",
                "sensor_checks.full_scale_m_s2",
                "telemetry_decimation"
            ]
        );
        let mut s = DeviceSection::default();
        s.exposure.axes.y.k = 0.0;
        let r = check(&s, rate(500.0), None).unwrap_err();
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].key, "exposure.axes.y.k");
        assert_eq!(
            r[0].reason,
            "exposure: axis factor k must be finite and positive"
        );
    }

    #[test]
    fn a_partial_table_takes_the_defaults_and_weightings_are_read_in_either_case() {
        // An empty table is every default: the core's own constants.
        let empty: DeviceSection = toml::from_str("").unwrap();
        assert_eq!(empty, DeviceSection::default());
        let s: DeviceSection = toml::from_str(
            "[alerts]\nrunning_rms_m_s2 = [0.4, 0.7, 1.1]\n\
             [exposure.axes]\nz = { kind = \"wk\" }\ny = { kind = \"WD\", k = 1.4 }\n",
        )
        .unwrap();
        assert_eq!(s.alerts.running_rms_m_s2, [0.4, 0.7, 1.1]);
        assert_eq!(s.alerts.hysteresis, AlertConfig::DEFAULT.hysteresis);
        assert_eq!(s.alerts.vdv_m_s175, AlertConfig::DEFAULT.vdv_m_s175);
        assert_eq!(s.exposure.axes.z.kind, WeightingKind::Wk);
        assert_eq!(s.exposure.axes.z.k, 1.0);
        assert_eq!(s.exposure.axes.y.kind, WeightingKind::Wd);
        assert_eq!(s.exposure.axes.y.k, 1.4);
        assert_eq!(s.exposure.axes.x, AxisMapping::SUPINE_HEAD.x);
        assert_eq!(s.sensor_checks, SensorCheckConfig::DEFAULT);
        let err = toml::from_str::<DeviceSection>("[exposure.axes.x]\nkind = \"wb\"\n")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("expected one of wk, wd, wj (either case), found \"wb\""),
            "{err}"
        );
        let err = toml::from_str::<DeviceSection>("[alerts]\nhysterisis = 0.1\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("unknown field `hysterisis`"), "{err}");
        let err = toml::from_str::<DeviceSection>("[mounting]\ngravity = 9.8\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("unknown field `gravity`"), "{err}");
        let err = toml::from_str::<DeviceSection>("[exposure.axes.z]\nk = 1.0\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing field `kind`"), "{err}");
    }

    #[test]
    fn the_commented_defaults_read_back_as_the_defaults() {
        let text = commented_defaults();
        assert!(text.lines().all(|l| l.is_empty() || l.starts_with('#')));
        // The prose ends at the first blank line.
        let (prose, tables) = text.split_once("\n\n").expect("prose, then the tables");
        assert!(prose.contains("\"neck_x\", \"neck_y\""), "{prose}");
        let uncommented: String = tables
            .lines()
            .map(|l| l.strip_prefix("# ").unwrap_or(l).to_string() + "\n")
            .collect();
        #[derive(Deserialize)]
        struct Wrapper {
            device: DeviceSection,
        }
        let read: Wrapper = toml::from_str(&uncommented).expect(&uncommented);
        assert_eq!(read.device, DeviceSection::default());
        assert!(uncommented.contains("kind = \"wj\""), "{uncommented}");
    }

    #[test]
    fn a_rate_dependent_rule_is_judged_at_the_rate_given() {
        let mut s = DeviceSection::default();
        // Two samples at 2 kHz, under one at 100 Hz.
        s.exposure.running_tau_s = 0.001;
        assert_eq!(check(&s, rate(2000.0), None), Ok(()));
        assert_eq!(
            check(&s, rate(100.0), None).unwrap_err()[0].key,
            "exposure.running_tau_s"
        );
    }

    #[test]
    fn keys_are_located_however_the_table_is_written() {
        let text = "a = 1\n[device.alerts]\nhysteresis = 2\n[device]\nmounting.gravity_m_s2 = 3\n\
                    telemetry_decimation = 0\nsensor_checks = { full_scale_m_s2 = -1 }\n";
        assert_eq!(
            locate(text, "alerts.hysteresis"),
            Some((3, 1, "2".to_string()))
        );
        assert_eq!(
            locate(text, "mounting.gravity_m_s2"),
            Some((5, 10, "3".to_string()))
        );
        assert_eq!(
            locate(text, "telemetry_decimation"),
            Some((6, 1, "0".to_string()))
        );
        assert_eq!(
            locate(text, "sensor_checks.full_scale_m_s2"),
            Some((7, 19, "-1".to_string()))
        );
        assert_eq!(locate(text, "alerts.clear_dwell_s"), None);
        // The table itself: where `device` is named (either of its headers).
        assert!(matches!(locate(text, ""), Some((2 | 4, ..))));
    }
}
