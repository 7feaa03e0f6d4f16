//! Where a ride happened: a track of position fixes (1-10 Hz from a phone's GNSS, a GPX
//! file, or latitude/longitude columns beside the acceleration), checked, placed in a
//! local metric frame and interpolated to the ride's samples
//! (`docs/exposure.md#positions-and-road-segments`).
//!
//! - A fix is used for a sample only when it is at most [`MAX_FIX_AGE_S`] from it: a
//!   sample between two fixes further apart than that, or outside the track, has no
//!   position (never an extrapolated one).
//! - A fix that implies a speed above [`MAX_PLAUSIBLE_SPEED_M_S`] from the last fix kept
//!   (a jump of hundreds of km in a second) is excluded and counted, as is a fix whose
//!   time is not after the last kept one's; a track that is mostly jumps is refused.
//! - A fix whose horizontal accuracy is worse than [`POOR_ACCURACY_M`] is used and
//!   counted, so the account says how far the map can be trusted.
//! - Distances are great-circle (haversine, on the mean Earth radius) between fixes;
//!   the map's frame is equirectangular about the track's centre, whose scale error is
//!   below 0.1 % within about 60 km of the centre (a ride's scale). Two formulas of a few
//!   lines each: the `geo` crate would serve, but brings a dozen crates to a build that
//!   needs none of its other algorithms.
//!
//! Memory: one [`Fix`] and one cumulative distance per fix, at most [`MAX_FIXES`] (more
//! than a day at 10 Hz).

use serde::Serialize;

/// Mean Earth radius (IUGG), m.
pub const EARTH_RADIUS_M: f64 = 6_371_008.8;
/// Oldest a fix may be (before or after a sample) and still place it, s.
pub const MAX_FIX_AGE_S: f64 = 5.0;
/// Fastest a litter travels between two fixes (a helicopter's cruise is about 80 m/s),
/// m/s: a faster step is a jump of the receiver, excluded.
pub const MAX_PLAUSIBLE_SPEED_M_S: f64 = 150.0;
/// Horizontal accuracy worse than this is flagged, m (a phone in a vehicle reports 3 to
/// 15 m; beyond 30 m a fix can sit on the next road).
pub const POOR_ACCURACY_M: f64 = 30.0;
/// Most fixes a track holds (24 h at 10 Hz, and some).
pub const MAX_FIXES: usize = 1 << 20;

/// One position fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fix {
    /// Time on the ride's clock, s.
    pub t_s: f64,
    /// Latitude, degrees north.
    pub lat_deg: f64,
    /// Longitude, degrees east.
    pub lon_deg: f64,
    /// Ground speed the receiver reported, m/s.
    pub speed_m_s: Option<f64>,
    /// Horizontal accuracy the receiver reported, m.
    pub accuracy_m: Option<f64>,
}

/// Why a latitude or longitude cannot be a position: `None` when both can.
pub fn out_of_range(lat_deg: f64, lon_deg: f64) -> Option<String> {
    if !(lat_deg.is_finite() && (-90.0..=90.0).contains(&lat_deg)) {
        return Some(format!(
            "expected a latitude within -90..90 degrees, found {lat_deg}"
        ));
    }
    if !(lon_deg.is_finite() && (-180.0..=180.0).contains(&lon_deg)) {
        return Some(format!(
            "expected a longitude within -180..180 degrees, found {lon_deg}"
        ));
    }
    None
}

/// Great-circle distance between two positions (degrees), m.
pub fn haversine_m(lat1_deg: f64, lon1_deg: f64, lat2_deg: f64, lon2_deg: f64) -> f64 {
    let (p1, p2) = (lat1_deg.to_radians(), lat2_deg.to_radians());
    let dp = p2 - p1;
    let dl = (lon2_deg - lon1_deg).to_radians();
    let h = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * EARTH_RADIUS_M * h.sqrt().min(1.0).asin()
}

