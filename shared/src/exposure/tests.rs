//! Host tests of the streaming evaluation against signals with known answers.

use std::f64::consts::PI;

use super::*;
use crate::weighting::analog_response;

const FS: f32 = 500.0;

/// A supported rate (every rate these tests build for is one).
fn rate(hz: f32) -> SampleRate {
    SampleRate::new(hz).expect("a supported rate")
}

fn run(settings: &ExposureSettings, signal: impl Fn(usize) -> [f32; 3], n: usize) -> ExposureState {
    let mut st = ExposureState::new();
    for i in 0..n {
        settings.step(&mut st, signal(i), i as u32);
    }
    st
}

fn close(got: f32, want: f64, rel: f64) -> bool {
    ((got as f64) / want - 1.0).abs() < rel
}

#[test]
fn a_sine_on_each_axis_gives_rms_of_amplitude_times_factor_over_root_two() {
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let (f, amp) = ([4.0, 1.5, 8.0], [1.0, 0.5, 2.0]);
    let secs = 60.0;
    let n = ((5.0 + secs) * FS as f64) as usize;
    let st = run(
        &s,
        |i| {
            let t = i as f64 / FS as f64;
            core::array::from_fn(|a| (amp[a] * (2.0 * PI * f[a] * t).sin()) as f32)
        },
        n,
    );
    let v = s.values(rate(FS), &st);
    assert!(v.valid);
    assert!((v.duration_s as f64 - secs).abs() < 1e-3);
    let kinds = [WeightingKind::Wd, WeightingKind::Wd, WeightingKind::Wj];
    let mut aw = [0.0f64; 3];
    for a in 0..3 {
        aw[a] = amp[a] * analog_response(kinds[a], f[a]).abs();
        let rms = aw[a] / 2f64.sqrt();
        let x = v.axes[a];
        assert!(
            close(x.rms_m_s2, rms, 0.01),
            "axis {a}: rms {} vs {rms}",
            x.rms_m_s2
        );
        assert!(
            close(x.running_rms_m_s2, rms, 0.03),
            "axis {a}: running {}",
            x.running_rms_m_s2
        );
        assert!(x.mtvv_m_s2 as f64 >= 0.99 * rms && close(x.mtvv_m_s2, rms, 0.04));
        // VDV of a sine: (3/8 A^4 T)^(1/4).
        let vdv = (0.375 * aw[a].powi(4) * secs).powf(0.25);
        assert!(
            close(x.vdv_m_s175, vdv, 0.02),
            "axis {a}: vdv {} vs {vdv}",
            x.vdv_m_s175
        );
        assert!(
            close(x.peak_m_s2, aw[a], 0.02),
            "axis {a}: peak {}",
            x.peak_m_s2
        );
        assert!(close(x.crest_factor, 2f64.sqrt(), 0.03));
        assert!(!x.additional.any());
    }
    // Vector sum: mean square adds; the fourth-power dose of (sum a_i^2)^2 for sines of
    // unrelated frequencies is T (3/8 sum A_i^4 + 2 sum_{i<j} A_i^2 A_j^2 / 4).
    let rms_v = (aw.iter().map(|a| a * a / 2.0).sum::<f64>()).sqrt();
    assert!(
        close(v.vector.rms_m_s2, rms_v, 0.01),
        "vector rms {}",
        v.vector.rms_m_s2
    );
    let cross: f64 = (0..3)
        .flat_map(|i| (i + 1..3).map(move |j| (i, j)))
        .map(|(i, j)| aw[i] * aw[i] * aw[j] * aw[j] / 2.0)
        .sum();
    let vdv_v = ((0.375 * aw.iter().map(|a| a.powi(4)).sum::<f64>() + cross) * secs).powf(0.25);
    assert!(
        close(v.vector.vdv_m_s175, vdv_v, 0.02),
        "vector vdv {} vs {vdv_v}",
        v.vector.vdv_m_s175
    );
    let rsq = v
        .axes
        .iter()
        .map(|x| (x.vdv_m_s175 as f64).powi(4))
        .sum::<f64>()
        .powf(0.25);
    assert!(v.vector.vdv_m_s175 as f64 >= rsq);
}

