//! How sure a fit is: the standard errors against linear least squares in closed form and
//! against the scatter of repeated fits, and the head exposure's prediction band against
//! the truth on synthetic data.

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use supine_core::model::{ModelParams, SystemMatrices};
use supine_host::identify::fit::band::{head_exposure, head_exposure_band, quantile};
use supine_host::identify::fit::objective::Target;
use supine_host::identify::fit::solver::{DampingScale, Problem, SolverSettings, solve};
use supine_host::identify::fit::uncertainty::{Covariance, StoredUncertainty};
use supine_host::identify::fit::{self, Determination, FitSettings};
use supine_host::identify::synth::band_limited_input;
use supine_host::io::recording::Recording;

/// r(x) = A x - y: linear least squares.
struct Linear {
    a: DMatrix<f64>,
    y: DVector<f64>,
}

impl Problem for Linear {
    fn residual_count(&self) -> usize {
        self.a.nrows()
    }
    fn param_count(&self) -> usize {
        self.a.ncols()
    }
    fn evaluate(
        &self,
        x: &[f64],
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        let r = &self.a * DVector::from_column_slice(x) - &self.y;
        residuals.copy_from_slice(r.as_slice());
        if let Some(j) = jacobian {
            j.copy_from(&self.a);
        }
        Ok(())
    }
}

/// A well-conditioned 200 x 4 design with columns of different scales.
fn design(rng: &mut ChaCha8Rng) -> DMatrix<f64> {
    let unit = Normal::new(0.0, 1.0).unwrap();
    DMatrix::from_fn(200, 4, |_, j| unit.sample(rng) * (1.0 + j as f64))
}

fn fit_linear(problem: &Linear) -> (Vec<f64>, DMatrix<f64>, f64) {
    let n = problem.param_count();
    let settings = SolverSettings {
        ftol: 1e-14,
        xtol: 1e-14,
        gtol: 1e-12,
        ..SolverSettings::default()
    };
    let s = solve(
        problem,
        &vec![0.0; n],
        &vec![-1e6; n],
        &vec![1e6; n],
        &settings,
        &mut |_, _| {},
    )
    .unwrap();
    (s.x, s.jacobian, s.cost)
}

#[test]
fn standard_errors_equal_linear_least_squares_in_closed_form() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let a = design(&mut rng);
    let noise = Normal::new(0.0, 0.1).unwrap();
    let truth = DVector::from_column_slice(&[1.0, -2.0, 0.5, 3.0]);
    let y = &a * &truth + DVector::from_fn(200, |_, _| noise.sample(&mut rng));
    let problem = Linear { a: a.clone(), y };
    let (_, jacobian, cost) = fit_linear(&problem);
    let c = Covariance::at_minimum(&jacobian, cost).unwrap();
    // Closed form: s^2 (A^T A)^-1 with s^2 = |r|^2 / (m - n) at the normal equations'
    // solution.
    let ata = a.transpose() * &a;
    let x_hat = ata
        .clone()
        .cholesky()
        .unwrap()
        .solve(&(a.transpose() * &problem.y));
    let r = &a * &x_hat - &problem.y;
    let s2 = r.norm_squared() / (200 - 4) as f64;
    let expected = ata.try_inverse().unwrap() * s2;
    assert_eq!(c.degrees_of_freedom, 196);
    assert!((c.residual_variance / s2 - 1.0).abs() < 1e-9);
    for i in 0..4 {
        for j in 0..4 {
            let scale = (expected[(i, i)] * expected[(j, j)]).sqrt();
            assert!(
                (c.matrix[(i, j)] - expected[(i, j)]).abs() < 1e-8 * scale,
                "({i}, {j}): {} against {}",
                c.matrix[(i, j)],
                expected[(i, j)]
            );
        }
    }
}

