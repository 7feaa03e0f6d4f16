//! The fit's report: a text summary (cost, starts, per-component error, parameters at a
//! bound, identifiability) and, with `--report DIR`, SVG plots in the paper's Fig. 3/4
//! layout (each fitted component's magnitude and phase: every subject in light grey, the
//! geometric mean in black, the fitted model in red) plus `summary.md`.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use supine_core::model::Transmissibility;
use supine_core::model::response::COUPLED_COMPONENTS;

use super::objective::COMPONENTS;
use super::{AtBound, FitResult, Identifiability, Setup};
use crate::identify::geomean::wrap_pi;
use crate::plot::{Panel, Series, figure_svg};

/// The paper's name of a component, e.g. `H13` (output 1..9, input 1..3).
pub fn component_name(c: usize) -> String {
    let (output, input) = COUPLED_COMPONENTS[c];
    format!(
        "H{}{} ({} / {})",
        output.index() + 1,
        input.index() + 1,
        output.name(),
        input.name()
    )
}

/// The summary as Markdown (also printed by `supine fit`).
pub fn summary(
    setup: &Setup,
    result: &FitResult,
    ident: &Identifiability,
    errors: &[(f64, f64); COMPONENTS],
    spectra_s: f64,
    solver_s: f64,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# supine fit: {} case\n", setup.case.name());
    let _ = writeln!(
        s,
        "final cost 0.5 sum r^2 = {:.6} over {} residuals ({} frequencies x 12 components x magnitude, phase), {} unknowns; reading and spectra {:.3} s, solver {:.3} s\n",
        result.solution.cost,
        result.solution.residuals.len(),
        setup.objective.target.freqs_hz.len(),
        setup.objective.free.len(),
        spectra_s,
        solver_s
    );
    let _ = writeln!(
        s,
        "| start | initial cost | final cost | iterations | evaluations | solver s | stop |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for (i, st) in result.starts.iter().enumerate() {
        let mark = if i == result.best { " (best)" } else { "" };
        let _ = writeln!(
            s,
            "| {}{mark} | {:.6} | {:.6} | {} | {} | {:.3} | {} |",
            st.label,
            st.initial_cost,
            st.final_cost,
            st.iterations,
            st.evaluations,
            st.seconds,
            st.termination.describe()
        );
    }
    if let Some(p) = &result.polish {
        let _ = writeln!(
            s,
            "| {} (Marquardt, tolerances x 1e-4) | {:.6} | {:.6} | {} | {} | {:.3} | {} |",
            p.label,
            p.initial_cost,
            p.final_cost,
            p.iterations,
            p.evaluations,
            p.seconds,
            p.termination.describe()
        );
    }
    let probes = if setup.probes.is_empty() {
        ""
    } else {
        ", then from its lowest minimum with each of its joint stiffnesses at its lower bound in turn (the probes)"
    };
    let _ = writeln!(
        s,
        "\nEach part (a subsystem: its parameters move only its own components) is solved on its own from every start{probes}, and each part keeps its lowest minimum (*). Final cost of each part (iterations):\n"
    );
    let mut header = String::from("| start |");
    for part in &result.parts {
        let _ = write!(header, " {} ({} parameters) |", part.name, part.params);
    }
    let _ = writeln!(s, "{header}\n|---|{}", "---|".repeat(result.parts.len()));
    for (i, start) in result.starts.iter().enumerate() {
        let mut row = format!("| {} |", start.label);
        for part in &result.parts {
            let o = &part.starts[i];
            let mark = if part.best == i { "*" } else { "" };
            let _ = write!(row, " {:.6}{mark} ({}) |", o.final_cost, o.iterations);
        }
        let _ = writeln!(s, "{row}");
    }
    // The probes: each moves one part's parameter, so it has a cost on that part only.
    for (k, part) in result.parts.iter().enumerate() {
        for (i, o) in part.starts.iter().enumerate().skip(result.starts.len()) {
            let mut row = format!("| {} |", o.label);
            for other in 0..result.parts.len() {
                if other == k {
                    let mark = if part.best == i { "*" } else { "" };
                    let _ = write!(row, " {:.6}{mark} ({}) |", o.final_cost, o.iterations);
                } else {
                    row.push_str(" - |");
                }
            }
            let _ = writeln!(s, "{row}");
        }
    }
    if result.parts.iter().any(|p| p.polish.is_some()) {
        let mut row = String::from("| polish |");
        for part in &result.parts {
            match &part.polish {
                Some(o) => {
                    let _ = write!(row, " {:.6} ({}) |", o.final_cost, o.iterations);
                }
                None => row.push_str(" - |"),
            }
        }
        let _ = writeln!(s, "{row}");
    }
    let _ = writeln!(
        s,
        "\n| component | rms magnitude error (relative) | rms phase error (deg) |"
    );
    let _ = writeln!(s, "|---|---|---|");
    for (c, (mag, phase)) in errors.iter().enumerate() {
        let _ = writeln!(s, "| {} | {:.4} | {:.2} |", component_name(c), mag, phase);
    }
    let s_max = ident.singular_values.first().copied().unwrap_or(0.0);
    let s_min_nonzero = ident
        .singular_values
        .iter()
        .copied()
        .filter(|v| *v > 1e-12 * s_max)
        .fold(f64::INFINITY, f64::min);
    let _ = writeln!(
        s,
        "\nJacobian (in ln p): largest singular value {:.3e}, smallest non-zero {:.3e}; {} of {} are below 1e-12 of the largest.\n",
        s_max,
        s_min_nonzero,
        ident
            .singular_values
            .iter()
            .filter(|v| **v <= 1e-12 * s_max)
            .count(),
        ident.singular_values.len()
    );
    let _ = writeln!(
        s,
        "| parameter | value | unit | at bound | sensitivity | weak share | determined by the data | standard error (ln p) | 95 % interval |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for p in &ident.params {
        let bound = match p.at_bound {
            Some(AtBound::Lower) => "lower",
            Some(AtBound::Upper) => "upper",
            None => "",
        };
        let (se, interval) = match (p.standard_error, p.interval_95()) {
            (Some(se), Some((lo, hi))) => (format!("{se:.3}"), format!("{lo:.4e} .. {hi:.4e}")),
            _ => (String::new(), String::new()),
        };
        let _ = writeln!(
            s,
            "| {} | {:.6e} | {} | {bound} | {:.2e} | {:.2} | {} | {se} | {interval} |",
            p.id,
            p.value,
            p.id.unit(),
            p.sensitivity,
            p.weak_loading,
            p.determination.name()
        );
    }
    if let Some(c) = &ident.covariance {
        let _ = writeln!(
            s,
            "\nStandard errors: s^2 (J^T J)^+ over the directions with singular value at least 1e-3 of the largest, s^2 = 2 cost / (m - n) = {:.4e} ({} degrees of freedom); 95 % interval p e^(+-1.96 se). Linearized: they describe the noise of these data around this minimum, not the model's structure or the spread between subjects (docs/model.md#uncertainty-of-a-fit).",
            c.residual_variance, c.degrees_of_freedom
        );
    }
    s
}

