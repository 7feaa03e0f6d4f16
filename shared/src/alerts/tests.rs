//! Host tests of the alert state machine and the sensor-fault check.

use super::*;
use crate::exposure::{ExposureConfig, ExposureSettings, ExposureState};

const FS: f32 = 500.0;

/// A supported rate (every rate these tests build for is one).
fn rate(hz: f32) -> SampleRate {
    SampleRate::new(hz).expect("a supported rate")
}

fn sample(rms_m_s2: f32, vdv_m_s175: f32) -> ExposureSample {
    ExposureSample {
        running_ms_m2_s4: rms_m_s2 * rms_m_s2,
        vdv4_m4_s7: vdv_m_s175.powi(4),
        valid: true,
        ..ExposureSample::default()
    }
}

/// The running-rms criterion as the state machine reports `rms_m_s2` (squared, then its
/// square root: IEEE-754 rounds both exactly, so this is what the step computes).
fn by_rms(rms_m_s2: f32) -> Criterion {
    Criterion::RunningRms {
        value_m_s2: (rms_m_s2 * rms_m_s2).sqrt(),
    }
}

/// The VDV criterion as the state machine reports `vdv_m_s175` (fourth power, two roots).
fn by_vdv(vdv_m_s175: f32) -> Criterion {
    Criterion::Vdv {
        value_m_s175: vdv_m_s175.powi(4).sqrt().sqrt(),
    }
}

/// Feeds `rms(i)` (VDV 0) for `n` samples from index `start`; returns the events.
fn feed(
    s: &AlertSettings,
    st: &mut AlertState,
    start: u32,
    n: u32,
    rms: impl Fn(u32) -> f32,
) -> Vec<AlertEvent> {
    (start..start + n)
        .filter_map(|i| s.step(st, &sample(rms(i), 0.0), i))
        .collect()
}

#[test]
fn a_rising_running_rms_raises_advisory_warning_and_alarm_after_the_raise_dwell() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    assert_eq!(s.raise_dwell_samples, 250);
    let mut st = AlertState::new();
    let mut ev = feed(&s, &mut st, 0, 1000, |_| 0.6);
    ev.extend(feed(&s, &mut st, 1000, 1000, |_| 0.9));
    ev.extend(feed(&s, &mut st, 2000, 1000, |_| 1.3));
    assert_eq!(
        ev,
        vec![
            AlertEvent::Level {
                from: Level::Normal,
                to: Level::Advisory,
                criterion: by_rms(0.6),
                at_sample: 249
            },
            AlertEvent::Level {
                from: Level::Advisory,
                to: Level::Warning,
                criterion: by_rms(0.9),
                at_sample: 1249
            },
            AlertEvent::Level {
                from: Level::Warning,
                to: Level::Alarm,
                criterion: by_rms(1.3),
                at_sample: 2249
            },
        ]
    );
    assert!(ev.iter().all(AlertEvent::is_raise));
    assert!((ev[0].at_s(FS) - 0.498).abs() < 1e-9);
}

#[test]
fn a_jump_straight_to_alarm_is_one_event() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = AlertState::new();
    let ev = feed(&s, &mut st, 0, 500, |_| 3.0);
    assert_eq!(
        ev,
        vec![AlertEvent::Level {
            from: Level::Normal,
            to: Level::Alarm,
            criterion: by_rms(3.0),
            at_sample: 249
        }]
    );
}

#[test]
fn a_spike_shorter_than_the_raise_dwell_raises_nothing() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = AlertState::new();
    let ev = feed(&s, &mut st, 0, 2000, |i| {
        if (100..300).contains(&i) { 2.0 } else { 0.1 }
    });
    assert!(ev.is_empty());
    assert_eq!(st.level(), Level::Normal);
}

