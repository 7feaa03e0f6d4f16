//! One entry of an evaluation's alert timeline: a core alert event stamped with the time of
//! its sample.

use serde::Serialize;
use supine_core::alerts::{AlertEvent, Level};

use crate::schema::event::{EventCriterion, criterion_fields};

use crate::io::wording::joint_alert_text;

/// One entry of the alert timeline.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimedEvent {
    /// Time of the event in the recording's time base, s.
    pub time_s: f64,
    /// Sample index from the first evaluated sample (0-based, at the evaluation's rate).
    pub sample: u32,
    /// `level` (exposure level change), `fault` (sensor fault raised or cleared) or
    /// `joint` (a joint output's alert).
    pub kind: &'static str,
    /// What happened, e.g. `normal -> warning` or `saturated raised`.
    pub event: String,
    /// The level after a level change (absent for faults and joint alerts).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<Level>,
    /// The event raises (rather than clears) an alert.
    pub raised: bool,
    /// What changed the alert, with its value then (absent for faults): serialized as
    /// [`criterion_fields`] names it.
    #[serde(flatten, serialize_with = "criterion_fields")]
    pub criterion: Option<EventCriterion>,
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
                level: Some(to),
                raised: e.is_raise(),
                criterion: EventCriterion::of(e),
            },
            AlertEvent::Fault { fault, active, .. } => Self {
                time_s,
                sample,
                kind: "fault",
                event: format!("{fault} {}", if active { "raised" } else { "cleared" }),
                level: None,
                raised: active,
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
                raised,
                criterion: EventCriterion::of(e),
            },
        }
    }
}
