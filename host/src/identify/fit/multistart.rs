//! Running the solver from every start of a [`Setup`]: two rounds spread over threads
//! (the anchors, then the others against the anchors' best cost), the best minimum kept
//! and polished. See the `fit` module for why.

use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{Result, anyhow, bail};
use supine_core::model::ModelParams;

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
pub(super) fn in_parallel<T: Send>(
    jobs: usize,
    threads: usize,
    work: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
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
