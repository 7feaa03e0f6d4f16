//! The litter-board fit over the rigid fit's minima ([`RigidMinima`]): the pipeline's
//! result, not only each stage's.
//!
//! Each part's litter-board cost depends only on that part's rigid parameters (its joints
//! and the contacts that bound it), so every part's options are fitted once: the kept
//! rigid minimum and each alternative (stored by the rigid fit, or found by continuing its
//! search, [`super::more_minima`]). Rank r fits, in one litter-board fit, every part's r-th
//! option. The pipeline then keeps, over every combination of the parts' options, the
//! one with the lowest litter-board cost (the lower rigid cost on a tie), and refits it as
//! a whole: every option is a minimum of the rigid problem, as the joints of a two-stage
//! pipeline are (SciPy's own is one of them), and the litter-board data choose among
//! them. With [`Region::Within`] only the combinations within the rigid fit's 95 %
//! confidence region (which its data cannot tell from its own minimum) are compared.
//! Every fit is the deterministic
//! [`super::run`], so the choice and the result are the same bits whatever the number of
//! threads (docs/model.md#the-pipeline-over-the-rigid-fits-minima).

use anyhow::{Result, bail};
use supine_core::model::{ModelParams, Subject};

use super::minima::{self, RigidMinima};
use super::objective::Target;
use super::{FitResult, FitSettings, Progress, Setup, litter_setup, run};

/// The litter-board `[fit]` table's key of what was explored.
pub const FIT_KEY: &str = "rigid_minima_explored";
/// The label of the kept rigid minimum among a part's options.
pub const KEPT: &str = "kept rigid fit";
/// Most combinations of the parts' options compared (MOST_EXPLORED_PER_PART + 1 per part
/// over 3 parts is 35,937).
const MOST_COMBINATIONS: usize = 1 << 16;

/// Which rigid minima the pipeline may keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// Every converged minimum of the rigid problem.
    Any,
    /// Only those within the rigid fit's 95 % confidence region.
    Within,
}

/// One option of one part: a rigid minimum and the litter-board cost it leads to.
#[derive(Clone, Debug, PartialEq)]
pub struct PartOption {
    /// The part.
    pub part: String,
    /// The start the rigid minimum came from ([`KEPT`] for the kept one).
    pub start: String,
    /// Its rigid cost above the kept minimum's.
    pub rigid_cost_above_kept: f64,
    /// This part's litter-board cost on it.
    pub litter_cost: f64,
    /// Whether the pipeline kept it.
    pub kept: bool,
}

/// What the exploration compared and what it kept.
#[derive(Clone, Debug, PartialEq)]
pub struct Exploration {
    /// The rigid fit's 95 % confidence region: the rise of its cost its data cannot tell
    /// from its minimum.
    pub cost_budget: f64,
    /// Which minima the pipeline could keep.
    pub region: Region,
    /// Every part's options, by part.
    pub options: Vec<PartOption>,
    /// The rigid parameters of the kept pair (the joints and the contacts' bounds).
    pub rigid: ModelParams,
    /// Their rigid cost.
    pub rigid_cost: f64,
    /// Their rigid cost above the rigid fit's.
    pub rigid_cost_above_kept: f64,
}

/// A part's litter-board cost in `result`: its polish's, or its kept start's.
fn part_cost(result: &FitResult, name: &str) -> Option<f64> {
    let part = result.parts.iter().find(|p| p.name == name)?;
    Some(
        part.polish
            .as_ref()
            .map_or(part.starts[part.best].final_cost, |p| p.final_cost),
    )
}

