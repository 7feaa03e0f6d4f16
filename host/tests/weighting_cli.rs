//! `supine weighting`, run in-process.

use clap::Parser;
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::{WeightingKind, WeightingSettings, analog_response};
use supine_host::cli::{Cli, one_line, run};

fn supine(args: &[&str]) -> anyhow::Result<()> {
    let mut argv = vec!["supine"];
    argv.extend_from_slice(args);
    run(Cli::try_parse_from(argv)?)
}

fn rows(path: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn weighting_writes_the_device_filter_at_exact_one_third_octave_centres_below_nyquist() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("W.csv");
    supine(&[
        "weighting",
        "--weighting",
        "wk",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap();
    let (header, rows) = rows(&out);
    assert_eq!(header, "freq_hz,magnitude,phase_rad,analog_magnitude");
    // 0.1 Hz (n = -10) up to 199.5 Hz (n = 23): the next centre, 251 Hz, is above fs/2.
    assert_eq!(rows.len(), 34);
    let fs = SampleRate::new(500.0).unwrap();
    let device = WeightingSettings::new(WeightingKind::Wk, fs).unwrap();
    for (r, n) in rows.iter().zip(-10..) {
        let f = 10f64.powf(n as f64 / 10.0);
        assert_eq!(r[0], f);
        let h = device.response(fs, f);
        assert_eq!(r[1], h.abs());
        assert_eq!(r[2], h.arg());
        assert_eq!(r[3], analog_response(WeightingKind::Wk, f).abs());
    }
    // 15.85 Hz (n = 12): close to the calibration factor 0.7718 at 15.915 Hz.
    assert!((rows[22][3] - 0.7718).abs() < 0.01);
}

#[test]
fn weighting_at_2_khz_runs_up_to_398_hz() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("W.csv");
    supine(&[
        "weighting",
        "--weighting",
        "wj",
        "--fs",
        "2000",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap();
    let (_, rows) = rows(&out);
    let last = rows.last().unwrap()[0];
    assert!((last - 10f64.powf(2.6)).abs() < 1e-9, "{last}");
    // Between 0.5 and 80 Hz the device's filter is within 1 % of the analog one at 2 kHz.
    for r in rows.iter().filter(|r| (0.5..=80.0).contains(&r[0])) {
        assert!((r[1] / r[3] - 1.0).abs() < 0.01, "{r:?}");
    }
}

#[test]
fn weighting_refuses_a_sample_rate_outside_100_to_2000_hz() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("W.csv");
    let err = supine(&[
        "weighting",
        "--weighting",
        "wd",
        "--fs",
        "50",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap_err();
    let msg = one_line(&err);
    assert!(msg.contains("100..=2000"), "{msg}");
    assert!(!out.exists());
}

#[test]
fn weighting_refuses_an_unknown_kind() {
    assert!(supine(&["weighting", "--weighting", "wb", "--out", "x.csv"]).is_err());
}
