//! Rides from real loggers' clocks, rates, units and orientations (issue 26): each test
//! checks the reader's output against something independent (a closed form, the same
//! ride sampled uniformly, the unrotated ride).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use realfft::RealFftPlanner;
use supine_core::calibration::SensorFrame;
use supine_core::model::Preset;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;
use supine_host::exposure::model_exposure::{ModelExposure, evaluate_model};
use supine_host::exposure::ride::{Profile, generate};
use supine_host::io::params_file::ParamFile;
use supine_host::io::ride_input::{AccelUnit, RideInputArgs};
use supine_host::ride::conditioned::{Conditioned, Conditioning};

const G: f64 = STANDARD_GRAVITY_M_S2;

/// A continuous ride: the Fourier series of a generated uniform ride (bins below
/// `band_hz`), evaluated at any time.
struct Continuous {
    duration_s: f64,
    bins: Vec<[(f64, f64, f64); 3]>,
}

impl Continuous {
    fn new(profile: Profile, duration_s: f64, band_hz: f64, seed: u64) -> Self {
        let fs = 500.0;
        let ride = generate(profile, duration_s, fs, seed).unwrap();
        let n = ride.len();
        let mut planner = RealFftPlanner::<f64>::new();
        let fft = planner.plan_fft_forward(n);
        let mut spectra = Vec::new();
        for axis in &ride.platform_m_s2 {
            let mut x = axis.clone();
            let mut out = fft.make_output_vec();
            fft.process(&mut x, &mut out).unwrap();
            spectra.push(out);
        }
        let top = ((band_hz * n as f64 / fs) as usize).min(n / 2 - 1);
        let bins = (1..=top)
            .map(|k| {
                std::array::from_fn(|a| {
                    let c = spectra[a][k];
                    (
                        2.0 * PI * k as f64 / (n as f64 / fs),
                        2.0 * c.re / n as f64,
                        -2.0 * c.im / n as f64,
                    )
                })
            })
            .collect();
        Self {
            duration_s: n as f64 / fs,
            bins,
        }
    }

    fn at(&self, t: f64) -> [f64; 3] {
        let mut v = [0.0; 3];
        for b in &self.bins {
            for (a, (w, c, s)) in b.iter().enumerate() {
                let (sin, cos) = (w * t).sin_cos();
                v[a] += c * cos + s * sin;
            }
        }
        v
    }
}

fn write(path: &Path, header: &str, rows: &[(String, [f64; 3])]) {
    let mut text = format!("{header}\n");
    for (t, v) in rows {
        text.push_str(&format!("{t},{:.9e},{:.9e},{:.9e}\n", v[0], v[1], v[2]));
    }
    std::fs::write(path, text).unwrap();
}

fn ride_file(path: &Path, rows: &[(f64, [f64; 3])]) -> PathBuf {
    let rows: Vec<(String, [f64; 3])> = rows.iter().map(|(t, v)| (format!("{t}"), *v)).collect();
    write(
        path,
        "time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2",
        &rows,
    );
    path.to_path_buf()
}

fn exposure(args: &RideInputArgs, path: &Path) -> ModelExposure {
    let source = args.open(path, &SensorFrame::LEVEL).unwrap();
    let file = ParamFile::preset(Preset::PaperLitter);
    evaluate_model(&source, &file, "litter".into(), None).unwrap()
}

fn assert_close(a: &ModelExposure, b: &ModelExposure, tolerance: f64, what: &str) {
    for (x, y, name) in [
        (a.vector.rms_m_s2, b.vector.rms_m_s2, "vector rms"),
        (a.vector.vdv_m_s175, b.vector.vdv_m_s175, "vector VDV"),
        (a.head[2].rms_m_s2, b.head[2].rms_m_s2, "head z rms"),
        (a.head[0].rms_m_s2, b.head[0].rms_m_s2, "head x rms"),
    ] {
        assert!(
            (x - y).abs() <= tolerance * y.abs(),
            "{what}: {name} {x} vs {y} ({:+.3} %)",
            100.0 * (x / y - 1.0)
        );
    }
}

/// Amplitude and phase (rad) of the `f_hz` sine fitted to `samples` at `times`.
fn fit_sine(times: &[f64], samples: &[f64], f_hz: f64) -> (f64, f64) {
    let w = 2.0 * PI * f_hz;
    let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (t, y) in times.iter().zip(samples) {
        let (s, c) = (w * t).sin_cos();
        ss += s * s;
        sc += s * c;
        cc += c * c;
        ys += y * s;
        yc += y * c;
    }
    let det = ss * cc - sc * sc;
    let a = (ys * cc - yc * sc) / det;
    let b = (yc * ss - ys * sc) / det;
    ((a * a + b * b).sqrt(), b.atan2(a))
}

