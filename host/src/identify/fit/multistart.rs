//! Running the solver on every part of a [`Setup`] from every start: two rounds spread
//! over threads (the anchors, then the others against each part's best anchor cost), each
//! part's lowest minimum kept and polished, the parts joined. See the `fit` module for why.

use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{Result, anyhow, bail};
use nalgebra::DMatrix;
use supine_core::model::ModelParams;

use super::part::PartProblem;

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

/// One part's ([`FitSubsystem`]) runs: every start's and the polish's.
#[derive(Clone, Debug)]
pub struct PartOutcome {
    /// The part's name (the model's subsystem).
    pub name: String,
    /// Its number of free parameters.
    pub params: usize,
    /// Every start on this part, in the starts' order.
    pub starts: Vec<StartOutcome>,
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

/// Solves every (part, start) job in parallel, each abandoned when it stagnates far above
/// its part's `best_elsewhere`.
fn solve_round(
    setup: &Setup,
    settings: &FitSettings,
    problems: &[PartProblem],
    jobs: &[(usize, usize)],
    best_elsewhere: &[f64],
    progress: Progress,
) -> Result<Vec<(usize, usize, StartOutcome, Solution)>> {
    let results = in_parallel(jobs.len(), settings.thread_count(), |job| {
        let (part, index) = jobs[job];
        let solver_settings = SolverSettings {
            damping: setup.starts[index].damping,
            best_elsewhere: settings.solver.best_elsewhere.min(best_elsewhere[part]),
            ..settings.solver
        };
        solve_from(setup, &problems[part], index, &solver_settings, progress)
            .map(|(outcome, solution)| (part, index, outcome, solution))
    });
    results.into_iter().collect()
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

/// Runs the solver on every part from every start in two rounds (the anchors, then the
/// others against the anchors' best cost of that part), keeps each part's lowest cost
/// (the first start on a tie), polishes it, and joins the parts (see the module
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

    let (anchors, others): (Vec<usize>, Vec<usize>) =
        (0..setup.starts.len()).partition(|&i| setup.starts[i].anchor);
    let jobs = |starts: &[usize]| -> Vec<(usize, usize)> {
        (0..parts.len())
            .flat_map(|k| starts.iter().map(move |&i| (k, i)))
            .collect()
    };
    let no_best = vec![f64::INFINITY; parts.len()];
    let mut solved = solve_round(
        setup,
        settings,
        &problems,
        &jobs(&anchors),
        &no_best,
        progress,
    )?;
    let mut best_anchor = no_best.clone();
    for (k, _, _, s) in &solved {
        best_anchor[*k] = best_anchor[*k].min(s.cost);
    }
    solved.extend(solve_round(
        setup,
        settings,
        &problems,
        &jobs(&others),
        &best_anchor,
        progress,
    )?);
    solved.sort_by_key(|(k, index, _, _)| (*k, *index));

    // Per part: every start's outcome and the lowest minimum (the first start on a tie).
    let mut outcomes: Vec<Vec<StartOutcome>> = vec![Vec::new(); parts.len()];
    let mut kept: Vec<Option<(usize, Solution)>> = (0..parts.len()).map(|_| None).collect();
    for (k, index, outcome, solution) in solved {
        outcomes[k].push(outcome);
        if kept[k].as_ref().is_none_or(|(_, b)| solution.cost < b.cost) {
            kept[k] = Some((index, solution));
        }
    }
    let kept: Vec<(usize, Solution)> = kept.into_iter().flatten().collect();
    let polished: Vec<Option<(StartOutcome, Solution)>> = if settings.polish {
        in_parallel(kept.len(), settings.thread_count(), |k| {
            let (index, solution) = &kept[k];
            polish(
                setup,
                settings,
                &problems[k],
                &setup.starts[*index].label,
                solution.clone(),
            )
            .map(Some)
        })
        .into_iter()
        .collect::<Result<_>>()?
    } else {
        vec![None; kept.len()]
    };

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
            starts: std::mem::take(&mut outcomes[k]),
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
