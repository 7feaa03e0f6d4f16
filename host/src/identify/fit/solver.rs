//! A bounded Levenberg-Marquardt solver with geodesic acceleration for small nonlinear
//! least-squares problems: minimize 0.5 |r(x)|^2 subject to lower <= x <= upper.
//!
//! Each iteration solves (J_F^T J_F + lambda D) v = -J_F^T r over the free variables F,
//! where a variable is held (not free) when it sits on a bound and the gradient pushes it
//! outward, or when it sits on a bound and the solved step would leave the box (it then
//! joins the held set and the step is solved again: the binding set of projected Newton
//! methods). D ([`DampingScale`]) is Levenberg's max(diag J^T J) I, scaled so that lambda
//! is dimensionless (a parameter without effect gets a zero step, not a singular system),
//! or Marquardt's diag J^T J (floored), which lets the parameters the data barely see
//! move: from one start the two end in different minima of a sloppy problem, and the fit
//! uses both (see `fit`). (A More-style trust region on |d| was tried and found worse
//! minima.)
//!
//! Derivatives: the Jacobian comes from the problem (the fit's is analytic, exact to
//! rounding); the second-order term of the geodesic acceleration is not: it is a finite
//! difference along the step, below. Only the step's curvature correction is approximate,
//! never the gradient, so the stopping tests and the first-order conditions are exact.
//!
//! Geodesic acceleration (Transtrum, Machta and Sethna, Phys. Rev. E 83, 036701 (2011);
//! Transtrum and Sethna, arXiv:1201.5885 (2012)): the second directional derivative of the
//! residuals along v by a finite difference with step h (`geodesic_h`, in ln p),
//! r_vv = (2 / h) ((r(x + h v) - r(x)) / h - J v), one extra residual evaluation without
//! Jacobian (no second derivatives of H are formed), gives the acceleration a from the same factorized system
//! with right-hand side -J_F^T r_vv; the step is v + a / 2, and it is refused (lambda
//! grows as on a failed step) when 2 |a| / |v| exceeds `geodesic_alpha`; it is skipped
//! while the last accepted step's gain ratio was within `geodesic_skip_band` of 1 and
//! when lambda is below `geodesic_min_lambda` (Gauss-Newton's endgame). This
//! follows the curved valleys of sloppy models (the rigid fit's paper start reaches a
//! lower minimum on the benchmark's seed 3: 18.167 against 18.826).
//!
//! The trial point is projected onto the box; the step is accepted when the actual
//! reduction is at least 1e-4 of the reduction the local quadratic model predicts for the
//! projected step, and lambda follows Nielsen's update (lambda *= max(lambda_min_factor,
//! 1 - (2 rho - 1)^3) on success, *= nu with nu doubling on failure).
//!
//! Stops (as scipy's `least_squares`) when an accepted step reduces the cost by less than
//! `ftol` times the cost, when the step is shorter than `xtol (xtol + |x|)`, when the
//! projected gradient's largest entry is below `gtol`, or after `max_iterations`; and, in
//! a multi-start fit, when the run stagnates far above another start's best cost
//! (`best_elsewhere`).

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::kernels::tr_mul_vec;

/// A least-squares problem: residuals and Jacobian at a point.
pub trait Problem {
    /// Number of residuals m.
    fn residual_count(&self) -> usize;
    /// Number of unknowns n.
    fn param_count(&self) -> usize;
    /// Fills `residuals` (m) and, if given, `jacobian` (m x n) at `x`; an error means the
    /// point cannot be evaluated (the step is then rejected).
    fn evaluate(
        &self,
        x: &[f64],
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String>;

    /// J^T J; a problem that knows its Jacobian's sparsity can do better than the default.
    fn gram(&self, jacobian: &DMatrix<f64>) -> DMatrix<f64> {
        jacobian.transpose() * jacobian
    }
}

/// The default ftol, xtol and gtol: the convention of docs/model.md#solver-and-tolerances, the paper's tolerances (its
/// trust-region reflective fit used 1e-6).
pub const DEFAULT_TOLERANCE: f64 = 1e-6;

/// The diagonal D of the damping term lambda D.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DampingScale {
    /// Levenberg's D = max(diag J^T J) I: in ln p every parameter is on one scale
    /// already, and a parameter without effect gets a zero step. Measured on the paper's
    /// all-ones start: better minima and fewer iterations than Marquardt's.
    Levenberg,
    /// Marquardt's D = diag J^T J (floored at 1e-12 of its largest entry): the damping
    /// no longer holds back the parameters the data barely see, so a run travels along
    /// the long, nearly flat valleys of the weakly determined directions in a few steps.
    Marquardt,
}

