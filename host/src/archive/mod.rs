//! The mission archive (`supine archive`): every mission's numbers kept in one database,
//! SQLite by default and PostgreSQL for a service whose stations share one archive, and
//! the views across missions (`docs/archive.md`).
//!
//! - [`location`]: where the archive is (`--archive PATH|URL`, or the user's data folder).
//! - [`db`]: the connection (sqlx's Any driver, the same SQL on both databases).
//! - [`schema`]: the versioned migrations.
//! - [`meta`]: a mission's metadata (flags and `--meta FILE.toml`).
//! - [`record`]: what `add` stores of a mission report.
//! - [`road`]: road segments across missions (places and passes).
//! - [`series`]: the per-second series kept for each leg.
//! - [`store`]: adding, listing, showing and removing missions.
//! - [`stats`]: quantiles, the median's interval and the two-group test.
//! - [`fleet`]: the fleet view's numbers; [`fleet_html`]: its page.
//! - [`fhir`]: a mission as a FHIR R4 Bundle of Observations.

pub mod db;
pub mod fhir;
pub mod fleet;
pub mod fleet_html;
pub mod location;
pub mod meta;
pub mod record;
pub mod road;
pub mod schema;
pub mod series;
pub mod stats;
pub mod store;
