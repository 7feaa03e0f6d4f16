//! How sure a fit is: the linearized (Gauss-Newton) covariance of the solver's unknowns
//! theta = ln p at the minimum, cov = s^2 (J^T J)^+, with the residual variance
//! s^2 = 2 cost / (m - n) estimated from the fit itself (m residuals, n unknowns).
//!
//! The pseudo-inverse keeps the directions the data determine: right singular vectors of J
//! whose singular value is at least [`super::WEAK_SINGULAR_RATIO`] of the largest, the same
//! cut that calls a parameter weakly determined. Along the other directions the data say
//! next to nothing and the linearization does not hold (one standard error there is a
//! factor of e^3 or more in p), so they get no variance here: the standard errors and the
//! prediction band describe the determined directions only (docs/model.md#uncertainty-of-a-fit).
//!
//! Intervals: theta +- 1.96 standard errors (the normal quantile: m - n is in the
//! thousands), mapped to p as p e^(+-1.96 se), so they are asymmetric in p and stay
//! positive.

use anyhow::{Result, anyhow, bail};
use nalgebra::{DMatrix, DVector, Dyn, SVD};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use supine_core::model::{ModelParams, ParamId};

use super::WEAK_SINGULAR_RATIO;

/// The two-sided 95 % quantile of the standard normal distribution.
pub const Z_95: f64 = 1.959_963_984_540_054;

/// The linearized covariance of theta = ln p at a minimum.
#[derive(Clone, Debug, PartialEq)]
pub struct Covariance {
    /// s^2 = 2 cost / (m - n).
    pub residual_variance: f64,
    /// m - n.
    pub degrees_of_freedom: usize,
    /// s^2 (J^T J)^+ over the determined directions, n x n, in the unknowns' order.
    pub matrix: DMatrix<f64>,
}

impl Covariance {
    /// From the Jacobian d r / d theta and the cost 0.5 |r|^2 at the minimum. None when
    /// there are no more residuals than unknowns (no residual variance to estimate).
    pub fn at_minimum(jacobian: &DMatrix<f64>, cost: f64) -> Option<Self> {
        let (m, n) = jacobian.shape();
        if m <= n {
            return None;
        }
        Self::from_svd(&jacobian.clone().svd(false, true), m, cost)
    }

    /// Like [`Covariance::at_minimum`], from the SVD of the m x n Jacobian (V^T computed)
    /// when the caller has it already (the fit's identifiability needs the same one).
    pub fn from_svd(svd: &SVD<f64, Dyn, Dyn>, m: usize, cost: f64) -> Option<Self> {
        let v_t = svd.v_t.as_ref()?;
        let n = v_t.ncols();
        if m <= n {
            return None;
        }
        let degrees_of_freedom = m - n;
        let residual_variance = 2.0 * cost / degrees_of_freedom as f64;
        let s_max = svd.singular_values.max();
        let mut matrix = DMatrix::zeros(n, n);
        for (k, &s) in svd.singular_values.iter().enumerate() {
            if s > 0.0 && s >= WEAK_SINGULAR_RATIO * s_max {
                let v = v_t.row(k).transpose();
                matrix += (residual_variance / (s * s)) * &v * v.transpose();
            }
        }
        Some(Self {
            residual_variance,
            degrees_of_freedom,
            matrix,
        })
    }

    /// Standard error of each unknown (ln p).
    pub fn standard_errors(&self) -> Vec<f64> {
        (0..self.matrix.nrows())
            .map(|i| self.matrix[(i, i)].max(0.0).sqrt())
            .collect()
    }

    /// The covariance of a subset of the unknowns (their marginal distribution).
    pub fn subset(&self, indices: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(indices.len(), indices.len(), |a, b| {
            self.matrix[(indices[a], indices[b])]
        })
    }
}

/// The 95 % interval of a parameter with value `p` and standard error `se` in ln p.
pub fn interval_95(p: f64, se: f64) -> (f64, f64) {
    (p * (-Z_95 * se).exp(), p * (Z_95 * se).exp())
}

