//! `supine exposure`'s neck and lower-back section against the joint response: a smoothly
//! started sine on the vertical axis must move each joint output by |H_J| times its
//! amplitude, and nothing the vertical axis does not drive.

use std::f64::consts::PI;
use std::fmt::Write as _;

use clap::Parser;
use serde_json::Value;
use supine_core::model::{JointOutput, JointUnit, ModelParams, Preset, SystemMatrices};
use supine_host::cli::{Cli, Command};
use supine_host::io::recording::PLATFORM_HEADER_LINE;

/// What `supine exposure --preset PRESET --input PATH [--json]` prints.
fn exposure_output(preset: &str, path: &std::path::Path, json: bool) -> Vec<u8> {
    let mut argv = vec![
        "supine",
        "exposure",
        "--preset",
        preset,
        "--input",
        path.to_str().unwrap(),
    ];
    if json {
        argv.push("--json");
    }
    let Command::Exposure(args) = Cli::try_parse_from(argv).unwrap().command else {
        unreachable!()
    };
    let mut out = Vec::new();
    supine_host::commands::exposure::run_to(&args, &mut out).unwrap();
    out
}

#[test]
fn a_vertical_sine_moves_the_joints_by_the_joint_response_and_the_report_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ride.csv");
    let (fs_hz, freq_hz, amplitude_m_s2, duration_s) = (500.0, 5.0, 1.5, 30.0);
    let n = (duration_s * fs_hz) as usize;
    let mut text = format!("{PLATFORM_HEADER_LINE}\n");
    for k in 0..n {
        let t = k as f64 / fs_hz;
        // Raised over 5 s so that the start from rest adds no transient overshoot.
        let ramp = if t < 5.0 {
            (1.0 - (PI * t / 5.0).cos()) / 2.0
        } else {
            1.0
        };
        let z = amplitude_m_s2 * ramp * (2.0 * PI * freq_hz * t).sin();
        writeln!(text, "{t},0,0,{z}").unwrap();
    }
    std::fs::write(&path, text).unwrap();
    // The rigid-platform preset: on the litter the torso's vertical contact is nearly free
    // (0.8 N/m), and its slow mode would carry a drift from the ramp into the excursion.
    let v: Value = serde_json::from_slice(&exposure_output("paper-rigid", &path, true)).unwrap();
    let joints = v["joints"].as_array().expect("a joints array");
    assert_eq!(joints.len(), 10);
    let h = SystemMatrices::assemble(&ModelParams::preset(Preset::PaperRigid))
        .joint_response(freq_hz)
        .unwrap();
    for (output, j) in JointOutput::ALL.iter().zip(joints) {
        assert_eq!(j["output"], output.name());
        let scale = match output.unit() {
            JointUnit::Metre => 1e3,
            JointUnit::Radian => 180.0 / PI,
        };
        let peak = j["largest_excursion"].as_f64().unwrap();
        let running = j["max_running_rms"].as_f64().unwrap();
        if output.input_axis().index() == 2 {
            let expected = amplitude_m_s2 * h[(output.index(), 2)].norm() * scale;
            assert!(
                (peak / expected - 1.0).abs() < 0.01,
                "{output}: {peak} against {expected}"
            );
            // The 1 s exponential average of a 5 Hz sine's square ripples by about 1.6 %.
            let expected_rms = expected / 2f64.sqrt();
            assert!(
                (running / expected_rms - 1.0).abs() < 0.015,
                "{output}: {running} against {expected_rms}"
            );
        } else {
            assert_eq!(peak, 0.0, "{output} is not driven by z");
        }
    }
    // And the table names the section.
    let text = String::from_utf8(exposure_output("paper-rigid", &path, false)).unwrap();
    assert!(text.contains("neck and lower back"), "{text}");
    assert!(text.contains("no standard sets limits"), "{text}");
    assert!(text.contains("low_back_ry"), "{text}");
}

/// A ride that starts in motion (a recording cut mid-ride): a vertical sine at its crest
/// at the first sample meets the model at rest, and its start-up transient swings a joint
/// further in the first second than the ride does later. The section counts from the end
/// of the head's warm-up, as the device does: its largest excursion is the largest |value|
/// of the f64 model after the warm-up (stepped here beside it), and happens after it.
#[test]
fn a_ride_that_starts_in_motion_keeps_the_models_start_up_out_of_the_joint_numbers() {
    use supine_core::model::{ModalState, Model};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ride.csv");
    let (fs_hz, freq_hz, amplitude_m_s2, duration_s, warmup_s) = (500.0, 1.5, 2.0, 15.0, 5.0);
    let n = (duration_s * fs_hz) as usize;
    let mut text = format!("{PLATFORM_HEADER_LINE}\n");
    let mut input = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 / fs_hz;
        let z = amplitude_m_s2 * (2.0 * PI * freq_hz * t).cos();
        writeln!(text, "{t},0,0,{z}").unwrap();
        input.push([0.0, 0.0, z]);
    }
    std::fs::write(&path, text).unwrap();
    let v: Value = serde_json::from_slice(&exposure_output("paper-litter", &path, true)).unwrap();
    assert_eq!(v["warmup_s"].as_f64(), Some(warmup_s));
    let joints = v["joints"].as_array().expect("a joints array");

    let realization = Model::new(&ModelParams::preset(Preset::PaperLitter))
        .and_then(|m| m.realization(fs_hz, &JointOutput::ALL))
        .unwrap();
    let mut state = ModalState::<f64>::default();
    let y: Vec<[f64; 10]> = input
        .iter()
        .map(|&u| realization.step(&mut state, u))
        .collect();
    let warmup = (warmup_s * fs_hz) as usize;
    let largest = |o: usize, range: std::ops::Range<usize>| {
        y[range].iter().map(|v| v[o].abs()).fold(0.0, f64::max)
    };
    let mut worst_ratio = 0.0_f64;
    for (output, j) in JointOutput::ALL.iter().zip(joints) {
        let o = output.index();
        let scale = match output.unit() {
            JointUnit::Metre => 1e3,
            JointUnit::Radian => 180.0 / PI,
        };
        let after = largest(o, warmup..n);
        let got = j["largest_excursion"].as_f64().unwrap();
        assert!(
            (got - scale * after).abs() <= 1e-9 * scale * after.max(1e-300),
            "{output}: {got} against {}",
            scale * after
        );
        if after > 0.0 {
            let at = j["largest_excursion_at_s"].as_f64().unwrap();
            assert!(at >= warmup_s, "{output} at {at} s");
            worst_ratio = worst_ratio.max(largest(o, 0..fs_hz as usize) / after);
        }
    }
    println!("first second against the ride after the warm-up: up to {worst_ratio:.2} x");
    assert!(worst_ratio > 1.2, "the start-up transient must stand out");
}
