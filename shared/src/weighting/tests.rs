//! Host tests of the weighting filters against independent references.

use super::*;

/// A supported rate (every rate these tests design for is one).
fn rate(hz: f32) -> SampleRate {
    SampleRate::new(hz).expect("a supported rate")
}

/// Minimal complex arithmetic for the reference formula, written apart from the module's.
#[derive(Clone, Copy)]
struct C(f64, f64);

impl C {
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    fn abs(self) -> f64 {
        (self.0 * self.0 + self.1 * self.1).sqrt()
    }
}

/// The ISO 8041 weighting straight from the parameter table in
/// docs/exposure.md#frequency-weightings: (f1, f2, f3, f4, Q4, f5, Q5, f6, Q6, K), `inf` written as `f64::INFINITY`.
fn reference_magnitude(kind: WeightingKind, f: f64) -> f64 {
    let inf = f64::INFINITY;
    let (f1, f2, f3, f4, q4, f5, q5, f6, q6, k) = match kind {
        WeightingKind::Wk => (0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91, 1.0),
        WeightingKind::Wd => (0.4, 100.0, 2.0, 2.0, 0.63, inf, 1.0, inf, 1.0, 1.0),
        WeightingKind::Wj => (0.4, 100.0, inf, inf, 1.0, 3.75, 0.91, 5.32, 0.91, 1.0),
    };
    let tau = 2.0 * std::f64::consts::PI;
    let q1 = 1.0 / 2f64.sqrt();
    let s = C(0.0, tau * f);
    let s2 = s.mul(s);
    let (w1, w2, w3, w4, w5, w6) = (tau * f1, tau * f2, tau * f3, tau * f4, tau * f5, tau * f6);
    let hh = s2.div(C(s2.0 + w1 * w1, s2.1 + s.1 * w1 / q1));
    let hl = C(w2 * w2, 0.0).div(C(s2.0 + w2 * w2, s2.1 + s.1 * w2 / q1));
    let ht = if f3.is_finite() {
        C(k, k * s.1 / w3).div(C(1.0 + s2.0 / (w4 * w4), s.1 / (q4 * w4)))
    } else {
        C(k, 0.0)
    };
    let hs = if f5.is_finite() {
        let n = C(s2.0 + w5 * w5, s.1 * w5 / q5);
        let d = C(s2.0 + w6 * w6, s.1 * w6 / q6);
        n.div(d)
    } else {
        C(1.0, 0.0)
    };
    hh.mul(hl).mul(ht).mul(hs).abs()
}

/// ISO 8041 tolerance (upper, lower) on a weighting's relative error at `f` Hz.
fn iso8041_tolerance(f: f64) -> (f64, f64) {
    if (0.631..=63.1).contains(&f) {
        (0.12, -0.11)
    } else {
        (0.26, -0.21)
    }
}

/// A log-spaced grid plus the exact one-third-octave centres, over `lo..=hi` Hz.
fn grid(lo: f64, hi: f64) -> Vec<f64> {
    let mut v: Vec<f64> = (0..=2000)
        .map(|i| lo * (hi / lo).powf(i as f64 / 2000.0))
        .collect();
    v.extend(
        (-10..=30)
            .map(|n| 10f64.powf(n as f64 / 10.0))
            .filter(|f| (lo..=hi).contains(f)),
    );
    v
}

/// Largest relative deviation of the device's filter from the analog formula, and where.
fn worst_deviation(kind: WeightingKind, fs: f32, lo: f64, hi: f64) -> (f64, f64) {
    let w = WeightingSettings::new(kind, rate(fs)).unwrap();
    let mut worst = (0.0f64, 0.0f64);
    for f in grid(lo, hi) {
        let e = w.response(rate(fs), f).abs() / reference_magnitude(kind, f) - 1.0;
        if e.abs() > worst.0.abs() {
            worst = (e, f);
        }
    }
    worst
}