/// The standard error predicts the scatter of the estimates over fresh noise.
#[test]
fn standard_errors_match_the_scatter_of_repeated_fits() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let a = design(&mut rng);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let truth = DVector::from_column_slice(&[0.3, 1.0, -0.7, 2.0]);
    let runs = 300;
    let mut estimates = vec![Vec::new(); 4];
    let mut predicted = [0.0; 4];
    for _ in 0..runs {
        let y = &a * &truth + DVector::from_fn(200, |_, _| noise.sample(&mut rng));
        let (x, jacobian, cost) = fit_linear(&Linear { a: a.clone(), y });
        let se = Covariance::at_minimum(&jacobian, cost)
            .unwrap()
            .standard_errors();
        for i in 0..4 {
            estimates[i].push(x[i]);
            predicted[i] += se[i] / runs as f64;
        }
    }
    for i in 0..4 {
        let mean = estimates[i].iter().sum::<f64>() / runs as f64;
        let sd = (estimates[i].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (runs - 1) as f64)
            .sqrt();
        // The scatter's own sampling error is about 1 / sqrt(2 * 300) = 4 %.
        assert!(
            (sd / predicted[i] - 1.0).abs() < 0.12,
            "parameter {i}: scatter {sd}, standard error {}",
            predicted[i]
        );
    }
}

/// A direction the data barely see (singular value below 1e-3 of the largest) gets no
/// variance, instead of an enormous one.
#[test]
fn weakly_determined_directions_get_no_variance() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut a = design(&mut rng);
    // Column 3 = column 0 plus a hair: the difference direction is nearly invisible.
    let hair = Normal::new(0.0, 1e-6).unwrap();
    for i in 0..200 {
        a[(i, 3)] = a[(i, 0)] + hair.sample(&mut rng);
    }
    let c = Covariance::at_minimum(&a, 1.0).unwrap();
    let weak = DVector::from_column_slice(&[1.0, 0.0, 0.0, -1.0]).normalize();
    let along = (&c.matrix * &weak).norm();
    // Kept, it would be about s^2 / (1e-6 sqrt(200))^2: 1e10 times the others.
    assert!(along < 1e-6 * c.matrix.norm(), "variance along it: {along}");
    assert!(c.standard_errors().iter().all(|se| se.is_finite()));
}

/// The exact H of `params` on a 0.25 Hz grid with multiplicative noise: the magnitude
/// residuals and the phase residuals (in units of pi) of the truth are N(0, sd^2).
fn noisy_target(params: &ModelParams, sd: f64, rng: &mut ChaCha8Rng) -> Target {
    let m = SystemMatrices::assemble(params);
    let freqs_hz: Vec<f64> = (0..63).map(|k| 0.5 + 0.25 * k as f64).collect();
    let unit = Normal::new(0.0, 1.0).unwrap();
    let h = freqs_hz
        .iter()
        .map(|&f| {
            m.transmissibility(f).unwrap().map(|v| {
                let magnitude = 1.0 + sd * unit.sample(rng);
                let phase = std::f64::consts::PI * sd * unit.sample(rng);
                v * nalgebra::Complex::from_polar(magnitude, phase)
            })
        })
        .collect();
    Target { freqs_hz, h }
}

/// 20 s of support acceleration at 200 Hz (the head exposure's input).
fn input_recording() -> Recording {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let input = band_limited_input(&mut rng, 4000, 200.0, (0.5, 16.0), 0.8).unwrap();
    Recording::from_columns(
        "input.csv".into(),
        200.0,
        input,
        core::array::from_fn(|_| vec![0.0; 4000]),
    )
}