#[test]
fn a_sine_on_a_jittered_clock_keeps_its_amplitude_and_phase_from_half_a_hertz_to_80_hz() {
    // A phone-like clock: 500 Hz nominal, each stamp off by up to +-0.5 ms, and a
    // 200 Hz one with +-1 ms (its band checked to 40 Hz, 0.2 of its rate).
    for (nominal_hz, jitter_s, top_hz, amplitude_tolerance, phase_tolerance_rad) in [
        (500.0, 0.5e-3, 80.0, 0.005, 0.005),
        (200.0, 1e-3, 40.0, 0.01, 0.01),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(26);
        let times: Vec<f64> = (0..(20.0 * nominal_hz) as usize)
            .map(|k| k as f64 / nominal_hz + rng.random_range(-jitter_s..jitter_s))
            .collect();
        for f_hz in [0.5, 2.0, 8.0, 20.0, 40.0, 80.0]
            .into_iter()
            .filter(|f| *f <= top_hz)
        {
            let rows: Vec<(f64, [f64; 3])> = times
                .iter()
                .map(|&t| (t, [0.0, 0.0, (2.0 * PI * f_hz * t + 0.3).sin()]))
                .collect();
            let scan = Conditioned::scan(&rows, 0.25).unwrap();
            let plan = Conditioned::new(
                &scan,
                Conditioning {
                    rate_hz: 500.0,
                    max_gap_s: 0.25,
                    levelling: None,
                },
            )
            .unwrap();
            let out: Vec<(f64, [f64; 3])> =
                plan.samples(&rows).unwrap().map(Result::unwrap).collect();
            assert_eq!(out.len(), plan.len());
            // The ends (a kernel's width) aside.
            let inner = &out[100..out.len() - 100];
            let t: Vec<f64> = inner.iter().map(|r| r.0).collect();
            let y: Vec<f64> = inner.iter().map(|r| r.1[2]).collect();
            let (amplitude, phase) = fit_sine(&t, &y, f_hz);
            assert!(
                (amplitude - 1.0).abs() <= amplitude_tolerance,
                "{nominal_hz} Hz clock, {f_hz} Hz: amplitude {amplitude}"
            );
            assert!(
                (phase - 0.3).abs() <= phase_tolerance_rad,
                "{nominal_hz} Hz clock, {f_hz} Hz: phase {phase} rad, expected 0.3"
            );
        }
    }
}

#[test]
fn a_retimed_ride_with_jitter_bursts_and_sample_and_hold_gives_the_uniform_rides_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let ride = Continuous::new(Profile::RoughRoad, 40.0, 100.0, 3);
    let uniform: Vec<(f64, [f64; 3])> = (0..(ride.duration_s * 500.0) as usize)
        .map(|k| {
            let t = k as f64 / 500.0;
            (t, ride.at(t))
        })
        .collect();
    let reference = exposure(
        &RideInputArgs::default(),
        &ride_file(&dir.path().join("u.csv"), &uniform),
    );
    // Jitter of +-0.6 ms, a burst every 2 s (10 stamps 0.2 ms apart, then a long step),
    // 30 % of rows a repeat of the one before (a logger polling faster than its sensor).
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut rows = Vec::new();
    let mut previous = uniform[0].1;
    for (k, (t, _)) in uniform.iter().enumerate() {
        let burst = k % 1000;
        let t = if (1..=10).contains(&burst) {
            (k - burst) as f64 / 500.0 + 0.0002 * burst as f64 + 0.018
        } else {
            t + rng.random_range(-0.6e-3..0.6e-3)
        };
        let t = t.max(0.0);
        let v = if k > 0 && rng.random_bool(0.3) {
            previous
        } else {
            ride.at(t)
        };
        previous = v;
        rows.push((t, v));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let path = ride_file(&dir.path().join("phone.csv"), &rows);
    let phone = exposure(&RideInputArgs::default(), &path);
    let q = phone.data_quality.as_ref().unwrap();
    assert!(q.repeated_samples > 5000, "{q:?}");
    assert_eq!(q.resampled_rate_hz, 500.0);
    assert_eq!(q.gaps, 0);
    assert_close(&phone, &reference, 0.01, "re-timed");
}