impl DampingScale {
    fn scale(self, jtj: &DMatrix<f64>) -> Vec<f64> {
        let n = jtj.ncols();
        let diag_max = (0..n).map(|i| jtj[(i, i)]).fold(0.0, f64::max).max(1e-300);
        match self {
            DampingScale::Levenberg => vec![diag_max; n],
            DampingScale::Marquardt => (0..n).map(|i| jtj[(i, i)].max(1e-12 * diag_max)).collect(),
        }
    }
}

/// Tolerances and limits: plain data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverSettings {
    /// Relative cost reduction below which the solver stops.
    pub ftol: f64,
    /// Relative step length below which the solver stops.
    pub xtol: f64,
    /// Largest projected-gradient entry below which the solver stops.
    pub gtol: f64,
    /// Most iterations (accepted or not).
    pub max_iterations: usize,
    /// Geodesic acceleration (Transtrum and Sethna 2012): the largest accepted ratio
    /// 2 |a| / |v| of the acceleration's contribution to the velocity; 0 turns it off.
    pub geodesic_alpha: f64,
    /// The finite-difference step h (along the velocity) of the second derivative.
    pub geodesic_h: f64,
    /// The acceleration is skipped (no extra evaluation) while the last accepted step's
    /// gain ratio rho is within this of 1: the quadratic model was accurate there, so the
    /// path is nearly straight (this also keeps Levenberg-Marquardt's fast endgame on
    /// zero-residual problems).
    pub geodesic_skip_band: f64,
    /// The acceleration is skipped when lambda is below this (Gauss-Newton regime: the
    /// accelerated step's gain ratio stays below 1, which would keep lambda from falling
    /// and turn the quadratic endgame of a zero-residual problem into a linear one).
    pub geodesic_min_lambda: f64,
    /// The damping's diagonal.
    pub damping: DampingScale,
    /// Smallest factor of Nielsen's lambda update on a successful step.
    pub lambda_min_factor: f64,
    /// The lowest cost another start reached (a multi-start fit sets it; infinity, the
    /// default, never abandons). A run is abandoned when its cost is above
    /// `abandon_ratio` times this and it stagnates: over its last `stagnation_window`
    /// accepted steps the cost fell by less than `stagnation_share` of the gap to it.
    pub best_elsewhere: f64,
    /// See `best_elsewhere`.
    pub abandon_ratio: f64,
    /// See `best_elsewhere`.
    pub stagnation_window: usize,
    /// See `best_elsewhere`.
    pub stagnation_share: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            ftol: DEFAULT_TOLERANCE,
            xtol: DEFAULT_TOLERANCE,
            gtol: DEFAULT_TOLERANCE,
            max_iterations: 1000,
            geodesic_alpha: 1.0,
            geodesic_h: 0.3,
            geodesic_skip_band: 0.1,
            geodesic_min_lambda: 1e-7,
            damping: DampingScale::Levenberg,
            lambda_min_factor: 0.1,
            best_elsewhere: f64::INFINITY,
            abandon_ratio: 2.0,
            stagnation_window: 25,
            stagnation_share: 0.1,
        }
    }
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// Cost reduction below ftol.
    Ftol,
    /// Step below xtol.
    Xtol,
    /// Projected gradient below gtol.
    Gtol,
    /// No step could reduce the cost (lambda grew without bound).
    Stalled,
    /// The iteration limit.
    MaxIterations,
    /// The cost stagnated above `abandon_above`.
    Abandoned,
}

