//! `supine demo`: the product end to end on one machine, with a report a user can read.
//!
//! Steps, each announced on one line: the firmware image (built into the tool, or
//! `--firmware`); make a ride
//! ([`demo_ride`], on the route of [`demo_track`], which the report's map draws); place the paper litter-board parameters in QEMU's PARAMS region (the
//! region image `supine flash` makes); run the image in QEMU with the ride streamed over
//! its UART, followed live by the monitor ([`crate::monitor`]) which logs the device's
//! telemetry and events to CSV; run the host's own computation on the same samples
//! ([`crate::exposure::reference`]: the device's f32 pipeline and the f64 model); write
//! the report: the mission report of `ride.csv` as `supine report` makes it
//! ([`crate::report`]), with the device's log (read back from the CSV files) beside the
//! host's as its device section ([`data`]); summarize ([`summary`]). Each step is a
//! function of its own below [`run`].
//!
//! The output folder gets `ride.csv`, `device.csv`, `device.events.csv`,
//! `device.input.csv` and `device.session.json` (what the device sent, as
//! `supine monitor --log` writes it), `host.csv` and `host.events.csv` (the host's reference), `params.toml`
//! (the parameters flashed) and `report.html`. A previous `report.html` is removed first,
//! so a failed run never leaves an older report that looks like this run's.

pub mod data;
pub mod demo_record;
pub mod demo_ride;
pub mod demo_track;
pub mod summary;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};
use supine_core::blob::DeviceParams;
use supine_core::model::Preset;

use crate::device::device_params::identity_hex;
use crate::device::flash;
use crate::device::image::ProductImage;
use crate::exposure::reference;
use crate::exposure::ride::ShockKind;
use crate::io::monitor_session::{input_path, session_path};
use crate::io::output_folder::{self, OutputFolder};
use crate::io::params_file::{self, DeviceSection, ParamFile};
use crate::io::recording::read_input;
use crate::io::ride_rows::{OpenRide, RideSource};
use crate::io::subject_args::SubjectArgs;
use crate::io::telemetry_csv::{event_records, telemetry_records, write_events, write_telemetry};
use crate::monitor::log::MonitorLog;
use crate::monitor::session::{Ending, QemuRun, run_qemu};
use crate::monitor::view::View;
use crate::monitor::{Monitor, device_line};
use crate::plot::Rgb;
use crate::plot::time_chart::{Band, Moment};
use crate::report::device_check::PassResult;
use crate::report::device_check::{DeviceLog, DeviceRun};
use crate::report::device_pass::{self, Session};
use crate::report::{self, MissionReport, page};
use crate::ride::position::Track;
use data::{DemoData, RunInfo};
use demo_ride::{DemoProfile, DemoRide};
use summary::Summary;

/// The output folder when none is given.
pub const DEFAULT_OUT_DIR: &str = "supine-demo";
/// The demo's sample rate, Hz (the device's default rate).
pub const SAMPLE_RATE_HZ: f64 = 500.0;
/// The parameters flashed unless told otherwise: the paper's litter-board case.
pub const PRESET: Preset = Preset::PaperLitter;
/// Shortest demo ride, s: the 5 s warm-up and something to evaluate after it.
pub const MIN_DURATION_S: f64 = 10.0;
/// Longest demo ride, s (an hour: about 15 minutes in QEMU).
pub const MAX_DURATION_S: f64 = 3600.0;
/// Number of steps announced.
pub const STEPS: usize = 7;
/// Shading of a rough stretch of road on the device section's charts.
const ROUGH_COLOR: Rgb = Rgb(255, 170, 60);

/// How to run the demo.
#[derive(Clone, Debug)]
pub struct DemoConfig {
    /// The output folder (created if missing).
    pub out_dir: PathBuf,
    /// The ride.
    pub profile: DemoProfile,
    /// Its length, s.
    pub duration_s: f64,
    /// Its seed.
    pub seed: u64,
    /// Stream the samples in real time (otherwise as fast as the device takes them).
    pub realtime: bool,
    /// A developer's firmware ELF instead of the image built into the tool.
    pub firmware: Option<PathBuf>,
    /// Write into an output folder that holds files the demo did not write.
    pub force: bool,
    /// The parameters to flash (telemetry is set to every sample, see `param_file`).
    pub model: ParamFile,
    /// What they are called in the steps and the report (a preset's name, a file's path).
    pub model_name: String,
    /// The patient the flashed model is scaled to (else the preset's mean subject).
    pub subject: SubjectArgs,
}

