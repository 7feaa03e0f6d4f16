//! A mission's numbers: each leg through the device's own pipeline (the values `supine
//! exposure` gives for the same file), the time spent at each alert level, the criterion
//! behind each alert, and the mission's ISO 2631-1 combination of its legs.
//!
//! Each leg is evaluated on its own, from a fresh pipeline state, as a device started at
//! the leg's beginning would: the legs are separate files, and the patient's dose across
//! them is the ISO combination ([`combined_vdv_m_s175`], [`combined_rms_m_s2`]), not one
//! long filter run over files with gaps between them.
//!
//! A leg is read in one pass, row by row ([`crate::io::ride_rows`]), and everything the
//! report keeps of it is bounded whatever its length: the values and events of
//! [`evaluate_model_with`] (the first [`MAX_LISTED_EVENTS`] events), the spectra's segment
//! sums, the chart series in at most [`MAX_CHART_POINTS`] buckets, and the two VDV values
//! the projection needs (its window is known before the pass: the leg's length is).

use anyhow::Result;
use serde::Serialize;
use supine_core::alerts::{AlertConfig, Level};
use supine_core::exposure::{combined_rms_m_s2, combined_vdv_m_s175};
use supine_core::model::JOINT_OUTPUT_COUNT;

use crate::device::device_params;
use crate::exposure::evaluation_input::EvaluationInput;
use crate::exposure::joints::JointReport;
use crate::exposure::model_exposure::{ModelExposure, evaluate_model_with};
use crate::exposure::model_run::{MAX_LISTED_EVENTS, Step};
use crate::exposure::reported_values::AxisReport;
use crate::exposure::timed_event::TimedEvent;
use crate::io::params_file::ParamFile;
use crate::io::ride_rows::RideSource;
pub use crate::report::level_time::TimeAtLevel;
use crate::report::mission_joints::{LegJoints, MissionJoint, mission_joints};
use crate::report::route::{PlacedEvent, Route, RouteBuilder};
use crate::report::spectrum::{AxisSpectrum, LegSpectra};
use crate::report::third_octave::{HeadBand, head_weighted_bands};
use crate::ride::quality::DataQuality;
use crate::schema::event::{EventCriterion, criterion_fields};

/// Rate of the time series kept for the charts, Hz: the running rms has a 1 s time
/// constant and the VDV only grows, so 10 points a second draw them exactly enough.
pub const CHART_RATE_HZ: f64 = 10.0;
/// Most buckets of a leg's chart series: a leg longer than this many chart steps (27 min
/// at [`CHART_RATE_HZ`]) gets buckets of twice, four times, ... the step, so the series
/// stays within about 2 MB however long the leg; each bucket keeps its largest running
/// rms and its extreme inputs, so no peak is lost (a chart has about a thousand columns).
pub const MAX_CHART_POINTS: usize = 1 << 14;
/// The projection's window: the dose rate of the last this many seconds of the mission
/// (or of the last leg's evaluated time, if shorter), s.
pub const PROJECTION_WINDOW_S: f64 = 300.0;

/// An alert event with what raised it: the exposure's timeline entry ([`TimedEvent`]'s
/// names) placed in the mission, with the vector values then.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlertRow {
    /// Time from the leg's start, s.
    pub leg_time_s: f64,
    /// Time from the mission's start, s.
    pub mission_time_s: f64,
    /// `level`, `fault` or `joint`.
    pub kind: &'static str,
    /// What happened (`normal -> warning`, `saturated raised`).
    pub event: String,
    /// The level after a level change (absent for faults and joint alerts).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<Level>,
    /// The event raises an alert.
    pub raised: bool,
    /// What changed the alert, with its value then, as the device's pipeline names it in
    /// the event (absent for a sensor fault): `criterion` and `value_m_s2`, ...
    #[serde(flatten, serialize_with = "criterion_fields")]
    pub criterion: Option<EventCriterion>,
    /// Vector running rms at the event, m/s^2.
    pub running_rms_m_s2: f64,
    /// Vector VDV at the event, m/s^1.75.
    pub vdv_m_s175: f64,
}

