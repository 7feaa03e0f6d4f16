//! Rides from the loggers people carry (phones, IMUs, the project's own files), whatever
//! their clock, rate, units and orientation, with an account of their data's quality
//! (`docs/exposure.md#rides-from-phones-and-loggers`).
//!
//! - [`clock`]: the time column in s, ms, us, ns or date-time text.
//! - [`formats`]: the exports recognized from their headers.
//! - [`regular`]: rows dropped (duplicates, steps back, sample-and-hold), gaps, and the
//!   interpolation onto a uniform grid.
//! - [`level`]: levelling by the ride's own gravity.
//! - [`position`]: the track of position fixes, checked and interpolated to samples.
//! - [`quality`]: the data-quality account and its verdict.
//! - [`units`]: the acceleration columns' unit.
//! - [`resample`]: the band-limited, zero-phase resampler.
//! - [`conditioned`]: the passes over a ride that give its uniform, levelled samples.
//! - [`scratch_rows`]: a ride's rows parsed once, kept in a scratch file for the passes
//!   after the scan.

pub mod clock;
pub mod conditioned;
pub mod formats;
pub mod level;
pub mod position;
pub mod quality;
pub mod regular;
pub mod resample;
pub mod scratch_rows;
pub mod units;
