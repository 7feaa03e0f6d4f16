//! The demo's route: where a [`DemoRide`] drives, as a phone's GNSS would log it (a fix
//! a second), so that the demo's report has a map. A winding road north-east of a made-up
//! start; the ambulance keeps [`PAVED_SPEED_M_S`] on paved road and slows to
//! [`ROUGH_SPEED_M_S`] on the rough stretch, over [`SPEED_CHANGE_S`], so the rough
//! road is a shorter, slower stretch of the map. The accelerations do not depend on it:
//! the track only places them.

use std::f64::consts::PI;

use crate::demo::demo_ride::{DemoProfile, DemoRide};
use crate::ride::position::{EARTH_RADIUS_M, Fix};

/// Where the route starts, degrees (latitude, longitude): open country, nowhere real in
/// particular.
pub const START_DEG: (f64, f64) = (47.95, 11.30);
/// Speed on paved road, m/s (79 km/h).
pub const PAVED_SPEED_M_S: f64 = 22.0;
/// Speed on the rough road, m/s (32 km/h).
pub const ROUGH_SPEED_M_S: f64 = 9.0;
/// A helicopter's cruise, m/s.
pub const HELICOPTER_SPEED_M_S: f64 = 60.0;
/// Time a change of speed takes, s.
pub const SPEED_CHANGE_S: f64 = 6.0;
/// Fixes per second.
pub const FIX_RATE_HZ: f64 = 1.0;

/// The speed on a stretch labelled `label`, m/s.
fn stretch_speed_m_s(label: &str) -> f64 {
    match label {
        "rough road" => ROUGH_SPEED_M_S,
        "helicopter" => HELICOPTER_SPEED_M_S,
        _ => PAVED_SPEED_M_S,
    }
}

/// The speed at `t_s`: each stretch's, eased from the previous one's over
/// [`SPEED_CHANGE_S`] after the join (raised cosine).
fn speed_at(ride: &DemoRide, t_s: f64) -> f64 {
    let mut speed = ride
        .segments
        .first()
        .map_or(PAVED_SPEED_M_S, |s| stretch_speed_m_s(&s.label));
    for s in &ride.segments {
        if t_s >= s.start_s {
            let target = stretch_speed_m_s(&s.label);
            let w = ((t_s - s.start_s) / SPEED_CHANGE_S).clamp(0.0, 1.0);
            speed += (target - speed) * (0.5 - 0.5 * (PI * w).cos());
        }
    }
    speed
}

/// The fixes of `ride`'s route from [`START_DEG`]: [`track_from`].
pub fn track(ride: &DemoRide) -> Vec<Fix> {
    track_from(ride, START_DEG)
}

/// The fixes of `ride`'s route from `start_deg` (latitude, longitude) to its end; none
/// for the laboratory's input, which goes nowhere.
pub fn track_from(ride: &DemoRide, start_deg: (f64, f64)) -> Vec<Fix> {
    if ride.profile == DemoProfile::Lab {
        return Vec::new();
    }
    let end_s = ride.duration_s();
    let step_s = 0.05;
    let per_fix = (1.0 / (FIX_RATE_HZ * step_s)).round() as usize;
    let (mut north_m, mut east_m) = (0.0f64, 0.0f64);
    let (lat0, lon0) = start_deg;
    let m_per_deg = EARTH_RADIUS_M * PI / 180.0;
    let mut fixes = Vec::new();
    let mut k = 0usize;
    loop {
        let t_s = k as f64 * step_s;
        let speed = speed_at(ride, t_s);
        if k % per_fix == 0 {
            fixes.push(Fix {
                t_s,
                lat_deg: lat0 + north_m / m_per_deg,
                lon_deg: lon0 + east_m / (m_per_deg * lat0.to_radians().cos()),
                speed_m_s: Some(speed),
                accuracy_m: Some(5.0),
            });
        }
        if t_s >= end_s {
            break;
        }
        // A winding road: the heading swings about north-east.
        let heading = (50.0 + 40.0 * (2.0 * PI * t_s / 80.0).sin()).to_radians();
        north_m += speed * step_s * heading.cos();
        east_m += speed * step_s * heading.sin();
        k += 1;
    }
    fixes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::demo_ride::make;
    use crate::ride::position::Track;

    #[test]
    fn the_road_trip_slows_on_the_rough_road_and_covers_its_distance() {
        let ride = make(DemoProfile::RoadTrip, 60.0, 500.0, 1).unwrap();
        let track = Track::new(track(&ride), "demo").unwrap();
        // Paved at 22 m/s for about 24 s with 6 s changes, rough at 9 m/s: the distance
        // is the speed's integral, the track's length within 1 %.
        let integral: f64 = (0..60_000)
            .map(|k| speed_at(&ride, k as f64 * 0.001) * 0.001)
            .sum();
        assert!((track.length_m() / integral - 1.0).abs() < 0.01);
        let rough = &ride.segments[1];
        let middle = track.at((rough.start_s + rough.end_s) / 2.0).unwrap();
        assert!((middle.speed_m_s - ROUGH_SPEED_M_S).abs() < 0.1);
        assert!((track.at(5.0).unwrap().speed_m_s - PAVED_SPEED_M_S).abs() < 0.1);
        assert!(track.fixes().last().unwrap().t_s >= 60.0);
        assert!(super::track(&make(DemoProfile::Lab, 10.0, 500.0, 1).unwrap()).is_empty());
    }
}
