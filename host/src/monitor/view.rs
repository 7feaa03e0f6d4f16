//! Showing a [`Monitor`]: a compact panel redrawn in place on a terminal (crossterm), with
//! alert events scrolling above it in colour; or, when the output is not a terminal,
//! plain lines (a status line per second and each event as it happens), no escape codes.
//!
//! The panel's content is a pure function ([`panel_lines`]), tested without a terminal;
//! the views only decide when to draw and how to colour.

use supine_core::joint_exposure::packed_order;
use supine_core::model::{JOINT_OUTPUT_COUNT, JointOutput};
use supine_core::protocol::Telemetry;

use crate::exposure::joints::display_unit;
use std::io::{self, Write};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use crossterm::style::{Attribute, Color, Print, ResetColor, SetAttribute, SetForegroundColor};
use crossterm::terminal::{Clear, ClearType};
use crossterm::{cursor, queue};

use super::state::{Monitor, Notice, Severity, describe_event, params_source_text, patient_text};
use crate::device::device_params::identity_hex;

/// Redraw period of the live panel (10 Hz, whatever the telemetry rate).
pub const REDRAW_INTERVAL: Duration = Duration::from_millis(100);
/// Period of the plain status line.
pub const PLAIN_INTERVAL: Duration = Duration::from_secs(1);
/// Alert events listed in the panel.
const PANEL_EVENTS: usize = 4;

/// A piece of a panel line, highlighted by `severity` (`None`: plain text).
#[derive(Clone, Debug, PartialEq)]
pub struct Span {
    /// Highlight, if any.
    pub severity: Option<Severity>,
    /// The text.
    pub text: String,
}

fn plain(text: impl Into<String>) -> Span {
    Span {
        severity: None,
        text: text.into(),
    }
}

fn marked(severity: Severity, text: impl Into<String>) -> Span {
    Span {
        severity: Some(severity),
        text: text.into(),
    }
}

/// The thresholds of advisory, warning and alarm as the panel shows them beside a value.
fn thresholds_text(thresholds: [f32; 3]) -> String {
    let [a, w, x] = thresholds;
    format!("  (advisory {a} / warning {w} / alarm {x})")
}

/// The panel. The most important first, each line starting with what matters most, so
/// that a short or narrow terminal (lines are cut, never wrapped) keeps the level and the
/// vector running rms: level and vector rms with its thresholds; VDV with its thresholds;
/// time (of the ride's length when known), highest level and faults; the joint alerts
/// raised, if any; head acceleration, per-axis running rms and the joint outputs; the
/// device; link counters; the latest alert events.
pub fn panel_lines(m: &Monitor) -> Vec<Vec<Span>> {
    let g = m.greeting();
    let level = m.level();
    let thresholds = m.thresholds();
    let mut lines = Vec::new();
    let level_span = marked(
        Severity::of_level(level),
        format!("{:<8}", level.name().to_ascii_uppercase()),
    );
    match m.latest() {
        None => lines.push(vec![level_span, plain(" waiting for telemetry")]),
        Some(t) => {
            let mut first = vec![
                level_span,
                plain(format!(
                    " vector rms {:.3} m/s^2",
                    t.vector_running_rms_m_s2
                )),
            ];
            if !t.valid {
                first.push(plain(" (settling)"));
            }
            if let Some(c) = thresholds {
                first.push(plain(thresholds_text(c.running_rms_m_s2)));
            }
            lines.push(first);
            let mut vdv = vec![plain(format!(
                "         VDV        {:.3} m/s^1.75",
                t.vdv_m_s175
            ))];
            if let Some(c) = thresholds {
                vdv.push(plain(thresholds_text(c.vdv_m_s175)));
            }
            lines.push(vdv);
        }
    }
    let faults = m.fault_names();
    let time = match m.ride_length_s() {
        Some(total_s) => format!("t {:.2} of {total_s:.2} s", m.time_s()),
        None => format!("t {:.2} s", m.time_s()),
    };
    lines.push(vec![
        plain(format!("{time}   highest {}   faults ", m.highest_level())),
        if faults.is_empty() {
            plain("none")
        } else {
            marked(Severity::Fault, faults.join(" + "))
        },
    ]);
    // Shown only while one is raised: the device's thresholds are set per mission, and
    // most missions set none (docs/exposure.md).
    let joint_alerts = m.joint_alerts_raised();
    if !joint_alerts.is_empty() {
        let names: Vec<String> = joint_alerts
            .iter()
            .map(|(output, criterion)| format!("{output} {criterion}"))
            .collect();
        lines.push(vec![
            plain("joint alerts  "),
            marked(Severity::Warning, names.join(" + ")),
        ]);
    }
    if let Some(t) = m.latest() {
        let [hx, hy, hz] = t.head_acc_m_s2;
        let [rx, ry, rz] = t.running_rms_m_s2;
        lines.push(vec![plain(format!(
            "head          x {hx:+8.3}  y {hy:+8.3}  z {hz:+8.3} m/s^2  peak {:.2}",
            m.peak_head_m_s2()
        ))]);
        lines.push(vec![plain(format!(
            "weighted rms  x {rx:8.3}  y {ry:8.3}  z {rz:8.3} m/s^2"
        ))]);
        lines.extend(joint_lines(m, t).into_iter().map(|l| vec![plain(l)]));
    }
    lines.push(vec![plain(format!(
        "device        fw {}  params {} ({})  {} Hz  {}",
        g.firmware_version.as_str(),
        // The first 8 hex digits name a parameter set well enough on screen.
        &identity_hex(&g.params_identity)[..8],
        params_source_text(g.params_source),
        g.sample_rate_hz,
        patient_text(g.height_m, g.mass_kg)
    ))]);
    let c = m.counters();
    let link = &c.link;
    let losses = link.lost_frames + link.bad_frames;
    let counters = format!(
        "frames {} lost {} bad {} reordered {}",
        link.frames, link.lost_frames, link.bad_frames, link.reordered_frames
    );
    lines.push(vec![
        plain("link          "),
        if losses > 0 {
            marked(Severity::Warning, counters)
        } else {
            plain(counters)
        },
        plain(format!("  events {} ({} raised)", c.events, c.raised)),
    ]);
    let recent: Vec<_> = m.history().collect();
    let skip = recent.len().saturating_sub(PANEL_EVENTS);
    for e in &recent[skip..] {
        lines.push(vec![
            plain("event         "),
            marked(Severity::of_event(e), describe_event(e, m.sample_rate_hz())),
        ]);
    }
    lines
}