#[test]
fn values_are_not_valid_during_the_warm_up_and_valid_after_it() {
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    assert_eq!(s.warmup_samples, 2500);
    let mut st = ExposureState::new();
    for i in 0..2500u32 {
        let out = s.step(&mut st, [0.1, 0.2, 0.3], i);
        assert!(!out.valid);
        assert!(!s.values(rate(FS), &st).valid);
    }
    let out = s.step(&mut st, [0.1, 0.2, 0.3], 2500);
    assert!(out.valid);
    let v = s.values(rate(FS), &st);
    assert!(v.valid);
    assert_eq!(v.at_sample, 2500);
    assert!((v.duration_s - 1.0 / FS).abs() < 1e-9);
}

#[test]
fn a_single_shock_on_a_quiet_ride_raises_the_crest_factor_and_mtvv_flags() {
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let n = (65.0 * FS) as usize;
    let shock_at = (40.0 * FS) as usize;
    let st = run(
        &s,
        |i| {
            let t = i as f64 / FS as f64;
            let base = 0.05 * (2.0 * PI * 5.0 * t).sin();
            // A half-sine bump of 20 ms, 20 m/s^2, on the vertical.
            let k = i as isize - shock_at as isize;
            let bump = if (0..10).contains(&k) {
                20.0 * (PI * k as f64 / 10.0).sin()
            } else {
                0.0
            };
            [base as f32, base as f32, (base + bump) as f32]
        },
        n,
    );
    let v = s.values(rate(FS), &st);
    let z = v.axes[2];
    assert!(
        z.crest_factor > CREST_FACTOR_LIMIT && z.additional.crest_factor,
        "crest {}",
        z.crest_factor
    );
    assert!(z.mtvv_ratio > MTVV_RATIO_LIMIT && z.additional.mtvv_ratio);
    assert!(z.vdv_ratio > VDV_RATIO_LIMIT && z.additional.vdv_ratio);
    assert!(v.vector.additional.any());
    assert!(!v.axes[0].additional.any());
}

#[test]
fn an_eight_hour_dose_keeps_its_precision() {
    let fs = 100.0f32;
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(fs)).unwrap();
    let hours = 8.0;
    let n = ((5.0 + hours * 3600.0) * fs as f64) as usize;
    let f = 4.0;
    let st = run(
        &s,
        |i| {
            let x = (2.0 * PI * f * i as f64 / fs as f64).sin() as f32;
            [0.0, 0.0, x]
        },
        n,
    );
    let v = s.values(rate(fs), &st);
    let own = s.weighting[2].response(rate(fs), f).abs();
    let t = hours * 3600.0;
    assert!(
        close(v.axes[2].rms_m_s2, own / 2f64.sqrt(), 1e-4),
        "rms {}",
        v.axes[2].rms_m_s2
    );
    let vdv = (0.375 * own.powi(4) * t).powf(0.25);
    assert!(
        close(v.axes[2].vdv_m_s175, vdv, 1e-4),
        "vdv {} vs {vdv}",
        v.axes[2].vdv_m_s175
    );
}

#[test]
fn the_vector_factor_k_scales_only_the_vector_sum() {
    let mut cfg = ExposureConfig::DEFAULT;
    cfg.axes.z.k = 1.4;
    let s1 = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let s2 = ExposureSettings::new(cfg, rate(FS)).unwrap();
    let sig = |i: usize| {
        let t = i as f64 / FS as f64;
        [0.0, 0.0, (2.0 * PI * 6.0 * t).sin() as f32]
    };
    let n = (20.0 * FS) as usize;
    let (v1, v2) = (
        s1.values(rate(FS), &run(&s1, sig, n)),
        s2.values(rate(FS), &run(&s2, sig, n)),
    );
    assert!(close(v2.axes[2].rms_m_s2, v1.axes[2].rms_m_s2 as f64, 1e-5));
    assert!(close(
        v2.axes[2].vdv_m_s175,
        v1.axes[2].vdv_m_s175 as f64,
        1e-5
    ));
    assert!(close(
        v2.vector.rms_m_s2,
        1.4 * v1.vector.rms_m_s2 as f64,
        1e-5
    ));
}