#[test]
fn a_running_rms_hovering_around_a_threshold_does_not_chatter() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = AlertState::new();
    // 0.5 m/s^2 +/- 8 %, alternating every 0.6 s: inside the 20 % hysteresis band.
    let ev = feed(&s, &mut st, 0, 30_000, |i| {
        if (i / 300) % 2 == 0 { 0.54 } else { 0.46 }
    });
    assert_eq!(ev.len(), 1, "{ev:?}");
    assert_eq!(st.level(), Level::Advisory);
}

#[test]
fn a_level_clears_only_below_the_hysteresis_band_and_after_the_clear_dwell() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = AlertState::new();
    feed(&s, &mut st, 0, 1000, |_| 0.9);
    assert_eq!(st.level(), Level::Warning);
    // 0.7 is below warning (0.8) but above its clear threshold (0.64): holds.
    assert!(feed(&s, &mut st, 1000, 10_000, |_| 0.7).is_empty());
    // 0.6 is below 0.64 and above advisory's clear (0.4): drops to advisory after 5 s.
    let ev = feed(&s, &mut st, 11_000, 3000, |_| 0.6);
    assert_eq!(
        ev,
        vec![AlertEvent::Level {
            from: Level::Warning,
            to: Level::Advisory,
            criterion: by_rms(0.6),
            at_sample: 13_499
        }]
    );
    assert!(!ev[0].is_raise());
    // Quiet: back to normal after another 5 s.
    let ev = feed(&s, &mut st, 14_000, 3000, |_| 0.1);
    assert_eq!(
        ev,
        vec![AlertEvent::Level {
            from: Level::Advisory,
            to: Level::Normal,
            criterion: by_rms(0.1),
            at_sample: 16_499
        }]
    );
}

#[test]
fn a_vdv_over_its_threshold_raises_a_level_that_stays() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = AlertState::new();
    let mut ev = Vec::new();
    for i in 0..2000u32 {
        ev.extend(s.step(&mut st, &sample(0.1, 9.0), i));
    }
    for i in 2000..5000u32 {
        ev.extend(s.step(&mut st, &sample(0.1, 17.5), i));
    }
    assert_eq!(
        ev,
        vec![
            AlertEvent::Level {
                from: Level::Normal,
                to: Level::Advisory,
                criterion: by_vdv(9.0),
                at_sample: 249
            },
            AlertEvent::Level {
                from: Level::Advisory,
                to: Level::Warning,
                criterion: by_vdv(17.5),
                at_sample: 2249
            },
        ]
    );
}

#[test]
fn nothing_is_raised_while_the_exposure_is_still_warming_up() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = AlertState::new();
    let warming = ExposureSample {
        valid: false,
        ..sample(5.0, 30.0)
    };
    assert!((0..5000).all(|i| s.step(&mut st, &warming, i).is_none()));
    assert_eq!(st.level(), Level::Normal);
}

#[test]
fn a_five_hertz_sine_through_the_exposure_stage_raises_advisory_half_a_second_after_warm_up() {
    let e = ExposureSettings::new(ExposureConfig::DEFAULT, rate(FS)).unwrap();
    let a = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let (mut es, mut ast) = (ExposureState::new(), AlertState::new());
    let (mut ev, mut rms_m_s2) = (Vec::new(), Vec::new());
    for i in 0..(20.0 * FS) as u32 {
        let t = i as f64 / FS as f64;
        let z = (2.0 * std::f64::consts::PI * 5.0 * t).sin() as f32;
        let out = e.step(&mut es, [0.0, 0.0, z], i);
        rms_m_s2.push(out.running_ms_m2_s4.sqrt());
        ev.extend(a.step(&mut ast, &out, i));
    }
    // Wj(5 Hz) is about 1.02: running rms about 0.72 m/s^2 -> advisory, not warning.
    assert_eq!(ev.len(), 1, "{ev:?}");
    let at_sample = 2500 + 249;
    assert_eq!(
        ev[0],
        AlertEvent::Level {
            from: Level::Normal,
            to: Level::Advisory,
            criterion: Criterion::RunningRms {
                value_m_s2: rms_m_s2[at_sample as usize]
            },
            at_sample
        }
    );
    // Named with a value between the advisory and warning thresholds.
    assert!(
        (0.5..0.8).contains(&ev[0].criterion().map_or(0.0, |c| c.value())),
        "{ev:?}"
    );
}