/// A leg's time series for the charts: one point per bucket of [`CHART_RATE_HZ`]'s step
/// (or a power-of-two multiple of it, for a leg of more than [`MAX_CHART_POINTS`] steps),
/// at the bucket's start, and one at the leg's end.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LegSeries {
    /// Time from the leg's start, s.
    pub t_s: Vec<f64>,
    /// Vector running rms, the largest in the bucket, m/s^2.
    pub vector_rms_m_s2: Vec<f64>,
    /// The leg's vector VDV at the bucket's start, m/s^1.75.
    pub vdv_m_s175: Vec<f64>,
    /// Alert level (0-3), the highest in the bucket.
    pub level: Vec<u8>,
    /// Litter-frame vertical acceleration (min and max over the bucket), m/s^2.
    pub platform_z_m_s2: Vec<(f64, f64)>,
    /// The joint outputs' running rms (1 s), in mm or degrees, in `JointOutput::ALL`'s
    /// order, the largest in the bucket.
    pub joint_running_rms: Vec<[f64; JOINT_OUTPUT_COUNT]>,
}

/// One leg: its exposure (as `supine exposure` reports it) and what the report adds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Leg {
    /// The file.
    pub input: String,
    /// How the report names it: `leg 1: ambulance.csv` in a mission, `ride A: ...` in a
    /// comparison of two rides ([`leg_label`]).
    pub label: String,
    /// Its length, s.
    pub duration_s: f64,
    /// Start within the mission, s.
    pub start_s: f64,
    /// Predicted head x, y, z, weighted.
    pub axes: [AxisReport; 3],
    /// The vector sum.
    pub vector: AxisReport,
    /// Alert events with their criteria (the first [`MAX_LISTED_EVENTS`]).
    pub alerts: Vec<AlertRow>,
    /// Events after the listed ones, counted only (absent when none).
    #[serde(skip_serializing_if = "crate::exposure::model_exposure::none_omitted")]
    pub alerts_omitted: usize,
    /// Seconds at each level.
    pub time_at_level_s: TimeAtLevel,
    /// Highest level reached.
    pub max_level: Level,
    /// The predicted neck and lower-back motion (as `supine exposure --json` gives it).
    pub joints: Vec<JointReport>,
    /// The ride's data-quality account (a logger's file; null for a recording), as
    /// `supine exposure --json` gives it.
    pub data_quality: Option<DataQuality>,
    /// Everything `supine exposure --json` gives for this file.
    #[serde(skip)]
    pub exposure: ModelExposure,
    /// Chart series.
    #[serde(skip)]
    pub series: LegSeries,
    /// Spectra of input and predicted head per axis.
    #[serde(skip)]
    pub spectra: Vec<AxisSpectrum>,
    /// The weighted head's one-third-octave band values, 0.5 to 80 Hz.
    pub third_octave_bands: Vec<HeadBand>,
    /// The dose rate at the leg's end, for the projection.
    #[serde(skip)]
    pub recent_dose: RecentDose,
    /// Where it happened, by road segment (`null` when the ride has no positions).
    pub route: Option<Route>,
}

/// The rate of VDV^4 over the end of a leg: the last [`PROJECTION_WINDOW_S`] of its
/// evaluated time, from the chart step's grid (the VDV at the first step at or after the
/// window's start, and at the last sample).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecentDose {
    /// The window, s (0 when the leg has no evaluated time).
    pub window_s: f64,
    /// VDV^4 per s, m^4 s^-7 per s.
    pub vdv4_rate_per_s: f64,
}

/// When the mission's VDV would reach each threshold at the recent dose rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Projection {
    /// The window the rate was measured over (the end of the last leg), s.
    pub window_s: f64,
    /// The rate of VDV^4 over that window, m^4 s^-7 per s (VDV^4 adds up over time).
    pub vdv4_rate_per_s: f64,
    /// For advisory, warning, alarm: the threshold, and seconds after the mission's end at
    /// which the VDV reaches it (0 when already reached, null when the rate is zero).
    pub thresholds: Vec<ProjectedThreshold>,
}