/// Draws from N(mean, covariance) for a symmetric positive semi-definite covariance
/// (negative eigenvalues from rounding count as zero).
#[derive(Clone, Debug)]
pub struct GaussianDraws {
    mean: DVector<f64>,
    /// Eigenvectors scaled by the square roots of their eigenvalues: x = mean + L z.
    factor: DMatrix<f64>,
}

impl GaussianDraws {
    /// Fails (None) when the sizes disagree or an entry is not finite.
    pub fn new(mean: &[f64], covariance: &DMatrix<f64>) -> Option<Self> {
        let n = mean.len();
        if covariance.shape() != (n, n) || covariance.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let symmetric = 0.5 * (covariance + covariance.transpose());
        let eigen = symmetric.symmetric_eigen();
        let mut factor = eigen.eigenvectors;
        for (k, &lambda) in eigen.eigenvalues.iter().enumerate() {
            factor.column_mut(k).scale_mut(lambda.max(0.0).sqrt());
        }
        Some(Self {
            mean: DVector::from_column_slice(mean),
            factor,
        })
    }

    /// One draw.
    pub fn sample(&self, rng: &mut impl Rng) -> Vec<f64> {
        let z = DVector::from_fn(self.mean.len(), |_, _| StandardNormal.sample(rng));
        (&self.mean + &self.factor * z).as_slice().to_vec()
    }
}

/// What the parameter file keeps of a fit's uncertainty (`[fit.uncertainty]`): the
/// determined parameters' standard errors and 95 % intervals (for reading) and their
/// correlation (their marginal distribution, for drawing parameter sets). Files written
/// before it existed have none.
///
/// Layout: `parameters` gives the order; `standard_error_ln_p`, `interval_95_low` and
/// `interval_95_high` are tables by parameter name; `correlation` holds one row per
/// parameter as a string of space-separated numbers in `parameters`' order (the file's
/// pretty printer would give every number of an array a line of its own).
#[derive(Clone, Debug, PartialEq)]
pub struct StoredUncertainty {
    /// s^2 = 2 cost / (m - n).
    pub residual_variance: f64,
    /// m - n.
    pub degrees_of_freedom: usize,
    /// The determined parameters, in the covariance's order.
    pub parameters: Vec<ParamId>,
    /// Their covariance in ln p.
    pub covariance_ln_p: DMatrix<f64>,
}

/// The `[fit]` table's key of the uncertainty.
pub const FIT_KEY: &str = "uncertainty";

/// The parameter named `name` in the `[fit]` sub-table `table` (named in the error).
pub fn parse_id(name: &str, table: &str) -> Result<ParamId> {
    ParamId::ALL
        .into_iter()
        .find(|id| id.to_string() == name)
        .ok_or_else(|| anyhow!("[{table}]: unknown parameter {name}"))
}

impl StoredUncertainty {
    /// The determined parameters' part of `covariance`; `free` are the fit's unknowns.
    pub fn of(covariance: &Covariance, free: &[ParamId], determined: &[usize]) -> Self {
        Self {
            residual_variance: covariance.residual_variance,
            degrees_of_freedom: covariance.degrees_of_freedom,
            parameters: determined.iter().map(|&i| free[i]).collect(),
            covariance_ln_p: covariance.subset(determined),
        }
    }

    /// Standard errors of ln p, in `parameters`' order.
    pub fn standard_errors(&self) -> Vec<f64> {
        (0..self.parameters.len())
            .map(|i| self.covariance_ln_p[(i, i)].max(0.0).sqrt())
            .collect()
    }

