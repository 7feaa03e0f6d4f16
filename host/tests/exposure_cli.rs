//! `supine exposure`, run in-process (and once as the binary, for the exit status): the
//! channel form against closed-form ISO 2631-1 values of a sine, the model form against the
//! device's stages stepped by hand, resampling, and every bad input as a one-line error.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use clap::Parser;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;
use supine_core::alerts::{AlertEvent, Criterion};
use supine_core::exposure::ExposureState;
use supine_core::input_resolution::quantize_m_s2;
use supine_core::model::ModalState;
use supine_core::weighting::{WeightingKind, analog_response};
use supine_host::cli::{Cli, Command, one_line, run};
use supine_host::exposure::ride::{Profile, generate, write_ride};
use supine_host::io::params_file::ParamFile;
use supine_host::io::recording::HEADER_LINE;

/// Runs `supine exposure ...` in-process and returns what it printed.
fn exposure(args: &[&str]) -> anyhow::Result<String> {
    let mut argv = vec!["supine", "exposure"];
    argv.extend_from_slice(args);
    let cli = Cli::try_parse_from(argv)?;
    let Command::Exposure(args) = cli.command else {
        unreachable!("parsed as exposure")
    };
    let mut out = Vec::new();
    supine_host::commands::exposure::run_to(&args, &mut out)?;
    Ok(String::from_utf8(out)?)
}

fn json(args: &[&str]) -> Value {
    let mut a = args.to_vec();
    a.push("--json");
    let text = exposure(&a).unwrap();
    assert_eq!(text.lines().count(), 1, "one JSON object on one line");
    serde_json::from_str(&text).unwrap()
}

fn err(args: &[&str]) -> String {
    match exposure(args) {
        Ok(out) => panic!("expected an error, got {out}"),
        Err(e) => one_line(&e),
    }
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}

/// A 13-column recording at `fs` whose column `column` (1..=12) is `signal(t)`, others 0.
fn write_recording(path: &Path, fs: f64, n: usize, column: usize, signal: impl Fn(f64) -> f64) {
    let mut text = format!("{HEADER_LINE}\n");
    for k in 0..n {
        let t = k as f64 / fs;
        let mut row = vec![format!("{t}")];
        for c in 1..13 {
            row.push(if c == column {
                format!("{}", signal(t))
            } else {
                "0".to_string()
            });
        }
        text.push_str(&row.join(","));
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Largest running mean square of a sine of amplitude `a` at `f` through the exponential
/// average with time constant `tau`: `a^2/2 (1 + 1/sqrt(1 + (2 w tau)^2))` (steady state).
fn mtvv_of_sine(a: f64, f: f64, tau: f64) -> f64 {
    let w = 2.0 * PI * f;
    (a * a / 2.0 * (1.0 + 1.0 / (1.0 + (2.0 * w * tau).powi(2)).sqrt())).sqrt()
}

#[test]
fn a_sine_evaluates_to_the_closed_form_rms_vdv_mtvv_peak_and_crest_factor() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 500.0;
    // Whole cycles in the 60 s evaluated after the 5 s warm-up.
    for (kind, name, f, amplitude, column) in [
        (WeightingKind::Wk, "wk", 6.0, 1.3, 6usize),
        (WeightingKind::Wd, "wd", 1.0, 0.8, 4),
        (WeightingKind::Wj, "wj", 10.0, 2.0, 3),
        (WeightingKind::Wj, "wj", 4.0, 0.5, 12),
    ] {
        let path = dir.path().join(format!("{name}_{f}.csv"));
        write_recording(&path, fs, 65 * fs as usize, column, |t| {
            amplitude * (2.0 * PI * f * t).sin()
        });
        let channel = supine_host::io::recording::COLUMNS[column];
        let v = json(&[
            "--input",
            s(&path),
            "--channel",
            channel,
            "--weighting",
            name,
        ]);
        let case = format!("{name} at {f} Hz on {channel}");
        assert_eq!(v["form"], "channel");
        assert_eq!(v["channel"], channel);
        assert_eq!(v["valid"], true);
        let t = num(&v, "evaluated_s");
        assert!((t - 60.0).abs() < 1e-3, "{case}: evaluated {t} s");
        // The weighted amplitude from the analog definition (the authority).
        let aw = amplitude * analog_response(kind, f).abs();
        let within = |key: &str, expected: f64, tol: f64| {
            let got = num(&v, key);
            eprintln!(
                "{case}: {key} off by {:+.4} %",
                (got / expected - 1.0) * 100.0
            );
            assert!(
                (got / expected - 1.0).abs() < tol,
                "{case}: {key} = {got}, expected {expected} +- {}",
                tol * 100.0
            );
        };
        within("rms_m_s2", aw / 2f64.sqrt(), 0.003);
        within("peak_m_s2", aw, 0.003);
        within("crest_factor", 2f64.sqrt(), 0.003);
        within("vdv_m_s175", (3.0 / 8.0 * aw.powi(4) * t).powf(0.25), 0.003);
        within("mtvv_m_s2", mtvv_of_sine(aw, f, 1.0), 0.003);
        within("unweighted_rms_m_s2", amplitude / 2f64.sqrt(), 1e-3);
        assert_eq!(v["additional_methods"]["crest_factor"], false);
    }
}

#[test]
fn the_channel_form_prints_a_readable_table() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.csv");
    write_recording(&path, 500.0, 4000, 6, |t| (2.0 * PI * 5.0 * t).sin());
    let text = exposure(&[
        "--input",
        s(&path),
        "--channel",
        "head_z_m_s2",
        "--weighting",
        "wk",
    ])
    .unwrap();
    assert!(text.contains("exposure of column head_z_m_s2"), "{text}");
    assert!(text.contains("m/s^1.75"), "{text}");
    assert!(
        text.lines()
            .any(|l| l.starts_with("head_z_m_s2") && l.contains("wk")),
        "{text}"
    );
}

