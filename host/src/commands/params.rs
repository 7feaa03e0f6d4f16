//! `supine params`: prints a parameter file, the format `--params` reads and fits write.

use anyhow::Result;

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
    print!("{}", args.source.load()?.to_toml()?);
    Ok(())
}