#[test]
fn analog_response_agrees_with_the_table_formula_written_independently() {
    for kind in WeightingKind::ALL {
        for f in grid(0.1, 400.0) {
            let a = analog_response(kind, f).abs();
            let r = reference_magnitude(kind, f);
            assert!((a / r - 1.0).abs() < 1e-12, "{kind} at {f} Hz: {a} vs {r}");
        }
    }
}

#[test]
fn calibration_factors_at_100_rad_per_s_are_within_1_percent_of_the_standard() {
    let f = 100.0 / (2.0 * std::f64::consts::PI);
    for (kind, expected) in [
        (WeightingKind::Wk, 0.7718),
        (WeightingKind::Wd, 0.1261),
        (WeightingKind::Wj, 1.019),
    ] {
        let analog = analog_response(kind, f).abs();
        assert!(
            (analog / expected - 1.0).abs() < 1e-3,
            "{kind} analog {analog}"
        );
        for fs in [200.0, 500.0, 1000.0, 2000.0] {
            let digital = WeightingSettings::new(kind, rate(fs))
                .unwrap()
                .response(rate(fs), f)
                .abs();
            assert!(
                (digital / expected - 1.0).abs() < 0.01,
                "{kind} at fs {fs}: {digital}"
            );
        }
    }
}

#[test]
fn analog_peaks_sit_where_the_standard_says() {
    for (kind, f_peak, peak) in [
        (WeightingKind::Wk, 6.17, 1.0545),
        (WeightingKind::Wd, 1.09, 1.0126),
        (WeightingKind::Wj, 10.15, 1.0302),
    ] {
        let (mut best_f, mut best) = (0.0, 0.0);
        for f in grid(0.5, 50.0) {
            let m = analog_response(kind, f).abs();
            if m > best {
                (best_f, best) = (f, m);
            }
        }
        assert!((best / peak - 1.0).abs() < 1e-3, "{kind} peak {best}");
        assert!(
            (best_f / f_peak - 1.0).abs() < 0.02,
            "{kind} peak at {best_f} Hz"
        );
    }
}

/// Nominal one-third-octave frequencies 0.1-80 Hz, the columns of the tables below.
const NOMINAL_HZ: [f64; 30] = [
    0.1, 0.125, 0.16, 0.2, 0.25, 0.315, 0.4, 0.5, 0.63, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0,
    5.0, 6.3, 8.0, 10.0, 12.5, 16.0, 20.0, 25.0, 31.5, 40.0, 50.0, 63.0, 80.0,
];

/// ISO 2631-1 Tables 3 and 4: factors x 1000 at the nominal frequencies (the standard
/// evaluates them there, not at 10^(n/10)), as transcribed in public sources. Two entries
/// of that transcription are misprints no smooth curve passes through (Wd 212 at 10 Hz
/// between 253 and 161, as docs/exposure.md#reference-values notes; Wj 528 at 4 Hz between
/// 524 and 793): the formula gives 202 and 628. They are `None` here and checked to be wrong below.
const TABLE_MILLI: [(WeightingKind, [Option<f64>; 30]); 3] = [
    (
        WeightingKind::Wk,
        [
            Some(31.2),
            Some(48.6),
            Some(79.0),
            Some(121.0),
            Some(182.0),
            Some(263.0),
            Some(352.0),
            Some(418.0),
            Some(459.0),
            Some(477.0),
            Some(482.0),
            Some(484.0),
            Some(494.0),
            Some(531.0),
            Some(631.0),
            Some(804.0),
            Some(967.0),
            Some(1039.0),
            Some(1054.0),
            Some(1036.0),
            Some(988.0),
            Some(902.0),
            Some(768.0),
            Some(636.0),
            Some(513.0),
            Some(405.0),
            Some(314.0),
            Some(246.0),
            Some(186.0),
            Some(132.0),
        ],
    ),
    (
        WeightingKind::Wd,
        [
            Some(62.4),
            Some(97.3),
            Some(158.0),
            Some(243.0),
            Some(365.0),
            Some(530.0),
            Some(713.0),
            Some(853.0),
            Some(944.0),
            Some(992.0),
            Some(1011.0),
            Some(1008.0),
            Some(968.0),
            Some(890.0),
            Some(776.0),
            Some(642.0),
            Some(512.0),
            Some(409.0),
            Some(323.0),
            Some(253.0),
            None,
            Some(161.0),
            Some(125.0),
            Some(100.0),
            Some(80.0),
            Some(63.2),
            Some(49.4),
            Some(38.8),
            Some(29.5),
            Some(21.1),
        ],
    ),
    (
        WeightingKind::Wj,
        [
            Some(31.0),
            Some(48.3),
            Some(78.5),
            Some(120.0),
            Some(181.0),
            Some(262.0),
            Some(351.0),
            Some(417.0),
            Some(458.0),
            Some(478.0),
            Some(484.0),
            Some(485.0),
            Some(483.0),
            Some(482.0),
            Some(489.0),
            Some(524.0),
            None,
            Some(793.0),
            Some(946.0),
            Some(1017.0),
            Some(1030.0),
            Some(1026.0),
            Some(1018.0),
            Some(1012.0),
            Some(1007.0),
            Some(1001.0),
            Some(991.0),
            Some(972.0),
            Some(931.0),
            Some(843.0),
        ],
    ),
];

