//! The device check in one pass: the input read sample by sample goes through the host's
//! f32 pipeline (the device's code) and the f64 model, block by block as the device runs
//! it; each host record is set against the device's record in the same position (read
//! row by row from its telemetry CSV), each host event against the device's (read row by
//! row from its events CSV). Memory holds a block, the figures, the first events and the
//! charts' bounded series, whatever the session's length.
//!
//! A device record's f64 difference is taken at its own sample when that sample is in
//! the block the host is at; a record out of step with the host's (the records are then
//! incomplete anyway) counts as an infinite difference.

use anyhow::Result;
use supine_core::alerts::Level;
use supine_core::blob::DeviceParams;
use supine_core::model::ModelParams;
use supine_core::pipeline::{BLOCK_LEN, PipelineOutput, PipelineState};
use supine_core::protocol::Telemetry;

use crate::exposure::reference::HeadF64;
use crate::io::telemetry_csv::EventRow;
use crate::plot::downsample::MinMax;
use crate::plot::time_chart::{Band, Moment, PLOT_COLUMNS};
use crate::report::device_check::{
    CheckBuilder, DeviceLog, DeviceRun, MAX_LISTED_EVENTS, PassResult,
};
use crate::report::device_series::{DeviceSeries, LevelMark, TraceSeriesBuilder};

impl PassResult {
    /// The report's account of the run: `run`, marked with `bands` and `moments`.
    pub fn into_log(
        self,
        run: DeviceRun,
        session: &Session<'_>,
        bands: Vec<Band>,
        moments: Vec<Moment>,
    ) -> DeviceLog {
        DeviceLog {
            run,
            sample_rate_hz: session.sample_rate_hz,
            samples: session.samples,
            bands,
            moments,
            pass: self,
        }
    }
}

/// The session's shape, known before the pass.
#[derive(Clone, Copy, Debug)]
pub struct Session<'a> {
    /// The parameters the device ran.
    pub params: &'a DeviceParams,
    /// The model's parameters (for the f64 reference).
    pub model: &'a ModelParams,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The device's index of the first input sample.
    pub first_sample: u32,
    /// Input samples.
    pub samples: usize,
    /// Telemetry records the device's CSV holds (cuts the charts' columns).
    pub device_records: usize,
}

/// Runs the pass over `input` (litter-frame samples, in order), the device's telemetry
/// `device` and its events `device_events`.
pub fn run(
    session: &Session<'_>,
    input: impl Iterator<Item = Result<[f32; 3]>>,
    mut device: impl Iterator<Item = Result<Telemetry>>,
    mut device_events: impl Iterator<Item = Result<EventRow>>,
) -> Result<PassResult> {
    let fs = session.sample_rate_hz;
    let n = session.samples;
    let mut model = HeadF64::new(session.model, fs)?;
    let mut state = PipelineState::new();
    let mut check = CheckBuilder::default();
    let column = || MinMax::new(n, PLOT_COLUMNS);
    let mut input_series = [column(), column(), column()];
    let mut head_series = [column(), column(), column()];
    let mut device_series = TraceSeriesBuilder::new(session.device_records);
    let mut host_series = TraceSeriesBuilder::new(session.device_records);
    let mut listed: Vec<EventRow> = Vec::new();
    // Listed level events waiting for the device record at their sample.
    let mut awaiting_mark: Vec<usize> = Vec::new();
    let mut marks: Vec<LevelMark> = Vec::new();

    let mut indices: Vec<u32> = Vec::with_capacity(BLOCK_LEN);
    let mut block: Vec<[f32; 3]> = Vec::with_capacity(BLOCK_LEN);
    let mut heads: Vec<[f64; 3]> = Vec::with_capacity(BLOCK_LEN);
    let mut host_records: Vec<Telemetry> = Vec::with_capacity(BLOCK_LEN);
    let mut host_events = Vec::new();
    let mut input = input.fuse();
    let mut k = 0usize;

    let mut take_device_event = |check: &mut CheckBuilder,
                                 host: Option<&EventRow>,
                                 listed: &mut Vec<EventRow>,
                                 awaiting: &mut Vec<usize>|
     -> Result<bool> {
        let d = device_events.next().transpose()?;
        if d.is_none() && host.is_none() {
            return Ok(false);
        }
        check.events(d.as_ref(), host);
        if let Some(e) = d
            && listed.len() < MAX_LISTED_EVENTS
        {
            if e.kind == "level" {
                awaiting.push(listed.len());
            }
            listed.push(e);
        }
        Ok(true)
    };

    loop {
        indices.clear();
        block.clear();
        heads.clear();
        for x in input.by_ref().take(BLOCK_LEN) {
            let x = x?;
            let t_s = k as f64 / fs;
            let head = model.step(x);
            for a in 0..3 {
                input_series[a].push(t_s, f64::from(x[a]));
                head_series[a].push(t_s, head[a]);
            }
            indices.push(session.first_sample.wrapping_add(k as u32));
            block.push(x);
            heads.push(head);
            k += 1;
        }
        if block.is_empty() {
            break;
        }
        let block_start = k - block.len();
        host_records.clear();
        host_events.clear();
        session
            .params
            .process(&mut state, &indices, &block, |out| match out {
                PipelineOutput::Telemetry(t) => host_records.push(t),
                PipelineOutput::Alert(e) => host_events.push(EventRow::from_event(&e, fs)),
            });
        for h in &host_events {
            take_device_event(&mut check, Some(h), &mut listed, &mut awaiting_mark)?;
        }
        for h in &host_records {
            host_series.push(h, fs);
            let d = device.next().transpose()?;
            check.host_record(h, d.as_ref());
            if let Some(d) = d {
                let at = d
                    .sample_index
                    .checked_sub(session.first_sample)
                    .map(|i| i as usize)
                    .filter(|&i| i >= block_start && i < k)
                    .map(|i| heads[i - block_start]);
                check.device_record(&d, at);
                device_series.push(&d, fs);
                mark(&d, fs, &listed, &mut awaiting_mark, &mut marks);
            }
        }
    }
    // What the device has beyond the host's run.
    while let Some(d) = device.next().transpose()? {
        check.device_record(&d, None);
        device_series.push(&d, fs);
        mark(&d, fs, &listed, &mut awaiting_mark, &mut marks);
    }
    while take_device_event(&mut check, None, &mut listed, &mut awaiting_mark)? {}
    let (device_records, host_records) = check.records();
    let (device_event_count, host_event_count) = check.event_counts();
    let end_s = n as f64 / fs;
    Ok(PassResult {
        check: check.finish(k == n),
        device_events: listed,
        device_event_count,
        host_event_count,
        device_records,
        host_records,
        series: DeviceSeries {
            input_m_s2: input_series.map(MinMax::finish),
            head_f64_m_s2: head_series.map(MinMax::finish),
            device: device_series.finish(end_s),
            host: host_series.finish(end_s),
            level_marks: marks,
        },
    })
}