/// The litter-board fit on `rigid` and on each of its other `minima`: the setup and result
/// of the kept pair, and what was compared.
pub fn litter_over_minima(
    target: &Target,
    subject: Subject,
    rigid: &ModelParams,
    minima: &RigidMinima,
    region: Region,
    settings: &FitSettings,
    progress: Progress,
) -> Result<(Setup, FitResult, Exploration)> {
    // Per part: its options, the kept rigid minimum first.
    let mut parts: Vec<(String, Vec<Option<usize>>)> = Vec::new();
    for (i, m) in minima.minima.iter().enumerate() {
        match parts.iter_mut().find(|(name, _)| *name == m.part) {
            Some((_, options)) => options.push(Some(i)),
            None => parts.push((m.part.clone(), vec![None, Some(i)])),
        }
    }
    let count: usize = parts.iter().map(|(_, o)| o.len()).product();
    if count > MOST_COMBINATIONS {
        bail!(
            "[fit.rigid_minima]: {count} combinations of rigid minima, expected at most {MOST_COMBINATIONS}"
        );
    }
    let params_of = |choice: &[usize]| {
        let mut p = *rigid;
        for ((_, options), &c) in parts.iter().zip(choice) {
            if let Some(i) = options[c] {
                minima.minima[i].apply(&mut p);
            }
        }
        p
    };
    let fit = |params: &ModelParams| -> Result<(Setup, FitResult)> {
        let setup = litter_setup(target.clone(), subject, params, settings)?;
        let result = run(&setup, settings, progress)?;
        Ok((setup, result))
    };

    // Rank r: every part's r-th option (or its kept one) in one fit.
    let ranks = parts.iter().map(|(_, o)| o.len()).max().unwrap_or(1);
    let mut litter_costs: Vec<Vec<f64>> = parts.iter().map(|_| Vec::new()).collect();
    let mut first: Option<(Setup, FitResult)> = None;
    for r in 0..ranks {
        let choice: Vec<usize> = parts
            .iter()
            .map(|(_, o)| if r < o.len() { r } else { 0 })
            .collect();
        let (setup, result) = fit(&params_of(&choice))?;
        for (k, (name, options)) in parts.iter().enumerate() {
            if r < options.len() {
                match part_cost(&result, name) {
                    Some(c) => litter_costs[k].push(c),
                    None => bail!("the litter-board fit has no part {name}"),
                }
            }
        }
        if r == 0 {
            first = Some((setup, result));
        }
    }
    let Some(first) = first else {
        bail!("the litter-board fit ran on no rigid minimum");
    };
    // The parts without another rigid minimum: the same cost in every combination.
    let unexplored: f64 = first
        .1
        .parts
        .iter()
        .filter(|p| !parts.iter().any(|(n, _)| *n == p.name))
        .filter_map(|p| part_cost(&first.1, &p.name))
        .sum();

    // Every combination (within the rigid fit's confidence region if asked); the lowest
    // litter-board cost, the lower rise on a tie (the first, the kept rigid minimum's, on
    // a full tie).
    let most_rise = match region {
        Region::Any => f64::INFINITY,
        Region::Within => minima.cost_budget,
    };
    let above =
        |k: usize, c: usize| parts[k].1[c].map_or(0.0, |i| minima.minima[i].cost_above_kept);
    let mut best: Option<((f64, f64), Vec<usize>)> = None;
    for index in 0..count {
        let mut rest = index;
        let choice: Vec<usize> = parts
            .iter()
            .map(|(_, o)| {
                let c = rest % o.len();
                rest /= o.len();
                c
            })
            .collect();
        let rise: f64 = choice.iter().enumerate().map(|(k, &c)| above(k, c)).sum();
        if rise > most_rise {
            continue;
        }
        let litter: f64 = unexplored
            + choice
                .iter()
                .enumerate()
                .map(|(k, &c)| litter_costs[k][c])
                .sum::<f64>();
        let score = (litter, rise);
        if best.as_ref().is_none_or(|(b, _)| score < *b) {
            best = Some((score, choice));
        }
    }
    let choice = best.map_or_else(|| vec![0; parts.len()], |(_, c)| c);

    let rigid_kept = params_of(&choice);
    let (setup, result) = if choice.iter().all(|&c| c == 0) {
        first
    } else {
        fit(&rigid_kept)?
    };
    let mut options = Vec::new();
    for (k, (name, part_options)) in parts.iter().enumerate() {
        for (c, option) in part_options.iter().enumerate() {
            options.push(PartOption {
                part: name.clone(),
                start: option.map_or_else(|| KEPT.to_string(), |i| minima.minima[i].start.clone()),
                rigid_cost_above_kept: above(k, c),
                litter_cost: litter_costs[k][c],
                kept: choice[k] == c,
            });
        }
    }
    // The parts without another rigid minimum: their kept one, for a complete account.
    for part in result
        .parts
        .iter()
        .filter(|p| !parts.iter().any(|(n, _)| *n == p.name))
    {
        if let Some(litter_cost) = part_cost(&result, &part.name) {
            options.push(PartOption {
                part: part.name.clone(),
                start: KEPT.to_string(),
                rigid_cost_above_kept: 0.0,
                litter_cost,
                kept: true,
            });
        }
    }
    let rigid_cost_above_kept: f64 = choice.iter().enumerate().map(|(k, &c)| above(k, c)).sum();
    Ok((
        setup,
        result,
        Exploration {
            cost_budget: minima.cost_budget,
            region,
            options,
            rigid: rigid_kept,
            rigid_cost: minima.rigid_cost + rigid_cost_above_kept,
            rigid_cost_above_kept,
        },
    ))
}

impl Exploration {
    /// The report's section: every option, and which the pipeline kept.
    pub fn markdown(&self) -> String {
        use std::fmt::Write as _;
        let mut s = format!(
            "\nThe rigid fit's other minima were each given to the litter-board fit, part by part; {}, the one kept (*) has the lowest litter-board cost. Its rigid cost {:.6} is {:.6} above the rigid fit's, {} the rigid fit's 95 % confidence region ({:.6}: {}).\n\n| part | rigid minimum from | rigid cost above the kept | litter-board cost of the part |\n|---|---|---|---|\n",
            match self.region {
                Region::Any =>
                    "of every pair of a converged rigid minimum and its litter-board fit",
                Region::Within => {
                    "of the pairs within the rigid fit's 95 % confidence region (--within-region)"
                }
            },
            self.rigid_cost,
            self.rigid_cost_above_kept,
            if self.rigid_cost_above_kept <= self.cost_budget {
                "within"
            } else {
                "beyond"
            },
            self.cost_budget,
            minima::REGION_RULE
        );
        for o in &self.options {
            let mark = if o.kept { " *" } else { "" };
            let _ = writeln!(
                s,
                "| {} | {}{mark} | {:.6} | {:.6} |",
                o.part, o.start, o.rigid_cost_above_kept, o.litter_cost
            );
        }
        s
    }

    /// The litter-board parameter file's `[fit.rigid_minima_explored]` table ([`FIT_KEY`]).
    pub fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert("cost_budget".into(), self.cost_budget.into());
        t.insert(
            "within_region".into(),
            (self.region == Region::Within).into(),
        );
        t.insert("rigid_cost".into(), self.rigid_cost.into());
        t.insert(
            "rigid_cost_above_kept".into(),
            self.rigid_cost_above_kept.into(),
        );
        let options: Vec<toml::Value> = self
            .options
            .iter()
            .map(|o| {
                let mut e = toml::Table::new();
                e.insert("part".into(), o.part.clone().into());
                e.insert("start".into(), o.start.clone().into());
                e.insert(
                    "rigid_cost_above_kept".into(),
                    o.rigid_cost_above_kept.into(),
                );
                e.insert("litter_cost".into(), o.litter_cost.into());
                e.insert("kept".into(), o.kept.into());
                e.into()
            })
            .collect();
        t.insert("option".into(), options.into());
        t
    }
}
