//! `supine monitor`: follow a device live (a serial port, or the firmware in QEMU fed with
//! a ride), with a terminal panel or plain lines, and an optional CSV log.

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Result, anyhow, bail};
use clap::ArgGroup;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::demo::demo_ride::{DemoProfile, make};
use crate::device::scratch::ScratchDir;
use crate::io::params_file::{ModelSource, PresetArg};
use crate::io::ride_input::{RideInputArgs, open_stream};
use crate::io::subject_args::SubjectArgs;
use crate::monitor::color::ColorFlag;
use crate::monitor::json::{JsonlView, summary_json};
use crate::monitor::log::{LogFiles, MonitorLog};
use crate::monitor::session::{Ending, QemuRun, run_qemu, run_serial};
use crate::monitor::view::{LiveView, PlainView, View};

/// Arguments of `supine monitor`.
#[derive(Debug, clap::Args)]
#[command(group(ArgGroup::new("target").required(true).args(["serial", "qemu"])))]
pub struct Args {
    /// `--color`.
    #[command(flatten)]
    pub color: ColorFlag,
    /// A real device on this serial port (e.g. /dev/ttyUSB0); only listens.
    #[arg(long, value_name = "PORT")]
    pub serial: Option<String>,
    /// The serial port's baud rate: by default the Black Pill image's USART1 speed (telemetry
    /// at 500 Hz needs about 230 kbaud, more than 115,200 carries).
    #[arg(long, default_value_t = 921_600, requires = "serial")]
    pub baud: u32,
    /// The firmware in QEMU (mps2-an386), fed with a ride over its UART.
    #[arg(long)]
    pub qemu: bool,
    /// With --qemu: one of the paper's parameter sets for the blob.
    #[arg(long, value_enum, conflicts_with_all = ["params", "serial"])]
    pub preset: Option<PresetArg>,
    /// With --qemu: a parameter file (TOML; optional `[device]` table) for the blob.
    #[arg(long, value_name = "FILE", conflicts_with = "serial")]
    pub params: Option<PathBuf>,
    /// With --qemu: a recording whose platform columns are streamed as samples.
    #[arg(long, value_name = "RIDE.csv", conflicts_with_all = ["profile", "serial"])]
    pub input: Option<PathBuf>,
    /// With --input: how to read the ride (another logger's columns and units, gravity).
    #[command(flatten)]
    pub ride: RideInputArgs,
    /// With --qemu: the patient (else the parameters' subject).
    #[command(flatten)]
    pub subject: SubjectArgs,
    /// With --qemu: generate the ride instead (see `supine ride`).
    #[arg(long, value_enum, conflicts_with = "serial")]
    pub profile: Option<DemoProfile>,
    /// Length of the generated ride, s.
    #[arg(long, default_value_t = values::DEFAULT_DURATION_S, requires = "profile")]
    pub duration_s: f64,
    /// Seed of the generated ride.
    #[arg(long, default_value_t = values::DEFAULT_SEED, requires = "profile")]
    pub seed: u64,
    /// With --qemu: send the samples in real time (default: as fast as the device takes them).
    #[arg(long, requires = "qemu")]
    pub realtime: bool,
    /// With --qemu: run this firmware ELF instead of the image built into supine.
    #[arg(long, value_name = "ELF", requires = "qemu")]
    pub firmware: Option<PathBuf>,
    /// Log every telemetry record to FILE.csv and every alert event to FILE.events.csv
    /// (the formats of `supine replay`).
    #[arg(long, value_name = "FILE.csv")]
    pub log: Option<PathBuf>,
    /// Longest wait for the device's greeting, s (above 0, at most a day;
    /// `--greeting-timeout-s` is an older spelling).
    #[arg(long, value_name = "S", default_value_t = 10.0, value_parser = values::timeout_s,
          alias = "greeting-timeout-s")]
    pub timeout_s: f64,
    /// Print the closing summary as one JSON object on standard output (instead of a
    /// line on standard error).
    #[command(flatten)]
    pub json: JsonFlag,
    /// Stream one JSON object per telemetry record and per event on standard output,
    /// instead of the panel.
    #[arg(long, conflicts_with = "json")]
    pub jsonl: bool,
}

