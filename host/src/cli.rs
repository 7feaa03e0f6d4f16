//! Argument parsing and dispatch for the `supine` command line.
//!
//! Each subcommand lives in its own module under `commands/`; this file only names them.
//! Errors print as one line, `supine: <what>`, and exit non-zero.

use std::ffi::OsString;
use std::process::ExitCode;

use clap::{CommandFactory, Parser, Subcommand};

use crate::commands;

/// What `supine --help` says first: what the tool is, and where to start.
const ABOUT: &str = "supine: predicts the vibration reaching a supine patient's head from an \
accelerometer on the litter frame, evaluates it as ISO 2631-1 exposure, and runs the device \
firmware that raises the alerts (in QEMU or on a board).\n\n\
Start with `supine demo`: it generates a ride, runs the firmware in QEMU, follows it live \
and writes an HTML report.";

/// The command line of `supine`.
#[derive(Debug, Parser)]
#[command(
    name = "supine",
    version,
    about = ABOUT,
    after_help = ENVIRONMENT_HELP
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Every environment variable the tool reads (the README's "Environment" lists the same).
pub const ENVIRONMENT_HELP: &str = "\
Example:
  supine demo --out supine-demo

Environment:
  SUPINE_ARCHIVE_STALL_MS  for tests only: archive add holds its transaction open this long
  SUPINE_QEMU       the QEMU program for --qemu, demo and monitor (default: qemu-system-arm on PATH)
  SUPINE_STATE_DIR  where flash keeps its last update counter (default: $XDG_STATE_HOME/supine,
                    else $HOME/.local/state/supine)
  TMPDIR            where QEMU runs get their private scratch folders, and where a ride
                    keeps the rows it parsed while a command reads it (default: /tmp)";

/// The subcommands of `supine`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Write the model's transmissibility H(f), all 27 components, as CSV.
    #[command(after_help = "Example:\n  supine model --preset paper-litter --out h.csv")]
    Model(commands::model::Args),
    /// Print the model's modes: frequency, damping ratio, subsystem, reachability.
    #[command(after_help = "Example:\n  supine modes --preset paper-litter")]
    Modes(commands::modes::Args),
    /// Print a parameter file (TOML) for a preset or a fitted file.
    #[command(after_help = "Example:\n  supine params --preset paper-litter > my-params.toml")]
    Params(commands::params::Args),
    /// Write the response of the device's ISO 2631-1 weighting filter (Wk, Wd, Wj) as CSV.
    #[command(after_help = "Example:\n  supine weighting --weighting wk --out wk.csv")]
    Weighting(commands::weighting::Args),
    /// Write a synthetic dataset (recordings and true parameters) from the model.
    #[command(after_help = "Example:\n  supine synth --out data --subjects 4")]
    Synth(commands::synth::Args),
    /// Estimate a dataset's transmissibility (H1, Welch) per subject or as a geometric mean.
    #[command(
        after_help = "Example:\n  supine transmissibility --dataset data --case rigid --exclude s1, s2 --out h.csv"
    )]
    Transmissibility(commands::transmissibility::Args),
    /// Fit the model's parameters to a dataset (rigid: all 42; litter: the 18 contacts).
    #[command(after_help = "Example:\n  supine fit --dataset data --case rigid --out fitted.toml")]
    Fit(commands::fit::Args),
    /// Predict the sensor accelerations for a recording's support acceleration.
    #[command(
        after_help = "Example:\n  supine predict --params fitted.toml --input data/s1_rigid.csv --out predicted.csv"
    )]
    Predict(commands::predict::Args),
    /// Compare predicted and measured sensor accelerations of a recording (rms, R^2).
    #[command(
        after_help = "Example:\n  supine validate --preset paper-rigid --input data/s1_rigid.csv"
    )]
    Validate(commands::validate::Args),
    /// ISO 2631-1 exposure of a recording: predicted head (model) or one channel (no model).
    #[command(after_help = "Example:\n  supine exposure --preset paper-litter --input ride.csv")]
    Exposure(commands::exposure::Args),
    /// Write a realistic litter-frame ride (ambulance, rough road, helicopter, lab) as CSV.
    #[command(after_help = "Example:\n  supine ride --profile road-trip --out ride.csv")]
    Ride(commands::ride::Args),
    /// Mission report of rides (legs) for a patient: report.html and --json.
    #[command(
        after_help = "Example:\n  supine report --preset paper-litter --input ambulance.csv --input helicopter.csv --out mission"
    )]
    Report(commands::report::Args),
    /// Keep missions in an archive (SQLite or PostgreSQL): add, list, show, remove, fleet, export.
    #[command(
        after_help = "Example:\n  supine archive add --preset paper-litter --input ride.csv --vehicle A1 --route A9"
    )]
    Archive(commands::archive::Args),
    /// Replay a recording through the firmware in QEMU; write its telemetry as CSV.
    #[command(
        after_help = "Example:\n  supine replay --qemu --preset paper-litter --input ride.csv --out device.csv"
    )]
    Replay(commands::replay::Args),
    /// ISO 8041-1 verification of the firmware in QEMU at each rate; a conformance report.
    #[command(after_help = "Example:\n  supine verify --qemu --fs 500 --out conformance")]
    Verify(commands::verify::Args),
    /// Follow a device live (serial port, or the firmware in QEMU fed a ride); log to CSV.
    #[command(
        after_help = "Example:\n  supine monitor --qemu --preset paper-litter --profile road-trip"
    )]
    Monitor(commands::monitor::Args),
    /// Print the `[device.mounting]` table for a reading at rest, or `[device.calibration]` from a tumble test.
    #[command(after_help = "Example:\n  supine calibrate --at-rest-m-s2 0.12, -0.05, 9.80")]
    Calibrate(commands::calibrate::Args),
    /// Put parameters on a device: QEMU region image, signed upload over serial, probe-rs.
    #[command(after_help = "Example:\n  supine flash --preset paper-litter --qemu")]
    Flash(commands::flash::Args),
    /// The whole product on this machine: ride, firmware in QEMU, monitor, check, HTML report.
    #[command(
        after_help = "Example:\n  supine demo --profile road-trip --duration-s 60 --out supine-demo"
    )]
    Demo(commands::demo::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    #[command(
        after_help = "Example:\n  supine completions bash > ~/.local/share/bash-completion/completions/supine"
    )]
    Completions(commands::completions::Args),
}

