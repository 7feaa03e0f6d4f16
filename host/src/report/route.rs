//! Where a leg's exposure happened: its samples placed on the ride's track
//! ([`crate::ride::position`]) and gathered into fixed-length road segments, each with
//! the head's weighted rms and VDV contribution, the largest running rms, mean speed and
//! time at each alert level (`docs/exposure.md#positions-and-road-segments`); and the
//! points and events the map draws.
//!
//! Segments are [`SEGMENT_LENGTH_M`] of distance along the track: a segment closes at
//! the first sample at or past its length (so it is longer by at most one sample's
//! travel) and at a sample with no position (a gap in the track); a stop adds time, not
//! distance, to its segment. The contributions come from the head's weighted vector
//! signal, the core's own weighting ([`supine_core::weighting::WeightingSettings::step`]) run on the pipeline's
//! head accelerations: the same f32 samples the device sums, here summed in f64 per
//! segment, over the samples after the warm-up, as the leg's values are. So the segments'
//! energy-equivalent rms, `sqrt(sum rms_i^2 T_i / sum T_i)`, is the leg's rms, and
//! `(sum VDV_i^4)^(1/4)` the leg's VDV, wherever every evaluated sample has a position.
//!
//! Memory: one segment per [`SEGMENT_LENGTH_M`] of the leg's route, and at most about
//! [`MAX_MAP_POINTS`] map points and the listed events' places.

use serde::Serialize;
use supine_core::exposure::ExposureSettings;
use supine_core::model::{JOINT_OUTPUT_COUNT, JointOutput};
use supine_core::weighting::WeightingState;

use crate::report::level_time::TimeAtLevel;
use crate::ride::position::{Place, Track, TrackAccount};

/// Length of a road segment, m: about 2 to 4 s at road speeds, long enough for the
/// 1 s running rms to mean something within it, short enough to name a stretch of road,
/// a speed bump's approach or a bend.
pub const SEGMENT_LENGTH_M: f64 = 50.0;
/// Most worst segments listed.
pub const WORST_SEGMENTS: usize = 5;
/// About how many points of a leg the map draws (more for a track with gaps).
pub const MAX_MAP_POINTS: usize = 2000;
/// Closest two map points are, m.
const MIN_MAP_STEP_M: f64 = 5.0;

/// One road segment.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Segment {
    /// Time of its first sample from the leg's start, s.
    pub start_s: f64,
    /// Time after its last sample from the leg's start, s.
    pub end_s: f64,
    /// Latitude of its midpoint (half its length along the track), degrees.
    pub lat_deg: f64,
    /// Longitude of its midpoint, degrees.
    pub lon_deg: f64,
    /// Distance along the track, m.
    pub length_m: f64,
    /// Mean ground speed over its samples, m/s.
    pub speed_m_s: f64,
    /// The head's weighted vector rms over its evaluated samples, m/s^2.
    pub rms_m_s2: f64,
    /// The head's weighted vector VDV contribution, `(integral a_v^4 dt)^(1/4)` over
    /// its samples, m/s^1.75.
    pub vdv_m_s175: f64,
    /// The largest vector running rms within it, m/s^2.
    pub max_running_rms_m_s2: f64,
    /// Time at each alert level within it, s.
    pub time_at_level_s: TimeAtLevel,
    /// The largest excursion of each neck and lower-back output within it, after the
    /// warm-up, as the leg's joints count them (absent when the model's joints are not
    /// tracked).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub largest_joint_excursions: Option<JointPeaks>,
    /// Its evaluated time (after the warm-up), s: the rms's weight.
    #[serde(skip)]
    pub evaluated_s: f64,
}

/// The largest |value| of each joint output over some samples, in its display unit, in
/// [`JointOutput::ALL`]'s order; written as an object keyed by output and unit
/// (`neck_x_mm`, ..., `low_back_rz_deg`), the units the report's joint tables use.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointPeaks(pub [f64; JOINT_OUTPUT_COUNT]);

