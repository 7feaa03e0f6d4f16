//! `supine model`, `supine modes` and `supine params`, run in-process.

use clap::Parser;
use supine_core::model::{Axis, JointOutput, Model, ModelParams, Preset, SystemMatrices};
use supine_host::cli::{Cli, one_line, run};
use supine_host::io::params_file::{self, ParamFile};

fn supine(args: &[&str]) -> anyhow::Result<()> {
    let mut argv = vec!["supine"];
    argv.extend_from_slice(args);
    run(Cli::try_parse_from(argv)?)
}

#[test]
fn model_writes_all_27_components_with_the_exact_header() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("H.csv");
    supine(&[
        "model",
        "--preset",
        "paper-rigid",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("freq_hz,output,input,magnitude,phase_rad")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // 0.5..=16 Hz in 0.05 Hz steps: 311 frequencies.
    assert_eq!(rows.len(), 311 * 27);
    let matrices = SystemMatrices::assemble(&ModelParams::preset(Preset::PaperRigid));
    let h = matrices.transmissibility(5.0).unwrap();
    let row = rows
        .iter()
        .find(|r| r[0].parse::<f64>().unwrap() == 5.0 && r[1] == "head_z" && r[2] == "z")
        .unwrap();
    assert!((row[3].parse::<f64>().unwrap() - h[(2, 2)].norm()).abs() < 1e-12);
    assert!((row[4].parse::<f64>().unwrap() - h[(2, 2)].arg()).abs() < 1e-12);
    let outputs: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(outputs.len(), 9);
}

#[test]
fn model_quantity_joints_writes_the_ten_joint_outputs_per_input_as_the_modal_sum_gives_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("J.csv");
    let grid = ["--fmin", "0.5", "--fmax", "20", "--df", "0.5"];
    let mut args = vec!["model", "--preset", "paper-litter", "--quantity", "joints"];
    args.extend_from_slice(&grid);
    args.extend_from_slice(&["--out", out.to_str().unwrap()]);
    supine(&args).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("freq_hz,output,input,magnitude,phase_rad")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 40 * 30);
    // The CLI solves the equations directly; the modal sum is another route to the same.
    let model = Model::new(&ModelParams::preset(Preset::PaperLitter)).unwrap();
    for row in &rows {
        let f: f64 = row[0].parse().unwrap();
        let output = JointOutput::from_name(row[1]).expect("a joint output name");
        let input = Axis::ALL.into_iter().find(|a| a.name() == row[2]).unwrap();
        let h = model.modes.joint_response(f)[(output.index(), input.index())];
        let magnitude: f64 = row[3].parse().unwrap();
        let scale = model.modes.joint_response(f)[(output.index(), output.input_axis().index())];
        assert!(
            (magnitude - h.norm()).abs() <= 1e-7 * scale.norm(),
            "{output} from {input} at {f} Hz"
        );
        if input == output.input_axis() {
            let phase: f64 = row[4].parse().unwrap();
            assert!((phase - h.arg()).abs() < 1e-6, "{output} {f} Hz");
        }
    }
    // The sensor default is unchanged by the option.
    let sensors = dir.path().join("H.csv");
    let mut args = vec!["model", "--preset", "paper-litter", "--quantity", "sensors"];
    args.extend_from_slice(&grid);
    args.extend_from_slice(&["--out", sensors.to_str().unwrap()]);
    supine(&args).unwrap();
    let default = dir.path().join("H_default.csv");
    let mut args = vec!["model", "--preset", "paper-litter"];
    args.extend_from_slice(&grid);
    args.extend_from_slice(&["--out", default.to_str().unwrap()]);
    supine(&args).unwrap();
    assert_eq!(
        std::fs::read_to_string(sensors).unwrap(),
        std::fs::read_to_string(default).unwrap()
    );
}

