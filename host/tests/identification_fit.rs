//! Parameter recovery by the fit, and the whole pipeline on a small synthetic dataset:
//! synth -> transmissibility -> fit (rigid, then litter) -> predict -> validate.

use std::path::Path;

use clap::Parser;
use supine_core::model::{ModelParams, ParamId, Preset, SystemMatrices};
use supine_host::cli::{Cli, run};
use supine_host::identify::fit::objective::Target;
use supine_host::identify::fit::solver::DampingScale;
use supine_host::identify::fit::{self, Determination, FitSettings};
use supine_host::identify::transmissibility::estimate;
use supine_host::io::dataset::{Case, Dataset};
use supine_host::io::params_file;
use supine_host::io::recording::{HEADER_LINE, Recording};

fn supine(args: &[&str]) -> anyhow::Result<()> {
    let mut argv = vec!["supine"];
    argv.extend_from_slice(args);
    run(Cli::try_parse_from(argv)?)
}

fn exact_target(params: &ModelParams) -> Target {
    let m = SystemMatrices::assemble(params);
    let freqs_hz: Vec<f64> = (0..63).map(|k| 0.5 + 0.25 * k as f64).collect();
    let h = freqs_hz
        .iter()
        .map(|&f| m.transmissibility(f).unwrap())
        .collect();
    Target { freqs_hz, h }
}

use crate::common::perturbed_truth as truth;

/// Stated tolerance: every parameter the fit calls determined comes back within 2 %.
const RECOVERY_TOLERANCE: f64 = 0.02;

#[test]
fn the_rigid_fit_recovers_every_determined_parameter_from_exact_data_within_2_percent() {
    let truth = truth();
    let settings = FitSettings {
        starts: 1,
        ..FitSettings::default()
    };
    let mut setup = fit::rigid_setup(exact_target(&truth), truth.subject, &settings).unwrap();
    // Start from the paper's values (every parameter off the truth by up to 12 %).
    let paper = ModelParams::preset(Preset::PaperRigid);
    setup.starts = vec![fit::Start::new(
        "paper",
        setup.objective.theta(&paper),
        DampingScale::Levenberg,
    )];
    let result = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
    // Exact data: zero residual, up to where the default gtol (1e-6, docs/model.md#solver-and-tolerances) stops.
    assert!(
        result.solution.cost < 1e-10,
        "cost {}",
        result.solution.cost
    );
    let ident = fit::identifiability(&setup, &result);
    let mut determined = 0;
    for p in &ident.params {
        let want = truth.get(p.id);
        match p.determination {
            Determination::Determined => {
                determined += 1;
                let err = (p.value / want - 1.0).abs();
                assert!(
                    err < RECOVERY_TOLERANCE,
                    "{}: fitted {} vs true {want}",
                    p.id,
                    p.value
                );
            }
            Determination::NoEffect => {
                assert!(
                    p.id.to_string().contains("rotational") && p.id.to_string().ends_with(".x")
                );
                // Untouched (up to exp(ln p) rounding): no gradient ever moves it.
                assert!((p.value / paper.get(p.id) - 1.0).abs() < 1e-12);
            }
            Determination::Weak => {}
        }
    }
    assert_eq!(
        ident
            .params
            .iter()
            .filter(|p| p.determination == Determination::NoEffect)
            .count(),
        4
    );
    // 29 of the 38 parameters with an effect are determined on this grid; the rest are weak.
    assert!(determined >= 25, "only {determined} parameters determined");
}

