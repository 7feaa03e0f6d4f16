//! The archive's schema and its versioned migrations (the tables are described in
//! `docs/archive.md`).
//!
//! Migration `n` takes an archive from version `n - 1` to `n`; the version is kept in
//! `archive_schema`. Opening an older archive runs the missing migrations in one
//! transaction, under a lock that a second process opening it at the same moment waits
//! for (PostgreSQL: an advisory lock; SQLite: the write lock); an archive of a newer
//! version than this program's is refused, never written.
//!
//! The SQL is the same on both databases except three type spellings, written as
//! `{id}`, `{blob}` and `{real}` and filled in per database by [`ddl`].

use anyhow::{Result, anyhow, bail};
use sqlx::Row as _;

use crate::archive::db::{Archive, Backend};

/// The schema this program writes.
pub const CURRENT_VERSION: i64 = 3;

/// The migrations, in order: `MIGRATIONS[n - 1]` makes version `n`.
pub const MIGRATIONS: [&[&str]; 3] = [V1, V2, V3];

/// Version 1: missions with their metadata and values, legs with their rides' hashes,
/// alert events, joint outputs, per-second series and tags.
const V1: &[&str] = &[
    "CREATE TABLE missions (
        id {id},
        added_at TEXT NOT NULL,
        start_time TEXT,
        start_epoch_s {real},
        vehicle TEXT,
        crew TEXT,
        driver TEXT,
        route TEXT,
        position TEXT,
        origin TEXT,
        destination TEXT,
        patient_id TEXT,
        encounter_id TEXT,
        model_name TEXT NOT NULL,
        params_identity TEXT NOT NULL,
        height_m {real} NOT NULL,
        mass_kg {real} NOT NULL,
        duration_s {real} NOT NULL,
        rms_m_s2 {real} NOT NULL,
        mtvv_m_s2 {real} NOT NULL,
        vdv_m_s175 {real} NOT NULL,
        normal_s {real} NOT NULL,
        advisory_s {real} NOT NULL,
        warning_s {real} NOT NULL,
        alarm_s {real} NOT NULL,
        max_level TEXT NOT NULL,
        mission_json TEXT NOT NULL
    )",
    "CREATE INDEX missions_start ON missions (start_epoch_s)",
    "CREATE INDEX missions_vehicle ON missions (vehicle, start_epoch_s)",
    "CREATE INDEX missions_crew ON missions (crew, start_epoch_s)",
    "CREATE INDEX missions_driver ON missions (driver, start_epoch_s)",
    "CREATE INDEX missions_route ON missions (route, start_epoch_s)",
    "CREATE TABLE mission_tags (
        mission_id BIGINT NOT NULL REFERENCES missions (id) ON DELETE CASCADE,
        tag TEXT NOT NULL,
        PRIMARY KEY (mission_id, tag)
    )",
    "CREATE INDEX mission_tags_tag ON mission_tags (tag)",
    "CREATE TABLE legs (
        mission_id BIGINT NOT NULL REFERENCES missions (id) ON DELETE CASCADE,
        leg BIGINT NOT NULL,
        input TEXT NOT NULL,
        ride_sha256 TEXT NOT NULL,
        ride_bytes BIGINT NOT NULL,
        ride_content {blob},
        duration_s {real} NOT NULL,
        start_s {real} NOT NULL,
        rms_m_s2 {real} NOT NULL,
        mtvv_m_s2 {real} NOT NULL,
        vdv_m_s175 {real} NOT NULL,
        peak_m_s2 {real} NOT NULL,
        normal_s {real} NOT NULL,
        advisory_s {real} NOT NULL,
        warning_s {real} NOT NULL,
        alarm_s {real} NOT NULL,
        max_level TEXT NOT NULL,
        leg_json TEXT NOT NULL,
        PRIMARY KEY (mission_id, leg)
    )",
    "CREATE UNIQUE INDEX legs_ride ON legs (ride_sha256)",
    "CREATE TABLE alerts (
        mission_id BIGINT NOT NULL REFERENCES missions (id) ON DELETE CASCADE,
        leg BIGINT NOT NULL,
        seq BIGINT NOT NULL,
        mission_time_s {real} NOT NULL,
        kind TEXT NOT NULL,
        event TEXT NOT NULL,
        raise BIGINT NOT NULL,
        criterion TEXT,
        value {real},
        value_unit TEXT,
        running_rms_m_s2 {real} NOT NULL,
        vdv_m_s175 {real} NOT NULL,
        PRIMARY KEY (mission_id, leg, seq)
    )",
    "CREATE TABLE joints (
        mission_id BIGINT NOT NULL REFERENCES missions (id) ON DELETE CASCADE,
        leg BIGINT NOT NULL,
        output TEXT NOT NULL,
        unit TEXT NOT NULL,
        rms {real} NOT NULL,
        max_running_rms {real} NOT NULL,
        largest_excursion {real} NOT NULL,
        largest_excursion_at_s {real} NOT NULL,
        PRIMARY KEY (mission_id, leg, output)
    )",
    "CREATE TABLE leg_seconds (
        mission_id BIGINT NOT NULL REFERENCES missions (id) ON DELETE CASCADE,
        leg BIGINT NOT NULL,
        seconds BIGINT NOT NULL,
        columns TEXT NOT NULL,
        series {blob} NOT NULL,
        PRIMARY KEY (mission_id, leg)
    )",
];