impl JointPeaks {
    /// Takes the outputs of one sample (display units).
    fn take(&mut self, outputs: &[f64; JOINT_OUTPUT_COUNT]) {
        for (peak, v) in self.0.iter_mut().zip(outputs) {
            *peak = peak.max(v.abs());
        }
    }
}

impl Serialize for JointPeaks {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap as _;
        let mut map = serializer.serialize_map(Some(JOINT_OUTPUT_COUNT))?;
        for (output, v) in JointOutput::ALL.iter().zip(self.0) {
            let (unit, _) = output.unit().display();
            map.serialize_entry(&format!("{}_{unit}", output.name()), &v)?;
        }
        map.end()
    }
}

/// A point of the map's line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPoint {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// The largest vector running rms since the previous point, m/s^2.
    pub running_rms_m_s2: f64,
    /// Ground speed, m/s.
    pub speed_m_s: f64,
    /// The line is broken before this point (a gap in the track).
    pub breaks: bool,
}

/// An alert event at its place.
#[derive(Clone, Debug, PartialEq)]
pub struct PlacedEvent {
    /// Time from the leg's start, s.
    pub leg_time_s: f64,
    /// What happened (`normal -> warning`).
    pub event: String,
    /// The level it raised to or lowered to (0-3), or `None` for a fault or joint alert.
    pub level: Option<u8>,
    /// It raises an alert.
    pub raise: bool,
    /// Where, degrees.
    pub lat_deg: f64,
    /// Where, degrees.
    pub lon_deg: f64,
}

/// A leg's route: its segments, the worst of them, and what the map draws.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Route {
    /// Position fixes in the track.
    pub fixes: usize,
    /// Distance travelled while placed, m.
    pub length_m: f64,
    /// The road segments in order.
    pub segments: Vec<Segment>,
    /// The [`WORST_SEGMENTS`] segments of highest rms, worst first.
    pub worst_segments: Vec<Segment>,
    /// The map's line.
    #[serde(skip)]
    pub map: Vec<MapPoint>,
    /// The listed alert events that have a place.
    #[serde(skip)]
    pub events: Vec<PlacedEvent>,
    /// Samples with no position (outside the track, or between fixes too far apart).
    #[serde(skip)]
    pub unplaced_s: f64,
    /// What the track's checks found.
    #[serde(skip)]
    pub track: TrackAccount,
}

/// The segment being filled.
#[derive(Clone, Debug, Default)]
struct Open {
    start_k: usize,
    start_along_m: f64,
    last_along_m: f64,
    midpoint: Option<(f64, f64)>,
    first: (f64, f64),
    samples: usize,
    evaluated: usize,
    sq: f64,
    q: f64,
    speed_sum: f64,
    max_running_rms: f64,
    at_level: [usize; 4],
    joints: Option<JointPeaks>,
}

/// Builds a leg's [`Route`] sample by sample.
pub struct RouteBuilder {
    fs_hz: f64,
    weighting: [supine_core::weighting::WeightingSettings; 3],
    states: [WeightingState; 3],
    fixes: usize,
    map_step_m: f64,
    open: Option<Open>,
    segments: Vec<Segment>,
    map: Vec<MapPoint>,
    last_map_along_m: f64,
    map_peak: f64,
    broken: bool,
    unplaced: usize,
    travelled_m: f64,
    account: TrackAccount,
}

impl RouteBuilder {
    /// For a leg at `fs_hz` on `track`, weighted as `exposure` weights.
    pub fn new(track: &Track, exposure: &ExposureSettings, fs_hz: f64) -> Self {
        Self {
            fs_hz,
            weighting: exposure.weighting,
            states: [WeightingState::new(); 3],
            fixes: track.fixes().len(),
            map_step_m: (track.length_m() / MAX_MAP_POINTS as f64).max(MIN_MAP_STEP_M),
            open: None,
            segments: Vec::new(),
            map: Vec::new(),
            last_map_along_m: f64::NEG_INFINITY,
            map_peak: 0.0,
            broken: true,
            unplaced: 0,
            travelled_m: 0.0,
            account: track.account().clone(),
        }
    }