#[test]
fn a_recording_written_before_the_columns_carried_their_unit_reads_as_before() {
    let dir = tempfile::tempdir().unwrap();
    let new = dir.path().join("new.csv");
    write_recording(&new, 500.0, 4000, 6, |t| (2.0 * PI * 5.0 * t).sin());
    let old = dir.path().join("old.csv");
    let text = std::fs::read_to_string(&new).unwrap();
    assert!(text.starts_with("time_s,platform_x_m_s2,"), "{text:.80}");
    let old_header = supine_host::io::recording::OLD_COLUMNS.join(",");
    std::fs::write(&old, text.replacen(HEADER_LINE, &old_header, 1)).unwrap();
    // Either name of the column, in either file: the same numbers (the file's and the
    // column's names aside).
    let unnamed = |mut v: Value| {
        v["input"] = Value::Null;
        v["channel"] = Value::Null;
        v
    };
    let channel = |path: &Path, name: &str| {
        unnamed(json(&[
            "--input",
            s(path),
            "--channel",
            name,
            "--weighting",
            "wj",
        ]))
    };
    let today = channel(&new, "head_z_m_s2");
    assert!(num(&today, "rms_m_s2") > 0.1, "{today}");
    assert_eq!(channel(&old, "head_z_m_s2"), today);
    assert_eq!(channel(&old, "head_z"), today);
    assert_eq!(channel(&new, "head_z"), today);
    // And through the model.
    let model = |path: &Path| unnamed(json(&["--preset", "paper-litter", "--input", s(path)]));
    assert_eq!(model(&old), model(&new));
}

/// The ride's platform columns as the file holds them (parsed here, independently).
fn read_platform(path: &Path) -> Vec<[f32; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [c[1] as f32, c[2] as f32, c[3] as f32]
        })
        .collect()
}

fn ride_file(dir: &Path, profile: Profile, duration_s: f64, fs: f64, seed: u64) -> PathBuf {
    let path = dir.join(format!("{}_{seed}.csv", profile.name()));
    write_ride(&path, &generate(profile, duration_s, fs, seed).unwrap()).unwrap();
    path
}

