//! The fit's analytic Jacobian against central finite differences, and the bounded solver
//! on problems with known bounded solutions.

use nalgebra::{Complex, DMatrix};
use supine_core::model::{ModelParams, ParamId, Preset, SystemMatrices, Transmissibility};
use supine_host::identify::fit::objective::{Objective, Target};
use supine_host::identify::fit::solver::{Problem, SolverSettings, Termination, solve};

/// A target that differs from the paper's model (so residuals are not zero) on a coarse grid.
fn target() -> Target {
    let mut other = ModelParams::preset(Preset::PaperRigid);
    for (i, id) in ParamId::ALL.into_iter().enumerate() {
        other.set(
            id,
            other.get(id) * (1.0 + 0.3 * ((i * 7 % 11) as f64 / 10.0 - 0.5)),
        );
    }
    let m = SystemMatrices::assemble(&other);
    let freqs_hz: Vec<f64> = (0..32).map(|k| 0.5 + 0.5 * k as f64).collect();
    let h: Vec<Transmissibility> = freqs_hz
        .iter()
        .map(|&f| m.transmissibility(f).unwrap())
        .collect();
    Target { freqs_hz, h }
}

#[test]
fn analytic_jacobian_matches_central_differences_for_all_42_parameters() {
    let base = ModelParams::preset(Preset::PaperRigid);
    let objective = Objective::new(base, ParamId::ALL.to_vec(), target());
    let theta = objective.theta(&base);
    let (m, n) = (objective.residual_count(), objective.param_count());
    let mut r = vec![0.0; m];
    let mut jac = DMatrix::zeros(m, n);
    objective.evaluate(&theta, &mut r, Some(&mut jac)).unwrap();
    // The residuals carry rounding noise near 1e-12 (A has entries from 1e-3 to 1e6), so
    // tiny steps drown in it; instead Richardson-extrapolated central differences
    // (4 D(h/2) - D(h)) / 3 with h = 2e-3 in ln p, whose truncation error is O(h^4); the
    // rounding noise left in them is about 1e-12 / 1e-3, hence the 1e-8 absolute floor.
    let central = |p: usize, h: f64| -> Vec<f64> {
        let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
        let mut t = theta.clone();
        t[p] += h;
        objective.evaluate(&t, &mut rp, None).unwrap();
        t[p] -= 2.0 * h;
        objective.evaluate(&t, &mut rm, None).unwrap();
        rp.iter()
            .zip(&rm)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect()
    };
    for p in 0..n {
        let (d1, d2) = (central(p, 2e-3), central(p, 1e-3));
        let column_scale = jac.column(p).amax().max(1e-8);
        for i in 0..m {
            let fd = (4.0 * d2[i] - d1[i]) / 3.0;
            let err = (fd - jac[(i, p)]).abs();
            assert!(
                err < 1e-6 * column_scale + 1e-8,
                "parameter {} residual {i}: analytic {} vs finite difference {fd}",
                ParamId::ALL[p],
                jac[(i, p)]
            );
        }
    }
    // The four roll parameters have no effect at all: their columns are exactly zero.
    let zero_columns: Vec<String> = (0..n)
        .filter(|&p| jac.column(p).amax() == 0.0)
        .map(|p| ParamId::ALL[p].to_string())
        .collect();
    assert_eq!(zero_columns.len(), 4, "{zero_columns:?}");
    assert!(
        zero_columns
            .iter()
            .all(|s| s.contains("rotational") && s.ends_with(".x"))
    );
}

#[test]
fn residuals_are_zero_when_the_model_equals_the_target() {
    let base = ModelParams::preset(Preset::PaperLitter);
    let m = SystemMatrices::assemble(&base);
    let freqs_hz = vec![1.0, 4.0, 9.5];
    let h = freqs_hz
        .iter()
        .map(|&f| m.transmissibility(f).unwrap())
        .collect();
    let objective = Objective::new(base, ParamId::ALL.to_vec(), Target { freqs_hz, h });
    let cost = objective.cost(&objective.theta(&base)).unwrap();
    assert!(cost < 1e-20, "{cost}");
    // And a phase residual is the wrapped difference over pi: conjugating the target
    // flips the sign of every phase residual.
    let conj = Target {
        freqs_hz: objective.target.freqs_hz.clone(),
        h: objective
            .target
            .h
            .iter()
            .map(|h| h.map(|z: Complex<f64>| z.conj()))
            .collect(),
    };
    let flipped = Objective::new(base, ParamId::ALL.to_vec(), conj);
    let mut r = vec![0.0; flipped.residual_count()];
    flipped
        .evaluate(&flipped.theta(&base), &mut r, None)
        .unwrap();
    let h33 = objective.target.h[1][(2, 2)];
    let i = Objective::residual_index(1, 2) + 1;
    let expected = supine_host::identify::geomean::wrap_pi(2.0 * h33.arg()) / std::f64::consts::PI;
    assert!((r[i] - expected).abs() < 1e-12, "{} vs {expected}", r[i]);
}

