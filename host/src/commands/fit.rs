//! `supine fit`: identifies the model's parameters from a dataset (see `fit` for the
//! method) and writes the parameter file that `--params` reads everywhere.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use crate::identify::fit::objective::Target;
use crate::identify::fit::report;
use crate::identify::fit::solver::{DEFAULT_TOLERANCE, SolverSettings};
use crate::identify::fit::{self, Determination, FitSettings};
use crate::identify::spectral::DEFAULT_RESOLUTION_HZ;
use crate::identify::transmissibility::estimate;
use crate::io::dataset::{Case, Dataset};
use crate::io::output::write_all_atomically;
use crate::io::params_file::{self, ParamFile};
use anyhow::{Result, bail};

/// Arguments of `supine fit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset folder (with dataset.toml).
    #[arg(long)]
    pub dataset: PathBuf,
    /// `rigid` fits all 42 parameters; `litter` fits the 18 contacts with --joints fixed.
    #[arg(long, value_enum)]
    pub case: Case,
    /// The rigid fit (parameter file) whose joints the litter-board fit keeps.
    #[arg(long, value_name = "FILE")]
    pub joints: Option<PathBuf>,
    /// Subjects to hold out, comma-separated (e.g. s8).
    #[arg(long, value_delimiter = ',')]
    pub exclude: Vec<String>,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of starts (the paper's start, the paper's values, then random ones).
    #[arg(long, default_value_t = 4)]
    pub starts: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction (model.md: 1e-6).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE)]
    pub ftol: f64,
    /// Stop when a step in ln p is shorter than this (relative; model.md: 1e-6).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE)]
    pub xtol: f64,
    /// Stop when the projected gradient's largest entry (in ln p) is below this (model.md: 1e-6).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE)]
    pub gtol: f64,
    /// Most solver iterations per start.
    #[arg(long, default_value_t = 1000)]
    pub max_iterations: usize,
    /// Frequency resolution of the measured H, Hz.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION_HZ)]
    pub resolution_hz: f64,
    /// Where to write the fitted parameter file.
    #[arg(long)]
    pub out: PathBuf,
    /// A folder for the SVG plots and the summary table.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// A bar over every start's iterations on stderr; hidden when stderr is not a terminal
