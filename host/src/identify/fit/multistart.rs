//! Running the solver on every part of a [`Setup`] from every start, spread over threads
//! (each part's anchors, then its other starts against its best anchor cost, then its
//! probes from the lowest of those), each part's lowest minimum kept and polished, the
//! parts joined. See the `fit` module for why.

use anyhow::{Result, anyhow, bail};
use nalgebra::DMatrix;
use supine_core::model::ModelParams;

use super::part::PartProblem;
use crate::parallel::on_pool;

use super::solver::{self, DampingScale, Solution, SolverSettings, Termination};
use super::{FitSettings, Setup};

/// The damping of the probes' runs: Marquardt's, as the probes start far along one axis
/// of ln p and Marquardt's scaling of the step is invariant to the parameters' scales.
const PROBE_DAMPING: DampingScale = DampingScale::Marquardt;

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
    /// Every start on this part, in the starts' order, then its probes (their labels
    /// name the parameter moved to its bound).
    pub starts: Vec<StartOutcome>,
    /// Every start's and probe's minimum of this part (ln p of `free`), in the same order:
    /// the other minima the litter-board fit may explore ([`super::minima`]).
    pub minima: Vec<Vec<f64>>,
    /// Index (in `starts`) of the start or probe whose minimum of this part was kept.
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

/// Where one run of a part begins.
struct RunStart {
    /// Its label in the report.
    label: String,
    /// The part's parameters (ln p) it starts from.
    x0: Vec<f64>,
    /// The index its progress is reported under: the start's, or past the starts for a
    /// probe.
    progress_index: usize,
}

/// Solves `problem` (a part of `setup`) from `from` with `solver_settings`.
fn solve_from(
    setup: &Setup,
    problem: &PartProblem,
    from: &RunStart,
    solver_settings: &SolverSettings,
    progress: Progress,
) -> Result<(StartOutcome, Solution)> {
    let started = std::time::Instant::now();
    let solution = solver::solve(
        problem,
        &from.x0,
        &problem.restrict(&setup.lower),
        &problem.restrict(&setup.upper),
        solver_settings,
        &mut |iteration, cost| progress(from.progress_index, iteration, cost),
    )
    .map_err(|e| {
        if from.progress_index < setup.starts.len() {
            anyhow!("start {}: {e}", from.label)
        } else {
            anyhow!("{}: {e}", from.label)
        }
    })?;
    let initial_cost = solution.initial_cost;
    let outcome = StartOutcome {
        label: from.label.clone(),
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
    /// Per probe, once released: its run, once finished.
    probes: Vec<Option<RunResult>>,
    /// Whether the other starts were released.
    others_released: bool,
    /// Whether the probes were released.
    probes_released: bool,
    /// Whether the polish was released.
    polish_released: bool,
    /// The polish of the part's kept minimum, once finished.
    polished: Option<RunResult>,
}

/// The lowest of `runs` (its index, outcome and solution, the first on a tie); None
/// unless every run has finished without error.
fn lowest<'r>(
    runs: impl Iterator<Item = &'r Option<RunResult>>,
) -> Option<(usize, &'r StartOutcome, &'r Solution)> {
    let mut kept: Option<(usize, &StartOutcome, &Solution)> = None;
    for (index, run) in runs.enumerate() {
        let (outcome, solution) = run.as_ref()?.as_ref().ok()?;
        if kept.is_none_or(|(_, _, b)| solution.cost < b.cost) {
            kept = Some((index, outcome, solution));
        }
    }
    kept
}

impl PartRuns {
    /// The start whose minimum the probes start from: the lowest cost over the starts.
    /// None unless every start has finished without error.
    fn best_start(&self) -> Option<(usize, &StartOutcome, &Solution)> {
        lowest(self.runs.iter())
    }

    /// The minimum the part keeps: the lowest over its starts and then its probes (an
    /// index past the starts is a probe's). None unless every one has finished without
    /// error.
    fn kept(&self) -> Option<(usize, &StartOutcome, &Solution)> {
        if !self.probes_released {
            return None;
        }
        lowest(self.runs.iter().chain(&self.probes))
    }

    /// Every run in the order of [`PartOutcome::starts`]: the starts', then the probes'.
    fn all_mut(&mut self) -> impl Iterator<Item = &mut Option<RunResult>> {
        self.runs.iter_mut().chain(&mut self.probes)
    }
}