#[test]
fn the_model_form_equals_the_device_stages_stepped_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 500.0;
    let path = ride_file(dir.path(), Profile::RoughRoad, 45.0, fs, 7);
    let v = json(&["--preset", "paper-litter", "--input", s(&path)]);
    assert_eq!(v["form"], "model");
    assert_eq!(v["layout"], "platform-only");
    assert_eq!(num(&v, "sample_rate_hz"), fs);

    // By hand: the input's rounding to the device's resolution, the model, the exposure
    // stage and the alert stage, one sample at a time.
    let file = ParamFile::preset(supine_core::model::Preset::PaperLitter);
    let params = supine_host::device::device_params::build(&file, fs).unwrap();
    let input = read_platform(&path);
    let mut model = ModalState::default();
    let mut exposure = ExposureState::new();
    let mut alerts = supine_core::alerts::AlertState::new();
    let mut events = Vec::new();
    for (k, x) in input.iter().enumerate() {
        let x = quantize_m_s2(*x, params.sensor_checks.config.full_scale_m_s2);
        let head = params.realization.step(&mut model, x);
        let e = params.exposure.step(&mut exposure, head, k as u32);
        if let Some(ev) = params.alerts.step(&mut alerts, &e, k as u32) {
            events.push(ev);
        }
    }
    let values = params.exposure.values(params.sample_rate, &exposure);
    let same = |json: &Value, key: &str, expected: f32| {
        assert_eq!(num(json, key) as f32, expected, "{key}");
    };
    for (i, axis) in values.axes.iter().enumerate() {
        let j = &v["head"][i];
        same(j, "rms_m_s2", axis.rms_m_s2);
        same(j, "mtvv_m_s2", axis.mtvv_m_s2);
        same(j, "vdv_m_s175", axis.vdv_m_s175);
        same(j, "peak_m_s2", axis.peak_m_s2);
        same(j, "crest_factor", axis.crest_factor);
    }
    same(&v["vector"], "rms_m_s2", values.vector.rms_m_s2);
    same(&v["vector"], "mtvv_m_s2", values.vector.mtvv_m_s2);
    same(&v["vector"], "vdv_m_s175", values.vector.vdv_m_s175);
    assert_eq!(v["head"][2]["weighting"], "wj");
    assert_eq!(v["head"][0]["weighting"], "wd");

    // The timeline: the same level changes at the same samples, and no sensor fault.
    let timeline = v["alerts"].as_array().unwrap();
    assert!(!events.is_empty(), "a rough road raises alerts");
    assert_eq!(timeline.len(), events.len(), "{timeline:?}");
    for (j, e) in timeline.iter().zip(&events) {
        let AlertEvent::Level {
            to,
            criterion,
            at_sample,
            ..
        } = *e
        else {
            panic!("only level events expected")
        };
        assert_eq!(j["kind"], "level");
        // What changed the level, with its value in a key that names the unit.
        assert_eq!(j["criterion"], criterion.name());
        let key = match criterion {
            Criterion::RunningRms { .. } => "value_m_s2",
            Criterion::Vdv { .. } => "value_m_s175",
        };
        assert_eq!(num(j, key), f64::from(criterion.value()));
        assert_eq!(j["sample"].as_u64(), Some(at_sample as u64));
        assert_eq!(j["level"], to.name());
        assert!((num(j, "time_s") - at_sample as f64 / fs).abs() < 1e-9);
    }
    assert_eq!(v["final_level"], alerts.level().name());
}

#[test]
fn the_model_form_prints_the_table_and_the_alert_timeline() {
    let dir = tempfile::tempdir().unwrap();
    let path = ride_file(dir.path(), Profile::RoughRoad, 30.0, 500.0, 3);
    let text = exposure(&["--params", "/nonexistent.toml", "--input", s(&path)]);
    assert!(one_line(&text.unwrap_err()).contains("/nonexistent.toml"));
    let text = exposure(&["--preset", "paper-rigid", "--input", s(&path)]).unwrap();
    for needle in [
        "model paper-rigid",
        "head z     wj",
        "vector",
        "time_s  event",
        "level normal -> ",
        "highest level: ",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in\n{text}");
    }
}

