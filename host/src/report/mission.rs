//! A mission's numbers: each leg through the device's own pipeline (the values `supine
//! exposure` gives for the same file), the time spent at each alert level, the criterion
//! behind each alert, and the mission's ISO 2631-1 combination of its legs.
//!
//! Each leg is evaluated on its own, from a fresh pipeline state, as a device started at
//! the leg's beginning would: the legs are separate files, and the patient's dose across
//! them is the ISO combination ([`combined_vdv_m_s175`], [`combined_rms_m_s2`]), not one
//! long filter run over files with gaps between them.

use anyhow::{Result, bail};
use serde::Serialize;
use supine_core::alerts::{AlertConfig, Criterion, Level};
use supine_core::blob::DeviceParams;
use supine_core::model::JOINT_OUTPUT_COUNT;
use supine_core::pipeline::{PipelineOutput, PipelineState};

use crate::device::device_params;
use crate::exposure::joints::{JointReport, JointTracker};
use crate::exposure::report::{
    AxisReport, ModelExposure, Prepared, combined_rms_m_s2, combined_vdv_m_s175, model_exposure,
    prepare,
};
use crate::io::params_file::ParamFile;
use crate::io::recording::{Layout, Recording};
use crate::report::joints::{MissionJoint, mission_joints};
use crate::report::spectrum::{AxisSpectrum, spectra};

/// Samples handed to the pipeline per call.
const CHUNK_SAMPLES: usize = 4096;
/// Rate of the time series kept for the charts, Hz: the running rms has a 1 s time
/// constant and the VDV only grows, so 10 points a second draw them exactly enough.
pub const CHART_RATE_HZ: f64 = 10.0;
/// The projection's window: the dose rate of the last this many seconds of the mission
/// (or of the last leg's evaluated time, if shorter), s.
pub const PROJECTION_WINDOW_S: f64 = 300.0;
/// Level names in order.
pub const LEVEL_NAMES: [&str; 4] = ["normal", "advisory", "warning", "alarm"];

/// Seconds spent at each alert level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TimeAtLevel {
    /// At normal, s.
    pub normal: f64,
    /// At advisory, s.
    pub advisory: f64,
    /// At warning, s.
    pub warning: f64,
    /// At alarm, s.
    pub alarm: f64,
}

impl TimeAtLevel {
    /// The seconds in level order.
    pub fn as_array(&self) -> [f64; 4] {
        [self.normal, self.advisory, self.warning, self.alarm]
    }

    fn from_array(a: [f64; 4]) -> Self {
        Self {
            normal: a[0],
            advisory: a[1],
            warning: a[2],
            alarm: a[3],
        }
    }
}

/// An alert event with what raised it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlertRow {
    /// Time from the leg's start, s.
    pub leg_time_s: f64,
    /// Time from the mission's start, s.
    pub mission_time_s: f64,
    /// `level` or `fault`.
    pub kind: &'static str,
    /// What happened (`normal -> warning`, `saturated raised`).
    pub event: String,
    /// The event raises an alert.
    pub raise: bool,
    /// What raised it, as the device's pipeline names it in the event: `running rms` or
    /// `VDV` (a lowered level: `running rms`, the only one that falls), or `sensor fault`.
    pub criterion: &'static str,
    /// The criterion's value at the event, m/s^2 (running rms) or m/s^1.75 (VDV); for a
    /// fault, the running rms.
    pub value: f64,
    /// Vector running rms at the event, m/s^2.
    pub running_rms_m_s2: f64,
    /// Vector VDV at the event, m/s^1.75.
    pub vdv_m_s175: f64,
}

/// A leg's time series for the charts, at about [`CHART_RATE_HZ`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LegSeries {
    /// Time from the leg's start, s.
    pub t_s: Vec<f64>,
    /// Vector running rms, m/s^2.
    pub vector_rms_m_s2: Vec<f64>,
    /// The leg's vector VDV so far, m/s^1.75.
    pub vdv_m_s175: Vec<f64>,
    /// Alert level (0-3).
    pub level: Vec<u8>,
    /// Litter-frame vertical acceleration (min and max over each chart step), m/s^2.
    pub platform_z_m_s2: Vec<(f64, f64)>,
    /// The joint outputs' running rms (1 s), in mm or degrees, in `JointOutput::ALL`'s
    /// order, at the same times.
    pub joint_running_rms: Vec<[f64; JOINT_OUTPUT_COUNT]>,
}