/// What a finished demo produced.
#[derive(Clone, Debug)]
pub struct DemoOutcome {
    /// The data behind the report.
    pub data: DemoData,
    /// The summary.
    pub summary: Summary,
    /// The report's path.
    pub report: PathBuf,
}

/// The files of a demo folder.
#[derive(Clone, Debug)]
pub struct DemoFiles {
    /// The ride's platform columns.
    pub ride: PathBuf,
    /// The parameter file flashed.
    pub params: PathBuf,
    /// The device's telemetry.
    pub device: PathBuf,
    /// The device's alert events.
    pub device_events: PathBuf,
    /// The device's input stream, as a ride.
    pub device_input: PathBuf,
    /// The device's session facts (parameters, patient, input stream).
    pub device_session: PathBuf,
    /// The host's reference telemetry.
    pub host: PathBuf,
    /// The host's reference events.
    pub host_events: PathBuf,
    /// The report.
    pub report: PathBuf,
}

impl DemoFiles {
    /// Every file, in the order they are listed above.
    pub fn all(&self) -> Vec<PathBuf> {
        [
            &self.ride,
            &self.params,
            &self.device,
            &self.device_events,
            &self.device_input,
            &self.device_session,
            &self.host,
            &self.host_events,
            &self.report,
        ]
        .into_iter()
        .cloned()
        .collect()
    }

    /// The files in `dir`.
    pub fn in_dir(dir: &Path) -> Self {
        Self {
            ride: dir.join("ride.csv"),
            params: dir.join("params.toml"),
            device: dir.join("device.csv"),
            device_events: dir.join("device.events.csv"),
            device_input: input_path(&dir.join("device.csv")),
            device_session: session_path(&dir.join("device.csv")),
            host: dir.join("host.csv"),
            host_events: dir.join("host.events.csv"),
            report: dir.join("report.html"),
        }
    }
}

/// Times a step and announces it on one line.
struct Steps<'a> {
    announce: &'a mut dyn FnMut(&str),
    times: Vec<(String, Duration)>,
    current: Option<(String, Instant)>,
}

impl Steps<'_> {
    fn start(&mut self, name: &str, text: &str) {
        self.finish();
        (self.announce)(&format!("[{}/{STEPS}] {text}", self.times.len() + 1));
        self.current = Some((name.to_string(), Instant::now()));
    }

    fn finish(&mut self) {
        if let Some((name, t)) = self.current.take() {
            self.times.push((name, t.elapsed()));
        }
    }
}

/// Runs the demo; `announce` gets each step's line, `view` shows the device live, `stop`
/// (Ctrl-C) ends the run early with an error, QEMU stopped and its folder removed.
pub fn run(
    config: &DemoConfig,
    announce: &mut dyn FnMut(&str),
    view: &mut dyn View,
    stop: &Arc<AtomicBool>,
) -> Result<DemoOutcome> {
    if !(MIN_DURATION_S..=MAX_DURATION_S).contains(&config.duration_s) {
        bail!(
            "--duration-s {}: expected {MIN_DURATION_S} to {MAX_DURATION_S} s",
            config.duration_s
        );
    }
    let (files, folder) = prepare_folder(&config.out_dir, config.force)?;
    // Listed before they are written, so that what a killed run leaves is known as the
    // demo's; a run that fails removes what it wrote.
    folder.write_or_undo(|folder| {
        folder.record(&files.all())?;
        run_in(config, &files, announce, view, stop)
    })
}

