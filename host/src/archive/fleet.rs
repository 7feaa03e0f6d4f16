//! The fleet view's numbers (`supine archive fleet`): missions over time, per vehicle,
//! crew, driver and route the distribution of the head's VDV per hour of ride with the
//! median's interval, time at warning and alarm and the joints' largest excursions, the
//! worst missions, and a compare of two groups by the Mann-Whitney test.
//!
//! Missions differ in length and the VDV grows with time as its fourth root, so missions
//! are compared by their VDV per hour of ride: the VDV one hour at the mission's own dose
//! rate would give, `VDV (3600 s / T)^(1/4)` (T the mission's duration). Computed from the
//! stored columns only (`store::fleet_rows`), never from the stored JSON, so that a test
//! can check one against the other.

use std::collections::BTreeMap;

use anyhow::{Result, anyhow, bail};
use jiff::Timestamp;
use serde::Serialize;

use crate::archive::meta::parse_bound;
use crate::archive::road::RoadSegment;
use crate::archive::stats::{Distribution, MannWhitney, mann_whitney};
use crate::archive::store::FleetRow;

/// The dimensions missions are grouped by, in [`FleetRow::keys`]' order.
pub const DIMENSIONS: [&str; 4] = ["vehicle", "crew", "driver", "route"];
/// Missions listed as the worst.
pub const WORST_LISTED: usize = 10;
/// The p-value below which a compare calls a difference more than chance.
pub const SIGNIFICANCE: f64 = 0.05;

/// A mission's VDV per hour of ride, m/s^1.75 (`None` for a mission of no duration).
pub fn vdv_per_hour_m_s175(vdv_m_s175: f64, duration_s: f64) -> Option<f64> {
    (duration_s > 0.0).then(|| vdv_m_s175 * (3600.0 / duration_s).powf(0.25))
}

/// One joint output's largest excursions over a group's missions.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointGroup {
    /// The output, e.g. `neck_x`.
    pub output: String,
    /// `mm` or `deg`.
    pub unit: String,
    /// The missions' largest excursions.
    pub largest_excursion: Distribution,
}

/// The missions that share one value of one dimension.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Group {
    /// `vehicle`, `crew`, `driver` or `route`.
    pub by: &'static str,
    /// The value.
    pub key: String,
    /// The number of missions.
    pub missions: usize,
    /// Their ride time, h.
    pub duration_h: f64,
    /// The head's VDV per hour of ride, m/s^1.75.
    pub vdv_per_hour_m_s175: Distribution,
    /// Seconds at warning, summed.
    pub warning_s: f64,
    /// Seconds at alarm, summed.
    pub alarm_s: f64,
    /// The fraction of ride time at warning or alarm.
    pub warning_or_alarm_fraction: f64,
    /// Missions whose highest level was warning or alarm.
    pub warning_or_alarm_missions: usize,
    /// Missions whose highest level was alarm.
    pub alarm_missions: usize,
    /// The joints' largest excursions.
    pub joints: Vec<JointGroup>,
}

/// A mission among the worst.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WorstMission {
    /// Its id (`supine archive show ID`).
    pub id: i64,
    /// Its start.
    pub start: Option<String>,
    /// Vehicle, crew, driver, route.
    pub vehicle: Option<String>,
    /// Crew.
    pub crew: Option<String>,
    /// Driver.
    pub driver: Option<String>,
    /// Route.
    pub route: Option<String>,
    /// Duration, s.
    pub duration_s: f64,
    /// The head's VDV, m/s^1.75.
    pub vdv_m_s175: f64,
    /// Its VDV per hour of ride, m/s^1.75.
    pub vdv_per_hour_m_s175: f64,
    /// Its highest level.
    pub max_level: String,
}

/// One week of missions.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Week {
    /// Its Monday (UTC), `YYYY-MM-DD`.
    pub week_of: String,
    /// Missions that started in it.
    pub missions: usize,
    /// Their VDV per hour of ride.
    pub vdv_per_hour_m_s175: Distribution,
}

/// One mission on the time axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimePoint {
    /// Its id.
    pub id: i64,
    /// Its start, s since 1970 (UTC).
    pub start_epoch_s: f64,
    /// Its VDV per hour of ride.
    pub vdv_per_hour_m_s175: f64,
    /// Its highest level.
    pub max_level: String,
}

