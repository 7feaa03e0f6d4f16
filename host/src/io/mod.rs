//! The file formats the host reads and writes, and writing files safely.
//!
//! - [`output`]: every output file is written whole or not at all.
//! - [`output_folder`]: a folder a command writes, refused if it holds a user's files.
//! - [`text_position`]: line and column of a parse error.
//! - [`excerpt`]: quoting input in error messages, bounded and escaped.
//! - [`small_file`]: reading a file that cannot legitimately be large, with a size limit.
//! - [`csv_lines`]: reading a CSV file line by line, each line bounded.
//! - [`csv_blocks`]: a CSV file's data lines parsed on every core, in order.
//! - [`decimal`]: a number from a CSV cell, exactly as `fast_float2` reads it, faster.
//! - [`params_file`]: the parameter file (`--params`), TOML.
//! - [`device_table`]: its `[device]` table, and which key the device would refuse;
//!   [`joint_alerts_section`] its `[device.joint_alerts]`, [`calibration_section`] its
//!   `[device.calibration]`.
//! - [`dataset`]: a dataset folder (`dataset.toml` and its recordings).
//! - [`recording`]: the recording CSV (13 columns, or the platform columns of a ride).
//! - [`ride_input`]: a ride from any logger (`--columns`, units, gravity), for exposure and report.
//! - [`ride_rows`]: a checked ride read row by row, whatever its length (and other loggers' rows).
//! - [`track_file`]: position tracks: GPX, phone apps' location files, a ride's own columns.
//! - [`subject_args`]: `--height-m`, `--mass-kg`, the patient the model is scaled to.
//! - [`h_csv`]: the transmissibility CSV of `supine model` and `supine transmissibility`.
//! - [`telemetry_csv`]: a device's telemetry and alert events as CSV (replay, monitor, demo).
//! - [`monitor_session`]: the input and session files beside a monitor log, for re-analysis.
//! - [`stdout`]: printing on standard output; a closed pipe ends the command quietly.
//! - [`tumble_csv`]: the six orientations' readings of a static tumble test.
//! - [`wording`]: counts with their noun in printed summaries.

pub mod calibration_section;
pub mod csv_blocks;
pub mod csv_lines;
pub mod dataset;
pub mod decimal;
pub mod device_table;
pub mod excerpt;
pub mod h_csv;
pub mod joint_alerts_section;
pub mod monitor_session;
pub mod output;
pub mod output_folder;
pub mod params_file;
pub mod recording;
pub mod ride_input;
pub mod ride_rows;
pub mod small_file;
pub mod stdout;
pub mod subject_args;
pub mod telemetry_csv;
pub mod text_position;
pub mod track_file;
pub mod tumble_csv;
pub mod wording;
