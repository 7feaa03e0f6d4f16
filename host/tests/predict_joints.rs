//! `supine predict`'s joint columns against the model's joint response: a sine on one
//! support axis must come out with the amplitude and phase the frequency response gives.

use std::f64::consts::PI;

use clap::Parser;
use supine_core::model::{JointOutput, JointUnit, ModelParams, Preset, SystemMatrices};
use supine_host::cli::{Cli, run};
use supine_host::io::params_file::{self, ParamFile};
use supine_host::io::recording::{COLUMNS, PREDICTED_JOINT_COLUMNS, Recording};

#[test]
fn predict_adds_the_joint_motion_in_mm_and_degrees_as_the_joint_response_gives_it() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("rec.csv"), dir.path().join("pred.csv"));
    let fs_hz = 500.0;
    let n = 20 * 500;
    let freq_hz = 2.0;
    let sine = |axis: usize| -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64 / fs_hz;
                (1.0 + axis as f64) * 0.3 * (2.0 * PI * freq_hz * t + axis as f64).sin()
            })
            .collect()
    };
    let platform = [sine(0), sine(1), sine(2)];
    Recording::from_columns(
        input.clone(),
        fs_hz,
        platform,
        core::array::from_fn(|_| vec![0.0; n]),
    )
    .write(&input)
    .unwrap();
    let params_path = dir.path().join("litter.toml");
    params_file::save(&params_path, &ParamFile::preset(Preset::PaperLitter)).unwrap();
    let argv = [
        "supine",
        "predict",
        "--params",
        params_path.to_str().unwrap(),
        "--input",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    run(Cli::try_parse_from(argv).unwrap()).unwrap();

    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[..13], &COLUMNS);
    assert_eq!(&header[13..], &PREDICTED_JOINT_COLUMNS);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), n);
    // The prediction still reads as a recording.
    assert_eq!(Recording::read(&out).unwrap().len(), n);

    // Steady state over the last 10 s (20 periods): fit a sine by projection.
    let h = SystemMatrices::assemble(&ModelParams::preset(Preset::PaperLitter))
        .joint_response(freq_hz)
        .unwrap();
    for output in JointOutput::ALL {
        let axis = output.input_axis().index();
        let column: Vec<f64> = rows.iter().map(|r| r[13 + output.index()]).collect();
        let (mut c, mut s) = (0.0, 0.0);
        for (k, v) in column.iter().enumerate().skip(n / 2) {
            let phase = 2.0 * PI * freq_hz * k as f64 / fs_hz + axis as f64;
            c += v * phase.cos();
            s += v * phase.sin();
        }
        let m = (n - n / 2) as f64 / 2.0;
        let (c, s) = (c / m, s / m);
        let amplitude = (c * c + s * s).sqrt();
        let unit = match output.unit() {
            JointUnit::Metre => 1e3,
            JointUnit::Radian => 180.0 / PI,
        };
        let h = h[(output.index(), axis)];
        let expected = (1.0 + axis as f64) * 0.3 * h.norm() * unit;
        assert!(
            (amplitude / expected - 1.0).abs() < 0.01,
            "{output}: {amplitude} against {expected}"
        );
        // y = A sin(w t + p + arg h) = A (cos(arg h) sin + sin(arg h) cos).
        let phase = c.atan2(s);
        assert!(
            (phase - h.arg()).abs() < 0.02,
            "{output}: phase {phase} against {}",
            h.arg()
        );
    }
}
