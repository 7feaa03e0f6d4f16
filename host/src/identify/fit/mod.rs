//! Identification of the model's parameters from a measured transmissibility (the paper's
//! section 2.2.3): bounded nonlinear least squares in log-parameters from several starts.
//!
//! - Rigid case: the 42 joint and contact parameters; bounds stiffness [1, 1e6] and damping
//!   [0.001, 1e6] (docs/model.md#unknowns-bounds-and-starts).
//! - Litter-board case: joints fixed to the rigid fit; the 18 contact parameters bounded by
//!   [0, rigid-case value]. The lower bound 0 has no logarithm: it becomes
//!   [`LITTER_FLOOR`] (1e-3 N/m or N s/m, under a millionth of any contact's effect).
//! - Parts: the cost is the sum of three independent parts (the longitudinal, lateral and
//!   vertical subsystems, [`objective::Objective::subsystems`]): every fitted component is
//!   driven by one input axis and so sees one block of A, and no parameter moves two
//!   parts (the roll parameters move none). Each part is solved on its own, from every
//!   start, with its own damping and stopping tests and one block of A per evaluation, and
//!   keeps its own lowest minimum; the fit joins them, at a cost at or below every
//!   start's own total (the best parts often come from different starts).
//! - Starts (deterministic for a seed): rigid: the paper's Table 3-4 values (twice: with
//!   Levenberg's and with Marquardt's damping, which end in different minima of this
//!   sloppy problem), then random starts at the paper's values times e^(N(0, 1)), their
//!   damping alternating (the paper's all-ones start was never the best part on the
//!   selection datasets, BENCHMARKS.md); litter: the rigid fit's contacts (the paper's
//!   start), the paper's litter-board contacts (clamped to the bounds, both dampings),
//!   then the rigid fit's contacts times e^(-|N(0, 2)|). The parameters of no part keep
//!   the first anchor's values.
//! - Order: on each part the anchors (the paper's values) run first, to the end; every
//!   other start then runs on that part knowing its best anchor cost, and is abandoned
//!   there when it stagnates far above it ([`SolverSettings::best_elsewhere`]). The
//!   (part, start) runs are spread over `threads` threads, each released as soon as its
//!   own part allows (`multistart`'s `Schedule`); a run's path never depends on another's
//!   timing.
//! - Probes (rigid case): from each part's lowest minimum over the starts, one more run
//!   per joint stiffness of the part, that stiffness moved to its lower bound (the spring
//!   taken out); the part keeps the lowest minimum of its starts and probes. Why: the
//!   rigid problem has basins where a joint's spring is all but absent, which random
//!   starts in ln p seldom reach (they would have to walk some ten e-folds down a flat
//!   valley), and which can be far lower (docs/model.md#probes-at-the-bounds). Each probe
//!   runs against its part's lowest cost, as the other starts against the anchors'.
//! - Polish: each part's kept minimum is refined with Marquardt's damping and tolerances
//!   10^4 times tighter ([`polish_settings`]): along the weakly determined directions the
//!   cost keeps falling slowly long after a step's relative reduction is below ftol.
//! - Determinism: each run's inputs fixed before it starts, ChaCha8 from the seed: the
//!   same seed gives bit-identical parameters and cost, whatever the number of threads
//!   and their timing. Another seed changes only the random starts (the third on in the
//!   rigid case, the fourth on in the litter-board case).

pub mod band;
pub mod block_solve;
pub mod determination;
pub mod explore;
pub mod kernels;
pub mod lane_atan2;
pub mod minima;
pub mod more_minima;
pub mod multistart;
pub mod objective;
pub mod part;
pub mod report;
pub mod solver;
pub mod uncertainty;
pub mod workflow;

use anyhow::{Result, anyhow};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use supine_core::model::{ModelParams, ParamId, Preset, Subject};

use crate::io::dataset::Case;
use objective::{COMPONENTS, Objective, Target};
use solver::{DampingScale, Problem, SolverSettings};

pub use determination::{AtBound, Determination, Identifiability, ParamSummary, identifiability};
pub use multistart::{
    FitResult, POLISH_TIGHTENING, PartOutcome, Progress, StartOutcome, polish_settings, run,
};

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
    /// Threads the (part, start) runs are spread over (0: one per core).
    pub threads: usize,
    /// Refine the best start's minimum ([`polish_settings`]).
    pub polish: bool,
}

/// The rigid fit's starts by default: the paper's values with either damping and two
/// random ones, then the probes (docs/model.md#probes-at-the-bounds: with the probes,
/// four starts cost what five did without them).
pub const RIGID_STARTS: usize = 4;

/// The litter-board fit's starts by default: the rigid fit's contacts, the paper's
/// litter-board contacts with either damping, and two random ones.
pub const LITTER_STARTS: usize = 5;

/// The default number of starts of `case`.
pub const fn default_starts(case: Case) -> usize {
    match case {
        Case::Rigid => RIGID_STARTS,
        Case::Litter => LITTER_STARTS,
    }
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            starts: LITTER_STARTS,
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
        crate::parallel::thread_count(self.threads)
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
    /// Runs first on every part, to the end; the others run after it, against its cost.
    pub anchor: bool,
}

impl Start {
    /// A start that runs after the anchors.
    pub fn new(label: impl Into<String>, theta: Vec<f64>, damping: DampingScale) -> Self {
        Self {
            label: label.into(),
            theta,
            damping,
            anchor: false,
        }
    }

    /// The same start, run first (an anchor).
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
    /// The unknowns whose lower bound is probed from each part's lowest minimum over the
    /// starts (indices into `objective.free`; see the module documentation).
    pub probes: Vec<usize>,
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
    let probes = (0..free.len())
        .filter(|&j| free[j].is_stiffness() && !free[j].is_contact())
        .collect();
    Ok(Setup {
        case: Case::Rigid,
        objective: Objective::new(base, free, target),
        lower,
        upper,
        starts,
        probes,
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
        probes: Vec::new(),
    })
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