    /// The table (see the type's documentation); `params` gives the fitted values.
    pub fn to_toml(&self, params: &ModelParams) -> toml::Table {
        let se = self.standard_errors();
        let by_name = |values: &mut dyn Iterator<Item = f64>| -> toml::Value {
            let mut t = toml::Table::new();
            for (id, v) in self.parameters.iter().zip(values) {
                t.insert(id.to_string(), v.into());
            }
            t.into()
        };
        let intervals: Vec<(f64, f64)> = self
            .parameters
            .iter()
            .zip(&se)
            .map(|(&id, &s)| interval_95(params.get(id), s))
            .collect();
        let mut correlation = toml::Table::new();
        for (i, id) in self.parameters.iter().enumerate() {
            let row: Vec<String> = (0..self.parameters.len())
                .map(|j| {
                    let r = self.covariance_ln_p[(i, j)] / (se[i] * se[j]);
                    // Exact zeros between uncoupled blocks stay short.
                    if !r.is_finite() || r.abs() < 5e-10 {
                        "0".to_string()
                    } else {
                        format!("{r:.9}")
                    }
                })
                .collect();
            correlation.insert(id.to_string(), row.join(" ").into());
        }
        let mut t = toml::Table::new();
        t.insert("residual_variance".into(), self.residual_variance.into());
        t.insert(
            "degrees_of_freedom".into(),
            (self.degrees_of_freedom as i64).into(),
        );
        let names = self.parameters.iter().map(|id| id.to_string().into());
        t.insert("parameters".into(), toml::Value::Array(names.collect()));
        t.insert(
            "standard_error_ln_p".into(),
            by_name(&mut se.iter().copied()),
        );
        t.insert(
            "interval_95_low".into(),
            by_name(&mut intervals.iter().map(|i| i.0)),
        );
        t.insert(
            "interval_95_high".into(),
            by_name(&mut intervals.iter().map(|i| i.1)),
        );
        t.insert("correlation".into(), correlation.into());
        t
    }

    /// Reads `[fit.uncertainty]`; None when the file has none (written before it existed,
    /// or a preset).
    pub fn from_fit_table(fit: Option<&toml::Table>) -> Result<Option<Self>> {
        let Some(value) = fit.and_then(|f| f.get(FIT_KEY)) else {
            return Ok(None);
        };
        let t = value
            .as_table()
            .ok_or_else(|| anyhow!("[fit.uncertainty]: expected a table"))?;
        let get = |key: &str| {
            t.get(key)
                .ok_or_else(|| anyhow!("[fit.uncertainty]: expected {key}"))
        };
        let table = |key: &str| {
            get(key)?
                .as_table()
                .ok_or_else(|| anyhow!("[fit.uncertainty] {key}: expected a table"))
        };
        let parameters = get("parameters")?
            .as_array()
            .ok_or_else(|| anyhow!("[fit.uncertainty] parameters: expected names"))?
            .iter()
            .map(|v| parse_id(v.as_str().unwrap_or_default(), "fit.uncertainty"))
            .collect::<Result<Vec<_>>>()?;
        let standard_errors = table("standard_error_ln_p")?;
        let correlation = table("correlation")?;
        let n = parameters.len();
        let mut se = Vec::with_capacity(n);
        for id in &parameters {
            let v = standard_errors
                .get(&id.to_string())
                .and_then(toml::Value::as_float)
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| anyhow!("[fit.uncertainty] standard_error_ln_p: {id}"))?;
            se.push(v);
        }
        let mut covariance_ln_p = DMatrix::zeros(n, n);
        for (i, id) in parameters.iter().enumerate() {
            let row = correlation
                .get(&id.to_string())
                .and_then(toml::Value::as_str)
                .ok_or_else(|| anyhow!("[fit.uncertainty] correlation: expected {id}"))?;
            let values: Vec<f64> = row
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|e| anyhow!("[fit.uncertainty] correlation {id}: {e}"))?;
            if values.len() != n {
                bail!("[fit.uncertainty] correlation {id}: expected {n} numbers");
            }
            for (j, r) in values.into_iter().enumerate() {
                covariance_ln_p[(i, j)] = r * se[i] * se[j];
            }
        }
        let residual_variance = get("residual_variance")?
            .as_float()
            .ok_or_else(|| anyhow!("[fit.uncertainty] residual_variance: expected a number"))?;
        let degrees_of_freedom = get("degrees_of_freedom")?
            .as_integer()
            .and_then(|d| usize::try_from(d).ok())
            .ok_or_else(|| anyhow!("[fit.uncertainty] degrees_of_freedom: expected a count"))?;
        Ok(Some(Self {
            residual_variance,
            degrees_of_freedom,
            parameters,
            covariance_ln_p,
        }))
    }
}