impl Termination {
    /// A short description.
    pub const fn describe(self) -> &'static str {
        match self {
            Termination::Ftol => "cost reduction below ftol",
            Termination::Xtol => "step below xtol",
            Termination::Gtol => "projected gradient below gtol",
            Termination::Stalled => "no step reduces the cost",
            Termination::MaxIterations => "iteration limit",
            Termination::Abandoned => "stagnated far above the best start",
        }
    }

    /// Whether the run ended at a minimum of its own (not given up on far above another).
    pub const fn at_minimum(self) -> bool {
        !matches!(self, Termination::Abandoned)
    }
}

/// The solver's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The cost at the start (projected into the box).
    pub initial_cost: f64,
    /// The best point found.
    pub x: Vec<f64>,
    /// 0.5 |r(x)|^2.
    pub cost: f64,
    /// Residuals at x.
    pub residuals: Vec<f64>,
    /// Jacobian at x.
    pub jacobian: DMatrix<f64>,
    /// Iterations done.
    pub iterations: usize,
    /// Residual evaluations done.
    pub evaluations: usize,
    /// Why it stopped.
    pub termination: Termination,
}

fn clamp(x: &mut [f64], lower: &[f64], upper: &[f64]) {
    for ((v, lo), hi) in x.iter_mut().zip(lower).zip(upper) {
        *v = v.clamp(*lo, *hi);
    }
}

fn half_sum_sq(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// Checks that the start and the bounds have the problem's size and that every lower
/// bound is at most its upper bound.
fn check_box(n: usize, x0: &[f64], lower: &[f64], upper: &[f64]) -> Result<(), String> {
    if x0.len() != n || lower.len() != n || upper.len() != n {
        return Err(format!("expected {n} unknowns and bounds"));
    }
    if let Some(i) = (0..n).find(|&i| lower[i] > upper[i] || lower[i].is_nan() || upper[i].is_nan())
    {
        return Err(format!(
            "bound {i}: lower {} above upper {}",
            lower[i], upper[i]
        ));
    }
    Ok(())
}

/// The largest entry of the projected gradient: how far a unit gradient step would move
/// each variable inside the box.
fn projected_gradient(x: &[f64], g: &DVector<f64>, lower: &[f64], upper: &[f64]) -> f64 {
    (0..x.len())
        .map(|i| (x[i] - (x[i] - g[i]).clamp(lower[i], upper[i])).abs())
        .fold(0.0, f64::max)
}

/// The variables not held on a bound by a gradient that pushes them outward.
fn free_variables(x: &[f64], g: &DVector<f64>, lower: &[f64], upper: &[f64]) -> Vec<usize> {
    (0..x.len())
        .filter(|&i| {
            let at_lower = x[i] <= lower[i] && g[i] > 0.0;
            let at_upper = x[i] >= upper[i] && g[i] < 0.0;
            !(at_lower || at_upper)
        })
        .collect()
}

/// The free variables that sit on a bound and whose step would leave the box.
fn leaving_the_box(
    free: &[usize],
    step: &DVector<f64>,
    x: &[f64],
    lower: &[f64],
    upper: &[f64],
) -> Vec<usize> {
    free.iter()
        .enumerate()
        .filter(|&(a, &i)| {
            (x[i] <= lower[i] && step[a] < 0.0) || (x[i] >= upper[i] && step[a] > 0.0)
        })
        .map(|(_, &i)| i)
        .collect()
}

/// The Cholesky factor of the damped system J_F^T J_F + lambda d I and its right-hand
/// side -J_F^T r on the free set; None when the system is not positive definite.
fn damped_system(
    jtj: &DMatrix<f64>,
    g: &DVector<f64>,
    free: &[usize],
    lambda: f64,
    scale: &[f64],
) -> Option<(Cholesky<f64, Dyn>, DVector<f64>)> {
    let nf = free.len();
    let mut system = DMatrix::zeros(nf, nf);
    let mut rhs = DVector::zeros(nf);
    for (a, &i) in free.iter().enumerate() {
        rhs[a] = -g[i];
        for (b, &j) in free.iter().enumerate() {
            system[(a, b)] = jtj[(i, j)];
        }
        system[(a, a)] += lambda * scale[i];
    }
    Some((system.cholesky()?, rhs))
}

/// Nielsen's damping: lambda and the growth factor nu of a failed step.
struct Damping {
    lambda: f64,
    nu: f64,
}

impl Damping {
    /// A failed step: lambda grows by nu, and nu doubles.
    fn reject(&mut self) {
        self.lambda *= self.nu;
        self.nu *= 2.0;
    }

    /// An accepted step with gain ratio rho.
    fn accept(&mut self, rho: f64, min_factor: f64) {
        self.lambda *= min_factor.max(1.0 - (2.0 * rho - 1.0).powi(3));
        self.nu = 2.0;
    }
}

/// Whether the geodesic acceleration corrected a step.
enum Acceleration {
    /// Added to the step.
    Applied,
    /// Not computed (skipped, or x + h v could not be evaluated): the plain step stands.
    None,
    /// The path bends too much for this step: refuse it (lambda grows).
    Refused,
}

/// One run of the solver: the problem, the box, the current point and the counters.
struct Run<'a> {
    problem: &'a dyn Problem,
    lower: &'a [f64],
    upper: &'a [f64],
    settings: &'a SolverSettings,
    x: Vec<f64>,
    r: Vec<f64>,
    jac: DMatrix<f64>,
    cost: f64,
    // Trial point buffers, swapped in when a step is accepted.
    trial_x: Vec<f64>,
    trial_r: Vec<f64>,
    trial_jac: DMatrix<f64>,
    // Residuals at x + h v for the second directional derivative.
    r_h: Vec<f64>,
    // The cost at the start.
    initial_cost: f64,
    // Accepted costs, for the stagnation test.
    history: Vec<f64>,
    // Gain ratio of the last accepted step (none yet: the acceleration is computed).
    last_rho: f64,
    damping: Damping,
    iterations: usize,
    evaluations: usize,
}

