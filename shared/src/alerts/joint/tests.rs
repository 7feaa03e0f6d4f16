//! Host tests of the joint-motion alert state machine.

use super::*;

extern crate std;
use std::vec::Vec;

fn rate(hz: f32) -> SampleRate {
    SampleRate::new(hz).expect("a supported rate")
}

/// Thresholds for output 0 (packed order), the others unset.
fn config(rms: f32, excursion: f32) -> JointAlertConfig {
    let mut c = JointAlertConfig::NONE;
    c.running_rms_m_or_rad[0] = rms;
    c.excursion_m_or_rad[0] = excursion;
    c
}

/// Runs readings of output 0's running rms (`rms[i]`, m) and largest excursion (the
/// running maximum of `rms`, for simplicity), returns `(reading, criterion, raised)`.
fn run(s: &JointAlertSettings, rms: &[f32]) -> Vec<(usize, JointCriterion, bool)> {
    let mut state = JointAlertState::new();
    let mut events = Vec::new();
    let mut peak = 0.0f32;
    for (i, &r) in rms.iter().enumerate() {
        peak = peak.max(r);
        s.step(&mut state, &[r * r], &[peak], |k, c, raised| {
            assert_eq!(k, 0);
            events.push((i, c, raised));
        });
    }
    events
}

#[test]
fn none_configured_watches_nothing_and_sends_nothing() {
    let s = JointAlertSettings::new(JointAlertConfig::NONE, rate(500.0), 5, 10).unwrap();
    assert!(!s.watches_any());
    assert!(run(&s, &[1.0; 100]).is_empty());
}

#[test]
fn the_dwell_is_counted_in_readings_of_the_joints() {
    let mut c = config(0.003, 0.0);
    c.raise_dwell_s = 0.5;
    c.clear_dwell_s = 5.0;
    // Every sample at 500 Hz: 250 and 2,500 readings; every 5th: 50 and 500.
    let every = JointAlertSettings::new(c, rate(500.0), 1, 10).unwrap();
    assert_eq!(
        (every.raise_dwell_readings, every.clear_dwell_readings),
        (250, 2500)
    );
    let fifth = JointAlertSettings::new(c, rate(500.0), 5, 10).unwrap();
    assert_eq!(
        (fifth.raise_dwell_readings, fifth.clear_dwell_readings),
        (50, 500)
    );
    // Above the threshold from reading 10 on: raised at the 50th reading above it.
    let mut rms = std::vec![0.001f32; 10];
    rms.extend([0.004; 100]);
    let events = run(&fifth, &rms);
    assert_eq!(events.len(), 1);
    assert_eq!(events[0].0, 10 + 50 - 1);
    assert!(events[0].2);
    assert_eq!(
        events[0].1,
        JointCriterion::RunningRms {
            value_m_or_rad: (0.004f32 * 0.004).sqrt()
        }
    );
}

#[test]
fn a_dip_restarts_the_raise_dwell() {
    let mut c = config(0.003, 0.0);
    c.raise_dwell_s = 0.05; // 5 readings at 100 Hz
    let s = JointAlertSettings::new(c, rate(500.0), 5, 10).unwrap();
    assert_eq!(s.raise_dwell_readings, 5);
    let rms = [
        0.004, 0.004, 0.004, 0.004, 0.001, 0.004, 0.004, 0.004, 0.004, 0.004,
    ];
    let events = run(&s, &rms);
    assert_eq!(events.iter().map(|e| e.0).collect::<Vec<_>>(), [9]);
}

#[test]
fn an_alert_clears_only_below_the_hysteresis_band_for_the_clear_dwell() {
    let mut c = config(0.002, 0.0);
    c.hysteresis = 0.25; // clears below 1.5 mm
    c.raise_dwell_s = 0.0; // one reading
    c.clear_dwell_s = 0.03; // 3 readings at 100 Hz
    let s = JointAlertSettings::new(c, rate(500.0), 5, 10).unwrap();
    assert_eq!((s.raise_dwell_readings, s.clear_dwell_readings), (1, 3));
    // Raised at once; 1.6 mm (below the threshold, inside the band) holds it for good;
    // 1.4 mm for two readings does not clear it, for three does.
    let rms = [
        0.0025, 0.0016, 0.0016, 0.0016, 0.0016, 0.0014, 0.0014, 0.0016, 0.0014, 0.0014, 0.0014,
    ];
    let events = run(&s, &rms);
    let edges: Vec<(usize, bool)> = events.iter().map(|e| (e.0, e.2)).collect();
    assert_eq!(edges, [(0, true), (10, false)]);
    assert_eq!(
        events[1].1,
        JointCriterion::RunningRms {
            value_m_or_rad: (0.0014f32 * 0.0014).sqrt()
        }
    );
}

