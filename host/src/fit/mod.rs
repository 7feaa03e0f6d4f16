//! Identification of the model's parameters from a measured transmissibility (the paper's
//! section 2.2.3): bounded nonlinear least squares in log-parameters from several starts.
//!
//! - Rigid case: the 42 joint and contact parameters; bounds stiffness [1, 1e6] and damping
//!   [0.001, 1e6] (docs/model.md).
//! - Litter-board case: joints fixed to the rigid fit; the 18 contact parameters bounded by
//!   [0, rigid-case value]. The lower bound 0 has no logarithm: it becomes
//!   [`LITTER_FLOOR`] (1e-3 N/m or N s/m, under a millionth of any contact's effect).
//! - Starts (deterministic for a seed): rigid: the paper's all-ones start, the paper's
//!   Table 3-4 values (twice: with Levenberg's and with Marquardt's damping, which end in
//!   different minima of this sloppy problem), then random starts at the paper's values
//!   times e^(N(0, 1)), their damping alternating; litter: the rigid fit's contacts (the
//!   paper's start), the paper's litter-board contacts (clamped to the bounds, both
//!   dampings), then the rigid fit's contacts times e^(-|N(0, 2)|).
//! - Rounds: the anchors (the paper's values) run first, to the end; every other start
//!   then runs knowing the anchors' best cost, and is abandoned when it stagnates far above
//!   it ([`SolverSettings::best_elsewhere`]). Each round spreads its starts over
//!   `threads` threads; a start's path never depends on another's timing.
//! - Polish: the best start's minimum is refined with Marquardt's damping and tolerances
//!   10^4 times tighter ([`polish_settings`]): along the weakly determined directions the
//!   cost keeps falling slowly long after a step's relative reduction is below ftol.
//! - Determinism: a fixed order of rounds, ChaCha8 from the seed: the same seed gives
//!   bit-identical parameters and cost, whatever the number of threads. Another seed
//!   changes only the random starts (the fourth on).

pub mod band;
pub mod objective;
pub mod report;
pub mod solver;
pub mod uncertainty;
pub mod workflow;

use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{Result, anyhow, bail};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use supine_core::model::{ModelParams, ParamId, Preset, Subject};

use crate::dataset::Case;
use objective::{COMPONENTS, Objective, Target};
use solver::{DampingScale, Problem, Solution, SolverSettings, Termination};

/// Rigid-case stiffness bounds, N/m or N m/rad.
pub const STIFFNESS_BOUNDS: (f64, f64) = (1.0, 1e6);
/// Rigid-case damping bounds, N s/m or N m s/rad.
pub const DAMPING_BOUNDS: (f64, f64) = (1e-3, 1e6);
/// The litter-board case's lower bound in place of 0 (log space cannot hold 0).
pub const LITTER_FLOOR: f64 = 1e-3;
/// A parameter whose Jacobian column is below this fraction of the largest has no effect.
pub const NO_EFFECT_RATIO: f64 = 1e-9;
/// Singular values below this fraction of the largest span the weakly determined directions.
pub const WEAK_SINGULAR_RATIO: f64 = 1e-3;
/// A parameter is weakly determined when more than this share of it lies in those directions.
pub const WEAK_LOADING: f64 = 0.5;

impl Problem for Objective {
    fn residual_count(&self) -> usize {
        Objective::residual_count(self)
    }
    fn param_count(&self) -> usize {
        Objective::param_count(self)
    }
    fn evaluate(
        &self,
        x: &[f64],
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        Objective::evaluate(self, x, residuals, jacobian)
    }
    fn gram(&self, jacobian: &DMatrix<f64>) -> DMatrix<f64> {
        Objective::gram(self, jacobian)
    }
}

/// How to fit: plain data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitSettings {
    /// Number of starts (at least 1; the first ones are the deterministic ones).
    pub starts: usize,
    /// Seed of the random starts.
    pub seed: u64,
    /// Solver tolerances.
    pub solver: SolverSettings,
    /// Threads the starts of a round are spread over (0: one per core).
    pub threads: usize,
    /// Refine the best start's minimum ([`polish_settings`]).
    pub polish: bool,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            starts: 6,
            seed: 1,
            solver: SolverSettings::default(),
            threads: 0,
            polish: true,
        }
    }
}

