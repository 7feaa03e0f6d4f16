//! A mission's metadata: who and what carried the patient, where, when, and the patient
//! or encounter identifier the user supplies (for the FHIR export). Given by flags or by
//! a small TOML file (`--meta`); a flag wins over the file, tags are joined.

use std::path::Path;

use anyhow::{Result, anyhow};
use jiff::Timestamp;
use serde::{Deserialize, Serialize};

/// The metadata of one mission. Every field is optional. The same fields are `add`'s
/// flags (their help is these comments) and the keys of its `--meta` file.
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize, Serialize, clap::Args)]
#[serde(deny_unknown_fields)]
pub struct MissionMeta {
    /// The vehicle (e.g. an ambulance's call sign).
    #[arg(long, value_name = "ID")]
    pub vehicle: Option<String>,
    /// The unit or crew.
    #[arg(long, value_name = "ID")]
    pub crew: Option<String>,
    /// The driver.
    #[arg(long, value_name = "ID")]
    pub driver: Option<String>,
    /// The route's name (e.g. A9 north).
    #[arg(long, value_name = "NAME")]
    pub route: Option<String>,
    /// The patient's transport position (e.g. supine).
    #[arg(long, value_name = "NAME")]
    pub position: Option<String>,
    /// Where the mission started.
    #[arg(long, value_name = "PLACE")]
    pub origin: Option<String>,
    /// Where it ended.
    #[arg(long, value_name = "PLACE")]
    pub destination: Option<String>,
    /// The start, ISO 8601 with an offset (2026-11-28T05:00:00Z, 2026-11-28T06:00:00+01:00).
    #[arg(long, value_name = "ISO8601")]
    pub start: Option<String>,
    /// A free tag (repeat for more).
    #[arg(long = "tag", value_name = "T")]
    #[serde(default)]
    pub tags: Vec<String>,
    /// A patient identifier (kept as given; used by `export --fhir`).
    #[arg(long, value_name = "ID")]
    pub patient: Option<String>,
    /// An encounter identifier (kept as given; used by `export --fhir`).
    #[arg(long, value_name = "ID")]
    pub encounter: Option<String>,
}

impl MissionMeta {
    /// Reads a `--meta` TOML file (keys as the fields above).
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
        toml::from_str(&text).map_err(|e| {
            anyhow!(
                "{}: {} (expected the keys vehicle, crew, driver, route, position, origin, \
                 destination, start, tags, patient, encounter)",
                path.display(),
                e.to_string().trim()
            )
        })
    }

    /// `self` with every field that `flags` sets replaced, and `flags`' tags added.
    pub fn overlaid(self, flags: MissionMeta) -> Self {
        let mut tags = self.tags;
        for tag in flags.tags {
            if !tags.contains(&tag) {
                tags.push(tag);
            }
        }
        Self {
            vehicle: flags.vehicle.or(self.vehicle),
            crew: flags.crew.or(self.crew),
            driver: flags.driver.or(self.driver),
            route: flags.route.or(self.route),
            position: flags.position.or(self.position),
            origin: flags.origin.or(self.origin),
            destination: flags.destination.or(self.destination),
            start: flags.start.or(self.start),
            tags,
            patient: flags.patient.or(self.patient),
            encounter: flags.encounter.or(self.encounter),
        }
    }

    /// The start as an instant, when given.
    pub fn start_time(&self) -> Result<Option<Timestamp>> {
        self.start.as_deref().map(parse_start).transpose()
    }
}

/// An ISO 8601 instant with its offset.
pub fn parse_start(text: &str) -> Result<Timestamp> {
    text.trim().parse::<Timestamp>().map_err(|e| {
        anyhow!(
            "start {text:?}: expected an ISO 8601 time with an offset, e.g. \
             2026-11-28T05:00:00Z or 2026-11-28T06:00:00+01:00 ({e})"
        )
    })
}

/// A `--since`/`--until` bound: a date (`2026-11-01`, midnight UTC) or an instant.
pub fn parse_bound(text: &str) -> Result<Timestamp> {
    if let Ok(date) = text.trim().parse::<jiff::civil::Date>() {
        return Ok(date.to_zoned(jiff::tz::TimeZone::UTC)?.timestamp());
    }
    parse_start(text).map_err(|_| {
        anyhow!("{text:?}: expected a date (2026-11-01) or an ISO 8601 time with an offset")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_win_and_tags_join() {
        let file = MissionMeta {
            vehicle: Some("A1".into()),
            crew: Some("red".into()),
            tags: vec!["night".into()],
            ..Default::default()
        };
        let flags = MissionMeta {
            vehicle: Some("A2".into()),
            tags: vec!["night".into(), "rain".into()],
            ..Default::default()
        };
        let m = file.overlaid(flags);
        assert_eq!(m.vehicle.as_deref(), Some("A2"));
        assert_eq!(m.crew.as_deref(), Some("red"));
        assert_eq!(m.tags, ["night", "rain"]);
    }

    #[test]
    fn times_need_an_offset_and_dates_are_utc_midnight() {
        let t = parse_start("2026-11-28T06:00:00+01:00").unwrap();
        assert_eq!(
            t.as_second(),
            parse_start("2026-11-28T05:00:00Z").unwrap().as_second()
        );
        assert!(parse_start("2026-11-28T05:00:00").is_err());
        assert_eq!(
            parse_bound("2026-11-28").unwrap(),
            parse_start("2026-11-28T00:00:00Z").unwrap()
        );
    }
}
