//! supine-host: the workstation side of supine.
//!
//! A library with a thin command line on top (`supine`), so every command is testable
//! in-process. The numbers themselves come from `supine-core`, the same code the device runs.

pub mod cli;
pub mod commands;
pub mod h_csv;
pub mod output;
pub mod params_file;
