//! The whole `supine fit` workflow on a dataset, in named steps: the measured H (reading
//! and spectra), the problem of the case, the fit from every start, what the data
//! determine, and the files to write (the parameter file with its `[fit]` table, and the
//! optional report). The command only parses arguments and shows progress.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Result, anyhow, bail};

use super::explore::{self, Exploration};
use super::minima::{self, RigidMinima};
use super::more_minima::{self, MoreStarts};
use super::objective::{COMPONENTS, Target};
use super::uncertainty::{self, StoredUncertainty};
use super::{Determination, FitResult, FitSettings, Identifiability, Progress, Setup, report};
use crate::identify::transmissibility::{CaseEstimate, estimate};
use crate::io::dataset::{Case, Dataset};
use crate::io::output::write_all_atomically;
use crate::io::params_file::{self, ParamFile};

/// The fitted band, Hz (the paper's 0.5-16 Hz).
pub const FIT_BAND_HZ: (f64, f64) = (0.5, 16.0);

/// What to fit: plain data.
#[derive(Clone, Debug)]
pub struct FitRequest {
    /// The dataset folder (with dataset.toml).
    pub dataset: PathBuf,
    /// Which case.
    pub case: Case,
    /// The litter-board fit's rigid fit (its joints stay fixed); None for the rigid fit.
    pub joints: Option<PathBuf>,
    /// Subjects held out.
    pub exclude: Vec<String>,
    /// Frequency resolution of the measured H, Hz.
    pub resolution_hz: f64,
    /// Starts, seed and solver settings.
    pub settings: FitSettings,
    /// Litter board: also fit on the rigid fit's other minima (`[fit.rigid_minima]`) and
    /// keep the pair with the lowest litter-board cost.
    pub explore: bool,
    /// Litter board, exploring: which rigid minima the kept pair may have.
    pub region: explore::Region,
    /// Litter board, exploring: the rigid fit's random starts continued by this many on
    /// the dataset's rigid recordings, for more minima ([`more_minima`]).
    pub explore_starts: usize,
}

/// The default of [`FitRequest::explore_starts`] (docs/model.md#the-pipeline-over-the-rigid-fits-minima).
pub const EXPLORE_STARTS: usize = 32;

/// A finished fit with everything the files and the summary are made from.
#[derive(Clone, Debug)]
pub struct DatasetFit {
    /// The measured H per subject and their geometric mean.
    pub estimate: CaseEstimate,
    /// The problem that was solved.
    pub setup: Setup,
    /// The best start's solution and every start's outcome.
    pub result: FitResult,
    /// What the data determine.
    pub identifiability: Identifiability,
    /// Rigid fit: its other converged minima, for the litter-board fit.
    pub rigid_minima: Option<RigidMinima>,
    /// Litter board: the rigid minima explored and the pair kept.
    pub exploration: Option<Exploration>,
    /// Per component: rms magnitude and phase errors.
    pub errors: [(f64, f64); COMPONENTS],
    /// Wall time of reading and spectra, s.
    pub spectra_s: f64,
    /// Wall time of the solver over every start, s.
    pub solver_s: f64,
}

/// The rigid fit whose joints the litter-board fit keeps: required for that case only.
fn load_joints(request: &FitRequest) -> Result<Option<ParamFile>> {
    match (request.case, &request.joints) {
        (Case::Litter, Some(path)) => Ok(Some(params_file::load(path)?)),
        (Case::Litter, None) => bail!("--case litter: expected --joints FILE (the rigid fit)"),
        (Case::Rigid, Some(_)) => {
            bail!("--joints: only the litter-board fit takes the rigid fit's joints")
        }
        (Case::Rigid, None) => Ok(None),
    }
}

/// Reads `case`'s recordings and estimates the measured H over the fitted band.
fn measure(request: &FitRequest, case: Case, dataset: &Dataset) -> Result<CaseEstimate> {
    estimate(
        dataset,
        case,
        None,
        &request.exclude,
        request.resolution_hz,
        FIT_BAND_HZ.0,
        FIT_BAND_HZ.1,
    )
}

/// The measured target of the case.
fn target(estimate: &CaseEstimate) -> Target {
    Target {
        freqs_hz: estimate.freqs_hz.clone(),
        h: estimate.geomean.clone(),
    }
}

/// The rigid fit's starts and seed, from its `[fit]` table.
fn rigid_search(rigid: &ParamFile, more: usize) -> Option<MoreStarts> {
    let fit = rigid.fit.as_ref()?;
    let whole = |key: &str| fit.get(key)?.as_integer().filter(|&v| v >= 0);
    Some(MoreStarts {
        rigid_starts: usize::try_from(whole("starts")?).ok()?,
        seed: u64::try_from(whole("seed")?).ok()?,
        more,
    })
}

