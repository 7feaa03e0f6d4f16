//! Running the solver on every part of a [`Setup`] from every start, spread over threads
//! (each part's anchors, then its other starts against its best anchor cost), each part's
//! lowest minimum kept and polished, the parts joined. See the `fit` module for why.

use anyhow::{Result, anyhow, bail};
use nalgebra::DMatrix;
use supine_core::model::ModelParams;

use super::part::PartProblem;
use crate::parallel::on_pool;

use super::solver::{self, DampingScale, Solution, SolverSettings, Termination};
use super::{FitSettings, Setup};

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

/// One part's (`FitSubsystem`) runs: every start's and the polish's.
#[derive(Clone, Debug)]
pub struct PartOutcome {
    /// The part's name (the model's subsystem).
    pub name: String,
    /// Its number of free parameters.
    pub params: usize,
    /// Its free parameters: indices into the fit's unknowns.
    pub free: Vec<usize>,
    /// Every start on this part, in the starts' order.
    pub starts: Vec<StartOutcome>,
    /// Every start's minimum of this part (ln p of `free`), in the starts' order: the
    /// other minima the litter-board fit may explore ([`super::minima`]).
    pub minima: Vec<Vec<f64>>,
    /// Index of the start whose minimum of this part was kept.
    pub best: usize,
    /// The polish of that minimum, if any.
    pub polish: Option<StartOutcome>,
}

/// The fit's result: the combined solution (each part's best minimum, polished if asked)
/// and a summary of every start and every part.
#[derive(Clone, Debug)]
pub struct FitResult {
    /// The full fitted parameter set.
    pub params: ModelParams,
    /// The combined solution (log-parameters, residuals, Jacobian of the whole problem).
    /// Its iterations and evaluations add up every part's kept run and polish; its
    /// termination is that of the part with the highest final cost.
    pub solution: Solution,
    /// Every start over all parts: costs of the whole problem (the final cost is the sum
    /// of its parts' minima), iterations, evaluations and seconds added up over the parts,
    /// and the termination of the part it iterated longest on.
    pub starts: Vec<StartOutcome>,
    /// Index of the start with the lowest final cost over all parts.
    pub best: usize,
    /// The polish over all parts (costs of the whole problem), if any.
    pub polish: Option<StartOutcome>,
    /// Per part: its starts, which one was kept, and its polish.
    pub parts: Vec<PartOutcome>,
}

/// `progress(start, iteration, cost)`: called after every accepted step, from the thread
/// that runs the start.
pub type Progress<'a> = &'a (dyn Fn(usize, usize, f64) + Sync);

/// Solves part `part` from start `index` with `solver_settings`.
fn solve_from(
    setup: &Setup,
    problem: &PartProblem,
    index: usize,
    solver_settings: &SolverSettings,
    progress: Progress,
) -> Result<(StartOutcome, Solution)> {
    let start = &setup.starts[index];
    let x0 = problem.restrict(&start.theta);
    let started = std::time::Instant::now();
    let solution = solver::solve(
        problem,
        &x0,
        &problem.restrict(&setup.lower),
        &problem.restrict(&setup.upper),
        solver_settings,
        &mut |iteration, cost| progress(index, iteration, cost),
    )
    .map_err(|e| anyhow!("start {}: {e}", start.label))?;
    let initial_cost = solution.initial_cost;
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

/// A run's outcome and solution, or why it failed.
type RunResult = Result<(StartOutcome, Solution)>;

/// The error of a finished run, taken out; a success stays where it is.
fn take_error(run: &mut Option<RunResult>) -> Option<anyhow::Error> {
    match run.take() {
        Some(Err(e)) => Some(e),
        other => {
            *run = other;
            None
        }
    }
}

/// One part's runs as they finish.
struct PartRuns {
    /// Per start (in the starts' order): its run, once finished.
    runs: Vec<Option<RunResult>>,
    /// Whether the other starts were released.
    others_released: bool,
    /// Whether the polish was released.
    polish_released: bool,
    /// The polish of the part's kept minimum, once finished.
    polished: Option<RunResult>,
}

impl PartRuns {
    /// The start whose minimum the part keeps: the lowest cost, the first start on a tie.
    /// None unless every run has finished without error.
    fn kept(&self) -> Option<(usize, &Solution)> {
        let mut kept: Option<(usize, &Solution)> = None;
        for (index, run) in self.runs.iter().enumerate() {
            let (_, solution) = run.as_ref()?.as_ref().ok()?;
            if kept.is_none_or(|(_, b)| solution.cost < b.cost) {
                kept = Some((index, solution));
            }
        }
        kept
    }
}

/// Every part's runs, scheduled by what each needs rather than in rounds: a part's other
/// starts are released as soon as its own anchors have finished (they run against the
/// anchors' best cost, [`SolverSettings::best_elsewhere`]), and its polish as soon as all
/// its starts have, so no thread waits for another part. Every run's inputs are fixed
/// before it is released, so the results never depend on the threads' timing. A failed
/// run releases nothing that needs it; the others still run, so which runs fail does not
/// depend on the timing either.
struct Schedule<'a> {
    setup: &'a Setup,
    settings: &'a FitSettings,
    problems: &'a [PartProblem<'a>],
    progress: Progress<'a>,
    parts: std::sync::Mutex<Vec<PartRuns>>,
}

