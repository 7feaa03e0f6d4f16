//! `supine replay`: a recording through the device image in QEMU, telemetry to CSV.

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use supine_core::blob::TelemetryConfig;

use crate::commands::json_output;
use crate::device::device_records::ReplaySummary;
use crate::device::image::ProductImage;
use crate::device::replay::replay;
use crate::device::scratch::ScratchDir;
use crate::io::params_file::ModelSource;
use crate::io::ride_input::{RideInputArgs, open_stream};
use crate::io::stdout::print_text;
use crate::io::subject_args::SubjectArgs;
use crate::io::telemetry_csv::{events_path, write_events, write_telemetry_streamed};
use crate::monitor::patient_text;
use crate::schema::subject::SubjectRecord;

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
    /// Count instructions (QEMU -icount) and print `instructions_per_sample: N` (the
    /// device's stack high-water mark, `stack_used_bytes: N`, is printed either way).
    #[arg(long)]
    pub icount: bool,
    /// Telemetry every this many samples. Replay compares samples, so it overrides the
    /// file's `telemetry_decimation` (which `supine flash` uses) with this.
    #[arg(long, value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u16).range(1..))]
    pub telemetry_decimation: u16,
    /// Run this firmware ELF instead of the image built into supine (development).
    #[arg(long, value_name = "ELF")]
    pub firmware: Option<PathBuf>,
    /// Print the result as one JSON object on standard output.
    #[arg(long)]
    pub json: bool,
}

/// Replays and writes the CSVs; Ctrl-C stops QEMU, removes its socket folder and says how
/// far the device had got.
pub fn run(args: &Args) -> Result<()> {
    if !args.qemu {
        bail!("give --qemu: replay runs the firmware in QEMU (no hardware target yet)");
    }
    let mut file = args.model.load()?;
    args.subject.apply(&mut file)?;
    // A full recording or a `supine ride` file (platform columns only), checked whole
    // first, then streamed: a ride of any length fits in memory. Another logger's file or
    // --remove-gravity: converted into a scratch folder first.
    let scratch = ScratchDir::new("ride")?;
    let frame = file.device.unwrap_or_default().sensor_frame();
    let ride = open_stream(&args.ride, &args.input, &frame, scratch.path())?;
    let kernel = ProductImage::select(args.firmware.as_deref())?;
    // Ctrl-C, SIGTERM and SIGHUP: QEMU stopped and its folder removed on the way out.
    let stop = crate::device::signals::stop_flag();
    let telemetry = TelemetryConfig {
        decimation: args.telemetry_decimation,
    };
    let total = ride.len() as u64;
    let mut progress = Progress::new(total, ride.sample_rate_hz());
    let mut records = 0usize;
    let mut processed = 0u64;
    let joint_mask = file.device.unwrap_or_default().joint_outputs.mask;
    let result = write_telemetry_streamed(&args.out, ride.sample_rate_hz(), joint_mask, |emit| {
        replay(
            &kernel,
            &file,
            &ride,
            telemetry,
            args.icount,
            &stop,
            &mut |t| {
                records += 1;
                processed = u64::from(t.sample_index) + 1;
                progress.update(processed);
                emit(t)
            },
        )
    });
    progress.finish();
    let result = match result {
        Ok(r) => r,
        Err(_) if stop.load(Ordering::Relaxed) => {
            bail!("interrupted after {processed} of {total} samples")
        }
        Err(e) => return Err(e),
    };
    let s = &result.session;
    let events = events_path(&args.out);
    write_events(&events, &s.events, result.sample_rate_hz)?;
    let raised = s.events.iter().filter(|e| e.is_raise()).count();
    let ride_s = result.samples as f64 / result.sample_rate_hz;
    let elapsed_s = s.elapsed.as_secs_f64();
    // The patient as the device itself reports it (its status), not as this host built it.
    let device = s.status();
    if args.json {
        return json_output::print(&ReplaySummary {
            samples: result.samples,
            sample_rate_hz: result.sample_rate_hz,
            ride_duration_s: ride_s,
            elapsed_s,
            real_time_factor: ride_s / elapsed_s,
            telemetry_records: records,
            telemetry_decimation: args.telemetry_decimation,
            lost_frames: s.link.lost_frames,
            bad_frames: s.link.bad_frames,
            alerts_raised: raised,
            subject: SubjectRecord::new(device.height_m, device.mass_kg),
            stack_used_bytes: s.status().stack_used_bytes,
            telemetry_csv: args.out.clone(),
            events_csv: events,
            instructions_per_sample: args.icount.then(|| s.instructions_per_sample()),
        });
    }
    let mut printed = String::new();
    if args.icount {
        printed += &format!(
            "instructions_per_sample: {:.0}\n",
            s.instructions_per_sample()
        );
    }
    // The device's own stack high-water mark: with the statics, its whole RAM use.
    printed += &format!("stack_used_bytes: {}\n", s.status().stack_used_bytes);
    print_text(&printed)?;
    eprintln!(
        "replayed {} samples in {elapsed_s:.1} s ({:.1}x real time) for a {}: {} telemetry records, frames lost {}, bad {}, alerts raised {}; wrote {} and {}",
        result.samples,
        ride_s / elapsed_s,
        patient_text(device.height_m, device.mass_kg),
        records,
        s.link.lost_frames,
        s.link.bad_frames,
        raised,
        args.out.display(),
        events.display()
    );
    Ok(())
}