#[test]
fn the_litter_fit_recovers_the_contacts_with_the_joints_fixed() {
    let rigid = ModelParams::preset(Preset::PaperRigid);
    let mut truth = ModelParams::preset(Preset::PaperLitter);
    // Keep the truth strictly inside [floor, rigid value] for the contacts.
    for id in ParamId::ALL.into_iter().filter(|id| id.is_contact()) {
        truth.set(id, truth.get(id).min(0.9 * rigid.get(id)));
    }
    let settings = FitSettings {
        starts: 1,
        ..FitSettings::default()
    };
    let setup = fit::litter_setup(exact_target(&truth), truth.subject, &rigid, &settings).unwrap();
    assert_eq!(setup.objective.free.len(), 18);
    let result = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
    // Exact data: zero residual, up to where the default gtol (1e-6, docs/model.md#solver-and-tolerances) stops.
    assert!(
        result.solution.cost < 1e-10,
        "cost {}",
        result.solution.cost
    );
    assert_eq!(result.params.joints, rigid.joints);
    let ident = fit::identifiability(&setup, &result);
    for p in ident
        .params
        .iter()
        .filter(|p| p.determination == Determination::Determined)
    {
        let want = truth.get(p.id);
        assert!(
            (p.value / want - 1.0).abs() < RECOVERY_TOLERANCE,
            "{}: fitted {} vs true {want}",
            p.id,
            p.value
        );
    }
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn the_pipeline_fits_synthetic_data_at_least_as_well_as_the_truths_geometric_mean() {
    let dir = tempfile::tempdir().unwrap();
    let ds = dir.path().join("ds");
    supine(&[
        "synth",
        "--out",
        path(&ds),
        "--subjects",
        "4",
        "--seed",
        "3",
        "--duration-s",
        "30",
    ])
    .unwrap();
    let text = std::fs::read_to_string(ds.join("s1_rigid.csv")).unwrap();
    assert_eq!(text.lines().next(), Some(HEADER_LINE));
    assert_eq!(text.lines().count(), 1 + 30 * 200);

    let rigid = dir.path().join("rigid.toml");
    let report = dir.path().join("report");
    let common = [
        "--dataset",
        path(&ds),
        "--exclude",
        "s4",
        "--resolution-hz",
        "0.25",
    ];
    let mut args = vec![
        "fit",
        "--case",
        "rigid",
        "--starts",
        "2",
        "--out",
        path(&rigid),
    ];
    args.extend_from_slice(&common);
    args.extend_from_slice(&["--report", path(&report)]);
    supine(&args).unwrap();
    let fitted = params_file::load(&rigid).unwrap();
    let fit_table = fitted.fit.clone().unwrap();
    let cost = fit_table["final_cost"].as_float().unwrap();
    let no_effect = fit_table["no_effect"].as_array().unwrap();
    assert_eq!(no_effect.len(), 4);
    assert!(report.join("components.svg").exists());
    let summary = std::fs::read_to_string(report.join("summary.md")).unwrap();
    assert!(summary.contains("| H13 (head_x / z) |"));

    // The reference: the model of the geometric mean of the training subjects' truths.
    let dataset = Dataset::load(&ds).unwrap();
    let exclude = vec!["s4".to_string()];
    let est = estimate(&dataset, Case::Rigid, None, &exclude, 0.25, 0.5, 16.0).unwrap();
    let target = Target {
        freqs_hz: est.freqs_hz.clone(),
        h: est.geomean.clone(),
    };
    let setup = fit::rigid_setup(target, est.mean_subject(), &FitSettings::default()).unwrap();
    let truths: Vec<ModelParams> = ["s1", "s2", "s3"]
        .iter()
        .map(|id| {
            params_file::load(&ds.join("truth").join(format!("{id}_rigid.toml")))
                .unwrap()
                .params
        })
        .collect();
    let mut reference = setup.objective.base;
    for id in ParamId::ALL {
        let mean_ln = truths.iter().map(|p| p.get(id).ln()).sum::<f64>() / 3.0;
        reference.set(id, mean_ln.exp());
    }
    let reference_cost = setup
        .objective
        .cost(&setup.objective.theta(&reference))
        .unwrap();
    assert!(
        cost <= reference_cost,
        "fit cost {cost} above the truth's geometric mean {reference_cost}"
    );

    // The litter-board fit on the rigid fit, with `extra` arguments, into `out`.
    let litter_fit = |extra: &[&str], out: &Path| {
        let mut args = vec!["fit", "--case", "litter", "--joints", path(&rigid)];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--starts", "2", "--out", path(out)]);
        args.extend_from_slice(&common);
        supine(&args).unwrap();
    };
    let litter = dir.path().join("litter.toml");
    litter_fit(&[], &litter);
    // On the rigid fit's own minimum alone: its joints kept, its contacts the bounds.
    let alone = dir.path().join("litter_alone.toml");
    litter_fit(&["--no-explore"], &alone);
    let alone = params_file::load(&alone).unwrap();
    assert_eq!(alone.params.joints, fitted.params.joints);
    for id in ParamId::ALL.into_iter().filter(|id| id.is_contact()) {
        assert!(alone.params.get(id) <= fitted.params.get(id) * (1.0 + 1e-9));
    }
    // The pipeline (the rigid fit's stored minima and those of its continued search):
    // its litter-board cost at or below that of the rigid fit's own minimum (one of the
    // pairs it chose among); with --within-region, also a pair within the rigid fit's
    // 95 % confidence region.
    let alone_cost = alone.fit.unwrap()["final_cost"].as_float().unwrap();
    let within = dir.path().join("litter_within.toml");
    litter_fit(&["--within-region"], &within);
    for (file, region_only) in [(&litter, false), (&within, true)] {
        let explored = params_file::load(file).unwrap().fit.unwrap();
        let pair = explored["rigid_minima_explored"].as_table().unwrap();
        assert_eq!(pair["within_region"].as_bool(), Some(region_only));
        let pair_rigid_cost = pair["rigid_cost"].as_float().unwrap();
        let litter_cost = explored["final_cost"].as_float().unwrap();
        assert!(
            litter_cost <= alone_cost * (1.0 + 1e-9),
            "pair ({pair_rigid_cost}, {litter_cost}) against the rigid fit's ({cost}, {alone_cost})"
        );
        if region_only {
            assert!(pair_rigid_cost <= cost + pair["cost_budget"].as_float().unwrap());
        }
    }

    // Predict and validate the held-out subject.
    let pred = dir.path().join("pred.csv");
    let held_out = ds.join("s4_litter.csv");
    supine(&[
        "predict",
        "--params",
        path(&litter),
        "--input",
        path(&held_out),
        "--out",
        path(&pred),
    ])
    .unwrap();
    let measured = Recording::read(&held_out).unwrap();
    let predicted = Recording::read(&pred).unwrap();
    assert_eq!(predicted.time_s, measured.time_s);
    assert_eq!(predicted.platform_m_s2, measured.platform_m_s2);
    let vreport = dir.path().join("validation");
    supine(&[
        "validate",
        "--params",
        path(&litter),
        "--input",
        path(&held_out),
        "--json",
        "--report",
        path(&vreport),
    ])
    .unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(vreport.join("validation.json")).unwrap())
            .unwrap();
    assert_eq!(json["channels"].as_array().unwrap().len(), 9);
    let r2 = json["r2_pearson"].as_f64().unwrap();
    assert!(r2 > 0.5 && r2 <= 1.0, "R^2 {r2}");
    assert!(vreport.join("psd.svg").exists());
}

