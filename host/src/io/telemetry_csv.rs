//! The telemetry CSV and its alert events CSV: what `supine replay`, `supine monitor --log`
//! and `supine demo` write of a device's telemetry, and what the demo reads back.
//!
//! Two files: `NAME.csv` ([`TELEMETRY_HEADER`], one row per telemetry record) and
//! `<stem>.events.csv` beside it ([`EVENTS_HEADER`], one row per alert event). Values are
//! written in f32's shortest round-trip form, so they read back exactly.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use supine_core::alerts::{AlertEvent, Criterion, FaultFlags, JointCriterion, Level};
use supine_core::joint_exposure::{JointValues, packed_order};
use supine_core::model::{JOINT_OUTPUT_COUNT, JointOutput};
use supine_core::protocol::Telemetry;

use super::csv_lines::CsvLines;
use super::excerpt::excerpt;
use super::output::write_atomically;
use super::wording::joint_alert_text;

/// Header of the telemetry CSV: the telemetry record's fields (the wire's names,
/// `docs/protocol.md`) with their units, `head_x_m_s2`: predicted head acceleration, litter
/// axes.
pub const TELEMETRY_HEADER: &str = "sample,time_s,head_x_m_s2,head_y_m_s2,head_z_m_s2,running_rms_x_m_s2,running_rms_y_m_s2,running_rms_z_m_s2,vector_running_rms_m_s2,vdv_m_s175,alert_level,fault_flags,valid";
/// The header logs had before the head's columns carried their unit and the vector running
/// rms its wire name: the same columns in the same order, still read.
pub const OLD_TELEMETRY_HEADER: &str = "sample,time_s,head_x,head_y,head_z,running_rms_x_m_s2,running_rms_y_m_s2,running_rms_z_m_s2,running_rms_vector_m_s2,vdv_m_s175,alert_level,fault_flags,valid";
/// The joint output columns' names for the outputs in `joint_mask` (bit `i` for
/// [`JointOutput::ALL`]`[i]`), in the order the device reports them
/// ([`packed_order`]), units in the names: `neck_x_m`, ..., `neck_ry_rad`.
pub fn joint_columns(joint_mask: u16) -> Vec<String> {
    packed_order(joint_mask).map(joint_column).collect()
}

fn joint_column(output: JointOutput) -> String {
    format!("{}_{}", output.name(), output.unit().si_suffix())
}

/// The telemetry CSV's header for a device reporting the joint outputs of `joint_mask`:
/// [`TELEMETRY_HEADER`], then one column per joint output ([`joint_columns`]).
pub fn telemetry_header(joint_mask: u16) -> String {
    let mut header = TELEMETRY_HEADER.to_string();
    for column in joint_columns(joint_mask) {
        header.push(',');
        header.push_str(&column);
    }
    header
}

/// Header of the alert events CSV. `criterion` is what changed a level (`running-rms` or
/// `vdv`, [`Criterion::name`]) with its `value` then, in `unit` (`m/s^2` or `m/s^1.75`); a
/// fault is its own cause, so those three cells are empty on a fault's row. A joint alert
/// (`kind` joint, `name` the output, e.g. `neck_x`) has `running-rms` or `excursion` with
/// the value in the output's SI unit (`m` or `rad`), as the telemetry CSV's joint columns.
pub const EVENTS_HEADER: &str = "sample,time_s,kind,name,raised,criterion,value,unit";

/// Cells of a telemetry row.
const TELEMETRY_CELLS: usize = 13;

/// `<stem>.events.csv` next to `out`.
pub fn events_path(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    out.with_file_name(format!("{stem}.events.csv"))
}