/// One leg: its exposure (as `supine exposure` reports it) and what the report adds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Leg {
    /// The file.
    pub input: String,
    /// Its length, s.
    pub duration_s: f64,
    /// Start within the mission, s.
    pub start_s: f64,
    /// Predicted head x, y, z, weighted.
    pub axes: [AxisReport; 3],
    /// The vector sum.
    pub vector: AxisReport,
    /// Alert events with their criteria.
    pub alerts: Vec<AlertRow>,
    /// Seconds at each level.
    pub time_at_level_s: TimeAtLevel,
    /// Highest level reached.
    pub max_level: &'static str,
    /// The predicted neck and lower-back motion (as `supine exposure --json` gives it).
    pub joints: Vec<JointReport>,
    /// Everything `supine exposure --json` gives for this file.
    #[serde(skip)]
    pub exposure: ModelExposure,
    /// Chart series.
    #[serde(skip)]
    pub series: LegSeries,
    /// Spectra of input and predicted head per axis.
    #[serde(skip)]
    pub spectra: Vec<AxisSpectrum>,
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
    pub level: &'static str,
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
    pub max_level: &'static str,
    /// The projection at the recent rate.
    pub projection: Projection,
    /// The neck and lower-back motion over the legs.
    pub joints: Vec<MissionJoint>,
}

/// Evaluates one leg (`recording`, starting at `start_s` in the mission) with `file`.
pub fn evaluate_leg(
    recording: &Recording,
    layout: Layout,
    file: &ParamFile,
    model: &str,
    start_s: f64,
) -> Result<Leg> {
    let [x, y, z] = &recording.platform_m_s2;
    let prepared = prepare(recording, &[x, y, z], None)?;
    let mut params = device_params::build(file, prepared.sample_rate_hz)?;
    let identity = device_params::identity_hex(&params.identity);
    let input = recording.path.display().to_string();
    let mut exposure = model_exposure(
        &params,
        &prepared,
        &input,
        layout,
        model.to_string(),
        identity,
    )?;
    // Every sample's telemetry: the head for the spectra, the values at each event.
    params.telemetry.decimation = 1;
    let mut run = run_leg(&params, &prepared)?;
    let (joints, joint_series) = joint_run(file, &prepared)?;
    exposure.joints = joints.clone();
    run.series.joint_running_rms = joint_series;
    let fs = prepared.sample_rate_hz;
    let n = prepared.channels[0].len();
    let alerts = exposure
        .alerts
        .iter()
        .map(|e| {
            let k = (e.sample as usize).min(n.saturating_sub(1));
            let (rms, vdv) = (run.vector_rms[k], run.vdv[k]);
            let (criterion, value) = match e.criterion {
                Some(c @ Criterion::RunningRms { .. }) => ("running rms", f64::from(c.value())),
                Some(c @ Criterion::Vdv { .. }) => ("VDV", f64::from(c.value())),
                None => ("sensor fault", rms),
            };
            AlertRow {
                leg_time_s: e.sample as f64 / fs,
                mission_time_s: start_s + e.sample as f64 / fs,
                kind: e.kind,
                event: e.event.clone(),
                raise: e.raise,
                criterion,
                value,
                running_rms_m_s2: rms,
                vdv_m_s175: vdv,
            }
        })
        .collect();
    let spectra = spectra(&prepared.channels, &run.head, fs, &params)?;
    Ok(Leg {
        input,
        duration_s: exposure.duration_s,
        start_s,
        axes: exposure.head,
        vector: exposure.vector,
        alerts,
        time_at_level_s: TimeAtLevel::from_array(time_at_level(&run.level, fs)),
        max_level: exposure.max_level,
        joints,
        series: run.series,
        spectra,
        exposure,
    })
}

/// The leg's neck and lower-back motion (the values `supine exposure` gives) and the
/// joints' running rms at the chart series' times (every chart step, and the last sample).
fn joint_run(
    file: &ParamFile,
    prepared: &Prepared,
) -> Result<(Vec<JointReport>, Vec<[f64; JOINT_OUTPUT_COUNT]>)> {
    let [x, y, z] = match prepared.channels.as_slice() {
        [x, y, z] => [x, y, z],
        _ => bail!("a leg needs the three platform columns"),
    };
    let fs = prepared.sample_rate_hz;
    let step = chart_step(fs);
    let n = x.len();
    let mut tracker = JointTracker::new(&file.params, fs)?;
    let mut series = Vec::with_capacity(n / step + 2);
    for k in 0..n {
        tracker.step([x[k], y[k], z[k]]);
        // As the head's series: the value after each step's first sample, and the last.
        if k % step == 0 {
            series.push(tracker.running_rms_display());
        }
        if k + 1 == n {
            series.push(tracker.running_rms_display());
        }
    }
    Ok((tracker.report(), series))
}

/// Samples per chart step at `fs_hz`.
fn chart_step(fs_hz: f64) -> usize {
    ((fs_hz / CHART_RATE_HZ).round() as usize).max(1)
}

/// Seconds at each level from a per-sample level trace.
fn time_at_level(level: &[u8], fs_hz: f64) -> [f64; 4] {
    let mut counts = [0usize; 4];
    for &l in level {
        counts[usize::from(l.min(3))] += 1;
    }
    counts.map(|c| c as f64 / fs_hz)
}

/// The per-sample outputs of one run.
struct LegRun {
    head: [Vec<f64>; 3],
    vector_rms: Vec<f64>,
    vdv: Vec<f64>,
    level: Vec<u8>,
    series: LegSeries,
}

