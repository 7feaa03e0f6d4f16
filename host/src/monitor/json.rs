//! The monitor's machine-readable forms: `--jsonl`, one JSON object per telemetry record
//! and per notice (alert event, greeting, status) as they arrive, and `--json`, the
//! closing summary as one object. Units are in the key names, as in the CSV log.

use crate::io::telemetry_csv::joint_columns;
use std::io::Write;

use anyhow::{Result, anyhow};
use serde_json::{Value, json};
use supine_core::alerts::AlertEvent;
use supine_core::pipeline::Telemetry;

use super::state::{Monitor, Notice, fault_names};
use super::view::{View, output_error};
use crate::schema::event::EventCriterion;
use crate::schema::shortest;
use crate::schema::subject::SubjectRecord;

/// One telemetry record as a JSON object, its time at `sample_rate_hz`.
pub fn telemetry_json(t: &Telemetry, sample_rate_hz: f64, joint_mask: u16) -> Value {
    let joints: serde_json::Map<String, Value> = joint_columns(joint_mask)
        .into_iter()
        .zip(t.joints.as_slice())
        .map(|(name, &v)| (name, json!(shortest(v))))
        .collect();
    json!({
        "type": "telemetry",
        "sample": t.sample_index,
        "time_s": f64::from(t.sample_index) / sample_rate_hz,
        "head_m_s2": t.head_acc_m_s2,
        "running_rms_m_s2": t.running_rms_m_s2,
        "vector_running_rms_m_s2": t.vector_running_rms_m_s2,
        "vdv_m_s175": t.vdv_m_s175,
        "level": t.alert_level.name(),
        "faults": fault_names(t.fault_flags),
        "valid": t.valid,
        "joints": joints,
    })
}

/// One alert event as a JSON object.
pub fn event_json(e: &AlertEvent, sample_rate_hz: f64) -> Value {
    let sample = e.at_sample();
    let time_s = f64::from(sample) / sample_rate_hz;
    match *e {
        AlertEvent::Level {
            from,
            to,
            criterion,
            ..
        } => {
            let mut event = json!({
                "type": "event", "kind": "level", "sample": sample, "time_s": time_s,
                "from": from.name(), "to": to.name(), "raised": to > from,
                "criterion": criterion.name(),
            });
            let (key, value) = EventCriterion::Exposure(criterion).value();
            event[key] = json!(shortest(value as f32));
            event
        }
        AlertEvent::Fault { fault, active, .. } => json!({
            "type": "event", "kind": "fault", "sample": sample, "time_s": time_s,
            "fault": fault.name(), "raised": active,
        }),
        AlertEvent::Joint { raised, .. } => {
            let mut event = json!({
                "type": "event", "kind": "joint", "sample": sample, "time_s": time_s,
                "raised": raised,
            });
            if let Some(c @ EventCriterion::Joint(output, _)) = EventCriterion::of(e) {
                event["output"] = json!(output.name());
                event["criterion"] = json!(c.name());
                let (key, value) = c.value();
                event[key] = json!(shortest(value as f32));
            }
            event
        }
    }
}

/// The closing summary (what [`Monitor::summary`] says) as one JSON object.
pub fn summary_json(m: &Monitor) -> Value {
    let c = m.counters();
    json!({
        "monitored_s": m.time_s(),
        "subject": SubjectRecord::new(m.greeting().height_m, m.greeting().mass_kg),
        "ride_s": m.ride_length_s(),
        "telemetry_records": c.telemetry,
        "alert_events": c.events,
        "alerts_raised": c.raised,
        "highest_level": m.highest_level().name(),
        "final_level": m.level().name(),
        "peak_head_m_s2": m.peak_head_m_s2(),
        "peak_vector_running_rms_m_s2": m.peak_vector_rms_m_s2(),
        "vdv_m_s175": m.latest().map(|t| t.vdv_m_s175),
        "link": {
            "frames": c.link.frames,
            "lost_frames": c.link.lost_frames,
            "bad_frames": c.link.bad_frames,
            "reordered_frames": c.link.reordered_frames,
        },
        "device": m.status().map(|s| json!({
            "samples_processed": s.samples_processed,
            "samples_dropped": s.samples_dropped,
            "bad_frames": s.bad_frames,
        })),
    })
}

/// `--jsonl`: a line per telemetry record, alert event and other notice, nothing else.
pub struct JsonlView<W: Write> {
    out: W,
    records_written: u64,
    events_written: u64,
}

impl<W: Write> JsonlView<W> {
    /// Writes to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            records_written: 0,
            events_written: 0,
        }
    }

    /// Gives the writer back (tests read what was written).
    pub fn into_inner(self) -> W {
        self.out
    }

    fn line(&mut self, value: &Value) -> Result<()> {
        writeln!(self.out, "{value}").map_err(output_error)
    }

    /// Writes the telemetry record and the events that arrived since the last call (the
    /// session calls [`View::refresh`] after every message, so each record is seen).
    fn catch_up(&mut self, m: &Monitor) -> Result<()> {
        let c = m.counters();
        if c.telemetry > self.records_written
            && let Some(t) = m.latest()
        {
            self.records_written = c.telemetry;
            let mask = m.greeting().joint_outputs;
            self.line(&telemetry_json(t, m.sample_rate_hz(), mask))?;
        }
        if c.events > self.events_written {
            let new = (c.events - self.events_written) as usize;
            let history: Vec<_> = m.history().collect();
            let skip = history.len().saturating_sub(new);
            for e in &history[skip..] {
                self.line(&event_json(e, m.sample_rate_hz()))?;
            }
            self.events_written = c.events;
        }
        self.out
            .flush()
            .map_err(|e| anyhow!("writing the monitor's output: {e}"))
    }
}

impl<W: Write> View for JsonlView<W> {
    fn notice(&mut self, m: &Monitor, notice: &Notice) -> Result<()> {
        // Alert events come out structured from `catch_up`; other notices as text.
        if m.counters().events > self.events_written {
            return self.catch_up(m);
        }
        self.line(&json!({
            "type": "notice",
            "severity": notice.severity.tag(),
            "text": notice.text,
        }))
    }

    fn refresh(&mut self, m: &Monitor) -> Result<()> {
        self.catch_up(m)
    }

    fn close(&mut self, m: &Monitor) -> Result<()> {
        self.catch_up(m)
    }
}
