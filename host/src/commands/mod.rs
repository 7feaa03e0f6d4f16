//! One module per `supine` subcommand.

pub mod model;
pub mod modes;
pub mod params;