/// Runs the device pipeline over the leg, keeping every sample's telemetry.
fn run_leg(params: &DeviceParams, prepared: &Prepared) -> Result<LegRun> {
    let [x, y, z] = match prepared.channels.as_slice() {
        [x, y, z] => [x, y, z],
        _ => bail!("a leg needs the three platform columns"),
    };
    let n = x.len();
    let fs = prepared.sample_rate_hz;
    let mut run = LegRun {
        head: Default::default(),
        vector_rms: Vec::with_capacity(n),
        vdv: Vec::with_capacity(n),
        level: Vec::with_capacity(n),
        series: LegSeries::default(),
    };
    let step = chart_step(fs);
    let mut state = PipelineState::new();
    let mut indices = Vec::with_capacity(CHUNK_SAMPLES);
    let mut samples = Vec::with_capacity(CHUNK_SAMPLES);
    for first in (0..n).step_by(CHUNK_SAMPLES) {
        let last = (first + CHUNK_SAMPLES).min(n);
        indices.clear();
        indices.extend(first as u32..last as u32);
        samples.clear();
        samples.extend((first..last).map(|k| [x[k] as f32, y[k] as f32, z[k] as f32]));
        params.process(&mut state, &indices, &samples, |out| {
            if let PipelineOutput::Telemetry(t) = out {
                for (axis, v) in run.head.iter_mut().zip(t.head_acc_m_s2) {
                    axis.push(f64::from(v));
                }
                run.vector_rms.push(f64::from(t.vector_running_rms_m_s2));
                run.vdv.push(f64::from(t.vdv_m_s175));
                run.level.push(t.alert_level as u8);
            }
        });
    }
    if run.level.len() != n {
        bail!(
            "the pipeline reported {} of {n} samples (telemetry decimation must be 1)",
            run.level.len()
        );
    }
    for start in (0..n).step_by(step) {
        let end = (start + step).min(n);
        let s = &mut run.series;
        s.t_s.push(start as f64 / fs);
        s.vector_rms_m_s2.push(run.vector_rms[start]);
        s.vdv_m_s175.push(run.vdv[start]);
        s.level
            .push(run.level[start..end].iter().copied().max().unwrap_or(0));
        let (lo, hi) = z[start..end]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        s.platform_z_m_s2.push((lo, hi));
    }
    // The last sample, so the charts end where the leg ends.
    if n > 0 {
        let s = &mut run.series;
        s.t_s.push(n as f64 / fs);
        s.vector_rms_m_s2.push(run.vector_rms[n - 1]);
        s.vdv_m_s175.push(run.vdv[n - 1]);
        s.level.push(run.level[n - 1]);
        s.platform_z_m_s2.push((z[n - 1], z[n - 1]));
    }
    Ok(run)
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
    let max_level = legs
        .iter()
        .filter_map(|l| LEVEL_NAMES.iter().position(|n| *n == l.max_level))
        .max()
        .unwrap_or(0);
    let mission_vdv = combined_vdv_m_s175(&vdv);
    MissionTotals {
        duration_s: legs.iter().map(|l| l.duration_s).sum(),
        vector: MissionVector {
            rms_m_s2: combined_rms_m_s2(&rms),
            mtvv_m_s2: legs.iter().map(|l| l.vector.mtvv_m_s2).fold(0.0, f64::max),
            vdv_m_s175: mission_vdv,
        },
        time_at_level_s: TimeAtLevel::from_array(at_level),
        max_level: LEVEL_NAMES[max_level],
        projection: projection(legs.last(), mission_vdv, config),
        joints: mission_joints(legs),
    }
}

/// The projection from the last leg's recent dose rate.
fn projection(last: Option<&Leg>, mission_vdv: f64, config: &AlertConfig) -> Projection {
    let (window_s, rate) = last.map_or((0.0, 0.0), |leg| {
        let s = &leg.series;
        let end_s = s.t_s.last().copied().unwrap_or(0.0);
        // Only evaluated time counts: the VDV is zero through the warm-up.
        let from_s = (end_s - PROJECTION_WINDOW_S).max(leg.exposure.warmup_s);
        let window_s = end_s - from_s;
        if window_s <= 0.0 {
            return (0.0, 0.0);
        }
        let k = s.t_s.partition_point(|&t| t < from_s).min(s.t_s.len() - 1);
        let v_end = s.vdv_m_s175.last().copied().unwrap_or(0.0);
        let v_from = s.vdv_m_s175[k];
        (
            window_s,
            (v_end.powi(4) - v_from.powi(4)).max(0.0) / window_s,
        )
    });
    let dose = mission_vdv.powi(4);
    let thresholds = LEVEL_NAMES[1..]
        .iter()
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

/// The level's index in [`LEVEL_NAMES`] (normal for an unknown name).
pub fn level_index(name: &str) -> usize {
    LEVEL_NAMES.iter().position(|n| *n == name).unwrap_or(0)
}

/// The core's level for a name.
pub fn level_of(name: &str) -> Level {
    Level::RAISED
        .into_iter()
        .find(|l| l.name() == name)
        .unwrap_or(Level::Normal)
}