#[test]
fn predict_with_the_true_parameters_reproduces_the_noise_free_response() {
    // One subject with no noise: predicting its own recording from its true parameters
    // must match the synthesized sensors up to the start-up transient and the hold error.
    let dir = tempfile::tempdir().unwrap();
    let ds = dir.path().join("ds");
    supine(&[
        "synth",
        "--out",
        path(&ds),
        "--subjects",
        "1",
        "--duration-s",
        "20",
        "--noise-m-s2",
        "0",
    ])
    .unwrap();
    let truth = params_file::load(&ds.join("truth/s1_rigid.toml"))
        .unwrap()
        .params;
    let rec = Recording::read(&ds.join("s1_rigid.csv")).unwrap();
    let predicted = supine_host::identify::validate::predict(&truth, &rec).unwrap();
    // Skip the first 10 s (the prediction starts from rest, the synthesis is periodic).
    let skip = 10 * 200;
    for (j, column) in predicted.iter().enumerate() {
        let measured = &rec.sensors_m_s2[j][skip..];
        let err: f64 = column[skip..]
            .iter()
            .zip(measured)
            .map(|(p, m)| (p - m).powi(2))
            .sum::<f64>()
            .sqrt();
        let norm: f64 = measured.iter().map(|m| m * m).sum::<f64>().sqrt();
        assert!(
            err / norm < 0.01,
            "channel {j}: relative error {}",
            err / norm
        );
    }
}

/// A quick fit's command line on a small dataset (2 subjects, 30 s; one start, few
/// iterations: only the outputs matter here).
fn quick_fit_args(ds: &Path, out: &Path, report: &Path) -> Vec<String> {
    [
        "fit",
        "--dataset",
        path(ds),
        "--case",
        "rigid",
        "--starts",
        "1",
        "--max-iterations",
        "3",
        "--resolution-hz",
        "0.25",
        "--out",
        path(out),
        "--report",
        path(report),
    ]
    .map(String::from)
    .to_vec()
}

fn small_dataset(dir: &Path) -> std::path::PathBuf {
    let ds = dir.join("ds");
    supine(&[
        "synth",
        "--out",
        path(&ds),
        "--subjects",
        "2",
        "--duration-s",
        "30",
    ])
    .unwrap();
    ds
}

