//! ISO 8041-1 self-verification through the shipping firmware image in QEMU
//! (`supine verify --qemu`, docs/exposure.md "ISO 8041-1 verification"): every test passes
//! at one rate here, at every supported rate under `--ignored`
//! (`cargo test --release -p supine-qemu-tests --test qemu verify:: -- --ignored --nocapture`),
//! and the verification can fail: a detuned weighting fails the frequency response, a
//! wrong time constant the decay test.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use supine_host::device::image::ProductImage;
use supine_host::verify::plan::Group;
use supine_host::verify::{self, Conformance, SUPPORTED_RATES_HZ, Variant};
use supine_qemu_tests::run_supine;

fn verify(rates: &[f64], variant: Variant, groups: &[Group]) -> Conformance {
    let image = ProductImage::embedded().expect("the embedded image");
    let stop = Arc::new(AtomicBool::new(false));
    verify::run(&image, rates, variant, groups, &stop, &mut |what| {
        eprintln!("verifying: {what}")
    })
    .expect("the verification runs")
}

fn failures(c: &Conformance) -> Vec<String> {
    c.tests
        .iter()
        .filter(|t| !t.pass)
        .map(|t| {
            format!(
                "{} Hz {} {} {:?}: measured {} expected {} limits {}..{}",
                t.fs_hz,
                t.name,
                t.weighting,
                t.frequency_hz,
                t.measured,
                t.expected,
                t.lower_limit,
                t.upper_limit
            )
        })
        .collect()
}

/// The command at one rate: every test passes, the report and the JSON are written, and
/// the JSON has exactly the keys, named by the output vocabulary's rules.
#[test]
fn every_test_passes_at_100_hz_and_the_report_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("conformance");
    let (ok, stdout, stderr) = run_supine(&[
        "verify",
        "--qemu",
        "--fs",
        "100",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_str(stdout.trim()).expect(&stderr);
    let failed: Vec<&serde_json::Value> = json["tests"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|t| t["pass"] != true)
        .collect();
    assert!(ok && failed.is_empty(), "{failed:#?}\n{stderr}");
    let mut keys: Vec<&String> = json.as_object().unwrap().keys().collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "date",
            "firmware_sha256",
            "params_identity",
            "pass",
            "tests",
            "version"
        ]
    );
    let test = json["tests"][1].as_object().unwrap();
    for key in [
        "clause",
        "name",
        "weighting",
        "fs_hz",
        "frequency_hz",
        "expected",
        "measured",
        "lower_limit",
        "upper_limit",
        "unit",
        "pass",
    ] {
        assert!(test.contains_key(key), "{key} in {test:?}");
    }
    assert_eq!(json["firmware_sha256"].as_str().unwrap().len(), 64);
    // The output vocabulary (host/tests/output_names.rs holds the host's commands to it).
    let problems = supine_host::schema::names::json_problems(&json, "verify");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    let names: Vec<&str> = json["tests"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["name"].as_str().unwrap())
        .collect();
    for name in [
        "reference check",
        "frequency response",
        "decay time to -20 dB",
        "burst of 1 cycle: MTVV",
        "burst of 16 cycles: VDV",
        "continuous signal: MTVV",
        "linearity at 0.01 m/s^2 rms input",
        "under-range indication",
    ] {
        assert!(names.contains(&name), "{name} in {names:?}");
    }
    let page = std::fs::read_to_string(out.join("conformance.html")).unwrap();
    assert!(page.contains("What this is not") && page.contains("PASS"));
    assert!(page.contains(json["firmware_sha256"].as_str().unwrap()));
    assert!(out.join("conformance.json").exists());
}

/// At 500 Hz, the shipping rate. At 100 Hz the same move changes the response less (the
/// pole sits nearer the origin already) and only the reference check (+-4 %) catches it,
/// the one-third-octave points staying inside +12/-11 %.
#[test]
fn a_weighting_with_one_pole_moved_5_percent_fails_the_frequency_response() {
    let c = verify(&[500.0], Variant::DetunedWk, &[Group::Response]);
    let failed = failures(&c);
    assert!(!c.pass, "the detuned weighting passed");
    assert!(
        c.tests
            .iter()
            .any(|t| !t.pass && t.weighting == "Wk" && t.name == "frequency response"),
        "{failed:#?}"
    );
    // Only Wk was detuned.
    assert!(
        c.tests
            .iter()
            .filter(|t| t.weighting != "Wk")
            .all(|t| t.pass),
        "{failed:#?}"
    );
}

#[test]
fn a_running_rms_with_the_wrong_time_constant_fails_the_decay_test() {
    let c = verify(&[100.0], Variant::RunningTau(1.25), &[Group::Decay]);
    assert!(!c.pass);
    let decay: Vec<_> = c
        .tests
        .iter()
        .filter(|t| t.name == "decay time to -20 dB")
        .collect();
    assert_eq!(decay.len(), 3);
    assert!(
        decay.iter().all(|t| !t.pass && t.measured > 5.0),
        "{decay:#?}"
    );
}

/// The full run, every supported rate (minutes): `cargo test --release -p
/// supine-qemu-tests --test qemu verify:: -- --ignored --nocapture`; the figures go to
/// BENCHMARKS.md.
#[test]
#[ignore]
fn every_test_passes_at_every_supported_rate() {
    let c = verify(&SUPPORTED_RATES_HZ, Variant::Shipping, &Group::ALL);
    eprintln!(
        "{} tests at {:?} Hz in {:.0} s, {} failed",
        c.tests.len(),
        SUPPORTED_RATES_HZ,
        c.elapsed_s,
        failures(&c).len()
    );
    for rate in SUPPORTED_RATES_HZ {
        let at: Vec<_> = c.tests.iter().filter(|t| t.fs_hz == rate).collect();
        let worst = at
            .iter()
            .filter_map(|t| t.deviation_percent().map(|d| (d.abs(), t)))
            .fold(None::<(f64, &&verify::TestResult)>, |m, x| match m {
                Some(m) if m.0 >= x.0 => Some(m),
                _ => Some(x),
            });
        if let Some((d, t)) = worst {
            eprintln!(
                "{rate} Hz: {} tests, largest deviation {d:.2} % ({} {} {:?})",
                at.len(),
                t.name,
                t.weighting,
                t.frequency_hz
            );
        }
    }
    assert!(c.pass, "{:#?}", failures(&c));
}