/// Runs the monitor until the ride ends (QEMU), Ctrl-C, or the link fails.
pub fn run(args: &Args) -> Result<()> {
    let color = args.color.color;
    let greeting_timeout = values::timeout("--timeout-s", args.timeout_s)?;
    let qemu_run = if args.qemu {
        Some(prepare_qemu(args, greeting_timeout)?)
    } else {
        None
    };
    // Ctrl-C, SIGTERM and SIGHUP: QEMU stopped and its folder removed on the way out.
    let stop = crate::device::signals::stop_flag();
    let mut log = args.log.as_deref().map(MonitorLog::create).transpose()?;
    let stdout = std::io::stdout();
    let mut view: Box<dyn View> = if args.jsonl {
        Box::new(JsonlView::new(stdout))
    } else if args.json.json {
        // stdout is the summary's; the panel or the lines go to stderr.
        let stderr = std::io::stderr();
        if stderr.is_terminal() {
            Box::new(LiveView::new(stderr, color.enabled_here(true))?)
        } else {
            Box::new(PlainView::new(stderr))
        }
    } else if stdout.is_terminal() {
        Box::new(LiveView::new(stdout, color.enabled_here(true))?)
    } else {
        Box::new(PlainView::new(stdout))
    };
    let result = match (&qemu_run, &args.serial) {
        (Some(run), _) => run_qemu(run, view.as_mut(), log.as_mut(), &stop),
        (None, Some(port)) => run_serial(
            port,
            args.baud,
            greeting_timeout,
            view.as_mut(),
            log.as_mut(),
            &stop,
        ),
        (None, None) => Err(anyhow!("give --serial PORT or --qemu")),
    };
    drop(view);
    let (monitor, ending) = match result {
        Ok(done) => done,
        Err(e) => {
            return Err(match log {
                Some(log) if log.rows() > 0 => {
                    let (t, _, _) = log.abandon();
                    e.context(format!("the log so far is in {}", t.display()))
                }
                Some(log) => {
                    log.discard();
                    e
                }
                None => e,
            });
        }
    };
    let written = log.map(MonitorLog::finish).transpose()?;
    if args.json.json {
        json_output::print(&summary_json(&monitor))?;
    } else {
        eprintln!("{}", monitor.summary());
    }
    if let Some(files) = written {
        eprintln!("{}", written_line(&files));
        if let Some(note) = input_note(&files) {
            eprintln!("supine monitor: {note}");
        }
    }
    match (ending, &qemu_run) {
        (Ending::Stopped, Some(run)) => bail!(
            "interrupted after {} of {} samples",
            monitor.latest().map_or(0, |t| t.sample_index + 1),
            run.samples.len()
        ),
        _ => Ok(()),
    }
}

/// The files a finished log wrote, in one line.
fn written_line(files: &LogFiles) -> String {
    let mut names = vec![
        files.telemetry.display().to_string(),
        files.events.display().to_string(),
        files.input.display().to_string(),
    ];
    if let Some((path, _)) = &files.session {
        names.push(path.display().to_string());
    }
    format!("wrote {}", names.join(", "))
}

/// What keeps the input file from being re-analysed as it is, if anything.
fn input_note(files: &LogFiles) -> Option<String> {
    let input = files.input.display();
    let Some((_, s)) = &files.session else {
        return Some(format!(
            "{input} is empty: the device never greeted, so no input stream was asked for"
        ));
    };
    if s.input_samples_lost > 0 || s.input_frames_bad > 0 {
        Some(format!(
            "the input stream lost {} samples ({} bad frames): {input} has gaps and \
             cannot be re-analysed",
            s.input_samples_lost, s.input_frames_bad
        ))
    } else if s.params_changed {
        Some(format!(
            "the device changed parameters during the session: {input} stops there"
        ))
    } else if s.input_samples == 0 {
        Some(format!("{input} is empty: the device sent no input stream"))
    } else {
        None
    }
}

/// The blob, the ride and the image for `--qemu`.
fn prepare_qemu(args: &Args, greeting_timeout: Duration) -> Result<QemuRun> {
    if args.preset.is_none() && args.params.is_none() {
        bail!("--qemu needs --preset NAME or --params FILE");
    }
    // The same source as other commands; optional here because --serial needs none.
    let model = ModelSource {
        preset: args.preset,
        params: args.params.clone(),
    };
    let mut file = model.load()?;
    args.subject.apply(&mut file)?;
    let (samples, sample_rate_hz) = match (&args.input, args.profile) {
        (Some(path), _) => {
            // Only the platform samples are kept (12 bytes each), not the whole recording.
            let scratch = ScratchDir::new("ride")?;
            let frame = file.device.unwrap_or_default().sensor_frame();
            let ride = open_stream(&args.ride, path, &frame, scratch.path())?;
            let samples = ride.samples()?.collect::<Result<Vec<_>, _>>()?;
            (samples, ride.sample_rate_hz())
        }
        (None, Some(profile)) => {
            let fs_hz = args.ride.fs_hz.unwrap_or(values::DEFAULT_SAMPLE_RATE_HZ);
            let ride = make(profile, args.duration_s, fs_hz, args.seed)?;
            (ride.samples(), ride.ride.sample_rate_hz)
        }
        (None, None) => bail!("--qemu needs a ride: --input RIDE.csv or --profile NAME"),
    };
    let kernel = crate::device::image::ProductImage::select(args.firmware.as_deref())?;
    QemuRun::new(
        kernel,
        &file,
        samples,
        sample_rate_hz,
        args.realtime,
        greeting_timeout,
    )
}