/// The joint outputs the device reports, per joint (neck, lower back): the latest
/// values, and from the latest status their running rms and largest excursion, in mm
/// and degrees; an output not reported is `-`.
fn joint_lines(m: &Monitor, t: &Telemetry) -> Vec<String> {
    let mask = m.greeting().joint_outputs;
    if mask == 0 {
        return Vec::new();
    }
    // Each output's place in the device's lists.
    let mut place = [None; JOINT_OUTPUT_COUNT];
    for (k, output) in packed_order(mask).enumerate() {
        place[output.index()] = Some(k);
    }
    // The live values carry their sign; running rms and largest excursion are sizes.
    let row = |label: &str, values: &[f32], signed: bool| -> Vec<String> {
        ["neck", "low back"]
            .iter()
            .enumerate()
            .map(|(j, joint)| {
                let cells: Vec<String> = JointOutput::ALL[5 * j..5 * j + 5]
                    .iter()
                    .map(|&o| {
                        let (_, scale) = display_unit(o);
                        let name = &o.name()[o.name().rfind('_').map_or(0, |i| i + 1)..];
                        match place[o.index()].and_then(|k| values.get(k)) {
                            Some(&v) if signed => {
                                format!("{name} {:+7.2}", f64::from(v) * scale)
                            }
                            Some(&v) => format!("{name} {:7.2}", f64::from(v) * scale),
                            None => format!("{name} {:>7}", "-"),
                        }
                    })
                    .collect();
                format!(
                    "{:<14}{}  mm, {}  deg",
                    format!("{joint} {label}"),
                    cells[..3].join("  "),
                    cells[3..].join("  ")
                )
            })
            .collect()
    };
    let mut lines = row("", t.joints.as_slice(), true);
    if let Some(s) = m.status() {
        lines.extend(row("rms", s.joint_running_rms.as_slice(), false));
        lines.extend(row("max", s.joint_largest_excursion.as_slice(), false));
    }
    lines
}

/// Where the monitor shows itself.
pub trait View {
    /// Shows something at once (an alert event, a greeting).
    fn notice(&mut self, m: &Monitor, notice: &Notice) -> Result<()>;
    /// Called often; redraws when its own interval has passed.
    fn refresh(&mut self, m: &Monitor) -> Result<()>;
    /// Draws the final state and gives the terminal back.
    fn close(&mut self, m: &Monitor) -> Result<()>;
}