/// How often the plain progress line is printed when standard error is not a terminal.
const PLAIN_PROGRESS_EVERY: Duration = Duration::from_secs(10);

/// How often the bar's rate is recomputed.
const BAR_RATE_EVERY: Duration = Duration::from_millis(500);

/// The replay's progress on standard error: a bar (samples, rate, ETA) on a terminal,
/// else a line every [`PLAIN_PROGRESS_EVERY`], so a log of a long ride shows it moving.
enum Progress {
    Bar {
        bar: indicatif::ProgressBar,
        sample_rate_hz: f64,
        started: Instant,
        next: Instant,
    },
    Lines {
        total: u64,
        sample_rate_hz: f64,
        started: Instant,
        next: Instant,
    },
}

impl Progress {
    fn new(total: u64, sample_rate_hz: f64) -> Self {
        if !std::io::stderr().is_terminal() {
            let started = Instant::now();
            return Self::Lines {
                total,
                sample_rate_hz,
                started,
                next: started + PLAIN_PROGRESS_EVERY,
            };
        }
        let bar = indicatif::ProgressBar::new(total);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "replay {bar:30} {human_pos}/{human_len} samples, {msg}, ETA {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let started = Instant::now();
        Self::Bar {
            bar,
            sample_rate_hz,
            started,
            next: started + BAR_RATE_EVERY,
        }
    }

    /// `done` samples have been processed by the device.
    fn update(&mut self, done: u64) {
        match self {
            Self::Bar {
                bar,
                sample_rate_hz,
                started,
                next,
            } => {
                bar.set_position(done);
                let now = Instant::now();
                if now >= *next {
                    *next = now + BAR_RATE_EVERY;
                    let rate = done as f64 / now.duration_since(*started).as_secs_f64();
                    bar.set_message(format!(
                        "{rate:.0} samples/s ({:.1}x real time)",
                        rate / *sample_rate_hz
                    ));
                }
            }
            Self::Lines {
                total,
                sample_rate_hz,
                started,
                next,
            } => {
                let now = Instant::now();
                if now < *next {
                    return;
                }
                *next = now + PLAIN_PROGRESS_EVERY;
                let elapsed_s = now.duration_since(*started).as_secs_f64();
                let rate = done as f64 / elapsed_s;
                let eta_s = total.saturating_sub(done) as f64 / rate.max(1.0);
                eprintln!(
                    "replay: {done} of {total} samples ({:.0}%), {rate:.0} samples/s ({:.1}x real time), ETA {eta_s:.0} s",
                    100.0 * done as f64 / (*total).max(1) as f64,
                    rate / *sample_rate_hz,
                );
            }
        }
    }

    fn finish(&self) {
        if let Self::Bar { bar, .. } = self {
            bar.finish_and_clear();
        }
    }
}
