//! What the monitor knows about a device: the latest telemetry, the alert level and its
//! history, the active faults, and counters. Pure state: fed one message at a time, read
//! by the views, the log and `supine demo`; no terminal, no I/O.

use std::collections::VecDeque;

use anyhow::Result;
use supine_core::alerts::{AlertConfig, AlertEvent, Criterion, FaultFlags, Level};
use supine_core::model::JointOutput;
use supine_core::protocol::{DeviceToHost, Greeting, Status, Telemetry};

use crate::device::device_params::identity_hex;
pub use crate::device::device_params::params_source_text;
use crate::device::link::{LinkStats, check_protocol};
use crate::io::wording::joint_alert_text;

/// Alert events kept for the view (the log keeps all of them).
pub const HISTORY_LEN: usize = 8;

/// How an event is shown: its colour in the live view, its tag in plain lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// Nothing to act on (a greeting, a cleared alert).
    Info,
    /// The exposure reached advisory.
    Advisory,
    /// The exposure reached warning.
    Warning,
    /// The exposure reached alarm.
    Alarm,
    /// A sensor fault started: the prediction is not trustworthy.
    Fault,
}

impl Severity {
    /// Upper-case tag for plain output (`INFO`, `ADVISORY`, `WARNING`, `ALARM`, `FAULT`).
    pub const fn tag(self) -> &'static str {
        match self {
            Severity::Info => "INFO",
            Severity::Advisory => "ADVISORY",
            Severity::Warning => "WARNING",
            Severity::Alarm => "ALARM",
            Severity::Fault => "FAULT",
        }
    }

    /// The severity of showing the alert level `level` (normal is informational).
    pub const fn of_level(level: Level) -> Severity {
        match level {
            Level::Normal => Severity::Info,
            Level::Advisory => Severity::Advisory,
            Level::Warning => Severity::Warning,
            Level::Alarm => Severity::Alarm,
        }
    }

    /// How an alert event is highlighted: a raise by what it raised, a clear as info.
    pub fn of_event(event: &AlertEvent) -> Severity {
        match *event {
            AlertEvent::Level { from, to, .. } if to > from => Severity::of_level(to),
            AlertEvent::Fault { active: true, .. } => Severity::Fault,
            // A threshold a medical director set for the patient's spine was passed.
            AlertEvent::Joint { raised: true, .. } => Severity::Warning,
            _ => Severity::Info,
        }
    }
}

/// Something to show at once (scrolling above the panel, or one plain line).
#[derive(Clone, Debug, PartialEq)]
pub struct Notice {
    /// How to highlight it.
    pub severity: Severity,
    /// One line of text, without the tag.
    pub text: String,
}

/// Names of the faults in `fault_flags`, in bit order (`SensorFault::ALL`).
pub fn fault_names(fault_flags: FaultFlags) -> Vec<String> {
    fault_flags.iter().map(|f| f.name().to_string()).collect()
}

/// One line describing an alert event, with its time at `sample_rate_hz`.
pub fn describe_event(event: &AlertEvent, sample_rate_hz: f64) -> String {
    let at = event.at_sample();
    let when = format!("t {:.3} s (sample {at})", f64::from(at) / sample_rate_hz);
    match *event {
        AlertEvent::Level {
            from,
            to,
            criterion,
            ..
        } => {
            let verb = if to > from { "raised" } else { "lowered" };
            format!(
                "{when}: alert level {verb} {from} -> {to} by {}",
                criterion_text(&criterion)
            )
        }
        AlertEvent::Fault { fault, active, .. } => {
            let verb = if active { "raised" } else { "cleared" };
            format!("{when}: sensor fault {fault} {verb}")
        }
        AlertEvent::Joint { raised, .. } => match event.joint_criterion() {
            Some((output, criterion)) => format!(
                "{when}: joint alert {}",
                joint_alert_text(output, &criterion, raised)
            ),
            None => format!("{when}: joint alert on an unknown output"),
        },
    }
}