/// Three significant figures: the rounding of a printed factor is at most 0.5 / 100.
const TABLE_ROUNDING: f64 = 0.005;

#[test]
fn tabulated_one_third_octave_factors_match_the_formula_within_their_rounding() {
    for (kind, row) in TABLE_MILLI {
        for (&f, milli) in NOMINAL_HZ.iter().zip(row) {
            let Some(milli) = milli else { continue };
            let m = 1000.0 * analog_response(kind, f).abs();
            assert!(
                (m / milli - 1.0).abs() < TABLE_ROUNDING,
                "{kind} at {f} Hz: {m:.1} vs {milli}"
            );
        }
    }
    // The misprints themselves: 5 % and 16 % off the formula.
    let wd10 = 1000.0 * analog_response(WeightingKind::Wd, 10.0).abs();
    assert!((wd10 / 212.0 - 1.0).abs() > 0.04);
    let wj4 = 1000.0 * analog_response(WeightingKind::Wj, 4.0).abs();
    assert!((wj4 / 528.0 - 1.0).abs() > 0.15);
}

#[test]
fn the_device_filters_meet_the_tabulated_factors_within_iso8041_from_0_5_to_80_hz() {
    for fs in [500.0, 1000.0] {
        for (kind, row) in TABLE_MILLI {
            let w = WeightingSettings::new(kind, rate(fs)).unwrap();
            for (&f, milli) in NOMINAL_HZ.iter().zip(row) {
                let Some(milli) = milli.filter(|_| f >= 0.5) else {
                    continue;
                };
                let e = 1000.0 * w.response(rate(fs), f).abs() / milli - 1.0;
                let (hi, lo) = iso8041_tolerance(f);
                assert!(
                    lo - TABLE_ROUNDING <= e && e <= hi + TABLE_ROUNDING,
                    "{kind} fs {fs} at {f} Hz: {e:+.4}"
                );
                // Much closer than the tolerance in practice: the design's own error.
                assert!(
                    e.abs() < 0.03 + TABLE_ROUNDING,
                    "{kind} fs {fs} at {f} Hz: {e:+.4}"
                );
            }
        }
    }
}

#[test]
fn deviation_from_analog_is_inside_iso8041_tolerance_from_0_5_to_80_hz_at_500_hz_and_1_khz() {
    for fs in [500.0, 1000.0] {
        for kind in WeightingKind::ALL {
            let w = WeightingSettings::new(kind, rate(fs)).unwrap();
            for f in grid(0.5, 80.0) {
                let e = w.response(rate(fs), f).abs() / reference_magnitude(kind, f) - 1.0;
                let (hi, lo) = iso8041_tolerance(f);
                assert!(lo <= e && e <= hi, "{kind} fs {fs} at {f:.2} Hz: {e:+.4}");
            }
        }
    }
}

