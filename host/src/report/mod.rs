//! The mission report (`supine report`): one or more legs of a ride, each evaluated by the
//! device's own pipeline for a given patient, combined as ISO 2631-1 combines exposures in
//! sequence, and written as one self-contained HTML page and one JSON object.
//!
//! Three layers, each importing only the ones before it, and one leaf of markup helpers:
//!
//! 1. The numbers (this module's [`MissionReport`], the `--json` data model; no markup):
//!    - [`mission`]: the legs, alerts with their criteria, time at each level, the
//!      mission's combination and the projection.
//!    - [`spectrum`]: the power spectral densities of input and predicted head;
//!      [`third_octave`] their one-third-octave band values.
//!    - [`mission_joints`]: the neck and lower-back motion combined over the legs.
//!    - [`level_time`]: time at each alert level (a leg's, the mission's, a segment's).
//!    - [`route`]: where each leg happened: its road segments, the worst of them, the
//!      map's points and placed events (a ride with positions).
//!    - [`prediction_band`]: with `--band N`, the prediction band of the head's vector values.
//!    - [`calibration`]: the sensor's calibration record, its age and whether it is flagged.
//!    - [`device_check`], [`device_pass`], [`device_series`]: with a device log (what a
//!      device sent for the ride, as `supine demo` has it), the device's own account
//!      beside the host's: the largest difference of each output, identical events.
//!    - [`monitor_log`]: a session logged by `supine monitor --log` as the input: its
//!      input stream is the ride, its telemetry and events the device log.
//! 2. The charts, built on the numbers: [`charts`] (what each chart of the legs shows),
//!    [`device_charts`] (the device's telemetry over the host's), [`route_charts`] (the
//!    route map and the running rms against speed).
//! 3. The sections of the page, built on the charts: [`page`] (the page and the legs'
//!    sections), [`joints_section`], [`band_section`], [`device_section`],
//!    [`calibration_section`], [`route_section`] (where it happened).
//!
//! [`markup`] (escaping, a level's tag, a chart as a figure) is the leaf every section uses.
//!
//! The JSON's key names are the contract of `--json` (`docs/exposure.md#mission-report`).

pub mod band_section;
pub mod calibration;
pub mod calibration_section;
pub mod charts;
pub mod device_charts;
pub mod device_check;
pub mod device_pass;
pub mod device_section;
pub mod device_series;
pub mod joints_section;
pub mod level_time;
pub mod markup;
pub mod mission;
pub mod mission_joints;
pub mod monitor_log;
pub mod page;
pub mod prediction_band;
pub mod quality_section;
pub mod route;
pub mod route_charts;
pub mod route_section;
pub mod spectrum;
pub mod third_octave;

use std::path::PathBuf;

use anyhow::{Result, bail};
use serde::Serialize;
use supine_core::alerts::AlertConfig;

use crate::device::device_params;
use crate::exposure::reported_values::ThresholdsReport;
use crate::io::params_file::ParamFile;
use crate::io::ride_rows::OpenRide;
use mission::{Leg, MissionTotals, evaluate_leg, totals};

/// The patient the model was scaled to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SubjectReport {
    /// Standing height, m.
    pub height_m: f64,
    /// Body mass, kg.
    pub mass_kg: f64,
}

/// The model the legs went through.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelReport {
    /// A preset's name or the parameter file.
    pub name: String,
    /// The parameter set's identity (hex), with the patient's height and mass in it.
    pub identity: String,
    /// The alert thresholds of the vector sum.
    pub thresholds: ThresholdsReport,
}

/// One compared quantity of two rides.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ComparedValue {
    /// What (e.g. `vector VDV, m/s^1.75`).
    pub quantity: String,
    /// Ride A's value.
    pub a: f64,
    /// Ride B's value.
    pub b: f64,
    /// `b - a`.
    pub difference: f64,
    /// `100 (b - a) / a`, when `a` is not zero.
    pub change_percent: Option<f64>,
    /// Whether more of it is worse for the patient (vibration, time at a raised level),
    /// better (time at normal), or neither (the duration): how the difference is coloured.
    pub more_is_worse: Option<bool>,
}

/// Two rides side by side.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The quantities compared.
    pub rows: Vec<ComparedValue>,
}

