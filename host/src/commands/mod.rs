//! One module per `supine` subcommand.

pub mod band_args;
pub mod calibrate;
pub mod completions;
pub mod demo;
pub mod exposure;
pub mod fit;
pub mod flash;
pub mod json_output;
pub mod model;
pub mod modes;
pub mod monitor;
pub mod params;
pub mod predict;
pub mod replay;
pub mod report;
pub mod ride;
pub mod synth;
pub mod transmissibility;
pub mod validate;
pub mod values;
pub mod verify;
pub mod weighting;