#[test]
fn a_two_second_gap_pauses_the_exposure_instead_of_being_bridged() {
    let dir = tempfile::tempdir().unwrap();
    let ride = generate(Profile::RoughRoad, 40.0, 500.0, 11).unwrap();
    let rows: Vec<(f64, [f64; 3])> = (0..ride.len())
        .map(|k| {
            (
                k as f64 / 500.0,
                ride.platform_m_s2.each_ref().map(|c| c[k]),
            )
        })
        .collect();
    let gapped: Vec<(f64, [f64; 3])> = rows
        .iter()
        .copied()
        .filter(|(t, _)| !(10.0..12.0).contains(t))
        .collect();
    let without: Vec<(f64, [f64; 3])> = gapped
        .iter()
        .map(|&(t, v)| (if t >= 12.0 { t - 2.0 } else { t }, v))
        .collect();
    let a = exposure(
        &RideInputArgs::default(),
        &ride_file(&dir.path().join("gap.csv"), &gapped),
    );
    let b = exposure(
        &RideInputArgs::default(),
        &ride_file(&dir.path().join("cut.csv"), &without),
    );
    let q = a.data_quality.as_ref().unwrap();
    assert_eq!(q.gaps, 1);
    assert!((q.gap_longest_s - 2.002).abs() < 1e-9, "{q:?}");
    assert!((q.gap_list[0].at_s - 9.998).abs() < 1e-9, "{q:?}");
    assert!(
        q.reasons
            .iter()
            .any(|r| r.contains("1 gap (2.00 s in all) not evaluated")),
        "{q:?}"
    );
    assert_eq!(a.samples, b.samples);
    assert_close(&a, &b, 1e-9, "gap");
}

