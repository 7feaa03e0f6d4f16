//! `supine fit`: identifies the model's parameters from a dataset (see `fit` for the
//! method) and writes the parameter file that `--params` reads everywhere.

use std::io::IsTerminal;
use std::path::PathBuf;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::identify::fit::explore::Region;
use crate::identify::fit::solver::{DEFAULT_TOLERANCE, SolverSettings};
use crate::identify::fit::workflow::{self, FitRequest};
use crate::identify::fit::{self, Determination, FitSettings};
use crate::identify::identify_records::FitSummary;
use crate::identify::spectral::DEFAULT_RESOLUTION_HZ;
use crate::io::dataset::Case;
use crate::io::output_folder;
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
    /// Subjects to hold out, comma-separated (e.g. s8 or "s1, s2").
    #[arg(long, value_name = "S1,S2")]
    pub exclude: Vec<String>,
    /// Seed of the random starts.
    #[arg(long, default_value_t = values::DEFAULT_SEED)]
    pub seed: u64,
    /// Number of starts (rigid: the paper's values with either damping, then random ones,
    /// default 4; litter board: the rigid fit's contacts, the paper's values, then random
    /// ones, default 5).
    #[arg(long)]
    pub starts: Option<usize>,
    /// Threads the starts run on (0: one per core). The result does not depend on it.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Skip the final polish of the best start's minimum.
    #[arg(long)]
    pub no_polish: bool,
    /// Litter board: fit on --joints' own rigid minimum only, not also on the rigid fit's
    /// other minima (`[fit.rigid_minima]`, docs/model.md#the-pipeline-over-the-rigid-fits-minima).
    #[arg(long)]
    pub no_explore: bool,
    /// Litter board, exploring: continue the rigid fit's random starts by this many on the
    /// dataset's rigid recordings, for more of its minima (0: only those it stored).
    #[arg(long, default_value_t = workflow::EXPLORE_STARTS)]
    pub explore_starts: usize,
    /// Litter board, exploring: keep only a pair whose rigid cost is within the rigid fit's
    /// 95 % confidence region (its data cannot tell it from the rigid fit), not the lowest
    /// litter-board cost over every rigid minimum.
    #[arg(long)]
    pub within_region: bool,
    /// Stop when an accepted step lowers the cost by less than this fraction (1e-6, docs/model.md#solver-and-tolerances).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE)]
    pub ftol: f64,
    /// Stop when a step in ln p is shorter than this (relative; 1e-6, docs/model.md#solver-and-tolerances).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE)]
    pub xtol: f64,
    /// Stop when the projected gradient's largest entry (in ln p) is below this (1e-6, docs/model.md#solver-and-tolerances).
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
    /// A folder for the SVG plots and the summary table (a folder holding files supine
    /// did not write is refused, see --force).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write into the folder even if it holds files supine did not write there (those
    /// are kept).
    #[arg(long)]
    pub force: bool,
    /// Print the fit's outcome as JSON (the summary table stays on standard error).
    #[command(flatten)]
    pub json: JsonFlag,
}

/// A spinner with the latest accepted step on stderr; hidden when stderr is not a
/// terminal (a log or a pipe gets the summary only).
fn progress_spinner() -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("fit {spinner} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar
}

/// The request the arguments describe, after checking the tolerances.
fn request(args: &Args) -> Result<FitRequest> {
    for (flag, value) in [
        ("--ftol", args.ftol),
        ("--xtol", args.xtol),
        ("--gtol", args.gtol),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            bail!("{flag}: expected a finite number >= 0, found {value}");
        }
    }
    Ok(FitRequest {
        dataset: args.dataset.clone(),
        case: args.case,
        joints: args.joints.clone(),
        exclude: values::comma_list("--exclude", &args.exclude)?,
        resolution_hz: args.resolution_hz,
        settings: FitSettings {
            starts: args.starts.unwrap_or(fit::default_starts(args.case)),
            seed: args.seed,
            solver: SolverSettings {
                ftol: args.ftol,
                xtol: args.xtol,
                gtol: args.gtol,
                max_iterations: args.max_iterations,
                ..SolverSettings::default()
            },
            threads: args.threads,
            polish: !args.no_polish,
        },
        explore: !args.no_explore,
        explore_starts: args.explore_starts,
        region: if args.within_region {
            Region::Within
        } else {
            Region::Any
        },
    })
}

/// Fits and writes the parameter file (and the report).
pub fn run(args: &Args) -> Result<()> {
    let request = request(args)?;
    // Checked before the fit, so that a refused folder costs no wait.
    let report_folder = args
        .report
        .as_deref()
        .map(|dir| output_folder::claim(dir, "supine fit", "--report", args.force))
        .transpose()?;
    let total = request.settings.starts.max(1);
    let bar = progress_spinner();
    // Starts run in parallel: the message shows whichever reported last.
    let fitted = workflow::fit_dataset(&request, &|start, iteration, cost| {
        let run = if start < total {
            format!("start {}/{total}", start + 1)
        } else {
            format!("probe {}", start - total + 1)
        };
        bar.set_message(format!("{run}, iteration {iteration}, cost {cost:.6}"));
        bar.tick();
    });
    bar.finish_and_clear();
    let fitted = match fitted {
        Ok(fitted) => fitted,
        Err(e) => {
            // The report folder was claimed before the wait: a failed fit leaves no trace.
            if let Some(folder) = report_folder {
                folder.undo();
            }
            return Err(e);
        }
    };
    let written = workflow::write_outputs(&fitted, &request, &args.out, args.report.as_deref());
    match (report_folder, written) {
        (Some(folder), Ok(())) => folder.write_or_undo(|f| f.record_new_entries())?,
        (Some(folder), Err(e)) => {
            folder.undo();
            return Err(e);
        }
        (None, written) => written?,
    }
    eprintln!("{}", fitted.summary());
    let unknown = fitted.params_with(Determination::NoEffect);
    if args.json.json {
        return json_output::print(&FitSummary::new(
            &fitted,
            args.case.name(),
            args.out.clone(),
        ));
    }
    eprintln!(
        "wrote {} (final cost {:.6}; {})",
        args.out.display(),
        fitted.result.solution.cost,
        without_effect(&unknown)
    );
    Ok(())
}

/// `every parameter has an effect`, or how many have none and which.
fn without_effect(names: &[String]) -> String {
    match names {
        [] => "every parameter has an effect".to_string(),
        [one] => format!("1 parameter without effect: {one}"),
        many => format!(
            "{} parameters without effect: {}",
            many.len(),
            many.join(", ")
        ),
    }
}