/// The colour of a severity on a terminal (256-colour palette): advisory yellow, warning
/// orange, alarm red, distinct at a glance and in the order of a traffic light; faults
/// magenta, which no level uses.
pub fn colour(severity: Severity) -> Color {
    match severity {
        Severity::Info => Color::AnsiValue(34),
        Severity::Advisory => Color::AnsiValue(226),
        Severity::Warning => Color::AnsiValue(208),
        Severity::Alarm => Color::AnsiValue(196),
        Severity::Fault => Color::AnsiValue(201),
    }
}

/// The redrawn panel on a terminal. Dropping it restores the cursor and colours (also
/// on an error or a panic unwinding through the caller).
pub struct LiveView<W: Write> {
    out: W,
    colour: bool,
    drawn_lines: u16,
    drawn_width: Option<usize>,
    last_draw: Option<Instant>,
}

impl<W: Write> LiveView<W> {
    /// Takes over `out` (a terminal): hides the cursor. Without `colour` (NO_COLOR,
    /// `--color never`) highlights are bold only.
    pub fn new(mut out: W, colour: bool) -> Result<Self> {
        queue!(out, cursor::Hide).map_err(term_error)?;
        out.flush().map_err(term_error)?;
        Ok(Self {
            out,
            colour,
            drawn_lines: 0,
            drawn_width: None,
            last_draw: None,
        })
    }

    /// Erases the panel drawn last (the cursor goes back to its first line).
    fn erase(&mut self) -> io::Result<()> {
        if self.drawn_lines > 0 {
            queue!(self.out, cursor::MoveUp(self.drawn_lines))?;
        }
        queue!(
            self.out,
            cursor::MoveToColumn(0),
            Clear(ClearType::FromCursorDown)
        )?;
        self.drawn_lines = 0;
        Ok(())
    }

    /// Prints one line, cut to `width` characters so that it never wraps (a wrapped line
    /// would throw off the count of lines to erase at the next redraw).
    fn print_spans(&mut self, spans: &[Span], width: usize) -> io::Result<()> {
        let mut room = width;
        for span in spans {
            let text: String = span.text.chars().take(room).collect();
            room -= text.chars().count();
            match span.severity {
                Some(s) if self.colour => queue!(
                    self.out,
                    SetForegroundColor(colour(s)),
                    SetAttribute(Attribute::Bold),
                    Print(text),
                    SetAttribute(Attribute::Reset),
                    ResetColor
                )?,
                Some(_) => queue!(
                    self.out,
                    SetAttribute(Attribute::Bold),
                    Print(text),
                    SetAttribute(Attribute::Reset),
                    ResetColor
                )?,
                None => queue!(self.out, Print(text))?,
            }
        }
        queue!(self.out, Print("\r\n"))
    }

    fn draw(&mut self, m: &Monitor) -> io::Result<()> {
        let width = terminal_width();
        if self.drawn_width.is_some_and(|w| w != width) {
            // A resized terminal rewraps the old panel: counting its lines back up no
            // longer finds its top, so the screen is cleared and the panel starts afresh.
            queue!(self.out, Clear(ClearType::All), cursor::MoveTo(0, 0))?;
            self.drawn_lines = 0;
        }
        self.drawn_width = Some(width);
        self.erase()?;
        let lines = panel_lines(m);
        for line in &lines {
            self.print_spans(line, width)?;
        }
        self.drawn_lines = u16::try_from(lines.len()).unwrap_or(u16::MAX);
        self.out.flush()?;
        self.last_draw = Some(Instant::now());
        Ok(())
    }
}

impl<W: Write> View for LiveView<W> {
    fn notice(&mut self, m: &Monitor, notice: &Notice) -> Result<()> {
        // The event goes above the panel, where it stays as the panel is redrawn.
        self.erase().map_err(term_error)?;
        let line = [marked(
            notice.severity,
            format!("[{}] {}", notice.severity.tag(), notice.text),
        )];
        self.print_spans(&line, usize::MAX).map_err(term_error)?;
        self.draw(m).map_err(term_error)
    }

    fn refresh(&mut self, m: &Monitor) -> Result<()> {
        if self
            .last_draw
            .is_none_or(|t| t.elapsed() >= REDRAW_INTERVAL)
        {
            self.draw(m).map_err(term_error)?;
        }
        Ok(())
    }

