//! Adding, listing, showing and removing missions: the archive's queries, one text for
//! both databases.
//!
//! A mission is added in one transaction: a process killed half-way leaves nothing of it
//! (the database rolls the transaction back), and two processes adding at once both land
//! (SQLite serializes them on its write lock, waiting up to the busy timeout; PostgreSQL
//! runs them side by side). A ride is archived once: adding a ride whose content (SHA-256)
//! is already in the archive is refused, naming the mission that has it, and a unique
//! index makes that hold even for two adds of the same ride at the same moment.

use std::collections::HashMap;
use std::time::Duration;

use anyhow::{Context as _, Result, anyhow, bail};
use jiff::Timestamp;
use serde::Serialize;
use serde_json::Value;
use sqlx::any::AnyRow;
use sqlx::{Any, Row as _};

use crate::archive::db::Archive;
use crate::archive::meta::MissionMeta;
use crate::archive::record::MissionRecord;
use crate::archive::road::{Cell, RoadSegment};
use crate::archive::series::SecondSeries;
use crate::report::level_time::TimeAtLevel;
use supine_core::alerts::Level;

/// An environment variable for the tests of a killed add: the milliseconds `add` holds its
/// transaction open, after writing everything and before committing (it says so on
/// standard error first).
pub const STALL_ENV: &str = "SUPINE_ARCHIVE_STALL_MS";

/// Which missions a listing or the fleet view covers. Empty lists match every value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Filter {
    /// Missions that started at or after this instant (missions without a start are left
    /// out when a bound is given).
    pub since: Option<Timestamp>,
    /// Missions that started before this instant.
    pub until: Option<Timestamp>,
    /// Only these vehicles.
    pub vehicle: Vec<String>,
    /// Only these crews.
    pub crew: Vec<String>,
    /// Only these drivers.
    pub driver: Vec<String>,
    /// Only these routes.
    pub route: Vec<String>,
}

/// A value bound to a query's `$n`.
enum Bind {
    Int(i64),
    Real(Option<f64>),
    Text(Option<String>),
    Blob(Option<Vec<u8>>),
}

impl From<i64> for Bind {
    fn from(v: i64) -> Self {
        Self::Int(v)
    }
}

impl From<f64> for Bind {
    fn from(v: f64) -> Self {
        Self::Real(Some(v))
    }
}

impl From<Option<f64>> for Bind {
    fn from(v: Option<f64>) -> Self {
        Self::Real(v)
    }
}

impl From<&str> for Bind {
    fn from(v: &str) -> Self {
        Self::Text(Some(v.to_string()))
    }
}

impl From<Option<String>> for Bind {
    fn from(v: Option<String>) -> Self {
        Self::Text(v)
    }
}

impl From<Option<Vec<u8>>> for Bind {
    fn from(v: Option<Vec<u8>>) -> Self {
        Self::Blob(v)
    }
}

impl Filter {
    /// The `WHERE` clause over `missions` (aliased `m`) and its values, numbered from `$1`.
    fn clause(&self) -> (String, Vec<Bind>) {
        let mut terms = Vec::new();
        let mut binds = Vec::new();
        if let Some(t) = self.since {
            binds.push(epoch_s(t).into());
            terms.push(format!("m.start_epoch_s >= ${}", binds.len()));
        }
        if let Some(t) = self.until {
            binds.push(epoch_s(t).into());
            terms.push(format!("m.start_epoch_s < ${}", binds.len()));
        }
        for (column, values) in [
            ("vehicle", &self.vehicle),
            ("crew", &self.crew),
            ("driver", &self.driver),
            ("route", &self.route),
        ] {
            if values.is_empty() {
                continue;
            }
            let mut slots = Vec::new();
            for v in values {
                binds.push(v.as_str().into());
                slots.push(format!("${}", binds.len()));
            }
            terms.push(format!("m.{column} IN ({})", slots.join(", ")));
        }
        let clause = if terms.is_empty() {
            String::new()
        } else {
            format!(" WHERE {}", terms.join(" AND "))
        };
        (clause, binds)
    }
}

