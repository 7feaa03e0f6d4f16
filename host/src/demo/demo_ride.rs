//! The demo's ride: by default a drive that tells the alerts' story within a minute, a
//! smooth paved road, then a rough road with its shocks, then the paved road again; or
//! one of `supine ride`'s profiles throughout.
//!
//! The road trip is made from two rides of [`crate::exposure::ride`] with the same seed: the
//! ambulance (paved road) for the whole duration, and a rough road as long as the middle
//! segment (with the shocks that profile draws for that length), blended in and out with
//! a raised-cosine cross-fade of [`CROSSFADE_S`] so that no step appears at the joins.

use std::f64::consts::PI;

use anyhow::Result;
use serde::Serialize;

use crate::exposure::ride::{Profile, Ride, Shock, generate};

/// Where the rough segment starts, as a fraction of the ride.
pub const ROUGH_START_FRACTION: f64 = 0.2;
/// Where the rough segment ends, as a fraction of the ride (the rest is left for the
/// running rms to fall and the levels to clear after their 5 s dwell).
pub const ROUGH_END_FRACTION: f64 = 0.6;
/// Length of each cross-fade between road surfaces, s.
pub const CROSSFADE_S: f64 = 1.0;

/// What the demo drives over.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum DemoProfile {
    /// Paved road (ambulance), rough road with shocks from 20 % to 60 % of the ride, paved
    /// road again: alerts are raised, then cleared.
    RoadTrip,
    /// Ground ambulance on a paved road throughout.
    Ambulance,
    /// Rough road with potholes and speed bumps throughout.
    RoughRoad,
    /// Helicopter throughout.
    Helicopter,
    /// The laboratory's 0.5-16 Hz random input throughout.
    Lab,
}

impl DemoProfile {
    /// The name the command line uses.
    pub const fn name(self) -> &'static str {
        match self {
            DemoProfile::RoadTrip => "road-trip",
            DemoProfile::Ambulance => "ambulance",
            DemoProfile::RoughRoad => "rough-road",
            DemoProfile::Helicopter => "helicopter",
            DemoProfile::Lab => "lab",
        }
    }

    fn single(self) -> Option<Profile> {
        match self {
            DemoProfile::RoadTrip => None,
            DemoProfile::Ambulance => Some(Profile::Ambulance),
            DemoProfile::RoughRoad => Some(Profile::RoughRoad),
            DemoProfile::Helicopter => Some(Profile::Helicopter),
            DemoProfile::Lab => Some(Profile::Lab),
        }
    }
}

/// A stretch of the ride on one surface.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Segment {
    /// Start, s.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// What it is (`paved road`, `rough road`, ...).
    pub label: String,
}

/// The demo's ride: the samples, the surfaces and the shocks.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoRide {
    /// The profile asked for.
    pub profile: DemoProfile,
    /// The samples (for the road trip, `ride.profile` is the rough segment's).
    pub ride: Ride,
    /// The surfaces, in time order, covering the ride.
    pub segments: Vec<Segment>,
    /// Shocks, with their times in the whole ride, s.
    pub shocks: Vec<Shock>,
}

impl DemoRide {
    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        self.ride.len() as f64 / self.ride.sample_rate_hz
    }

    /// The samples as the device takes them (f32, litter axes).
    pub fn samples(&self) -> Vec<[f32; 3]> {
        self.ride.samples()
    }
}

fn label(profile: Profile) -> &'static str {
    match profile {
        Profile::Ambulance => "paved road",
        Profile::RoughRoad => "rough road",
        Profile::Helicopter => "helicopter",
        Profile::Lab => "laboratory random input",
    }
}

