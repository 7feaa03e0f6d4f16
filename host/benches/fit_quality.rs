//! Fit quality and speed on `supine synth` data (BENCHMARKS.md, section Identification).
//!
//! For each seed: an 8-subject dataset (60 s at 200 Hz, the defaults) with s8 held
//! out; the rigid fit's final cost against the cost of the model built from the geometric
//! mean of the 7 training subjects' true parameters; the same for the litter-board fit
//! (against the true contacts with the fitted joints, the fit's own feasible set, and
//! against the all-true model); the time of the transmissibility of 8 subjects x 2 cases.
//! Datasets stay in `target/identification-bench/seedN` for `host/benches/scipy_fit.py`.
//!
//! Run: `cargo bench -p supine-host --bench fit_quality [-- SEED ...]`.

use std::path::PathBuf;
use std::time::Instant;

use supine_core::model::{ModelParams, ParamId};
use supine_host::identify::fit::objective::{Objective, Target};
use supine_host::identify::fit::solver::SolverSettings;
use supine_host::identify::fit::{self, FitSettings};
use supine_host::identify::synth::{SynthSettings, write_dataset};
use supine_host::identify::transmissibility::estimate;
use supine_host::io::dataset::{Case, Dataset};
use supine_host::io::params_file;

/// ftol = xtol = gtol of the recorded table (and of `scipy_fit.py`): tighter than the
/// defaults (1e-6, docs/model.md#solver-and-tolerances), so the figures in BENCHMARKS.md stay reproducible.
const BENCH_TOLERANCE: f64 = 1e-8;

fn truth_geomean(
    dir: &std::path::Path,
    ids: &[String],
    case: &str,
    subject: ModelParams,
) -> ModelParams {
    let sets: Vec<ModelParams> = ids
        .iter()
        .map(|id| {
            params_file::load(&dir.join("truth").join(format!("{id}_{case}.toml")))
                .unwrap()
                .params
        })
        .collect();
    let mut out = subject;
    for id in ParamId::ALL {
        let mean_ln = sets.iter().map(|p| p.get(id).ln()).sum::<f64>() / sets.len() as f64;
        out.set(id, mean_ln.exp());
    }
    out
}

fn main() {
    let seeds: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let seeds = if seeds.is_empty() {
        vec![1, 2, 3]
    } else {
        seeds
    };
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/identification-bench");
    println!(
        "| seed | rigid fit cost | rigid truth-geomean cost | rigid solver s | litter fit cost | litter truth contacts + fitted joints | litter all-truth cost | litter solver s | transmissibility 8 x 2 s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for seed in seeds {
        let dir = root.join(format!("seed{seed}"));
        let settings = SynthSettings {
            seed,
            ..SynthSettings::default()
        };
        write_dataset(&dir, &settings, |_, _| {}).unwrap();
        let dataset = Dataset::load(&dir).unwrap();
        // Transmissibility of all 8 subjects x 2 cases, as `supine transmissibility` does.
        let t0 = Instant::now();
        for case in [Case::Rigid, Case::Litter] {
            estimate(&dataset, case, None, &[], 0.1, 0.5, 16.0).unwrap();
        }
        let transmissibility_s = t0.elapsed().as_secs_f64();

        let exclude = vec!["s8".to_string()];
        let fit_settings = FitSettings {
            seed,
            solver: SolverSettings {
                ftol: BENCH_TOLERANCE,
                xtol: BENCH_TOLERANCE,
                gtol: BENCH_TOLERANCE,
                ..SolverSettings::default()
            },
            ..FitSettings::default()
        };
        let rigid_est = estimate(&dataset, Case::Rigid, None, &exclude, 0.1, 0.5, 16.0).unwrap();
        let ids: Vec<String> = rigid_est.subjects.iter().map(|s| s.id.clone()).collect();
        let subject = rigid_est.mean_subject();
        let target = Target {
            freqs_hz: rigid_est.freqs_hz.clone(),
            h: rigid_est.geomean.clone(),
        };
        let setup = fit::rigid_setup(target.clone(), subject, &fit_settings).unwrap();
        let t1 = Instant::now();
        let rigid = fit::run(&setup, &fit_settings, &|_, _, _| {}).unwrap();
        let rigid_s = t1.elapsed().as_secs_f64();
        let mut base = setup.objective.base;
        base.subject = subject;
        let truth_rigid = truth_geomean(&dir, &ids, "rigid", base);
        let truth_rigid_cost = setup
            .objective
            .cost(&setup.objective.theta(&truth_rigid))
            .unwrap();

        let litter_est = estimate(&dataset, Case::Litter, None, &exclude, 0.1, 0.5, 16.0).unwrap();
        let litter_target = Target {
            freqs_hz: litter_est.freqs_hz.clone(),
            h: litter_est.geomean.clone(),
        };
        let lsetup =
            fit::litter_setup(litter_target.clone(), subject, &rigid.params, &fit_settings)
                .unwrap();
        let t2 = Instant::now();
        let litter = fit::run(&lsetup, &fit_settings, &|_, _, _| {}).unwrap();
        let litter_s = t2.elapsed().as_secs_f64();
        let truth_litter = truth_geomean(&dir, &ids, "litter", base);
        let clamped: Vec<f64> = lsetup
            .objective
            .theta(&truth_litter)
            .iter()
            .zip(lsetup.lower.iter().zip(&lsetup.upper))
            .map(|(t, (lo, hi))| t.clamp(*lo, *hi))
            .collect();
        let litter_feasible_cost = lsetup.objective.cost(&clamped).unwrap();
        let all_truth = Objective::new(truth_litter, Vec::new(), litter_target);
        let litter_truth_cost = all_truth.cost(&[]).unwrap();
        println!(
            "| {seed} | {:.6} | {:.4} | {:.3} | {:.6} | {:.4} | {:.4} | {:.3} | {:.3} |",
            rigid.solution.cost,
            truth_rigid_cost,
            rigid_s,
            litter.solution.cost,
            litter_feasible_cost,
            litter_truth_cost,
            litter_s,
            transmissibility_s
        );
    }
}