/// Which missions one side of a compare takes: one value of one dimension, optionally
/// within a period (`route=A9,until=2026-06-01`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Side {
    /// The dimension.
    pub by: &'static str,
    /// Its value.
    pub key: String,
    /// Started at or after.
    pub since: Option<String>,
    /// Started before.
    pub until: Option<String>,
}

impl Side {
    /// Parses `FIELD=VALUE[,since=DATE][,until=DATE]`.
    pub fn parse(text: &str) -> Result<Self> {
        let mut parts = text.split(',');
        let first = parts.next().unwrap_or_default();
        let (by, key) = first.split_once('=').ok_or_else(|| {
            anyhow!("--compare {text:?}: expected FIELD=VALUE[,since=DATE][,until=DATE]")
        })?;
        let by = DIMENSIONS
            .into_iter()
            .find(|d| *d == by.trim())
            .ok_or_else(|| {
                anyhow!("--compare {text:?}: {by:?} is not one of vehicle, crew, driver, route")
            })?;
        let mut side = Self {
            by,
            key: key.trim().to_string(),
            since: None,
            until: None,
        };
        for part in parts {
            match part.split_once('=') {
                Some(("since", d)) => {
                    parse_bound(d)?;
                    side.since = Some(d.trim().to_string());
                }
                Some(("until", d)) => {
                    parse_bound(d)?;
                    side.until = Some(d.trim().to_string());
                }
                _ => bail!("--compare {text:?}: {part:?}: expected since=DATE or until=DATE"),
            }
        }
        Ok(side)
    }

    fn label(&self) -> String {
        let mut s = format!("{} {}", self.by, self.key);
        if let Some(d) = &self.since {
            s += &format!(" since {d}");
        }
        if let Some(d) = &self.until {
            s += &format!(" until {d}");
        }
        s
    }

    fn takes(&self, row: &FleetRow) -> bool {
        let k = DIMENSIONS.iter().position(|d| *d == self.by).unwrap_or(0);
        if row.keys[k].as_deref() != Some(self.key.as_str()) {
            return false;
        }
        let at = row.start_epoch_s;
        let bound = |d: &Option<String>| {
            d.as_deref()
                .and_then(|d| parse_bound(d).ok())
                .map(|t: Timestamp| t.as_millisecond() as f64 / 1e3)
        };
        if let Some(since) = bound(&self.since) {
            if at.is_none_or(|t| t < since) {
                return false;
            }
        }
        if let Some(until) = bound(&self.until) {
            if at.is_none_or(|t| t >= until) {
                return false;
            }
        }
        true
    }
}

/// One side of a compare as found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompareSide {
    /// What it takes.
    pub side: Side,
    /// In words.
    pub label: String,
    /// Its missions' VDV per hour of ride (null when it has none).
    pub vdv_per_hour_m_s175: Option<Distribution>,
}

/// Two groups compared.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The first group.
    pub a: CompareSide,
    /// The second.
    pub b: CompareSide,
    /// `median(b) - median(a)`, m/s^1.75.
    pub median_difference_m_s175: Option<f64>,
    /// The test: two-sided Mann-Whitney U of the VDV per hour of ride.
    pub test: &'static str,
    /// Its result (null when a side has no missions).
    pub mann_whitney: Option<MannWhitney>,
    /// Whether p < [`SIGNIFICANCE`].
    pub more_than_chance: bool,
}

/// The fleet view.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FleetView {
    /// Missions covered.
    pub missions: usize,
    /// Their ride time, h.
    pub duration_h: f64,
    /// Missions without a start time (left off the time axis).
    pub undated_missions: usize,
    /// Each mission on the time axis, oldest first.
    pub timeline: Vec<TimePoint>,
    /// Missions per week.
    pub weeks: Vec<Week>,
    /// The groups, dimension by dimension, each by missions (most first), then key.
    pub groups: Vec<Group>,
    /// The worst missions by VDV per hour of ride.
    pub worst: Vec<WorstMission>,
    /// The compare, when there are two groups to compare.
    pub compare: Option<Comparison>,
    /// The places passed, with their passes and the head's exposure there, worst first
    /// (none when no ride has positions).
    pub road_segments: Vec<RoadSegment>,
}