/// One line of the telemetry CSV ([`telemetry_header`]: the record's joint values last),
/// newline included; written whole by [`write_telemetry`] and row by row by `supine
/// monitor`'s live log.
pub fn telemetry_row(t: &Telemetry, sample_rate_hz: f64) -> String {
    let [hx, hy, hz] = t.head_acc_m_s2;
    let [rx, ry, rz] = t.running_rms_m_s2;
    let joints: String = t
        .joints
        .as_slice()
        .iter()
        .map(|v| format!(",{v}"))
        .collect();
    format!(
        "{},{},{hx},{hy},{hz},{rx},{ry},{rz},{},{},{},{},{}{joints}\n",
        t.sample_index,
        f64::from(t.sample_index) / sample_rate_hz,
        t.vector_running_rms_m_s2,
        t.vdv_m_s175,
        t.alert_level.name(),
        t.fault_flags.as_repr(),
        u8::from(t.valid),
    )
}

/// One line of the events CSV ([`EVENTS_HEADER`]), newline included.
pub fn event_row(e: &AlertEvent, sample_rate_hz: f64) -> String {
    EventRow::from_event(e, sample_rate_hz).to_line()
}

/// Writes the telemetry CSV ([`telemetry_header`] of `joint_mask`, the joint outputs the
/// records carry), whole or not at all.
pub fn write_telemetry(
    path: &Path,
    telemetry: &[Telemetry],
    sample_rate_hz: f64,
    joint_mask: u16,
) -> Result<()> {
    write_telemetry_streamed(path, sample_rate_hz, joint_mask, |emit| {
        telemetry.iter().try_for_each(emit)
    })
}

/// Writes the telemetry CSV ([`TELEMETRY_HEADER`]) as the records are produced, whole or
/// not at all: `produce` is given a function that writes one record, and the file
/// appears only if `produce` succeeds (a replay of any length holds no record in memory).
pub fn write_telemetry_streamed<T>(
    path: &Path,
    sample_rate_hz: f64,
    joint_mask: u16,
    produce: impl FnOnce(&mut dyn FnMut(&Telemetry) -> Result<()>) -> Result<T>,
) -> Result<T> {
    let mut produced = None;
    write_atomically(path, |w| {
        writeln!(w, "{}", telemetry_header(joint_mask))?;
        let mut emit = |t: &Telemetry| -> Result<()> {
            Ok(w.write_all(telemetry_row(t, sample_rate_hz).as_bytes())?)
        };
        produced = Some(produce(&mut emit)?);
        Ok(())
    })?;
    produced.ok_or_else(|| anyhow!("{}: nothing was written", path.display()))
}

/// Writes the alert events CSV ([`EVENTS_HEADER`]), whole or not at all.
pub fn write_events(path: &Path, events: &[AlertEvent], sample_rate_hz: f64) -> Result<()> {
    write_atomically(path, |w| {
        writeln!(w, "{EVENTS_HEADER}")?;
        for e in events {
            w.write_all(event_row(e, sample_rate_hz).as_bytes())?;
        }
        Ok(())
    })
}

/// The data rows of the CSV at `path`, whose first line must be one `accepts` takes
/// (`header` describes it in errors), each turned into a record by `parse` (given the
/// row's cells and its position, `FILE: line N`), one at a time: memory holds one line,
/// whatever the file's length ([`CsvLines`]).
pub struct CsvRecords<T> {
    path: PathBuf,
    header: String,
    lines: CsvLines<std::fs::File>,
    first: bool,
    accepts: Box<HeaderCheck>,
    parse: Box<RowParser<T>>,
}

/// Whether a header row's cells are one the file may start with.
type HeaderCheck = dyn FnMut(&[&str]) -> bool;

/// Turns a row's cells (and where it is, `FILE: line N`) into a record.
type RowParser<T> = dyn FnMut(&[&str], &str) -> Result<T>;

impl<T> CsvRecords<T> {
    fn open(
        path: &Path,
        header: String,
        accepts: impl FnMut(&[&str]) -> bool + 'static,
        parse: impl FnMut(&[&str], &str) -> Result<T> + 'static,
    ) -> Result<Self> {
        let lines =
            CsvLines::open(path).map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
        Ok(Self {
            path: path.to_path_buf(),
            header,
            lines,
            first: true,
            accepts: Box::new(accepts),
            parse: Box::new(parse),
        })
    }

