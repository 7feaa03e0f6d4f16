//! The rigid fit's other minima, kept in the parameter file (`[fit.rigid_minima]`) for the
//! litter-board fit to explore ([`super::explore`]).
//!
//! Why: the litter-board contacts are bounded by the rigid fit's contacts and share its
//! joints, yet the rigid data barely determine some of them: two starts can end a part
//! at almost the same rigid cost with contacts 10^4 apart, and which one bounds the
//! litter-board problem decides its cost. Every start's minimum of a part that converged
//! (not abandoned far above the others) is kept, at most [`MOST_PER_PART`] besides the
//! lowest, with its rise over the kept one; the litter-board fit weighs that rise against
//! what it gains on its own data
//! (docs/model.md#the-pipeline-over-the-rigid-fits-minima). The rigid fit's 95 %
//! confidence region in cost (a rise below 0.5 chi-square(p, 95 %) s^2, p the parameters
//! that move the cost, s^2 = 2 cost / (m - n)) is stored beside them, to say which of them
//! its own data cannot tell from the kept one.

use anyhow::{Result, anyhow};
use statrs::distribution::{ChiSquared, ContinuousCDF as _};
use supine_core::model::{ModelParams, ParamId};

use super::uncertainty::parse_id;
use super::{FitResult, PartOutcome, Setup};

/// Confidence of the region of minima the rigid data cannot tell apart.
pub const CONFIDENCE: f64 = 0.95;
/// The region's bound as the reports state it.
pub const REGION_RULE: &str =
    "2 x rise / s^2 below chi-square(p, 95 %), p the parameters that move the cost";
/// The `[fit]` table's key of the stored minima.
pub const FIT_KEY: &str = "rigid_minima";
/// Most minima kept per part besides the kept one (the lowest): bounds the litter-board
/// fit's work and the file's size whatever `--starts` is.
pub const MOST_PER_PART: usize = 4;
/// Most minima per part besides the kept one once the litter-board fit has continued the
/// rigid search ([`super::more_minima`]): each costs a litter-board fit only when it is
/// its part's r-th option for a new r, and 33 options over 3 parts are 35,937
/// combinations, each a sum.
pub const MOST_EXPLORED_PER_PART: usize = 32;
/// Two minima of a part whose every ln p differs by less than this are one minimum.
pub const SAME_MINIMUM_LN: f64 = 1e-3;

/// Whether two minima of a part (ln p of its parameters, in the same order) are one.
pub fn same_minimum(a: &[f64], b: &[f64]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (x - y).abs() < SAME_MINIMUM_LN)
}

/// One part's minimum from another start.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidMinimum {
    /// The part (the model's subsystem, e.g. `vertical`).
    pub part: String,
    /// The start it came from.
    pub start: String,
    /// Its rigid cost above the kept minimum's, of this part.
    pub cost_above_kept: f64,
    /// The part's parameters at this minimum.
    pub values: Vec<(ParamId, f64)>,
}

impl RigidMinimum {
    /// The minimum `x` (ln p) that `start` reached on `part` of a fit over the unknowns
    /// `free`, `cost_above_kept` above the kept one.
    pub fn of_part(
        part: &PartOutcome,
        start: &str,
        cost_above_kept: f64,
        free: &[ParamId],
        x: &[f64],
    ) -> Self {
        Self {
            part: part.name.clone(),
            start: start.to_string(),
            cost_above_kept,
            values: part
                .free
                .iter()
                .zip(x)
                .map(|(&j, t)| (free[j], t.exp()))
                .collect(),
        }
    }

    /// `params` with this part's parameters replaced by this minimum's.
    pub fn apply(&self, params: &mut ModelParams) {
        for &(id, v) in &self.values {
            params.set(id, v);
        }
    }
}

/// The rigid fit's other minima, by part.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidMinima {
    /// The kept rigid fit's cost.
    pub rigid_cost: f64,
    /// Its number of residuals (m).
    pub residuals: usize,
    /// s^2 = 2 cost / (m - n) of the rigid fit.
    pub residual_variance: f64,
    /// The rigid fit's 95 % confidence region in cost: a rise of the rigid cost below
    /// 0.5 chi2(p, 95 %) s^2 (p the parameters that move the cost), which its data cannot
    /// tell from the kept minimum.
    pub cost_budget: f64,
    /// The other converged minima, by part, then by rising cost.
    pub minima: Vec<RigidMinimum>,
}

/// The cost budget of a fit with residual variance `s2` and `parameters` parameters that
/// move its cost: the likelihood-ratio joint confidence region of all of them at
/// [`CONFIDENCE`], -2 ln L rising by less than chi2(p, 95 %), i.e. the cost by
/// 0.5 chi2(p, 95 %) s^2 (Bates & Watts 1988, section 6.1). A minimum within it is one the
/// data cannot reject in favour of the kept one: every parameter may differ between two
/// minima, so the region is the joint one, not one parameter's.
pub fn cost_budget(s2: f64, parameters: usize) -> f64 {
    ChiSquared::new(parameters.max(1) as f64).map_or(0.0, |c| 0.5 * c.inverse_cdf(CONFIDENCE) * s2)
}

fn float(t: &toml::Table, key: &str, at: &str) -> Result<f64> {
    t.get(key)
        .and_then(toml::Value::as_float)
        .filter(|v| v.is_finite() && *v >= 0.0)
        .ok_or_else(|| anyhow!("[{at}] {key}: expected a number >= 0"))
}