/// The rigid fit's minima for the litter-board fit to explore: the stored ones, and those
/// of `--explore-starts` more rigid starts on the dataset's rigid recordings.
fn minima_to_explore(
    request: &FitRequest,
    dataset: &Dataset,
    rigid: &ParamFile,
    stored: RigidMinima,
    progress: Progress,
) -> Result<RigidMinima> {
    let search = rigid_search(rigid, request.explore_starts).filter(|m| m.more > 0);
    let Some(search) = search else {
        return Ok(stored);
    };
    let estimate = measure(request, Case::Rigid, dataset)?;
    more_minima::with_more_starts(
        target(&estimate),
        estimate.mean_subject(),
        &rigid.params,
        &stored,
        search,
        &request.settings,
        progress,
    )
    .map_err(|e| {
        let path = request.joints.as_deref().unwrap_or(Path::new("--joints"));
        anyhow!("{}: {e}", path.display())
    })
}

/// The case's problem, solved: the rigid fit, or the litter-board fit on the rigid fit's
/// joints (and, with `explore` and stored minima, on each of the rigid fit's other minima).
fn solve(
    request: &FitRequest,
    dataset: &Dataset,
    estimate: &CaseEstimate,
    joints: Option<&ParamFile>,
    progress: Progress,
) -> Result<(Setup, FitResult, Option<Exploration>)> {
    let settings = &request.settings;
    let subject = estimate.mean_subject();
    let Some(rigid) = joints else {
        let setup = super::rigid_setup(target(estimate), subject, settings)?;
        let result = super::run(&setup, settings, progress)?;
        return Ok((setup, result, None));
    };
    let stored = RigidMinima::from_fit_table(rigid.fit.as_ref()).map_err(|e| {
        let path = request.joints.as_deref().unwrap_or(Path::new("--joints"));
        anyhow!("{}: {e}", path.display())
    })?;
    match stored.filter(|_| request.explore) {
        Some(stored) => {
            let stored = minima_to_explore(request, dataset, rigid, stored, progress)?;
            let (setup, result, exploration) = explore::litter_over_minima(
                &target(estimate),
                subject,
                &rigid.params,
                &stored,
                request.region,
                settings,
                progress,
            )?;
            Ok((setup, result, Some(exploration)))
        }
        None => {
            let setup = super::litter_setup(target(estimate), subject, &rigid.params, settings)?;
            let result = super::run(&setup, settings, progress)?;
            Ok((setup, result, None))
        }
    }
}

/// Measures, sets up and fits. `progress(start, iteration, cost)` as in [`super::run`].
pub fn fit_dataset(request: &FitRequest, progress: Progress) -> Result<DatasetFit> {
    let started = Instant::now();
    let dataset = Dataset::load(&request.dataset)?;
    let joints = load_joints(request)?;
    let estimate = measure(request, request.case, &dataset)?;
    let spectra_s = started.elapsed().as_secs_f64();
    let solver_started = Instant::now();
    let (setup, result, exploration) =
        solve(request, &dataset, &estimate, joints.as_ref(), progress)?;
    let solver_s = solver_started.elapsed().as_secs_f64();
    let identifiability = super::identifiability(&setup, &result);
    let errors = super::component_errors(
        &result.solution.residuals,
        setup.objective.target.freqs_hz.len(),
    );
    let rigid_minima = (request.case == Case::Rigid).then(|| RigidMinima::of_fit(&setup, &result));
    Ok(DatasetFit {
        estimate,
        setup,
        result,
        identifiability,
        rigid_minima,
        exploration,
        errors,
        spectra_s,
        solver_s,
    })
}

impl DatasetFit {
    /// The Markdown summary (printed, and `summary.md` of the report).
    pub fn summary(&self) -> String {
        let mut s = report::summary(
            &self.setup,
            &self.result,
            &self.identifiability,
            &self.errors,
            self.spectra_s,
            self.solver_s,
        );
        if let Some(m) = &self.rigid_minima {
            let within = m
                .minima
                .iter()
                .filter(|x| x.cost_above_kept <= m.cost_budget)
                .count();
            s.push_str(&format!(
                "\n{} other converged minima of the parts are kept in [fit.rigid_minima] for the litter-board fit to explore, {within} of them within this fit's 95 % confidence region (rigid cost at most {:.6} above it: {}).\n",
                m.minima.len(),
                m.cost_budget,
                minima::REGION_RULE
            ));
        }
        if let Some(e) = &self.exploration {
            s.push_str(&e.markdown());
        }
        s
    }

    /// The names of the free parameters with the given verdict, in the fit's order.
    pub fn params_with(&self, determination: Determination) -> Vec<String> {
        self.identifiability
            .params
            .iter()
            .filter(|p| p.determination == determination)
            .map(|p| p.id.to_string())
            .collect()
    }