#[test]
fn a_rotated_ride_levelled_by_its_own_gravity_gives_the_unrotated_rides_values() {
    let dir = tempfile::tempdir().unwrap();
    let ride = generate(Profile::Ambulance, 40.0, 500.0, 5).unwrap();
    let rows: Vec<(f64, [f64; 3])> = (0..ride.len())
        .map(|k| {
            (
                k as f64 / 500.0,
                ride.platform_m_s2.each_ref().map(|c| c[k]),
            )
        })
        .collect();
    let flat = exposure(
        &RideInputArgs::default(),
        &ride_file(&dir.path().join("flat.csv"), &rows),
    );
    let removing = RideInputArgs {
        remove_gravity: true,
        ..RideInputArgs::default()
    };
    let s = std::f64::consts::FRAC_1_SQRT_2;
    // Sensor axes from litter axes (rows): upright in a holder (litter z along sensor
    // y, litter y along -z); and tilted 45 degrees about y.
    for (name, r, tilt_deg) in [
        (
            "upright",
            [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
            90.0,
        ),
        ("tilted", [[s, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, s]], 45.0),
    ] {
        let sensor: Vec<(f64, [f64; 3])> = rows
            .iter()
            .map(|&(t, [x, y, z])| {
                let litter = [x, y, z + G];
                (
                    t,
                    r.map(|row: [f64; 3]| {
                        row[0] * litter[0] + row[1] * litter[1] + row[2] * litter[2]
                    }),
                )
            })
            .collect();
        let path = ride_file(&dir.path().join(format!("{name}.csv")), &sensor);
        let levelled = exposure(&removing, &path);
        let l = levelled.data_quality.as_ref().unwrap().levelling.unwrap();
        assert!(
            (l.tilt_rad.to_degrees() - tilt_deg).abs() < 0.05,
            "{name}: {l:?}"
        );
        assert!((l.gravity_m_s2 - G).abs() < 0.01, "{name}: {l:?}");
        assert_close(&levelled, &flat, 0.005, name);
    }
}

#[test]
fn a_50_hz_ride_is_upsampled_with_its_band_and_caveat_and_the_values_of_the_ride_low_passed() {
    let dir = tempfile::tempdir().unwrap();
    let ride = Continuous::new(Profile::Ambulance, 60.0, 25.0, 9);
    let fine: Vec<(f64, [f64; 3])> = (0..(ride.duration_s * 500.0) as usize)
        .map(|k| (k as f64 / 500.0, ride.at(k as f64 / 500.0)))
        .collect();
    let coarse: Vec<(f64, [f64; 3])> = fine.iter().step_by(10).copied().collect();
    let reference = exposure(
        &RideInputArgs::default(),
        &ride_file(&dir.path().join("fine.csv"), &fine),
    );
    let at_50 = exposure(
        &RideInputArgs::default(),
        &ride_file(&dir.path().join("coarse.csv"), &coarse),
    );
    let q = at_50.data_quality.as_ref().unwrap();
    assert_eq!(q.resampled_rate_hz, 500.0);
    assert!((q.band_upper_hz - 25.0).abs() < 1e-6, "{q:?}");
    assert!(q.weighting_band_missing_fraction > 0.1, "{q:?}");
    assert_eq!(q.verdict, "usable with caveats");
    assert!(
        q.reasons
            .iter()
            .any(|r| r.contains("below the weighting's 80 Hz")),
        "{q:?}"
    );
    assert_close(&at_50, &reference, 0.02, "50 Hz");
}

#[test]
fn files_of_each_recognized_app_read_without_columns() {
    let dir = tempfile::tempdir().unwrap();
    let ride = Continuous::new(Profile::Ambulance, 30.0, 100.0, 2);
    let times: Vec<f64> = (0..(30.0 * 200.0) as usize)
        .map(|k| k as f64 / 200.0)
        .collect();
    let removing = RideInputArgs {
        remove_gravity: true,
        ..RideInputArgs::default()
    };
    let reference = {
        let rows: Vec<(f64, [f64; 3])> = times.iter().map(|&t| (t, ride.at(t))).collect();
        exposure(
            &RideInputArgs::default(),
            &ride_file(&dir.path().join("ref.csv"), &rows),
        )
    };
    // Headers as the apps write them (phyphox quotes its header; Sensor Logger counts ns
    // since the epoch and orders z, y, x; Physics Toolbox writes g and date-time text).
    let with_g = |t: f64| {
        let [x, y, z] = ride.at(t);
        [x, y, z + G]
    };
    let phyphox: Vec<(String, [f64; 3])> = times
        .iter()
        .map(|&t| (format!("{t:.9e}"), with_g(t)))
        .collect();
    let sensor_logger: Vec<(String, [f64; 3])> = times
        .iter()
        .map(|&t| {
            let [x, y, z] = with_g(t);
            (
                format!(
                    "{},{t}",
                    1_718_030_736_872_695_300u64 + (t * 1e9).round() as u64
                ),
                [z, y, x],
            )
        })
        .collect();
    let toolbox: Vec<(String, [f64; 3])> = times
        .iter()
        .map(|&t| {
            let ms = (t * 1e3).round() as u64;
            (
                format!(
                    "2018-10-03 17:{:02}:{:02}.{:03}0",
                    23 + (55 + ms / 1000) / 60,
                    (55 + ms / 1000) % 60,
                    ms % 1000
                ),
                with_g(t).map(|v| v / G),
            )
        })
        .collect();
    for (name, header, rows) in [
        (
            "phyphox (acceleration with g)",
            "\"Time (s)\",\"Acceleration x (m/s^2)\",\"Acceleration y (m/s^2)\",\"Acceleration z (m/s^2)\"",
            phyphox,
        ),
        ("Sensor Logger", "time,seconds_elapsed,z,y,x", sensor_logger),
        ("Physics Toolbox Sensor Suite", "time,gFx,gFy,gFz", toolbox),
    ] {
        let path = dir
            .path()
            .join(format!("{}.csv", name.split(' ').next().unwrap()));
        write(&path, header, &rows);
        let e = exposure(&removing, &path);
        let q = e.data_quality.as_ref().unwrap();
        assert_eq!(q.format, name);
        assert!((q.source_rate_hz - 200.0).abs() < 0.5, "{name}: {q:?}");
        assert_close(&e, &reference, 0.01, name);
    }
}

#[test]
fn a_tilted_phone_file_in_g_is_refused_without_units_g_and_read_with_them() {
    let dir = tempfile::tempdir().unwrap();
    let ride = generate(Profile::Ambulance, 30.0, 500.0, 4).unwrap();
    // Tilted so that z reads 0.77 g: gravity along (0, 0.638, 0.77).
    let up = [0.0, (1.0f64 - 0.77 * 0.77).sqrt(), 0.77];
    let rows = |scale: f64| -> Vec<(f64, [f64; 3])> {
        (0..ride.len())
            .map(|k| {
                let [x, y, z] = ride.platform_m_s2.each_ref().map(|c| c[k]);
                // Litter z along `up`, litter y perpendicular in the y-z plane.
                let v = [x, y * up[2] + (z + G) * up[1], -y * up[1] + (z + G) * up[2]];
                (k as f64 / 500.0, v.map(|c| c / scale))
            })
            .collect()
    };
    let columns = "time=time_s,x=platform_x_m_s2,y=platform_y_m_s2,z=platform_z_m_s2";
    let g_file = ride_file(&dir.path().join("g.csv"), &rows(G));
    let m_file = ride_file(&dir.path().join("m.csv"), &rows(1.0));
    let removing = RideInputArgs {
        remove_gravity: true,
        columns: Some(supine_host::io::ride_input::ColumnNames::parse(columns).unwrap()),
        ..RideInputArgs::default()
    };
    let err = removing
        .open(&g_file, &SensorFrame::LEVEL)
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(err.contains("z 0.77") && err.contains("--units g"), "{err}");
    let in_g = RideInputArgs {
        units: Some(AccelUnit::G),
        ..removing.clone()
    };
    assert_close(
        &exposure(&in_g, &g_file),
        &exposure(&removing, &m_file),
        1e-5,
        "g",
    );
}

#[test]
fn a_ride_clipped_on_its_gravity_axis_is_counted_and_located_before_gravity_is_removed() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 500.0;
    let ride = generate(Profile::RoughRoad, 30.0, fs, 6).unwrap();
    // A logger whose z (gravity's axis) saturates: its shocks' peaks read flat at a full
    // scale below them, as a +-2 g sensor clips a rough road's shocks.
    let z: Vec<f64> = ride.platform_m_s2[2].iter().map(|v| v + G).collect();
    let full_scale = G + 0.6 * ride.platform_m_s2[2].iter().cloned().fold(0.0, f64::max);
    // Independently: the runs of 3 or more samples at or above full scale.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut start = None;
    for (k, v) in z.iter().chain([&f64::NEG_INFINITY]).enumerate() {
        match (start, *v >= full_scale) {
            (None, true) => start = Some(k),
            (Some(s), false) => {
                if k - s >= 3 {
                    runs.push((s, k - s));
                }
                start = None;
            }
            _ => {}
        }
    }
    assert!(runs.len() >= 2, "the shocks are clipped: {runs:?}");
    let rows: Vec<(f64, [f64; 3])> = (0..ride.len())
        .map(|k| {
            let [x, y] = [0, 1].map(|a| ride.platform_m_s2[a][k]);
            (k as f64 / fs, [x, y, z[k].min(full_scale)])
        })
        .collect();
    let path = ride_file(&dir.path().join("clipped.csv"), &rows);
    let removing = RideInputArgs {
        remove_gravity: true,
        ..RideInputArgs::default()
    };
    let e = exposure(&removing, &path);
    let q = e.data_quality.as_ref().unwrap();
    assert_eq!(q.clipping.len(), 1, "{:?}", q.clipping);
    let c = &q.clipping[0];
    assert_eq!(c.axis, "z");
    // Written with 9 decimals: the file's full scale, not the value after levelling.
    assert!(
        (c.value_m_s2 - full_scale).abs() < 1e-6 * full_scale,
        "{c:?}"
    );
    assert_eq!(c.samples, runs.iter().map(|r| r.1 as u64).sum::<u64>());
    assert!(
        (c.first_s - runs[0].0 as f64 / fs).abs() < 1e-9,
        "{c:?} {runs:?}"
    );
    assert!((c.last_s - runs.last().unwrap().0 as f64 / fs).abs() < 1e-9);
    assert_eq!(q.verdict, "usable with caveats");
    assert!(
        q.reasons
            .iter()
            .any(|r| r.contains(&format!("{} samples clipped", c.samples))),
        "{:?}",
        q.reasons
    );
}