/// Marks the listed level events at record `d`'s sample; those before it have no record.
fn mark(
    d: &Telemetry,
    fs: f64,
    listed: &[EventRow],
    awaiting: &mut Vec<usize>,
    marks: &mut Vec<LevelMark>,
) {
    awaiting.retain(|&i| {
        let e = &listed[i];
        if e.sample > d.sample_index {
            return true;
        }
        if e.sample == d.sample_index
            && let Some(level) = Level::from_name(&e.name)
        {
            marks.push(LevelMark {
                t_s: f64::from(e.sample) / fs,
                vector_rms_m_s2: f64::from(d.vector_running_rms_m_s2),
                level,
                raised: e.raised,
            });
        }
        false
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::device_params;
    use crate::exposure::reference;
    use crate::io::params_file::ParamFile;
    use crate::io::telemetry_csv::{
        event_records, events_path, telemetry_records, write_events, write_telemetry,
    };
    use crate::report::device_check::Check;
    use supine_core::alerts::AlertEvent;
    use supine_core::model::Preset;

    const FS_HZ: f64 = 100.0;

    /// A ride that raises levels: quiet, then a strong 5 Hz vertical stretch, then quiet.
    fn ride(n: usize) -> Vec<[f32; 3]> {
        (0..n)
            .map(|k| {
                let t = k as f64 / FS_HZ;
                let a = if (20.0..50.0).contains(&t) { 6.0 } else { 0.3 };
                let z = a * (2.0 * std::f64::consts::PI * 5.0 * t).sin();
                let x = 0.2 * (2.0 * std::f64::consts::PI * 1.3 * t).cos();
                [x as f32, 0.0, z as f32]
            })
            .collect()
    }

    /// The whole-log check, the way it was computed before the pass: every series held,
    /// compared by position; the device's events scanned whole.
    fn whole_log_check(
        device: &[Telemetry],
        device_events: &[EventRow],
        host: &[Telemetry],
        host_events: &[EventRow],
        head_f64: &[[f64; 3]],
    ) -> Check {
        let max_diff = |f: &dyn Fn(&Telemetry) -> [f64; 3], g: &dyn Fn(usize) -> [f64; 3]| {
            if device.len() != host.len() {
                return f64::INFINITY;
            }
            (0..device.len())
                .flat_map(|i| {
                    let (a, b) = (f(&device[i]), g(i));
                    (0..3).map(move |x| (a[x] - b[x]).abs())
                })
                .fold(0.0, f64::max)
        };
        let head = |t: &Telemetry| t.head_acc_m_s2.map(f64::from);
        let highest = device
            .iter()
            .map(|t| t.alert_level)
            .max()
            .unwrap_or(Level::Normal);
        let same = device_events.len() == host_events.len()
            && device_events.iter().zip(host_events).all(|(a, b)| {
                a.sample == b.sample && a.kind == b.kind && a.name == b.name && a.raised == b.raised
            });
        Check {
            device_mtvv_m_s2: device
                .iter()
                .filter(|t| t.valid)
                .map(|t| f64::from(t.vector_running_rms_m_s2))
                .fold(0.0, f64::max),
            device_vdv_m_s175: device.last().map_or(0.0, |t| f64::from(t.vdv_m_s175)),
            highest_level: highest,
            highest_at_s: device_events
                .iter()
                .find(|e| {
                    e.kind == "level" && e.raised && Level::from_name(&e.name) == Some(highest)
                })
                .map(|e| e.time_s),
            final_level: device.last().map_or(Level::Normal, |t| t.alert_level),
            cleared_at_s: device_events
                .iter()
                .rev()
                .find(|e| e.kind == "level" && Level::from_name(&e.name) == Some(Level::Normal))
                .map(|e| e.time_s),
            level_events: device_events.iter().filter(|e| e.kind == "level").count(),
            faults: device_events
                .iter()
                .filter(|e| e.kind == "fault" && e.raised)
                .map(|e| (e.name.clone(), e.time_s))
                .collect(),
            head_diff_f32_m_s2: max_diff(&head, &|i| head(&host[i])),
            head_diff_f64_m_s2: device
                .iter()
                .flat_map(|t| {
                    let h = head_f64
                        .get(t.sample_index as usize)
                        .copied()
                        .unwrap_or([f64::INFINITY; 3]);
                    (0..3).map(move |a| (f64::from(t.head_acc_m_s2[a]) - h[a]).abs())
                })
                .fold(0.0, f64::max),
            rms_diff_m_s2: max_diff(&|t| [f64::from(t.vector_running_rms_m_s2); 3], &|i| {
                [f64::from(host[i].vector_running_rms_m_s2); 3]
            }),
            differing_values: crate::report::device_check::COMPARED_VALUES
                .iter()
                .enumerate()
                .filter(|(k, _)| {
                    device
                        .iter()
                        .zip(host)
                        .any(|(d, h)| crate::report::device_check::differing(d, h)[*k])
                })
                .map(|(_, name)| *name)
                .collect(),
            events_agree: same,
            first_event_difference: None,
            records_complete: device.len() == host.len()
                && device
                    .iter()
                    .zip(host)
                    .all(|(a, b)| a.sample_index == b.sample_index),
        }
    }

    struct Fixture {
        params: DeviceParams,
        file: ParamFile,
        samples: Vec<[f32; 3]>,
        host: Vec<Telemetry>,
        host_events: Vec<AlertEvent>,
        head_f64: Vec<[f64; 3]>,
    }

    fn fixture(n: usize) -> Fixture {
        let file = ParamFile::preset(Preset::PaperLitter);
        let params = device_params::build(&file, FS_HZ).unwrap();
        let samples = ride(n);
        let indices: Vec<u32> = (0..n as u32).collect();
        let run = reference::pipeline(&params, &indices, &samples);
        let head_f64 = reference::head_f64(&file.params, FS_HZ, &samples).unwrap();
        Fixture {
            params,
            file,
            samples,
            host: run.telemetry,
            host_events: run.events,
            head_f64,
        }
    }

    /// Writes `device` and `events` as a monitor would and runs the pass on them.
    fn pass(f: &Fixture, device: &[Telemetry], events: &[AlertEvent]) -> PassResult {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("log.csv");
        write_telemetry(&log, device, FS_HZ, f.params.joints.mask()).unwrap();
        write_events(&events_path(&log), events, FS_HZ).unwrap();
        let session = Session {
            params: &f.params,
            model: &f.file.params,
            sample_rate_hz: FS_HZ,
            first_sample: 0,
            samples: f.samples.len(),
            device_records: device.len(),
        };
        run(
            &session,
            f.samples.iter().map(|&x| Ok(x)),
            telemetry_records(&log).unwrap(),
            event_records(&events_path(&log), FS_HZ).unwrap(),
        )
        .unwrap()
    }

    fn rows(events: &[AlertEvent]) -> Vec<EventRow> {
        events
            .iter()
            .map(|e| EventRow::from_event(e, FS_HZ))
            .collect()
    }

    #[test]
    fn the_streamed_check_is_the_whole_log_check() {
        let f = fixture(7000);
        assert!(
            f.host_events.len() >= 2,
            "the ride raises and clears a level"
        );
        // The device as the host: they agree, and the figures are the whole log's.
        let same = pass(&f, &f.host, &f.host_events);
        let expected = whole_log_check(
            &f.host,
            &rows(&f.host_events),
            &f.host,
            &rows(&f.host_events),
            &f.head_f64,
        );
        assert_eq!(same.check, expected);
        assert!(same.check.agree() && same.check.highest_level > Level::Normal);
        assert_eq!(same.device_events, rows(&f.host_events));
        assert_eq!(
            (same.device_records, same.host_records),
            (f.host.len(), f.host.len())
        );
        assert!(!same.series.level_marks.is_empty());

        // One record's head one f32 step off, and the last event missing.
        let mut device = f.host.clone();
        let i = device.len() / 2;
        device[i].head_acc_m_s2[2] = f32::from_bits(device[i].head_acc_m_s2[2].to_bits() + 1);
        let events = &f.host_events[..f.host_events.len() - 1];
        let off = pass(&f, &device, events);
        let mut expected = whole_log_check(
            &device,
            &rows(events),
            &f.host,
            &rows(&f.host_events),
            &f.head_f64,
        );
        expected.first_event_difference = Some(events.len());
        assert_eq!(off.check, expected);
        assert!(off.check.head_diff_f32_m_s2 > 0.0 && !off.check.events_agree);

        // A record missing: incomplete, and the f32 differences cannot be taken.
        let mut gap = f.host.clone();
        gap.remove(i);
        let missing = pass(&f, &gap, &f.host_events);
        assert!(!missing.check.records_complete && !missing.check.agree());
        assert!(missing.check.head_diff_f32_m_s2.is_infinite());
        assert_eq!(missing.device_records + 1, missing.host_records);
    }

    #[test]
    fn every_value_the_device_reports_is_compared_and_named_when_it_differs() {
        let f = fixture(7000);
        let i = f.host.len() - 3;
        type Edit = (&'static str, fn(&mut Telemetry));
        let edits: [Edit; 6] = [
            ("vdv_m_s175", |t| {
                t.vdv_m_s175 = f32::from_bits(t.vdv_m_s175.to_bits() - 1)
            }),
            ("running_rms_y_m_s2", |t| t.running_rms_m_s2[1] += 0.25),
            ("vector_running_rms_m_s2", |t| {
                t.vector_running_rms_m_s2 += 0.25
            }),
            ("alert_level", |t| {
                t.alert_level = if t.alert_level == Level::Alarm {
                    Level::Normal
                } else {
                    Level::Alarm
                }
            }),
            ("valid", |t| t.valid = !t.valid),
            ("joints", |t| {
                let mut v = t.joints.as_slice().to_vec();
                v[0] = -v[0] - 1e-3;
                t.joints = supine_core::joint_exposure::JointValues::from_slice(&v).unwrap();
            }),
        ];
        for (name, edit) in edits {
            let mut device = f.host.clone();
            edit(&mut device[i]);
            let p = pass(&f, &device, &f.host_events);
            assert_eq!(p.check.differing_values, [name], "{name}");
            assert!(!p.check.agree(), "{name}: said to agree");
            // The head and the events are untouched: only the named value tells.
            assert_eq!(p.check.head_diff_f32_m_s2, 0.0);
            assert!(p.check.events_agree && p.check.records_complete);
        }
    }

    #[test]
    fn a_long_sessions_series_stay_bounded() {
        let f = fixture(120_000);
        let p = pass(&f, &f.host, &f.host_events);
        assert!(p.check.agree());
        let bound = 2 * PLOT_COLUMNS;
        let s = &p.series;
        for points in s
            .input_m_s2
            .iter()
            .chain(&s.head_f64_m_s2)
            .chain(&s.device.head_m_s2)
            .chain(&s.host.running_rms_m_s2)
            .chain([&s.device.vector_rms_m_s2, &s.host.vdv_m_s175])
        {
            assert!(points.len() <= bound, "{} points", points.len());
        }
        // The peaks survive: the input's largest z is the series' largest.
        let peak = f
            .samples
            .iter()
            .map(|x| f64::from(x[2]))
            .fold(0.0, f64::max);
        let drawn = s.input_m_s2[2].iter().map(|p| p.1).fold(0.0, f64::max);
        assert_eq!(drawn, peak);
    }
}