/// The demo's steps, writing into the claimed folder's `files`.
fn run_in(
    config: &DemoConfig,
    files: &DemoFiles,
    announce: &mut dyn FnMut(&str),
    view: &mut dyn View,
    stop: &Arc<AtomicBool>,
) -> Result<DemoOutcome> {
    let mut steps = Steps {
        announce,
        times: Vec::new(),
        current: None,
    };

    steps.start(
        "firmware",
        &match &config.firmware {
            Some(elf) => format!("firmware: {} (--firmware)", elf.display()),
            None => "firmware: the device image built into supine".to_owned(),
        },
    );
    let kernel = ProductImage::select(config.firmware.as_deref())?;

    steps.start(
        "ride",
        &format!(
            "ride: {}, {} s at {SAMPLE_RATE_HZ} Hz, seed {} -> {}",
            config.profile.name(),
            config.duration_s,
            config.seed,
            files.ride.display()
        ),
    );
    let ride = make_ride(config, &files.ride)?;
    let samples = ride.samples();

    let file = param_file(&config.model, &config.subject)?;
    // One build: the identity announced and checked is the one of the blob flashed.
    let (params, blob) = flash::device_blob(&file, SAMPLE_RATE_HZ)?;
    steps.start(
        "parameters",
        &format!(
            "parameters: {} (identity {}) into QEMU's PARAMS region, slot A -> {}",
            config.model_name,
            identity_hex(&params.identity),
            files.params.display()
        ),
    );
    params_file::save(&files.params, &file)?;
    let region = flash::qemu_region_image(&blob)?;

    steps.start(
        "device",
        &format!(
            "device: the firmware in QEMU (mps2-an386), {} samples over its UART{} -> {}",
            samples.len(),
            if config.realtime {
                " in real time"
            } else {
                ", as fast as it takes them"
            },
            files.device.display()
        ),
    );
    let qemu_run = QemuRun {
        kernel,
        blob: region,
        identity: params.identity,
        samples,
        sample_rate_hz: SAMPLE_RATE_HZ,
        realtime: config.realtime,
        greeting_timeout: Duration::from_secs(20),
        thresholds: params.alerts.config,
    };
    let monitor = run_device(&qemu_run, files, view, stop)?;

    steps.start(
        "host reference",
        &format!(
            "host reference: the same samples through the device's code (f32) and the f64 model -> {}",
            files.host.display()
        ),
    );
    host_reference(&params, &qemu_run.samples, files)?;
    let (pass, session) = device_pass(&params, &file, &qemu_run.samples, files)?;

    steps.start("report", &format!("report: {}", files.report.display()));
    let track = demo_track::track(&ride);
    let report = report::build(
        std::slice::from_ref(&files.ride),
        WithTrack {
            track: (!track.is_empty())
                .then(|| Track::new(track, "the demo's route"))
                .transpose()
                .map_err(|e| anyhow::anyhow!(e))?,
        },
        &file,
        &config.model_name,
        false,
    )?;
    steps.finish();
    let info = RunInfo {
        profile: config.profile,
        seed: config.seed,
        sample_rate_hz: SAMPLE_RATE_HZ,
        samples: qemu_run.samples.len(),
        params_name: params_name(config),
    };
    let run = device_run(config, &info, &params, &monitor, &steps.times);
    let log = pass.into_log(run, &session, road_bands(&ride), shocks(&ride));
    write_report(&files.report, &report, &log)?;
    let data = DemoData { info, report, log };
    let summary = Summary::new(&data);
    (steps.announce)(&format!("[{STEPS}/{STEPS}] summary"));
    Ok(DemoOutcome {
        data,
        summary,
        report: files.report.clone(),
    })
}

/// The demo's ride as the report opens it: the file read whole, placed on the route.
struct WithTrack {
    track: Option<Track>,
}

impl OpenRide for WithTrack {
    fn open_ride(&self, path: &Path) -> Result<RideSource> {
        let (recording, layout) = read_input(path)?;
        let source = RideSource::from_recording(recording, layout);
        match &self.track {
            Some(track) => source.with_track(track.clone()),
            None => Ok(source),
        }
    }
}