#[test]
fn a_corrupt_stamp_far_ahead_is_refused_by_its_line_and_a_few_rows_behind_one_are_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let ride = generate(Profile::Ambulance, 12.0, 200.0, 8).unwrap();
    let rows = |stamp: &dyn Fn(usize) -> f64| -> Vec<(f64, [f64; 3])> {
        (0..ride.len())
            .map(|k| (stamp(k), [0, 1, 2].map(|a| ride.platform_m_s2[a][k])))
            .collect()
    };
    // Row 1000 (line 1002) stamped 1e300 s: every row after it is earlier.
    let corrupt = ride_file(
        &dir.path().join("corrupt.csv"),
        &rows(&|k| if k == 1000 { 1e300 } else { k as f64 / 200.0 }),
    );
    let err = RideInputArgs::default()
        .open(&corrupt, &SensorFrame::LEVEL)
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("corrupt.csv: line 1002, column time_s: time 1e300 s")
            && err.contains(&format!("the next {} rows are earlier", ride.len() - 1001)),
        "{err}"
    );
    // A row stamped 2 ms late (a burst delivered out of order): the one row behind it
    // is dropped and counted, the ride read.
    let late = ride_file(
        &dir.path().join("late.csv"),
        &rows(&|k| k as f64 / 200.0 + if k == 1000 { 0.007 } else { 0.0 }),
    );
    let e = exposure(&RideInputArgs::default(), &late);
    assert_eq!(e.data_quality.unwrap().dropped_samples, 1);
}
