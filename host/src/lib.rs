//! supine-host: the workstation side of supine.
//!
//! A library with a thin command line on top (`supine`), so every command is testable
//! in-process. The numbers themselves come from `supine-core`, the same code the device runs.
//!
//! The modules follow the architecture (`docs/architecture.md`): file formats ([`io`]),
//! identification of the model from measurements ([`identify`]), exposure of rides
//! ([`exposure`]), the device and the ways to reach it ([`device`]), the live monitor
//! ([`monitor`]), the end-to-end demo ([`demo`]), the mission report ([`report`]), the ISO 8041-1
//! self-verification ([`verify`]), the one plotting layer ([`plot`]), jobs over the cores
//! ([`parallel`]), the names every output uses ([`schema`]), and the command line
//! ([`cli`], [`commands`]) on top of them all.

pub mod cli;
pub mod commands;
pub mod demo;
pub mod device;
pub mod exposure;
pub mod identify;
pub mod io;
pub mod monitor;
pub mod parallel;
pub mod plot;
pub mod report;
pub mod ride;
pub mod schema;
pub mod verify;
