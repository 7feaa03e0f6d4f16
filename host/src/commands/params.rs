//! `supine params`: prints a parameter file, the format `--params` reads and fits write;
//! without a `[device]` table of its own, the device's defaults follow, commented out, so
//! that every key a file may set is in front of the user.

use anyhow::Result;

use crate::io::device_table::commented_defaults;
use crate::io::params_file::ModelSource;

/// Arguments of `supine params`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters.
    #[command(flatten)]
    pub source: ModelSource,
}

/// Prints the parameters as TOML on standard output.
pub fn run(args: &Args) -> Result<()> {
    let file = args.source.load()?;
    print!("{}", file.to_toml()?);
    if file.device.is_none() {
        print!("\n{}", commented_defaults());
    }
    Ok(())
}