/// Claims the output folder (refused if it holds a user's files, see
/// [`crate::io::output_folder`]) and removes a previous report, so that a failed run
/// never leaves an older report that looks like this run's.
fn prepare_folder(dir: &Path, force: bool) -> Result<(DemoFiles, OutputFolder)> {
    let folder = output_folder::claim(dir, "supine demo", "--out", force)?;
    let files = DemoFiles::in_dir(dir);
    match std::fs::remove_file(&files.report) {
        Ok(()) => Ok((files, folder)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok((files, folder)),
        Err(e) => bail!(
            "{}: cannot remove the previous report: {e}",
            files.report.display()
        ),
    }
}

/// Makes the ride, writes it to `path` and keeps what the file holds (accelerations to
/// 1e-6 m/s^2): the device gets exactly that, so that `supine replay` of the file
/// reproduces device.csv.
fn make_ride(config: &DemoConfig, path: &Path) -> Result<DemoRide> {
    let mut ride = demo_ride::make(
        config.profile,
        config.duration_s,
        SAMPLE_RATE_HZ,
        config.seed,
    )?;
    crate::exposure::ride::write_ride(path, &ride.ride)?;
    let (recording, _) = read_input(path)?;
    if recording.len() != ride.ride.len() {
        bail!(
            "{}: read back {} samples of {}",
            path.display(),
            recording.len(),
            ride.ride.len()
        );
    }
    ride.ride.platform_m_s2 = recording.platform_m_s2;
    Ok(ride)
}

/// The parameters flashed: `model`, with telemetry for every sample (a device in
/// service sends 100 Hz). The report overlays the host's computation on each of the
/// device's samples, and `supine replay` of ride.csv with these parameters reproduces
/// device.csv.
fn param_file(model: &ParamFile, subject: &SubjectArgs) -> Result<ParamFile> {
    let mut file = model.clone();
    file.device = Some(DeviceSection {
        telemetry_decimation: Some(1),
        ..model.device.unwrap_or_default()
    });
    subject.apply(&mut file)?;
    Ok(file)
}

/// Runs the device in QEMU, followed by the monitor, which logs to device.csv and
/// device.events.csv; then reads them back (the report shows what a user can open).
fn run_device(
    qemu_run: &QemuRun,
    files: &DemoFiles,
    view: &mut dyn View,
    stop: &Arc<AtomicBool>,
) -> Result<Monitor> {
    let mut log = MonitorLog::create(&files.device)?;
    let (monitor, ending) = match run_qemu(qemu_run, view, Some(&mut log), stop) {
        Ok(done) => done,
        Err(e) => {
            log.discard();
            return Err(e.context("running the device in QEMU"));
        }
    };
    if ending == Ending::Stopped {
        log.discard();
        bail!(
            "interrupted after {} of {} samples",
            monitor.latest().map_or(0, |t| t.sample_index + 1),
            qemu_run.samples.len()
        );
    }
    log.finish()?;
    Ok(monitor)
}

/// Runs the device's own pipeline (f32) on the host and writes host.csv and
/// host.events.csv, the reference a user can open beside the device's files.
fn host_reference(params: &DeviceParams, samples: &[[f32; 3]], files: &DemoFiles) -> Result<()> {
    let indices: Vec<u32> = (0..samples.len() as u32).collect();
    let run = reference::pipeline(params, &indices, samples);
    write_telemetry(
        &files.host,
        &run.telemetry,
        SAMPLE_RATE_HZ,
        params.joints.mask(),
    )?;
    write_events(&files.host_events, &run.events, SAMPLE_RATE_HZ)
}

/// The device's account (read back from the files the monitor logged, so the report
/// shows what a user can open) set against the host's, in one pass
/// ([`device_pass::run`]).
fn device_pass<'a>(
    params: &'a DeviceParams,
    file: &'a ParamFile,
    samples: &[[f32; 3]],
    files: &DemoFiles,
) -> Result<(PassResult, Session<'a>)> {
    let mut device_records = 0;
    for record in telemetry_records(&files.device)? {
        record?;
        device_records += 1;
    }
    let session = Session {
        params,
        model: &file.params,
        sample_rate_hz: SAMPLE_RATE_HZ,
        first_sample: 0,
        samples: samples.len(),
        device_records,
    };
    let pass = device_pass::run(
        &session,
        samples.iter().map(|&x| Ok(x)),
        telemetry_records(&files.device)?,
        event_records(&files.device_events, SAMPLE_RATE_HZ)?,
    )?;
    Ok((pass, session))
}