/// One threshold of the projection.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProjectedThreshold {
    /// `advisory`, `warning` or `alarm`.
    pub level: Level,
    /// The VDV threshold, m/s^1.75.
    pub vdv_m_s175: f64,
    /// Seconds after the end at which it is reached; 0 if already, null if never.
    pub reached_after_s: Option<f64>,
}

/// The mission's vector values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MissionVector {
    /// Energy-equivalent rms over the legs' evaluated time, m/s^2.
    pub rms_m_s2: f64,
    /// Largest MTVV of any leg, m/s^2.
    pub mtvv_m_s2: f64,
    /// `(sum VDV_i^4)^(1/4)`, m/s^1.75.
    pub vdv_m_s175: f64,
}

/// The whole mission.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionTotals {
    /// Sum of the legs' durations, s.
    pub duration_s: f64,
    /// Vector values combined over the legs.
    pub vector: MissionVector,
    /// Seconds at each level, summed over the legs.
    pub time_at_level_s: TimeAtLevel,
    /// Highest level of any leg.
    pub max_level: Level,
    /// The projection at the recent rate.
    pub projection: Projection,
    /// The neck and lower-back motion over the legs.
    pub joints: Vec<MissionJoint>,
}

/// The name of the ride `input`, the `index`-th given (from 0): `leg 1: NAME` in a
/// mission, `ride A: NAME` when two rides are `compared`.
pub fn leg_label(index: usize, input: &str, compared: bool) -> String {
    let name = std::path::Path::new(input)
        .file_name()
        .map_or_else(|| input.to_string(), |n| n.to_string_lossy().into_owned());
    named_leg_label(index, &name, compared)
}

/// [`leg_label`] with the leg's own `name` (its `--label`) in place of its file's.
pub fn named_leg_label(index: usize, name: &str, compared: bool) -> String {
    if compared {
        format!("ride {}: {name}", ["A", "B"][index % 2])
    } else {
        format!("leg {}: {name}", index + 1)
    }
}