#[test]
fn a_parameter_files_device_table_sets_the_thresholds() {
    let dir = tempfile::tempdir().unwrap();
    let path = ride_file(dir.path(), Profile::Ambulance, 30.0, 500.0, 1);
    let mut file = ParamFile::preset(supine_core::model::Preset::PaperLitter);
    let mut device = supine_host::io::params_file::DeviceSection::default();
    device.alerts.running_rms_m_s2 = [0.05, 0.08, 0.1];
    file.device = Some(device);
    let params = dir.path().join("p.toml");
    supine_host::io::params_file::save(&params, &file).unwrap();
    let v = json(&["--params", s(&params), "--input", s(&path)]);
    assert_eq!(v["max_level"], "alarm", "tiny thresholds on a real ride");
    assert_eq!(v["thresholds"]["running_rms_m_s2"][0].as_f64(), Some(0.05));
}

#[test]
fn fs_resamples_the_recording_before_the_device_runs() {
    let dir = tempfile::tempdir().unwrap();
    let path = ride_file(dir.path(), Profile::Lab, 30.0, 1000.0, 2);
    let own = json(&["--preset", "paper-litter", "--input", s(&path)]);
    let v = json(&[
        "--preset",
        "paper-litter",
        "--input",
        s(&path),
        "--fs",
        "500",
    ]);
    assert_eq!(num(&v, "sample_rate_hz"), 500.0);
    assert_eq!(num(&v, "resampled_from_hz"), 1000.0);
    assert_eq!(num(&v, "samples"), 15_000.0);
    // The lab input lies far below 200 Hz: the exposure hardly depends on the rate.
    for key in ["rms_m_s2", "vdv_m_s175"] {
        let (a, b) = (num(&v["vector"], key), num(&own["vector"], key));
        assert!(
            (a / b - 1.0).abs() < 0.01,
            "{key}: {a} at 500 Hz, {b} at 1 kHz"
        );
    }
    assert!(own["resampled_from_hz"].is_null());
    // --fs at the recording's own rate converts nothing.
    let same = json(&[
        "--preset",
        "paper-litter",
        "--input",
        s(&path),
        "--fs",
        "1000",
    ]);
    assert!(same["resampled_from_hz"].is_null());
    assert_eq!(same["vector"], own["vector"]);
}

#[test]
fn a_recording_outside_100_to_2000_hz_needs_fs() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("slow.csv");
    write_recording(&path, 50.0, 1000, 3, |t| (2.0 * PI * 2.0 * t).sin());
    let e = err(&["--preset", "paper-litter", "--input", s(&path)]);
    assert!(
        e.contains("slow.csv") && e.contains("50.0") && e.contains("--fs"),
        "{e}"
    );
    let e = err(&[
        "--input",
        s(&path),
        "--channel",
        "platform_z",
        "--weighting",
        "wk",
    ]);
    assert!(e.contains("100..=2000") && e.contains("--fs"), "{e}");
    let v = json(&[
        "--input",
        s(&path),
        "--channel",
        "platform_z",
        "--weighting",
        "wk",
        "--fs",
        "200",
    ]);
    assert_eq!(num(&v, "sample_rate_hz"), 200.0);
    assert_eq!(num(&v, "samples"), 3997.0);
    let e = err(&[
        "--preset",
        "paper-litter",
        "--input",
        s(&path),
        "--fs",
        "5000",
    ]);
    assert!(e.contains("--fs 5000") && e.contains("100..=2000"), "{e}");
}

