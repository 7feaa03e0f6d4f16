//! `supine modes`: the model's modes, and which of them the device realization keeps.

use anyhow::{Result, anyhow};
use supine_core::model::{DEFAULT_SAMPLE_RATE_HZ, Model};

use crate::commands::json_output::{self, JsonFlag};
use crate::identify::identify_records::ModesSummary;
use crate::io::params_file::ModelSource;
use crate::io::stdout::print_text;

/// Arguments of `supine modes`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters.
    #[command(flatten)]
    pub source: ModelSource,
    /// Print the modes as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Prints one row per mode (a complex pair once), slowest first within each subsystem.
pub fn run(args: &Args) -> Result<()> {
    let params = args.source.load()?.params;
    let model = Model::new(&params).map_err(|e| anyhow!("{e}"))?;
    let device = model
        .device_realization(DEFAULT_SAMPLE_RATE_HZ)
        .map_err(|e| anyhow!("{e}"))?;
    if args.json.json {
        return json_output::print(&ModesSummary::new(&model, &device, DEFAULT_SAMPLE_RATE_HZ));
    }
    print_text(&format!(
        "{}device realization at {DEFAULT_SAMPLE_RATE_HZ} Hz: {} modal blocks (2 states each), {} multiply-adds per sample for head x, y, z\n",
        table(&model),
        device.block_count,
        device.multiply_adds_per_sample()
    ))
}

/// The modes table as text.
pub fn table(model: &Model) -> String {
    let mut out =
        String::from("subsystem      frequency_hz  damping_ratio  kind           reachable\n");
    for m in &model.modes.components {
        let (zeta, kind) = match m.damping_ratio() {
            Some(z) => (format!("{z:.4}"), "oscillatory"),
            None => ("-".to_string(), "real pole"),
        };
        out.push_str(&format!(
            "{:<14} {:>12.4}  {:>13}  {:<14} {}\n",
            m.subsystem.name(),
            m.natural_frequency_hz(),
            zeta,
            kind,
            if m.reachable { "yes" } else { "no" }
        ));
    }
    out
}
