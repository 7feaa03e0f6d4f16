//! `supine demo`: build, ride, flash, run in QEMU, monitor, check against the host, and
//! write `DIR/report.html` (see [`crate::demo`]).

use std::io::IsTerminal as _;
use std::path::PathBuf;

use anyhow::Result;
use supine_core::model::Preset;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::demo::demo_record::DemoRecord;
use crate::demo::demo_ride::DemoProfile;
use crate::demo::{self, DEFAULT_OUT_DIR, DemoConfig};
use crate::io::params_file::{self, ParamFile, PresetArg};
use crate::io::stdout::{print_line, print_text};
use crate::io::subject_args::SubjectArgs;
use crate::monitor::color::ColorFlag;
use crate::monitor::view::{LiveView, PlainView, View};

/// Arguments of `supine demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// `--color`.
    #[command(flatten)]
    pub color: ColorFlag,
    /// Output folder: report.html and the CSV files it was made from. A folder holding
    /// files the demo did not write is refused (see --force).
    #[arg(long, value_name = "DIR", default_value = DEFAULT_OUT_DIR)]
    pub out: PathBuf,
    /// Write into --out even if it holds files the demo did not write (those are kept;
    /// the demo's own files are replaced).
    #[arg(long)]
    pub force: bool,
    /// The ride (road-trip: paved road, rough road with shocks, paved road again).
    #[arg(long, value_enum, default_value_t = DemoProfile::RoadTrip)]
    pub profile: DemoProfile,
    /// Length of the ride, s (at 500 Hz the device in QEMU runs about 4 times real time).
    #[arg(long, default_value_t = values::DEFAULT_DURATION_S)]
    pub duration_s: f64,
    /// Seed of the ride's random draws: the same seed gives the same ride and report numbers.
    #[arg(long, default_value_t = values::DEFAULT_SEED)]
    pub seed: u64,
    /// Stream the ride in real time (otherwise as fast as the device takes it).
    #[arg(long)]
    pub realtime: bool,
    /// Run this firmware ELF instead of the image built into supine (development).
    #[arg(long, value_name = "ELF")]
    pub firmware: Option<PathBuf>,
    /// One of the paper's parameter sets to flash (default: paper-litter).
    #[arg(long, value_enum, conflicts_with = "params")]
    pub preset: Option<PresetArg>,
    /// A parameter file (TOML; its optional `[device]` table sets the weighting, the
    /// alert thresholds and the sensor checks) to flash instead.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Print the summary as one JSON object on standard output (the steps and the live
    /// view go to standard error).
    #[command(flatten)]
    pub json: JsonFlag,
    /// The patient (else the paper's mean subject, 1.82 m, 81 kg).
    #[command(flatten)]
    pub subject: SubjectArgs,
}

/// Runs the demo: step lines and the summary on standard output, the live view on
/// standard error; Ctrl-C stops QEMU and removes its folder.
pub fn run(args: &Args) -> Result<()> {
    let color = args.color.color;
    // Ctrl-C, SIGTERM and SIGHUP: QEMU stopped and its folder removed on the way out.
    let stop = crate::device::signals::stop_flag();
    let (model, model_name) = match (&args.params, args.preset) {
        (Some(path), _) => (params_file::load(path)?, path.display().to_string()),
        (None, preset) => {
            let preset = preset.map_or(demo::PRESET, Preset::from);
            (ParamFile::preset(preset), preset.name().to_string())
        }
    };
    let config = DemoConfig {
        model,
        model_name,
        out_dir: args.out.clone(),
        profile: args.profile,
        duration_s: args.duration_s,
        seed: args.seed,
        realtime: args.realtime,
        firmware: args.firmware.clone(),
        force: args.force,
        subject: args.subject,
    };
    let stderr = std::io::stderr();
    let mut view: Box<dyn View> = if stderr.is_terminal() {
        Box::new(LiveView::new(stderr, color.enabled_here(true))?)
    } else {
        Box::new(PlainView::new(stderr))
    };
    let json = args.json.json;
    let mut announce = |line: &str| {
        if json {
            eprintln!("{line}");
        } else {
            // A failure here shows again, and is reported, when the summary is printed.
            let _ = print_line(line);
        }
    };
    let outcome = demo::run(&config, &mut announce, view.as_mut(), &stop);
    drop(view);
    let outcome = outcome?;
    if json {
        return json_output::print(&DemoRecord::new(
            &outcome.summary,
            &outcome.report,
            args.profile,
            args.duration_s,
            args.seed,
        ));
    }
    print_text(&format!(
        "{}report: {}\n",
        outcome.summary.to_text(&outcome.data),
        outcome.report.display()
    ))
}