/// The arguments with a list split by the shell after its commas joined back into one
/// word: `--exclude s1, s2` and `--at-rest-m-s2 0.1, -0.2, 9.8` are read as if typed
/// without the spaces (a word ending in a comma, or one starting with a comma, continues
/// the list).
pub fn join_list_words(args: impl IntoIterator<Item = OsString>) -> Vec<OsString> {
    let mut joined: Vec<OsString> = Vec::new();
    let mut continues = false;
    for arg in args {
        let text = arg.to_string_lossy();
        let starts_with_comma = text.starts_with(',');
        let ends_with_comma = text.ends_with(',');
        match joined.last_mut() {
            Some(last) if continues || starts_with_comma => last.push(&arg),
            _ => joined.push(arg.clone()),
        }
        continues = ends_with_comma;
    }
    joined
}

/// Parses the process arguments, runs the command and maps errors to a one-line message.
pub fn main() -> ExitCode {
    let cli = Cli::parse_from(join_list_words(std::env::args_os()));
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) if crate::io::stdout::is_reader_gone(&err) => ExitCode::SUCCESS,
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
        Command::Archive(args) => commands::archive::run(&args),
        Command::Replay(args) => commands::replay::run(&args),
        Command::Verify(args) => commands::verify::run(&args),
        Command::Monitor(args) => commands::monitor::run(&args),
        Command::Calibrate(args) => commands::calibrate::run(&args),
        Command::Flash(args) => commands::flash::run(&args),
        Command::Demo(args) => commands::demo::run(&args),
        Command::Completions(args) => commands::completions::run(&args, Cli::command()),
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

#[cfg(test)]
mod tests {
    use super::*;

    fn joined(words: &[&str]) -> Vec<String> {
        join_list_words(words.iter().map(OsString::from))
            .into_iter()
            .map(|w| w.into_string().unwrap())
            .collect()
    }

    #[test]
    fn list_words_split_after_commas_are_joined_and_others_are_kept() {
        assert_eq!(
            joined(&["supine", "fit", "--exclude", "s1,", "s2", "--seed", "3"]),
            ["supine", "fit", "--exclude", "s1,s2", "--seed", "3"]
        );
        assert_eq!(
            joined(&[
                "calibrate",
                "--at-rest-m-s2",
                "0.1",
                ",-0.2",
                ", 9.8",
                "--json"
            ]),
            ["calibrate", "--at-rest-m-s2", "0.1,-0.2, 9.8", "--json"]
        );
        assert_eq!(joined(&["a", "b"]), ["a", "b"]);
    }
}
