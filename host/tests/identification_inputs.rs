//! Every bad-input case of a dataset gives a one-line error naming the file, the line and
//! column, and what was expected; nothing panics and no output file is left behind.

use std::path::{Path, PathBuf};

use clap::Parser;
use supine_host::cli::{Cli, one_line, run};
use supine_host::identify::synth::{SynthSettings, write_dataset};
use supine_host::io::recording::OLD_COLUMNS;

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
    edit_line(&file, 1, |l| l.replace("head_x_m_s2", "head_X_m_s2"));
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains(
            "s1_rigid.csv: line 1, column 5: expected the header field \"head_x_m_s2\", found \"head_X_m_s2\""
        ),
        "{e}"
    );
    // A header written before the columns carried their unit is read; a slip in one is
    // named in its own naming.
    let old = OLD_COLUMNS.join(",");
    edit_line(&file, 1, |_| old.clone());
    let out = ds.join("H.csv");
    let (ds_arg, out_arg) = (ds.to_str().unwrap(), out.to_str().unwrap());
    supine(&[
        "transmissibility",
        "--dataset",
        ds_arg,
        "--case",
        "rigid",
        "--out",
        out_arg,
    ])
    .unwrap();
    std::fs::remove_file(&out).unwrap();
    edit_line(&file, 1, |_| old.replace("head_x", "head_X"));
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
        l.replace(
            "platform_x_m_s2,platform_y_m_s2",
            "platform_y_m_s2,platform_x_m_s2",
        )
    });
    let e = transmissibility_error(&ds, &[]);
    assert!(
        e.contains(
            "line 1, column 2: expected the header field \"platform_x_m_s2\", found \"platform_y_m_s2\""
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
        e.contains(
            "s2_rigid.csv: line 17, column platform_y_m_s2: expected a number, found \"abc\""
        ),
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
                "s1_rigid.csv: line 40, column head_z_m_s2: expected a finite number, found \"{bad}\""
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
    assert!(
        e.ends_with(
            "dataset.toml:11:1: field rigid (subject s2): expected a `rigid` recording for --case rigid, found none"
        ),
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
    assert!(
        e.ends_with(
            "dataset.toml:12:6: field id: expected unique subject ids, found \"s1\" again (its first table starts on line 4)"
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
    // Line 7 is s1's `mass_kg = ...`; the value starts in column 11.
    assert!(e.contains("dataset.toml:7:11: field mass_kg: "), "{e}");
    assert!(e.contains("expected f64"), "{e}");
}

/// Rewrites dataset.toml with `from` replaced by `to` (once) and returns the error.
fn dataset_toml_error(from: &str, to: &str) -> String {
    let (_dir, ds) = dataset();
    let toml_path = ds.join("dataset.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    assert!(text.contains(from));
    std::fs::write(&toml_path, text.replacen(from, to, 1)).unwrap();
    let e = transmissibility_error(&ds, &[]);
    let prefix = format!("{}:", toml_path.display());
    assert!(e.starts_with(&prefix), "{e}");
    e[prefix.len()..].to_string()
}

#[test]
fn a_non_positive_height_names_line_column_and_field() {
    // Line 6 of s1's table is `height_m = ...`: the value starts in column 12.
    let e = dataset_toml_error("height_m = ", "height_m = -1.0 # ");
    assert_eq!(
        e,
        "6:12: field height_m (subject s1): expected a positive finite number, found -1"
    );
}

#[test]
fn an_unknown_key_names_line_column_and_field() {
    let e = dataset_toml_error("mass_kg = ", "weight_kg = ");
    assert!(
        e.starts_with("7:1: field weight_kg: unknown field `weight_kg`"),
        "{e}"
    );
}

#[test]
fn a_missing_key_names_the_subjects_table_and_field() {
    let e = dataset_toml_error("id = \"s2\"\n", "");
    assert!(e.starts_with("11:1: field id: missing field `id`"), "{e}");
}

#[test]
fn an_empty_subject_id_names_line_column_and_field() {
    let e = dataset_toml_error("id = \"s2\"", "id = \" \"");
    assert_eq!(e, "12:6: field id: expected a non-empty subject id");
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
    assert!(stderr.contains(
        "s2_rigid.csv: line 17, column platform_y_m_s2: expected a number, found \"abc\""
    ));
    assert!(!out.exists());
}

#[test]
fn a_dead_platform_axis_names_the_recording_and_the_band() {
    let (_dir, ds) = dataset();
    let file = ds.join("s2_rigid.csv");
    let text = std::fs::read_to_string(&file).unwrap();
    let mut out = vec![text.lines().next().unwrap().to_string()];
    for line in text.lines().skip(1) {
        let mut cells: Vec<&str> = line.split(',').collect();
        cells[2] = "0";
        out.push(cells.join(","));
    }
    std::fs::write(&file, out.join("\n") + "\n").unwrap();
    let e = transmissibility_error(&ds, &[]);
    // 2048-sample segments at 200 Hz: bins of 0.0977 Hz, the 158 in 0.5-16 Hz span 0.586-15.918.
    assert!(
        e.contains("s2_rigid.csv: columns platform_x_m_s2, platform_y_m_s2, platform_z_m_s2: the inputs' cross-spectral matrix Sxx is singular or ill-conditioned"),
        "{e}"
    );
    assert!(e.contains("at 158 of 158 bins in 0.586-15.918 Hz"), "{e}");
}