/// What changed a level, as the monitor shows it: `vdv 17.012 m/s^1.75`.
pub fn criterion_text(c: &Criterion) -> String {
    format!("{} {:.3} {}", c.name(), c.value(), c.unit())
}

/// The patient the device's parameters were scaled to: `patient 1.82 m, 81 kg`.
pub fn patient_text(height_m: f32, mass_kg: f32) -> String {
    format!("patient {height_m} m, {mass_kg} kg")
}

/// Counters of a monitoring session.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Telemetry records received.
    pub telemetry: u64,
    /// Alert events received (raises and clears).
    pub events: u64,
    /// Alert events that raised something.
    pub raised: u64,
    /// Greetings after the first (the device restarted or was asked to greet).
    pub greetings: u64,
    /// Status reports received.
    pub statuses: u64,
    /// Other messages (parameter acks and nacks).
    pub other: u64,
    /// Input-stream frames received (the log writes their samples).
    pub input_frames: u64,
    /// The link's frame counters (decoded, bad, lost, reordered), as last reported.
    pub link: LinkStats,
}

/// The monitor's view of one device.
#[derive(Clone, Debug)]
pub struct Monitor {
    greeting: Greeting,
    sample_rate_hz: f64,
    latest: Option<Telemetry>,
    level: Level,
    highest_level: Level,
    faults: FaultFlags,
    peak_head_m_s2: f32,
    peak_vector_rms_m_s2: f32,
    history: VecDeque<AlertEvent>,
    status: Option<Status>,
    counters: Counters,
    ride_length_s: Option<f64>,
    thresholds: Option<AlertConfig>,
    /// The joint alerts raised and not cleared, as (output, criterion name), in the
    /// order they were raised.
    joint_alerts_raised: Vec<(JointOutput, &'static str)>,
}

impl Monitor {
    /// Starts monitoring the device that sent `greeting`; refuses another protocol
    /// version (with what to update) and a sample rate that is not positive.
    pub fn new(greeting: &Greeting) -> Result<Self> {
        check_protocol(greeting.protocol_version)?;
        let sample_rate_hz = f64::from(greeting.sample_rate_hz);
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            anyhow::bail!("the device's greeting gives a sample rate of {sample_rate_hz} Hz");
        }
        Ok(Self {
            greeting: greeting.clone(),
            sample_rate_hz,
            latest: None,
            level: Level::Normal,
            highest_level: Level::Normal,
            faults: FaultFlags::empty(),
            peak_head_m_s2: 0.0,
            peak_vector_rms_m_s2: 0.0,
            history: VecDeque::with_capacity(HISTORY_LEN),
            status: None,
            counters: Counters::default(),
            ride_length_s: None,
            thresholds: None,
            joint_alerts_raised: Vec::new(),
        })
    }

    /// Sets the length of the ride being streamed, s (known for QEMU, not for a device
    /// in service): the panel then shows `t of T s`.
    pub fn set_ride_length_s(&mut self, ride_length_s: Option<f64>) {
        self.ride_length_s = ride_length_s;
    }

    /// Sets the device's alert thresholds (known when this host built its parameters):
    /// the panel then shows them beside the values.
    pub fn set_thresholds(&mut self, thresholds: Option<AlertConfig>) {
        self.thresholds = thresholds;
    }

    /// The device's alert thresholds, when they are known.
    pub fn thresholds(&self) -> Option<AlertConfig> {
        self.thresholds
    }

    /// The length of the ride being streamed, s, when it is known.
    pub fn ride_length_s(&self) -> Option<f64> {
        self.ride_length_s
    }

