//! `supine flash`: a parameter file onto a device, as a QEMU region image, an
//! authenticated upload over a serial port (or into QEMU), or with probe-rs.

use std::path::PathBuf;

use anyhow::{Result, anyhow};

use crate::commands::json_output;
use crate::commands::values;
use crate::device::device_params::identity_hex;
use crate::device::device_records::{FlashSummary, UploadSummary};
use crate::device::flash::{self, UploadOutcome};
use crate::device::image::{DEVELOPMENT_KEY_NOTICE, ProductImage};
use crate::io::params_file::ModelSource;
use crate::io::stdout::print_line;
use crate::io::subject_args::SubjectArgs;
use crate::monitor::patient_text;
use crate::schema::subject::SubjectRecord;

/// Arguments of `supine flash`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The model parameters (and optional `[device]` table) to build the blob from.
    #[command(flatten)]
    pub model: ModelSource,
    /// The patient (else the parameters' subject).
    #[command(flatten)]
    pub subject: SubjectArgs,
    /// Sample rate the device runs at, Hz (the blob holds the realization for it).
    #[arg(long = "fs", value_name = "HZ", default_value_t = 500.0)]
    pub fs_hz: f64,
    /// Where the parameters go.
    #[command(flatten)]
    pub target: Target,
    /// Serial speed for --serial, baud.
    #[arg(long, value_name = "N", default_value_t = 921_600)]
    pub baud: u32,
    /// Device key file (64 hex digits) that signs the upload; default: the development key.
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Update counter; must exceed every one the device accepted (default: the Unix time in
    /// seconds, or one above the last counter this host used if that is larger).
    #[arg(long, value_name = "N")]
    pub counter: Option<u32>,
    /// Flash address of the PARAMS region for --probe (the Black Pill's sectors 6 and 7).
    #[arg(long, value_name = "ADDR", default_value = "0x08040000", value_parser = parse_address)]
    pub base_address: u32,
    /// Longest wait for each answer of the device, s (above 0, at most a day).
    #[arg(long, value_name = "S", default_value_t = 10.0, value_parser = values::timeout_s)]
    pub timeout_s: f64,
    /// With --qemu: run this firmware ELF instead of the image built into supine.
    #[arg(long, value_name = "ELF", requires = "qemu")]
    pub firmware: Option<PathBuf>,
    /// Print the result as one JSON object on standard output.
    #[arg(long)]
    pub json: bool,
}

/// Exactly one destination.
#[derive(Debug, clap::Args)]
#[group(required = true, multiple = false)]
pub struct Target {
    /// Write the PARAMS region image for QEMU's `-device loader,file=OUT,addr=0x70000`.
    #[arg(long, value_name = "OUT")]
    pub qemu_image: Option<PathBuf>,
    /// Upload over the UART protocol to a running device on this serial port.
    #[arg(long, value_name = "PORT")]
    pub serial: Option<String>,
    /// Write the region image (Black Pill layout) to a board: `probe-rs download --chip CHIP`.
    #[arg(long, value_name = "CHIP")]
    pub probe: Option<String>,
    /// Start the device image in QEMU, upload over its UART, check the new greeting, exit.
    #[arg(long)]
    pub qemu: bool,
}

fn parse_address(text: &str) -> Result<u32, String> {
    let digits = text.strip_prefix("0x").or_else(|| text.strip_prefix("0X"));
    match digits {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => text.parse(),
    }
    .map_err(|_| format!("expected an address like 0x08060000, got {text:?}"))
}