impl FitSettings {
    /// The number of threads: `threads`, or one per core when 0.
    pub fn thread_count(&self) -> usize {
        if self.threads > 0 {
            return self.threads;
        }
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
}

/// One starting point of the solver.
#[derive(Clone, Debug, PartialEq)]
pub struct Start {
    /// Its name in the report.
    pub label: String,
    /// ln p.
    pub theta: Vec<f64>,
    /// The damping the solver uses from it.
    pub damping: DampingScale,
    /// Runs in the first round, to the end; the others run after it, against its cost.
    pub anchor: bool,
}

impl Start {
    /// A start that runs in the second round.
    pub fn new(label: impl Into<String>, theta: Vec<f64>, damping: DampingScale) -> Self {
        Self {
            label: label.into(),
            theta,
            damping,
            anchor: false,
        }
    }

    /// The same start, run in the first round.
    pub fn anchor(mut self) -> Self {
        self.anchor = true;
        self
    }
}

/// The damping of the k-th random start: alternating, Levenberg's first.
fn random_damping(k: usize) -> DampingScale {
    if k % 2 == 1 {
        DampingScale::Levenberg
    } else {
        DampingScale::Marquardt
    }
}

/// How much tighter the polish's ftol, xtol and gtol are than the fit's.
pub const POLISH_TIGHTENING: f64 = 1e-4;

/// The polish's settings: Marquardt's damping, tolerances [`POLISH_TIGHTENING`] times the
/// fit's, no geodesic acceleration (cheaper steps; the path no longer matters).
pub fn polish_settings(solver: &SolverSettings) -> SolverSettings {
    SolverSettings {
        ftol: solver.ftol * POLISH_TIGHTENING,
        xtol: solver.xtol * POLISH_TIGHTENING,
        gtol: solver.gtol * POLISH_TIGHTENING,
        damping: DampingScale::Marquardt,
        geodesic_alpha: 0.0,
        best_elsewhere: f64::INFINITY,
        ..*solver
    }
}

/// Clamps every start into the box.
fn clamp_starts(starts: &mut [Start], lower: &[f64], upper: &[f64]) {
    for start in starts {
        for ((t, lo), hi) in start.theta.iter_mut().zip(lower).zip(upper) {
            *t = t.clamp(*lo, *hi);
        }
    }
}

/// A fit's problem: the objective, the box (log space), and the starts (log space).
#[derive(Clone, Debug)]
pub struct Setup {
    /// Which case.
    pub case: Case,
    /// Residuals and Jacobian.
    pub objective: Objective,
    /// Lower bounds of ln p.
    pub lower: Vec<f64>,
    /// Upper bounds of ln p.
    pub upper: Vec<f64>,
    /// The starting points.
    pub starts: Vec<Start>,
}

fn normal(sd: f64) -> Result<Normal<f64>> {
    Normal::new(0.0, sd).map_err(|e| anyhow!("{e}"))
}

/// The rigid-case problem for a subject of `subject`'s anthropometry.
pub fn rigid_setup(target: Target, subject: Subject, settings: &FitSettings) -> Result<Setup> {
    let mut base = ModelParams::preset(Preset::PaperRigid);
    base.subject = subject;
    let free: Vec<ParamId> = ParamId::ALL.to_vec();
    let bounds = |id: &ParamId| {
        if id.is_stiffness() {
            STIFFNESS_BOUNDS
        } else {
            DAMPING_BOUNDS
        }
    };
    let lower: Vec<f64> = free.iter().map(|id| bounds(id).0.ln()).collect();
    let upper: Vec<f64> = free.iter().map(|id| bounds(id).1.ln()).collect();
    let paper: Vec<f64> = free.iter().map(|&id| base.get(id).ln()).collect();
    let mut starts = vec![
        Start::new(
            "all ones (paper)",
            vec![0.0; free.len()],
            DampingScale::Levenberg,
        ),
        Start::new("paper Tables 3-4", paper.clone(), DampingScale::Levenberg).anchor(),
        Start::new(
            "paper Tables 3-4, Marquardt",
            paper.clone(),
            DampingScale::Marquardt,
        )
        .anchor(),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let spread = normal(1.0)?;
    for k in 1..=settings.starts.max(1).saturating_sub(starts.len()) {
        let theta = paper.iter().map(|t| t + spread.sample(&mut rng)).collect();
        starts.push(Start::new(format!("random {k}"), theta, random_damping(k)));
    }
    starts.truncate(settings.starts.max(1));
    clamp_starts(&mut starts, &lower, &upper);
    Ok(Setup {
        case: Case::Rigid,
        objective: Objective::new(base, free, target),
        lower,
        upper,
        starts,
    })
}

/// The litter-board problem: joints (and the contacts' upper bounds) from `rigid`.
pub fn litter_setup(
    target: Target,
    subject: Subject,
    rigid: &ModelParams,
    settings: &FitSettings,
) -> Result<Setup> {
    let mut base = *rigid;
    base.subject = subject;
    let free: Vec<ParamId> = ParamId::ALL
        .into_iter()
        .filter(|id| id.is_contact())
        .collect();
    let upper: Vec<f64> = free.iter().map(|&id| rigid.get(id).ln()).collect();
    let lower: Vec<f64> = free
        .iter()
        .map(|&id| LITTER_FLOOR.min(rigid.get(id)).ln())
        .collect();
    let paper = ModelParams::preset(Preset::PaperLitter);
    let paper_theta: Vec<f64> = free.iter().map(|&id| paper.get(id).ln()).collect();
    let mut starts = vec![
        Start::new(
            "rigid-case contacts (paper)",
            upper.clone(),
            DampingScale::Levenberg,
        )
        .anchor(),
        Start::new(
            "paper Table 4 litter-board",
            paper_theta.clone(),
            DampingScale::Levenberg,
        )
        .anchor(),
        Start::new(
            "paper Table 4 litter-board, Marquardt",
            paper_theta,
            DampingScale::Marquardt,
        ),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let spread = normal(2.0)?;
    for k in 1..=settings.starts.max(1).saturating_sub(starts.len()) {
        let theta = upper
            .iter()
            .map(|t| t - spread.sample(&mut rng).abs())
            .collect();
        starts.push(Start::new(format!("random {k}"), theta, random_damping(k)));
    }
    starts.truncate(settings.starts.max(1));
    clamp_starts(&mut starts, &lower, &upper);
    Ok(Setup {
        case: Case::Litter,
        objective: Objective::new(base, free, target),
        lower,
        upper,
        starts,
    })
}

/// One start's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct StartOutcome {
    /// Which start.
    pub label: String,
    /// Cost at the start.
    pub initial_cost: f64,
    /// Cost at the end.
    pub final_cost: f64,
    /// Iterations.
    pub iterations: usize,
    /// Residual evaluations.
    pub evaluations: usize,
    /// Why it stopped.
    pub termination: Termination,
    /// Wall time of this start's solve, s.
    pub seconds: f64,
}

/// The fit's result: the best start's solution and a summary of every start.
#[derive(Clone, Debug)]
pub struct FitResult {
    /// The full fitted parameter set.
    pub params: ModelParams,
    /// The best solution (log-parameters, residuals, Jacobian), polished if asked.
    pub solution: Solution,
    /// Every start.
    pub starts: Vec<StartOutcome>,
    /// Index of the best start.
    pub best: usize,
    /// The polish of the best start's minimum, if any.
    pub polish: Option<StartOutcome>,
}

/// `progress(start, iteration, cost)`: called after every accepted step, from the thread
/// that runs the start.
pub type Progress<'a> = &'a (dyn Fn(usize, usize, f64) + Sync);

/// Runs `work(0..jobs)` on up to `threads` scoped threads; the results in job order.
fn in_parallel<T: Send>(jobs: usize, threads: usize, work: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let next = AtomicUsize::new(0);
    let worker = || {
        let mut done = Vec::new();
        loop {
            let job = next.fetch_add(1, Ordering::Relaxed);
            if job >= jobs {
                return done;
            }
            done.push((job, work(job)));
        }
    };
    let mut slots: Vec<Option<T>> = (0..jobs).map(|_| None).collect();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (1..threads.clamp(1, jobs.max(1)))
            .map(|_| scope.spawn(worker))
            .collect();
        // This thread works too.
        let mut finished = vec![worker()];
        for handle in handles {
            match handle.join() {
                Ok(done) => finished.push(done),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        for (job, value) in finished.into_iter().flatten() {
            slots[job] = Some(value);
        }
    });
    slots.into_iter().flatten().collect()
}

/// Solves from one start with its damping; `best_elsewhere` lets it be abandoned.
fn solve_from(
    setup: &Setup,
    index: usize,
    solver_settings: &SolverSettings,
    progress: Progress,
) -> Result<(StartOutcome, Solution)> {
    let start = &setup.starts[index];
    let initial_cost = setup
        .objective
        .cost(&start.theta)
        .map_err(|e| anyhow!("{e}"))?;
    let started = std::time::Instant::now();
    let solution = solver::solve(
        &setup.objective,
        &start.theta,
        &setup.lower,
        &setup.upper,
        solver_settings,
        &mut |iteration, cost| progress(index, iteration, cost),
    )
    .map_err(|e| anyhow!("start {}: {e}", start.label))?;
    let outcome = StartOutcome {
        label: start.label.clone(),
        initial_cost,
        final_cost: solution.cost,
        iterations: solution.iterations,
        evaluations: solution.evaluations,
        termination: solution.termination,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok((outcome, solution))
}

/// Solves from the starts `indices` in parallel, each abandoned when it stagnates far
/// above `best_elsewhere`.
fn solve_round(
    setup: &Setup,
    settings: &FitSettings,
    indices: &[usize],
    best_elsewhere: f64,
    progress: Progress,
) -> Result<Vec<(usize, StartOutcome, Solution)>> {
    let results = in_parallel(indices.len(), settings.thread_count(), |job| {
        let index = indices[job];
        let solver_settings = SolverSettings {
            damping: setup.starts[index].damping,
            best_elsewhere: settings.solver.best_elsewhere.min(best_elsewhere),
            ..settings.solver
        };
        solve_from(setup, index, &solver_settings, progress)
            .map(|(outcome, solution)| (index, outcome, solution))
    });
    results.into_iter().collect()
}

/// Refines `solution` with [`polish_settings`]; the polish's outcome and the better of
/// the two solutions.
fn polish(
    setup: &Setup,
    settings: &FitSettings,
    label: &str,
    solution: Solution,
) -> Result<(StartOutcome, Solution)> {
    let started = std::time::Instant::now();
    let polished = solver::solve(
        &setup.objective,
        &solution.x,
        &setup.lower,
        &setup.upper,
        &polish_settings(&settings.solver),
        &mut |_, _| {},
    )
    .map_err(|e| anyhow!("polish: {e}"))?;
    let outcome = StartOutcome {
        label: format!("polish of {label}"),
        initial_cost: solution.cost,
        final_cost: polished.cost,
        iterations: polished.iterations,
        evaluations: polished.evaluations,
        termination: polished.termination,
        seconds: started.elapsed().as_secs_f64(),
    };
    // The solver only accepts steps that lower the cost; the check keeps that explicit.
    let best = if polished.cost <= solution.cost {
        polished
    } else {
        solution
    };
    Ok((outcome, best))
}

/// Runs the solver from every start in two rounds (the anchors, then the others against
/// the anchors' best cost), keeps the lowest cost (the first start on a tie) and polishes
/// it (see the module documentation).
pub fn run(setup: &Setup, settings: &FitSettings, progress: Progress) -> Result<FitResult> {
    let (anchors, others): (Vec<usize>, Vec<usize>) =
        (0..setup.starts.len()).partition(|&i| setup.starts[i].anchor);
    let mut solved = solve_round(setup, settings, &anchors, f64::INFINITY, progress)?;
    let best_anchor = solved
        .iter()
        .map(|(_, _, s)| s.cost)
        .fold(f64::INFINITY, f64::min);
    solved.extend(solve_round(
        setup,
        settings,
        &others,
        best_anchor,
        progress,
    )?);
    solved.sort_by_key(|(index, _, _)| *index);
    let mut best: Option<(usize, Solution)> = None;
    let mut starts = Vec::with_capacity(solved.len());
    for (index, outcome, solution) in solved {
        starts.push(outcome);
        if best.as_ref().is_none_or(|(_, b)| solution.cost < b.cost) {
            best = Some((index, solution));
        }
    }
    let Some((best, mut solution)) = best else {
        bail!("no start to fit from");
    };
    let mut polished = None;
    if settings.polish {
        let (outcome, better) = polish(setup, settings, &setup.starts[best].label, solution)?;
        polished = Some(outcome);
        solution = better;
    }
    Ok(FitResult {
        params: setup.objective.params(&solution.x),
        solution,
        starts,
        best,
        polish: polished,
    })
}

/// What the data says about one parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Determination {
    /// The parameter has no effect on the fitted components at all.
    NoEffect,
    /// It lies mostly in directions the data barely constrains.
    Weak,
    /// The data determines it.
    Determined,
}

impl Determination {
    /// `none`, `weak` or `determined`.
    pub const fn name(self) -> &'static str {
        match self {
            Determination::NoEffect => "none",
            Determination::Weak => "weak",
            Determination::Determined => "determined",
        }
    }
}

/// Which bound a parameter ended on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtBound {
    /// On its lower bound.
    Lower,
    /// On its upper bound.
    Upper,
}