    fn close(&mut self, m: &Monitor) -> Result<()> {
        self.draw(m).map_err(term_error)?;
        restore(&mut self.out).map_err(term_error)
    }
}

impl<W: Write> Drop for LiveView<W> {
    fn drop(&mut self) {
        let _ = restore(&mut self.out);
    }
}

/// Columns of the terminal less one (the last column would wrap on some terminals); 200
/// when it cannot be asked (not a terminal: the tests).
fn terminal_width() -> usize {
    crossterm::terminal::size().map_or(200, |(columns, _)| usize::from(columns.max(2)) - 1)
}

fn restore(out: &mut impl Write) -> io::Result<()> {
    queue!(
        out,
        SetAttribute(Attribute::Reset),
        ResetColor,
        cursor::Show
    )?;
    out.flush()
}

fn term_error(e: io::Error) -> anyhow::Error {
    anyhow!("writing to the terminal: {e}")
}

/// Plain lines for pipes and logs: `[SEVERITY] text` for each event as it happens, and
/// the status line ([`Monitor::render_line`]) once per [`PLAIN_INTERVAL`].
pub struct PlainView<W: Write> {
    out: W,
    last_line: Instant,
}

/// An error writing the monitor's lines: a closed pipe (`supine monitor ... | head`) ends
/// the session quietly ([`crate::io::stdout::ReaderGone`]); anything else is reported.
pub fn output_error(error: io::Error) -> anyhow::Error {
    if error.kind() == io::ErrorKind::BrokenPipe {
        crate::io::stdout::ReaderGone.into()
    } else {
        anyhow!("writing the monitor's output: {error}")
    }
}

impl<W: Write> PlainView<W> {
    /// Writes to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            last_line: Instant::now(),
        }
    }

    /// Gives the writer back (tests read what was written).
    pub fn into_inner(self) -> W {
        self.out
    }

    fn line(&mut self, text: &str) -> Result<()> {
        writeln!(self.out, "{text}")
            .and_then(|()| self.out.flush())
            .map_err(output_error)
    }
}

impl<W: Write> View for PlainView<W> {
    fn notice(&mut self, _m: &Monitor, notice: &Notice) -> Result<()> {
        self.line(&format!("[{}] {}", notice.severity.tag(), notice.text))
    }

    fn refresh(&mut self, m: &Monitor) -> Result<()> {
        if self.last_line.elapsed() >= PLAIN_INTERVAL {
            self.last_line = Instant::now();
            self.line(&m.render_line())?;
        }
        Ok(())
    }

