//! What the data determine at a fit's minimum: per free parameter whether it has an
//! effect, whether it lies mostly in the weakly determined directions of the Jacobian, its
//! bound, and (determined ones) its standard error.

use nalgebra::{DMatrix, DVector, Dyn, SVD};
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
    let svd = jacobian_svd(setup, jac);
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

/// The SVD of the fit's Jacobian (V^T only). The Jacobian is block diagonal over the fit's
/// parts (a part's parameters move only its own residuals, and the parameters of no part
/// move none), so its SVD is the union of the blocks' SVDs: each block's right singular
/// vectors in its own columns, and a zero singular value with a unit vector for each
/// column of no part. That is about a tenth of the whole matrix's work, on the one thread
/// left after the fit. A Jacobian with a non-zero entry outside the blocks gets the whole
/// matrix's SVD.
fn jacobian_svd(setup: &Setup, jac: &DMatrix<f64>) -> SVD<f64, Dyn, Dyn> {
    let whole = || jac.clone().svd(false, true);
    let (m, n) = jac.shape();
    let parts = setup.objective.subsystems();
    let (mut part_of_row, mut part_of_column) = (vec![None; m], vec![None; n]);
    for (k, part) in parts.iter().enumerate() {
        part.rows.iter().for_each(|&i| part_of_row[i] = Some(k));
        part.params
            .iter()
            .for_each(|&j| part_of_column[j] = Some(k));
    }
    let outside_zero = (0..n).all(|j| {
        (0..m).all(|i| {
            jac[(i, j)] == 0.0
                || (part_of_column[j].is_some() && part_of_column[j] == part_of_row[i])
        })
    });
    if !outside_zero {
        return whole();
    }
    let mut singular_values = Vec::with_capacity(n);
    let mut v_t = DMatrix::zeros(n, n);
    for part in &parts {
        let block = DMatrix::from_fn(part.rows.len(), part.params.len(), |i, j| {
            jac[(part.rows[i], part.params[j])]
        });
        let svd = block.svd(false, true);
        let Some(block_v_t) = svd.v_t else {
            return whole();
        };
        for (k, &s) in svd.singular_values.iter().enumerate() {
            for (j, &column) in part.params.iter().enumerate() {
                v_t[(singular_values.len(), column)] = block_v_t[(k, j)];
            }
            singular_values.push(s);
        }
    }
    for column in (0..n).filter(|&j| part_of_column[j].is_none()) {
        v_t[(singular_values.len(), column)] = 1.0;
        singular_values.push(0.0);
    }
    if singular_values.len() != n {
        // A block with fewer rows than columns: its SVD is short.
        return whole();
    }
    SVD {
        u: None,
        v_t: Some(v_t),
        singular_values: DVector::from_vec(singular_values),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::objective::perturbed_target;
    use crate::identify::fit::{FitSettings, rigid_setup};
    use supine_core::model::{ModelParams, Preset};

    /// The rigid fit's problem against a perturbed model's H, and its Jacobian at the
    /// paper's values.
    fn setup_and_jacobian() -> (Setup, DMatrix<f64>) {
        let freqs_hz: Vec<f64> = (0..60).map(|k| 0.5 + 0.25 * k as f64).collect();
        let subject = ModelParams::preset(Preset::PaperRigid).subject;
        let target = perturbed_target(freqs_hz);
        let setup = rigid_setup(target, subject, &FitSettings::default()).unwrap();
        let theta = setup.starts[0].theta.clone();
        let objective = &setup.objective;
        let mut r = vec![0.0; objective.residual_count()];
        let mut jac = DMatrix::zeros(r.len(), objective.param_count());
        objective.evaluate(&theta, &mut r, Some(&mut jac)).unwrap();
        (setup, jac)
    }

    /// The projector onto the span of the right singular vectors with singular value at
    /// least `floor`, and those values, sorted: what the fit reads from an SVD.
    fn spectrum(svd: &SVD<f64, Dyn, Dyn>, floor: f64) -> (Vec<f64>, DMatrix<f64>) {
        let v_t = svd.v_t.as_ref().unwrap();
        let n = v_t.ncols();
        let mut values: Vec<f64> = svd.singular_values.iter().copied().collect();
        values.sort_by(|a, b| b.total_cmp(a));
        let mut projector = DMatrix::zeros(n, n);
        for (k, &s) in svd.singular_values.iter().enumerate() {
            if s >= floor {
                let v = v_t.row(k).transpose();
                projector += &v * v.transpose();
            }
        }
        (values, projector)
    }

    #[test]
    fn the_blocks_svd_is_the_whole_jacobians() {
        let (setup, jac) = setup_and_jacobian();
        let blocks = jacobian_svd(&setup, &jac);
        let whole = jac.clone().svd(false, true);
        let s_max = whole.singular_values.max();
        assert_eq!(blocks.singular_values.len(), jac.ncols());
        let (blocks_values, blocks_projector) = spectrum(&blocks, 1e-6 * s_max);
        let (whole_values, whole_projector) = spectrum(&whole, 1e-6 * s_max);
        for (a, b) in blocks_values.iter().zip(&whole_values) {
            assert!((a - b).abs() <= 1e-12 * s_max, "{a} against {b}");
        }
        // Four roll parameters move nothing: four zero singular values (to rounding).
        assert_eq!(blocks_values.iter().filter(|&&s| s == 0.0).count(), 4);
        assert!((&blocks_projector - &whole_projector).amax() < 1e-8);
        // V is orthogonal.
        let v_t = blocks.v_t.unwrap();
        let identity = DMatrix::<f64>::identity(v_t.nrows(), v_t.nrows());
        assert!((&v_t * v_t.transpose() - identity).amax() < 1e-12);
    }

    #[test]
    fn a_jacobian_that_is_not_block_diagonal_gets_the_whole_svd() {
        let (setup, mut jac) = setup_and_jacobian();
        // Couple the first part's first row to a parameter of another part.
        let parts = setup.objective.subsystems();
        jac[(parts[0].rows[0], parts[1].params[0])] = 1.0;
        let svd = jacobian_svd(&setup, &jac);
        let whole = jac.clone().svd(false, true);
        assert_eq!(svd.singular_values, whole.singular_values);
    }
}