impl<'a> Run<'a> {
    /// Evaluates the start (projected into the box).
    fn start(
        problem: &'a dyn Problem,
        x0: &[f64],
        lower: &'a [f64],
        upper: &'a [f64],
        settings: &'a SolverSettings,
    ) -> Result<Self, String> {
        let (m, n) = (problem.residual_count(), problem.param_count());
        let mut x = x0.to_vec();
        clamp(&mut x, lower, upper);
        let mut r = vec![0.0; m];
        let mut jac = DMatrix::zeros(m, n);
        problem.evaluate(&x, &mut r, Some(&mut jac))?;
        let cost = half_sum_sq(&r);
        if !cost.is_finite() {
            return Err("the cost at the start is not finite".into());
        }
        Ok(Self {
            problem,
            lower,
            upper,
            settings,
            x,
            r,
            jac,
            cost,
            trial_x: vec![0.0; n],
            trial_r: vec![0.0; m],
            trial_jac: DMatrix::zeros(m, n),
            r_h: vec![0.0; m],
            initial_cost: cost,
            history: Vec::new(),
            last_rho: f64::NEG_INFINITY,
            damping: Damping {
                lambda: 1e-3,
                nu: 2.0,
            },
            iterations: 0,
            evaluations: 1,
        })
    }

    /// Iterates until a stopping test holds.
    fn iterate(&mut self, progress: &mut dyn FnMut(usize, f64)) -> Termination {
        while self.iterations < self.settings.max_iterations {
            let jtj = self.problem.gram(&self.jac);
            let g = tr_mul_vec(&self.jac, &self.r);
            if projected_gradient(&self.x, &g, self.lower, self.upper) < self.settings.gtol {
                return Termination::Gtol;
            }
            if let Some(stop) = self.advance(&jtj, &g, progress) {
                return stop;
            }
        }
        Termination::MaxIterations
    }

