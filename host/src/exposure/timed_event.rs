//! One entry of an evaluation's alert timeline: a core alert event stamped with the time of
//! its sample.

use serde::Serialize;
use supine_core::alerts::{AlertEvent, Criterion};

use crate::io::wording::joint_alert_text;

/// One entry of the alert timeline.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimedEvent {
    /// Time of the event in the recording's time base, s.
    pub time_s: f64,
    /// Sample index from the first evaluated sample (0-based, at the evaluation's rate).
    pub sample: u32,
    /// `level` (exposure level change) or `fault` (sensor fault raised or cleared).
    pub kind: &'static str,
    /// What happened, e.g. `normal -> warning` or `saturated raised`.
    pub event: String,
    /// The level after a level change (absent for faults).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<&'static str>,
    /// The event raises (rather than clears) an alert.
    pub raise: bool,
    /// What changed the level, with its value then (absent for faults): serialized as
    /// `criterion` (`running-rms` or `vdv`) and `value_m_s2` or `value_m_s175`.
    #[serde(flatten, serialize_with = "criterion_fields")]
    pub criterion: Option<Criterion>,
}

/// [`TimedEvent::criterion`] as flat keys with the unit in the value's name.
fn criterion_fields<S: serde::Serializer>(
    c: &Option<Criterion>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = serializer.serialize_map(None)?;
    if let Some(c) = c {
        map.serialize_entry("criterion", c.name())?;
        let key = match c {
            Criterion::RunningRms { .. } => "value_m_s2",
            Criterion::Vdv { .. } => "value_m_s175",
        };
        map.serialize_entry(key, &f64::from(c.value()))?;
    }
    map.end()
}

impl TimedEvent {
    /// Stamps a core event with the time of its sample.
    pub fn new(e: &AlertEvent, start_s: f64, sample_rate_hz: f64) -> Self {
        let sample = e.at_sample();
        let time_s = start_s + sample as f64 / sample_rate_hz;
        match *e {
            AlertEvent::Level { from, to, .. } => Self {
                time_s,
                sample,
                kind: "level",
                event: format!("{from} -> {to}"),
                level: Some(to.name()),
                raise: e.is_raise(),
                criterion: e.criterion(),
            },
            AlertEvent::Fault { fault, active, .. } => Self {
                time_s,
                sample,
                kind: "fault",
                event: format!("{fault} {}", if active { "raised" } else { "cleared" }),
                level: None,
                raise: active,
                criterion: None,
            },
            AlertEvent::Joint { raised, .. } => Self {
                time_s,
                sample,
                kind: "joint",
                event: e
                    .joint_criterion()
                    .map_or_else(String::new, |(o, c)| joint_alert_text(o, &c, raised)),
                level: None,
                raise: raised,
                criterion: None,
            },
        }
    }
}