/// The probes of a part from its best start's minimum `x` (ln p of the part's
/// parameters): per unknown of [`Setup::probes`] in the part and not already at its lower
/// bound, where the run begins (`x` with that unknown at its lower bound), labelled.
fn probe_starts(setup: &Setup, problem: &PartProblem, x: &[f64]) -> Vec<RunStart> {
    let mut probes = Vec::new();
    for &unknown in &setup.probes {
        let Some(position) = problem.position(unknown) else {
            continue;
        };
        let bound = setup.lower[unknown];
        if x[position] <= bound {
            continue;
        }
        let mut x0 = x.to_vec();
        x0[position] = bound;
        probes.push(RunStart {
            label: format!(
                "probe: {} at its lower bound",
                setup.objective.free[unknown]
            ),
            x0,
            progress_index: setup.starts.len() + probes.len(),
        });
    }
    probes
}

/// Every part's runs, scheduled by what each needs rather than in rounds: a part's other
/// starts are released as soon as its own anchors have finished (they run against the
/// anchors' best cost, [`SolverSettings::best_elsewhere`]), its probes as soon as all its
/// starts have (against their best cost), and its polish as soon as all its probes have,
/// so no thread waits for another part. Every run's inputs are fixed
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
                probes: Vec::new(),
                others_released: false,
                probes_released: false,
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
        let start = &self.setup.starts[index];
        let from = RunStart {
            label: start.label.clone(),
            x0: self.problems[k].restrict(&start.theta),
            progress_index: index,
        };
        self.spawn(
            scope,
            k,
            from,
            start.damping,
            best_elsewhere,
            move |part, run| {
                part.runs[index] = Some(run);
            },
        );
    }

    /// Solves part `k` from `from` with `damping` on the pool, abandoned when it
    /// stagnates far above `best_elsewhere`; stores the run with `store`, then releases
    /// what its end allows.
    fn spawn<'s>(
        &'s self,
        scope: &rayon::Scope<'s>,
        k: usize,
        from: RunStart,
        damping: DampingScale,
        best_elsewhere: f64,
        store: impl FnOnce(&mut PartRuns, RunResult) + Send + 's,
    ) {
        scope.spawn(move |scope| {
            let solver_settings = SolverSettings {
                damping,
                best_elsewhere: self.settings.solver.best_elsewhere.min(best_elsewhere),
                ..self.settings.solver
            };
            let run = solve_from(
                self.setup,
                &self.problems[k],
                &from,
                &solver_settings,
                self.progress,
            );
            let mut parts = self.lock();
            let part = &mut parts[k];
            store(part, run);
            self.release(scope, k, part);
        });
    }

    /// Releases part `k`'s other starts once its anchors have all finished well (against
    /// their lowest cost), its probes once every start has (against the starts' lowest
    /// cost), and its polish once every probe has; each once.
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
        // `best_start` is Some once every start has finished well.
        if !part.probes_released {
            let best = part.best_start().map(|(_, _, best)| {
                let probes = probe_starts(self.setup, &self.problems[k], &best.x);
                (probes, best.cost)
            });
            if let Some((probes, best_cost)) = best {
                part.probes_released = true;
                part.probes = probes.iter().map(|_| None).collect();
                for (p, from) in probes.into_iter().enumerate() {
                    self.spawn(
                        scope,
                        k,
                        from,
                        PROBE_DAMPING,
                        best_cost,
                        move |part, run| {
                            part.probes[p] = Some(run);
                        },
                    );
                }
            }
        }
        // `kept` is Some once every start and probe has finished well.
        if !part.polish_released && self.settings.polish {
            let kept = part.kept().map(|(_, o, s)| (o.label.clone(), s.clone()));
            if let Some((label, solution)) = kept {
                part.polish_released = true;
                scope.spawn(move |_| {
                    let polished = polish(
                        self.setup,
                        self.settings,
                        &self.problems[k],
                        &label,
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
        for probe in &mut part.probes {
            if let Some(e) = take_error(probe) {
                return Err(e);
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
            .map(|(index, _, solution)| (index, solution.clone()))
            .ok_or_else(|| anyhow!("part {}: a start or probe did not finish", parts[k].name))?;
        kept.push((index, solution));
        polished.push(part.polished.take().and_then(Result::ok));
        for run in part.all_mut() {
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