#[test]
fn deviation_is_under_3_percent_at_500_hz_1_percent_at_1_khz_and_0_3_percent_at_2_khz() {
    for kind in WeightingKind::ALL {
        let (e500, f500) = worst_deviation(kind, 500.0, 0.5, 80.0);
        let (e1k, f1k) = worst_deviation(kind, 1000.0, 0.5, 80.0);
        let (e2k, f2k) = worst_deviation(kind, 2000.0, 0.5, 80.0);
        println!("{kind}: fs 2000 worst {e2k:+.4} at {f2k:.1} Hz");
        assert!(e2k.abs() < 0.003);
        println!(
            "{kind}: fs 500 worst {e500:+.4} at {f500:.1} Hz; fs 1000 worst {e1k:+.4} at {f1k:.1} Hz"
        );
        assert!(e500.abs() < 0.03 && e1k.abs() < 0.01);
    }
}

/// At 200 Hz the whole 0.5-80 Hz band is within ISO 8041, with the largest error near
/// 80 Hz (about -14 %) inside the wider +26/-21 % tolerance above 63.1 Hz; up to 40 Hz
/// the error stays under 5 %.
#[test]
fn deviation_at_200_hz_meets_iso8041_over_0_5_to_80_hz_and_is_under_5_percent_to_40_hz() {
    for kind in WeightingKind::ALL {
        let w = WeightingSettings::new(kind, rate(200.0)).unwrap();
        for f in grid(0.5, 80.0) {
            let e = w.response(rate(200.0), f).abs() / reference_magnitude(kind, f) - 1.0;
            let (hi, lo) = iso8041_tolerance(f);
            assert!(lo <= e && e <= hi, "{kind} at {f:.2} Hz: {e:+.4}");
            if f <= 40.0 {
                assert!(e.abs() < 0.05, "{kind} at {f:.2} Hz: {e:+.4}");
            }
        }
        let (e, f) = worst_deviation(kind, 200.0, 0.5, 80.0);
        println!("{kind}: fs 200 worst {e:+.4} at {f:.1} Hz");
        let (e, f) = worst_deviation(kind, 200.0, 0.5, 63.1);
        println!("{kind}: fs 200 worst up to 63.1 Hz {e:+.4} at {f:.1} Hz");
    }
}

#[test]
fn every_sample_rate_from_100_to_2000_hz_designs_a_stable_filter() {
    for kind in WeightingKind::ALL {
        for fs in (100..=2000).step_by(7).chain([2000]) {
            let w = WeightingSettings::new(kind, rate(fs as f32));
            assert!(w.is_ok(), "{kind} at {fs} Hz: {w:?}");
            assert!(w.unwrap().validate().is_ok());
        }
    }
}

#[test]
fn below_200_hz_the_filter_follows_the_analog_magnitude_up_to_nyquist() {
    for kind in WeightingKind::ALL {
        for fs in [100.0f32, 150.0] {
            let w = WeightingSettings::new(kind, rate(fs)).unwrap();
            for f in grid(0.5, 0.999 * fs as f64 / 2.0) {
                let e = w.response(rate(fs), f).abs() / reference_magnitude(kind, f) - 1.0;
                let (hi, lo) = iso8041_tolerance(f);
                // Meets the wide tolerance everywhere; the narrow one up to fs/4.
                assert!(
                    (-0.21..=0.26).contains(&e),
                    "{kind} fs {fs} at {f:.2}: {e:+.4}"
                );
                if f < fs as f64 / 4.0 {
                    assert!(lo <= e && e <= hi, "{kind} fs {fs} at {f:.2}: {e:+.4}");
                }
            }
        }
    }
}

#[test]
fn stored_settings_with_an_unstable_or_non_finite_section_are_refused() {
    let good = WeightingSettings::new(WeightingKind::Wd, rate(500.0)).unwrap();
    let mut bad = good;
    bad.shaping[0].a = [-2.0, 1.0];
    assert_eq!(bad.validate(), Err(WeightingError::Unstable));
    let mut bad = good;
    bad.band.low_pass.b[2] = f32::NAN;
    assert_eq!(bad.validate(), Err(WeightingError::NonFiniteCoefficient));
    let mut bad = good;
    bad.band.high_pass.k_plus_g = 0.0;
    assert_eq!(bad.validate(), Err(WeightingError::Unstable));
    for n in [0, 2, 3] {
        let mut bad = good;
        bad.n_shaping = n;
        assert_eq!(
            bad.validate(),
            Err(WeightingError::WrongSectionCount),
            "{n}"
        );
    }
}

