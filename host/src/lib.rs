//! supine-host: the workstation side of supine.
//!
//! A library with a thin command line on top (`supine`), so every command is testable
//! in-process. The numbers themselves come from `supine-core`, the same code the device runs.

pub mod cli;
pub mod commands;
pub mod dataset;
pub mod demo;
pub mod device_params;
pub mod exposure_report;
pub mod firmware;
pub mod fit;
pub mod flash;
pub mod geomean;
pub mod h_csv;
pub mod link;
pub mod memory_map;
pub mod monitor;
pub mod output;
pub mod params_file;
pub mod plot;
pub mod qemu;
pub mod recording;
pub mod reference;
pub mod replay;
pub mod report;
pub mod resample;
pub mod ride;
pub mod signals;
pub mod spectral;
pub mod synth;
pub mod text_position;
pub mod upload_client;
pub mod validate;