#[test]
fn model_applies_height_and_mass_overrides() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    let common = [
        "--preset",
        "paper-litter",
        "--fmin",
        "5",
        "--fmax",
        "6",
        "--df",
        "1",
    ];
    let mut args_a = vec!["model"];
    args_a.extend_from_slice(&common);
    args_a.extend_from_slice(&["--out", a.to_str().unwrap()]);
    supine(&args_a).unwrap();
    let mut args_b = args_a.clone();
    let last = args_b.len() - 1;
    args_b[last] = b.to_str().unwrap();
    args_b.extend_from_slice(&["--mass-kg", "60"]);
    supine(&args_b).unwrap();
    assert_ne!(
        std::fs::read_to_string(a).unwrap(),
        std::fs::read_to_string(b).unwrap()
    );
}

#[test]
fn model_refuses_a_bad_frequency_grid_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("H.csv");
    let err = supine(&[
        "model",
        "--preset",
        "paper-rigid",
        "--fmin",
        "5",
        "--fmax",
        "1",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap_err();
    assert_eq!(
        one_line(&err),
        "--fmax 1: expected a frequency above --fmin 5 Hz"
    );
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no partial file left"
    );
}

/// `supine model` with `extra` grid flags: the error's one line.
fn model_grid_error(extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("H.csv");
    let mut args = vec![
        "model",
        "--preset",
        "paper-rigid",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let err = supine(&args).unwrap_err();
    assert!(!out.exists(), "{extra:?} wrote {}", out.display());
    one_line(&err)
}

#[test]
fn model_needs_a_grid_above_zero_hz_with_a_positive_step_and_bounded_size() {
    for (extra, flag, expected) in [
        (
            &["--fmin", "0"][..],
            "--fmin <HZ>",
            "expected a frequency above 0 Hz, got 0",
        ),
        (
            &["--fmin=-1"],
            "--fmin <HZ>",
            "expected a frequency above 0 Hz, got -1",
        ),
        (
            &["--fmax", "NaN"],
            "--fmax <HZ>",
            "expected a frequency above 0 Hz, got NaN",
        ),
        (
            &["--df", "0"],
            "--df <HZ>",
            "expected a frequency above 0 Hz, got 0",
        ),
        (
            &["--df", "inf"],
            "--df <HZ>",
            "expected a frequency above 0 Hz, got inf",
        ),
    ] {
        let msg = model_grid_error(extra);
        assert!(
            msg.contains(flag) && msg.contains(expected),
            "{extra:?}: {msg}"
        );
    }
    assert_eq!(
        model_grid_error(&["--fmin", "2", "--fmax", "2"]),
        "--fmax 2: expected a frequency above --fmin 2 Hz"
    );
    let msg = model_grid_error(&["--df", "1e-6"]);
    assert!(
        msg.starts_with(
            "--df 0.000001: 0.5..16 Hz would need 15500001 frequencies, expected at most 100000"
        ),
        "{msg}"
    );
}

#[test]
fn modes_prints_every_mode_of_the_modal_analysis_to_printed_precision() {
    use supine_core::model::{DEFAULT_SAMPLE_RATE_HZ, Model, Subsystem};
    for preset in Preset::ALL {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_supine"))
            .args(["modes", "--preset", preset.name()])
            .output()
            .unwrap();
        assert!(output.status.success(), "{output:?}");
        let text = String::from_utf8(output.stdout).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("subsystem      frequency_hz  damping_ratio  kind           reachable")
        );
        let model = Model::new(&ModelParams::preset(preset)).unwrap();
        let modes = &model.modes.components;
        let rows: Vec<Vec<&str>> = lines
            .by_ref()
            .take(modes.len())
            .map(|l| l.split_whitespace().collect())
            .collect();
        assert_eq!(rows.len(), modes.len());
        for (row, mode) in rows.iter().zip(modes) {
            let (zeta, kind) = match mode.damping_ratio() {
                Some(z) => (format!("{z:.4}"), ["oscillatory"].as_slice()),
                None => ("-".into(), ["real", "pole"].as_slice()),
            };
            let mut expected = vec![
                mode.subsystem.name().to_string(),
                format!("{:.4}", mode.natural_frequency_hz()),
                zeta,
            ];
            expected.extend(kind.iter().map(|k| k.to_string()));
            expected.push(if mode.reachable { "yes" } else { "no" }.into());
            assert_eq!(row, &expected, "{}", preset.name());
            // Nothing drives roll; every other subsystem has a support axis.
            assert_eq!(
                mode.subsystem == Subsystem::Roll,
                row.last() == Some(&"no"),
                "{row:?}"
            );
        }
        // 18 degrees of freedom: 18 oscillatory pairs unless some are overdamped.
        let pairs = modes.iter().filter(|m| m.damping_ratio().is_some()).count();
        let reals = modes.len() - pairs;
        assert_eq!(2 * pairs + reals, 36, "{}", preset.name());
        let device = model.device_realization(DEFAULT_SAMPLE_RATE_HZ).unwrap();
        assert_eq!(
            lines.next(),
            Some(
                format!(
                    "device realization at {DEFAULT_SAMPLE_RATE_HZ} Hz: {} modal blocks (2 states each), {} multiply-adds per sample for head x, y, z",
                    device.block_count,
                    device.multiply_adds_per_sample()
                )
                .as_str()
            )
        );
        assert_eq!(lines.next(), None);
    }
}

