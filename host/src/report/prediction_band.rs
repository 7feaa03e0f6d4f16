//! `supine report --band N`: the head exposure's prediction band. N parameter sets are
//! drawn from the fit's uncertainty (`identify::fit::band`: the same draws and quantiles
//! as `supine predict --band`), every leg goes through the device's pipeline once per set
//! (the evaluation the report's own values come from, [`ModelRun`]), and each draw's legs
//! are combined into a mission as the report combines them. The band of each value is
//! its 2.5 %, 50 % and 97.5 % quantile over the draws.
//!
//! A leg is read once for all the draws: the N pipelines run side by side over each
//! batch of [`BATCH_SAMPLES`] rows, spread over the threads, so memory holds N pipeline
//! states and one batch whatever the leg's length.
//!
//! What it covers and what it does not: docs/model.md#uncertainty-of-a-fit.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use serde::Serialize;
use supine_core::exposure::{combined_rms_m_s2, combined_vdv_m_s175};
use supine_core::model::ModelParams;

use super::mission::{Leg, MissionTotals};
use crate::device::device_params;
use crate::exposure::evaluation_input::EvaluationInput;
use crate::exposure::model_run::ModelRun;
use crate::exposure::reported_values::{AxisReport, tidy};
use crate::identify::fit::band::{BAND_MEDIAN, BAND_QUANTILES, BandRequest, Spread, draw_params};
use crate::io::params_file::ParamFile;
use crate::io::ride_rows::{OpenRide, RideSource};

/// Rows read before the draws' pipelines take them (1.5 MB of f64 triples).
pub const BATCH_SAMPLES: usize = 1 << 16;

/// One value: the report's own (the fitted parameters') and its band over the draws.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ValueBand {
    /// The value the report shows (the fitted parameters).
    pub nominal: f64,
    /// The 2.5 % quantile over the draws.
    pub low: f64,
    /// The median over the draws.
    pub median: f64,
    /// The 97.5 % quantile over the draws.
    pub high: f64,
}

impl ValueBand {
    fn new(nominal: f64, draws: &[f64]) -> Self {
        let Spread { low, median, high } = Spread::of(draws);
        Self {
            nominal,
            low,
            median,
            high,
        }
    }
}

/// The band of one leg's (or the mission's) head vector values.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VectorBand {
    /// The vector sum's overall rms, m/s^2.
    pub vector_rms_m_s2: ValueBand,
    /// The vector sum's VDV, m/s^1.75.
    pub vector_vdv_m_s175: ValueBand,
}

/// The report's band: per leg and for the mission.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReportBand {
    /// Parameter sets drawn.
    pub draws: usize,
    /// Seed of the draws.
    pub seed: u64,
    /// The quantiles given: low, median, high.
    pub quantiles: [f64; 3],
    /// Per leg, in the report's order.
    pub legs: Vec<VectorBand>,
    /// The legs combined as the report combines them.
    pub mission: VectorBand,
}

/// The head vector values of one leg for each parameter set of `sets`: (rms m/s^2, VDV
/// m/s^1.75, evaluated s), each from the same pipeline run as the report's leg values,
/// all in one pass over the ride on `threads` threads (the result does not depend on it).
fn leg_vectors(
    sets: &[ModelParams],
    file: &ParamFile,
    source: &RideSource,
    threads: usize,
) -> Result<Vec<(f64, f64, f64)>> {
    let input = EvaluationInput::new(source, None)?;
    let mut runs = sets
        .iter()
        .map(|params| {
            let drawn = ParamFile {
                params: *params,
                ..file.clone()
            };
            let device = device_params::build(&drawn, input.sample_rate_hz)?;
            Ok(ModelRun::new(&device, None, input.start_s))
        })
        .collect::<Result<Vec<_>>>()?;
    let group = runs.len().div_ceil(threads.max(1)).max(1);
    let mut rows = input.platform()?;
    let mut batch = Vec::with_capacity(BATCH_SAMPLES);
    loop {
        batch.clear();
        for row in rows.by_ref().take(BATCH_SAMPLES) {
            batch.push(row?);
        }
        if batch.is_empty() {
            break;
        }
        let batch = &batch;
        std::thread::scope(|scope| {
            let workers: Vec<_> = runs
                .chunks_mut(group)
                .map(|runs| {
                    scope.spawn(move || -> Result<()> {
                        for run in runs {
                            for &u in batch {
                                run.push(u, &mut |_| {})?;
                            }
                        }
                        Ok(())
                    })
                })
                .collect();
            workers
                .into_iter()
                .try_for_each(|w| w.join().map_err(|_| anyhow!("a band worker panicked"))?)
        })?;
    }
    Ok(runs
        .into_iter()
        .map(|run| {
            let values = run.finish(&mut |_| {}).values;
            let vector = AxisReport::new("vector", &values.vector);
            (vector.rms_m_s2, vector.vdv_m_s175, tidy(values.duration_s))
        })
        .collect())
}

/// The band of the report whose `legs` and `mission` came from the rides at `inputs`
/// (opened again one at a time by `rides`, as the report opens them) and `file`.
pub fn build(
    inputs: &[PathBuf],
    rides: impl OpenRide,
    file: &ParamFile,
    legs: &[Leg],
    mission: &MissionTotals,
    request: &BandRequest,
    threads: usize,
) -> Result<ReportBand> {
    let sets = draw_params(
        &file.params,
        &request.uncertainty,
        request.draws,
        request.seed,
    )?;
    // Per leg, per draw: (rms, VDV, evaluated s).
    let mut per_leg = Vec::with_capacity(inputs.len());
    for path in inputs {
        let ride = rides.open_ride(path)?;
        let values = leg_vectors(&sets, file, &ride, threads)
            .map_err(|e| anyhow!("{}: --band: {e}", path.display()))?;
        per_leg.push(values);
    }
    let band_of = |nominal_rms: f64, nominal_vdv: f64, draws: &[(f64, f64, f64)]| {
        let rms: Vec<f64> = draws.iter().map(|d| d.0).collect();
        let vdv: Vec<f64> = draws.iter().map(|d| d.1).collect();
        VectorBand {
            vector_rms_m_s2: ValueBand::new(nominal_rms, &rms),
            vector_vdv_m_s175: ValueBand::new(nominal_vdv, &vdv),
        }
    };
    let leg_bands = legs
        .iter()
        .zip(&per_leg)
        .map(|(leg, draws)| band_of(leg.vector.rms_m_s2, leg.vector.vdv_m_s175, draws))
        .collect();
    // Each draw's mission: its legs combined.
    let missions: Vec<(f64, f64, f64)> = (0..sets.len())
        .map(|k| {
            let rms: Vec<(f64, f64)> = per_leg.iter().map(|l| (l[k].0, l[k].2)).collect();
            let vdv: Vec<f64> = per_leg.iter().map(|l| l[k].1).collect();
            (combined_rms_m_s2(&rms), combined_vdv_m_s175(&vdv), 0.0)
        })
        .collect();
    Ok(ReportBand {
        draws: sets.len(),
        seed: request.seed,
        quantiles: [BAND_QUANTILES.0, BAND_MEDIAN, BAND_QUANTILES.1],
        legs: leg_bands,
        mission: band_of(
            mission.vector.rms_m_s2,
            mission.vector.vdv_m_s175,
            &missions,
        ),
    })
}