/// Makes the ride of `profile`, `duration_s` long at `sample_rate_hz`, for `seed`.
pub fn make(
    profile: DemoProfile,
    duration_s: f64,
    sample_rate_hz: f64,
    seed: u64,
) -> Result<DemoRide> {
    if let Some(single) = profile.single() {
        let ride = generate(single, duration_s, sample_rate_hz, seed)?;
        let end_s = ride.len() as f64 / sample_rate_hz;
        return Ok(DemoRide {
            profile,
            segments: vec![Segment {
                start_s: 0.0,
                end_s,
                label: label(single).to_string(),
            }],
            shocks: ride.shocks.clone(),
            ride,
        });
    }
    let mut paved = generate(Profile::Ambulance, duration_s, sample_rate_hz, seed)?;
    let n = paved.len();
    let total_s = n as f64 / sample_rate_hz;
    let first = (ROUGH_START_FRACTION * n as f64).round() as usize;
    let last = (ROUGH_END_FRACTION * n as f64).round() as usize;
    let start_s = first as f64 / sample_rate_hz;
    let end_s = last as f64 / sample_rate_hz;
    let rough_len_s = (last - first) as f64 / sample_rate_hz;
    let rough = generate(Profile::RoughRoad, rough_len_s, sample_rate_hz, seed)?;
    let fade = |t_s: f64| -> f64 {
        // Weight of the rough road at `t_s` into its segment.
        let rise = (t_s / CROSSFADE_S).clamp(0.0, 1.0);
        let fall = ((rough_len_s - t_s) / CROSSFADE_S).clamp(0.0, 1.0);
        let w = rise.min(fall);
        0.5 - 0.5 * (PI * w).cos()
    };
    for (k, r) in (first..last.min(n)).zip(0..rough.len()) {
        let w = fade(r as f64 / sample_rate_hz);
        for axis in 0..3 {
            let p = &mut paved.platform_m_s2[axis][k];
            *p = (1.0 - w) * *p + w * rough.platform_m_s2[axis][r];
        }
    }
    let shocks: Vec<Shock> = rough
        .shocks
        .iter()
        .map(|s| Shock {
            time_s: s.time_s + start_s,
            kind: s.kind,
        })
        .collect();
    paved.profile = Profile::RoughRoad;
    paved.shocks = shocks.clone();
    paved.stationary_rms_m_s2 = rough.stationary_rms_m_s2;
    let segment = |a: f64, b: f64, l: &str| Segment {
        start_s: a,
        end_s: b,
        label: l.to_string(),
    };
    Ok(DemoRide {
        profile,
        ride: paved,
        segments: vec![
            segment(0.0, start_s, "paved road"),
            segment(start_s, end_s, "rough road"),
            segment(end_s, total_s, "paved road"),
        ],
        shocks,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rms(x: &[f64]) -> f64 {
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
    }

    #[test]
    fn the_road_trip_is_paved_then_rough_then_paved() {
        let fs = 500.0;
        let trip = make(DemoProfile::RoadTrip, 60.0, fs, 3).expect("ride");
        assert_eq!(trip.ride.len(), 30_000);
        let z = &trip.ride.platform_m_s2[2];
        let s = |a: f64, b: f64| rms(&z[(a * fs) as usize..(b * fs) as usize]);
        // Paved road: the ambulance's 0.3 m/s^2 vertical; rough road: 1 m/s^2 and more
        // with shocks (24 s of rough road: 2.3 shocks on average, all inside the segment).
        let paved = generate(Profile::Ambulance, 60.0, fs, 3).expect("paved");
        assert_eq!(&z[..5000], &paved.platform_m_s2[2][..5000]);
        assert_eq!(&z[19000..], &paved.platform_m_s2[2][19000..]);
        assert!(s(14.0, 34.0) > 0.9, "rough {}", s(14.0, 34.0));
        assert!(s(0.0, 11.0) < 0.4 && s(38.0, 60.0) < 0.4);
        assert!(!trip.shocks.is_empty());
        assert!(trip.shocks.iter().all(|s| (12.0..36.0).contains(&s.time_s)));
        assert_eq!(trip.segments.len(), 3);
        assert_eq!(trip.segments[1].start_s, 12.0);
        assert_eq!(trip.segments[1].end_s, 36.0);
        // No jump at the joins: the cross-fade starts from the paved road's own sample.
        let step = (z[6000] - z[5999]).abs();
        assert!(step < 0.2, "step {step} at the first join");
    }

    #[test]
    fn a_single_profile_is_that_ride_throughout() {
        let demo = make(DemoProfile::Helicopter, 10.0, 500.0, 1).expect("ride");
        let ride = generate(Profile::Helicopter, 10.0, 500.0, 1).expect("ride");
        assert_eq!(demo.ride, ride);
        assert_eq!(demo.segments.len(), 1);
        assert_eq!(demo.segments[0].label, "helicopter");
    }
}