    /// Takes one message from the device; returns what to show at once, if anything.
    /// Errors only on a (new) greeting in another protocol version.
    pub fn on_message(&mut self, message: &DeviceToHost) -> Result<Option<Notice>> {
        match message {
            DeviceToHost::Telemetry(t) => {
                self.counters.telemetry += 1;
                self.level = t.alert_level;
                self.highest_level = self.highest_level.max(t.alert_level);
                self.faults = t.fault_flags;
                let [x, y, z] = t.head_acc_m_s2;
                let magnitude = (x * x + y * y + z * z).sqrt();
                self.peak_head_m_s2 = peak_of(self.peak_head_m_s2, magnitude);
                if t.valid {
                    self.peak_vector_rms_m_s2 =
                        peak_of(self.peak_vector_rms_m_s2, t.vector_running_rms_m_s2);
                }
                self.latest = Some(*t);
                Ok(None)
            }
            DeviceToHost::Alert(e) => {
                self.counters.events += 1;
                if e.is_raise() {
                    self.counters.raised += 1;
                }
                match *e {
                    AlertEvent::Level { to, .. } => {
                        self.level = to;
                        self.highest_level = self.highest_level.max(to);
                    }
                    AlertEvent::Fault { fault, active, .. } => {
                        if active {
                            self.faults.insert(fault);
                        } else {
                            self.faults.remove(fault);
                        }
                    }
                    AlertEvent::Joint { raised, .. } => {
                        if let Some((output, criterion)) = e.joint_criterion() {
                            let key = (output, criterion.name());
                            self.joint_alerts_raised.retain(|k| *k != key);
                            if raised {
                                self.joint_alerts_raised.push(key);
                            }
                        }
                    }
                }
                if self.history.len() == HISTORY_LEN {
                    self.history.pop_front();
                }
                self.history.push_back(*e);
                Ok(Some(Notice {
                    severity: Severity::of_event(e),
                    text: describe_event(e, self.sample_rate_hz),
                }))
            }
            DeviceToHost::Greeting(g) => {
                check_protocol(g.protocol_version)?;
                self.counters.greetings += 1;
                let changed = g.params_identity != self.greeting.params_identity
                    || g.sample_rate_hz != self.greeting.sample_rate_hz;
                self.greeting = g.clone();
                if g.sample_rate_hz.is_finite() && g.sample_rate_hz > 0.0 {
                    self.sample_rate_hz = f64::from(g.sample_rate_hz);
                }
                Ok(Some(Notice {
                    severity: Severity::Info,
                    text: format!(
                        "the device greeted again ({}, reset cause {:?}){}",
                        device_line(g),
                        g.reset_cause,
                        if changed { "; parameters changed" } else { "" }
                    ),
                }))
            }
            DeviceToHost::Status(s) => {
                self.counters.statuses += 1;
                self.status = Some(*s);
                Ok(None)
            }
            DeviceToHost::ParamAck(_) | DeviceToHost::ParamNack(_) => {
                self.counters.other += 1;
                Ok(None)
            }
            DeviceToHost::Input(_) => {
                self.counters.input_frames += 1;
                Ok(None)
            }
        }
    }

    /// Records the link's frame counters (decoded, bad, lost, reordered).
    pub fn on_link(&mut self, stats: LinkStats) {
        self.counters.link = stats;
    }