/// Version 2: each leg's data-quality account, and where it happened: places (road
/// segments keyed by a cell of about 50 m, `archive::road`) and each pass of a leg over
/// one with the head's exposure there (`report --json`'s `"route"` segments).
const V2: &[&str] = &[
    "ALTER TABLE legs ADD COLUMN data_quality_json TEXT",
    "CREATE TABLE road_segments (
        cell_lat BIGINT NOT NULL,
        cell_lon BIGINT NOT NULL,
        lat_deg {real} NOT NULL,
        lon_deg {real} NOT NULL,
        PRIMARY KEY (cell_lat, cell_lon)
    )",
    "CREATE TABLE segment_passes (
        mission_id BIGINT NOT NULL REFERENCES missions (id) ON DELETE CASCADE,
        leg BIGINT NOT NULL,
        seq BIGINT NOT NULL,
        cell_lat BIGINT NOT NULL,
        cell_lon BIGINT NOT NULL,
        start_s {real} NOT NULL,
        end_s {real} NOT NULL,
        lat_deg {real} NOT NULL,
        lon_deg {real} NOT NULL,
        length_m {real} NOT NULL,
        speed_m_s {real} NOT NULL,
        rms_m_s2 {real} NOT NULL,
        vdv_m_s175 {real} NOT NULL,
        max_running_rms_m_s2 {real} NOT NULL,
        PRIMARY KEY (mission_id, leg, seq),
        FOREIGN KEY (cell_lat, cell_lon) REFERENCES road_segments (cell_lat, cell_lon)
    )",
    "CREATE INDEX segment_passes_cell ON segment_passes (cell_lat, cell_lon)",
];

/// Version 3: the columns named as the outputs name them (`docs/architecture.md`, the
/// output vocabulary): an alert that raises is `raised` (as in `report --json`), a
/// place's cell is its `cell_row` and `cell_column` (as `fleet --json`'s `"cell"`), not
/// a latitude and longitude. Both databases rename a column in place, keeping its key,
/// index and foreign key.
const V3: &[&str] = &[
    "ALTER TABLE alerts RENAME COLUMN raise TO raised",
    "ALTER TABLE segment_passes RENAME COLUMN cell_lat TO cell_row",
    "ALTER TABLE segment_passes RENAME COLUMN cell_lon TO cell_column",
    "ALTER TABLE road_segments RENAME COLUMN cell_lat TO cell_row",
    "ALTER TABLE road_segments RENAME COLUMN cell_lon TO cell_column",
];