/// Evaluates one leg (`source`, the `index`-th ride, starting at `start_s` in the
/// mission, or one of two `compared` rides) with `file`, in one pass over its rows.
pub fn evaluate_leg(
    source: &RideSource,
    file: &ParamFile,
    model: &str,
    (index, compared): (usize, bool),
    start_s: f64,
) -> Result<Leg> {
    let input = EvaluationInput::new(source, None)?;
    let fs = input.sample_rate_hz;
    let n = input.samples;
    let mut spectra = LegSpectra::new(n, fs)?;
    let mut series = SeriesBuilder::new(n, fs);
    let device = device_params::build(file, fs)?;
    let warmup_s = f64::from(device.exposure.config.warmup_s);
    // With a track: each sample's time in the ride's clock (read beside the evaluation,
    // in step with it), its place, and the route built from them.
    let track = source.track();
    let mut route = track.map(|t| RouteBuilder::new(t, &device.exposure, fs));
    let mut times = match track {
        Some(_) => Some(source.rows()?.map(|r| r.map(|row| row[0]))),
        None => None,
    };
    let mut time_error: Option<anyhow::Error> = None;
    let mut placed_events: Vec<PlacedEvent> = Vec::new();
    let mut pending_events: Vec<(f64, String, Option<u8>, bool)> = Vec::new();
    let mut dose = DoseWindow::new(n, fs, warmup_s);
    let mut at_level = [0usize; 4];
    let mut alerts: Vec<AlertRow> = Vec::new();
    // Rows of the events of the sample whose telemetry comes next.
    let mut awaiting = 0usize;
    let (exposure, params) =
        evaluate_model_with(&input, file, model.to_string(), |step| match step {
            Step::Alert(e) => {
                if alerts.len() < MAX_LISTED_EVENTS {
                    let sample = e.at_sample();
                    let timed = TimedEvent::new(e, 0.0, fs);
                    if route.is_some() {
                        let level = match e {
                            supine_core::alerts::AlertEvent::Level { to, .. } => Some(*to as u8),
                            _ => None,
                        };
                        pending_events.push((
                            sample as f64 / fs,
                            timed.event.clone(),
                            level,
                            timed.raised,
                        ));
                    }
                    alerts.push(AlertRow {
                        leg_time_s: sample as f64 / fs,
                        mission_time_s: start_s + sample as f64 / fs,
                        kind: timed.kind,
                        event: timed.event,
                        level: timed.level,
                        raised: timed.raised,
                        criterion: timed.criterion,
                        running_rms_m_s2: 0.0,
                        vdv_m_s175: 0.0,
                    });
                    awaiting += 1;
                }
            }
            Step::Sample {
                telemetry: t,
                input_m_s2,
                joints,
            } => {
                let k = t.sample_index as usize;
                let rms = f64::from(t.vector_running_rms_m_s2);
                let vdv = f64::from(t.vdv_m_s175);
                let level = t.alert_level as u8;
                let listed = alerts.len();
                for row in &mut alerts[listed - awaiting..] {
                    row.running_rms_m_s2 = rms;
                    row.vdv_m_s175 = vdv;
                }
                awaiting = 0;
                if let (Some(builder), Some(times), Some(track)) = (&mut route, &mut times, track) {
                    let place = match times.next() {
                        Some(Ok(t_s)) => track.at(t_s),
                        Some(Err(e)) => {
                            time_error.get_or_insert(e);
                            None
                        }
                        None => None,
                    };
                    if let Some(p) = place {
                        for (leg_time_s, event, level, raise) in pending_events.drain(..) {
                            placed_events.push(PlacedEvent {
                                leg_time_s,
                                event,
                                level,
                                raise,
                                lat_deg: p.lat_deg,
                                lon_deg: p.lon_deg,
                            });
                        }
                    }
                    pending_events.clear();
                    let outputs = joints.map(|j| j.outputs);
                    builder.push(
                        k,
                        place,
                        t.head_acc_m_s2,
                        t.valid,
                        rms,
                        level,
                        outputs.as_ref(),
                    );
                }
                at_level[usize::from(level.min(3))] += 1;
                spectra.push(input_m_s2, t.head_acc_m_s2.map(f64::from));
                dose.push(k, vdv);
                let joints = joints.map(|j| j.running_rms).unwrap_or_default();
                series.push(k, rms, vdv, level, input_m_s2[2], joints);
            }
        })?;
    if let Some(e) = time_error {
        return Err(e);
    }
    let spectra = spectra.finish(&params)?;
    let route = route.map(|r| r.finish(n, placed_events));
    Ok(Leg {
        label: leg_label(index, &exposure.input, compared),
        input: exposure.input.clone(),
        duration_s: exposure.duration_s,
        start_s,
        axes: exposure.head,
        vector: exposure.vector,
        alerts,
        alerts_omitted: exposure.alerts_omitted,
        time_at_level_s: TimeAtLevel::from_array(at_level.map(|c| c as f64 / fs)),
        max_level: exposure.max_level,
        joints: exposure.joints.clone(),
        data_quality: exposure.data_quality.clone().map(|mut q| {
            q.positions = route.as_ref().map(|r| r.track.clone());
            q
        }),
        series: series.finish(),
        third_octave_bands: head_weighted_bands(&spectra),
        spectra,
        recent_dose: dose.finish(),
        exposure,
        route,
    })
}

/// Samples per chart step at `fs_hz`.
fn chart_step(fs_hz: f64) -> usize {
    ((fs_hz / CHART_RATE_HZ).round() as usize).max(1)
}

/// The chart series of a leg of known length, built bucket by bucket.
struct SeriesBuilder {
    fs_hz: f64,
    samples: usize,
    bucket: usize,
    series: LegSeries,
}

