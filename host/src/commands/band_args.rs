//! `--band N` and `--seed`: the prediction band's flags, one definition shared by
//! `supine predict` and `supine report`, and the check that the parameter file carries the
//! fit's uncertainty the draws come from (docs/model.md#uncertainty-of-a-fit).

use anyhow::{Result, anyhow};

use crate::commands::values;
use crate::identify::fit::band::{BandRequest, check_draws};
use crate::identify::fit::uncertainty::StoredUncertainty;
use crate::io::params_file::{ModelSource, ParamFile};

/// The band's flags (the default: no band).
#[derive(Clone, Debug, clap::Args)]
pub struct BandArgs {
    /// Also give the head exposure's 95 % prediction band from this many parameter sets
    /// drawn from the fit's uncertainty (the --params file's [fit.uncertainty]).
    #[arg(long, value_name = "DRAWS")]
    pub band: Option<usize>,
    /// Seed of the band's draws (`--band-seed` is another spelling).
    #[arg(long, default_value_t = values::DEFAULT_SEED, alias = "band-seed")]
    pub seed: u64,
}

impl Default for BandArgs {
    fn default() -> Self {
        Self {
            band: None,
            seed: values::DEFAULT_SEED,
        }
    }
}

impl BandArgs {
    /// The band asked for, if any: `source` must name a parameter file whose `[fit]`
    /// table (already loaded into `file`) holds the uncertainty.
    pub fn request(&self, source: &ModelSource, file: &ParamFile) -> Result<Option<BandRequest>> {
        let Some(draws) = self.band else {
            return Ok(None);
        };
        check_draws(draws)?;
        let path = source.params.as_ref().ok_or_else(|| {
            anyhow!(
                "--band: expected --params FILE written by supine fit (a preset has no uncertainty)"
            )
        })?;
        let uncertainty = StoredUncertainty::from_fit_table(file.fit.as_ref())
            .map_err(|e| anyhow!("{}: {e}", path.display()))?
            .ok_or_else(|| {
                anyhow!(
                    "{}: --band: expected a [fit.uncertainty] table (written by supine fit)",
                    path.display()
                )
            })?;
        Ok(Some(BandRequest {
            draws,
            seed: self.seed,
            uncertainty,
        }))
    }
}

/// The threads a band's draws are spread over (the result does not depend on it).
pub fn band_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