    /// The next record, `None` after the last.
    pub fn next_record(&mut self) -> Result<Option<T>> {
        let path = self.path.display();
        loop {
            let row = match self.lines.next_row() {
                Ok(Some(row)) => row,
                Ok(None) if self.first => bail!(
                    "{path}: line 1: expected the header \"{}\", found an empty file",
                    self.header
                ),
                Ok(None) => return Ok(None),
                Err(e) => bail!("{path}: {e}"),
            };
            let at = format!("{path}: line {}", row.line);
            let mut cells: Vec<&str> = Vec::with_capacity(TELEMETRY_CELLS);
            for (i, cell) in row.cells().enumerate() {
                cells.push(std::str::from_utf8(cell).map_err(|_| {
                    anyhow!(
                        "{at}, cell {}: expected text, found {}",
                        i + 1,
                        excerpt(cell)
                    )
                })?);
            }
            if self.first {
                if !(self.accepts)(&cells) {
                    bail!(
                        "{at}: expected the header \"{}\", found {}",
                        self.header,
                        excerpt(cells.join(","))
                    );
                }
                self.first = false;
                continue;
            }
            return (self.parse)(&cells, &at).map(Some);
        }
    }
}

impl<T> Iterator for CsvRecords<T> {
    type Item = Result<T>;

    fn next(&mut self) -> Option<Result<T>> {
        self.next_record().transpose()
    }
}

/// The joint outputs a telemetry header names after [`TELEMETRY_HEADER`] (or
/// [`OLD_TELEMETRY_HEADER`]), as a mask, if
/// they are joint columns in the device's order ([`telemetry_header`] of that mask); `None`
/// for any other header.
pub fn joint_mask_of(header: &[&str]) -> Option<u16> {
    let base = TELEMETRY_HEADER.split(',').count();
    let named = header.get(..base)?.join(",");
    if named != TELEMETRY_HEADER && named != OLD_TELEMETRY_HEADER {
        return None;
    }
    let mut mask = 0u16;
    for name in &header[base..] {
        let output = JointOutput::ALL
            .into_iter()
            .find(|o| joint_column(*o) == *name)?;
        mask |= 1 << output.index();
    }
    (joint_columns(mask) == header[base..]).then_some(mask)
}

/// Reads a telemetry CSV ([`telemetry_header`]) back into the records it was written
/// from (the `time_s` column is derived, so it is not read).
pub fn read_telemetry(path: &Path) -> Result<Vec<Telemetry>> {
    telemetry_records(path)?.collect()
}

/// The records of a telemetry CSV ([`telemetry_header`]: joint columns as its header
/// names them), read one at a time.
pub fn telemetry_records(path: &Path) -> Result<CsvRecords<Telemetry>> {
    // Set by the header, read by every row.
    let joint_count = std::rc::Rc::new(std::cell::Cell::new(0));
    let described = format!(
        "{TELEMETRY_HEADER}[,joint columns of {}]",
        joint_columns((1 << JOINT_OUTPUT_COUNT) - 1).join(",")
    );
    let header_count = std::rc::Rc::clone(&joint_count);
    let accepts = move |h: &[&str]| match joint_mask_of(h) {
        Some(mask) => {
            header_count.set(mask.count_ones() as usize);
            true
        }
        None => false,
    };
    CsvRecords::open(path, described, accepts, move |cells, at| {
        telemetry_record(cells, at, joint_count.get())
    })
}