impl<'a> Schedule<'a> {
    fn new(
        setup: &'a Setup,
        settings: &'a FitSettings,
        problems: &'a [PartProblem<'a>],
        progress: Progress<'a>,
    ) -> Self {
        let parts = problems
            .iter()
            .map(|_| PartRuns {
                runs: (0..setup.starts.len()).map(|_| None).collect(),
                others_released: false,
                polish_released: false,
                polished: None,
            })
            .collect();
        Self {
            setup,
            settings,
            problems,
            progress,
            parts: std::sync::Mutex::new(parts),
        }
    }

    /// Runs every part's anchors, and what they release, on the pool; each part's runs.
    fn run(self) -> Vec<PartRuns> {
        on_pool(self.settings.threads, || {
            rayon::scope(|scope| {
                for k in 0..self.problems.len() {
                    let anchors =
                        (0..self.setup.starts.len()).filter(|&i| self.setup.starts[i].anchor);
                    for index in anchors {
                        self.start(scope, k, index, f64::INFINITY);
                    }
                    // A setup without anchors releases its other starts at once.
                    self.release(scope, k, &mut self.lock()[k]);
                }
            })
        });
        self.parts
            .into_inner()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<PartRuns>> {
        self.parts
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Solves part `k` from start `index` on the pool, abandoned when it stagnates far
    /// above `best_elsewhere`; then releases what its end allows.
    fn start<'s>(&'s self, scope: &rayon::Scope<'s>, k: usize, index: usize, best_elsewhere: f64) {
        scope.spawn(move |scope| {
            let solver_settings = SolverSettings {
                damping: self.setup.starts[index].damping,
                best_elsewhere: self.settings.solver.best_elsewhere.min(best_elsewhere),
                ..self.settings.solver
            };
            let run = solve_from(
                self.setup,
                &self.problems[k],
                index,
                &solver_settings,
                self.progress,
            );
            let mut parts = self.lock();
            let part = &mut parts[k];
            part.runs[index] = Some(run);
            self.release(scope, k, part);
        });
    }

    /// Releases part `k`'s other starts once its anchors have all finished well (against
    /// their lowest cost), and its polish once every start has; each once.
    fn release<'s>(&'s self, scope: &rayon::Scope<'s>, k: usize, part: &mut PartRuns) {
        let is_anchor = |i: &usize| self.setup.starts[*i].anchor;
        let anchor_costs: Option<Vec<f64>> = (0..part.runs.len())
            .filter(is_anchor)
            .map(|i| match &part.runs[i] {
                Some(Ok((_, solution))) => Some(solution.cost),
                _ => None,
            })
            .collect();
        if let (false, Some(costs)) = (part.others_released, anchor_costs) {
            part.others_released = true;
            let best_anchor = costs.into_iter().fold(f64::INFINITY, f64::min);
            for index in (0..part.runs.len()).filter(|i| !is_anchor(i)) {
                self.start(scope, k, index, best_anchor);
            }
        }
        // `kept` is Some once every start has finished well.
        if !part.polish_released && self.settings.polish {
            if let Some((index, solution)) = part.kept().map(|(i, s)| (i, s.clone())) {
                part.polish_released = true;
                let label = &self.setup.starts[index].label;
                scope.spawn(move |_| {
                    let polished = polish(
                        self.setup,
                        self.settings,
                        &self.problems[k],
                        label,
                        solution,
                    );
                    self.lock()[k].polished = Some(polished);
                });
            }
        }
    }
}