    fn close(&mut self, m: &Monitor) -> Result<()> {
        self.line(&m.render_line())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::{AlertEvent, Level, SensorFault};
    use supine_core::protocol::{
        DeviceToHost, Greeting, PROTOCOL_VERSION, ParamsSource, ResetCause, Telemetry,
    };

    use crate::device::link::LinkStats;

    fn monitor() -> Monitor {
        let g = Greeting {
            protocol_version: PROTOCOL_VERSION,
            firmware_version: heapless::String::try_from("0.1.0+test").expect("fits"),
            params_identity: [0xab; 16],
            params_source: ParamsSource::Flash { slot: 0 },
            sample_rate_hz: 500.0,
            height_m: 1.82,
            mass_kg: 81.0,
            reset_cause: ResetCause::PowerOn,
            last_panic: heapless::String::new(),
            joint_outputs: 0,
            calibration: supine_core::calibration::SensorCalibration::DATASHEET,
        };
        let mut m = Monitor::new(&g).expect("monitor");
        m.on_message(&DeviceToHost::Telemetry(Telemetry {
            sample_index: 2500,
            head_acc_m_s2: [0.5, -0.25, 2.0],
            running_rms_m_s2: [0.3, 0.4, 1.2],
            vector_running_rms_m_s2: 1.3,
            vdv_m_s175: 3.25,
            alert_level: Level::Alarm,
            fault_flags: SensorFault::Stuck.into(),
            valid: true,
            joints: supine_core::joint_exposure::JointValues::EMPTY,
        }))
        .expect("telemetry");
        m.on_message(&DeviceToHost::Alert(AlertEvent::Fault {
            fault: SensorFault::Stuck,
            active: true,
            at_sample: 2400,
        }))
        .expect("event");
        m.on_link(LinkStats {
            frames: 100,
            bad_frames: 1,
            lost_frames: 2,
            reordered_frames: 0,
        });
        m
    }

    #[test]
    fn the_panel_shows_the_reported_joint_outputs_in_mm_and_degrees() {
        let mut g = monitor().greeting().clone();
        // neck_x and neck_ry: x's group first, then z's.
        g.joint_outputs = (1 << 0) | (1 << 3);
        let mut m = Monitor::new(&g).expect("monitor");
        let t = Telemetry {
            joints: supine_core::joint_exposure::JointValues::from_slice(&[0.0015, -0.01])
                .expect("two"),
            ..*monitor().latest().expect("telemetry")
        };
        m.on_message(&DeviceToHost::Telemetry(t))
            .expect("telemetry");
        let text: Vec<String> = panel_lines(&m)
            .iter()
            .map(|l| l.iter().map(|s| s.text.as_str()).collect())
            .collect();
        let neck = text
            .iter()
            .find(|l| l.starts_with("neck "))
            .expect("a neck line");
        assert!(neck.contains("x   +1.50"), "{neck}");
        assert!(neck.contains("y       -"), "{neck}");
        assert!(neck.contains("ry   -0.57"), "{neck}");
        assert!(text.iter().any(|l| l.starts_with("low back ")), "{text:?}");
        // Without a status yet, no running rms or largest excursion lines.
        assert!(!text.iter().any(|l| l.starts_with("neck rms")), "{text:?}");
        // With one, they are sizes: no sign.
        let values = |v: &[f32]| supine_core::joint_exposure::JointValues::from_slice(v);
        m.on_message(&DeviceToHost::Status(supine_core::protocol::Status {
            joint_running_rms: values(&[0.0012, 0.004]).expect("two"),
            joint_largest_excursion: values(&[0.003, 0.02]).expect("two"),
            ..Default::default()
        }))
        .expect("status");
        let text: Vec<String> = panel_lines(&m)
            .iter()
            .map(|l| l.iter().map(|s| s.text.as_str()).collect())
            .collect();
        let line = |start: &str| {
            text.iter()
                .find(|l| l.starts_with(start))
                .unwrap_or_else(|| panic!("no {start} line in {text:?}"))
                .clone()
        };
        let (rms, max) = (line("neck rms"), line("neck max"));
        assert!(
            rms.contains("x    1.20") && rms.contains("ry    0.23"),
            "{rms}"
        );
        assert!(max.contains("x    3.00") && !max.contains('+'), "{max}");
    }

    fn find(lines: &[Vec<Span>], text: &str) -> Span {
        lines
            .iter()
            .flatten()
            .find(|s| s.text.contains(text))
            .cloned()
            .unwrap_or_else(|| panic!("no span with {text:?} in {lines:?}"))
    }

    #[test]
    fn the_panel_shows_values_and_highlights_level_faults_losses_and_events() {
        let lines = panel_lines(&monitor());
        assert!(
            find(&lines, "params abababab (flash slot A)")
                .severity
                .is_none()
        );
        // The patient the device's parameters were scaled to, from its greeting.
        assert!(
            find(&lines, "500 Hz  patient 1.82 m, 81 kg")
                .severity
                .is_none()
        );
        assert_eq!(find(&lines, "ALARM").severity, Some(Severity::Alarm));
        assert_eq!(find(&lines, "stuck").severity, Some(Severity::Fault));
        assert!(find(&lines, "z   +2.000 m/s^2").severity.is_none());
        assert!(find(&lines, "vector rms 1.300 m/s^2").severity.is_none());
        assert!(find(&lines, "3.250 m/s^1.75").severity.is_none());
        // The level and the vector rms open the panel: a narrow terminal keeps them.
        let first: String = lines[0].iter().map(|s| s.text.as_str()).collect();
        assert!(
            first.starts_with("ALARM    vector rms 1.300 m/s^2"),
            "{first}"
        );
        // Unknown thresholds and ride length (a device in service): none shown.
        assert!(!first.contains("advisory"), "{first}");
        assert!(find(&lines, "t 5.00 s").severity.is_none());
        assert_eq!(
            find(&lines, "frames 100 lost 2 bad 1").severity,
            Some(Severity::Warning)
        );
        assert_eq!(
            find(&lines, "sensor fault stuck raised").severity,
            Some(Severity::Fault)
        );
    }

    #[test]
    fn raised_joint_alerts_stay_on_the_panel_until_cleared() {
        use supine_core::alerts::JointCriterion;
        let joint = |output: u8, criterion: JointCriterion, raised: bool| {
            DeviceToHost::Alert(AlertEvent::Joint {
                output,
                criterion,
                raised,
                at_sample: 2600,
            })
        };
        let rms = JointCriterion::RunningRms {
            value_m_or_rad: 0.002,
        };
        let excursion = JointCriterion::Excursion {
            value_m_or_rad: 0.05,
        };
        let mut m = monitor();
        let line = |m: &Monitor| {
            panel_lines(m)
                .iter()
                .find(|l| l.first().is_some_and(|s| s.text == "joint alerts  "))
                .map(|l| (l[1].text.clone(), l[1].severity))
        };
        assert_eq!(line(&m), None, "no line while none is raised");
        m.on_message(&joint(2, rms, true)).expect("event");
        m.on_message(&joint(3, excursion, true)).expect("event");
        assert_eq!(
            line(&m),
            Some((
                "neck_z running-rms + neck_ry excursion".to_owned(),
                Some(Severity::Warning)
            ))
        );
        m.on_message(&joint(2, rms, false)).expect("event");
        assert_eq!(
            line(&m),
            Some(("neck_ry excursion".to_owned(), Some(Severity::Warning)))
        );
    }

    #[test]
    fn known_thresholds_and_ride_length_are_shown_beside_the_values() {
        let mut m = monitor();
        m.set_thresholds(Some(supine_core::alerts::AlertConfig::DEFAULT));
        m.set_ride_length_s(Some(60.0));
        let lines = panel_lines(&m);
        let text: Vec<String> = lines
            .iter()
            .map(|l| l.iter().map(|s| s.text.as_str()).collect())
            .collect();
        assert_eq!(
            text[0],
            "ALARM    vector rms 1.300 m/s^2  (advisory 0.5 / warning 0.8 / alarm 1.25)"
        );
        assert_eq!(
            text[1],
            "         VDV        3.250 m/s^1.75  (advisory 8.5 / warning 17 / alarm 21)"
        );
        assert!(text[2].starts_with("t 5.00 of 60.00 s"), "{}", text[2]);
    }

    #[test]
    fn the_live_view_colours_and_restores_the_terminal() {
        let m = monitor();
        let mut out = Vec::new();
        {
            let mut view = LiveView::new(&mut out, true).expect("view");
            view.refresh(&m).expect("draw");
            view.notice(
                &m,
                &Notice {
                    severity: Severity::Alarm,
                    text: "alarm!".into(),
                },
            )
            .expect("notice");
            view.close(&m).expect("close");
        }
        let text = String::from_utf8_lossy(&out);
        assert!(text.starts_with("\x1b[?25l"), "cursor hidden first");
        assert!(text.contains("[ALARM] alarm!"), "{text}");
        // Red (196) for the alarm, and the cursor shown again at the end.
        assert!(text.contains("\x1b[38;5;196m"), "{text:?}");
        assert!(text.ends_with("\x1b[?25h"), "{text:?}");
        // Without colour (NO_COLOR, --color never): bold only, no colour at all.
        let mut out = Vec::new();
        {
            let mut view = LiveView::new(&mut out, false).expect("view");
            view.close(&m).expect("close");
        }
        let text = String::from_utf8_lossy(&out);
        assert!(text.contains("\x1b[1mALARM"), "{text:?}");
        assert!(!text.contains("\x1b[38;"), "{text:?}");
    }

    #[test]
    fn every_severity_has_its_own_colour_and_warning_is_orange() {
        let all = [
            Severity::Info,
            Severity::Advisory,
            Severity::Warning,
            Severity::Alarm,
            Severity::Fault,
        ];
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert_ne!(colour(*a), colour(*b), "{a:?} and {b:?}");
            }
        }
        // xterm-256 colour 208 is orange (#ff8700).
        assert_eq!(colour(Severity::Warning), Color::AnsiValue(208));
    }

    #[test]
    fn the_plain_view_writes_lines_without_escape_codes() {
        let m = monitor();
        let mut view = PlainView::new(Vec::new());
        view.refresh(&m).expect("too early: nothing");
        view.notice(
            &m,
            &Notice {
                severity: Severity::Warning,
                text: "w".into(),
            },
        )
        .expect("notice");
        view.close(&m).expect("close");
        let text = String::from_utf8(view.into_inner()).expect("utf-8");
        assert_eq!(text.lines().count(), 2, "{text}");
        assert_eq!(text.lines().next(), Some("[WARNING] w"));
        assert!(text.contains("level alarm  faults stuck"), "{text}");
        assert!(!text.contains('\x1b'));
    }
}