/// The view of `rows`, grouped by `dims`, comparing `compare` (or, when `None`, the two
/// largest groups of the first dimension).
pub fn build(
    rows: &[FleetRow],
    road_segments: Vec<RoadSegment>,
    dims: &[&'static str],
    compare: Option<[Side; 2]>,
) -> FleetView {
    let rate = |r: &FleetRow| vdv_per_hour_m_s175(r.vdv_m_s175, r.duration_s);
    let mut groups = Vec::new();
    for &by in dims {
        let k = DIMENSIONS.iter().position(|d| *d == by).unwrap_or(0);
        let mut members: BTreeMap<&str, Vec<&FleetRow>> = BTreeMap::new();
        for r in rows {
            if let Some(key) = r.keys[k].as_deref() {
                members.entry(key).or_default().push(r);
            }
        }
        let mut these: Vec<Group> = members
            .into_iter()
            .filter_map(|(key, m)| group(by, key, &m))
            .collect();
        these.sort_by(|a, b| b.missions.cmp(&a.missions).then(a.key.cmp(&b.key)));
        groups.extend(these);
    }
    let mut ranked: Vec<(&FleetRow, f64)> =
        rows.iter().filter_map(|r| Some((r, rate(r)?))).collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.id.cmp(&b.0.id)));
    let worst = ranked
        .iter()
        .take(WORST_LISTED)
        .map(|(r, v)| WorstMission {
            id: r.id,
            start: r.start.clone(),
            vehicle: r.keys[0].clone(),
            crew: r.keys[1].clone(),
            driver: r.keys[2].clone(),
            route: r.keys[3].clone(),
            duration_s: r.duration_s,
            vdv_m_s175: r.vdv_m_s175,
            vdv_per_hour_m_s175: *v,
            max_level: r.max_level.clone(),
        })
        .collect();
    let timeline: Vec<TimePoint> = rows
        .iter()
        .filter_map(|r| {
            Some(TimePoint {
                id: r.id,
                start_epoch_s: r.start_epoch_s?,
                vdv_per_hour_m_s175: rate(r)?,
                max_level: r.max_level.clone(),
            })
        })
        .collect();
    let compare = compare
        .or_else(|| default_sides(&groups, dims))
        .map(|[a, b]| compared(rows, a, b));
    FleetView {
        missions: rows.len(),
        duration_h: rows.iter().map(|r| r.duration_s).sum::<f64>() / 3600.0,
        undated_missions: rows.iter().filter(|r| r.start_epoch_s.is_none()).count(),
        weeks: weeks(&timeline),
        timeline,
        groups,
        worst,
        compare,
        road_segments,
    }
}

fn group(by: &'static str, key: &str, members: &[&FleetRow]) -> Option<Group> {
    let rates: Vec<f64> = members
        .iter()
        .filter_map(|r| vdv_per_hour_m_s175(r.vdv_m_s175, r.duration_s))
        .collect();
    let seconds: f64 = members.iter().map(|r| r.duration_s).sum();
    let warning_s: f64 = members.iter().map(|r| r.warning_s).sum();
    let alarm_s: f64 = members.iter().map(|r| r.alarm_s).sum();
    let mut joints: BTreeMap<(&str, &str), Vec<f64>> = BTreeMap::new();
    for r in members {
        for (output, unit, v) in &r.joints {
            joints.entry((output, unit)).or_default().push(*v);
        }
    }
    Some(Group {
        by,
        key: key.to_string(),
        missions: members.len(),
        duration_h: seconds / 3600.0,
        vdv_per_hour_m_s175: Distribution::of(&rates)?,
        warning_s,
        alarm_s,
        warning_or_alarm_fraction: if seconds > 0.0 {
            (warning_s + alarm_s) / seconds
        } else {
            0.0
        },
        warning_or_alarm_missions: members
            .iter()
            .filter(|r| r.max_level == "warning" || r.max_level == "alarm")
            .count(),
        alarm_missions: members.iter().filter(|r| r.max_level == "alarm").count(),
        joints: joints
            .into_iter()
            .filter_map(|((output, unit), v)| {
                Some(JointGroup {
                    output: output.to_string(),
                    unit: unit.to_string(),
                    largest_excursion: Distribution::of(&v)?,
                })
            })
            .collect(),
    })
}

