//! The H1 estimator on a known 3-input, 9-output system driven by correlated inputs, the
//! PSD's scaling, and the geometric mean of complex values (including the branch cut).

use std::f64::consts::PI;

use nalgebra::Complex;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use supine_host::identify::geomean::{geometric_mean, wrap_pi};
use supine_host::identify::spectral::{
    MAX_INPUT_CONDITION, SpectralError, WelchSettings, h1, input_condition, psd,
};

const FS_HZ: f64 = 200.0;

/// Filter of output j from input k: gain, delay in samples and a one-pole low-pass
/// y[n] = a y[n-1] + (1 - a) x[n - d], whose response is g e^(-j w d) (1 - a) / (1 - a e^(-j w)).
fn filter(j: usize, k: usize) -> (f64, usize, f64) {
    let gain = 0.3 + 0.13 * ((3 * j + k) % 10) as f64;
    let delay = (j + 2 * k) % 5;
    let pole = [0.0, 0.5, 0.8][(j + k) % 3];
    (gain, delay, pole)
}

fn exact(j: usize, k: usize, freq_hz: f64) -> Complex<f64> {
    let (g, d, a) = filter(j, k);
    let w = 2.0 * PI * freq_hz / FS_HZ;
    let z1 = Complex::from_polar(1.0, -w);
    Complex::from_polar(g, -w * d as f64) * (1.0 - a) / (Complex::new(1.0, 0.0) - z1 * a)
}

fn apply(j: usize, k: usize, x: &[f64]) -> Vec<f64> {
    let (g, d, a) = filter(j, k);
    let mut y = vec![0.0; x.len()];
    let mut state = 0.0;
    for n in 0..x.len() {
        let input = if n >= d { x[n - d] } else { 0.0 };
        state = a * state + (1.0 - a) * input;
        y[n] = g * state;
    }
    y
}

#[test]
fn h1_recovers_a_known_three_input_system_with_correlated_inputs() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let unit = Normal::new(0.0, 1.0).unwrap();
    // 600 s: 233 half-overlapping segments. Each segment's output also holds the response
    // to input from before the segment (impulse responses of up to ~25 samples against
    // 2048), which acts like noise of about 1 % per segment and averages down.
    let n = 600 * FS_HZ as usize;
    let w: Vec<Vec<f64>> = (0..3)
        .map(|_| (0..n).map(|_| unit.sample(&mut rng)).collect())
        .collect();
    // Strongly correlated inputs: a SISO estimate per input would be badly biased.
    let x = [
        w[0].clone(),
        (0..n)
            .map(|i| 0.7 * w[0][i] + 0.7 * w[1][i])
            .collect::<Vec<_>>(),
        (0..n)
            .map(|i| 0.5 * w[0][i] - 0.3 * w[1][i] + 0.8 * w[2][i])
            .collect::<Vec<_>>(),
    ];
    // Measurement noise 0.1 % of the outputs' rms: the random error of the weakest
    // component (gain 0.3 among gains up to 1.5) then stays near 0.2 %.
    let noise = Normal::new(0.0, 0.001).unwrap();
    let y: Vec<Vec<f64>> = (0..9)
        .map(|j| {
            let mut out = vec![0.0; n];
            for (k, xk) in x.iter().enumerate() {
                for (o, v) in out.iter_mut().zip(apply(j, k, xk)) {
                    *o += v;
                }
            }
            for o in &mut out {
                *o += noise.sample(&mut rng);
            }
            out
        })
        .collect();
    let settings = WelchSettings::for_resolution(FS_HZ, 0.1);
    assert_eq!(settings.segment_len, 2048);
    let est = h1(
        [&x[0], &x[1], &x[2]],
        core::array::from_fn(|j| y[j].as_slice()),
        FS_HZ,
        &settings,
        0.5,
        16.0,
    )
    .unwrap();
    assert!(est.freqs_hz.len() > 150);
    let (mut worst_mag, mut worst_phase_deg) = (0.0f64, 0.0f64);
    for (f, &freq) in est.freqs_hz.iter().enumerate() {
        for j in 0..9 {
            assert!(
                est.coherence[f][j] > 0.99,
                "coherence {}",
                est.coherence[f][j]
            );
            for k in 0..3 {
                let (got, want) = (est.h[f][(j, k)], exact(j, k, freq));
                worst_mag = worst_mag.max((got.norm() / want.norm() - 1.0).abs());
                worst_phase_deg =
                    worst_phase_deg.max(wrap_pi(got.arg() - want.arg()).abs().to_degrees());
            }
        }
    }
    eprintln!("worst magnitude error {worst_mag}, phase {worst_phase_deg} deg");
    assert!(worst_mag < 0.02, "worst magnitude error {worst_mag}");
    assert!(
        worst_phase_deg < 2.0,
        "worst phase error {worst_phase_deg} deg"
    );
    // The sign of the phase: output 0 from input 2 is delayed by 4 samples, so at 10 Hz its
    // phase lags by about 72 degrees plus the low-pass lag (a conjugated estimator leads).
    let f10 = est
        .freqs_hz
        .iter()
        .position(|f| (*f - 10.0).abs() < 0.05)
        .unwrap();
    let phase = est.h[f10][(0, 2)].arg();
    assert!(phase < -1.0, "phase {phase} rad must lag");
}