/// An instant as the archive keeps it: seconds since 1970 (UTC).
fn epoch_s(t: Timestamp) -> f64 {
    t.as_millisecond() as f64 / 1e3
}

fn bound<'q>(
    mut query: sqlx::query::Query<'q, Any, sqlx::any::AnyArguments<'q>>,
    binds: &'q [Bind],
) -> sqlx::query::Query<'q, Any, sqlx::any::AnyArguments<'q>> {
    for b in binds {
        query = match b {
            Bind::Int(v) => query.bind(*v),
            Bind::Real(v) => query.bind(*v),
            Bind::Text(v) => query.bind(v.as_deref()),
            Bind::Blob(v) => query.bind(v.as_deref()),
        };
    }
    query
}

/// One row to insert: each column with its value, the statement written from them (so
/// a column and its value stand side by side, never counted into a `$n` list).
struct Insert {
    table: &'static str,
    columns: Vec<&'static str>,
    values: Vec<Bind>,
}

impl Insert {
    fn into(table: &'static str) -> Self {
        Self {
            table,
            columns: Vec::new(),
            values: Vec::new(),
        }
    }

    fn set(mut self, column: &'static str, value: impl Into<Bind>) -> Self {
        self.columns.push(column);
        self.values.push(value.into());
        self
    }

    /// The head's weighted vector values and the time at each level, as both `missions`
    /// and `legs` keep them.
    fn exposure(self, vector: [f64; 3], levels: TimeAtLevel, max_level: Level) -> Self {
        let [rms, mtvv, vdv] = vector;
        self.set("rms_m_s2", rms)
            .set("mtvv_m_s2", mtvv)
            .set("vdv_m_s175", vdv)
            .set("normal_s", levels.normal)
            .set("advisory_s", levels.advisory)
            .set("warning_s", levels.warning)
            .set("alarm_s", levels.alarm)
            .set("max_level", max_level.name())
    }

    /// The statement, followed by `tail` (`ON CONFLICT ..`, `RETURNING ..`).
    fn sql(&self, tail: &str) -> String {
        let slots: Vec<String> = (1..=self.values.len()).map(|i| format!("${i}")).collect();
        format!(
            "INSERT INTO {} ({}) VALUES ({}){tail}",
            self.table,
            self.columns.join(", "),
            slots.join(", ")
        )
    }

    async fn execute(
        &self,
        tx: &mut sqlx::Transaction<'_, Any>,
        tail: &str,
    ) -> Result<(), sqlx::Error> {
        let sql = self.sql(tail);
        bound(sqlx::query(&sql), &self.values)
            .execute(&mut **tx)
            .await?;
        Ok(())
    }
}

/// The mission and leg that already hold a ride with this content, if any.
pub async fn find_ride(archive: &Archive, sha256: &str) -> Result<Option<(i64, i64)>> {
    let row = sqlx::query("SELECT mission_id, leg FROM legs WHERE ride_sha256 = $1")
        .bind(sha256)
        .fetch_optional(archive.pool())
        .await?;
    Ok(match row {
        Some(r) => Some((r.try_get("mission_id")?, r.try_get("leg")?)),
        None => None,
    })
}