#[test]
fn invalid_configurations_are_refused_with_the_reason() {
    let mut c = ExposureConfig::DEFAULT;
    c.axes.y.k = 0.0;
    assert_eq!(
        ExposureSettings::new(c, rate(FS)),
        Err(ExposureError::AxisFactor)
    );
    c.axes.y.k = f32::NAN;
    assert_eq!(
        ExposureSettings::new(c, rate(FS)),
        Err(ExposureError::AxisFactor)
    );
    let mut c = ExposureConfig::DEFAULT;
    c.running_tau_s = 0.0;
    assert_eq!(
        ExposureSettings::new(c, rate(FS)),
        Err(ExposureError::TimeConstant)
    );
    let mut c = ExposureConfig::DEFAULT;
    c.warmup_s = -1.0;
    assert_eq!(
        ExposureSettings::new(c, rate(FS)),
        Err(ExposureError::Warmup)
    );
    c.warmup_s = 1e6;
    assert_eq!(
        ExposureSettings::new(c, rate(FS)),
        Err(ExposureError::Warmup)
    );
    // Too short a time constant for the rate: under two samples at 2 kHz.
    let mut c = ExposureConfig::DEFAULT;
    c.running_tau_s = 0.9e-3;
    assert_eq!(
        ExposureSettings::new(c, rate(SampleRate::MAX_HZ)),
        Err(ExposureError::TimeConstant)
    );
    c.running_tau_s = 1.1e-3;
    assert!(ExposureSettings::new(c, rate(SampleRate::MAX_HZ)).is_ok());
    let mut s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    assert_eq!(s.validate(rate(FS)), Ok(()));
    s.running_gain = 2.0;
    assert_eq!(s.validate(rate(FS)), Err(ExposureError::TimeConstant));
    let mut s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    s.weighting[1].band.high_pass.g *= 1.01;
    assert_eq!(s.validate(rate(FS)), Err(ExposureError::Mismatch));
}

#[test]
fn config_and_settings_survive_a_postcard_round_trip() {
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let mut buf = [0u8; 512];
    let bytes = postcard::to_slice(&s, &mut buf).unwrap();
    let back: ExposureSettings = postcard::from_bytes(bytes).unwrap();
    assert_eq!(back, s);
    let bytes = postcard::to_slice(&ExposureConfig::DEFAULT, &mut buf).unwrap();
    assert_eq!(
        postcard::from_bytes::<ExposureConfig>(bytes).unwrap(),
        ExposureConfig::DEFAULT
    );
}

// ---- The ISO 8041 saw-tooth burst signals, with an independent frequency-domain reference ----

#[derive(Clone, Copy)]
struct Cx(f64, f64);

/// In-place iterative radix-2 FFT (`inverse` divides by N).
fn fft(buf: &mut [Cx], inverse: bool) {
    let n = buf.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            buf.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = 2.0 * PI / len as f64 * if inverse { 1.0 } else { -1.0 };
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (c, s) = ((ang * k as f64).cos(), (ang * k as f64).sin());
                let u = buf[start + k];
                let v = buf[start + k + len / 2];
                let t = Cx(v.0 * c - v.1 * s, v.0 * s + v.1 * c);
                buf[start + k] = Cx(u.0 + t.0, u.1 + t.1);
                buf[start + k + len / 2] = Cx(u.0 - t.0, u.1 - t.1);
            }
        }
        len <<= 1;
    }
    if inverse {
        for x in buf.iter_mut() {
            *x = Cx(x.0 / n as f64, x.1 / n as f64);
        }
    }
}

/// The analog weighting applied to a sampled signal in the frequency domain.
fn weighted_reference(kind: WeightingKind, x: &[f64], fs: f64) -> Vec<f64> {
    let n = (x.len() * 4).next_power_of_two();
    let mut buf: Vec<Cx> = (0..n)
        .map(|i| Cx(x.get(i).copied().unwrap_or(0.0), 0.0))
        .collect();
    fft(&mut buf, false);
    for k in 0..=n / 2 {
        let w = analog_response(kind, k as f64 * fs / n as f64);
        let b = buf[k];
        buf[k] = Cx(b.0 * w.re - b.1 * w.im, b.0 * w.im + b.1 * w.re);
        if k != 0 && k != n / 2 {
            let b = buf[n - k];
            // W(-f) = conj W(f)
            buf[n - k] = Cx(b.0 * w.re + b.1 * w.im, -b.0 * w.im + b.1 * w.re);
        }
    }
    fft(&mut buf, true);
    buf[..x.len()].iter().map(|c| c.0).collect()
}

