//! `supine completions`: a completion script for the user's shell, generated from the same
//! clap definition that parses the arguments, so it can never list a flag that is gone.

use anyhow::Result;
use clap_complete::Shell;

use crate::io::stdout::print_text;

/// Arguments of `supine completions`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The shell to complete for.
    #[arg(value_enum)]
    pub shell: Shell,
}

/// Prints the script for `command` (the whole `supine` definition, which `cli` passes in)
/// on standard output.
pub fn run(args: &Args, mut command: clap::Command) -> Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command, "supine", &mut script);
    print_text(&String::from_utf8_lossy(&script))
}