/// Adds a mission; returns its id.
pub async fn add(archive: &Archive, record: &MissionRecord<'_>) -> Result<i64> {
    for (i, leg) in record.legs.iter().enumerate() {
        if let Some(other) = record.legs[..i]
            .iter()
            .find(|l| l.ride.sha256 == leg.ride.sha256)
        {
            bail!(
                "{}: the same ride as {} (identical content): a ride is one leg",
                leg.ride.input,
                other.ride.input
            );
        }
        if let Some((mission, at)) = find_ride(archive, &leg.ride.sha256).await? {
            bail!(
                "{}: already archived as leg {at} of mission {mission} (identical content, \
                 SHA-256 {}); nothing was added (`supine archive remove {mission}` first to \
                 add it again)",
                leg.ride.input,
                &leg.ride.sha256[..12]
            );
        }
    }
    let r = record.report;
    let m = &r.mission;
    let meta = &record.meta;
    let mut tx = archive.pool().begin().await?;
    let mission = Insert::into("missions")
        .set("added_at", Timestamp::now().to_string().as_str())
        .set("start_time", record.start.map(|t| t.to_string()))
        .set("start_epoch_s", record.start.map(epoch_s))
        .set("vehicle", meta.vehicle.clone())
        .set("crew", meta.crew.clone())
        .set("driver", meta.driver.clone())
        .set("route", meta.route.clone())
        .set("position", meta.position.clone())
        .set("origin", meta.origin.clone())
        .set("destination", meta.destination.clone())
        .set("patient_id", meta.patient.clone())
        .set("encounter_id", meta.encounter.clone())
        .set("model_name", r.model.name.as_str())
        .set("params_identity", r.model.identity.as_str())
        .set("height_m", r.subject.height_m)
        .set("mass_kg", r.subject.mass_kg)
        .set("duration_s", m.duration_s)
        .exposure(
            [m.vector.rms_m_s2, m.vector.mtvv_m_s2, m.vector.vdv_m_s175],
            m.time_at_level_s,
            m.max_level,
        )
        .set("mission_json", record.mission_json.to_string().as_str());
    let sql = mission.sql(" RETURNING id");
    let id: i64 = bound(sqlx::query(&sql), &mission.values)
        .fetch_one(&mut *tx)
        .await?
        .try_get("id")?;
    for tag in &meta.tags {
        Insert::into("mission_tags")
            .set("mission_id", id)
            .set("tag", tag.as_str())
            .execute(&mut tx, "")
            .await?;
    }
    for j in &m.joints {
        let values = [
            j.rms,
            j.max_running_rms,
            j.largest_excursion,
            j.largest_excursion_at_mission_s,
        ];
        joint(id, 0, (j.output, j.unit), values)
            .execute(&mut tx, "")
            .await?;
    }
    for (i, (leg, stored)) in r.legs.iter().zip(&record.legs).enumerate() {
        let n = i as i64 + 1;
        let v = &leg.vector;
        Insert::into("legs")
            .set("mission_id", id)
            .set("leg", n)
            .set("input", stored.ride.input.as_str())
            .set("ride_sha256", stored.ride.sha256.as_str())
            .set("ride_bytes", stored.ride.bytes as i64)
            .set("ride_content", stored.ride.content.clone())
            .set("duration_s", leg.duration_s)
            .set("start_s", leg.start_s)
            .set("peak_m_s2", v.peak_m_s2)
            .exposure(
                [v.rms_m_s2, v.mtvv_m_s2, v.vdv_m_s175],
                leg.time_at_level_s,
                leg.max_level,
            )
            .set("leg_json", stored.json.to_string().as_str())
            .set(
                "data_quality_json",
                stored.data_quality.as_ref().map(Value::to_string),
            )
            .execute(&mut tx, "")
            .await
            .map_err(|e| duplicate_or(e, &stored.ride.input))?;
        for (seq, a) in leg.alerts.iter().enumerate() {
            Insert::into("alerts")
                .set("mission_id", id)
                .set("leg", n)
                .set("seq", seq as i64)
                .set("mission_time_s", a.mission_time_s)
                .set("kind", a.kind)
                .set("event", a.event.as_str())
                .set("raised", i64::from(a.raised))
                .set("criterion", a.criterion.map(|c| c.name().to_string()))
                .set("value", a.criterion.map(|c| c.value().1))
                .set("value_unit", a.criterion.map(|c| c.unit().to_string()))
                .set("running_rms_m_s2", a.running_rms_m_s2)
                .set("vdv_m_s175", a.vdv_m_s175)
                .execute(&mut tx, "")
                .await?;
        }
        for j in &leg.joints {
            let values = [
                j.rms,
                j.max_running_rms,
                j.largest_excursion,
                j.largest_excursion_at_s,
            ];
            joint(id, n, (j.output, j.unit), values)
                .execute(&mut tx, "")
                .await?;
        }
        for (seq, p) in stored.passes.iter().enumerate() {
            let s = &p.segment;
            // The place is kept once, where its first pass put it.
            Insert::into("road_segments")
                .set("cell_row", p.cell.row)
                .set("cell_column", p.cell.column)
                .set("lat_deg", s.lat_deg)
                .set("lon_deg", s.lon_deg)
                .execute(&mut tx, " ON CONFLICT (cell_row, cell_column) DO NOTHING")
                .await?;
            Insert::into("segment_passes")
                .set("mission_id", id)
                .set("leg", n)
                .set("seq", seq as i64)
                .set("cell_row", p.cell.row)
                .set("cell_column", p.cell.column)
                .set("start_s", s.start_s)
                .set("end_s", s.end_s)
                .set("lat_deg", s.lat_deg)
                .set("lon_deg", s.lon_deg)
                .set("length_m", s.length_m)
                .set("speed_m_s", s.speed_m_s)
                .set("rms_m_s2", s.rms_m_s2)
                .set("vdv_m_s175", s.vdv_m_s175)
                .set("max_running_rms_m_s2", s.max_running_rms_m_s2)
                .execute(&mut tx, "")
                .await?;
        }
        let s = &stored.seconds;
        Insert::into("leg_seconds")
            .set("mission_id", id)
            .set("leg", n)
            .set("seconds", s.rows() as i64)
            .set("columns", s.columns.join(",").as_str())
            .set("series", Some(s.to_blob()))
            .execute(&mut tx, "")
            .await?;
    }
    if let Some(ms) = std::env::var(STALL_ENV)
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
    {
        eprintln!(
            "supine: archive: holding mission {id}'s transaction open for {ms} ms ({STALL_ENV})"
        );
        tokio::time::sleep(Duration::from_millis(ms)).await;
    }
    tx.commit().await.context("committing the mission")?;
    Ok(id)
}

