//! What the route's figures show: the map of every leg's track in one frame, coloured by
//! the head's running rms against the alert thresholds, each leg cased in its own colour
//! with its start and end marked, and each placed alert event; and the running rms
//! against speed. How they are drawn is [`crate::plot::map`] and
//! [`crate::plot::scatter`].

use supine_core::alerts::{AlertConfig, Level};

use crate::plot::Rgb;
use crate::plot::map::{Map, Marker, Piece, Shape};
use crate::plot::scatter::{Group, Scatter};
use crate::plot::time_chart::{LEVEL_COLORS, alert_thresholds};
use crate::report::mission::Leg;
use crate::ride::position::{centre_deg, project_m};

/// The legs' casing colours, in turn.
pub const LEG_COLORS: [Rgb; 3] = [Rgb(70, 110, 200), Rgb(150, 90, 180), Rgb(90, 160, 170)];
/// Width of the track's coloured line, px.
const TRACK_PX: u32 = 5;
/// Width of a leg's casing under it, px.
const CASING_PX: u32 = 11;

/// The alert level (0-3) a running rms of `value` would be at by `config`'s thresholds.
pub fn rms_level(value: f64, config: &AlertConfig) -> usize {
    config
        .running_rms_m_s2
        .iter()
        .filter(|t| value >= f64::from(**t))
        .count()
}

/// The map's frame centre: the middle of every leg's drawn points.
fn mission_centre(legs: &[Leg]) -> Option<(f64, f64)> {
    let mut points = legs
        .iter()
        .filter_map(|l| l.route.as_ref())
        .flat_map(|r| r.map.iter().map(|p| (p.lat_deg, p.lon_deg)))
        .peekable();
    points.peek()?;
    Some(centre_deg(points))
}

/// The route map of `legs`, or `None` when no leg has two points to draw.
pub fn route_map(legs: &[Leg], config: &AlertConfig) -> Option<Map> {
    let drawn = legs
        .iter()
        .filter(|l| l.route.as_ref().is_some_and(|r| r.map.len() >= 2))
        .count();
    if drawn == 0 {
        return None;
    }
    let centre = mission_centre(legs)?;
    let at = |lat: f64, lon: f64| project_m(centre, lat, lon);
    let mut map = Map {
        title: "Where it happened: the head's running rms along the route".to_string(),
        ..Map::default()
    };
    let mut coloured: Vec<Piece> = Vec::new();
    for (i, leg) in legs.iter().enumerate() {
        let Some(route) = leg.route.as_ref().filter(|r| r.map.len() >= 2) else {
            continue;
        };
        let casing = LEG_COLORS[i % LEG_COLORS.len()];
        let mut previous: Option<[f64; 2]> = None;
        for p in &route.map {
            let here = at(p.lat_deg, p.lon_deg);
            if p.breaks || previous.is_none() {
                map.pieces.push(Piece {
                    points: vec![here],
                    color: casing,
                    width: CASING_PX,
                });
            } else if let Some(last) = map.pieces.last_mut() {
                last.points.push(here);
            }
            if let (Some(from), false) = (previous, p.breaks) {
                let color = LEVEL_COLORS[rms_level(p.running_rms_m_s2, config)];
                match coloured.last_mut() {
                    Some(piece) if piece.color == color && piece.points.last() == Some(&from) => {
                        piece.points.push(here);
                    }
                    _ => coloured.push(Piece {
                        points: vec![from, here],
                        color,
                        width: TRACK_PX,
                    }),
                }
            }
            previous = Some(here);
        }
        let number = i + 1;
        let (first, last) = (&route.map[0], &route.map[route.map.len() - 1]);
        map.markers.push(Marker {
            at: at(first.lat_deg, first.lon_deg),
            color: casing,
            shape: Shape::Circle,
            label: format!("start {number}"),
        });
        map.markers.push(Marker {
            at: at(last.lat_deg, last.lon_deg),
            color: casing,
            shape: Shape::Square,
            label: format!("end {number}"),
        });
        for e in &route.events {
            map.markers.push(Marker {
                at: at(e.lat_deg, e.lon_deg),
                color: e
                    .level
                    .map_or(Rgb(90, 90, 90), |l| LEVEL_COLORS[usize::from(l.min(3))]),
                shape: Shape::Triangle,
                label: if e.raise {
                    format!(
                        "{:.0} s {}",
                        leg.start_s + e.leg_time_s,
                        Level::ALL[usize::from(e.level.unwrap_or(0).min(3))].name()
                    )
                } else {
                    String::new()
                },
            });
        }
        map.legend.push((casing, leg.label.clone()));
    }
    map.pieces.extend(coloured);
    let t = config.running_rms_m_s2;
    let ranges = [
        format!("running rms below {} m/s^2", t[0]),
        format!("from {} m/s^2 (advisory)", t[0]),
        format!("from {} m/s^2 (warning)", t[1]),
        format!("from {} m/s^2 (alarm)", t[2]),
    ];
    for (color, text) in LEVEL_COLORS.iter().zip(ranges) {
        map.legend.push((*color, text));
    }
    Some(map)
}

/// The head's running rms against speed at each map point, a group per leg, with the
/// running-rms thresholds; `None` when no leg has a route.
pub fn rms_against_speed(legs: &[Leg], config: &AlertConfig) -> Option<Scatter> {
    let groups: Vec<Group> = legs
        .iter()
        .enumerate()
        .filter_map(|(i, leg)| {
            let route = leg.route.as_ref()?;
            Some(Group {
                points: route
                    .map
                    .iter()
                    .map(|p| (p.speed_m_s, p.running_rms_m_s2))
                    .collect(),
                color: LEG_COLORS[i % LEG_COLORS.len()],
                label: leg.label.clone(),
            })
        })
        .collect();
    if groups.is_empty() {
        return None;
    }
    Some(Scatter {
        title: "The head's running rms against speed".to_string(),
        x_label: "ground speed, m/s".to_string(),
        y_label: "vector running rms, m/s^2".to_string(),
        groups,
        thresholds: alert_thresholds(config.running_rms_m_s2),
    })
}