#[test]
fn an_excursion_alert_is_raised_once_and_stays() {
    let s = JointAlertSettings::new(config(0.0, 0.005), rate(500.0), 5, 10).unwrap();
    // At the threshold is not above it; the first reading above raises it, at its value.
    let rms = [0.001, 0.005, 0.0051, 0.002, 0.009, 0.0];
    let events = run(&s, &rms);
    assert_eq!(
        events,
        [(
            2,
            JointCriterion::Excursion {
                value_m_or_rad: 0.0051
            },
            true
        )]
    );
}

#[test]
fn each_output_is_watched_on_its_own() {
    let mut c = JointAlertConfig::NONE;
    c.excursion_m_or_rad[3] = 0.01;
    c.running_rms_m_or_rad[7] = 0.02;
    c.raise_dwell_s = 0.0;
    let s = JointAlertSettings::new(c, rate(500.0), 5, 10).unwrap();
    let mut state = JointAlertState::new();
    let mut ms = [0.0f32; 10];
    let mut peak = [0.0f32; 10];
    // Output 0 far above what outputs 3 and 7 are set to: nothing.
    ms[0] = 1.0;
    peak[0] = 1.0;
    let mut events = Vec::new();
    s.step(&mut state, &ms, &peak, |k, c, r| {
        events.push((k, c.name(), r))
    });
    assert!(events.is_empty());
    peak[3] = 0.011;
    ms[7] = 0.0004; // exactly at 0.02^2: raised
    s.step(&mut state, &ms, &peak, |k, c, r| {
        events.push((k, c.name(), r))
    });
    assert_eq!(events, [(7, "running-rms", true), (3, "excursion", true)]);
    assert_eq!(state.rms_raised(), 1 << 7);
    assert_eq!(state.excursion_raised(), 1 << 3);
}

#[test]
fn bad_thresholds_hysteresis_and_times_are_refused() {
    let fs = rate(500.0);
    let refused = |c: JointAlertConfig, read: usize| JointAlertSettings::new(c, fs, 5, read);
    for t in [-0.001, f32::NAN, f32::INFINITY] {
        assert_eq!(
            refused(config(t, 0.0), 10),
            Err(AlertError::JointThresholds)
        );
        assert_eq!(
            refused(config(0.0, t), 10),
            Err(AlertError::JointThresholds)
        );
    }
    // A threshold past the outputs read.
    let mut c = JointAlertConfig::NONE;
    c.excursion_m_or_rad[4] = 0.01;
    assert!(refused(c, 5).is_ok());
    assert_eq!(refused(c, 4), Err(AlertError::JointThresholds));
    let mut c = config(0.001, 0.0);
    c.hysteresis = 0.95;
    assert_eq!(refused(c, 10), Err(AlertError::Hysteresis));
    let mut c = config(0.001, 0.0);
    c.clear_dwell_s = 601.0;
    assert_eq!(refused(c, 10), Err(AlertError::Time));
}

#[test]
fn stored_settings_that_do_not_match_their_config_are_refused() {
    let fs = rate(500.0);
    let s = JointAlertSettings::new(config(0.001, 0.002), fs, 5, 10).unwrap();
    assert_eq!(s.validate(fs, 5, 10), Ok(()));
    // Built for another reading interval.
    assert_eq!(s.validate(fs, 1, 10), Err(AlertError::JointThresholds));
    let mut t = s;
    t.clear_factor *= 0.5;
    assert_eq!(t.validate(fs, 5, 10), Err(AlertError::JointThresholds));
    let mut t = s;
    t.rms_watched = 0;
    assert_eq!(t.validate(fs, 5, 10), Err(AlertError::JointThresholds));
}
