//! The archive's connection: sqlx's Any driver over SQLite or PostgreSQL, so that every
//! query is written once and runs on both (`docs/archive.md` says why sqlx). The commands
//! are synchronous; a current-thread tokio runtime runs each query to completion.
//!
//! SQLite runs in WAL mode with a busy timeout, so that a reader never blocks a writer and
//! two processes adding at once wait for each other instead of failing; foreign keys are
//! enforced on both.

use std::future::Future;
use std::time::Duration;

use anyhow::{Context as _, Result, anyhow};
use sqlx::AnyPool;
use sqlx::any::AnyPoolOptions;

use crate::archive::location::Location;
use crate::archive::schema;

/// How long a SQLite writer waits for another's transaction before giving up, ms.
pub const SQLITE_BUSY_TIMEOUT_MS: u32 = 30_000;

/// Which database an archive is on (the few places where their SQL differs ask this).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// A SQLite file.
    Sqlite,
    /// A PostgreSQL database.
    Postgres,
}

/// An open archive: its schema is this program's (an older one was migrated on opening).
pub struct Archive {
    runtime: tokio::runtime::Runtime,
    pool: AnyPool,
    backend: Backend,
    location: Location,
}

impl Archive {
    /// Opens (creating a SQLite file and its folder when missing) and migrates to the
    /// current schema; refuses an archive of a newer schema.
    pub fn open(location: &Location) -> Result<Self> {
        let archive = Self::connect(location)?;
        archive.run(schema::migrate(&archive, schema::CURRENT_VERSION))?;
        Ok(archive)
    }

    /// Opens without migrating past `version` (for tests of the migrations: an archive as
    /// an older supine left it).
    pub fn open_at_version(location: &Location, version: i64) -> Result<Self> {
        let archive = Self::connect(location)?;
        archive.run(schema::migrate(&archive, version))?;
        Ok(archive)
    }

    fn connect(location: &Location) -> Result<Self> {
        sqlx::any::install_default_drivers();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .context("starting the database runtime")?;
        let (url, backend) = match location {
            Location::Sqlite(path) => {
                if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                    std::fs::create_dir_all(dir)
                        .with_context(|| format!("{}: cannot create the folder", dir.display()))?;
                }
                (sqlite_url(path)?, Backend::Sqlite)
            }
            Location::Postgres(url) => (url.clone(), Backend::Postgres),
        };
        let options = AnyPoolOptions::new()
            .max_connections(1)
            .acquire_timeout(Duration::from_secs(60))
            .after_connect(move |conn, _| {
                Box::pin(async move {
                    if backend == Backend::Sqlite {
                        for pragma in [
                            "PRAGMA journal_mode = WAL".to_string(),
                            format!("PRAGMA busy_timeout = {SQLITE_BUSY_TIMEOUT_MS}"),
                            "PRAGMA foreign_keys = ON".to_string(),
                        ] {
                            sqlx::query(&pragma).execute(&mut *conn).await?;
                        }
                    }
                    Ok(())
                })
            });
        let pool = runtime
            .block_on(options.connect(&url))
            .map_err(|e| anyhow!("{}: cannot open the archive: {e}", location.display()))?;
        Ok(Self {
            runtime,
            pool,
            backend,
            location: location.clone(),
        })
    }

    /// Runs a query (or several) to completion.
    pub fn run<T>(&self, work: impl Future<Output = T>) -> T {
        self.runtime.block_on(work)
    }

    /// The connection pool.
    pub fn pool(&self) -> &AnyPool {
        &self.pool
    }

    /// The database it is on.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Where it is.
    pub fn location(&self) -> &Location {
        &self.location
    }
}

impl Drop for Archive {
    fn drop(&mut self) {
        // Closing checkpoints SQLite's WAL and ends a PostgreSQL session cleanly.
        let pool = self.pool.clone();
        self.runtime.block_on(pool.close());
    }
}

/// A `sqlite://` URL for `path`, created when missing; the characters that a URL gives a
/// meaning to are percent-encoded.
fn sqlite_url(path: &std::path::Path) -> Result<String> {
    let text = path
        .to_str()
        .ok_or_else(|| anyhow!("{}: the archive's path is not UTF-8", path.display()))?;
    let mut encoded = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '%' | '?' | '#' | ' ' => encoded.push_str(&format!("%{:02X}", c as u32)),
            c => encoded.push(c),
        }
    }
    Ok(format!("sqlite://{encoded}?mode=rwc"))
}