/// Rosenbrock as least squares: r = (10 (y - x^2), 1 - x); minimum (1, 1), cost 0.
struct Rosenbrock;

impl Problem for Rosenbrock {
    fn residual_count(&self) -> usize {
        2
    }
    fn param_count(&self) -> usize {
        2
    }
    fn evaluate(
        &self,
        x: &[f64],
        r: &mut [f64],
        jac: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        r[0] = 10.0 * (x[1] - x[0] * x[0]);
        r[1] = 1.0 - x[0];
        if let Some(j) = jac {
            j[(0, 0)] = -20.0 * x[0];
            j[(0, 1)] = 10.0;
            j[(1, 0)] = -1.0;
            j[(1, 1)] = 0.0;
        }
        Ok(())
    }
}

#[test]
fn solver_finds_the_rosenbrock_minimum_without_bounds() {
    let s = solve(
        &Rosenbrock,
        &[-1.2, 1.0],
        &[-10.0, -10.0],
        &[10.0, 10.0],
        &SolverSettings::default(),
        &mut |_, _| {},
    )
    .unwrap();
    assert!(
        (s.x[0] - 1.0).abs() < 1e-6 && (s.x[1] - 1.0).abs() < 1e-6,
        "{:?}",
        s.x
    );
    assert!(s.cost < 1e-12);
}

#[test]
fn solver_stops_on_an_active_bound_of_rosenbrock() {
    // With x <= 0.5 the minimum is on the bound: x = 0.5, y = x^2 = 0.25, cost 0.125.
    let s = solve(
        &Rosenbrock,
        &[-1.2, 1.0],
        &[-2.0, -2.0],
        &[0.5, 2.0],
        &SolverSettings::default(),
        &mut |_, _| {},
    )
    .unwrap();
    assert!((s.x[0] - 0.5).abs() < 1e-9, "{:?}", s.x);
    assert!((s.x[1] - 0.25).abs() < 1e-6, "{:?}", s.x);
    assert!((s.cost - 0.125).abs() < 1e-9, "{}", s.cost);
}

/// Linear least squares r = A x - b with a known bounded solution.
struct Linear {
    a: DMatrix<f64>,
    b: Vec<f64>,
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
        r: &mut [f64],
        jac: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        for (i, ri) in r.iter_mut().enumerate() {
            *ri = (0..x.len()).map(|j| self.a[(i, j)] * x[j]).sum::<f64>() - self.b[i];
        }
        if let Some(j) = jac {
            j.copy_from(&self.a);
        }
        Ok(())
    }
}

#[test]
fn solver_solves_a_bounded_linear_least_squares_problem() {
    // A = I (3x3) stacked on nothing else: the minimizer of |x - b|^2 over the box is b
    // clamped to the box. b = (2, -3, 0.5), box [0, 1]^3: solution (1, 0, 0.5).
    let problem = Linear {
        a: DMatrix::from_row_slice(
            4,
            3,
            &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0],
        ),
        b: vec![2.0, -3.0, 0.5, -1.0],
    };
    // Fourth row couples x0 and x1: r3 = x0 + x1 + 1. The constrained optimum: with x1 at
    // 0, minimize (x0 - 2)^2 + (x0 + 1)^2 -> x0 = 0.5; check x1's gradient pushes outward:
    // d/dx1 = 2 (x1 + 3) + 2 (x0 + x1 + 1) = 6 + 3 > 0 at the lower bound. So (0.5, 0, 0.5).
    let s = solve(
        &problem,
        &[0.9, 0.9, 0.9],
        &[0.0; 3],
        &[1.0; 3],
        &SolverSettings::default(),
        &mut |_, _| {},
    )
    .unwrap();
    let want = [0.5, 0.0, 0.5];
    for (got, want) in s.x.iter().zip(want) {
        assert!((got - want).abs() < 1e-7, "{:?}", s.x);
    }
}

#[test]
fn structured_gram_equals_the_dense_normal_matrix() {
    let base = ModelParams::preset(Preset::PaperRigid);
    let objective = Objective::new(base, ParamId::ALL.to_vec(), target());
    let theta = objective.theta(&base);
    let (m, n) = (objective.residual_count(), objective.param_count());
    let mut r = vec![0.0; m];
    let mut jac = DMatrix::zeros(m, n);
    objective.evaluate(&theta, &mut r, Some(&mut jac)).unwrap();
    let dense = jac.transpose() * &jac;
    let gram = objective.gram(&jac);
    let scale = dense.amax();
    assert!((dense - gram).amax() < 1e-12 * scale);
}

