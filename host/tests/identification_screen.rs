//! The multi-start fit's screen (docs/model.md#unknowns-bounds-and-starts): every random
//! start runs the screen's iterations, only the lowest of each part run on to their
//! minima, and the result does not depend on the number of threads.

use supine_core::model::SystemMatrices;
use supine_host::identify::fit::minima::RigidMinima;
use supine_host::identify::fit::objective::Target;
use supine_host::identify::fit::solver::Termination;
use supine_host::identify::fit::{self, FitResult, FitSettings, Screen, Setup};

use crate::common::perturbed_truth;

/// Six iterations, then two random starts a part run on.
const SCREEN: Screen = Screen {
    iterations: 6,
    continued: 2,
};

/// The exact H of a perturbed truth on a coarse grid: a rigid problem whose random starts
/// end in several minima.
fn target() -> Target {
    let matrices = SystemMatrices::assemble(&perturbed_truth());
    let freqs_hz: Vec<f64> = (0..40).map(|k| 0.5 + 0.4 * k as f64).collect();
    let h = freqs_hz
        .iter()
        .map(|&f| matrices.transmissibility(f).unwrap())
        .collect();
    Target { freqs_hz, h }
}

/// The rigid fit from the paper's two anchors and eight random starts.
fn fit(screen: Option<Screen>, threads: usize) -> (Setup, FitResult) {
    let settings = FitSettings {
        starts: 10,
        threads,
        screen,
        ..FitSettings::default()
    };
    let setup = fit::rigid_setup(target(), perturbed_truth().subject, &settings).unwrap();
    let result = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
    (setup, result)
}

/// Per part: the anchors run to their ends; of the random starts at most `continued` run
/// past the screen's iterations, and every start left behind stopped exactly there, at a
/// cost no lower than any continued start's (the screen keeps the lowest, and running on
/// only lowers a cost); no start left behind is stored as a minimum.
#[test]
fn the_screen_runs_on_only_the_lowest_random_starts_of_each_part() {
    let (setup, result) = fit(Some(SCREEN), 0);
    let mut left_behind = 0;
    for part in &result.parts {
        let (anchors, random): (Vec<_>, Vec<_>) = part
            .starts
            .iter()
            .zip(&setup.starts)
            .partition(|(_, start)| start.anchor);
        assert_eq!((anchors.len(), random.len()), (2, 8));
        for (anchor, _) in &anchors {
            assert!(anchor.termination.at_minimum(), "{}", anchor.label);
        }
        let on: Vec<_> = random
            .iter()
            .map(|(s, _)| s)
            .filter(|s| s.iterations > SCREEN.iterations)
            .collect();
        assert!(
            on.len() <= SCREEN.continued,
            "{}: {} ran on",
            part.name,
            on.len()
        );
        for (s, _) in random
            .iter()
            .filter(|(s, _)| s.termination == Termination::Screened)
        {
            left_behind += 1;
            assert_eq!(s.iterations, SCREEN.iterations, "{}", s.label);
            for o in &on {
                assert!(
                    s.final_cost >= o.final_cost,
                    "{} below {}",
                    s.label,
                    o.label
                );
            }
        }
    }
    assert!(
        left_behind > 0,
        "eight random starts, two run on a part: some left behind"
    );
    for m in RigidMinima::of_fit(&setup, &result).minima {
        let part = result.parts.iter().find(|p| p.name == m.part).unwrap();
        let start = part.starts.iter().find(|s| s.label == m.start).unwrap();
        assert!(start.termination.at_minimum(), "{}: {}", m.part, m.start);
    }
}

/// The screen chooses from finished runs only, so one thread or three give the same bits
/// and the same runs; without a screen no start is left behind.
#[test]
fn the_screened_fit_is_the_same_on_any_thread_count_and_unscreened_leaves_none_behind() {
    let ((_, one), (_, three)) = (fit(Some(SCREEN), 1), fit(Some(SCREEN), 3));
    assert_eq!(one.solution.cost.to_bits(), three.solution.cost.to_bits());
    let bits = |r: &FitResult| r.solution.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&one), bits(&three));
    let runs = |r: &FitResult| {
        r.parts
            .iter()
            .flat_map(|p| &p.starts)
            .map(|s| {
                (
                    s.final_cost.to_bits(),
                    s.iterations,
                    s.evaluations,
                    s.termination,
                )
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(runs(&one), runs(&three));
    let (_, unscreened) = fit(None, 0);
    let ended = |s: &fit::StartOutcome| s.termination != Termination::Screened;
    assert!(unscreened.parts.iter().flat_map(|p| &p.starts).all(ended));
}