#[test]
fn a_printed_parameter_file_reads_back_to_the_same_parameters() {
    for preset in Preset::ALL {
        let file = ParamFile::preset(preset);
        let text = file.to_toml().unwrap();
        let back = ParamFile::from_toml(&text, std::path::Path::new("p.toml")).unwrap();
        assert_eq!(back, file);
    }
}

#[test]
fn a_bad_parameter_file_names_the_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    let text = ParamFile::preset(Preset::PaperLitter).to_toml().unwrap();
    // Make the litter torso contact's vertical damping negative.
    let lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let header = lines
        .iter()
        .position(|l| l == "[contacts.torso.damping_n_s_per_m]")
        .unwrap();
    let z = header
        + lines[header..]
            .iter()
            .position(|l| l.starts_with("z ="))
            .unwrap();
    let mut edited = lines.clone();
    edited[z] = "z = -5.0".into();
    std::fs::write(&path, edited.join("\n")).unwrap();
    let msg = one_line(&params_file::load(&path).unwrap_err());
    assert_eq!(
        msg,
        format!(
            "{}: line {}: contacts.torso.damping_n_s_per_m.z: must be greater than zero",
            path.display(),
            z + 1
        )
    );

    std::fs::write(&path, text.replace("mass_kg = 81.0", "mass_kg = \"heavy\"")).unwrap();
    let msg = one_line(&params_file::load(&path).unwrap_err());
    assert!(
        msg.starts_with(&format!("{}: line 11, column", path.display())),
        "{msg}"
    );
    assert!(!msg.contains('\n'));

    std::fs::write(
        &path,
        text.replace("[subject]", "[subject]\nage_years = 23"),
    )
    .unwrap();
    let msg = one_line(&params_file::load(&path).unwrap_err());
    assert!(msg.contains("age_years"), "{msg}");

    let missing = dir.path().join("nope.toml");
    let msg = one_line(&params_file::load(&missing).unwrap_err());
    assert!(
        msg.starts_with(&format!("{}: cannot read", missing.display())),
        "{msg}"
    );
}

#[test]
fn modes_and_params_accept_a_parameter_file_wherever_a_preset_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("litter.toml");
    params_file::save(&path, &ParamFile::preset(Preset::PaperLitter)).unwrap();
    supine(&["modes", "--params", path.to_str().unwrap()]).unwrap();
    supine(&["params", "--params", path.to_str().unwrap()]).unwrap();
    assert!(supine(&["modes", "--preset", "paper-litter", "--params", "x.toml"]).is_err());
    assert!(supine(&["modes"]).is_err());
}