/// A row of `joints`: an output's values over leg `leg` (0: the mission) of mission `id`.
fn joint(
    id: i64,
    leg: i64,
    (output, unit): (&str, &str),
    [rms, max_running_rms, largest, at_s]: [f64; 4],
) -> Insert {
    Insert::into("joints")
        .set("mission_id", id)
        .set("leg", leg)
        .set("output", output)
        .set("unit", unit)
        .set("rms", rms)
        .set("max_running_rms", max_running_rms)
        .set("largest_excursion", largest)
        .set("largest_excursion_at_s", at_s)
}

/// A unique-index violation on a ride's hash as the message a user can act on.
fn duplicate_or(e: sqlx::Error, input: &str) -> anyhow::Error {
    match &e {
        sqlx::Error::Database(d) if d.is_unique_violation() => anyhow!(
            "{input}: already archived (identical content, added by another process at the \
             same moment); nothing was added"
        ),
        _ => e.into(),
    }
}

/// A ride of a listed mission.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RideSummary {
    /// The path it was added from.
    pub input: String,
    /// SHA-256 of its content, hex.
    pub sha256: String,
    /// Its size, bytes.
    pub size_bytes: i64,
    /// Whether the archive holds a copy.
    pub copied: bool,
}

impl RideSummary {
    /// From a row of `legs` with `input`, `ride_sha256`, `ride_bytes` and `copied` (0 or 1).
    fn of(row: &AnyRow) -> Result<Self> {
        Ok(Self {
            input: row.try_get("input")?,
            sha256: row.try_get("ride_sha256")?,
            size_bytes: row.try_get("ride_bytes")?,
            copied: row.try_get::<i64, _>("copied")? != 0,
        })
    }
}

/// The patient's height and mass (as `report --json`'s `"subject"`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SubjectSummary {
    /// m.
    pub height_m: f64,
    /// kg.
    pub mass_kg: f64,
}

/// The model (as `report --json`'s `"model"`, without the thresholds).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelSummary {
    /// A preset's name or the parameter file.
    pub name: String,
    /// The parameter set's identity.
    pub identity: String,
}

/// One mission as `archive list --json` gives it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionSummary {
    /// Its id.
    pub id: i64,
    /// When it was added (UTC).
    pub added_at: String,
    /// Its metadata (`start` in UTC).
    #[serde(flatten)]
    pub meta: MissionMeta,
    /// The patient's size.
    pub subject: SubjectSummary,
    /// The model.
    pub model: ModelSummary,
    /// Its rides, in leg order.
    pub rides: Vec<RideSummary>,
    /// `report --json`'s `"mission"` object, as the report wrote it.
    pub mission: Value,
}