#[test]
fn a_report_that_cannot_be_written_leaves_no_parameter_file_and_exits_non_zero() {
    let dir = tempfile::tempdir().unwrap();
    let ds = small_dataset(dir.path());
    let out = dir.path().join("rigid.toml");
    // The report folder would be inside a regular file: it cannot be created.
    let blocker = dir.path().join("not_a_folder");
    std::fs::write(&blocker, "x").unwrap();
    let report = blocker.join("report");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(quick_fit_args(&ds, &out, &report))
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!(
            "supine: {}: --report: cannot create:",
            report.display()
        )),
        "{stderr}"
    );
    assert!(!out.exists(), "the parameter file must not be written");
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.contains("partial")), "{names:?}");
}

#[test]
fn a_report_file_that_cannot_be_replaced_leaves_no_parameter_file() {
    let dir = tempfile::tempdir().unwrap();
    let ds = small_dataset(dir.path());
    let out = dir.path().join("rigid.toml");
    let report = dir.path().join("report");
    // summary.md is a folder: the report refuses to write over it; the parameter file is
    // written last, so it is not written.
    std::fs::create_dir_all(report.join("summary.md").join("x")).unwrap();
    let mut args = quick_fit_args(&ds, &out, &report);
    // The folder holds what supine did not write (summary.md as a folder): --force.
    args.push("--force".to_string());
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let err = supine(&argv).expect_err("the report cannot be written");
    let line = supine_host::cli::one_line(&err);
    assert!(
        line.starts_with(&format!(
            "{}: is a folder",
            report.join("summary.md").display()
        )),
        "{line}"
    );
    assert!(!out.exists(), "the parameter file must not be written");
    let leftovers: Vec<String> = std::fs::read_dir(&report)
        .unwrap()
        .chain(std::fs::read_dir(dir.path()).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn a_fit_writes_the_report_and_the_parameter_file_together() {
    let dir = tempfile::tempdir().unwrap();
    let ds = small_dataset(dir.path());
    let out = dir.path().join("rigid.toml");
    let report = dir.path().join("new").join("report");
    let args = quick_fit_args(&ds, &out, &report);
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    supine(&argv).unwrap();
    assert!(params_file::load(&out).is_ok());
    assert!(report.join("components.svg").is_file());
    assert!(report.join("summary.md").is_file());
}

/// A model whose head-torso vertical spring is absent (at its lower bound, 1 N/m), fitted
/// from a start with that spring at its upper bound: the start's run ends in another
/// minimum, and the probe that takes the spring out (docs/model.md#probes-at-the-bounds)
/// finds the truth; without the probes the fit stays in the start's minimum.
#[test]
fn a_probe_finds_the_minimum_where_a_joint_spring_is_absent() {
    let spring = crate::common::param("joints.head_torso.translational.stiffness_n_per_m.z");
    let mut truth = truth();
    truth.set(spring, fit::STIFFNESS_BOUNDS.0);
    // No polish: the probes alone are tested.
    let settings = FitSettings {
        starts: 1,
        polish: false,
        ..FitSettings::default()
    };
    let mut setup = fit::rigid_setup(exact_target(&truth), truth.subject, &settings).unwrap();
    let mut start = truth;
    start.set(spring, fit::STIFFNESS_BOUNDS.1);
    setup.starts = vec![fit::Start::new(
        "spring at its upper bound",
        setup.objective.theta(&start),
        DampingScale::Levenberg,
    )];
    let with_probes = fit::run(&setup, &settings, &|_, _, _| {}).unwrap();
    let mut without = setup.clone();
    without.probes.clear();
    let without_probes = fit::run(&without, &settings, &|_, _, _| {}).unwrap();
    assert!(
        without_probes.solution.cost > 1.0,
        "the start's own run reached the truth: {}",
        without_probes.solution.cost
    );
    assert!(
        with_probes.solution.cost < 1e-10,
        "cost {}",
        with_probes.solution.cost
    );
    // The vertical part keeps a probe's minimum; every probe of it starts from the start's
    // minimum with one joint stiffness of the part at its lower bound.
    let vertical = with_probes
        .parts
        .iter()
        .find(|p| p.name == "vertical")
        .unwrap();
    assert!(vertical.best >= setup.starts.len(), "{:?}", vertical.starts);
    let probed: Vec<&str> = vertical.starts[setup.starts.len()..]
        .iter()
        .map(|o| o.label.as_str())
        .collect();
    for label in &probed {
        assert!(
            label.starts_with("probe: joints.") && label.contains(".stiffness_n"),
            "{label}"
        );
    }
    assert!(probed.contains(
        &"probe: joints.head_torso.translational.stiffness_n_per_m.z at its lower bound"
    ));
    assert!(
        vertical.starts[vertical.best].final_cost
            <= vertical
                .starts
                .iter()
                .map(|o| o.final_cost)
                .fold(f64::INFINITY, f64::min)
    );
}