/// One free parameter's summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSummary {
    /// Which parameter.
    pub id: ParamId,
    /// Fitted value (in `id.unit()`).
    pub value: f64,
    /// Whether it ended on a bound (within 1e-6 in ln p).
    pub at_bound: Option<AtBound>,
    /// Jacobian column norm over the largest (sensitivity of the residuals to ln p).
    pub sensitivity: f64,
    /// Share of the parameter in the weakly determined directions, 0..=1.
    pub weak_loading: f64,
    /// The verdict.
    pub determination: Determination,
    /// Standard error of ln p ([`uncertainty`]); determined parameters only.
    pub standard_error: Option<f64>,
}

impl ParamSummary {
    /// The 95 % interval of the value, for a determined parameter.
    pub fn interval_95(&self) -> Option<(f64, f64)> {
        self.standard_error
            .map(|se| uncertainty::interval_95(self.value, se))
    }
}

/// Identifiability from the Jacobian at the solution (in ln p).
#[derive(Clone, Debug, PartialEq)]
pub struct Identifiability {
    /// Singular values of J, largest first.
    pub singular_values: Vec<f64>,
    /// Per free parameter, in the fit's order.
    pub params: Vec<ParamSummary>,
    /// The linearized covariance of ln p (None with no more residuals than unknowns).
    pub covariance: Option<uncertainty::Covariance>,
}

