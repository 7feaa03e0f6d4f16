//! Criterion benchmarks of the identification pipeline's hot parts: one H1 estimate
//! (one subject, 60 s at 200 Hz, 0.1 Hz resolution), the fit's residuals with and
//! without the exact Jacobian (158 frequencies x 12 components, 42 parameters), and the
//! structured J^T J.
//!
//! Run: `cargo bench -p supine-host --bench identification`.

#![allow(missing_docs)] // criterion_group! generates an undocumented public function.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use supine_core::model::{ModelParams, ParamId, Preset, SystemMatrices};
use supine_host::identify::fit::objective::{Objective, Target};
use supine_host::identify::spectral::{WelchSettings, h1};
use supine_host::identify::synth::{SynthSettings, synth_recording};

fn benches(c: &mut Criterion) {
    let params = ModelParams::preset(Preset::PaperRigid);
    let settings = SynthSettings::default();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let rec = synth_recording(&params, &settings, &mut rng, "bench.csv".into()).unwrap();
    let welch = WelchSettings::for_resolution(200.0, 0.1);
    let inputs = [0, 1, 2].map(|a| rec.platform_m_s2[a].as_slice());
    let outputs = core::array::from_fn(|j| rec.sensors_m_s2[j].as_slice());
    c.bench_function("h1 one subject 60 s at 200 Hz", |b| {
        b.iter(|| h1(inputs, outputs, 200.0, &welch, 0.5, 16.0).unwrap())
    });

    let est = h1(inputs, outputs, 200.0, &welch, 0.5, 16.0).unwrap();
    let target = Target {
        freqs_hz: est.freqs_hz.clone(),
        h: est.h.clone(),
    };
    let mut start = params;
    for (i, id) in ParamId::ALL.into_iter().enumerate() {
        start.set(id, start.get(id) * (1.0 + 0.1 * (i % 5) as f64));
    }
    let objective = Objective::new(start, ParamId::ALL.to_vec(), target);
    let theta = objective.theta(&start);
    let (m, n) = (objective.residual_count(), objective.param_count());
    let mut r = vec![0.0; m];
    let mut jac = DMatrix::zeros(m, n);
    c.bench_function("fit residuals (158 f x 12 components)", |b| {
        b.iter(|| objective.evaluate(&theta, &mut r, None).unwrap())
    });
    c.bench_function("fit residuals and exact Jacobian (42 parameters)", |b| {
        b.iter(|| objective.evaluate(&theta, &mut r, Some(&mut jac)).unwrap())
    });
    c.bench_function("fit structured J^T J", |b| b.iter(|| objective.gram(&jac)));
    c.bench_function("fit dense J^T J", |b| b.iter(|| jac.transpose() * &jac));
    let matrices = SystemMatrices::assemble(&start);
    c.bench_function("model H at 158 frequencies (core, 18 x 18 LU)", |b| {
        b.iter(|| {
            for &f in &objective.target.freqs_hz {
                matrices.transmissibility(f).unwrap();
            }
        })
    });
}

criterion_group! {
    name = identification;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    targets = benches
}
criterion_main!(identification);