/// Impulse response energy of the stored high-pass after `n` samples, relative to the first.
fn high_pass_energy_growth(svf: &HighPassSvf, n: usize) -> f64 {
    let mut st = [0.0f32; 2];
    let first = svf.step(&mut st, 1.0) as f64;
    let mut last = 0.0f64;
    for _ in 0..n {
        last = svf.step(&mut st, 0.0) as f64;
    }
    (last * last) / (first * first)
}

#[test]
fn a_high_pass_whose_plausible_coefficients_combine_into_an_unstable_recursion_is_refused() {
    let good = WeightingSettings::new(WeightingKind::Wk, rate(500.0)).unwrap();
    assert!(high_pass_energy_growth(&good.band.high_pass, 20_000) < 1e-6);
    // Each value positive and finite, k = k_plus_g - g > 0 (what an analog check accepts),
    // but d no longer 1 / (1 + g k + g^2): a2 = 1 - 2 d g k falls below -1.
    let mut bad = good;
    bad.band.high_pass.d = 400.0;
    assert!(high_pass_energy_growth(&bad.band.high_pass, 50) > 1e6);
    assert_eq!(bad.validate(), Err(WeightingError::Unstable));
}

#[test]
fn the_gain_check_accepts_the_axis_factor_folded_in_and_nothing_else() {
    for kind in WeightingKind::ALL {
        for fs in (100..=2000).step_by(50).map(|f| f as f32) {
            let w = WeightingSettings::new(kind, rate(fs)).unwrap();
            assert_eq!(w.validate_gain(1.0), Ok(()), "{kind} at {fs} Hz");
            assert_eq!(
                w.scaled(1.4).validate_gain(1.4),
                Ok(()),
                "{kind} at {fs} Hz"
            );
            assert_eq!(
                w.scaled(1.4).validate_gain(1.0),
                Err(WeightingError::GainMismatch),
                "{kind} at {fs} Hz"
            );
            assert_eq!(
                w.scaled(1.02).validate_gain(1.0),
                Err(WeightingError::GainMismatch),
                "{kind} at {fs} Hz"
            );
        }
    }
}

/// Runs a sine of amplitude 1 m/s^2 through the f32 filter and returns the output rms
/// over whole periods after the high-pass has settled.
fn measured_sine_rms(w: &WeightingSettings, fs: f64, f: f64) -> f64 {
    let mut st = WeightingState::new();
    let settle = (20.0 * fs) as usize;
    let periods = (20.0 * f).ceil().max(10.0);
    let n = (periods * fs / f).round() as usize;
    let mut acc = 0.0f64;
    for i in 0..settle + n {
        let x = (2.0 * std::f64::consts::PI * f * i as f64 / fs).sin() as f32;
        let y = w.step(&mut st, x) as f64;
        if i >= settle {
            acc += y * y;
        }
    }
    (acc / n as f64).sqrt()
}

#[test]
fn sines_through_the_f32_filter_give_rms_of_amplitude_times_factor_over_root_two() {
    for kind in WeightingKind::ALL {
        for fs in [200.0f32, 500.0, 2000.0] {
            let w = WeightingSettings::new(kind, rate(fs)).unwrap();
            for f in [0.5, 1.0, 4.0, 15.915, 63.1] {
                if f >= fs as f64 / 2.0 {
                    continue;
                }
                let rms = measured_sine_rms(&w, fs as f64, f);
                // The device's own response: the f32 arithmetic must not add error.
                let own = w.response(rate(fs), f).abs() / 2f64.sqrt();
                assert!(
                    (rms / own - 1.0).abs() < 2e-3,
                    "{kind} fs {fs} f {f}: {rms} vs {own}"
                );
                // And the analog factor, within ISO 8041.
                let analog = reference_magnitude(kind, f) / 2f64.sqrt();
                let (hi, lo) = iso8041_tolerance(f);
                let e = rms / analog - 1.0;
                assert!(lo <= e && e <= hi, "{kind} fs {fs} f {f}: {e:+.4}");
            }
        }
    }
}