/// Refines a part's `solution` with [`polish_settings`]; the polish's outcome and the
/// better of the two solutions.
fn polish(
    setup: &Setup,
    settings: &FitSettings,
    problem: &PartProblem,
    label: &str,
    solution: Solution,
) -> Result<(StartOutcome, Solution)> {
    let started = std::time::Instant::now();
    let polished = solver::solve(
        problem,
        &solution.x,
        &problem.restrict(&setup.lower),
        &problem.restrict(&setup.upper),
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

/// The outcomes of several parts' runs as one: costs and counts added up, the
/// termination of the longest run.
fn combined(label: &str, initial_cost: f64, offset: f64, runs: &[&StartOutcome]) -> StartOutcome {
    let longest = runs.iter().max_by_key(|o| o.iterations);
    StartOutcome {
        label: label.to_string(),
        initial_cost,
        final_cost: offset + runs.iter().map(|o| o.final_cost).sum::<f64>(),
        iterations: runs.iter().map(|o| o.iterations).sum(),
        evaluations: runs.iter().map(|o| o.evaluations).sum(),
        termination: longest.map_or(Termination::Ftol, |o| o.termination),
        seconds: runs.iter().map(|o| o.seconds).sum(),
    }
}

/// Runs the solver on every part from every start (the anchors first, then the others
/// against the anchors' best cost of that part, `Schedule`), keeps each part's lowest
/// cost (the first start on a tie), polishes it, and joins the parts (see the module
/// documentation of `fit`).
pub fn run(setup: &Setup, settings: &FitSettings, progress: Progress) -> Result<FitResult> {
    if setup.starts.is_empty() {
        bail!("no start to fit from");
    }
    let objective = &setup.objective;
    let parts = objective.subsystems();
    // The parameters of no part (no effect) keep the first anchor's values.
    let reference = setup
        .starts
        .iter()
        .find(|s| s.anchor)
        .unwrap_or(&setup.starts[0])
        .theta
        .clone();
    let problems: Vec<PartProblem> = parts
        .iter()
        .map(|part| PartProblem::new(objective, part, &reference))
        .collect();
    // Residuals no part moves (none for the model's free sets) add a constant cost.
    let mut r = vec![0.0; objective.residual_count()];
    objective
        .evaluate(&reference, &mut r, None)
        .map_err(|e| anyhow!("{e}"))?;
    let mut covered = vec![false; r.len()];
    for part in &parts {
        for &row in &part.rows {
            covered[row] = true;
        }
    }
    let offset = 0.5
        * r.iter()
            .zip(&covered)
            .filter(|(_, c)| !**c)
            .map(|(v, _)| v * v)
            .sum::<f64>();

    let mut runs = Schedule::new(setup, settings, &problems, progress).run();
    // The first error as the rounds would meet them: the anchors', the other starts', the
    // polishes', each in the parts' and the starts' order.
    let is_anchor = |&i: &usize| setup.starts[i].anchor;
    let (anchors, others): (Vec<usize>, Vec<usize>) = (0..setup.starts.len()).partition(is_anchor);
    for starts in [&anchors, &others] {
        for part in &mut runs {
            for &index in starts {
                if let Some(e) = take_error(&mut part.runs[index]) {
                    return Err(e);
                }
            }
        }
    }
    for part in &mut runs {
        if let Some(e) = take_error(&mut part.polished) {
            return Err(e);
        }
    }

    // Per part: every start's outcome and the lowest minimum (the first start on a tie).
    let mut outcomes: Vec<Vec<StartOutcome>> = vec![Vec::new(); parts.len()];
    let mut minima: Vec<Vec<Vec<f64>>> = vec![Vec::new(); parts.len()];
    let mut kept: Vec<(usize, Solution)> = Vec::with_capacity(parts.len());
    let mut polished: Vec<Option<(StartOutcome, Solution)>> = Vec::with_capacity(parts.len());
    for (k, part) in runs.iter_mut().enumerate() {
        let (index, solution) = part
            .kept()
            .map(|(index, solution)| (index, solution.clone()))
            .ok_or_else(|| anyhow!("part {}: a start did not finish", parts[k].name))?;
        kept.push((index, solution));
        polished.push(part.polished.take().and_then(Result::ok));
        for run in &mut part.runs {
            if let Some(Ok((outcome, solution))) = run.take() {
                outcomes[k].push(outcome);
                minima[k].push(solution.x);
            }
        }
    }

    // Join the parts.
    let mut x = reference;
    let mut part_outcomes = Vec::with_capacity(parts.len());
    let (mut iterations, mut evaluations) = (0, 0);
    let mut worst: Option<(f64, Termination)> = None;
    for (k, part) in parts.iter().enumerate() {
        let (index, run) = &kept[k];
        let (polish, solution) = match &polished[k] {
            Some((outcome, better)) => (Some(outcome.clone()), better),
            None => (None, run),
        };
        problems[k].scatter(&solution.x, &mut x);
        iterations += run.iterations + polish.as_ref().map_or(0, |p| p.iterations);
        evaluations += run.evaluations + polish.as_ref().map_or(0, |p| p.evaluations);
        let termination = polish.as_ref().map_or(run.termination, |p| p.termination);
        if worst.is_none_or(|(cost, _)| solution.cost > cost) {
            worst = Some((solution.cost, termination));
        }
        part_outcomes.push(PartOutcome {
            name: part.name.clone(),
            params: part.params.len(),
            free: part.params.clone(),
            starts: std::mem::take(&mut outcomes[k]),
            minima: std::mem::take(&mut minima[k]),
            best: *index,
            polish,
        });
    }
    let mut residuals = vec![0.0; objective.residual_count()];
    let mut jacobian = DMatrix::zeros(residuals.len(), objective.param_count());
    objective
        .evaluate(&x, &mut residuals, Some(&mut jacobian))
        .map_err(|e| anyhow!("{e}"))?;
    let cost = 0.5 * residuals.iter().map(|v| v * v).sum::<f64>();

    let mut starts = Vec::with_capacity(setup.starts.len());
    for (index, start) in setup.starts.iter().enumerate() {
        let initial_cost = objective.cost(&start.theta).map_err(|e| anyhow!("{e}"))?;
        let runs: Vec<&StartOutcome> = part_outcomes.iter().map(|p| &p.starts[index]).collect();
        starts.push(combined(&start.label, initial_cost, offset, &runs));
    }
    let best = (0..starts.len())
        .min_by(|&a, &b| starts[a].final_cost.total_cmp(&starts[b].final_cost))
        .unwrap_or(0);
    let polish = settings.polish.then(|| {
        let initial = offset + kept.iter().map(|(_, s)| s.cost).sum::<f64>();
        let runs: Vec<&StartOutcome> = part_outcomes
            .iter()
            .filter_map(|p| p.polish.as_ref())
            .collect();
        combined("polish of each part's best", initial, offset, &runs)
    });
    Ok(FitResult {
        params: objective.params(&x),
        solution: Solution {
            initial_cost: starts[best].initial_cost,
            x,
            cost,
            residuals,
            jacobian,
            iterations,
            evaluations,
            termination: worst.map_or(Termination::Ftol, |(_, t)| t),
        },
        starts,
        best,
        polish,
        parts: part_outcomes,
    })
}