#[test]
fn solver_finds_the_rosenbrock_minimum_with_and_without_geodesic_acceleration() {
    for geodesic_alpha in [0.0, 0.75, 1.0] {
        let settings = SolverSettings {
            geodesic_alpha,
            ..SolverSettings::default()
        };
        let s = solve(
            &Rosenbrock,
            &[-1.2, 1.0],
            &[-10.0, -10.0],
            &[10.0, 10.0],
            &settings,
            &mut |_, _| {},
        )
        .unwrap();
        assert!(
            (s.x[0] - 1.0).abs() < 1e-6 && (s.x[1] - 1.0).abs() < 1e-6,
            "alpha {geodesic_alpha}: {:?}",
            s.x
        );
        assert!(s.cost < 1e-12, "alpha {geodesic_alpha}: {}", s.cost);
        if geodesic_alpha > 0.0 {
            // One extra residual evaluation per solved step.
            assert!(s.evaluations > s.iterations, "{s:?}");
        }
    }
}

#[test]
fn solver_abandons_a_run_that_stagnates_far_above_another_starts_cost() {
    // Another start reached 1e-3; this run (from cost 12.1) must fall by the whole gap on
    // every accepted step or stop: Rosenbrock's valley does not allow that.
    let settings = SolverSettings {
        best_elsewhere: 1e-3,
        stagnation_window: 1,
        stagnation_share: 1.0,
        ..SolverSettings::default()
    };
    let s = solve(
        &Rosenbrock,
        &[-1.2, 1.0],
        &[-10.0, -10.0],
        &[10.0, 10.0],
        &settings,
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(s.termination, Termination::Abandoned, "{s:?}");
    assert!(s.cost > 2e-3);
    // Below abandon_ratio times the other start's cost nothing is abandoned.
    let s = solve(
        &Rosenbrock,
        &[-1.2, 1.0],
        &[-10.0, -10.0],
        &[10.0, 10.0],
        &SolverSettings {
            best_elsewhere: 1e3,
            ..settings
        },
        &mut |_, _| {},
    )
    .unwrap();
    assert!(s.cost < 1e-12, "{s:?}");
}

/// The fit solves the parts (subsystems) apart: that is exact only if every residual is
/// moved by the parameters of one part alone and the parts' own evaluations agree with
/// the whole problem's. Checked against the whole problem's Jacobian (itself checked
/// against finite differences above) at a point away from the paper's values.
#[test]
fn the_parts_partition_the_problem_and_agree_with_the_whole() {
    let base = ModelParams::preset(Preset::PaperRigid);
    let objective = Objective::new(base, ParamId::ALL.to_vec(), target());
    let theta: Vec<f64> = objective
        .theta(&base)
        .iter()
        .enumerate()
        .map(|(i, t)| t + 0.4 * ((i * 5 % 7) as f64 / 6.0 - 0.5))
        .collect();
    let (m, n) = (objective.residual_count(), objective.param_count());
    let mut r = vec![0.0; m];
    let mut jac = DMatrix::zeros(m, n);
    objective.evaluate(&theta, &mut r, Some(&mut jac)).unwrap();
    let parts = objective.subsystems();
    let names: Vec<&str> = parts.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["longitudinal", "lateral", "vertical"]);
    // Every residual in exactly one part; every parameter in at most one, and the ones in
    // none (roll) have no effect at all.
    let mut row_part = vec![None; m];
    let mut param_part = vec![None; n];
    for (k, part) in parts.iter().enumerate() {
        for &i in &part.rows {
            assert!(
                row_part[i].replace(k).is_none(),
                "residual {i} in two parts"
            );
        }
        for &p in &part.params {
            assert!(
                param_part[p].replace(k).is_none(),
                "parameter {p} in two parts"
            );
        }
    }
    assert!(row_part.iter().all(Option::is_some));
    for p in 0..n {
        for i in 0..m {
            if param_part[p] != row_part[i] {
                assert_eq!(
                    jac[(i, p)],
                    0.0,
                    "parameter {p} moves residual {i} of another part"
                );
            }
        }
    }
    assert_eq!(param_part.iter().filter(|p| p.is_none()).count(), 4);
    let mut total = 0.0;
    for part in &parts {
        let mut rp = vec![0.0; part.rows.len()];
        let mut jp = DMatrix::zeros(part.rows.len(), part.params.len());
        objective
            .evaluate_subsystem(part, &theta, &mut rp, Some(&mut jp))
            .unwrap();
        for (a, &i) in part.rows.iter().enumerate() {
            assert!((rp[a] - r[i]).abs() <= 1e-12 * r[i].abs().max(1.0));
            for (b, &p) in part.params.iter().enumerate() {
                let scale = jac.column(p).amax().max(1e-12);
                assert!((jp[(a, b)] - jac[(i, p)]).abs() <= 1e-12 * scale);
            }
        }
        total += 0.5 * rp.iter().map(|v| v * v).sum::<f64>();
    }
    let whole = 0.5 * r.iter().map(|v| v * v).sum::<f64>();
    assert!((total - whole).abs() <= 1e-12 * whole);
}
