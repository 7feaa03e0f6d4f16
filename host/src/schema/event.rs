//! An alert's criterion and its value, as every output names them: the core's criterion
//! name under `criterion` (`running-rms`, `vdv`, `excursion`), the joint output under
//! `output` for a joint alert, and the value under a key that carries its unit:
//! `value_m_s2` (running rms), `value_m_s175` (VDV), `value_mm` or `value_deg` (a joint
//! output, in the unit a person reads: [`JointUnit::display`]).

use serde::ser::SerializeMap;
use supine_core::alerts::{AlertEvent, Criterion, JointCriterion};
use supine_core::model::{JointOutput, JointUnit};

/// What changed an alert, with its value then.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EventCriterion {
    /// The head's exposure level: its running rms or its VDV.
    Exposure(Criterion),
    /// A joint output's running rms or excursion.
    Joint(JointOutput, JointCriterion),
}

impl EventCriterion {
    /// The criterion of a core event (none for a sensor fault).
    pub fn of(e: &AlertEvent) -> Option<Self> {
        e.criterion().map(EventCriterion::Exposure).or_else(|| {
            e.joint_criterion()
                .map(|(output, c)| EventCriterion::Joint(output, c))
        })
    }

    /// The core's name of the criterion: `running-rms`, `vdv` or `excursion`.
    pub fn name(&self) -> &'static str {
        match self {
            EventCriterion::Exposure(c) => c.name(),
            EventCriterion::Joint(_, c) => c.name(),
        }
    }

    /// The key of the value, with its unit, and the value in that unit.
    pub fn value(&self) -> (&'static str, f64) {
        match *self {
            EventCriterion::Exposure(Criterion::RunningRms { value_m_s2 }) => {
                ("value_m_s2", f64::from(value_m_s2))
            }
            EventCriterion::Exposure(Criterion::Vdv { value_m_s175 }) => {
                ("value_m_s175", f64::from(value_m_s175))
            }
            EventCriterion::Joint(output, c) => {
                let (unit, scale) = output.unit().display();
                let key = match output.unit() {
                    JointUnit::Metre => "value_mm",
                    JointUnit::Radian => "value_deg",
                };
                debug_assert!(key.ends_with(unit));
                (key, scale * f64::from(c.value_m_or_rad()))
            }
        }
    }

    /// The unit of [`value`](Self::value) as a person reads it: `m/s^2`, `m/s^1.75`, `mm`
    /// or `deg`.
    pub fn unit(&self) -> &'static str {
        match self {
            EventCriterion::Exposure(c) => c.unit(),
            EventCriterion::Joint(output, _) => output.unit().display().0,
        }
    }
}

/// Serializes an optional criterion as flat keys (use with `#[serde(flatten,
/// serialize_with = "criterion_fields")]`): `criterion`, `output` for a joint alert, and
/// the value under its unit's key; nothing for none.
pub fn criterion_fields<S: serde::Serializer>(
    c: &Option<EventCriterion>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    let mut map = serializer.serialize_map(None)?;
    if let Some(c) = c {
        map.serialize_entry("criterion", c.name())?;
        if let EventCriterion::Joint(output, _) = c {
            map.serialize_entry("output", output.name())?;
        }
        let (key, value) = c.value();
        map.serialize_entry(key, &value)?;
    }
    map.end()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Row {
        #[serde(flatten, serialize_with = "criterion_fields")]
        criterion: Option<EventCriterion>,
    }

    #[test]
    fn each_criterion_names_its_value_with_its_unit() {
        let json = |c| serde_json::to_value(Row { criterion: c }).unwrap();
        let vdv = EventCriterion::Exposure(Criterion::Vdv { value_m_s175: 8.5 });
        assert_eq!(
            json(Some(vdv)),
            serde_json::json!({"criterion": "vdv", "value_m_s175": 8.5})
        );
        let neck_ry = JointOutput::ALL[3];
        let joint = EventCriterion::Joint(
            neck_ry,
            JointCriterion::Excursion {
                value_m_or_rad: core::f32::consts::PI / 2.0,
            },
        );
        let v = json(Some(joint));
        assert_eq!(v["criterion"], "excursion");
        assert_eq!(v["output"], neck_ry.name());
        assert!(
            (v["value_deg"].as_f64().unwrap() - 90.0).abs() < 1e-5,
            "{v}"
        );
        assert_eq!(json(None), serde_json::json!({}));
    }
}