/// The missions that `filter` selects, oldest start first (missions without a start
/// last, by id).
pub async fn list(archive: &Archive, filter: &Filter) -> Result<Vec<MissionSummary>> {
    let (clause, binds) = filter.clause();
    let sql = format!(
        "SELECT m.* FROM missions m{clause} ORDER BY m.start_epoch_s IS NULL, \
         m.start_epoch_s, m.id"
    );
    let rows = bound(sqlx::query(&sql), &binds)
        .fetch_all(archive.pool())
        .await?;
    let mut tags: HashMap<i64, Vec<String>> = HashMap::new();
    for row in sqlx::query("SELECT mission_id, tag FROM mission_tags ORDER BY mission_id, tag")
        .fetch_all(archive.pool())
        .await?
    {
        tags.entry(row.try_get("mission_id")?)
            .or_default()
            .push(row.try_get("tag")?);
    }
    let mut rides: HashMap<i64, Vec<RideSummary>> = HashMap::new();
    for row in sqlx::query(
        "SELECT mission_id, input, ride_sha256, ride_bytes, \
         CASE WHEN ride_content IS NULL THEN 0 ELSE 1 END AS copied \
         FROM legs ORDER BY mission_id, leg",
    )
    .fetch_all(archive.pool())
    .await?
    {
        rides
            .entry(row.try_get("mission_id")?)
            .or_default()
            .push(RideSummary::of(&row)?);
    }
    rows.iter()
        .map(|row| {
            let id: i64 = row.try_get("id")?;
            summary(
                row,
                tags.remove(&id).unwrap_or_default(),
                rides.remove(&id).unwrap_or_default(),
            )
        })
        .collect()
}

fn summary(row: &AnyRow, tags: Vec<String>, rides: Vec<RideSummary>) -> Result<MissionSummary> {
    let mission: String = row.try_get("mission_json")?;
    let id: i64 = row.try_get("id")?;
    let [vehicle, crew, driver, route] = group_keys(row)?;
    Ok(MissionSummary {
        id,
        added_at: row.try_get("added_at")?,
        meta: MissionMeta {
            start: row.try_get("start_time")?,
            vehicle,
            crew,
            driver,
            route,
            position: row.try_get("position")?,
            origin: row.try_get("origin")?,
            destination: row.try_get("destination")?,
            tags,
            patient: row.try_get("patient_id")?,
            encounter: row.try_get("encounter_id")?,
        },
        subject: SubjectSummary {
            height_m: row.try_get("height_m")?,
            mass_kg: row.try_get("mass_kg")?,
        },
        model: ModelSummary {
            name: row.try_get("model_name")?,
            identity: row.try_get("params_identity")?,
        },
        rides,
        mission: serde_json::from_str(&mission)
            .with_context(|| format!("mission {id}: its stored values are not JSON"))?,
    })
}

/// The columns missions are grouped by, in [`FleetRow::keys`]' order: vehicle, crew,
/// driver, route.
fn group_keys(row: &AnyRow) -> Result<[Option<String>; 4]> {
    Ok([
        row.try_get("vehicle")?,
        row.try_get("crew")?,
        row.try_get("driver")?,
        row.try_get("route")?,
    ])
}

/// A leg's per-second series as `show --json` gives it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LegSeconds {
    /// The columns.
    pub columns: Vec<String>,
    /// One row a second.
    pub rows: Vec<Vec<f32>>,
}

/// One mission in full, as `archive show --json` gives it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionDetail {
    /// What `list` gives.
    #[serde(flatten)]
    pub summary: MissionSummary,
    /// `report --json`'s `"legs"`, as the report wrote them.
    pub legs: Vec<Value>,
    /// Each leg's per-second series.
    pub seconds: Vec<LegSeconds>,
}

