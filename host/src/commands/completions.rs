//! `supine completions`: a completion script for the user's shell, generated from the same
//! clap definition that parses the arguments, so it can never list a flag that is gone.

use anyhow::Result;
use clap::CommandFactory;
use clap_complete::Shell;

use crate::cli::Cli;

/// Arguments of `supine completions`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The shell to complete for.
    #[arg(value_enum)]
    pub shell: Shell,
}

/// Prints the script on standard output.
pub fn run(args: &Args) -> Result<()> {
    let mut command = Cli::command();
    clap_complete::generate(args.shell, &mut command, "supine", &mut std::io::stdout());
    Ok(())
}