fn string(t: &toml::Table, key: &str, at: &str) -> Result<String> {
    t.get(key)
        .and_then(toml::Value::as_str)
        .map(str::to_string)
        .ok_or_else(|| anyhow!("[{at}] {key}: expected a string"))
}

impl RigidMinima {
    /// The other minima of a rigid fit's parts: every converged start's minimum of a
    /// part, but the kept one and repeats of another, the lowest [`MOST_PER_PART`].
    pub fn of_fit(setup: &Setup, result: &FitResult) -> Self {
        let m = result.solution.residuals.len();
        let n = setup.objective.free.len();
        let residual_variance = 2.0 * result.solution.cost / m.saturating_sub(n).max(1) as f64;
        let moving: usize = result.parts.iter().map(|p| p.free.len()).sum();
        let cost_budget = cost_budget(residual_variance, moving);
        let mut minima = Vec::new();
        for part in &result.parts {
            let kept_cost = part
                .polish
                .as_ref()
                .map_or(part.starts[part.best].final_cost, |p| p.final_cost);
            let mut listed: Vec<&[f64]> = vec![&part.minima[part.best]];
            let mut order: Vec<usize> = (0..part.starts.len()).collect();
            order.sort_by(|&a, &b| {
                part.starts[a]
                    .final_cost
                    .total_cmp(&part.starts[b].final_cost)
            });
            let mut of_part = Vec::new();
            for i in order {
                let above = part.starts[i].final_cost - kept_cost;
                let x = &part.minima[i];
                let repeat = listed.iter().any(|y| same_minimum(x, y));
                let abandoned = !part.starts[i].termination.at_minimum();
                if abandoned || repeat || of_part.len() == MOST_PER_PART {
                    continue;
                }
                listed.push(x);
                of_part.push(RigidMinimum::of_part(
                    part,
                    &part.starts[i].label,
                    above.max(0.0),
                    &setup.objective.free,
                    x,
                ));
            }
            minima.extend(of_part);
        }
        Self {
            rigid_cost: result.solution.cost,
            residuals: m,
            residual_variance,
            cost_budget,
            minima,
        }
    }

    /// The `[fit.rigid_minima]` table: the rigid cost, its residuals, the variance, the
    /// budget, and one sub-table per minimum (`part`, `start`, `cost_above_kept`, and its
    /// parameters by name).
    pub fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert("rigid_cost".into(), self.rigid_cost.into());
        t.insert("residuals".into(), (self.residuals as i64).into());
        t.insert("residual_variance".into(), self.residual_variance.into());
        t.insert("cost_budget".into(), self.cost_budget.into());
        let minima: Vec<toml::Value> = self
            .minima
            .iter()
            .map(|m| {
                let mut e = toml::Table::new();
                e.insert("part".into(), m.part.clone().into());
                e.insert("start".into(), m.start.clone().into());
                e.insert("cost_above_kept".into(), m.cost_above_kept.into());
                let mut values = toml::Table::new();
                for (id, v) in &m.values {
                    values.insert(id.to_string(), (*v).into());
                }
                e.insert("values".into(), values.into());
                e.into()
            })
            .collect();
        t.insert("minimum".into(), minima.into());
        t
    }

    /// Reads `[fit.rigid_minima]`; None when the file has none (a preset, a litter-board
    /// fit, or a rigid fit written before it existed).
    pub fn from_fit_table(fit: Option<&toml::Table>) -> Result<Option<Self>> {
        let Some(value) = fit.and_then(|f| f.get(FIT_KEY)) else {
            return Ok(None);
        };
        let at = "fit.rigid_minima";
        let t = value
            .as_table()
            .ok_or_else(|| anyhow!("[{at}]: expected a table"))?;
        let rigid_cost = float(t, "rigid_cost", at)?;
        let residuals = t
            .get("residuals")
            .and_then(toml::Value::as_integer)
            .and_then(|v| usize::try_from(v).ok())
            .filter(|&v| v > 0)
            .ok_or_else(|| anyhow!("[{at}] residuals: expected a whole number > 0"))?;
        let residual_variance = float(t, "residual_variance", at)?;
        let cost_budget = float(t, "cost_budget", at)?;
        let entries = t
            .get("minimum")
            .and_then(toml::Value::as_array)
            .ok_or_else(|| anyhow!("[{at}] minimum: expected a list of tables"))?;
        let mut minima = Vec::with_capacity(entries.len());
        for (k, entry) in entries.iter().enumerate() {
            let at = format!("fit.rigid_minima.minimum {}", k + 1);
            let e = entry
                .as_table()
                .ok_or_else(|| anyhow!("[{at}]: expected a table"))?;
            let values = e
                .get("values")
                .and_then(toml::Value::as_table)
                .ok_or_else(|| anyhow!("[{at}] values: expected a table of parameters"))?;
            let values = values
                .iter()
                .map(|(name, v)| {
                    let id = parse_id(name, &at)?;
                    let v = v
                        .as_float()
                        .filter(|v| v.is_finite() && *v > 0.0)
                        .ok_or_else(|| anyhow!("[{at}] {name}: expected a number > 0"))?;
                    Ok((id, v))
                })
                .collect::<Result<Vec<_>>>()?;
            minima.push(RigidMinimum {
                part: string(e, "part", &at)?,
                start: string(e, "start", &at)?,
                cost_above_kept: float(e, "cost_above_kept", &at)?,
                values,
            });
        }
        Ok(Some(Self {
            rigid_cost,
            residuals,
            residual_variance,
            cost_budget,
            minima,
        }))
    }
}