impl SeriesBuilder {
    /// For `samples` at `fs_hz`: buckets of the chart step, doubled until at most
    /// [`MAX_CHART_POINTS`] cover the leg.
    fn new(samples: usize, fs_hz: f64) -> Self {
        let mut bucket = chart_step(fs_hz);
        while samples.div_ceil(bucket) > MAX_CHART_POINTS {
            bucket *= 2;
        }
        let points = samples.div_ceil(bucket) + 1;
        let series = LegSeries {
            t_s: Vec::with_capacity(points),
            vector_rms_m_s2: Vec::with_capacity(points),
            vdv_m_s175: Vec::with_capacity(points),
            level: Vec::with_capacity(points),
            platform_z_m_s2: Vec::with_capacity(points),
            joint_running_rms: Vec::with_capacity(points),
        };
        Self {
            fs_hz,
            samples,
            bucket,
            series,
        }
    }

    /// Sample `k`'s values (sample 0 first, in order).
    fn push(
        &mut self,
        k: usize,
        rms: f64,
        vdv: f64,
        level: u8,
        z: f64,
        joints: [f64; JOINT_OUTPUT_COUNT],
    ) {
        let s = &mut self.series;
        if k % self.bucket == 0 {
            s.t_s.push(k as f64 / self.fs_hz);
            s.vector_rms_m_s2.push(rms);
            s.vdv_m_s175.push(vdv);
            s.level.push(level);
            s.platform_z_m_s2.push((z, z));
            s.joint_running_rms.push(joints);
        } else if let Some(i) = s.t_s.len().checked_sub(1) {
            s.vector_rms_m_s2[i] = s.vector_rms_m_s2[i].max(rms);
            s.level[i] = s.level[i].max(level);
            let (lo, hi) = &mut s.platform_z_m_s2[i];
            *lo = lo.min(z);
            *hi = hi.max(z);
            for (m, v) in s.joint_running_rms[i].iter_mut().zip(joints) {
                *m = m.max(v);
            }
        }
        // The last sample, so the charts end where the leg ends.
        if k + 1 == self.samples {
            s.t_s.push(self.samples as f64 / self.fs_hz);
            s.vector_rms_m_s2.push(rms);
            s.vdv_m_s175.push(vdv);
            s.level.push(level);
            s.platform_z_m_s2.push((z, z));
            s.joint_running_rms.push(joints);
        }
    }

    fn finish(self) -> LegSeries {
        self.series
    }
}

/// The two VDV values of a leg's [`RecentDose`], caught as the leg goes by: the window
/// is known before the pass, since the leg's length is.
struct DoseWindow {
    fs_hz: f64,
    step: usize,
    from_s: f64,
    window_s: f64,
    from_vdv: Option<f64>,
    last_vdv: f64,
}

impl DoseWindow {
    fn new(samples: usize, fs_hz: f64, warmup_s: f64) -> Self {
        let end_s = samples as f64 / fs_hz;
        // Only evaluated time counts: the VDV is zero through the warm-up.
        let from_s = (end_s - PROJECTION_WINDOW_S).max(warmup_s);
        Self {
            fs_hz,
            step: chart_step(fs_hz),
            from_s,
            window_s: end_s - from_s,
            from_vdv: None,
            last_vdv: 0.0,
        }
    }

    fn push(&mut self, k: usize, vdv: f64) {
        if self.from_vdv.is_none() && k % self.step == 0 && k as f64 / self.fs_hz >= self.from_s {
            self.from_vdv = Some(vdv);
        }
        self.last_vdv = vdv;
    }

    fn finish(&self) -> RecentDose {
        if self.window_s <= 0.0 {
            return RecentDose::default();
        }
        // No step at or after the window's start: the window begins at the last sample.
        let from = self.from_vdv.unwrap_or(self.last_vdv);
        RecentDose {
            window_s: self.window_s,
            vdv4_rate_per_s: (self.last_vdv.powi(4) - from.powi(4)).max(0.0) / self.window_s,
        }
    }
}