fn unwrapped_deg(values: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len());
    let mut offset = 0.0;
    for (i, &v) in values.iter().enumerate() {
        if i > 0 {
            let prev = values[i - 1];
            let jump = v - prev;
            if jump > PI {
                offset -= 2.0 * PI;
            } else if jump < -PI {
                offset += 2.0 * PI;
            }
        }
        out.push((v + offset).to_degrees());
    }
    out
}

/// The Fig. 3/4-style figure: for each group of four components a row of magnitudes and
/// a row of phases (degrees: the model's unwrapped along frequency, the measured ones on
/// the branch nearest the model's).
pub fn components_svg(
    title: &str,
    freqs_hz: &[f64],
    subjects: &[Vec<Transmissibility>],
    geomean: &[Transmissibility],
    model: &[Transmissibility],
) -> anyhow::Result<String> {
    let mut panels = Vec::with_capacity(2 * COMPONENTS);
    let series = |h: &[Transmissibility], c: usize, phase: bool, color: &str, width: f64, label| {
        let (output, input) = COUPLED_COMPONENTS[c];
        let at = |m: &Transmissibility| m[(output.index(), input.index())];
        let ys: Vec<f64> = if phase {
            // The model's phase unwrapped along frequency; every other curve on the 2 pi
            // branch nearest it, which is what the objective's wrapped residual sees.
            let reference = unwrapped_deg(&model.iter().map(|m| at(m).arg()).collect::<Vec<_>>());
            h.iter()
                .zip(&reference)
                .map(|(m, r)| r + wrap_pi(at(m).arg() - r.to_radians()).to_degrees())
                .collect()
        } else {
            h.iter().map(|m| at(m).norm()).collect()
        };
        Series::line(
            freqs_hz.iter().copied().zip(ys).collect(),
            color,
            width,
            label,
        )
    };
    for group in 0..COMPONENTS / 4 {
        for phase in [false, true] {
            for c in 4 * group..4 * group + 4 {
                let mut panel = Panel {
                    title: format!(
                        "{} {}",
                        component_name(c),
                        if phase { "phase" } else { "magnitude" }
                    ),
                    x_label: "frequency (Hz)".into(),
                    y_label: if phase {
                        "phase (deg)".into()
                    } else {
                        "|H|".into()
                    },
                    ..Panel::default()
                };
                for (i, s) in subjects.iter().enumerate() {
                    let label = (i == 0).then_some("subjects");
                    panel
                        .series
                        .push(series(s, c, phase, "#c8c8c8", 1.0, label));
                }
                panel.series.push(series(
                    geomean,
                    c,
                    phase,
                    "#000000",
                    1.8,
                    Some("geometric mean"),
                ));
                panel.series.push(series(
                    model,
                    c,
                    phase,
                    "#d62728",
                    1.8,
                    Some("fitted model"),
                ));
                panels.push(panel);
            }
        }
    }
    figure_svg(title, &panels, 4)
}

/// The report's files in `dir`, `components.svg` and `summary.md`, with their contents
/// (written together with the parameter file by `output::write_all_atomically`).
pub fn files(dir: &Path, summary_md: &str, components_svg: &str) -> Vec<(PathBuf, Vec<u8>)> {
    vec![
        (
            dir.join("components.svg"),
            components_svg.as_bytes().to_vec(),
        ),
        (dir.join("summary.md"), summary_md.as_bytes().to_vec()),
    ]
}
