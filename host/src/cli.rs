//! Argument parsing and dispatch for the `supine` command line.
//!
//! Each subcommand lives in its own module under `commands/`; this file only names them.
//! Errors print as one line, `supine: <what>`, and exit non-zero.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::commands;

/// Predict the vibration reaching a supine patient's head from a litter-frame accelerometer.
#[derive(Debug, Parser)]
#[command(name = "supine", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `supine`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Write the model's transmissibility H(f), all 27 components, as CSV.
    Model(commands::model::Args),
    /// Print the model's modes: frequency, damping ratio, subsystem, reachability.
    Modes(commands::modes::Args),
    /// Print a parameter file (TOML) for a preset or a fitted file.
    Params(commands::params::Args),
    /// Write the response of the device's ISO 2631-1 weighting filter (Wk, Wd, Wj) as CSV.
    Weighting(commands::weighting::Args),
    /// Write a synthetic dataset (recordings and true parameters) from the model.
    Synth(commands::synth::Args),
    /// Estimate a dataset's transmissibility (H1, Welch) per subject or as a geometric mean.
    Transmissibility(commands::transmissibility::Args),
    /// Fit the model's parameters to a dataset (rigid: all 42; litter: the 18 contacts).
    Fit(commands::fit::Args),
    /// Predict the sensor accelerations for a recording's support acceleration.
    Predict(commands::predict::Args),
    /// Compare predicted and measured sensor accelerations of a recording (rms, R^2).
    Validate(commands::validate::Args),
    /// ISO 2631-1 exposure of a recording: predicted head (model) or one channel (no model).
    Exposure(commands::exposure::Args),
    /// Write a realistic litter-frame ride (ambulance, rough road, helicopter, lab) as CSV.
    Ride(commands::ride::Args),
    /// Mission report of rides (legs) for a patient: report.html and --json.
    Report(commands::report::Args),
    /// Replay a recording through the firmware in QEMU; write its telemetry as CSV.
    Replay(commands::replay::Args),
    /// Follow a device live (serial port, or the firmware in QEMU fed a ride); log to CSV.
    Monitor(commands::monitor::Args),
    /// Print the `[device.mounting]` calibration for an accelerometer reading at rest.
    Calibrate(commands::calibrate::Args),
    /// Put parameters on a device: QEMU region image, signed upload over serial, probe-rs.
    Flash(commands::flash::Args),
    /// The whole product on this machine: ride, firmware in QEMU, monitor, check, HTML report.
    Demo(commands::demo::Args),
}

/// Parses the process arguments, runs the command and maps errors to a one-line message.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("supine: {}", one_line(&err));
            ExitCode::FAILURE
        }
    }
}

/// Runs one parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Model(args) => commands::model::run(&args),
        Command::Modes(args) => commands::modes::run(&args),
        Command::Params(args) => commands::params::run(&args),
        Command::Weighting(args) => commands::weighting::run(&args),
        Command::Synth(args) => commands::synth::run(&args),
        Command::Transmissibility(args) => commands::transmissibility::run(&args),
        Command::Fit(args) => commands::fit::run(&args),
        Command::Predict(args) => commands::predict::run(&args),
        Command::Validate(args) => commands::validate::run(&args),
        Command::Exposure(args) => commands::exposure::run(&args),
        Command::Ride(args) => commands::ride::run(&args),
        Command::Report(args) => commands::report::run(&args),
        Command::Replay(args) => commands::replay::run(&args),
        Command::Monitor(args) => commands::monitor::run(&args),
        Command::Calibrate(args) => commands::calibrate::run(&args),
        Command::Flash(args) => commands::flash::run(&args),
        Command::Demo(args) => commands::demo::run(&args),
    }
}

/// Joins an error and its causes into a single line.
pub fn one_line(err: &anyhow::Error) -> String {
    let mut parts: Vec<String> = Vec::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if !parts.iter().any(|p| p.contains(&text)) {
            parts.push(text);
        }
    }
    parts.join(": ").replace('\n', " ")
}