    /// Tries damped steps from the current point until one is accepted (None) or a
    /// stopping test holds. Each try counts as an iteration.
    fn advance(
        &mut self,
        jtj: &DMatrix<f64>,
        g: &DVector<f64>,
        progress: &mut dyn FnMut(usize, f64),
    ) -> Option<Termination> {
        let free = free_variables(&self.x, g, self.lower, self.upper);
        let scale = self.settings.damping.scale(jtj);
        loop {
            self.iterations += 1;
            if self.iterations > self.settings.max_iterations {
                return Some(Termination::MaxIterations);
            }
            let mut step_free = free.clone();
            let Some(step) = self.step(jtj, g, &mut step_free, &scale) else {
                self.damping.reject();
                continue;
            };
            let s = self.set_trial_point(&step_free, &step);
            let step_norm = s.norm();
            let x_norm = self.x.iter().map(|v| v * v).sum::<f64>().sqrt();
            let xtol = self.settings.xtol;
            if step_norm < xtol * (xtol + x_norm) {
                return Some(Termination::Xtol);
            }
            let predicted = -(g.dot(&s) + 0.5 * s.dot(&(jtj * &s)));
            let trial_cost = self.evaluate_trial();
            let actual = self.cost - trial_cost;
            let rho = if predicted > 0.0 {
                actual / predicted
            } else {
                -1.0
            };
            if trial_cost.is_finite() && rho > 1e-4 {
                let previous = self.cost;
                self.accept(trial_cost, rho);
                progress(self.iterations, self.cost);
                if self.stagnated() {
                    return Some(Termination::Abandoned);
                }
                if actual < self.settings.ftol * previous {
                    return Some(Termination::Ftol);
                }
                return None;
            }
            self.damping.reject();
            if self.damping.lambda > 1e20 {
                return Some(Termination::Stalled);
            }
        }
    }

    /// The damped step on the free set (which shrinks while variables on a bound would
    /// leave the box: projecting such a step instead would shorten it to almost nothing
    /// in a narrow valley), with the geodesic acceleration when it is due. None when the
    /// step is refused (lambda must grow).
    fn step(
        &mut self,
        jtj: &DMatrix<f64>,
        g: &DVector<f64>,
        free: &mut Vec<usize>,
        scale: &[f64],
    ) -> Option<DVector<f64>> {
        loop {
            let (ch, rhs) = damped_system(jtj, g, free, self.damping.lambda, scale)?;
            let mut step = ch.solve(&rhs);
            if let Acceleration::Refused = self.accelerate(&ch, free, &mut step) {
                return None;
            }
            let leaving = leaving_the_box(free, &step, &self.x, self.lower, self.upper);
            if leaving.is_empty() {
                return Some(step);
            }
            free.retain(|i| !leaving.contains(i));
        }
    }

    /// Adds half the geodesic acceleration to `step` when it is due (see the module
    /// documentation for when it is skipped or refused).
    fn accelerate(
        &mut self,
        ch: &Cholesky<f64, Dyn>,
        free: &[usize],
        step: &mut DVector<f64>,
    ) -> Acceleration {
        let settings = self.settings;
        if !(settings.geodesic_alpha > 0.0
            && (self.last_rho - 1.0).abs() >= settings.geodesic_skip_band
            && self.damping.lambda >= settings.geodesic_min_lambda)
        {
            return Acceleration::None;
        }
        let mut velocity = DVector::zeros(self.x.len());
        for (a, &i) in free.iter().enumerate() {
            velocity[i] = step[a];
        }
        self.evaluations += 1;
        let Some(g_vv) = geodesic_acceleration(
            self.problem,
            &self.x,
            &self.r,
            &self.jac,
            &velocity,
            settings.geodesic_h,
            &mut self.r_h,
        ) else {
            return Acceleration::None;
        };
        let rhs = DVector::from_iterator(free.len(), free.iter().map(|&i| -g_vv[i]));
        let acc = ch.solve(&rhs);
        if 2.0 * acc.norm() > settings.geodesic_alpha * step.norm() {
            return Acceleration::Refused;
        }
        *step += 0.5 * acc;
        Acceleration::Applied
    }

