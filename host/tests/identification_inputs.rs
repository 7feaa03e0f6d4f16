//! Every bad-input case of a dataset gives a one-line error naming the file, the line and
//! column, and what was expected; nothing panics and no output file is left behind.

use std::path::{Path, PathBuf};

use clap::Parser;
use supine_host::cli::{Cli, one_line, run};
use supine_host::synth::{SynthSettings, write_dataset};

fn supine(args: &[&str]) -> anyhow::Result<()> {
    let mut argv = vec!["supine"];
    argv.extend_from_slice(args);
    run(Cli::try_parse_from(argv)?)
}

/// A valid two-subject dataset of 30 s at 200 Hz.
fn dataset() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let ds = dir.path().join("ds");
    let settings = SynthSettings {
        subjects: 2,
        duration_s: 30.0,
        seed: 5,
        ..SynthSettings::default()
    };
    write_dataset(&ds, &settings, |_, _| {}).unwrap();
    (dir, ds)
}

/// Runs `transmissibility` on the dataset and returns its one-line error; checks that the
/// output was not written.
fn transmissibility_error(ds: &Path, extra: &[&str]) -> String {
    let out = ds.join("H.csv");
    let mut args = vec![
        "transmissibility",
        "--dataset",
        ds.to_str().unwrap(),
        "--case",
        "rigid",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let err = supine(&args).expect_err("bad input must fail");
    assert!(!out.exists(), "no output may be left behind");
    let leftovers: Vec<_> = std::fs::read_dir(ds)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty());
    let line = one_line(&err);
    assert!(!line.contains('\n'));
    line
}

fn edit_line(file: &Path, line_no: usize, f: impl Fn(&str) -> String) {
    let text = std::fs::read_to_string(file).unwrap();
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == line_no {
                f(l)
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(file, lines.join("\n") + "\n").unwrap();
}

fn set_cell(file: &Path, line_no: usize, column: usize, value: &str) {
    edit_line(file, line_no, |l| {
        let mut cells: Vec<&str> = l.split(',').collect();
        cells[column] = value;
        cells.join(",")
    });
}

#[test]
fn a_valid_dataset_gives_a_transmissibility_file() {
    let (_dir, ds) = dataset();
    let out = ds.join("H.csv");
    supine(&[
        "transmissibility",
        "--dataset",
        ds.to_str().unwrap(),
        "--case",
        "litter",
        "--subject",
        "s2",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("freq_hz,output,input,magnitude,phase_rad,coherence\n"));
}

#[test]
fn a_missing_recording_names_the_file() {
    let (_dir, ds) = dataset();
    std::fs::remove_file(ds.join("s2_rigid.csv")).unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(e.contains("s2_rigid.csv: cannot read the recording"), "{e}");
}

#[test]
fn a_missing_dataset_description_names_it() {
    let (_dir, ds) = dataset();
    std::fs::remove_file(ds.join("dataset.toml")).unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains("dataset.toml: cannot read the dataset description"),
        "{e}"
    );
}

#[test]
fn a_wrong_header_names_the_first_differing_field() {
    let (_dir, ds) = dataset();
    let file = ds.join("s1_rigid.csv");
    edit_line(&file, 1, |l| l.replace("head_x", "head_X"));
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains(
            "s1_rigid.csv: line 1, column 5: expected the header field \"head_x\", found \"head_X\""
        ),
        "{e}"
    );
}

#[test]
fn a_reordered_header_is_refused() {
    let (_dir, ds) = dataset();
    let file = ds.join("s1_rigid.csv");
    edit_line(&file, 1, |l| {
        l.replace("platform_x,platform_y", "platform_y,platform_x")
    });
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains(
            "line 1, column 2: expected the header field \"platform_x\", found \"platform_y\""
        ),
        "{e}"
    );
}

#[test]
fn a_non_numeric_cell_names_line_and_column() {
    let (_dir, ds) = dataset();
    let file = ds.join("s2_rigid.csv");
    set_cell(&file, 17, 2, "abc");
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains("s2_rigid.csv: line 17, column platform_y: expected a number, found \"abc\""),
        "{e}"
    );
}

#[test]
fn nan_and_infinite_values_are_refused() {
    for bad in ["NaN", "inf", "-infinity"] {
        let (_dir, ds) = dataset();
        let file = ds.join("s1_rigid.csv");
        set_cell(&file, 40, 6, bad);
        let e = transmissibility_error(&ds, &[]);
        assert!(
            e.contains(&format!(
                "s1_rigid.csv: line 40, column head_z: expected a finite number, found \"{bad}\""
            )),
            "{e}"
        );
    }
}

