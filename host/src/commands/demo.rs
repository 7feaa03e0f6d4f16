//! `supine demo`: build, ride, flash, run in QEMU, monitor, check against the host, and
//! write `DIR/report.html` (see [`crate::demo`]).

use std::io::IsTerminal as _;
use std::path::PathBuf;

use anyhow::Result;

use crate::demo::ride::DemoProfile;
use crate::demo::{self, DEFAULT_OUT_DIR, DemoConfig};
use crate::io::subject_args::SubjectArgs;
use crate::monitor::view::{LiveView, PlainView, View};

/// Arguments of `supine demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder: report.html and the CSV files it was made from.
    #[arg(long, value_name = "DIR", default_value = DEFAULT_OUT_DIR)]
    pub out: PathBuf,
    /// The ride (road-trip: paved road, rough road with shocks, paved road again).
    #[arg(long, value_enum, default_value_t = DemoProfile::RoadTrip)]
    pub profile: DemoProfile,
    /// Length of the ride, s (at 500 Hz the device in QEMU runs about 4 times real time).
    #[arg(long, default_value_t = 60.0)]
    pub duration_s: f64,
    /// Seed of the ride's random draws: the same seed gives the same ride and report numbers.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stream the ride in real time (otherwise as fast as the device takes it).
    #[arg(long)]
    pub realtime: bool,
    /// The patient (else the paper's mean subject, 1.82 m, 81 kg).
    #[command(flatten)]
    pub subject: SubjectArgs,
}

/// Runs the demo: step lines and the summary on standard output, the live view on
/// standard error; Ctrl-C stops QEMU and removes its folder.
pub fn run(args: &Args) -> Result<()> {
    // Ctrl-C, SIGTERM and SIGHUP: QEMU stopped and its folder removed on the way out.
    let stop = crate::device::signals::stop_flag();
    let config = DemoConfig {
        out_dir: args.out.clone(),
        profile: args.profile,
        duration_s: args.duration_s,
        seed: args.seed,
        realtime: args.realtime,
        subject: args.subject,
    };
    let stderr = std::io::stderr();
    let mut view: Box<dyn View> = if stderr.is_terminal() {
        Box::new(LiveView::new(stderr)?)
    } else {
        Box::new(PlainView::new(stderr))
    };
    let mut announce = |line: &str| println!("{line}");
    let outcome = demo::run(&config, &mut announce, view.as_mut(), &stop);
    drop(view);
    let outcome = outcome?;
    print!("{}", outcome.summary.to_text(&outcome.data));
    println!("report: {}", outcome.report.display());
    Ok(())
}