    /// Sets the trial point x + step (projected into the box) and returns the actual
    /// step taken.
    fn set_trial_point(&mut self, free: &[usize], step: &DVector<f64>) -> DVector<f64> {
        self.trial_x.copy_from_slice(&self.x);
        for (a, &i) in free.iter().enumerate() {
            self.trial_x[i] += step[a];
        }
        clamp(&mut self.trial_x, self.lower, self.upper);
        DVector::from_iterator(
            self.x.len(),
            (0..self.x.len()).map(|i| self.trial_x[i] - self.x[i]),
        )
    }

    /// The cost at the trial point with its residuals and Jacobian (infinite when the
    /// point cannot be evaluated).
    fn evaluate_trial(&mut self) -> f64 {
        let evaluated =
            self.problem
                .evaluate(&self.trial_x, &mut self.trial_r, Some(&mut self.trial_jac));
        self.evaluations += 1;
        if evaluated.is_ok() {
            half_sum_sq(&self.trial_r)
        } else {
            f64::INFINITY
        }
    }

    /// Moves to the trial point.
    fn accept(&mut self, trial_cost: f64, rho: f64) {
        std::mem::swap(&mut self.x, &mut self.trial_x);
        std::mem::swap(&mut self.r, &mut self.trial_r);
        std::mem::swap(&mut self.jac, &mut self.trial_jac);
        self.last_rho = rho;
        self.cost = trial_cost;
        self.damping.accept(rho, self.settings.lambda_min_factor);
        self.history.push(trial_cost);
    }

    /// The stagnation test of a multi-start fit (see [`SolverSettings::best_elsewhere`]).
    fn stagnated(&self) -> bool {
        let settings = self.settings;
        let (w, best, cost) = (
            settings.stagnation_window,
            settings.best_elsewhere,
            self.cost,
        );
        cost > settings.abandon_ratio * best
            && w > 0
            && self.history.len() > w
            && self.history[self.history.len() - 1 - w] - cost
                < settings.stagnation_share * (cost - best)
    }

    fn finish(self, termination: Termination) -> Solution {
        Solution {
            initial_cost: self.initial_cost,
            x: self.x,
            cost: self.cost,
            residuals: self.r,
            jacobian: self.jac,
            iterations: self.iterations.min(self.settings.max_iterations),
            evaluations: self.evaluations,
            termination,
        }
    }
}

/// Minimizes 0.5 |r(x)|^2 over the box from `x0` (projected into it first).
///
/// `progress(iteration, cost)` is called after each accepted step. Fails if the start
/// cannot be evaluated or the bounds are inconsistent.
pub fn solve(
    problem: &dyn Problem,
    x0: &[f64],
    lower: &[f64],
    upper: &[f64],
    settings: &SolverSettings,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<Solution, String> {
    check_box(problem.param_count(), x0, lower, upper)?;
    let mut run = Run::start(problem, x0, lower, upper, settings)?;
    let termination = run.iterate(progress);
    Ok(run.finish(termination))
}

/// J^T r_vv, where r_vv = (2 / h) ((r(x + h v) - r(x)) / h - J v) is the second
/// directional derivative of the residuals along the velocity v (zero off the free set):
/// minus the right-hand side of the geodesic acceleration's system. x + h v is not projected onto
/// the box (the derivative is the model's, not the box's); None when it cannot be
/// evaluated (the plain step is then taken).
fn geodesic_acceleration(
    problem: &dyn Problem,
    x: &[f64],
    r: &[f64],
    jac: &DMatrix<f64>,
    velocity: &DVector<f64>,
    h: f64,
    r_h: &mut [f64],
) -> Option<DVector<f64>> {
    let x_h: Vec<f64> = x
        .iter()
        .zip(velocity.iter())
        .map(|(x, v)| x + h * v)
        .collect();
    problem.evaluate(&x_h, r_h, None).ok()?;
    let jv = jac * velocity;
    let scale = 2.0 / (h * h);
    let dev: Vec<f64> = r_h
        .iter()
        .zip(r)
        .zip(jv.iter())
        .map(|((rh, r0), jv)| scale * (rh - r0 - h * jv))
        .collect();
    Some(tr_mul_vec(jac, &dev))
}