/// One telemetry row with `joint_count` joint columns.
fn telemetry_record(cells: &[&str], at: &str, joint_count: usize) -> Result<Telemetry> {
    let expected = TELEMETRY_CELLS + joint_count;
    if cells.len() != expected {
        bail!("{at}: expected {expected} cells, found {}", cells.len());
    }
    let num = |i: usize| -> Result<f32> {
        cells[i].parse::<f32>().map_err(|_| {
            anyhow!(
                "{at}, cell {}: expected a number, found {}",
                i + 1,
                excerpt(cells[i])
            )
        })
    };
    let sample_index: u32 = cells[0].parse().map_err(|_| {
        anyhow!(
            "{at}, column sample: expected an index, found {}",
            excerpt(cells[0])
        )
    })?;
    let alert_level = Level::from_name(cells[10]).ok_or_else(|| {
        anyhow!(
            "{at}, column alert_level: expected normal, advisory, warning or alarm, found {}",
            excerpt(cells[10])
        )
    })?;
    let fault_flags = cells[11]
        .parse()
        .ok()
        .and_then(FaultFlags::try_from_repr)
        .ok_or_else(|| {
            anyhow!(
                "{at}, column fault_flags: expected 0..={}, found {}",
                FaultFlags::all().as_repr(),
                excerpt(cells[11])
            )
        })?;
    let valid = match cells[12] {
        "0" => false,
        "1" => true,
        other => bail!(
            "{at}, column valid: expected 0 or 1, found {}",
            excerpt(other)
        ),
    };
    Ok(Telemetry {
        sample_index,
        head_acc_m_s2: [num(2)?, num(3)?, num(4)?],
        running_rms_m_s2: [num(5)?, num(6)?, num(7)?],
        vector_running_rms_m_s2: num(8)?,
        vdv_m_s175: num(9)?,
        alert_level,
        fault_flags,
        valid,
        joints: joints_of(&cells[TELEMETRY_CELLS..], at)?,
    })
}

/// The joint cells of a telemetry row, numbers each.
fn joints_of(cells: &[&str], at: &str) -> Result<JointValues> {
    let mut values = [0.0f32; JOINT_OUTPUT_COUNT];
    for (k, (v, cell)) in values.iter_mut().zip(cells).enumerate() {
        *v = cell.parse().map_err(|_| {
            anyhow!(
                "{at}, cell {}: expected a joint output's value, found {}",
                TELEMETRY_CELLS + k + 1,
                excerpt(cell)
            )
        })?;
    }
    Ok(JointValues::packed(cells.len(), values))
}

/// One row of an events CSV ([`EVENTS_HEADER`]).
#[derive(Clone, Debug, PartialEq)]
pub struct EventRow {
    /// Sample index the event is stamped with.
    pub sample: u32,
    /// Its time from sample 0, s.
    pub time_s: f64,
    /// `level`, `fault` or `joint`.
    pub kind: String,
    /// The level reached (`kind` level), the fault's name, or the joint output's.
    pub name: String,
    /// Raised (rather than cleared).
    pub raised: bool,
    /// What changed the level and its value then (`None` for a fault or a joint alert).
    pub criterion: Option<Criterion>,
    /// A joint alert's criterion and value (`None` for the other kinds).
    pub joint: Option<JointCriterion>,
}

impl EventRow {
    /// The row of `e`, at `sample_rate_hz`.
    pub fn from_event(e: &AlertEvent, sample_rate_hz: f64) -> Self {
        let (kind, name) = match *e {
            AlertEvent::Level { to, .. } => ("level", to.name()),
            AlertEvent::Fault { fault, .. } => ("fault", fault.name()),
            AlertEvent::Joint { .. } => (
                "joint",
                e.joint_criterion().map_or("unknown", |(o, _)| o.name()),
            ),
        };
        Self {
            sample: e.at_sample(),
            time_s: f64::from(e.at_sample()) / sample_rate_hz,
            kind: kind.to_string(),
            name: name.to_string(),
            raised: e.is_raise(),
            criterion: e.criterion(),
            joint: e.joint_criterion().map(|(_, c)| c),
        }
    }

    /// The joint output of a joint alert's row.
    pub fn joint_output(&self) -> Option<JointOutput> {
        self.joint.and(JointOutput::from_name(&self.name))
    }

    /// The row as a line of the file, newline included.
    pub fn to_line(&self) -> String {
        let (criterion, value, unit) = match (&self.criterion, &self.joint, self.joint_output()) {
            (Some(c), ..) => (c.name(), c.value().to_string(), c.unit()),
            (_, Some(c), Some(o)) => (
                c.name(),
                c.value_m_or_rad().to_string(),
                o.unit().si_suffix(),
            ),
            _ => ("", String::new(), ""),
        };
        format!(
            "{},{},{},{},{},{criterion},{value},{unit}\n",
            self.sample,
            self.time_s,
            self.kind,
            self.name,
            u8::from(self.raised)
        )
    }

