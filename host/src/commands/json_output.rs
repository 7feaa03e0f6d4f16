//! `--json`: every command's results as one JSON object on standard output, units in the
//! key names, so that scripts read the same numbers the text shows.

use anyhow::{Result, anyhow};
use serde::Serialize;

use crate::io::stdout::print_line;

/// The `--json` flag, the same help on every command.
#[derive(Clone, Copy, Debug, Default, clap::Args)]
pub struct JsonFlag {
    /// Print the results as one JSON object on standard output (units in the key names).
    #[arg(long)]
    pub json: bool,
}

/// Prints `value` (one of the library's output records) as one line of JSON on standard
/// output, every object's keys in alphabetical order (as the outputs have always been
/// written, whatever order a record declares its fields in).
pub fn print(value: &impl Serialize) -> Result<()> {
    let value = serde_json::to_value(value).map_err(|e| anyhow!("rendering JSON: {e}"))?;
    let text = serde_json::to_string(&value).map_err(|e| anyhow!("rendering JSON: {e}"))?;
    print_line(&text)
}
