//! `supine replay`: a recording through the device image in QEMU, telemetry to CSV.

use std::path::PathBuf;

use anyhow::{Result, bail};
use supine_core::blob::TelemetryConfig;

use crate::device::replay::replay;
use crate::io::params_file::ModelSource;
use crate::io::ride_input::{RideInputArgs, open_stream};
use crate::io::subject_args::SubjectArgs;
use crate::io::telemetry_csv::{events_path, write_events, write_telemetry_streamed};

/// Arguments of `supine replay`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Run the firmware in QEMU (mps2-an386); the only target for now.
    #[arg(long)]
    pub qemu: bool,
    /// The model parameters (and optional `[device]` table) to build the blob from.
    #[command(flatten)]
    pub model: ModelSource,
    /// The recording whose platform columns are streamed as samples.
    #[arg(long, value_name = "RIDE.csv")]
    pub input: PathBuf,
    /// How to read the ride (another logger's columns and units, gravity).
    #[command(flatten)]
    pub ride: RideInputArgs,
    /// The patient (else the parameters' subject).
    #[command(flatten)]
    pub subject: SubjectArgs,
    /// Where to write the device's telemetry (events go to `<stem>.events.csv`).
    #[arg(long, value_name = "DEVICE.csv")]
    pub out: PathBuf,
    /// Count instructions (QEMU -icount) and print `instructions_per_sample: N`.
    #[arg(long)]
    pub icount: bool,
    /// Telemetry every this many samples. Replay compares samples, so it overrides the
    /// file's `telemetry_decimation` (which `supine flash` uses) with this.
    #[arg(long, value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u16).range(1..))]
    pub telemetry_decimation: u16,
}

/// Replays and writes the CSVs; Ctrl-C stops QEMU and removes its socket folder.
pub fn run(args: &Args) -> Result<()> {
    if !args.qemu {
        bail!("give --qemu: replay runs the firmware in QEMU (no hardware target yet)");
    }
    let mut file = args.model.load()?;
    args.subject.apply(&mut file)?;
    // A full recording or a `supine ride` file (platform columns only), checked whole
    // first, then streamed: a ride of any length fits in memory.
    // Another logger's file or --remove-gravity: converted into a scratch folder first.
    let scratch = tempfile::tempdir()?;
    let mounting = file.device.unwrap_or_default().mounting;
    let ride = open_stream(&args.ride, &args.input, &mounting, scratch.path())?;
    // Ctrl-C, SIGTERM and SIGHUP: QEMU stopped and its folder removed on the way out.
    let stop = crate::device::signals::stop_flag();
    let telemetry = TelemetryConfig {
        decimation: args.telemetry_decimation,
    };
    let mut records = 0usize;
    let result = write_telemetry_streamed(&args.out, ride.sample_rate_hz(), |emit| {
        replay(&file, &ride, telemetry, args.icount, &stop, &mut |t| {
            records += 1;
            emit(t)
        })
    })?;
    let s = &result.session;
    let events = events_path(&args.out);
    write_events(&events, &s.events, result.sample_rate_hz)?;
    if args.icount {
        println!(
            "instructions_per_sample: {:.0}",
            s.instructions_per_sample()
        );
    }
    let raised = s.events.iter().filter(|e| e.is_raise()).count();
    eprintln!(
        "replayed {} samples: {} telemetry records, frames lost {}, bad {}, alerts raised {}; wrote {} and {}",
        result.samples,
        records,
        s.link.lost_frames,
        s.link.bad_frames,
        raised,
        args.out.display(),
        events.display()
    );
    Ok(())
}