/// Builds the blob and delivers it.
pub fn run(args: &Args) -> Result<()> {
    let mut file = args.model.load()?;
    args.subject.apply(&mut file)?;
    let timeout = values::timeout("--timeout-s", args.timeout_s)?;
    let (params, blob) = flash::device_blob(&file, args.fs_hz)?;
    let id = identity_hex(&params.identity);
    let patient = patient_text(params.patient.height_m, params.patient.mass_kg);
    let subject = SubjectRecord::new(params.patient.height_m, params.patient.mass_kg);
    let counter = || flash::choose_counter(args.counter);
    let t = &args.target;
    let (text, json) = if let Some(out) = &t.qemu_image {
        let image = flash::qemu_region_image(&blob)?;
        crate::io::output::write_atomically(out, |w| {
            std::io::Write::write_all(w, &image)
                .map_err(|e| anyhow!("{}: cannot write: {e}", out.display()))
        })?;
        let addr = crate::device::qemu::PARAMS_ADDR;
        (
            format!(
                "wrote {} ({} bytes: parameters {id} at {} Hz for a {patient} in slot A); run with -device loader,file={},addr={addr:#x}",
                out.display(),
                image.len(),
                args.fs_hz,
                out.display(),
            ),
            FlashSummary::QemuImage {
                path: out.clone(),
                size_bytes: image.len(),
                params_identity: id,
                sample_rate_hz: args.fs_hz,
                subject,
                load_address: format!("{addr:#x}"),
            },
        )
    } else if let Some(port) = &t.serial {
        let key = key(args)?;
        let counter = counter()?;
        let outcome =
            flash::upload_serial(port, args.baud, &params, &blob, &key, counter, timeout)?;
        report(&outcome, port, counter, args.key.is_none())
    } else if let Some(chip) = &t.probe {
        let image =
            flash::region_image_with_stride(&blob, counter()?, flash::BLACKPILL_SLOT_STRIDE)?;
        flash::probe_download(chip, args.base_address, &image)?;
        (
            format!(
                "flashed parameters {id} at {} Hz for a {patient} to {chip} at {:#010x}; now reset the board \
                 (`probe-rs reset --chip {chip}`, its reset button, or a power cycle): it reads \
                 its parameters only at boot",
                args.fs_hz, args.base_address
            ),
            FlashSummary::Probe {
                chip: chip.clone(),
                base_address: format!("{:#010x}", args.base_address),
                params_identity: id,
                sample_rate_hz: args.fs_hz,
                subject,
            },
        )
    } else {
        // The group requires one target: this is --qemu.
        let kernel = ProductImage::select(args.firmware.as_deref())?;
        let key = key(args)?;
        // A fresh QEMU device has accepted no counter: nothing to remember.
        let counter = args.counter.map_or_else(flash::unix_seconds, Ok)?;
        let outcome = flash::upload_qemu(&kernel, &params, &blob, &key, counter, timeout)?;
        report(&outcome, "QEMU", counter, args.key.is_none())
    };
    if args.json {
        json_output::print(&json)
    } else {
        print_line(&text)
    }
}

/// The signing key: `--key`, or the public development key, said so on standard error.
fn key(args: &Args) -> Result<[u8; supine_core::upload::KEY_LEN]> {
    if args.key.is_none() {
        eprintln!("{DEVELOPMENT_KEY_NOTICE}");
    }
    flash::load_key(args.key.as_deref())
}

/// The line and the JSON object that report an upload.
fn report(
    outcome: &UploadOutcome,
    device: &str,
    counter: u32,
    development_key: bool,
) -> (String, FlashSummary) {
    let id = identity_hex(&outcome.uploaded.identity);
    let g = &outcome.greeting;
    (
        format!(
            "{device}: parameters {id} committed to slot {} and running (greeting: {} Hz, {}, firmware {}; counter {counter})",
            outcome.uploaded.slot,
            g.sample_rate_hz,
            patient_text(g.height_m, g.mass_kg),
            g.firmware_version
        ),
        {
            let upload = UploadSummary {
                device: device.to_string(),
                params_identity: id,
                slot: outcome.uploaded.slot,
                counter,
                greeting_sample_rate_hz: g.sample_rate_hz,
                greeting_subject: SubjectRecord::new(g.height_m, g.mass_kg),
                firmware_version: g.firmware_version.as_str().to_string(),
                development_key,
            };
            if device == "QEMU" {
                FlashSummary::Qemu(upload)
            } else {
                FlashSummary::Serial(upload)
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_in_hex_or_decimal_and_the_default_is_the_boards() {
        assert_eq!(
            parse_address("0x08040000"),
            Ok(flash::BLACKPILL_PARAMS_ADDR)
        );
        assert_eq!(parse_address("458752"), Ok(0x70000));
        assert!(parse_address("0x8zz").unwrap_err().contains("0x8zz"));
        #[derive(clap::Parser)]
        struct Flash {
            #[command(flatten)]
            args: Args,
        }
        let Flash { args } = <Flash as clap::Parser>::try_parse_from([
            "flash",
            "--preset",
            "paper-litter",
            "--probe",
            "X",
        ])
        .unwrap();
        assert_eq!(args.base_address, flash::BLACKPILL_PARAMS_ADDR);
        assert_eq!(args.fs_hz, 500.0);
    }
}