/// A position east and north of `centre_deg` (latitude, longitude), m: equirectangular,
/// the scale true along the centre's parallel and every meridian.
pub fn project_m(centre_deg: (f64, f64), lat_deg: f64, lon_deg: f64) -> [f64; 2] {
    let (lat0, lon0) = centre_deg;
    [
        EARTH_RADIUS_M * (lon_deg - lon0).to_radians() * lat0.to_radians().cos(),
        EARTH_RADIUS_M * (lat_deg - lat0).to_radians(),
    ]
}

/// The centre of the box around `points` (latitude, longitude), degrees.
pub fn centre_deg(points: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (lat, lon) in points {
        lo = [lo[0].min(lat), lo[1].min(lon)];
        hi = [hi[0].max(lat), hi[1].max(lon)];
    }
    ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0)
}

/// What the checks made of a track's fixes.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TrackAccount {
    /// Where the fixes came from (`GPX`, an app's location file, `--columns`).
    pub source: String,
    /// Fixes read.
    pub fixes: usize,
    /// Fixes excluded: a jump faster than [`MAX_PLAUSIBLE_SPEED_M_S`] from the last kept.
    #[serde(rename = "jump_excluded_fixes")]
    pub jumps_excluded: usize,
    /// Fixes excluded: time not after the last kept fix's.
    #[serde(rename = "out_of_order_fixes")]
    pub out_of_order: usize,
    /// Kept fixes whose accuracy is worse than [`POOR_ACCURACY_M`].
    #[serde(rename = "poor_accuracy_fixes")]
    pub poor_accuracy: usize,
}

/// A checked track in time order, with its cumulative distance and its map frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    fixes: Vec<Fix>,
    /// Distance from the first fix to each, m.
    along_m: Vec<f64>,
    /// Centre of the map frame, degrees.
    centre_deg: (f64, f64),
    account: TrackAccount,
}

/// A sample's place on the track.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Place {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Distance along the track from its first fix, m.
    pub along_m: f64,
    /// Ground speed: the receiver's where it gave one, else the track's, m/s.
    pub speed_m_s: f64,
}

impl Track {
    /// Checks `fixes` (in the order read; each within range, which the readers check
    /// with the file and line): excludes and counts jumps and fixes out of order, counts
    /// poor accuracy. Refuses a track with fewer than 2 fixes kept, more than
    /// [`MAX_FIXES`], or as many jumps as fixes kept.
    pub fn new(fixes: impl IntoIterator<Item = Fix>, source: &str) -> Result<Self, String> {
        let mut account = TrackAccount {
            source: source.to_string(),
            ..TrackAccount::default()
        };
        let mut kept: Vec<Fix> = Vec::new();
        let mut along_m: Vec<f64> = Vec::new();
        for fix in fixes {
            account.fixes += 1;
            if account.fixes > MAX_FIXES {
                return Err(format!(
                    "{source}: more than {MAX_FIXES} position fixes: expected a ride's track \
                     (at most a day at 10 Hz); cut it to the ride"
                ));
            }
            let Some(last) = kept.last() else {
                kept.push(fix);
                along_m.push(0.0);
                continue;
            };
            let dt = fix.t_s - last.t_s;
            if dt.is_nan() || dt <= 0.0 {
                account.out_of_order += 1;
                continue;
            }
            let step = haversine_m(last.lat_deg, last.lon_deg, fix.lat_deg, fix.lon_deg);
            if step / dt > MAX_PLAUSIBLE_SPEED_M_S {
                account.jumps_excluded += 1;
                continue;
            }
            let total = along_m.last().copied().unwrap_or(0.0) + step;
            kept.push(fix);
            along_m.push(total);
        }
        if kept.len() < 2 {
            return Err(format!(
                "{source}: expected at least 2 position fixes in time order, found {} of {} read",
                kept.len(),
                account.fixes
            ));
        }
        if account.jumps_excluded > 0 && account.jumps_excluded >= kept.len() {
            return Err(format!(
                "{source}: {} of {} position fixes jump faster than {MAX_PLAUSIBLE_SPEED_M_S} m/s \
                 from the last plausible one: expected a track that follows a road",
                account.jumps_excluded, account.fixes
            ));
        }
        account.poor_accuracy = kept
            .iter()
            .filter(|f| f.accuracy_m.is_some_and(|a| a > POOR_ACCURACY_M))
            .count();
        let centre_deg = centre_deg(kept.iter().map(|f| (f.lat_deg, f.lon_deg)));
        Ok(Self {
            fixes: kept,
            along_m,
            centre_deg,
            account,
        })
    }