/// Saw-tooth at 15.915 Hz, 1 m/s^2 zero-to-peak, starting and ending each cycle at 0.
fn sawtooth_burst(cycles: Option<u32>, start_s: f64, total_s: f64, fs: f64) -> Vec<f64> {
    let f0 = 100.0 / (2.0 * PI);
    (0..(total_s * fs) as usize)
        .map(|i| {
            let t = i as f64 / fs - start_s;
            let phase = t * f0;
            let inside = t >= 0.0 && cycles.is_none_or(|c| phase < c as f64);
            if inside {
                2.0 * (phase + 0.5).fract() - 1.0
            } else {
                0.0
            }
        })
        .collect()
}

struct Reference {
    mtvv: f64,
    vdv: f64,
    peak: f64,
    rms: f64,
}

fn reference_values(a: &[f64], fs: f64, warmup: usize) -> Reference {
    let alpha = (-1.0 / fs).exp();
    let (mut ms, mut mtvv_sq, mut q, mut sq, mut peak) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (i, &x) in a.iter().enumerate() {
        ms = alpha * ms + (1.0 - alpha) * x * x;
        if i >= warmup {
            mtvv_sq = mtvv_sq.max(ms);
            q += x.powi(4);
            sq += x * x;
            peak = peak.max(x.abs());
        }
    }
    let n = (a.len() - warmup) as f64;
    Reference {
        mtvv: mtvv_sq.sqrt(),
        vdv: (q / fs).powf(0.25),
        peak,
        rms: (sq / n).sqrt(),
    }
}

#[test]
fn sawtooth_bursts_of_1_to_16_cycles_and_continuous_match_a_frequency_domain_reference() {
    let fs = FS as f64;
    let cfg = ExposureConfig {
        axes: AxisMapping {
            x: AxisWeighting {
                kind: WeightingKind::Wk,
                k: 1.0,
            },
            y: AxisWeighting {
                kind: WeightingKind::Wd,
                k: 1.0,
            },
            z: AxisWeighting {
                kind: WeightingKind::Wj,
                k: 1.0,
            },
        },
        ..ExposureConfig::DEFAULT
    };
    let s = ExposureSettings::new(cfg, rate(FS)).unwrap();
    let kinds = [WeightingKind::Wk, WeightingKind::Wd, WeightingKind::Wj];
    for cycles in [Some(1), Some(2), Some(4), Some(8), Some(16), None] {
        let x = sawtooth_burst(cycles, 10.0, 30.0, fs);
        let st = run(&s, |i| [x[i] as f32; 3], x.len());
        let v = s.values(rate(FS), &st);
        let weighted: Vec<Vec<f64>> = kinds
            .iter()
            .map(|&k| weighted_reference(k, &x, fs))
            .collect();
        for a in 0..3 {
            let r = reference_values(&weighted[a], fs, s.warmup_samples as usize);
            let got = v.axes[a];
            let msg = format!(
                "{:?} cycles, {}: mtvv {} vs {:.4}, vdv {} vs {:.4}, peak {} vs {:.4}, rms {} vs {:.4}",
                cycles,
                kinds[a],
                got.mtvv_m_s2,
                r.mtvv,
                got.vdv_m_s175,
                r.vdv,
                got.peak_m_s2,
                r.peak,
                got.rms_m_s2,
                r.rms
            );
            println!("{msg}");
            // The digital filter departs from the analog one by under 3 % in magnitude up
            // to 80 Hz at 500 Hz (and in phase near Nyquist, which moves the peak).
            assert!(close(got.mtvv_m_s2, r.mtvv, 0.005), "{msg}");
            assert!(close(got.vdv_m_s175, r.vdv, 0.01), "{msg}");
            assert!(close(got.rms_m_s2, r.rms, 0.005), "{msg}");
            assert!(close(got.peak_m_s2, r.peak, 0.03), "{msg}");
        }
        // Vector sum of the three time histories.
        let av: Vec<f64> = (0..x.len())
            .map(|i| (0..3).map(|a| weighted[a][i].powi(2)).sum::<f64>().sqrt())
            .collect();
        let r = reference_values(&av, fs, s.warmup_samples as usize);
        assert!(
            close(v.vector.mtvv_m_s2, r.mtvv, 0.005),
            "vector mtvv {} vs {}",
            v.vector.mtvv_m_s2,
            r.mtvv
        );
        assert!(
            close(v.vector.vdv_m_s175, r.vdv, 0.01),
            "vector vdv {} vs {}",
            v.vector.vdv_m_s175,
            r.vdv
        );
        assert!(close(v.vector.rms_m_s2, r.rms, 0.005));
        assert!(close(v.vector.peak_m_s2, r.peak, 0.03));
    }
}