/// The two largest groups of the first dimension, when it has two.
fn default_sides(groups: &[Group], dims: &[&'static str]) -> Option<[Side; 2]> {
    let by = *dims.first()?;
    let mut of_dim = groups.iter().filter(|g| g.by == by);
    let side = |g: &Group| Side {
        by,
        key: g.key.clone(),
        since: None,
        until: None,
    };
    Some([side(of_dim.next()?), side(of_dim.next()?)])
}

fn compared(rows: &[FleetRow], a: Side, b: Side) -> Comparison {
    let rates = |s: &Side| -> Vec<f64> {
        rows.iter()
            .filter(|r| s.takes(r))
            .filter_map(|r| vdv_per_hour_m_s175(r.vdv_m_s175, r.duration_s))
            .collect()
    };
    let (ra, rb) = (rates(&a), rates(&b));
    let (da, db) = (Distribution::of(&ra), Distribution::of(&rb));
    let test = mann_whitney(&ra, &rb);
    Comparison {
        median_difference_m_s175: match (&da, &db) {
            (Some(x), Some(y)) => Some(y.median - x.median),
            _ => None,
        },
        more_than_chance: test.as_ref().is_some_and(|t| t.p_value < SIGNIFICANCE),
        mann_whitney: test,
        test: "Mann-Whitney U, two-sided, normal approximation with tie and continuity corrections",
        a: CompareSide {
            label: a.label(),
            side: a,
            vdv_per_hour_m_s175: da,
        },
        b: CompareSide {
            label: b.label(),
            side: b,
            vdv_per_hour_m_s175: db,
        },
    }
}

/// Missions per week (weeks from Monday, UTC), oldest first.
fn weeks(timeline: &[TimePoint]) -> Vec<Week> {
    const DAY_S: i64 = 86_400;
    let mut by_week: BTreeMap<i64, Vec<f64>> = BTreeMap::new();
    for p in timeline {
        let day = (p.start_epoch_s / DAY_S as f64).floor() as i64;
        // 1970-01-01 was a Thursday: Monday-based weeks start 3 days earlier.
        let monday = day - (day + 3).rem_euclid(7);
        by_week
            .entry(monday)
            .or_default()
            .push(p.vdv_per_hour_m_s175);
    }
    by_week
        .into_iter()
        .filter_map(|(monday, v)| {
            let date = Timestamp::from_second(monday * DAY_S)
                .ok()?
                .strftime("%Y-%m-%d")
                .to_string();
            Some(Week {
                week_of: date,
                missions: v.len(),
                vdv_per_hour_m_s175: Distribution::of(&v)?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(id: i64, vehicle: &str, duration_s: f64, vdv: f64, start: f64) -> FleetRow {
        FleetRow {
            id,
            start: None,
            start_epoch_s: Some(start),
            keys: [Some(vehicle.into()), None, None, None],
            duration_s,
            vdv_m_s175: vdv,
            mtvv_m_s2: 0.0,
            max_level: "normal".into(),
            warning_s: 1.0,
            alarm_s: 0.5,
            joints: vec![],
        }
    }

    #[test]
    fn vdv_per_hour_is_the_fourth_root_scaling() {
        // A quarter of an hour: an hour at the same rate has four times the VDV^4.
        let v = vdv_per_hour_m_s175(2.0, 900.0).unwrap();
        assert!((v.powi(4) - 4.0 * 16.0).abs() < 1e-9);
        assert_eq!(vdv_per_hour_m_s175(1.0, 0.0), None);
    }

    #[test]
    fn weeks_start_on_monday_and_groups_sort_by_size() {
        // 2026-11-23 is a Monday; 2026-11-29 the Sunday of the same week.
        let mon = 1_795_392_000.0;
        let rows = [
            row(1, "A", 3600.0, 1.0, mon),
            row(2, "A", 3600.0, 2.0, mon + 6.0 * 86_400.0 + 3600.0),
            row(3, "B", 3600.0, 3.0, mon + 7.0 * 86_400.0),
        ];
        let v = build(&rows, Vec::new(), &["vehicle"], None);
        assert_eq!(v.weeks.len(), 2);
        assert_eq!(v.weeks[0].week_of, "2026-11-23");
        assert_eq!(v.weeks[0].missions, 2);
        assert_eq!(v.groups[0].key, "A");
        assert_eq!(v.groups[0].warning_s, 2.0);
        assert_eq!(v.worst[0].id, 3);
        let c = v.compare.unwrap();
        assert_eq!((c.a.side.key.as_str(), c.b.side.key.as_str()), ("A", "B"));
    }

    #[test]
    fn compare_sides_parse() {
        let s = Side::parse("route=A9,until=2026-06-01").unwrap();
        assert_eq!((s.by, s.key.as_str()), ("route", "A9"));
        assert_eq!(s.until.as_deref(), Some("2026-06-01"));
        assert!(Side::parse("colour=red").is_err());
        assert!(Side::parse("route=A9,after=2026").is_err());
    }
}