    /// Sample `k` (0, 1, ... in order): its place (if any), the pipeline's head
    /// acceleration, whether it is evaluated (after the warm-up), its vector running rms,
    /// its alert level and the joint outputs (display units), when tracked.
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        k: usize,
        place: Option<Place>,
        head_acc_m_s2: [f32; 3],
        evaluated: bool,
        running_rms_m_s2: f64,
        level: u8,
        joints: Option<&[f64; JOINT_OUTPUT_COUNT]>,
    ) {
        let mut a2 = [0.0f32; 3];
        for i in 0..3 {
            let a = self.weighting[i].step(&mut self.states[i], head_acc_m_s2[i]);
            a2[i] = a * a;
        }
        // As the core sums it: the squares in f32, in axis order.
        let av2 = a2[0] + a2[1] + a2[2];
        let Some(place) = place else {
            self.unplaced += 1;
            self.close(k);
            self.broken = true;
            return;
        };
        let open = self.open.get_or_insert_with(|| Open {
            start_k: k,
            start_along_m: place.along_m,
            last_along_m: place.along_m,
            first: (place.lat_deg, place.lon_deg),
            ..Open::default()
        });
        open.samples += 1;
        if evaluated {
            open.evaluated += 1;
            open.sq += f64::from(av2);
            open.q += f64::from(av2 * av2);
            if let Some(outputs) = joints {
                open.joints.get_or_insert_default().take(outputs);
            }
        }
        open.speed_sum += place.speed_m_s;
        open.max_running_rms = open.max_running_rms.max(running_rms_m_s2);
        open.at_level[usize::from(level.min(3))] += 1;
        self.travelled_m += place.along_m - open.last_along_m;
        open.last_along_m = place.along_m;
        let gone = place.along_m - open.start_along_m;
        if open.midpoint.is_none() && gone >= SEGMENT_LENGTH_M / 2.0 {
            open.midpoint = Some((place.lat_deg, place.lon_deg));
        }
        self.map_peak = self.map_peak.max(running_rms_m_s2);
        if self.broken || place.along_m - self.last_map_along_m >= self.map_step_m {
            self.map.push(MapPoint {
                lat_deg: place.lat_deg,
                lon_deg: place.lon_deg,
                running_rms_m_s2: self.map_peak,
                speed_m_s: place.speed_m_s,
                breaks: self.broken,
            });
            self.last_map_along_m = place.along_m;
            self.map_peak = running_rms_m_s2;
            self.broken = false;
        }
        if gone >= SEGMENT_LENGTH_M {
            self.close(k + 1);
            // The next segment starts where this one ended.
            self.open = Some(Open {
                start_k: k + 1,
                start_along_m: place.along_m,
                last_along_m: place.along_m,
                first: (place.lat_deg, place.lon_deg),
                ..Open::default()
            });
        }
    }

    /// Closes the open segment before sample `end_k`.
    fn close(&mut self, end_k: usize) {
        let Some(open) = self.open.take() else {
            return;
        };
        if open.samples == 0 {
            return;
        }
        let dt = 1.0 / self.fs_hz;
        let (lat_deg, lon_deg) = open.midpoint.unwrap_or(open.first);
        self.segments.push(Segment {
            start_s: open.start_k as f64 * dt,
            end_s: end_k as f64 * dt,
            lat_deg,
            lon_deg,
            length_m: open.last_along_m - open.start_along_m,
            speed_m_s: open.speed_sum / open.samples as f64,
            rms_m_s2: if open.evaluated > 0 {
                (open.sq / open.evaluated as f64).sqrt()
            } else {
                0.0
            },
            vdv_m_s175: (open.q * dt).sqrt().sqrt(),
            max_running_rms_m_s2: open.max_running_rms,
            time_at_level_s: TimeAtLevel::from_array(open.at_level.map(|c| c as f64 * dt)),
            largest_joint_excursions: open.joints,
            evaluated_s: open.evaluated as f64 * dt,
        });
    }

    /// The route, with `events` (the leg's listed events at their sample's place).
    pub fn finish(mut self, samples: usize, events: Vec<PlacedEvent>) -> Route {
        self.close(samples);
        if let (Some(last), true) = (self.map.last_mut(), self.map_peak > 0.0) {
            last.running_rms_m_s2 = last.running_rms_m_s2.max(self.map_peak);
        }
        let mut worst: Vec<Segment> = self.segments.clone();
        worst.sort_by(|a, b| b.rms_m_s2.total_cmp(&a.rms_m_s2));
        worst.truncate(WORST_SEGMENTS);
        Route {
            fixes: self.fixes,
            length_m: self.travelled_m,
            segments: self.segments,
            worst_segments: worst,
            map: self.map,
            events,
            unplaced_s: self.unplaced as f64 / self.fs_hz,
            track: self.account,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ride::position::{EARTH_RADIUS_M, Fix};
    use supine_core::exposure::ExposureConfig;
    use supine_core::sample_rate::SampleRate;

    /// A track due east along the equator at `v` m/s for `seconds`, fixes at 1 Hz.
    fn eastward(v: f64, seconds: usize) -> Track {
        let deg_per_m = 180.0 / (std::f64::consts::PI * EARTH_RADIUS_M);
        Track::new(
            (0..=seconds).map(|k| Fix {
                t_s: k as f64,
                lat_deg: 0.0,
                lon_deg: v * k as f64 * deg_per_m,
                speed_m_s: None,
                accuracy_m: None,
            }),
            "test",
        )
        .unwrap()
    }

    #[test]
    fn segments_are_fifty_metres_and_combine_to_the_whole() {
        let fs = 100.0;
        let settings = ExposureSettings::new(
            ExposureConfig::default(),
            SampleRate::from_hz_f64(fs).unwrap(),
        )
        .unwrap();
        let track = eastward(12.5, 60);
        let mut builder = RouteBuilder::new(&track, &settings, fs);
        let n = 6000;
        let (mut sq, mut q) = (0.0f64, 0.0f64);
        let mut check = [WeightingState::new(); 3];
        for k in 0..n {
            let t = k as f64 / fs;
            let head = [
                (0.3 * (2.0 * std::f64::consts::PI * 2.0 * t).sin()) as f32,
                0.0,
                ((1.0 + t / 20.0) * (2.0 * std::f64::consts::PI * 5.0 * t).sin()) as f32,
            ];
            let evaluated = k >= 100;
            // The independent sums over the whole leg.
            let mut av2 = 0.0f32;
            for i in 0..3 {
                let a = settings.weighting[i].step(&mut check[i], head[i]);
                av2 += a * a;
            }
            if evaluated {
                sq += f64::from(av2);
                q += f64::from(av2 * av2);
            }
            builder.push(k, track.at(t), head, evaluated, 0.1, 0, None);
        }
        let route = builder.finish(n, Vec::new());
        // 12.5 m/s for 60 s: 750 m in 15 segments of 50 m (to a sample's 0.125 m).
        assert!((route.length_m - 750.0).abs() < 0.2, "{}", route.length_m);
        assert_eq!(route.segments.len(), 15);
        for s in &route.segments[..14] {
            assert!((s.length_m - 50.0).abs() <= 0.125 + 1e-6, "{}", s.length_m);
            assert!((s.speed_m_s - 12.5).abs() < 1e-6);
            assert!((s.end_s - s.start_s - 4.0).abs() <= 0.01 + 1e-9);
        }
        let evaluated_s = (n - 100) as f64 / fs;
        let leg_rms = (sq / (n - 100) as f64).sqrt();
        let leg_vdv = (q / fs).sqrt().sqrt();
        let combined_rms = (route
            .segments
            .iter()
            .map(|s| s.rms_m_s2.powi(2) * s.evaluated_s)
            .sum::<f64>()
            / evaluated_s)
            .sqrt();
        let combined_vdv = route
            .segments
            .iter()
            .map(|s| s.vdv_m_s175.powi(4))
            .sum::<f64>()
            .powf(0.25);
        assert!((combined_rms / leg_rms - 1.0).abs() < 1e-9);
        assert!((combined_vdv / leg_vdv - 1.0).abs() < 1e-9);
        // The rougher end of the ride is the worst.
        assert!(route.worst_segments[0].start_s > 50.0);
    }
}