#[test]
fn time_that_does_not_increase_is_refused() {
    let (_dir, ds) = dataset();
    let file = ds.join("s1_rigid.csv");
    set_cell(&file, 101, 0, "0.485");
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains("s1_rigid.csv: line 101, column time_s: expected a time after 0.49 s (strictly increasing), found 0.485 s"),
        "{e}"
    );
}

#[test]
fn non_uniform_time_states_the_tolerance() {
    let (_dir, ds) = dataset();
    let file = ds.join("s1_rigid.csv");
    // Line 101 (sample 99) at 0.4955 s instead of 0.495 s: a step 10 % long.
    set_cell(&file, 101, 0, "0.4955");
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains("s1_rigid.csv: line 101, column time_s: expected uniform sampling"),
        "{e}"
    );
    assert!(e.contains("+- 1 %"), "{e}");
}

#[test]
fn a_recording_too_short_for_the_welch_settings_says_what_it_needs() {
    let (_dir, ds) = dataset();
    let file = ds.join("s2_rigid.csv");
    let text = std::fs::read_to_string(&file).unwrap();
    let short: Vec<&str> = text.lines().take(3001).collect();
    std::fs::write(&file, short.join("\n") + "\n").unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains("s2_rigid.csv: expected at least 5120 samples (4 Welch segments of 2048 samples with 1024 overlapping), found 3000"),
        "{e}"
    );
}

#[test]
fn a_subject_without_the_requested_case_is_named() {
    let (_dir, ds) = dataset();
    let toml_path = ds.join("dataset.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    std::fs::write(&toml_path, text.replace("rigid = \"s2_rigid.csv\"\n", "")).unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(e.contains("dataset.toml: line"), "{e}");
    assert!(
        e.contains("subject s2: expected a `rigid` recording for --case rigid, found none"),
        "{e}"
    );
}

#[test]
fn a_duplicate_subject_id_names_both_lines() {
    let (_dir, ds) = dataset();
    let toml_path = ds.join("dataset.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    std::fs::write(&toml_path, text.replace("id = \"s2\"", "id = \"s1\"")).unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(e.contains("dataset.toml: line"), "{e}");
    assert!(
        e.contains(
            "line 12, id: expected unique subject ids, found \"s1\" again (its first table starts on line 4)"
        ),
        "{e}"
    );
}

#[test]
fn recordings_with_different_sample_rates_are_refused() {
    let (_dir, ds) = dataset();
    let file = ds.join("s2_rigid.csv");
    let text = std::fs::read_to_string(&file).unwrap();
    let mut out = vec![text.lines().next().unwrap().to_string()];
    for (k, line) in text.lines().skip(1).enumerate() {
        let rest = line.split_once(',').unwrap().1;
        out.push(format!("{},{rest}", k as f64 / 250.0));
    }
    std::fs::write(&file, out.join("\n") + "\n").unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains("s2_rigid.csv: column time_s: expected the sample rate of"),
        "{e}"
    );
    assert!(e.contains("(200.000000 Hz), found 250.000000 Hz"), "{e}");
}

#[test]
fn an_unknown_subject_or_exclusion_is_named() {
    let (_dir, ds) = dataset();
    let e = transmissibility_error(&ds, &["--exclude", "s9"]);
    assert!(
        e.contains("expected a subject id among s1, s2, found \"s9\""),
        "{e}"
    );
}

#[test]
fn a_malformed_dataset_description_names_the_line() {
    let (_dir, ds) = dataset();
    let toml_path = ds.join("dataset.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    std::fs::write(
        &toml_path,
        text.replacen("mass_kg = ", "mass_kg = \"heavy\" # ", 1),
    )
    .unwrap();
    let e = transmissibility_error(&ds, &[]);
    assert!(e.contains("dataset.toml: line 7"), "{e}");
}

#[test]
fn the_binary_exits_non_zero_with_one_line_on_stderr() {
    let (_dir, ds) = dataset();
    let file = ds.join("s2_rigid.csv");
    set_cell(&file, 17, 2, "abc");
    let out = ds.join("H.csv");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["transmissibility", "--dataset"])
        .arg(&ds)
        .args(["--case", "rigid", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("supine: "), "{stderr}");
    assert!(
        stderr
            .contains("s2_rigid.csv: line 17, column platform_y: expected a number, found \"abc\"")
    );
    assert!(!out.exists());
}