/// Mission `id` in full.
pub async fn show(archive: &Archive, id: i64) -> Result<MissionDetail> {
    let row = sqlx::query("SELECT m.* FROM missions m WHERE m.id = $1")
        .bind(id)
        .fetch_optional(archive.pool())
        .await?
        .ok_or_else(|| not_found(archive, id))?;
    let tags = sqlx::query("SELECT tag FROM mission_tags WHERE mission_id = $1 ORDER BY tag")
        .bind(id)
        .fetch_all(archive.pool())
        .await?
        .iter()
        .map(|r| r.try_get("tag"))
        .collect::<Result<Vec<String>, _>>()?;
    let leg_rows = sqlx::query(
        "SELECT l.input, l.ride_sha256, l.ride_bytes, l.leg_json, \
         CASE WHEN l.ride_content IS NULL THEN 0 ELSE 1 END AS copied, \
         s.seconds, s.columns, s.series \
         FROM legs l JOIN leg_seconds s ON s.mission_id = l.mission_id AND s.leg = l.leg \
         WHERE l.mission_id = $1 ORDER BY l.leg",
    )
    .bind(id)
    .fetch_all(archive.pool())
    .await?;
    let mut rides = Vec::new();
    let mut legs = Vec::new();
    let mut seconds = Vec::new();
    for r in &leg_rows {
        rides.push(RideSummary::of(r)?);
        let text: String = r.try_get("leg_json")?;
        legs.push(serde_json::from_str(&text)?);
        let columns: String = r.try_get("columns")?;
        let n: i64 = r.try_get("seconds")?;
        let blob: Vec<u8> = r.try_get("series")?;
        let s = SecondSeries::from_blob(&columns, n.max(0) as usize, &blob)
            .with_context(|| format!("mission {id}"))?;
        let width = s.columns.len().max(1);
        seconds.push(LegSeconds {
            rows: s.values.chunks(width).map(<[f32]>::to_vec).collect(),
            columns: s.columns,
        });
    }
    Ok(MissionDetail {
        summary: summary(&row, tags, rides)?,
        legs,
        seconds,
    })
}

fn not_found(archive: &Archive, id: i64) -> anyhow::Error {
    anyhow!(
        "mission {id}: not in the archive {} (`supine archive list` lists them)",
        archive.location().display()
    )
}

/// Removes mission `id` and everything stored with it.
pub async fn remove(archive: &Archive, id: i64) -> Result<()> {
    let mut tx = archive.pool().begin().await?;
    for table in [
        "segment_passes",
        "leg_seconds",
        "joints",
        "alerts",
        "legs",
        "mission_tags",
    ] {
        sqlx::query(&format!("DELETE FROM {table} WHERE mission_id = $1"))
            .bind(id)
            .execute(&mut *tx)
            .await?;
    }
    let gone = sqlx::query("DELETE FROM missions WHERE id = $1")
        .bind(id)
        .execute(&mut *tx)
        .await?
        .rows_affected();
    if gone == 0 {
        return Err(not_found(archive, id));
    }
    tx.commit().await?;
    Ok(())
}

/// The numbers of one mission that the fleet view groups.
#[derive(Clone, Debug, PartialEq)]
pub struct FleetRow {
    /// Its id.
    pub id: i64,
    /// Its start (UTC), when given.
    pub start: Option<String>,
    /// Its start, s since 1970 (UTC), when given.
    pub start_epoch_s: Option<f64>,
    /// Vehicle, crew, driver, route.
    pub keys: [Option<String>; 4],
    /// Its length, s.
    pub duration_s: f64,
    /// The head's vector VDV over the mission, m/s^1.75.
    pub vdv_m_s175: f64,
    /// Its MTVV, m/s^2.
    pub mtvv_m_s2: f64,
    /// Its highest level.
    pub max_level: String,
    /// Seconds at warning.
    pub warning_s: f64,
    /// Seconds at alarm.
    pub alarm_s: f64,
    /// The mission's largest excursion of each joint output: output, unit, value.
    pub joints: Vec<(String, String, f64)>,
}