/// Why the high-pass is an SVF: the same 0.4 Hz high-pass as a direct-form biquad with
/// f32 coefficients is visibly off at 2 kHz, while the SVF's stored values are not.
#[test]
fn a_direct_form_high_pass_with_f32_coefficients_would_be_off_at_2_khz_while_the_svf_is_not() {
    let fs = 2000.0f64;
    let w1 = 2.0 * std::f64::consts::PI * 0.4;
    let c = w1 / (w1 / (2.0 * fs)).tan();
    let q1 = 1.0 / 2f64.sqrt();
    let a0 = c * c + c * w1 / q1 + w1 * w1;
    let direct = Biquad {
        b: [
            (c * c / a0) as f32,
            (-2.0 * c * c / a0) as f32,
            (c * c / a0) as f32,
        ],
        a: [
            ((2.0 * w1 * w1 - 2.0 * c * c) / a0) as f32,
            ((c * c - c * w1 / q1 + w1 * w1) / a0) as f32,
        ],
    };
    let svf = HighPassSvf::design(0.4, q1, fs);
    let mut worst_direct = 0.0f64;
    let mut worst_svf = 0.0f64;
    for f in grid(0.25, 2.0) {
        let z = Complex64::from_angle(2.0 * std::f64::consts::PI * f / fs);
        let s = C(0.0, 2.0 * std::f64::consts::PI * f);
        let s2 = s.mul(s);
        let exact = s2.div(C(s2.0 + w1 * w1, s.1 * w1 / q1)).abs();
        worst_direct = worst_direct.max((direct.response_at(z).abs() / exact - 1.0).abs());
        worst_svf = worst_svf.max((svf.response_at(z).abs() / exact - 1.0).abs());
    }
    println!(
        "0.4 Hz high-pass at 2 kHz, 0.25-2 Hz: direct form {worst_direct:.4}, SVF {worst_svf:.2e}"
    );
    assert!(worst_svf < 1e-6);
    assert!(worst_direct > 10.0 * worst_svf);
}

#[test]
fn settings_survive_a_postcard_round_trip_bit_for_bit() {
    let w = WeightingSettings::new(WeightingKind::Wj, rate(500.0)).unwrap();
    let mut buf = [0u8; 128];
    let bytes = postcard::to_slice(&w, &mut buf).unwrap();
    let back: WeightingSettings = postcard::from_bytes(bytes).unwrap();
    assert_eq!(back, w);
}

#[test]
fn scaling_multiplies_the_response_by_k() {
    let w = WeightingSettings::new(WeightingKind::Wk, rate(500.0)).unwrap();
    let k = 1.4f32;
    let ratio = w.scaled(k).response(rate(500.0), 5.0).abs() / w.response(rate(500.0), 5.0).abs();
    assert!((ratio - k as f64).abs() < 1e-6);
}

/// The device's f32 DC gain of each section agrees with the same gain in f64 within 0.2 %
/// (worst about 0.11 %, Wk near 2 kHz), so three sections stay well inside the check's 1 %.
#[test]
fn the_f32_dc_gain_is_within_0_2_percent_of_f64_at_every_rate() {
    let f64_gain = |q: &Biquad| {
        let num: f64 = q.b.iter().map(|&b| b as f64).sum();
        num / (1.0 + q.a[0] as f64 + q.a[1] as f64)
    };
    for kind in WeightingKind::ALL {
        for fs in (100..=2000).step_by(50) {
            let w = WeightingSettings::new(kind, rate(fs as f32)).unwrap();
            let sections =
                core::iter::once(&w.band.low_pass).chain(&w.shaping[..w.n_shaping as usize]);
            for q in sections {
                let e = q.dc_gain() as f64 / f64_gain(q) - 1.0;
                assert!(e.abs() < 2e-3, "{kind} at {fs} Hz: {e:+.2e}");
            }
        }
    }
}