    /// The same track with every time moved by `offset_s` (a track on another clock).
    pub fn shifted(mut self, offset_s: f64) -> Self {
        for f in &mut self.fixes {
            f.t_s += offset_s;
        }
        self
    }

    /// The fixes kept.
    pub fn fixes(&self) -> &[Fix] {
        &self.fixes
    }

    /// What the checks found.
    pub fn account(&self) -> &TrackAccount {
        &self.account
    }

    /// The track's length, m.
    pub fn length_m(&self) -> f64 {
        self.along_m.last().copied().unwrap_or(0.0)
    }

    /// First and last fix times, s.
    pub fn span_s(&self) -> (f64, f64) {
        (self.fixes[0].t_s, self.fixes[self.fixes.len() - 1].t_s)
    }

    /// Whether the track covers some of `start_s..end_s`.
    pub fn overlaps(&self, start_s: f64, end_s: f64) -> bool {
        let (first, last) = self.span_s();
        first <= end_s && last >= start_s
    }

    /// A position in the map frame: east and north of the track's centre, m.
    pub fn project(&self, lat_deg: f64, lon_deg: f64) -> [f64; 2] {
        project_m(self.centre_deg, lat_deg, lon_deg)
    }

    /// Where the track was at `t_s`: interpolated between the fixes around it when
    /// both are within [`MAX_FIX_AGE_S`] (or at a fix's own time); `None` otherwise.
    pub fn at(&self, t_s: f64) -> Option<Place> {
        let after = self.fixes.partition_point(|f| f.t_s < t_s);
        if after == self.fixes.len() {
            return None;
        }
        let b = &self.fixes[after];
        if b.t_s == t_s {
            let speed = match after {
                0 => self.speed_between(0, 1),
                _ => self.speed_between(after - 1, after),
            };
            return Some(Place {
                lat_deg: b.lat_deg,
                lon_deg: b.lon_deg,
                along_m: self.along_m[after],
                speed_m_s: b.speed_m_s.unwrap_or(speed),
            });
        }
        let before = after.checked_sub(1)?;
        let a = &self.fixes[before];
        if t_s - a.t_s > MAX_FIX_AGE_S || b.t_s - t_s > MAX_FIX_AGE_S {
            return None;
        }
        let w = (t_s - a.t_s) / (b.t_s - a.t_s);
        let mix = |x: f64, y: f64| x + w * (y - x);
        let track_speed = self.speed_between(before, after);
        let speed_m_s = match (a.speed_m_s, b.speed_m_s) {
            (Some(x), Some(y)) => mix(x, y),
            _ => track_speed,
        };
        Some(Place {
            lat_deg: mix(a.lat_deg, b.lat_deg),
            lon_deg: mix(a.lon_deg, b.lon_deg),
            along_m: mix(self.along_m[before], self.along_m[after]),
            speed_m_s,
        })
    }