#[test]
fn a_raise_names_the_criterion_that_reaches_the_new_level() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    // Running rms at advisory (0.6 m/s^2), VDV at warning (18 m/s^1.75): warning, by the VDV.
    let mut st = AlertState::new();
    let ev: Vec<_> = (0..1000)
        .filter_map(|i| s.step(&mut st, &sample(0.6, 18.0), i))
        .collect();
    assert_eq!(
        ev,
        vec![AlertEvent::Level {
            from: Level::Normal,
            to: Level::Warning,
            criterion: by_vdv(18.0),
            at_sample: 249
        }]
    );
    // Both at alarm: the running rms is named.
    let mut st = AlertState::new();
    let ev: Vec<_> = (0..1000)
        .filter_map(|i| s.step(&mut st, &sample(1.5, 22.0), i))
        .collect();
    assert_eq!(ev.len(), 1);
    assert_eq!(ev[0].criterion(), Some(by_rms(1.5)));
    assert_eq!(by_vdv(18.0).name(), "vdv");
    assert_eq!(by_rms(1.5).unit(), "m/s^2");
}

#[test]
fn alert_configurations_that_make_no_sense_are_refused() {
    let bad = |f: fn(&mut AlertConfig)| {
        let mut c = AlertConfig::DEFAULT;
        f(&mut c);
        AlertSettings::new(c, rate(FS)).unwrap_err()
    };
    assert_eq!(
        bad(|c| c.running_rms_m_s2 = [0.8, 0.5, 1.25]),
        AlertError::Thresholds
    );
    assert_eq!(bad(|c| c.vdv_m_s175[1] = f32::NAN), AlertError::Thresholds);
    assert_eq!(bad(|c| c.running_rms_m_s2[0] = 0.0), AlertError::Thresholds);
    assert_eq!(bad(|c| c.hysteresis = 1.0), AlertError::Hysteresis);
    assert_eq!(bad(|c| c.raise_dwell_s = -1.0), AlertError::Time);
    assert_eq!(bad(|c| c.clear_dwell_s = f32::INFINITY), AlertError::Time);
    let mut s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    assert_eq!(s.validate(rate(FS)), Ok(()));
    // Dwell times count samples: settings built for one rate are refused at another.
    assert!(s.validate(rate(2.0 * FS)).is_err());
    s.raise_ms_m2_s4[0] = 0.0;
    assert!(s.validate(rate(FS)).is_err());
    let mut c = SensorCheckConfig::DEFAULT;
    c.full_scale_m_s2 = -1.0;
    assert_eq!(
        SensorCheckSettings::new(c, rate(FS)),
        Err(AlertError::FullScale)
    );
}

#[test]
fn alert_settings_survive_a_postcard_round_trip() {
    let s = AlertSettings::new(AlertConfig::DEFAULT, rate(FS)).unwrap();
    let mut buf = [0u8; 256];
    let bytes = postcard::to_slice(&s, &mut buf).unwrap();
    assert_eq!(postcard::from_bytes::<AlertSettings>(bytes).unwrap(), s);
    let c = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let bytes = postcard::to_slice(&c, &mut buf).unwrap();
    assert_eq!(
        postcard::from_bytes::<SensorCheckSettings>(bytes).unwrap(),
        c
    );
}

// ---- sensor faults ----

/// A noisy but healthy sample: every axis changes every sample.
fn healthy(i: u32) -> [f32; 3] {
    let t = i as f32 * 0.01;
    [0.1 * t.sin(), 0.2 * t.cos(), 9.81 + 0.05 * (3.0 * t).sin()]
}