    /// The joint alerts raised and not cleared, as (output, criterion name such as
    /// `running-rms`), in the order they were raised.
    pub fn joint_alerts_raised(&self) -> &[(JointOutput, &'static str)] {
        &self.joint_alerts_raised
    }

    /// The greeting in force (the latest one).
    pub fn greeting(&self) -> &Greeting {
        &self.greeting
    }

    /// The device's sample rate, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// The latest telemetry record.
    pub fn latest(&self) -> Option<&Telemetry> {
        self.latest.as_ref()
    }

    /// The current alert level (from the latest telemetry or alert event).
    pub fn level(&self) -> Level {
        self.level
    }

    /// The highest alert level seen.
    pub fn highest_level(&self) -> Level {
        self.highest_level
    }

    /// The active faults.
    pub fn fault_flags(&self) -> FaultFlags {
        self.faults
    }

    /// Names of the active faults.
    pub fn fault_names(&self) -> Vec<String> {
        fault_names(self.faults)
    }

    /// Largest predicted head acceleration magnitude seen, m/s^2.
    pub fn peak_head_m_s2(&self) -> f32 {
        self.peak_head_m_s2
    }

    /// Largest valid vector running rms seen, m/s^2.
    pub fn peak_vector_rms_m_s2(&self) -> f32 {
        self.peak_vector_rms_m_s2
    }

    /// The last alert events, oldest first (at most [`HISTORY_LEN`]).
    pub fn history(&self) -> impl Iterator<Item = &AlertEvent> {
        self.history.iter()
    }

    /// The device's last status report.
    pub fn status(&self) -> Option<&Status> {
        self.status.as_ref()
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Seconds of signal covered so far (from the latest telemetry's sample index).
    pub fn time_s(&self) -> f64 {
        self.latest
            .map_or(0.0, |t| f64::from(t.sample_index) / self.sample_rate_hz)
    }

    /// One plain status line: time, head, running rms, VDV, level, faults, counters.
    pub fn render_line(&self) -> String {
        let c = &self.counters;
        let values = match &self.latest {
            None => "no telemetry yet".to_string(),
            Some(t) => {
                let [hx, hy, hz] = t.head_acc_m_s2;
                let [rx, ry, rz] = t.running_rms_m_s2;
                format!(
                    "t {:.2}{} s  head {hx:+.3} {hy:+.3} {hz:+.3} m/s^2  rms {rx:.3} {ry:.3} {rz:.3} (vector {:.3}) m/s^2  VDV {:.3} m/s^1.75{}",
                    self.time_s(),
                    self.ride_length_s
                        .map_or(String::new(), |total_s| format!(" of {total_s:.2}")),
                    t.vector_running_rms_m_s2,
                    t.vdv_m_s175,
                    if t.valid { "" } else { " (settling)" },
                )
            }
        };
        format!(
            "{values}  level {}  faults {}  frames {} lost {} bad {}  events {}",
            self.level,
            self.faults_text(),
            c.link.frames,
            c.link.lost_frames,
            c.link.bad_frames,
            c.events
        )
    }

    /// The active faults as text (`none`, or names joined with `+`).
    pub fn faults_text(&self) -> String {
        let names = self.fault_names();
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join("+")
        }
    }

    /// A closing summary: what was received, the worst exposure, the link's losses.
    pub fn summary(&self) -> String {
        let c = &self.counters;
        let vdv = self.latest.map_or(0.0, |t| t.vdv_m_s175);
        let mut text = format!(
            "monitored {:.2} s: {} telemetry records, {} alert events ({} raised), highest level {}, peak head {:.3} m/s^2, peak running rms {:.3} m/s^2, VDV {:.3} m/s^1.75; frames {}, lost {}, bad {}, reordered {}",
            self.time_s(),
            c.telemetry,
            c.events,
            c.raised,
            self.highest_level,
            self.peak_head_m_s2,
            self.peak_vector_rms_m_s2,
            vdv,
            c.link.frames,
            c.link.lost_frames,
            c.link.bad_frames,
            c.link.reordered_frames,
        );
        let g = &self.greeting;
        text.push_str(&format!("; {}", patient_text(g.height_m, g.mass_kg)));
        if let Some(s) = &self.status {
            text.push_str(&format!(
                "; device: {} samples processed, {} dropped, {} bad frames received",
                s.samples_processed, s.samples_dropped, s.bad_frames
            ));
        }
        text
    }
}

/// The device in one line: firmware, parameters and their source, sample rate, patient.
pub fn device_line(g: &Greeting) -> String {
    let source = params_source_text(g.params_source);
    format!(
        "firmware {}, protocol {}, parameters {} from {source}, {} Hz, {}",
        g.firmware_version.as_str(),
        g.protocol_version,
        identity_hex(&g.params_identity),
        g.sample_rate_hz,
        patient_text(g.height_m, g.mass_kg)
    )
}

/// The larger of a peak so far and a new value, where a NaN stays NaN: a summary must
/// show that a device sent a value that is not a number, never skip it (`f32::max`
/// ignores NaN).
fn peak_of(peak: f32, value: f32) -> f32 {
    if peak.is_nan() || value.is_nan() {
        f32::NAN
    } else {
        peak.max(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::SensorFault;
    use supine_core::protocol::{PROTOCOL_VERSION, ParamsSource, ResetCause};

    pub(crate) fn greeting(protocol_version: u16) -> Greeting {
        Greeting {
            protocol_version,
            firmware_version: heapless::String::try_from("0.1.0+test").expect("fits"),
            params_identity: [7; 16],
            params_source: ParamsSource::Flash { slot: 0 },
            sample_rate_hz: 500.0,
            height_m: 1.82,
            mass_kg: 81.0,
            reset_cause: ResetCause::PowerOn,
            last_panic: heapless::String::new(),
            joint_outputs: 0,
            calibration: supine_core::calibration::SensorCalibration::DATASHEET,
        }
    }

    fn telemetry(sample_index: u32, level: Level, fault_flags: FaultFlags) -> Telemetry {
        Telemetry {
            sample_index,
            head_acc_m_s2: [0.3, -0.4, 1.2],
            running_rms_m_s2: [0.1, 0.2, 0.6],
            vector_running_rms_m_s2: 0.7,
            vdv_m_s175: 1.5,
            alert_level: level,
            fault_flags,
            valid: true,
            joints: supine_core::joint_exposure::JointValues::EMPTY,
        }
    }

    #[test]
    fn a_non_finite_value_from_the_device_shows_in_the_summary() {
        let mut m = Monitor::new(&greeting(PROTOCOL_VERSION)).expect("monitor");
        let normal = telemetry(1, Level::Normal, FaultFlags::empty());
        let nan = Telemetry {
            vector_running_rms_m_s2: f32::NAN,
            head_acc_m_s2: [f32::INFINITY, 0.0, 0.0],
            ..telemetry(2, Level::Normal, FaultFlags::empty())
        };
        for t in [normal, nan, normal] {
            m.on_message(&DeviceToHost::Telemetry(t)).expect("ok");
        }
        assert!(m.peak_vector_rms_m_s2().is_nan());
        assert_eq!(m.peak_head_m_s2(), f32::INFINITY);
        let summary = m.summary();
        assert!(summary.contains("peak running rms NaN"), "{summary}");
    }

    #[test]
    fn another_protocol_version_is_refused_with_what_to_update() {
        let newer = Monitor::new(&greeting(PROTOCOL_VERSION + 1))
            .expect_err("refused")
            .to_string();
        assert!(
            newer.contains(&format!(
                "protocol version {}, this supine speaks {PROTOCOL_VERSION}",
                PROTOCOL_VERSION + 1
            )),
            "{newer}"
        );
        assert!(newer.contains("update this host tool"), "{newer}");
        let older = Monitor::new(&greeting(PROTOCOL_VERSION - 1))
            .expect_err("refused")
            .to_string();
        assert!(older.contains("reflash the device"), "{older}");
        // A device that restarts mid-session with another version is refused too.
        let mut m = Monitor::new(&greeting(PROTOCOL_VERSION)).expect("same version");
        let again = DeviceToHost::Greeting(greeting(PROTOCOL_VERSION + 1));
        assert!(m.on_message(&again).is_err());
    }

    #[test]
    fn fault_flags_are_named_in_bit_order() {
        let named = |byte: u8| fault_names(FaultFlags::try_from_repr(byte).expect("known bits"));
        assert!(named(0).is_empty());
        assert_eq!(named(0b0001), ["non-finite"]);
        assert_eq!(named(0b1010), ["saturated", "index-gap"]);
        assert_eq!(
            named(0b1111),
            ["non-finite", "saturated", "stuck", "index-gap"]
        );
    }

    #[test]
    fn events_are_highlighted_by_what_they_raise_and_clears_are_info() {
        let level = |from, to| AlertEvent::Level {
            from,
            to,
            criterion: Criterion::RunningRms { value_m_s2: 0.6 },
            at_sample: 1000,
        };
        assert_eq!(
            Severity::of_event(&level(Level::Normal, Level::Advisory)),
            Severity::Advisory
        );
        assert_eq!(
            Severity::of_event(&level(Level::Advisory, Level::Warning)),
            Severity::Warning
        );
        assert_eq!(
            Severity::of_event(&level(Level::Normal, Level::Alarm)),
            Severity::Alarm
        );
        assert_eq!(
            Severity::of_event(&level(Level::Alarm, Level::Warning)),
            Severity::Info
        );
        let fault = |active| AlertEvent::Fault {
            fault: SensorFault::Stuck,
            active,
            at_sample: 1000,
        };
        assert_eq!(Severity::of_event(&fault(true)), Severity::Fault);
        assert_eq!(Severity::of_event(&fault(false)), Severity::Info);
        assert_eq!(
            describe_event(&level(Level::Warning, Level::Advisory), 500.0),
            "t 2.000 s (sample 1000): alert level lowered warning -> advisory by running-rms 0.600 m/s^2"
        );
        assert_eq!(
            describe_event(&fault(true), 250.0),
            "t 4.000 s (sample 1000): sensor fault stuck raised"
        );
    }

    #[test]
    fn the_state_follows_telemetry_and_events() {
        let mut m = Monitor::new(&greeting(PROTOCOL_VERSION)).expect("monitor");
        assert!(m.latest().is_none());
        assert!(m.render_line().starts_with("no telemetry yet"));
        let t = telemetry(1000, Level::Normal, FaultFlags::empty());
        assert_eq!(m.on_message(&DeviceToHost::Telemetry(t)).expect("ok"), None);
        assert_eq!(m.time_s(), 2.0);
        let raise = AlertEvent::Level {
            from: Level::Normal,
            to: Level::Warning,
            criterion: Criterion::RunningRms { value_m_s2: 0.6 },
            at_sample: 1001,
        };
        let notice = m
            .on_message(&DeviceToHost::Alert(raise))
            .expect("ok")
            .expect("an event is shown at once");
        assert_eq!(notice.severity, Severity::Warning);
        assert_eq!(m.level(), Level::Warning);
        let fault = AlertEvent::Fault {
            fault: SensorFault::IndexGap,
            active: true,
            at_sample: 1002,
        };
        m.on_message(&DeviceToHost::Alert(fault)).expect("ok");
        assert_eq!(m.fault_names(), ["index-gap"]);
        assert_eq!(m.faults_text(), "index-gap");
        let lower = AlertEvent::Level {
            from: Level::Warning,
            to: Level::Normal,
            criterion: Criterion::RunningRms { value_m_s2: 0.6 },
            at_sample: 4000,
        };
        m.on_message(&DeviceToHost::Alert(lower)).expect("ok");
        // The next telemetry is the device's word on the level and faults.
        m.on_message(&DeviceToHost::Telemetry(telemetry(
            4001,
            Level::Normal,
            SensorFault::Saturated.into(),
        )))
        .expect("ok");
        assert_eq!(m.level(), Level::Normal);
        assert_eq!(m.highest_level(), Level::Warning);
        assert_eq!(m.fault_names(), ["saturated"]);
        let c = m.counters();
        assert_eq!((c.telemetry, c.events, c.raised), (2, 3, 2));
        assert_eq!(m.history().count(), 3);
        assert!(
            (m.peak_head_m_s2() - 1.3).abs() < 1e-6,
            "{}",
            m.peak_head_m_s2()
        );
        let line = m.render_line();
        assert!(line.contains("t 8.00 s"), "{line}");
        assert!(line.contains("VDV 1.500 m/s^1.75"), "{line}");
        assert!(line.contains("level normal  faults saturated"), "{line}");
        // The history keeps the last HISTORY_LEN events.
        for k in 0..20 {
            m.on_message(&DeviceToHost::Alert(AlertEvent::Fault {
                fault: SensorFault::Stuck,
                active: k % 2 == 0,
                at_sample: 5000 + k,
            }))
            .expect("ok");
        }
        assert_eq!(m.history().count(), HISTORY_LEN);
        assert_eq!(m.history().last().map(AlertEvent::at_sample), Some(5019));
    }
}