/// Classifies every free parameter: no effect (zero Jacobian column), weak (mostly in the
/// span of right singular vectors with singular value below 1e-3 of the largest), or
/// determined; and flags those on a bound.
pub fn identifiability(setup: &Setup, result: &FitResult) -> Identifiability {
    let jac = &result.solution.jacobian;
    let n = jac.ncols();
    let norms: Vec<f64> = (0..n).map(|j| jac.column(j).norm()).collect();
    let max_norm = norms
        .iter()
        .copied()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let svd = jac.clone().svd(false, true);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let singular_values: Vec<f64> = order.iter().map(|&k| svd.singular_values[k]).collect();
    let s_max = singular_values.first().copied().unwrap_or(0.0);
    let v_t = svd.v_t.unwrap_or_else(|| DMatrix::zeros(0, n));
    let covariance = uncertainty::Covariance::at_minimum(jac, result.solution.cost);
    let standard_errors = covariance.as_ref().map(|c| c.standard_errors());
    let params = (0..n)
        .map(|j| {
            let id = setup.objective.free[j];
            let theta = result.solution.x[j];
            let at_bound = if theta <= setup.lower[j] + 1e-6 {
                Some(AtBound::Lower)
            } else if theta >= setup.upper[j] - 1e-6 {
                Some(AtBound::Upper)
            } else {
                None
            };
            let weak_loading: f64 = (0..v_t.nrows())
                .filter(|&k| svd.singular_values[k] < WEAK_SINGULAR_RATIO * s_max)
                .map(|k| v_t[(k, j)].powi(2))
                .sum();
            let sensitivity = norms[j] / max_norm;
            let determination = if sensitivity < NO_EFFECT_RATIO {
                Determination::NoEffect
            } else if weak_loading > WEAK_LOADING {
                Determination::Weak
            } else {
                Determination::Determined
            };
            let standard_error = match (&standard_errors, determination) {
                (Some(se), Determination::Determined) => Some(se[j]),
                _ => None,
            };
            ParamSummary {
                id,
                value: theta.exp(),
                at_bound,
                sensitivity,
                weak_loading,
                determination,
                standard_error,
            }
        })
        .collect();
    Identifiability {
        covariance,
        singular_values,
        params,
    }
}

/// Per fitted component: rms relative magnitude error and rms phase error (degrees).
pub fn component_errors(residuals: &[f64], frequencies: usize) -> [(f64, f64); COMPONENTS] {
    core::array::from_fn(|c| {
        let (mut mag, mut phase) = (0.0, 0.0);
        for f in 0..frequencies {
            let r = Objective::residual_index(f, c);
            mag += residuals[r].powi(2);
            phase += (residuals[r + 1] * 180.0).powi(2);
        }
        let n = frequencies.max(1) as f64;
        ((mag / n).sqrt(), (phase / n).sqrt())
    })
}