/// The report: the patient, the model, the legs and the mission.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionReport {
    /// The patient.
    pub subject: SubjectReport,
    /// The model.
    pub model: ModelReport,
    /// The legs in order (or the two rides compared).
    pub legs: Vec<Leg>,
    /// The legs combined (for a comparison: both rides' totals, not a real mission).
    pub mission: MissionTotals,
    /// Present when two rides were compared rather than joined.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comparison: Option<Comparison>,
    /// The prediction band (`--band N`), when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band: Option<prediction_band::ReportBand>,
    /// The sensor's calibration, its age and verdict: the parameter file's as of the
    /// report's date, or, for a monitor session, the device's as of the session's start.
    pub calibration: calibration::CalibrationReport,
    /// The alert thresholds.
    #[serde(skip)]
    pub thresholds: AlertConfig,
}

/// Evaluates the rides at `inputs` (each opened by `rides`) as the legs of a mission, or
/// as two rides compared. Each ride is read row by row; a leg keeps only its values, its
/// bounded chart series and its spectra.
pub fn build(
    inputs: &[PathBuf],
    rides: impl OpenRide,
    file: &ParamFile,
    model: &str,
    compare: bool,
) -> Result<MissionReport> {
    if compare && inputs.len() != 2 {
        bail!(
            "--compare: expected exactly two --input rides, found {}",
            inputs.len()
        );
    }
    let mut legs = Vec::with_capacity(inputs.len());
    let mut start_s = 0.0;
    for (index, path) in inputs.iter().enumerate() {
        let ride = rides.open_ride(path)?;
        // Compared rides share one time axis from zero; legs follow each other.
        let start = if compare { 0.0 } else { start_s };
        let leg = evaluate_leg(&ride, file, model, (index, compare), start)?;
        start_s += leg.duration_s;
        legs.push(leg);
    }
    let device = file.device.unwrap_or_default();
    let config = device.alerts;
    let mission = totals(&legs, &config);
    let identity = device_params::identity_hex(&device_params::identity(file)?);
    let comparison = compare.then(|| compare_rides(&legs[0], &legs[1]));
    Ok(MissionReport {
        subject: SubjectReport {
            height_m: file.params.subject.height_m,
            mass_kg: file.params.subject.mass_kg,
        },
        model: ModelReport {
            name: model.to_string(),
            identity,
            thresholds: (&config).into(),
        },
        legs,
        mission,
        comparison,
        band: None,
        calibration: calibration::CalibrationReport::new(
            &device.calibration,
            calibration::today(),
            "the report's date",
        ),
        thresholds: config,
    })
}

fn compare_rides(a: &Leg, b: &Leg) -> Comparison {
    let mut rows = Vec::new();
    let mut push_as = |quantity: String, a: f64, b: f64, more_is_worse: Option<bool>| {
        rows.push(ComparedValue {
            quantity,
            a,
            b,
            difference: b - a,
            change_percent: (a != 0.0).then(|| 100.0 * (b - a) / a),
            more_is_worse,
        });
    };
    push_as("duration, s".into(), a.duration_s, b.duration_s, None);
    let mut push = |quantity: String, a: f64, b: f64| push_as(quantity, a, b, Some(true));
    let names = ["x", "y", "z", "vector"];
    let axes_a = a.axes.iter().chain([&a.vector]);
    let axes_b = b.axes.iter().chain([&b.vector]);
    for ((name, va), vb) in names.iter().zip(axes_a).zip(axes_b) {
        push(format!("{name} rms, m/s^2"), va.rms_m_s2, vb.rms_m_s2);
        push(format!("{name} MTVV, m/s^2"), va.mtvv_m_s2, vb.mtvv_m_s2);
        push(
            format!("{name} VDV, m/s^1.75"),
            va.vdv_m_s175,
            vb.vdv_m_s175,
        );
        push(format!("{name} peak, m/s^2"), va.peak_m_s2, vb.peak_m_s2);
    }
    let at_a = a.time_at_level_s.as_array();
    let at_b = b.time_at_level_s.as_array();
    for (i, name) in supine_core::alerts::Level::ALL.iter().enumerate() {
        // More time at normal is better; at any raised level, worse.
        push_as(format!("time at {name}, s"), at_a[i], at_b[i], Some(i > 0));
    }
    Comparison { rows }
}