    /// What happened, in words (`level raised to warning by vdv 17.2 m/s^1.75`,
    /// `sensor fault stuck cleared`, `joint alert neck_x running-rms 3.100 mm raised`).
    pub fn text(&self) -> String {
        if let (Some(c), Some(o)) = (&self.joint, self.joint_output()) {
            return format!("joint alert {}", joint_alert_text(o, c, self.raised));
        }
        let by = self
            .criterion
            .map(|c| format!(" by {c}"))
            .unwrap_or_default();
        match (self.kind.as_str(), self.raised) {
            ("level", true) => format!("level raised to {}{by}", self.name),
            ("level", false) => format!("level lowered to {}{by}", self.name),
            (_, true) => format!("sensor fault {} raised", self.name),
            (_, false) => format!("sensor fault {} cleared", self.name),
        }
    }
}

/// Reads an events CSV ([`EVENTS_HEADER`]) written at `sample_rate_hz`.
pub fn read_events(path: &Path, sample_rate_hz: f64) -> Result<Vec<EventRow>> {
    event_records(path, sample_rate_hz)?.collect()
}

/// The rows of an events CSV ([`EVENTS_HEADER`]) written at `sample_rate_hz`, read one at
/// a time.
pub fn event_records(path: &Path, sample_rate_hz: f64) -> Result<CsvRecords<EventRow>> {
    CsvRecords::open(
        path,
        EVENTS_HEADER.to_string(),
        |h: &[&str]| h.join(",") == EVENTS_HEADER,
        move |cells, at| {
            let [sample, _time, kind, name, raised, criterion, value, unit] = cells[..] else {
                bail!("{at}: expected 8 cells, found {}", cells.len());
            };
            let sample: u32 = sample.parse().map_err(|_| {
                anyhow!(
                    "{at}, column sample: expected an index, found {}",
                    excerpt(sample)
                )
            })?;
            if !["level", "fault", "joint"].contains(&kind) {
                bail!(
                    "{at}, column kind: expected level, fault or joint, found {}",
                    excerpt(kind)
                );
            }
            let raised = match raised {
                "0" => false,
                "1" => true,
                other => bail!(
                    "{at}, column raised: expected 0 or 1, found {}",
                    excerpt(other)
                ),
            };
            Ok(EventRow {
                sample,
                time_s: f64::from(sample) / sample_rate_hz,
                kind: kind.to_string(),
                name: name.to_string(),
                raised,
                criterion: match kind {
                    "joint" => None,
                    _ => criterion_from_cells(kind, criterion, value, unit, at)?,
                },
                joint: match kind {
                    "joint" => Some(joint_from_cells(name, criterion, value, unit, at)?),
                    _ => None,
                },
            })
        },
    )
}

/// The criterion of an events row: for a level change `running-rms` with a value in `m/s^2`
/// or `vdv` in `m/s^1.75`; for a fault, three empty cells.
fn criterion_from_cells(
    kind: &str,
    criterion: &str,
    value: &str,
    unit: &str,
    at: &str,
) -> Result<Option<Criterion>> {
    if kind == "fault" {
        if [criterion, value, unit].iter().any(|c| !c.is_empty()) {
            bail!("{at}, column criterion: expected empty criterion, value and unit for a fault");
        }
        return Ok(None);
    }
    let number = value.parse::<f32>().map_err(|_| {
        anyhow!(
            "{at}, column value: expected a number, found {}",
            excerpt(value)
        )
    })?;
    let criterion = match criterion {
        "running-rms" => Criterion::RunningRms { value_m_s2: number },
        "vdv" => Criterion::Vdv {
            value_m_s175: number,
        },
        other => bail!(
            "{at}, column criterion: expected running-rms or vdv, found {}",
            excerpt(other)
        ),
    };
    if unit != criterion.unit() {
        bail!(
            "{at}, column unit: expected {} for {}, found {}",
            criterion.unit(),
            criterion.name(),
            excerpt(unit)
        );
    }
    Ok(Some(criterion))
}

