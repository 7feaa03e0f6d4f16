//! What the data determine at a fit's minimum: per free parameter whether it has an
//! effect, whether it lies mostly in the weakly determined directions of the Jacobian, its
//! bound, and (determined ones) its standard error.

use nalgebra::DMatrix;
use supine_core::model::ParamId;

use super::{FitResult, NO_EFFECT_RATIO, Setup, WEAK_LOADING, WEAK_SINGULAR_RATIO, uncertainty};

/// What the data says about one parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Determination {
    /// The parameter has no effect on the fitted components at all.
    NoEffect,
    /// It lies mostly in directions the data barely constrains.
    Weak,
    /// The data determines it.
    Determined,
}

impl Determination {
    /// `none`, `weak` or `determined`.
    pub const fn name(self) -> &'static str {
        match self {
            Determination::NoEffect => "none",
            Determination::Weak => "weak",
            Determination::Determined => "determined",
        }
    }
}

/// Which bound a parameter ended on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtBound {
    /// On its lower bound.
    Lower,
    /// On its upper bound.
    Upper,
}

/// One free parameter's summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSummary {
    /// Which parameter.
    pub id: ParamId,
    /// Fitted value (in `id.unit()`).
    pub value: f64,
    /// Whether it ended on a bound (within 1e-6 in ln p).
    pub at_bound: Option<AtBound>,
    /// Jacobian column norm over the largest (sensitivity of the residuals to ln p).
    pub sensitivity: f64,
    /// Share of the parameter in the weakly determined directions, 0..=1.
    pub weak_loading: f64,
    /// The verdict.
    pub determination: Determination,
    /// Standard error of ln p ([`uncertainty`]); determined parameters only.
    pub standard_error: Option<f64>,
}

impl ParamSummary {
    /// The 95 % interval of the value, for a determined parameter.
    pub fn interval_95(&self) -> Option<(f64, f64)> {
        self.standard_error
            .map(|se| uncertainty::interval_95(self.value, se))
    }
}

/// Identifiability from the Jacobian at the solution (in ln p).
#[derive(Clone, Debug, PartialEq)]
pub struct Identifiability {
    /// Singular values of J, largest first.
    pub singular_values: Vec<f64>,
    /// Per free parameter, in the fit's order.
    pub params: Vec<ParamSummary>,
    /// The linearized covariance of ln p (None with no more residuals than unknowns).
    pub covariance: Option<uncertainty::Covariance>,
}

/// Classifies every free parameter: no effect (zero Jacobian column), weak (mostly in the
/// span of right singular vectors with singular value below 1e-3 of the largest), or
/// determined; and flags those on a bound.
pub fn identifiability(setup: &Setup, result: &FitResult) -> Identifiability {
    let jac = &result.solution.jacobian;
    let n = jac.ncols();
    let norms: Vec<f64> = (0..n).map(|j| jac.column(j).norm()).collect();
    let max_norm = norms
        .iter()
        .copied()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let svd = jac.clone().svd(false, true);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let singular_values: Vec<f64> = order.iter().map(|&k| svd.singular_values[k]).collect();
    let s_max = singular_values.first().copied().unwrap_or(0.0);
    // One SVD for both: the same as the covariance's own (`Covariance::at_minimum`).
    let covariance = uncertainty::Covariance::from_svd(&svd, jac.nrows(), result.solution.cost);
    let v_t = svd.v_t.unwrap_or_else(|| DMatrix::zeros(0, n));
    let standard_errors = covariance.as_ref().map(|c| c.standard_errors());
    let params = (0..n)
        .map(|j| {
            let id = setup.objective.free[j];
            let theta = result.solution.x[j];
            let at_bound = if theta <= setup.lower[j] + 1e-6 {
                Some(AtBound::Lower)
            } else if theta >= setup.upper[j] - 1e-6 {
                Some(AtBound::Upper)
            } else {
                None
            };
            let weak_loading: f64 = (0..v_t.nrows())
                .filter(|&k| svd.singular_values[k] < WEAK_SINGULAR_RATIO * s_max)
                .map(|k| v_t[(k, j)].powi(2))
                .sum();
            let sensitivity = norms[j] / max_norm;
            let determination = if sensitivity < NO_EFFECT_RATIO {
                Determination::NoEffect
            } else if weak_loading > WEAK_LOADING {
                Determination::Weak
            } else {
                Determination::Determined
            };
            let standard_error = match (&standard_errors, determination) {
                (Some(se), Determination::Determined) => Some(se[j]),
                _ => None,
            };
            ParamSummary {
                id,
                value: theta.exp(),
                at_bound,
                sensitivity,
                weak_loading,
                determination,
                standard_error,
            }
        })
        .collect();
    Identifiability {
        covariance,
        singular_values,
        params,
    }
}