#[test]
fn psd_of_white_noise_is_its_variance_over_half_the_sample_rate() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let sigma = 0.3;
    let noise = Normal::new(0.0, sigma).unwrap();
    let x: Vec<f64> = (0..200_000).map(|_| noise.sample(&mut rng)).collect();
    let settings = WelchSettings::for_resolution(FS_HZ, 1.0);
    let (f, p) = psd(&x, FS_HZ, &settings).unwrap();
    let expected = sigma * sigma / (FS_HZ / 2.0);
    let band: Vec<f64> = f
        .iter()
        .zip(&p)
        .filter(|(f, _)| **f > 1.0 && **f < 99.0)
        .map(|(_, p)| *p)
        .collect();
    let mean = band.iter().sum::<f64>() / band.len() as f64;
    assert!((mean / expected - 1.0).abs() < 0.02, "{mean} vs {expected}");
}

#[test]
fn welch_rejects_a_record_shorter_than_four_segments() {
    let settings = WelchSettings::for_resolution(FS_HZ, 0.1);
    let x = vec![0.0; settings.min_samples() - 1];
    let err = psd(&x, FS_HZ, &settings).unwrap_err().to_string();
    assert!(err.contains("expected at least 5120 samples"), "{err}");
}

fn close(a: Complex<f64>, b: Complex<f64>) -> bool {
    (a - b).norm() < 1e-12 * b.norm().max(1.0)
}

#[test]
fn geometric_mean_takes_the_geometric_magnitude_and_the_mean_phase() {
    let values = [Complex::from_polar(2.0, 0.2), Complex::from_polar(8.0, 0.6)];
    assert!(close(
        geometric_mean(&values),
        Complex::from_polar(4.0, 0.4)
    ));
    let three = [
        Complex::from_polar(1.0, -0.5),
        Complex::from_polar(10.0, 0.1),
        Complex::from_polar(100.0, 1.0),
    ];
    assert!(close(
        geometric_mean(&three),
        Complex::from_polar(10.0, 0.6 / 3.0)
    ));
}

#[test]
fn geometric_mean_across_the_branch_cut_is_near_pi_not_zero() {
    let d = 1f64.to_radians();
    let values = [
        Complex::from_polar(1.0, PI - d),
        Complex::from_polar(1.0, -PI + d),
    ];
    let mean = geometric_mean(&values);
    assert!((mean.norm() - 1.0).abs() < 1e-12);
    assert!(wrap_pi(mean.arg() - PI).abs() < 1e-12, "{}", mean.arg());
    // Three phases straddling the cut: on the branch nearest the circular mean they are
    // 170, 190 and 176 degrees, whose mean is 178.67 (a naive mean gives 58.67).
    let values = [
        Complex::from_polar(1.0, 170f64.to_radians()),
        Complex::from_polar(1.0, (-170f64).to_radians()),
        Complex::from_polar(1.0, 176f64.to_radians()),
    ];
    let want = (170.0 + 190.0 + 176.0) / 3.0;
    let got = geometric_mean(&values).arg().to_degrees();
    assert!(
        wrap_pi((got - want).to_radians()).abs() < 1e-9,
        "{got} vs {want}"
    );
}