/// The criterion of a joint alert's row: its output's name, `running-rms` or `excursion`,
/// a number, and the output's SI unit.
fn joint_from_cells(
    name: &str,
    criterion: &str,
    value: &str,
    unit: &str,
    at: &str,
) -> Result<JointCriterion> {
    let Some(output) = JointOutput::from_name(name) else {
        bail!(
            "{at}, column name: expected a joint output (neck_x ... low_back_rz), found {}",
            excerpt(name)
        );
    };
    let value_m_or_rad = value.parse::<f32>().map_err(|_| {
        anyhow!(
            "{at}, column value: expected a number, found {}",
            excerpt(value)
        )
    })?;
    let joint = match criterion {
        "running-rms" => JointCriterion::RunningRms { value_m_or_rad },
        "excursion" => JointCriterion::Excursion { value_m_or_rad },
        other => bail!(
            "{at}, column criterion: expected running-rms or excursion, found {}",
            excerpt(other)
        ),
    };
    if unit != output.unit().si_suffix() {
        bail!(
            "{at}, column unit: expected {} for {output}, found {}",
            output.unit().si_suffix(),
            excerpt(unit)
        );
    }
    Ok(joint)
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::SensorFault;

    #[test]
    fn telemetry_and_events_read_back_exactly_what_was_written() {
        let t = Telemetry {
            sample_index: 1234,
            head_acc_m_s2: [0.1, -2.5e-7, 3.3333333],
            running_rms_m_s2: [0.123_456_7, 1e-9, 7.0],
            vector_running_rms_m_s2: 7.001,
            vdv_m_s175: 2.25,
            alert_level: Level::Warning,
            fault_flags: FaultFlags::try_from_repr(0b0100).expect("a known fault bit"),
            valid: true,
            joints: supine_core::joint_exposure::JointValues::EMPTY,
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("device.csv");
        write_telemetry(&path, &[t], 500.0, 0).expect("write");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            format!(
                "{TELEMETRY_HEADER}\n1234,2.468,0.1,-0.00000025,3.3333333,0.1234567,0.000000001,7,7.001,2.25,warning,4,1\n"
            )
        );
        assert_eq!(read_telemetry(&path).expect("read"), vec![t]);

        // With joint outputs: neck_x (x), neck_ry and low_back_z (z), in the device's order.
        let mask = (1 << 0) | (1 << 3) | (1 << 7);
        let with_joints = Telemetry {
            joints: JointValues::from_slice(&[1.5e-4, -0.0125, 3e-5]).expect("three"),
            ..t
        };
        write_telemetry(&path, &[with_joints], 500.0, mask).expect("write");
        let text = std::fs::read_to_string(&path).expect("read");
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some(format!("{TELEMETRY_HEADER},neck_x_m,neck_ry_rad,low_back_z_m").as_str())
        );
        assert!(
            lines
                .next()
                .expect("a row")
                .ends_with(",warning,4,1,0.00015,-0.0125,0.00003")
        );
        assert_eq!(read_telemetry(&path).expect("read"), vec![with_joints]);
        // A log written before the head's columns carried their unit reads the same.
        let old = text.replacen(TELEMETRY_HEADER, OLD_TELEMETRY_HEADER, 1);
        assert_ne!(old, text);
        std::fs::write(&path, old).expect("write");
        assert_eq!(read_telemetry(&path).expect("read"), vec![with_joints]);
        // Joint columns out of the device's order are not a telemetry header.
        let swapped = text.replace("neck_ry_rad,low_back_z_m", "low_back_z_m,neck_ry_rad");
        std::fs::write(&path, swapped).expect("write");
        let err = read_telemetry(&path).unwrap_err().to_string();
        assert!(err.contains("line 1: expected the header"), "{err}");

        let e = AlertEvent::Fault {
            fault: SensorFault::Stuck,
            active: false,
            at_sample: 900,
        };
        let path = events_path(&path);
        assert_eq!(path, dir.path().join("device.events.csv"));
        write_events(&path, &[e], 500.0).expect("write");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            format!("{EVENTS_HEADER}\n900,1.8,fault,stuck,0,,,\n")
        );
        let events = read_events(&path, 500.0).expect("read");
        assert_eq!(events.len(), 1);
        assert_eq!(events[0].sample, 900);
        assert!((events[0].time_s - 1.8).abs() < 1e-12);
        assert_eq!(events[0].text(), "sensor fault stuck cleared");
        assert_eq!(events[0], EventRow::from_event(&e, 500.0));

        // A level change carries its criterion and value, and reads back exactly.
        let raised = AlertEvent::Level {
            from: Level::Advisory,
            to: Level::Warning,
            criterion: Criterion::Vdv {
                value_m_s175: 17.000_002,
            },
            at_sample: 1000,
        };
        let lowered = AlertEvent::Level {
            from: Level::Warning,
            to: Level::Normal,
            criterion: Criterion::RunningRms { value_m_s2: 0.25 },
            at_sample: 1500,
        };
        write_events(&path, &[raised, lowered], 500.0).expect("write");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            format!(
                "{EVENTS_HEADER}\n1000,2,level,warning,1,vdv,17.000002,m/s^1.75\n1500,3,level,normal,0,running-rms,0.25,m/s^2\n"
            )
        );
        let events = read_events(&path, 500.0).expect("read");
        assert_eq!(events[0], EventRow::from_event(&raised, 500.0));
        assert_eq!(events[1], EventRow::from_event(&lowered, 500.0));
        assert_eq!(
            events[0].text(),
            "level raised to warning by vdv 17.000002 m/s^1.75"
        );
        // A unit that does not go with its criterion is refused, naming the column.
        std::fs::write(
            &path,
            format!("{EVENTS_HEADER}\n1000,2,level,warning,1,vdv,17,m/s^2\n"),
        )
        .expect("write");
        let err = read_events(&path, 500.0).expect_err("bad unit").to_string();
        assert!(
            err.ends_with("line 2, column unit: expected m/s^1.75 for vdv, found \"m/s^2\""),
            "{err}"
        );

        // A joint alert: the output's name, its value in m or rad; read back exactly.
        let joint = AlertEvent::Joint {
            output: 3,
            criterion: JointCriterion::Excursion {
                value_m_or_rad: 0.034_906_585,
            },
            raised: true,
            at_sample: 2000,
        };
        write_events(&path, &[joint], 500.0).expect("write");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            format!("{EVENTS_HEADER}\n2000,4,joint,neck_ry,1,excursion,0.034906585,rad\n")
        );
        let events = read_events(&path, 500.0).expect("read");
        assert_eq!(events, [EventRow::from_event(&joint, 500.0)]);
        assert_eq!(
            events[0].text(),
            "joint alert neck_ry excursion 2.000 deg raised"
        );
        // The unit must be the output's own.
        std::fs::write(
            &path,
            format!("{EVENTS_HEADER}\n2000,4,joint,neck_x,1,running-rms,0.003,rad\n"),
        )
        .expect("write");
        let err = read_events(&path, 500.0).expect_err("bad unit").to_string();
        assert!(
            err.ends_with("line 2, column unit: expected m for neck_x, found \"rad\""),
            "{err}"
        );
    }

    #[test]
    fn a_bad_cell_names_the_file_line_and_column() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("device.csv");
        std::fs::write(
            &path,
            format!("{TELEMETRY_HEADER}\n1,0.002,0,0,0,0,0,0,0,0,loud,0,1\n"),
        )
        .expect("write");
        let err = read_telemetry(&path).expect_err("bad level").to_string();
        assert!(err.contains("line 2, column alert_level"), "{err}");
        std::fs::write(&path, "sample,time_s\n").expect("write");
        let err = read_telemetry(&path).expect_err("bad header").to_string();
        assert!(err.contains("line 1: expected the header"), "{err}");
    }
}