/// (a log or a pipe gets the summary only).
fn progress_bar(starts: usize, max_iterations: usize) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new((starts * max_iterations) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("fit [{bar:25}] {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

/// Fits and writes the parameter file (and the report).
pub fn run(args: &Args) -> Result<()> {
    let started = Instant::now();
    for (flag, value) in [
        ("--ftol", args.ftol),
        ("--xtol", args.xtol),
        ("--gtol", args.gtol),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            bail!("{flag}: expected a finite number >= 0, found {value}");
        }
    }
    let dataset = Dataset::load(&args.dataset)?;
    let joints = match (args.case, &args.joints) {
        (Case::Litter, Some(path)) => Some(params_file::load(path)?),
        (Case::Litter, None) => bail!("--case litter: expected --joints FILE (the rigid fit)"),
        (Case::Rigid, Some(_)) => {
            bail!("--joints: only the litter-board fit takes the rigid fit's joints")
        }
        (Case::Rigid, None) => None,
    };
    let est = estimate(
        &dataset,
        args.case,
        None,
        &args.exclude,
        args.resolution_hz,
        0.5,
        16.0,
    )?;
    let spectra_s = started.elapsed().as_secs_f64();
    let settings = FitSettings {
        starts: args.starts,
        seed: args.seed,
        solver: SolverSettings {
            ftol: args.ftol,
            xtol: args.xtol,
            gtol: args.gtol,
            max_iterations: args.max_iterations,
            ..SolverSettings::default()
        },
    };
    let target = Target {
        freqs_hz: est.freqs_hz.clone(),
        h: est.geomean.clone(),
    };
    let subject = est.mean_subject();
    let setup = match &joints {
        Some(rigid) => fit::litter_setup(target, subject, &rigid.params, &settings)?,
        None => fit::rigid_setup(target, subject, &settings)?,
    };
    let total = setup.starts.len();
    let bar = progress_bar(total, settings.solver.max_iterations);
    let solver_started = Instant::now();
    // Length: every start's iteration limit. A start that stops early jumps to its end.
    let per_start = settings.solver.max_iterations as u64;
    let (mut current, mut finished) = (None, 0u64);
    let fitted = fit::run(&setup, &settings, &mut |start, iteration, cost| {
        if current != Some(start) {
            finished += u64::from(current.is_some());
            current = Some(start);
        }
        bar.set_position(finished * per_start + iteration as u64);
        bar.set_message(format!(
            "start {}/{total}, iteration {iteration}, cost {cost:.6}",
            finished + 1
        ));
    });
    bar.finish_and_clear();
    let result = fitted?;
    let solver_s = solver_started.elapsed().as_secs_f64();
    let ident = fit::identifiability(&setup, &result);
    let errors = fit::component_errors(
        &result.solution.residuals,
        setup.objective.target.freqs_hz.len(),
    );
    let summary = report::summary(&setup, &result, &ident, &errors, spectra_s, solver_s);

    let mut table = toml::Table::new();
    table.insert("case".into(), args.case.name().into());
    table.insert("dataset".into(), args.dataset.display().to_string().into());
    let ids: Vec<toml::Value> = est.subjects.iter().map(|s| s.id.clone().into()).collect();
    table.insert("subjects".into(), ids.into());
    let excluded: Vec<toml::Value> = args.exclude.iter().map(|s| s.clone().into()).collect();
    table.insert("excluded".into(), excluded.into());
    table.insert("seed".into(), (args.seed as i64).into());
    table.insert("starts".into(), (setup.starts.len() as i64).into());
    table.insert(
        "best_start".into(),
        setup.starts[result.best].0.clone().into(),
    );
    table.insert("final_cost".into(), result.solution.cost.into());
    table.insert(
        "frequencies".into(),
        (setup.objective.target.freqs_hz.len() as i64).into(),
    );
    table.insert(
        "resolution_hz".into(),
        est.settings.resolution_hz(est.sample_rate_hz).into(),
    );
    table.insert(
        "termination".into(),
        result.solution.termination.describe().into(),
    );
    if let Some(j) = &args.joints {
        table.insert("joints_from".into(), j.display().to_string().into());
    }
    let list = |d: Determination| -> toml::Value {
        let v: Vec<toml::Value> = ident
            .params
            .iter()
            .filter(|p| p.determination == d)
            .map(|p| p.id.to_string().into())
            .collect();
        v.into()
    };
    table.insert("no_effect".into(), list(Determination::NoEffect));
    table.insert("weakly_determined".into(), list(Determination::Weak));
    let at_bound: Vec<toml::Value> = ident
        .params
        .iter()
        .filter(|p| p.at_bound.is_some())
        .map(|p| p.id.to_string().into())
        .collect();
    table.insert("at_bound".into(), at_bound.into());
    // Everything is computed before anything is written: the report and the parameter
    // file are written together, the parameter file last, or not at all.
    let params_text = ParamFile {
        params: result.params,
        fit: Some(table),
        device: None,
    }
    .to_toml()?;
    let mut outputs = Vec::new();
    let mut created_report_dir = None;
    if let Some(dir) = &args.report {
        let model_h = setup
            .objective
            .model_h(&result.solution.x)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let subjects: Vec<_> = est.subjects.iter().map(|s| s.estimate.h.clone()).collect();
        let svg = report::components_svg(
            &format!(
                "supine fit, {} case: subjects (grey), geometric mean (black), model (red)",
                args.case.name()
            ),
            &est.freqs_hz,
            &subjects,
            &est.geomean,
            &model_h,
        )?;
        if !dir.is_dir() {
            std::fs::create_dir_all(dir)
                .map_err(|e| anyhow::anyhow!("{}: --report: cannot create: {e}", dir.display()))?;
            created_report_dir = Some(dir);
        }
        outputs.extend(report::files(dir, &summary, &svg));
    }
    outputs.push((args.out.clone(), params_text.into_bytes()));
    if let Err(e) = write_all_atomically(&outputs) {
        if let Some(dir) = created_report_dir {
            // Only removes the folder if nothing landed in it.
            let _ = std::fs::remove_dir(dir);
        }
        return Err(e);
    }
    eprintln!("{summary}");
    let unknown: Vec<String> = ident
        .params
        .iter()
        .filter(|p| p.determination == Determination::NoEffect)
        .map(|p| p.id.to_string())
        .collect();
    eprintln!(
        "wrote {} (final cost {:.6}; {} parameter(s) without effect: {})",
        args.out.display(),
        result.solution.cost,
        unknown.len(),
        unknown.join(", ")
    );
    Ok(())
}
