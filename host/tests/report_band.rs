//! `supine report --band N`: the head's prediction band against what it must be whatever
//! the draws: the report's own values at the fitted parameters, an ordered band that holds
//! its median and (for a smooth model) the nominal value, a width that scales with the
//! covariance's standard deviations, a one-leg mission that is its leg, and refusals.

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use serde_json::Value;
use supine_core::model::{ParamId, Preset};

use supine_host::commands::band_args::BandArgs;
use supine_host::commands::report::{self, MissionArgs};
use supine_host::exposure::ride::{Profile, generate, write_ride};
use supine_host::identify::fit::uncertainty::{FIT_KEY, StoredUncertainty};
use supine_host::io::params_file::{self, ModelSource, ParamFile, PresetArg};
use supine_host::io::ride_input::RideInputArgs;
use supine_host::io::subject_args::SubjectArgs;

fn ride(dir: &Path, profile: Profile, duration_s: f64, seed: u64) -> PathBuf {
    let path = dir.join(format!("{}-{seed}.csv", profile.name()));
    write_ride(&path, &generate(profile, duration_s, 500.0, seed).unwrap()).unwrap();
    path
}

/// The paper's litter-board parameters with a diagonal covariance of standard deviation
/// `sd_ln_p` on every parameter's ln p, as `supine fit` would store it.
fn params_with_covariance(dir: &Path, sd_ln_p: f64) -> PathBuf {
    let mut file = ParamFile::preset(Preset::PaperLitter);
    let parameters = ParamId::ALL.to_vec();
    let n = parameters.len();
    let uncertainty = StoredUncertainty {
        residual_variance: 1.0,
        degrees_of_freedom: 1000,
        parameters,
        covariance_ln_p: DMatrix::from_diagonal_element(n, n, sd_ln_p * sd_ln_p),
    };
    let mut fit = toml::Table::new();
    fit.insert(
        FIT_KEY.into(),
        toml::Value::Table(uncertainty.to_toml(&file.params)),
    );
    file.fit = Some(fit);
    let path = dir.join(format!("fitted-{sd_ln_p}.toml"));
    params_file::save(&path, &file).unwrap();
    path
}

fn args(inputs: &[PathBuf], model: ModelSource, out: &Path, draws: Option<usize>) -> report::Args {
    report::Args {
        mission: MissionArgs {
            input: inputs.to_vec(),
            ride: RideInputArgs::default(),
            track: Default::default(),
            model,
            subject: SubjectArgs {
                height_m: None,
                mass_kg: None,
            },
        },
        out: out.to_path_buf(),
        json: true,
        compare: false,
        band: BandArgs {
            band: draws,
            ..BandArgs::default()
        },
    }
}

fn params_source(path: &Path) -> ModelSource {
    ModelSource {
        preset: None,
        params: Some(path.to_path_buf()),
    }
}

fn report_json(inputs: &[PathBuf], params: &Path, out: &Path, draws: usize) -> Value {
    let mut text = Vec::new();
    report::run_to(
        &args(inputs, params_source(params), out, Some(draws)),
        &mut text,
    )
    .unwrap();
    serde_json::from_slice(&text).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// The bands of a report: (where, the report's own value, the band's value object).
fn bands(report: &Value) -> Vec<(String, f64, Value)> {
    let band = &report["band"];
    let mut out = Vec::new();
    let rows = band["legs"]
        .as_array()
        .unwrap()
        .iter()
        .zip(report["legs"].as_array().unwrap())
        .map(|(b, leg)| (b, &leg["vector"]))
        .chain([(&band["mission"], &report["mission"]["vector"])]);
    for (i, (b, own)) in rows.enumerate() {
        out.push((
            format!("row {i} rms"),
            f(&own["rms_m_s2"]),
            b["vector_rms_m_s2"].clone(),
        ));
        out.push((
            format!("row {i} VDV"),
            f(&own["vdv_m_s175"]),
            b["vector_vdv_m_s175"].clone(),
        ));
    }
    out
}

#[test]
fn the_band_holds_the_reports_values_and_narrows_with_the_covariance() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = [
        ride(dir.path(), Profile::Ambulance, 30.0, 1),
        ride(dir.path(), Profile::RoughRoad, 30.0, 2),
    ];
    let wide = report_json(
        &inputs,
        &params_with_covariance(dir.path(), 0.03),
        &dir.path().join("wide"),
        200,
    );
    let narrow = report_json(
        &inputs,
        &params_with_covariance(dir.path(), 0.003),
        &dir.path().join("narrow"),
        200,
    );
    assert_eq!(wide["band"]["draws"], 200);
    assert_eq!(
        wide["band"]["quantiles"],
        serde_json::json!([0.025, 0.5, 0.975])
    );
    let (wide, narrow) = (bands(&wide), bands(&narrow));
    assert_eq!(wide.len(), 6);
    for ((name, own, w), (_, own_narrow, n)) in wide.iter().zip(&narrow) {
        // The nominal is the report's own value: the same pipeline, the fitted parameters.
        assert_eq!(f(&w["nominal"]), *own, "{name}");
        assert_eq!(own, own_narrow, "{name}");
        let [low, median, high] = ["low", "median", "high"].map(|k| f(&w[k]));
        assert!(
            low < median && median < high,
            "{name}: {low} {median} {high}"
        );
        // A smooth model and a symmetric spread of ln p: the fitted value lies inside.
        assert!(
            low < *own && *own < high,
            "{name}: {own} outside {low}..{high}"
        );
        // Ten times smaller standard deviations, the same draws of N(0, 1): ten times
        // narrower to first order (within 25 %: the model's curvature, the pipeline's f32).
        let ratio = (f(&n["high"]) - f(&n["low"])) / (high - low);
        assert!(
            (0.08..0.125).contains(&ratio),
            "{name}: width ratio {ratio}"
        );
    }
}