fn run_sensor(
    s: &SensorCheckSettings,
    st: &mut SensorCheckState,
    indices: impl IntoIterator<Item = u32>,
    x: impl Fn(u32) -> [f32; 3],
) -> Vec<AlertEvent> {
    indices
        .into_iter()
        .flat_map(|i| s.step(st, x(i), i))
        .collect()
}

#[test]
fn a_healthy_stream_raises_no_fault() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = SensorCheckState::new();
    assert!(run_sensor(&s, &mut st, 0..10_000, healthy).is_empty());
}

#[test]
fn a_nan_sample_raises_non_finite_and_clears_after_a_second_of_finite_samples() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = SensorCheckState::new();
    let ev = run_sensor(&s, &mut st, 0..2000, |i| {
        let mut x = healthy(i);
        if i == 100 {
            x[1] = f32::NAN;
        }
        x
    });
    assert_eq!(
        ev,
        vec![
            AlertEvent::Fault {
                fault: SensorFault::NonFinite,
                active: true,
                at_sample: 100
            },
            AlertEvent::Fault {
                fault: SensorFault::NonFinite,
                active: false,
                at_sample: 600
            },
        ]
    );
}

#[test]
fn an_infinite_sample_is_non_finite_and_a_full_scale_sample_is_saturation() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let fs = SensorCheckConfig::DEFAULT.full_scale_m_s2;
    let mut st = SensorCheckState::new();
    let ev = run_sensor(&s, &mut st, 0..300, |i| {
        let mut x = healthy(i);
        if i == 10 {
            x[0] = f32::NEG_INFINITY;
        }
        if i == 20 {
            x[2] = -fs;
        }
        x
    });
    assert_eq!(
        ev,
        vec![
            AlertEvent::Fault {
                fault: SensorFault::NonFinite,
                active: true,
                at_sample: 10
            },
            AlertEvent::Fault {
                fault: SensorFault::Saturated,
                active: true,
                at_sample: 20
            },
        ]
    );
    // The non-finite sample at 10 has not been cleared yet (that takes a second).
    assert_eq!(st.active(), SensorFault::NonFinite | SensorFault::Saturated);
}

#[test]
fn an_axis_repeating_the_same_value_for_a_second_is_stuck_until_it_moves() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = SensorCheckState::new();
    let ev = run_sensor(&s, &mut st, 0..3000, |i| {
        let mut x = healthy(i);
        if (1000..1800).contains(&i) {
            x[2] = 9.81;
        }
        x
    });
    // 800 identical samples at 500 Hz: 1.6 s; stuck after 500 repeats (1000 is the first value).
    assert_eq!(
        ev,
        vec![
            AlertEvent::Fault {
                fault: SensorFault::Stuck,
                active: true,
                at_sample: 1500
            },
            AlertEvent::Fault {
                fault: SensorFault::Stuck,
                active: false,
                at_sample: 2299
            },
        ]
    );
}

#[test]
fn a_skipped_or_repeated_sample_index_raises_an_index_gap() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = SensorCheckState::new();
    let indices = (0..100).chain(103..200).chain(199..1000);
    let ev = run_sensor(&s, &mut st, indices, healthy);
    assert_eq!(
        ev,
        vec![
            AlertEvent::Fault {
                fault: SensorFault::IndexGap,
                active: true,
                at_sample: 103
            },
            AlertEvent::Fault {
                fault: SensorFault::IndexGap,
                active: false,
                at_sample: 699
            },
        ]
    );
}

#[test]
fn the_sample_index_wrapping_past_u32_max_is_not_a_gap() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let mut st = SensorCheckState::new();
    let indices = (u32::MAX - 10..=u32::MAX).chain(0..10);
    assert!(run_sensor(&s, &mut st, indices, healthy).is_empty());
}

