//! The host's integration tests, one module per file, in one binary (a binary per file
//! linked the whole tool each time). Each file's own documentation says what it checks;
//! `cargo test -p supine-host --test host NAME::` runs one file's tests.
//! `hostile_files.rs` is a binary of its own (host/Cargo.toml says why).

#[path = "archive/main.rs"]
mod archive;
mod calibrate_cli;
mod cli_conventions;
mod common;
mod docs_numbers;
mod exposure_cli;
mod exposure_joints;
mod exposure_resample;
mod flash_serial;
mod identification_fit;
mod identification_inputs;
mod identification_jacobian;
mod identification_pipeline;
mod identification_recovery;
mod identification_robustness;
mod identification_spectral;
mod identification_uncertainty;
mod install;
mod json_output;
mod model_cli;
mod module_layers;
mod monitor_args;
mod monitor_serial;
mod output_names;
mod predict_joints;
mod predict_ride;
mod report_band;
mod report_mission;
mod report_route;
mod report_streamed;
mod ride_clocks;
mod ride_profiles;
mod test_files_declared;
mod weighting_cli;
