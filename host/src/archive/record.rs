//! What `supine archive add` stores of a mission: the report that `supine report` builds
//! for the same rides (its JSON kept as `report --json` writes it, its numbers also in
//! columns for queries), the rides' content hashes, the per-second series and the
//! metadata.

use std::io::Read as _;
use std::path::Path;

use anyhow::{Result, anyhow};
use jiff::Timestamp;
use serde::Serialize;
use serde_json::Value;
use sha2::{Digest, Sha256};

use crate::archive::meta::MissionMeta;
use crate::archive::road::{self, Pass};
use crate::archive::series::SecondSeries;
use crate::report::MissionReport;

/// A ride file as the archive knows it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RideFile {
    /// The path given to `add`.
    pub input: String,
    /// SHA-256 of its bytes, hex.
    pub sha256: String,
    /// Its size, bytes.
    pub bytes: u64,
    /// Its bytes, when `add --copy-rides` asked for them.
    pub content: Option<Vec<u8>>,
}

impl RideFile {
    /// Hashes `path` (streamed), keeping its bytes when `copy`.
    pub fn read(path: &Path, copy: bool) -> Result<Self> {
        let mut file = std::fs::File::open(path)
            .map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
        let mut hasher = Sha256::new();
        let mut content = copy.then(Vec::new);
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let n = file
                .read(&mut buf)
                .map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
            if let Some(c) = content.as_mut() {
                c.extend_from_slice(&buf[..n]);
            }
            bytes += n as u64;
        }
        let sha256 = hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        Ok(Self {
            input: path.display().to_string(),
            sha256,
            bytes,
            content,
        })
    }
}

/// One leg as stored.
pub struct LegRecord {
    /// Its ride.
    pub ride: RideFile,
    /// `report --json`'s object for the leg.
    pub json: Value,
    /// Its data-quality account (`"data_quality"` of the leg's JSON), when the report has
    /// one.
    pub data_quality: Option<Value>,
    /// Its per-second series.
    pub seconds: SecondSeries,
    /// Its passes over road segments (none without positions).
    pub passes: Vec<Pass>,
}

/// A mission as stored.
pub struct MissionRecord<'a> {
    /// The report of its rides.
    pub report: &'a MissionReport,
    /// `report --json`'s `"mission"` object.
    pub mission_json: Value,
    /// The legs, in order.
    pub legs: Vec<LegRecord>,
    /// Its metadata.
    pub meta: MissionMeta,
    /// The start, when given.
    pub start: Option<Timestamp>,
}

/// `supine archive add --json`: the mission just added.
#[derive(Clone, Debug, Serialize)]
pub struct AddedMission<'a> {
    /// The mission's id in the archive.
    pub id: i64,
    /// The archive it went into (its file, or its database URL).
    pub archive: String,
    /// Each leg's ride file and the SHA-256 of its bytes, in order.
    pub rides: Vec<AddedRide<'a>>,
    /// The mission's values, named as in `report --json`'s `"mission"`.
    pub mission: &'a Value,
}

/// One ride of [`AddedMission`].
#[derive(Clone, Debug, Serialize)]
pub struct AddedRide<'a> {
    /// The path given to `add`.
    pub input: &'a str,
    /// SHA-256 of its bytes, hex.
    pub sha256: &'a str,
}

impl<'a> AddedMission<'a> {
    /// The record of `mission`, added as `id` to `archive`.
    pub fn new(id: i64, archive: String, mission: &'a MissionRecord<'_>) -> Self {
        Self {
            id,
            archive,
            rides: mission
                .legs
                .iter()
                .map(|l| AddedRide {
                    input: &l.ride.input,
                    sha256: &l.ride.sha256,
                })
                .collect(),
            mission: &mission.mission_json,
        }
    }
}

impl<'a> MissionRecord<'a> {
    /// The record of `report`, whose legs are the rides `rides` in order.
    pub fn new(report: &'a MissionReport, rides: Vec<RideFile>, meta: MissionMeta) -> Result<Self> {
        if rides.len() != report.legs.len() {
            return Err(anyhow!(
                "{} rides for {} legs",
                rides.len(),
                report.legs.len()
            ));
        }
        let json = serde_json::to_value(report)?;
        let mission_json = json["mission"].clone();
        let legs_json = json["legs"].as_array().cloned().unwrap_or_default();
        let legs = report
            .legs
            .iter()
            .zip(rides)
            .zip(legs_json)
            .map(|((leg, ride), json)| LegRecord {
                data_quality: json.get("data_quality").cloned(),
                seconds: SecondSeries::of_leg(leg),
                passes: road::passes(leg.route.as_ref().map_or(&[], |r| &r.segments)),
                ride,
                json,
            })
            .collect();
        let start = meta.start_time()?;
        Ok(Self {
            report,
            mission_json,
            legs,
            meta,
            start,
        })
    }
}