/// The fleet view's rows for `filter`, oldest first.
pub async fn fleet_rows(archive: &Archive, filter: &Filter) -> Result<Vec<FleetRow>> {
    let (clause, binds) = filter.clause();
    let sql = format!(
        "SELECT m.id, m.start_time, m.start_epoch_s, m.vehicle, m.crew, m.driver, m.route, \
         m.duration_s, m.vdv_m_s175, m.mtvv_m_s2, m.max_level, m.warning_s, m.alarm_s \
         FROM missions m{clause} ORDER BY m.start_epoch_s IS NULL, m.start_epoch_s, m.id"
    );
    let rows = bound(sqlx::query(&sql), &binds)
        .fetch_all(archive.pool())
        .await?;
    let joint_sql = format!(
        "SELECT j.mission_id, j.output, j.unit, j.largest_excursion FROM joints j \
         JOIN missions m ON m.id = j.mission_id{} j.leg = 0 ORDER BY j.mission_id, j.output",
        if clause.is_empty() {
            " WHERE".to_string()
        } else {
            format!("{clause} AND")
        }
    );
    let mut joints: HashMap<i64, Vec<(String, String, f64)>> = HashMap::new();
    for r in bound(sqlx::query(&joint_sql), &binds)
        .fetch_all(archive.pool())
        .await?
    {
        joints.entry(r.try_get("mission_id")?).or_default().push((
            r.try_get("output")?,
            r.try_get("unit")?,
            r.try_get("largest_excursion")?,
        ));
    }
    rows.iter()
        .map(|r| {
            let id: i64 = r.try_get("id")?;
            Ok(FleetRow {
                id,
                start: r.try_get("start_time")?,
                start_epoch_s: r.try_get("start_epoch_s")?,
                keys: group_keys(r)?,
                duration_s: r.try_get("duration_s")?,
                vdv_m_s175: r.try_get("vdv_m_s175")?,
                mtvv_m_s2: r.try_get("mtvv_m_s2")?,
                max_level: r.try_get("max_level")?,
                warning_s: r.try_get("warning_s")?,
                alarm_s: r.try_get("alarm_s")?,
                joints: joints.remove(&id).unwrap_or_default(),
            })
        })
        .collect()
}

/// The number of missions in the archive.
pub async fn count(archive: &Archive) -> Result<i64> {
    Ok(sqlx::query("SELECT COUNT(*) AS n FROM missions")
        .fetch_one(archive.pool())
        .await?
        .try_get("n")?)
}

/// The places passed by the missions `filter` selects, with their passes and the head's
/// exposure there, worst (highest rms) first.
pub async fn road_segments(archive: &Archive, filter: &Filter) -> Result<Vec<RoadSegment>> {
    let (clause, binds) = filter.clause();
    let sql = format!(
        "SELECT p.cell_row, p.cell_column, s.lat_deg, s.lon_deg, COUNT(*) AS passes, \
         COUNT(DISTINCT p.mission_id) AS missions, \
         SUM(p.rms_m_s2 * p.rms_m_s2 * (p.end_s - p.start_s)) AS energy, \
         SUM(p.end_s - p.start_s) AS seconds, MAX(p.rms_m_s2) AS max_rms \
         FROM segment_passes p JOIN missions m ON m.id = p.mission_id \
         JOIN road_segments s ON s.cell_row = p.cell_row AND s.cell_column = p.cell_column{clause} \
         GROUP BY p.cell_row, p.cell_column, s.lat_deg, s.lon_deg"
    );
    let mut segments = bound(sqlx::query(&sql), &binds)
        .fetch_all(archive.pool())
        .await?
        .iter()
        .map(|r| {
            Ok(RoadSegment::from_sums(
                Cell {
                    row: r.try_get("cell_row")?,
                    column: r.try_get("cell_column")?,
                },
                (r.try_get("lat_deg")?, r.try_get("lon_deg")?),
                (r.try_get("passes")?, r.try_get("missions")?),
                r.try_get("energy")?,
                r.try_get("seconds")?,
                r.try_get("max_rms")?,
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    segments.sort_by(|a, b| b.rms_m_s2.total_cmp(&a.rms_m_s2).then(a.cell.cmp(&b.cell)));
    Ok(segments)
}