#[test]
fn the_per_sample_output_carries_the_vector_mean_square_and_dose_for_the_alerts() {
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = ExposureState::new();
    let mut last = ExposureSample::default();
    for i in 0..(20.0 * FS) as usize {
        let t = i as f64 / FS as f64;
        let x = (2.0 * PI * 6.0 * t).sin() as f32;
        last = s.step(&mut st, [x, 0.5 * x, 2.0 * x], i as u32);
    }
    let v = s.values(rate(FS), &st);
    assert!(close(
        last.running_ms_m2_s4.sqrt(),
        v.vector.running_rms_m_s2 as f64,
        1e-5
    ));
    assert!(close(
        last.vdv4_m4_s7.sqrt().sqrt(),
        v.vector.vdv_m_s175 as f64,
        1e-4
    ));
}

#[test]
fn a_block_of_32_samples_gives_bit_for_bit_what_32_single_steps_give() {
    let s = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let (mut one, mut block) = (ExposureState::new(), ExposureState::new());
    let sig = |i: usize| {
        let t = i as f64 / FS as f64;
        [
            (0.3 * (2.0 * PI * 3.0 * t).sin()) as f32,
            (0.2 * (2.0 * PI * 11.0 * t).cos()) as f32,
            (9.81 + 0.7 * (2.0 * PI * 5.0 * t).sin()) as f32,
        ]
    };
    // 200 blocks of 32: through the 2500-sample warm-up and 15 folds of the f64 totals.
    for b in 0..200usize {
        let x: [[f32; 3]; 32] = core::array::from_fn(|n| sig(32 * b + n));
        let mut outs = [ExposureSample::default(); 32];
        s.step_block(&mut block, &x, (32 * b) as u32, &mut outs);
        for n in 0..32 {
            let single = s.step(&mut one, x[n], (32 * b + n) as u32);
            assert_eq!(single, outs[n], "sample {}", 32 * b + n);
        }
        assert_eq!(one, block);
    }
    assert_eq!(s.values(rate(FS), &one), s.values(rate(FS), &block));
}

#[test]
fn legs_in_sequence_combine_as_one_exposure_of_their_joined_time() {
    // Closed forms: n equal legs give VDV n^(1/4) times one leg's and the same rms; a leg
    // of twice the duration weighs twice in the mean square.
    let n = 16;
    assert!((combined_vdv_m_s175(&vec![1.5; n]) - 1.5 * 2.0).abs() < 1e-12);
    assert!((combined_rms_m_s2(&vec![(0.7, 30.0); n]) - 0.7).abs() < 1e-12);
    let rms = combined_rms_m_s2(&[(1.0, 20.0), (2.0, 10.0)]);
    assert!((rms - ((1.0 * 20.0 + 4.0 * 10.0) / 30.0_f64).sqrt()).abs() < 1e-12);
    // The VDV's fourth power is an integral over time, so it adds across legs.
    let vdv = combined_vdv_m_s175(&[1.0, 2.0, 3.0]);
    assert!((vdv.powi(4) - (1.0 + 16.0 + 81.0)).abs() < 1e-9);
    // Nothing evaluated: nothing to combine.
    assert_eq!(combined_rms_m_s2(&[(3.0, 0.0)]), 0.0);
    assert_eq!(combined_vdv_m_s175(&[]), 0.0);
}