#[test]
fn bad_cells_are_reported_with_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full.csv");
    write_recording(&full, 500.0, 3000, 3, |_| 0.1);
    let text = std::fs::read_to_string(&full).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[3] = "0.004,0,abc,0,0,0,0,0,0,0,0,0,0".to_string();
    std::fs::write(&full, lines.join("\n")).unwrap();
    let e = err(&["--preset", "paper-litter", "--input", s(&full)]);
    assert!(
        e.contains("full.csv: line 4, column platform_y") && e.contains("abc"),
        "{e}"
    );

    // A platform-only file: the reader's own checks, line for line.
    let ride = ride_file(dir.path(), Profile::Lab, 10.0, 500.0, 1);
    let text = std::fs::read_to_string(&ride).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[9] = "0.016,0.1,0.2".to_string();
    std::fs::write(&ride, lines.join("\n")).unwrap();
    let e = err(&["--preset", "paper-litter", "--input", s(&ride)]);
    assert!(
        e.contains("line 10: expected 4 ','-separated cells") && e.contains("found 3"),
        "{e}"
    );
    lines[9] = "0.016,0.1,0.2,inf".to_string();
    std::fs::write(&ride, lines.join("\n")).unwrap();
    let e = err(&["--preset", "paper-litter", "--input", s(&ride)]);
    assert!(
        e.contains(
            "line 10, column platform_z_m_s2: expected an acceleration in m/s^2 (a finite number)"
        ),
        "{e}"
    );
    let wrong = dir.path().join("wrong.csv");
    std::fs::write(&wrong, "time_s,platform_x,platform_q,platform_z\n0,0,0,0\n").unwrap();
    let e = err(&["--preset", "paper-litter", "--input", s(&wrong)]);
    assert!(
        e.contains("line 1: header not recognized")
            && e.ends_with("give --columns time=time_s,x=platform_x,y=platform_q,z=platform_z"),
        "{e}"
    );
    let e = err(&[
        "--preset",
        "paper-litter",
        "--input",
        "/nonexistent/ride.csv",
    ]);
    assert!(e.contains("/nonexistent/ride.csv: cannot read"), "{e}");
}

#[test]
fn an_unknown_or_absent_channel_is_refused_with_the_columns_there_are() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full.csv");
    write_recording(&full, 500.0, 3000, 3, |_| 0.1);
    let e = err(&[
        "--input",
        s(&full),
        "--channel",
        "head_w",
        "--weighting",
        "wj",
    ]);
    assert!(
        e.contains("--channel head_w")
            && e.contains("platform_x_m_s2, platform_y_m_s2")
            && e.contains("pelvis_z"),
        "{e}"
    );
    let e = err(&[
        "--input",
        s(&full),
        "--channel",
        "time_s",
        "--weighting",
        "wj",
    ]);
    assert!(e.contains("--channel time_s"), "{e}");
    // A ride has no head column.
    let ride = ride_file(dir.path(), Profile::Lab, 10.0, 500.0, 1);
    let e = err(&[
        "--input",
        s(&ride),
        "--channel",
        "head_z",
        "--weighting",
        "wj",
    ]);
    assert!(
        e.contains("platform_x_m_s2, platform_y_m_s2, platform_z_m_s2") && !e.contains("pelvis"),
        "{e}"
    );
}

#[test]
fn the_two_forms_cannot_be_mixed_and_one_must_be_given() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("r.csv");
    let p = s(&p);
    // Neither form: the model form with the litter-board preset.
    assert!(Cli::try_parse_from(["supine", "exposure", "--input", p]).is_ok());
    for args in [
        vec!["--input", p, "--channel", "head_z"],
        vec!["--input", p, "--weighting", "wk"],
        vec![
            "--input",
            p,
            "--preset",
            "paper-litter",
            "--channel",
            "head_z",
            "--weighting",
            "wk",
        ],
        vec![
            "--input",
            p,
            "--preset",
            "paper-litter",
            "--params",
            "x.toml",
        ],
    ] {
        let mut argv = vec!["supine", "exposure"];
        argv.extend(args.iter().copied());
        assert!(Cli::try_parse_from(&argv).is_err(), "{argv:?} parsed");
    }
}

#[test]
fn a_recording_shorter_than_the_warm_up_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.csv");
    write_recording(&path, 500.0, 2000, 3, |t| t.sin());
    let e = err(&["--preset", "paper-litter", "--input", s(&path)]);
    assert!(
        e.contains("short.csv") && e.contains("4.000 s") && e.contains("5 s warm-up"),
        "{e}"
    );
}

