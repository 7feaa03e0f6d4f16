//! The two-stage pipeline (rigid fit, then the litter-board fit bounded by it) as a whole.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use supine_core::model::{ModelParams, ParamId, SystemMatrices, Transmissibility};
use supine_host::identify::fit::objective::Target;
use supine_host::identify::fit::{self, FitSettings};
use supine_host::identify::geomean::geometric_mean_h;
use supine_host::identify::synth::{SynthSettings, draw_subjects};

fn h_of(params: &ModelParams, freqs_hz: &[f64]) -> Vec<Transmissibility> {
    let m = SystemMatrices::assemble(params);
    freqs_hz
        .iter()
        .map(|&f| m.transmissibility(f).unwrap())
        .collect()
}

/// Geometric means of four drawn subjects' exact H, rigid and litter board.
fn targets(seed: u64) -> (Target, Target, supine_core::model::Subject) {
    let settings = SynthSettings {
        subjects: 4,
        seed,
        param_log_sd: 0.3,
        ..SynthSettings::default()
    };
    let subjects = draw_subjects(&settings, &mut ChaCha8Rng::seed_from_u64(seed)).unwrap();
    let freqs_hz: Vec<f64> = (0..63).map(|k| 0.5 + 0.25 * k as f64).collect();
    let rigid: Vec<_> = subjects.iter().map(|s| h_of(&s.rigid, &freqs_hz)).collect();
    let litter: Vec<_> = subjects.iter().map(|s| h_of(&s.litter, &freqs_hz)).collect();
    let n = subjects.len() as f64;
    let subject = supine_core::model::Subject {
        height_m: subjects.iter().map(|s| s.rigid.subject.height_m).sum::<f64>() / n,
        mass_kg: subjects.iter().map(|s| s.rigid.subject.mass_kg).sum::<f64>() / n,
    };
    (
        Target {
            freqs_hz: freqs_hz.clone(),
            h: geometric_mean_h(&rigid),
        },
        Target {
            freqs_hz,
            h: geometric_mean_h(&litter),
        },
        subject,
    )
}

#[test]
#[ignore]
fn scout() {
    let settings = FitSettings::default();
    for seed in [1u64, 2, 3] {
        let (rigid_t, litter_t, subject) = targets(seed);
        let setup = fit::rigid_setup(rigid_t.clone(), subject, &settings).unwrap();
        let a = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
        let minima = fit::minima::RigidMinima::of_fit(&setup, &a);
        let ls = fit::litter_setup(litter_t.clone(), subject, &a.params, &settings).unwrap();
        let la = fit::run(&ls, &settings, &|_, _, _| {}).unwrap();
        eprintln!(
            "seed {seed}: rigid {} budget {} minima {} litter {}",
            a.solution.cost,
            minima.cost_budget,
            minima.minima.len(),
            la.solution.cost
        );
        for m in &minima.minima {
            eprintln!("   {} {} {}", m.part, m.start, m.cost_above_kept);
        }
        for id in ParamId::ALL.into_iter().filter(|id| id.is_contact()) {
            for scale in [1e-3, 1e3] {
                let mut base = a.params;
                let v = (base.get(id) * scale).clamp(1e-3, 1e6);
                base.set(id, v);
                let free: Vec<ParamId> = ParamId::ALL.into_iter().filter(|&p| p != id).collect();
                let mut s2 = setup.clone();
                s2.objective = fit::objective::Objective::new(base, free.clone(), rigid_t.clone());
                let bounds = |p: &ParamId| {
                    if p.is_stiffness() {
                        fit::STIFFNESS_BOUNDS
                    } else {
                        fit::DAMPING_BOUNDS
                    }
                };
                s2.lower = free.iter().map(|p| bounds(p).0.ln()).collect();
                s2.upper = free.iter().map(|p| bounds(p).1.ln()).collect();
                let theta = s2.objective.theta(&base);
                s2.starts = vec![fit::Start::new(
                    "pinned",
                    theta,
                    fit::solver::DampingScale::Marquardt,
                )];
                let b = fit::run(&s2, &settings, &|_, _, _| {}).unwrap();
                let lb_setup =
                    fit::litter_setup(litter_t.clone(), subject, &b.params, &settings).unwrap();
                let lb = fit::run(&lb_setup, &settings, &|_, _, _| {}).unwrap();
                eprintln!(
                    "  {id} x{scale}: rigid +{:.3e} ({:.2} budgets), litter {:+.2} %",
                    b.solution.cost - a.solution.cost,
                    (b.solution.cost - a.solution.cost) / minima.cost_budget,
                    100.0 * (lb.solution.cost / la.solution.cost - 1.0)
                );
            }
        }
    }
}