#[test]
fn wrap_pi_maps_into_minus_pi_exclusive_to_pi_inclusive() {
    assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-12);
    assert!((wrap_pi(-PI) - PI).abs() < 1e-12);
    assert!((wrap_pi(0.5 - 4.0 * PI) - 0.5).abs() < 1e-12);
}

/// Three inputs of white noise (seed 11), `n` samples, with nine outputs that sum them.
fn white_inputs(n: usize) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let unit = Normal::new(0.0, 1.0).unwrap();
    let x: Vec<Vec<f64>> = (0..3)
        .map(|_| (0..n).map(|_| unit.sample(&mut rng)).collect())
        .collect();
    let y: Vec<Vec<f64>> = (0..9)
        .map(|j| {
            (0..n)
                .map(|i| x[0][i] + 0.5 * x[1][i] + 0.1 * j as f64 * x[2][i])
                .collect()
        })
        .collect();
    (x, y)
}

fn h1_of(
    x: &[Vec<f64>],
    y: &[Vec<f64>],
) -> Result<supine_host::identify::spectral::H1Estimate, SpectralError> {
    let settings = WelchSettings::for_resolution(FS_HZ, 1.0);
    h1(
        [&x[0], &x[1], &x[2]],
        core::array::from_fn(|j| y[j].as_slice()),
        FS_HZ,
        &settings,
        0.5,
        16.0,
    )
}

#[test]
fn well_conditioned_inputs_give_a_finite_h1_with_the_known_gains() {
    let (x, y) = white_inputs(60 * FS_HZ as usize);
    let est = h1_of(&x, &y).unwrap();
    for h in &est.h {
        assert!((h[(0, 0)].re - 1.0).abs() < 1e-9 && (h[(0, 1)].re - 0.5).abs() < 1e-9);
    }
}

#[test]
fn a_dead_input_axis_is_an_error_naming_the_band_not_nan() {
    let (mut x, y) = white_inputs(60 * FS_HZ as usize);
    x[1] = vec![0.0; x[1].len()];
    let err = h1_of(&x, &y).unwrap_err();
    // 256-sample segments at 200 Hz: bins of 0.78125 Hz, 0.781-15.625 Hz in 0.5-16 Hz.
    let SpectralError::IllConditioned {
        from_hz,
        to_hz,
        bins,
        of,
        condition,
    } = err
    else {
        panic!("expected IllConditioned, found {err}");
    };
    assert_eq!((from_hz, to_hz, bins, of), (0.78125, 15.625, 20, 20));
    assert!(condition.is_infinite());
    assert!(
        err.to_string()
            .contains("at 20 of 20 bins in 0.781-15.625 Hz")
    );
}

#[test]
fn two_identical_input_axes_are_an_error() {
    let (mut x, y) = white_inputs(60 * FS_HZ as usize);
    x[2] = x[0].clone();
    let err = h1_of(&x, &y).unwrap_err();
    assert!(
        matches!(err, SpectralError::IllConditioned { condition, .. } if condition > MAX_INPUT_CONDITION),
        "{err}"
    );
}

#[test]
fn the_condition_number_of_a_diagonal_input_matrix_is_its_eigenvalue_ratio() {
    let c = |v: f64| Complex::new(v, 0.0);
    let sxx = nalgebra::Matrix3::new(
        c(4.0),
        c(0.0),
        c(0.0),
        c(0.0),
        c(2.0),
        c(0.0),
        c(0.0),
        c(0.0),
        c(1e-3),
    );
    assert!((input_condition(&sxx) / 4e3 - 1.0).abs() < 1e-12);
}