/// Runs a [`Recursion2`](crate::gain_bound::Recursion2) in f64 on an impulse: its response.
fn recursion_impulse(rec: &crate::gain_bound::Recursion2, n: usize) -> Vec<f64> {
    let d = rec.a_minus_identity.map(|r| r.map(f64::from));
    let (b, c) = (rec.b.map(f64::from), rec.c.map(f64::from));
    let mut x = [0.0f64; 2];
    (0..n)
        .map(|k| {
            let u = if k == 0 { 1.0 } else { 0.0 };
            let y = c[0] * x[0] + c[1] * x[1] + f64::from(rec.d) * u;
            x = [
                x[0] + d[0][0] * x[0] + d[0][1] * x[1] + b[0] * u,
                x[1] + d[1][0] * x[0] + d[1][1] * x[1] + b[1] * u,
            ];
            y
        })
        .collect()
}

#[test]
fn the_state_space_forms_behind_the_gain_bound_are_the_filters_that_run() {
    // Each section's recursion, run in f64, against the section's own f32 step: the same
    // impulse response (to f32 rounding, amplified near z = 1 at 2 kHz; a wrong term would
    // differ at the first samples by the term itself), so the blob's gain bound bounds what
    // runs.
    for hz in [100.0, 500.0, 2000.0] {
        for kind in [WeightingKind::Wk, WeightingKind::Wd, WeightingKind::Wj] {
            let w = WeightingSettings::new(kind, rate(hz)).unwrap();
            let mut svf_state = [0.0f32; 2];
            let svf: Vec<f64> = (0..400)
                .map(|k| {
                    w.band
                        .high_pass
                        .step(&mut svf_state, if k == 0 { 1.0 } else { 0.0 })
                        as f64
                })
                .collect();
            let sections = [(w.band.low_pass, "low-pass"), (w.shaping[0], "shaping")];
            let mut pairs = vec![(
                svf,
                recursion_impulse(&w.band.high_pass.recursion(), 400),
                "high-pass",
            )];
            for (q, name) in sections {
                let mut st = [0.0f32; 2];
                let run: Vec<f64> = (0..400)
                    .map(|k| q.step(&mut st, if k == 0 { 1.0 } else { 0.0 }) as f64)
                    .collect();
                pairs.push((run, recursion_impulse(&q.recursion(), 400), name));
            }
            for (run, model, name) in pairs {
                let scale = run.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (k, (a, b)) in run.iter().zip(&model).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-3 * scale,
                        "{kind:?} {hz} Hz {name} at {k}: {a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_high_pass_recursion_has_the_denominator_of_its_transfer_function() {
    // Multiplying `hp = 1 / (1/d + 2 c g/(z-1) + 2 g^2 (z+1)/(z-1)^2)` by `d (z-1)^2` gives
    // the denominator `z^2 + a1 z + a2` with `a1 = 2 d g c + 2 d g^2 - 2`,
    // `a2 = 1 - 2 d g k`: A's trace is -a1 and its determinant a2.
    let w = WeightingSettings::new(WeightingKind::Wk, rate(500.0)).unwrap();
    let hp = w.band.high_pass;
    let (g, c, d) = (hp.g as f64, hp.k_plus_g as f64, hp.d as f64);
    let (a1, a2) = (2.0 * d * g * (c + g) - 2.0, 1.0 - 2.0 * d * g * (c - g));
    let m = hp.recursion().a_minus_identity.map(|r| r.map(f64::from));
    let a = [[1.0 + m[0][0], m[0][1]], [m[1][0], 1.0 + m[1][1]]];
    assert!((a[0][0] + a[1][1] + a1).abs() < 1e-6);
    assert!((a[0][0] * a[1][1] - a[0][1] * a[1][0] - a2).abs() < 1e-6);
}
