//! The resampler `supine exposure --fs` uses: amplitude and phase of in-band sines are
//! kept, content above the lower rate's Nyquist frequency is removed, the time span is kept.

use std::f64::consts::PI;

use supine_host::ride::resample::{PASSBAND_FRACTION, Resampler, resample};

/// Least-squares amplitude and phase of `y[m] ~ A sin(2 pi f t_m + phi)` over `m` in `range`.
fn fit_sine(y: &[f64], fs: f64, f: f64, range: std::ops::Range<usize>) -> (f64, f64) {
    let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for m in range {
        let w = 2.0 * PI * f * m as f64 / fs;
        let (s, c) = w.sin_cos();
        ss += s * s;
        sc += s * c;
        cc += c * c;
        ys += y[m] * s;
        yc += y[m] * c;
    }
    // Solve [ss sc; sc cc] [a; b] = [ys; yc] for y ~ a sin + b cos.
    let det = ss * cc - sc * sc;
    let a = (ys * cc - yc * sc) / det;
    let b = (yc * ss - ys * sc) / det;
    ((a * a + b * b).sqrt(), b.atan2(a))
}

#[test]
fn in_band_sines_keep_amplitude_within_2e_4_and_phase_within_1e_5_rad() {
    let amplitude = 1.7;
    let phase = 0.6;
    for (fs_in, fs_out) in [
        (1000.0, 500.0),
        (200.0, 500.0),
        (333.3, 500.0),
        (500.0, 2000.0),
        (2000.0, 100.0),
    ] {
        let low: f64 = f64::min(fs_in, fs_out);
        for f in [1.0, 0.1 * low, 0.9 * PASSBAND_FRACTION * low] {
            let n = (20.0 * fs_in) as usize;
            let x: Vec<f64> = (0..n)
                .map(|k| amplitude * (2.0 * PI * f * k as f64 / fs_in + phase).sin())
                .collect();
            let y = resample(&x, fs_in, fs_out).unwrap();
            // Away from the ends (1 s each side), against the exact sine at the output times.
            let edge = fs_out as usize;
            let interior = edge..y.len() - edge;
            let (a, p) = fit_sine(&y, fs_out, f, interior.clone());
            eprintln!(
                "{fs_in} -> {fs_out} Hz, {f:.2} Hz: amplitude {:+.2e}, phase {:+.2e} rad",
                a / amplitude - 1.0,
                p - phase
            );
            assert!(
                (a / amplitude - 1.0).abs() < 2e-4,
                "{fs_in} -> {fs_out} Hz, {f} Hz: amplitude {a}"
            );
            assert!(
                (p - phase).abs() < 1e-5,
                "{fs_in} -> {fs_out} Hz, {f} Hz: phase {p}"
            );
            let worst = interior
                .map(|m| {
                    let t = m as f64 / fs_out;
                    (y[m] - amplitude * (2.0 * PI * f * t + phase).sin()).abs()
                })
                .fold(0.0, f64::max);
            assert!(
                worst < 2e-3 * amplitude,
                "{fs_in} -> {fs_out} Hz, {f} Hz: sample error {worst}"
            );
        }
    }
}

#[test]
fn slow_signals_are_carried_to_the_very_ends() {
    // The mirrored extension keeps a 1 Hz sine right to the first and last output sample.
    let (fs_in, fs_out) = (1000.0, 400.0);
    let x: Vec<f64> = (0..10_001)
        .map(|k| (2.0 * PI * k as f64 / fs_in).cos())
        .collect();
    let y = resample(&x, fs_in, fs_out).unwrap();
    assert_eq!(y.len(), 4001);
    for (m, v) in y.iter().enumerate() {
        let expected = (2.0 * PI * m as f64 / fs_out).cos();
        assert!((v - expected).abs() < 2e-3, "sample {m}: {v} vs {expected}");
    }
}

#[test]
fn a_tone_above_the_output_nyquist_is_removed_rather_than_aliased() {
    // 150 Hz at 1 kHz would alias to 50 Hz at 200 Hz; the kernel's stopband takes it out.
    let (fs_in, fs_out) = (1000.0, 200.0);
    let x: Vec<f64> = (0..20_000)
        .map(|k| (2.0 * PI * 150.0 * k as f64 / fs_in).sin())
        .collect();
    let y = resample(&x, fs_in, fs_out).unwrap();
    let interior = &y[200..y.len() - 200];
    let rms = (interior.iter().map(|v| v * v).sum::<f64>() / interior.len() as f64).sqrt();
    assert!(
        rms < 1e-3,
        "residual rms {rms} of a unit tone (80 dB would be 7e-5)"
    );
}

#[test]
fn the_output_spans_the_same_time_as_the_input() {
    let r = Resampler::new(500.0, 200.0).unwrap();
    // 0 .. 2.998 s at 500 Hz: 1500 samples; at 200 Hz, 0 .. 2.995 s: 600 samples.
    assert_eq!(r.output_len(1500), 600);
    assert_eq!(r.output_len(1501), 601);
    assert_eq!(r.output_len(0), 0);
    assert_eq!(Resampler::new(200.0, 500.0).unwrap().output_len(601), 1501);
}

#[test]
fn rates_must_be_finite_and_positive() {
    for (a, b) in [(0.0, 500.0), (500.0, -1.0), (f64::NAN, 500.0)] {
        let err = Resampler::new(a, b).unwrap_err().to_string();
        assert!(err.contains("finite positive"), "{err}");
    }
}