/// Fits to noisy exact-structure data many times: the 95 % band of the head exposure
/// contains the truth's exposure at about its nominal rate, and the central 50 % of the
/// draws at about half the time (a band far too wide would contain it every time).
#[test]
fn the_prediction_band_contains_the_truth_at_about_its_nominal_rate() {
    let truth = crate::common::perturbed_truth();
    let recording = input_recording();
    let truth_exposure = head_exposure(&truth, &recording).unwrap().vector_rms_m_s2;
    let mut rng = ChaCha8Rng::seed_from_u64(2025);
    let replicates = 16;
    let (mut in_95, mut in_50) = (0, 0);
    let settings = FitSettings {
        starts: 1,
        ..FitSettings::default()
    };
    for r in 0..replicates {
        let target = noisy_target(&truth, 0.03, &mut rng);
        let mut setup = fit::rigid_setup(target, truth.subject, &settings).unwrap();
        setup.starts = vec![fit::Start::new(
            "truth",
            setup.objective.theta(&truth),
            DampingScale::Levenberg,
        )];
        let result = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
        let ident = fit::identifiability(&setup, &result);
        let determined: Vec<usize> = (0..ident.params.len())
            .filter(|&i| ident.params[i].determination == Determination::Determined)
            .collect();
        let stored = StoredUncertainty::of(
            ident.covariance.as_ref().unwrap(),
            &setup.objective.free,
            &determined,
        );
        let band =
            head_exposure_band(&result.params, &stored, &recording, 80, r as u64, 2).unwrap();
        if (band.low.vector_rms_m_s2..=band.high.vector_rms_m_s2).contains(&truth_exposure) {
            in_95 += 1;
        }
        let vector: Vec<f64> = band.draws.iter().map(|e| e.vector_rms_m_s2).collect();
        if (quantile(&vector, 0.25)..=quantile(&vector, 0.75)).contains(&truth_exposure) {
            in_50 += 1;
        }
    }
    eprintln!("truth in the 95 % band {in_95} times, in the central 50 % {in_50} times");
    // Binomial(16, 0.95): 13 or more with probability 0.99; Binomial(16, 0.5): 3..=13
    // with probability 0.996.
    assert!(in_95 >= 13, "95 % band: {in_95} of {replicates}");
    assert!(
        (3..=13).contains(&in_50),
        "50 % band: {in_50} of {replicates}"
    );
}

/// The parameter file keeps the covariance (as standard errors and correlations) to 9
/// digits; a `[fit]` table without it (files written before it existed) reads as none.
#[test]
fn the_stored_uncertainty_reads_back_and_old_files_have_none() {
    let truth = crate::common::perturbed_truth();
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let settings = FitSettings {
        starts: 1,
        ..FitSettings::default()
    };
    let mut setup = fit::rigid_setup(
        noisy_target(&truth, 0.02, &mut rng),
        truth.subject,
        &settings,
    )
    .unwrap();
    setup.starts = vec![fit::Start::new(
        "truth",
        setup.objective.theta(&truth),
        DampingScale::Levenberg,
    )];
    let result = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
    let ident = fit::identifiability(&setup, &result);
    let determined: Vec<usize> = (0..ident.params.len())
        .filter(|&i| ident.params[i].standard_error.is_some())
        .collect();
    assert!(determined.len() >= 30, "{} determined", determined.len());
    let stored = StoredUncertainty::of(
        ident.covariance.as_ref().unwrap(),
        &setup.objective.free,
        &determined,
    );
    let mut fit_table = toml::Table::new();
    fit_table.insert("uncertainty".into(), stored.to_toml(&result.params).into());
    let text = toml::to_string_pretty(&fit_table).unwrap();
    let back: toml::Table = toml::from_str(&text).unwrap();
    let read = StoredUncertainty::from_fit_table(Some(&back))
        .unwrap()
        .unwrap();
    assert_eq!(read.parameters, stored.parameters);
    assert_eq!(read.degrees_of_freedom, stored.degrees_of_freedom);
    let n = stored.parameters.len();
    let se = stored.standard_errors();
    for i in 0..n {
        for j in 0..n {
            let diff = (read.covariance_ln_p[(i, j)] - stored.covariance_ln_p[(i, j)]).abs();
            assert!(diff <= 1e-9 * se[i] * se[j], "({i}, {j})");
        }
    }
    let mut old = back.clone();
    old.remove("uncertainty");
    assert_eq!(StoredUncertainty::from_fit_table(Some(&old)).unwrap(), None);
    assert_eq!(StoredUncertainty::from_fit_table(None).unwrap(), None);
}
