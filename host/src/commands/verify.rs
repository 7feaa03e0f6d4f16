//! `supine verify --qemu`: ISO 8041-1's electrical verification through the shipping
//! firmware in QEMU at each sample rate asked for; writes `DIR/conformance.html` and
//! `DIR/conformance.json` (the same object `--json` prints). Exits non-zero when a test
//! fails.

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::{Context as _, Result, bail};

use crate::commands::json_output::{self, JsonFlag};
use crate::device::image::ProductImage;
use crate::io::output::write_atomically;
use crate::verify::plan::Group;
use crate::verify::{self, SUPPORTED_RATES_HZ, Variant, html};

/// Arguments of `supine verify`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Run the firmware in QEMU (mps2-an386); the only target for now.
    #[arg(long, required = true)]
    pub qemu: bool,
    /// Sample rates to verify at, Hz (default: every supported rate, 100, 200, 400, 500,
    /// 1000 and 2000).
    #[arg(long = "fs", value_name = "HZ", num_args = 1..)]
    pub fs_hz: Vec<f64>,
    /// The folder for conformance.html and conformance.json.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// A developer's firmware ELF instead of the image built into supine.
    #[arg(long, value_name = "ELF")]
    pub firmware: Option<PathBuf>,
    /// Print the results as JSON too.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Runs the verification and writes the report; an error when a test fails.
pub fn run(args: &Args) -> Result<()> {
    let rates = if args.fs_hz.is_empty() {
        SUPPORTED_RATES_HZ.to_vec()
    } else {
        args.fs_hz.clone()
    };
    for rate in &rates {
        supine_core::sample_rate::SampleRate::from_hz_f64(*rate)
            .map_err(|e| anyhow::anyhow!("--fs {rate}: {e}"))?;
    }
    let image = ProductImage::select(args.firmware.as_deref())?;
    let stop = crate::device::signals::stop_flag();
    let c = verify::run(
        &image,
        &rates,
        Variant::Shipping,
        &Group::ALL,
        &stop,
        &mut |what| eprintln!("verifying: {what}"),
    )?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let page = html::render(&c);
    let html_path = args.out.join("conformance.html");
    write_atomically(&html_path, |w| Ok(w.write_all(page.as_bytes())?))?;
    let json = serde_json::to_string_pretty(&c)? + "\n";
    write_atomically(&args.out.join("conformance.json"), |w| {
        Ok(w.write_all(json.as_bytes())?)
    })?;
    if args.json.json {
        json_output::print(&c)?;
    }
    let failed = c.tests.iter().filter(|t| !t.pass).count();
    eprintln!(
        "wrote {}: {} tests, {} failed, in {:.0} s",
        html_path.display(),
        c.tests.len(),
        failed,
        c.elapsed_s
    );
    if failed > 0 {
        bail!(
            "ISO 8041-1 verification failed: {failed} of {} tests",
            c.tests.len()
        );
    }
    Ok(())
}