#[test]
fn a_one_leg_missions_band_is_its_legs_and_the_page_shows_it() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = [ride(dir.path(), Profile::Ambulance, 20.0, 3)];
    let out = dir.path().join("one");
    let report = report_json(&inputs, &params_with_covariance(dir.path(), 0.1), &out, 20);
    let band = &report["band"];
    for key in ["vector_rms_m_s2", "vector_vdv_m_s175"] {
        for q in ["nominal", "low", "median", "high"] {
            let (leg, mission) = (f(&band["legs"][0][key][q]), f(&band["mission"][key][q]));
            assert!(
                (leg - mission).abs() <= 1e-6 * leg,
                "{key} {q}: {leg} {mission}"
            );
        }
    }
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(page.contains("<h3>Prediction band</h3>"));
    assert!(page.contains("from 20 parameter sets"));
}

#[test]
fn a_band_needs_a_fitted_file_and_two_draws() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = [ride(dir.path(), Profile::Ambulance, 10.0, 4)];
    let out = dir.path().join("r");
    let preset = ModelSource {
        preset: Some(PresetArg::PaperLitter),
        params: None,
    };
    let error = report::run_to(&args(&inputs, preset, &out, Some(10)), &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(error.contains("--band: expected --params"), "{error}");
    let plain = dir.path().join("plain.toml");
    params_file::save(&plain, &ParamFile::preset(Preset::PaperLitter)).unwrap();
    let error = report::run_to(
        &args(&inputs, params_source(&plain), &out, Some(10)),
        &mut Vec::new(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("expected a [fit.uncertainty] table"),
        "{error}"
    );
    let fitted = params_with_covariance(dir.path(), 0.1);
    let error = report::run_to(
        &args(&inputs, params_source(&fitted), &out, Some(1)),
        &mut Vec::new(),
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("expected at least 2 draws"), "{error}");
    // Without --band the JSON has no band.
    let mut text = Vec::new();
    report::run_to(
        &args(&inputs, params_source(&fitted), &out, None),
        &mut text,
    )
    .unwrap();
    let report: Value = serde_json::from_slice(&text).unwrap();
    assert!(report.get("band").is_none());
}

#[test]
fn a_comparisons_band_names_its_last_row_both_rides() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = [
        ride(dir.path(), Profile::Ambulance, 10.0, 5),
        ride(dir.path(), Profile::RoughRoad, 10.0, 6),
    ];
    let out = dir.path().join("compare");
    let fitted = params_with_covariance(dir.path(), 0.1);
    let mut compare = args(&inputs, params_source(&fitted), &out, Some(5));
    compare.compare = true;
    let mut text = Vec::new();
    report::run_to(&compare, &mut text).unwrap();
    let report: Value = serde_json::from_slice(&text).unwrap();
    assert_eq!(report["band"]["legs"].as_array().unwrap().len(), 2);
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        page.contains("<tr><td>both rides</td>"),
        "no 'both rides' row"
    );
}