#[test]
fn the_binary_exits_non_zero_with_one_line_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    std::fs::write(&path, format!("{HEADER_LINE}\n0,1,2\n")).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["exposure", "--preset", "paper-litter", "--input", s(&path)])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("supine: ") && stderr.contains("bad.csv: line 2"),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
    // And a good run through `run` (the CLI entry tests use) succeeds.
    let ok = dir.path().join("ok.csv");
    write_recording(&ok, 500.0, 3000, 3, |t| t.sin());
    run(Cli::try_parse_from([
        "supine",
        "exposure",
        "--input",
        s(&ok),
        "--channel",
        "platform_z",
        "--weighting",
        "wk",
        "--json",
    ])
    .unwrap())
    .unwrap();
}

/// Issue 17, D1: one absurd but finite sample (1e30 m/s^2) used to print inf and NaN with
/// exit 0. It is clipped at the sensor's full scale, raises the saturation fault, and
/// every value stays finite.
#[test]
fn one_sample_of_1e30_gives_finite_values_and_a_saturation_fault() {
    let dir = tempfile::tempdir().unwrap();
    let path = ride_file(dir.path(), Profile::Ambulance, 20.0, 500.0, 3);
    let text = std::fs::read_to_string(&path).unwrap();
    let spiked: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(k, line)| {
            if k == 2000 {
                let mut cells: Vec<&str> = line.split(',').collect();
                cells[3] = "1e30";
                cells.join(",")
            } else {
                line.to_string()
            }
        })
        .collect();
    std::fs::write(&path, spiked.join("\n") + "\n").unwrap();
    let v = json(&["--preset", "paper-litter", "--input", s(&path)]);
    let mut numbers = Vec::new();
    fn collect(v: &Value, out: &mut Vec<f64>) {
        match v {
            Value::Number(n) => out.push(n.as_f64().unwrap()),
            Value::Array(a) => a.iter().for_each(|x| collect(x, out)),
            Value::Object(o) => o.values().for_each(|x| collect(x, out)),
            _ => {}
        }
    }
    collect(&v, &mut numbers);
    assert!(numbers.iter().all(|x| x.is_finite()), "{v}");
    // JSON has no inf or NaN: serde_json writes them as null, which must not appear in the
    // exposure values either.
    for values in [&v["head"], &v["vector"]] {
        assert!(!values.to_string().contains("null"), "{values}");
    }
    let text = exposure(&["--preset", "paper-litter", "--input", s(&path)]).unwrap();
    assert!(!text.contains("inf") && !text.contains("NaN"), "{text}");
    assert!(text.contains("fault saturated raised"), "{text}");
}

/// A logger's rows are parsed once and kept in a scratch file for the passes after
/// (`ride::scratch_rows`); where none can be made (`TMPDIR` missing), the passes parse the
/// text again: the same output, byte for byte.
#[test]
fn a_ride_read_without_a_scratch_file_gives_the_same_output() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("jittered.csv");
    let mut text = format!("{}\n", supine_host::io::recording::PLATFORM_HEADER_LINE);
    let mut rng = ChaCha8Rng::seed_from_u64(26);
    for k in 0..4000 {
        // 200 Hz with up to +-1 ms of jitter.
        let jitter_s = rng.random_range(-1e-3..1e-3);
        let t = k as f64 / 200.0 + jitter_s;
        let z = 9.81 + (2.0 * PI * 4.0 * t).sin();
        text.push_str(&format!(
            "{t:.6},{:.6},0,{z:.6}\n",
            0.3 * (2.0 * PI * 1.5 * t).cos()
        ));
    }
    std::fs::write(&path, text).unwrap();
    let run = |tmpdir: &Path| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_supine"))
            .args([
                "exposure",
                "--input",
                s(&path),
                "--remove-gravity",
                "--json",
            ])
            .env("TMPDIR", tmpdir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        String::from_utf8(out.stdout).unwrap()
    };
    let kept = run(dir.path());
    let missing = run(&dir.path().join("no such folder"));
    assert!(kept.contains("\"data_quality\""), "{kept}");
    assert_eq!(missing, kept);
}