#[test]
fn a_block_of_32_samples_gives_the_same_events_and_state_as_32_single_steps() {
    let mut cfg = AlertConfig::DEFAULT;
    cfg.raise_dwell_s = 0.02;
    cfg.clear_dwell_s = 0.1;
    let s = AlertSettings::new(cfg, rate(FS)).unwrap();
    // A running rms that wanders through every level, with invalid stretches and a VDV
    // that creeps up past its thresholds.
    let rms = |i: u32| {
        let t = i as f32 / FS;
        0.9 + 0.8 * (0.7 * t).sin() + 0.3 * (5.3 * t).sin()
    };
    let sample = |i: u32| ExposureSample {
        running_ms_m2_s4: rms(i) * rms(i),
        vdv4_m4_s7: (i as f32 * 0.0007).powi(4),
        valid: !(3000..3100).contains(&i),
        ..ExposureSample::default()
    };
    let (mut one, mut block) = (AlertState::new(), AlertState::new());
    let (mut ev_one, mut ev_block) = (Vec::new(), Vec::new());
    for b in 0..400u32 {
        let xs: [ExposureSample; 32] = core::array::from_fn(|n| sample(32 * b + n as u32));
        s.step_block(&mut block, &xs, 32 * b, |e| ev_block.push(e));
        for (n, x) in xs.iter().enumerate() {
            ev_one.extend(s.step(&mut one, x, 32 * b + n as u32));
        }
        assert_eq!(one, block, "block {b}");
    }
    assert!(ev_one.len() > 10, "{ev_one:?}");
    assert_eq!(ev_one, ev_block);
}

#[test]
fn a_sensor_block_of_32_samples_gives_the_same_events_and_state_as_32_single_steps() {
    let s = SensorCheckSettings::new(SensorCheckConfig::DEFAULT, rate(FS)).unwrap();
    let fs = SensorCheckConfig::DEFAULT.full_scale_m_s2;
    // Healthy noise with a NaN, a saturation, a stuck stretch and index gaps.
    let x = |i: u32| {
        let mut x = healthy(i);
        match i {
            700 => x[0] = f32::NAN,
            2000..=2004 => x[1] = fs * 1.1,
            4000..=4700 => x[2] = 9.81,
            _ => {}
        }
        x
    };
    let index = |i: u32| {
        if i < 6000 {
            i
        } else if i < 9000 {
            i + 3
        } else {
            i + 2
        }
    };
    let (mut one, mut block) = (SensorCheckState::new(), SensorCheckState::new());
    let (mut ev_one, mut ev_block) = (Vec::new(), Vec::new());
    for b in 0..400u32 {
        let xs: [[f32; 3]; 32] = core::array::from_fn(|n| x(32 * b + n as u32));
        let ix: [u32; 32] = core::array::from_fn(|n| index(32 * b + n as u32));
        s.step_block(&mut block, &xs, &ix, |e| ev_block.push(e));
        for n in 0..32 {
            ev_one.extend(s.step(&mut one, xs[n], ix[n]));
        }
        assert_eq!(one, block, "block {b}");
    }
    assert_eq!(ev_one.len(), 10, "{ev_one:?}");
    assert_eq!(ev_one, ev_block);
}

#[test]
fn fault_flags_are_one_byte_with_bit_n_for_the_nth_fault_and_other_bits_do_not_decode() {
    for byte in 0u8..=255 {
        let decoded = postcard::from_bytes::<FaultFlags>(&[byte]);
        if byte >= 1 << SensorFault::ALL.len() {
            assert!(decoded.is_err(), "{byte:#010b} decoded");
            continue;
        }
        let flags = decoded.unwrap();
        for (n, fault) in SensorFault::ALL.into_iter().enumerate() {
            assert_eq!(flags.contains(fault), byte & (1 << n) != 0, "{byte:#06b}");
        }
        assert_eq!(flags.as_repr(), byte);
        let mut buf = [0u8; 4];
        assert_eq!(postcard::to_slice(&flags, &mut buf).unwrap(), [byte]);
        let listed: Vec<SensorFault> = flags.iter().collect();
        let expected: Vec<SensorFault> = SensorFault::ALL
            .into_iter()
            .filter(|f| flags.contains(*f))
            .collect();
        assert_eq!(listed, expected, "iteration in bit order");
    }
}