    /// The parameter file's `[fit]` table: where the fit came from and how it ended.
    pub fn fit_table(&self, request: &FitRequest) -> toml::Table {
        let strings = |v: Vec<String>| -> toml::Value {
            v.into_iter()
                .map(toml::Value::from)
                .collect::<Vec<_>>()
                .into()
        };
        let setup = &self.setup;
        let solution = &self.result.solution;
        let mut table = toml::Table::new();
        table.insert("case".into(), request.case.name().into());
        table.insert(
            "dataset".into(),
            request.dataset.display().to_string().into(),
        );
        let ids = self
            .estimate
            .subjects
            .iter()
            .map(|s| s.id.clone())
            .collect();
        table.insert("subjects".into(), strings(ids));
        table.insert("excluded".into(), strings(request.exclude.clone()));
        table.insert("seed".into(), (request.settings.seed as i64).into());
        table.insert("starts".into(), (setup.starts.len() as i64).into());
        table.insert(
            "best_start".into(),
            setup.starts[self.result.best].label.clone().into(),
        );
        table.insert("polished".into(), self.result.polish.is_some().into());
        table.insert("final_cost".into(), solution.cost.into());
        table.insert(
            "frequencies".into(),
            (setup.objective.target.freqs_hz.len() as i64).into(),
        );
        table.insert(
            "resolution_hz".into(),
            self.estimate
                .settings
                .resolution_hz(self.estimate.sample_rate_hz)
                .into(),
        );
        table.insert("termination".into(), solution.termination.describe().into());
        if let Some(j) = &request.joints {
            table.insert("joints_from".into(), j.display().to_string().into());
        }
        table.insert(
            "no_effect".into(),
            strings(self.params_with(Determination::NoEffect)),
        );
        table.insert(
            "weakly_determined".into(),
            strings(self.params_with(Determination::Weak)),
        );
        let at_bound = self
            .identifiability
            .params
            .iter()
            .filter(|p| p.at_bound.is_some())
            .map(|p| p.id.to_string())
            .collect();
        table.insert("at_bound".into(), strings(at_bound));
        if let Some(m) = &self.rigid_minima {
            table.insert(minima::FIT_KEY.into(), m.to_toml().into());
        }
        if let Some(e) = &self.exploration {
            table.insert(explore::FIT_KEY.into(), e.to_toml().into());
        }
        if let Some(c) = &self.identifiability.covariance {
            let determined: Vec<usize> = (0..setup.objective.free.len())
                .filter(|&i| self.identifiability.params[i].standard_error.is_some())
                .collect();
            let stored = StoredUncertainty::of(c, &setup.objective.free, &determined);
            table.insert(
                uncertainty::FIT_KEY.into(),
                stored.to_toml(&self.result.params).into(),
            );
        }
        table
    }

    /// The parameter file's text: the fitted parameters and the `[fit]` table.
    pub fn parameter_file(&self, request: &FitRequest) -> Result<String> {
        ParamFile {
            params: self.result.params,
            fit: Some(self.fit_table(request)),
            device: None,
        }
        .to_toml()
    }

    /// The report's files in `dir`: the components figure and the summary.
    pub fn report_files(&self, dir: &Path, case: Case) -> Result<Vec<(PathBuf, Vec<u8>)>> {
        let model_h = self
            .setup
            .objective
            .model_h(&self.result.solution.x)
            .map_err(|e| anyhow!("{e}"))?;
        let subjects: Vec<_> = self
            .estimate
            .subjects
            .iter()
            .map(|s| s.estimate.h.clone())
            .collect();
        let svg = report::components_svg(
            &format!(
                "supine fit, {} case: subjects (grey), geometric mean (black), model (red)",
                case.name()
            ),
            &self.estimate.freqs_hz,
            &subjects,
            &self.estimate.geomean,
            &model_h,
        )?;
        Ok(report::files(dir, &self.summary(), &svg))
    }
}

/// Writes the parameter file to `out` and, with `report_dir`, the report beside it: all
/// computed first, then written together (the parameter file last) or not at all. A
/// report folder created here is removed again if the writing fails.
pub fn write_outputs(
    fit: &DatasetFit,
    request: &FitRequest,
    out: &Path,
    report_dir: Option<&Path>,
) -> Result<()> {
    let params_text = fit.parameter_file(request)?;
    let mut outputs = Vec::new();
    let mut created_report_dir = None;
    if let Some(dir) = report_dir {
        let files = fit.report_files(dir, request.case)?;
        if !dir.is_dir() {
            std::fs::create_dir_all(dir)
                .map_err(|e| anyhow!("{}: --report: cannot create: {e}", dir.display()))?;
            created_report_dir = Some(dir);
        }
        outputs.extend(files);
    }
    outputs.push((out.to_path_buf(), params_text.into_bytes()));
    if let Err(e) = write_all_atomically(&outputs) {
        if let Some(dir) = created_report_dir {
            // Only removes the folder if nothing landed in it.
            let _ = std::fs::remove_dir(dir);
        }
        return Err(e);
    }
    Ok(())
}