/// The mission's totals over `legs` (in order), with the alert thresholds of `config`.
pub fn totals(legs: &[Leg], config: &AlertConfig) -> MissionTotals {
    let vdv: Vec<f64> = legs.iter().map(|l| l.vector.vdv_m_s175).collect();
    let rms: Vec<(f64, f64)> = legs
        .iter()
        .map(|l| (l.vector.rms_m_s2, l.exposure.evaluated_s))
        .collect();
    let mut at_level = [0.0; 4];
    for leg in legs {
        for (t, l) in at_level.iter_mut().zip(leg.time_at_level_s.as_array()) {
            *t += l;
        }
    }
    let max_level = legs.iter().map(|l| l.max_level).max().unwrap_or_default();
    let mission_vdv = combined_vdv_m_s175(&vdv);
    MissionTotals {
        duration_s: legs.iter().map(|l| l.duration_s).sum(),
        vector: MissionVector {
            rms_m_s2: combined_rms_m_s2(&rms),
            mtvv_m_s2: legs.iter().map(|l| l.vector.mtvv_m_s2).fold(0.0, f64::max),
            vdv_m_s175: mission_vdv,
        },
        time_at_level_s: TimeAtLevel::from_array(at_level),
        max_level,
        projection: projection(legs.last(), mission_vdv, config),
        joints: mission_joints(
            &legs
                .iter()
                .map(|l| LegJoints {
                    start_s: l.start_s,
                    evaluated_s: l.exposure.evaluated_s,
                    joints: &l.joints,
                })
                .collect::<Vec<_>>(),
        ),
    }
}

/// The projection from the last leg's recent dose rate.
fn projection(last: Option<&Leg>, mission_vdv: f64, config: &AlertConfig) -> Projection {
    let RecentDose {
        window_s,
        vdv4_rate_per_s: rate,
    } = last.map(|leg| leg.recent_dose).unwrap_or_default();
    let dose = mission_vdv.powi(4);
    let thresholds = Level::RAISED
        .into_iter()
        .zip(config.vdv_m_s175)
        .map(|(level, thr)| {
            let thr = f64::from(thr);
            let remaining = thr.powi(4) - dose;
            ProjectedThreshold {
                level,
                vdv_m_s175: thr,
                reached_after_s: if remaining <= 0.0 {
                    Some(0.0)
                } else if rate > 0.0 {
                    Some(remaining / rate)
                } else {
                    None
                },
            }
        })
        .collect();
    Projection {
        window_s,
        vdv4_rate_per_s: rate,
        thresholds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_legs_series_stays_bounded_and_keeps_its_peaks() {
        let fs = 500.0;
        // Three times the points at 10 Hz: buckets of four chart steps.
        let n = 3 * MAX_CHART_POINTS * chart_step(fs) + 7;
        let mut series = SeriesBuilder::new(n, fs);
        assert_eq!(series.bucket, 4 * chart_step(fs));
        let spike = 1_234_567;
        for k in 0..n {
            let rms = if k == spike { 9.0 } else { 0.5 };
            let z = if k == spike + 1 { -30.0 } else { 0.1 };
            let level = u8::from(k == spike + 2) * 3;
            series.push(k, rms, k as f64, level, z, [rms; JOINT_OUTPUT_COUNT]);
        }
        let s = series.finish();
        assert!(s.t_s.len() <= MAX_CHART_POINTS + 1, "{}", s.t_s.len());
        assert_eq!(s.t_s.len(), n.div_ceil(4 * chart_step(fs)) + 1);
        assert_eq!(s.vector_rms_m_s2.iter().copied().fold(0.0, f64::max), 9.0);
        assert_eq!(
            s.joint_running_rms.iter().map(|j| j[3]).fold(0.0, f64::max),
            9.0
        );
        assert_eq!(
            s.platform_z_m_s2.iter().map(|p| p.0).fold(0.0, f64::min),
            -30.0
        );
        assert_eq!(s.level.iter().copied().max(), Some(3));
        // The VDV at each bucket's start, and the leg's end last.
        assert_eq!(s.vdv_m_s175[1], (4 * chart_step(fs)) as f64);
        assert_eq!(s.t_s.last().copied(), Some(n as f64 / fs));
    }
}