/// The parameters' name, with the patient when one was given.
fn params_name(config: &DemoConfig) -> String {
    match (config.subject.height_m, config.subject.mass_kg) {
        (None, None) => config.model_name.clone(),
        (h, m) => {
            let mean = supine_core::model::Subject::PAPER_MEAN;
            format!(
                "{} for a {} m, {} kg patient",
                config.model_name,
                h.unwrap_or(mean.height_m),
                m.unwrap_or(mean.mass_kg)
            )
        }
    }
}

/// How the run was made, from the configuration, the parameters and the device's own
/// account (its greeting, status and link counters).
fn device_run(
    config: &DemoConfig,
    info: &RunInfo,
    params: &DeviceParams,
    monitor: &Monitor,
    step_times: &[(String, Duration)],
) -> DeviceRun {
    let greeting = monitor.greeting();
    let duration_s = info.samples as f64 / info.sample_rate_hz;
    let streamed = if config.realtime {
        "in real time"
    } else {
        "as fast as the device took them"
    };
    DeviceRun {
        account: format!(
            "A {duration_s:.0} s {} ride at {} Hz, streamed into the supine firmware running in QEMU \
             (mps2-an386, Cortex-M4F) with the parameters {}. The device predicted the patient's head \
             acceleration sample by sample, weighted it as ISO 2631-1 prescribes, and raised alerts; the \
             report above is the host's evaluation of the same ride, and this section compares the two.",
            info.profile.name(),
            info.sample_rate_hz,
            info.params_name
        ),
        device_line: device_line(greeting),
        firmware_version: greeting.firmware_version.as_str().to_string(),
        status: monitor.status().copied(),
        link: monitor.counters().link,
        step_times: step_times.to_vec(),
        notes: vec![
            (
                "parameters".into(),
                format!(
                    "{}, identity {}, placed in the PARAMS region's slot A as supine flash would (file: params.toml)",
                    info.params_name,
                    identity_hex(&params.identity)
                ),
            ),
            (
                "ride".into(),
                format!(
                    "{}, seed {}; streamed {streamed}",
                    info.profile.name(),
                    info.seed
                ),
            ),
            (
                "instructions per sample".into(),
                "not measured in this run (QEMU ran without -icount); supine replay --qemu --icount \
                 measures it, see BENCHMARKS.md"
                    .into(),
            ),
            (
                "again".into(),
                format!(
                    "supine demo --profile {} --duration-s {} --seed {} gives the same ride and the same numbers",
                    info.profile.name(),
                    duration_s,
                    info.seed
                ),
            ),
        ],
        files: [
            ("ride.csv", "the input"),
            ("device.csv", "the device's telemetry"),
            ("device.events.csv", "the device's alert events"),
            ("device.input.csv", "the input the device's model got (its input stream)"),
            (
                "device.session.json",
                "the device's parameters identity, rate and patient",
            ),
            ("host.csv", "the host's reference telemetry"),
            ("host.events.csv", "the host's reference events"),
            ("params.toml", "the parameters flashed"),
        ]
        .map(|(f, what)| (f.to_string(), what.to_string()))
        .to_vec(),
    }
}

/// The rough stretches of a ride of several surfaces (not the base road), to shade.
fn road_bands(ride: &DemoRide) -> Vec<Band> {
    if ride.segments.len() < 2 {
        return Vec::new();
    }
    ride.segments
        .iter()
        .filter(|s| s.label != "paved road")
        .map(|s| Band {
            start_s: s.start_s,
            end_s: s.end_s,
            label: s.label.clone(),
            color: ROUGH_COLOR,
        })
        .collect()
}

/// The ride's shocks, to mark.
fn shocks(ride: &DemoRide) -> Vec<Moment> {
    ride.shocks
        .iter()
        .map(|s| Moment {
            t_s: s.time_s,
            label: match s.kind {
                ShockKind::Pothole => "pothole".into(),
                ShockKind::SpeedBump => "speed bump".into(),
            },
        })
        .collect()
}

/// Renders the report and writes it, whole or not at all.
fn write_report(path: &Path, report: &MissionReport, log: &DeviceLog) -> Result<()> {
    let page = page::render(report, Some(log))?;
    crate::io::output::write_atomically(path, |w| {
        use std::io::Write as _;
        w.write_all(page.as_bytes())
            .with_context(|| format!("writing {}", path.display()))
    })
}