/// A migration statement in `backend`'s spelling.
pub fn ddl(statement: &str, backend: Backend) -> String {
    let (id, blob) = match backend {
        Backend::Sqlite => ("INTEGER PRIMARY KEY AUTOINCREMENT", "BLOB"),
        Backend::Postgres => (
            "BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY",
            "BYTEA",
        ),
    };
    statement
        .replace("{id}", id)
        .replace("{blob}", blob)
        .replace("{real}", "DOUBLE PRECISION")
}

/// The archive's schema version (0 for an empty database).
pub async fn version(archive: &Archive) -> Result<i64> {
    let exists = match archive.backend() {
        Backend::Sqlite => {
            "SELECT COUNT(*) AS n FROM sqlite_master WHERE type = 'table' AND name = 'archive_schema'"
        }
        Backend::Postgres => {
            "SELECT COUNT(*) AS n FROM information_schema.tables \
             WHERE table_schema = current_schema() AND table_name = 'archive_schema'"
        }
    };
    let n: i64 = sqlx::query(exists)
        .fetch_one(archive.pool())
        .await?
        .try_get("n")?;
    if n == 0 {
        return Ok(0);
    }
    let row = sqlx::query("SELECT MAX(version) AS v FROM archive_schema")
        .fetch_one(archive.pool())
        .await?;
    Ok(row.try_get::<Option<i64>, _>("v")?.unwrap_or(0))
}

/// Brings the archive to `target` (at most [`CURRENT_VERSION`]); refuses one newer than
/// this program.
pub async fn migrate(archive: &Archive, target: i64) -> Result<()> {
    let found = version(archive).await.map_err(|e| {
        anyhow!(
            "{}: cannot read the schema version: {e}",
            archive.location().display()
        )
    })?;
    refuse_newer(archive, found)?;
    if found >= target {
        return Ok(());
    }
    let mut tx = archive.pool().begin().await?;
    // Take the lock first, then read the version again: a second process opening the same
    // new archive waits here and then finds it migrated.
    match archive.backend() {
        Backend::Postgres => {
            sqlx::query("SELECT pg_advisory_xact_lock(2631)")
                .execute(&mut *tx)
                .await?;
            sqlx::query("CREATE TABLE IF NOT EXISTS archive_schema (version BIGINT NOT NULL)")
                .execute(&mut *tx)
                .await?;
        }
        Backend::Sqlite => {
            // A write as the transaction's first statement takes SQLite's write lock.
            sqlx::query("CREATE TABLE IF NOT EXISTS archive_schema (version BIGINT NOT NULL)")
                .execute(&mut *tx)
                .await?;
            sqlx::query("DELETE FROM archive_schema WHERE version < 0")
                .execute(&mut *tx)
                .await?;
        }
    }
    let row = sqlx::query("SELECT MAX(version) AS v FROM archive_schema")
        .fetch_one(&mut *tx)
        .await?;
    let current = row.try_get::<Option<i64>, _>("v")?.unwrap_or(0);
    refuse_newer(archive, current)?;
    for (n, statements) in MIGRATIONS
        .iter()
        .enumerate()
        .map(|(i, s)| (i as i64 + 1, s))
        .filter(|(n, _)| *n > current && *n <= target)
    {
        for statement in *statements {
            sqlx::query(&ddl(statement, archive.backend()))
                .execute(&mut *tx)
                .await
                .map_err(|e| anyhow!("migrating the archive to version {n}: {e}"))?;
        }
    }
    if current < target {
        sqlx::query("DELETE FROM archive_schema")
            .execute(&mut *tx)
            .await?;
        sqlx::query("INSERT INTO archive_schema (version) VALUES ($1)")
            .bind(target)
            .execute(&mut *tx)
            .await?;
    }
    tx.commit().await?;
    Ok(())
}

fn refuse_newer(archive: &Archive, found: i64) -> Result<()> {
    if found > CURRENT_VERSION {
        bail!(
            "{}: the archive has schema version {found}, newer than this supine's \
             ({CURRENT_VERSION}): use a newer supine (the archive was left unchanged)",
            archive.location().display()
        );
    }
    Ok(())
}