    /// The track's speed between fixes `i < j`, m/s.
    fn speed_between(&self, i: usize, j: usize) -> f64 {
        let dt = self.fixes[j].t_s - self.fixes[i].t_s;
        if dt > 0.0 {
            (self.along_m[j] - self.along_m[i]) / dt
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fix(t_s: f64, lat_deg: f64, lon_deg: f64) -> Fix {
        Fix {
            t_s,
            lat_deg,
            lon_deg,
            speed_m_s: None,
            accuracy_m: None,
        }
    }

    /// Metres per degree of latitude on the mean sphere.
    fn m_per_deg() -> f64 {
        EARTH_RADIUS_M * std::f64::consts::PI / 180.0
    }

    #[test]
    fn a_straight_line_has_its_closed_form_length_bearing_and_speed() {
        // Due north-east from 48 N, 11 E at 15 m/s for 200 s, fixes at 1 Hz: 3000 m.
        let (lat0, lon0) = (48.0f64, 11.0f64);
        let (v, bearing) = (15.0, 45f64.to_radians());
        let fixes = (0..=200).map(|k| {
            let d = v * k as f64;
            let lat = lat0 + d * bearing.cos() / m_per_deg();
            let lon = lon0 + d * bearing.sin() / (m_per_deg() * lat0.to_radians().cos());
            fix(k as f64, lat, lon)
        });
        let track = Track::new(fixes, "test").unwrap();
        assert!(
            (track.length_m() - 3000.0).abs() < 3000.0 * 1e-3,
            "{}",
            track.length_m()
        );
        let place = track.at(100.5).unwrap();
        assert!((place.along_m - 1507.5).abs() < 2.0, "{}", place.along_m);
        assert!((place.speed_m_s - 15.0).abs() < 0.05, "{}", place.speed_m_s);
        // The map frame: the line's bearing and length.
        let [x0, y0] = track.project(track.fixes()[0].lat_deg, track.fixes()[0].lon_deg);
        let last = track.fixes()[200];
        let [x1, y1] = track.project(last.lat_deg, last.lon_deg);
        let (dx, dy) = (x1 - x0, y1 - y0);
        assert!(((dx * dx + dy * dy).sqrt() - 3000.0).abs() < 3.0);
        assert!((dx.atan2(dy) - bearing).abs() < 1e-3);
    }

    #[test]
    fn a_circle_has_its_circumference() {
        // Radius 200 m about 60 N, once round in 120 s, fixes at 10 Hz.
        let (lat0, lon0, r) = (60.0f64, 25.0f64, 200.0);
        let fixes = (0..=1200).map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / 1200.0;
            let lat = lat0 + r * a.cos() / m_per_deg();
            let lon = lon0 + r * a.sin() / (m_per_deg() * lat0.to_radians().cos());
            fix(k as f64 / 10.0, lat, lon)
        });
        let track = Track::new(fixes, "test").unwrap();
        let closed_form = 2.0 * std::f64::consts::PI * r;
        assert!((track.length_m() - closed_form).abs() < closed_form * 1e-3);
        // Every fix at r from the centre in the map frame.
        let [cx, cy] = track.project(lat0, lon0);
        for f in track.fixes() {
            let [x, y] = track.project(f.lat_deg, f.lon_deg);
            assert!((((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - r).abs() < 0.5);
        }
    }

    #[test]
    fn jumps_and_steps_back_are_excluded_and_stale_fixes_not_used() {
        let mut fixes: Vec<Fix> = (0..20)
            .map(|k| fix(k as f64, 50.0, 8.0 + k as f64 * 1e-4))
            .collect();
        // Hundreds of km in a second, then a repeated time.
        fixes.insert(10, fix(9.5, 53.0, 8.0));
        fixes.insert(5, fix(4.0, 50.0, 8.0004));
        // A fix 30 s after the rest: the 30 s between have no position.
        fixes.push(fix(49.0, 50.0, 8.0021));
        let track = Track::new(fixes, "test").unwrap();
        let account = track.account();
        assert_eq!((account.jumps_excluded, account.out_of_order), (1, 1));
        assert_eq!(track.fixes().len(), 21);
        assert!(track.length_m() < 200.0, "{}", track.length_m());
        assert!(track.at(9.5).is_some());
        assert!(track.at(30.0).is_none());
        assert!(track.at(-1.0).is_none() && track.at(50.0).is_none());
        assert!(track.at(46.0).is_none() && track.at(49.0).is_some());
    }

    #[test]
    fn a_track_of_jumps_or_out_of_range_is_refused() {
        let fixes = (0..10).map(|k| fix(k as f64, if k % 2 == 0 { 10.0 } else { 40.0 }, 0.0));
        assert!(Track::new(fixes, "t").unwrap_err().contains("jump faster"));
        assert!(out_of_range(91.0, 0.0).unwrap().contains("latitude"));
        assert!(out_of_range(0.0, -180.5).unwrap().contains("longitude"));
        assert!(out_of_range(f64::NAN, 0.0).is_some());
        assert!(out_of_range(-90.0, 180.0).is_none());
    }
}
