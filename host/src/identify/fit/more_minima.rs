//! The rigid fit's search continued by the litter-board fit: more random starts on the
//! dataset's rigid recordings, for more rigid minima to explore ([`super::explore`]).
//!
//! Why here and not in the rigid fit: the rigid fit's own result is its lowest minimum,
//! which a few starts find; what the pipeline needs besides is the other minima its data
//! cannot tell apart, and those only more starts find. The rigid command stays as fast as
//! its own problem needs, and the pipeline pays for the search it needs
//! (docs/model.md#the-pipeline-over-the-rigid-fits-minima). The starts continue the rigid
//! fit's own sequence (the same seed, the random starts after its last one, the paper's
//! values run again as the anchors the economy measures against), so the search is the
//! rigid fit with `rigid starts + more` starts, none of its runs repeated but the anchors.

use anyhow::{Result, anyhow, bail};
use supine_core::model::{ModelParams, Subject};

use super::minima::{MOST_EXPLORED_PER_PART, RigidMinima, RigidMinimum, same_minimum};
use super::objective::Target;
use super::{FitSettings, Progress, rigid_setup, run};

/// Relative difference allowed between the rigid file's cost and its parameters' cost on
/// the dataset's rigid recordings: the same data, read again, give the same cost up to
/// the rounding of the parameters' decimal text.
const SAME_DATA_RELATIVE: f64 = 1e-7;

/// What the continued search was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoreStarts {
    /// The rigid fit's own starts (its random starts are not run again).
    pub rigid_starts: usize,
    /// The seed of the rigid fit's random starts.
    pub seed: u64,
    /// The random starts run after them.
    pub more: usize,
}

/// `stored` and the minima of `more.more` further random starts of the rigid fit on
/// `target` (the rigid case's measured H, `subject` its mean subject), the rigid fit's
/// parameters `kept`. Each part keeps its lowest [`MOST_EXPLORED_PER_PART`] distinct minima
/// besides the kept one; a minimum below the kept one has a negative rise.
pub fn with_more_starts(
    target: Target,
    subject: Subject,
    kept: &ModelParams,
    stored: &RigidMinima,
    more: MoreStarts,
    settings: &FitSettings,
    progress: Progress,
) -> Result<RigidMinima> {
    if more.more == 0 {
        return Ok(stored.clone());
    }
    let search = FitSettings {
        starts: more.rigid_starts + more.more,
        seed: more.seed,
        polish: false,
        ..*settings
    };
    let mut setup = rigid_setup(target, subject, &search)?;
    // The search is for its starts' minima; the rigid fit's probes ran with it.
    setup.probes.clear();
    let rigid_starts = more.rigid_starts;
    let mut index = 0;
    setup.starts.retain(|s| {
        index += 1;
        s.anchor || index > rigid_starts
    });
    let objective = &setup.objective;
    let kept_theta = objective.theta(kept);
    let kept_cost = objective.cost(&kept_theta).map_err(|e| anyhow!("{e}"))?;
    if (kept_cost - stored.rigid_cost).abs() > SAME_DATA_RELATIVE * stored.rigid_cost {
        bail!(
            "the rigid fit's cost {:.6} is {kept_cost:.6} on this dataset's rigid recordings: expected the dataset it was fitted on (or --explore-starts 0)",
            stored.rigid_cost
        );
    }
    let result = run(&setup, &search, progress)?;

    let mut minima = Vec::new();
    for part in &result.parts {
        let mut of_part: Vec<RigidMinimum> = stored
            .minima
            .iter()
            .filter(|m| m.part == part.name)
            .cloned()
            .collect();
        // ln p of every minimum of the part listed so far: the kept one, then the options.
        let mut known: Vec<Vec<f64>> =
            std::iter::once(part.free.iter().map(|&j| kept_theta[j]).collect())
                .chain(
                    of_part
                        .iter()
                        .map(|m| m.values.iter().map(|(_, v)| v.ln()).collect()),
                )
                .collect();
        for (i, x) in part.minima.iter().enumerate() {
            let start = &setup.starts[i];
            let converged = part.starts[i].termination.at_minimum();
            if start.anchor || !converged || known.iter().any(|y| same_minimum(x, y)) {
                continue;
            }
            known.push(x.clone());
            let mut theta = kept_theta.clone();
            for (&j, &t) in part.free.iter().zip(x) {
                theta[j] = t;
            }
            let cost = objective.cost(&theta).map_err(|e| anyhow!("{e}"))?;
            of_part.push(RigidMinimum::of_part(
                part,
                &start.label,
                cost - kept_cost,
                &objective.free,
                x,
            ));
        }
        of_part.sort_by(|a, b| a.cost_above_kept.total_cmp(&b.cost_above_kept));
        of_part.truncate(MOST_EXPLORED_PER_PART);
        minima.extend(of_part);
    }
    Ok(RigidMinima {
        minima,
        ..stored.clone()
    })
}
