//! `supine validate`: measured against predicted sensor accelerations of one recording,
//! per channel and as the paper's R^2 (see `validate`).

use std::path::{Path, PathBuf};

use anyhow::Result;

use crate::commands::json_output::JsonFlag;
use crate::identify::validate::{predict, table, validate, write_report};
use crate::io::dataset::{DATASET_FILE, Dataset, SubjectEntry};
use crate::io::output_folder;
use crate::io::params_file::ModelSource;
use crate::io::recording::Recording;
use crate::io::stdout::{print_line, print_text};
use crate::io::subject_args::SubjectArgs;

/// Arguments of `supine validate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters (`supine fit` writes a file for --params).
    #[command(flatten)]
    pub source: ModelSource,
    /// The recording to compare with (`--recording` is an older spelling).
    #[arg(long, value_name = "REC.csv", alias = "recording")]
    pub input: PathBuf,
    /// Print the comparison as JSON instead of a table.
    #[command(flatten)]
    pub json: JsonFlag,
    /// A folder for the PSD plots (psd.svg) and the JSON (validation.json); a folder
    /// holding files supine did not write is refused, see --force.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write into the folder even if it holds files supine did not write there (those
    /// are kept).
    #[arg(long)]
    pub force: bool,
    /// The subject, if not the one `dataset.toml` beside the recording gives it (else the
    /// parameters' own).
    #[command(flatten)]
    pub subject: SubjectArgs,
}

/// The subject of a dataset's recording `input`: the entry of `dataset.toml` in its
/// folder that names it (either case), with that file's path; none when the folder has
/// no `dataset.toml` or it does not name the recording.
fn dataset_subject(input: &Path) -> Result<Option<(SubjectEntry, PathBuf)>> {
    let dir = match input.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let path = dir.join(DATASET_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let dataset = Dataset::load(dir)?;
    let same = |p: &Path| match (p.canonicalize(), input.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    Ok(dataset
        .subjects
        .into_iter()
        .find(|e| [&e.rigid, &e.litter].into_iter().flatten().any(|p| same(p)))
        .map(|e| (e, path)))
}

/// Predicts, compares, prints.
pub fn run(args: &Args) -> Result<()> {
    let subject = match dataset_subject(&args.input)? {
        Some((entry, path)) => {
            eprintln!(
                "subject {} from {}: {} m, {} kg",
                entry.id,
                path.display(),
                entry.subject.height_m,
                entry.subject.mass_kg
            );
            SubjectArgs {
                height_m: args.subject.height_m.or(Some(entry.subject.height_m)),
                mass_kg: args.subject.mass_kg.or(Some(entry.subject.mass_kg)),
            }
        }
        None => args.subject,
    };
    let params = subject.load_from(&args.source)?;
    let recording = Recording::read(&args.input)?;
    let predicted = predict(&params, &recording)?;
    let result = validate(&recording, &predicted);
    let json = serde_json::to_string_pretty(&result)?;
    if let Some(dir) = &args.report {
        let folder = output_folder::claim(dir, "supine validate", "--report", args.force)?;
        folder.write_or_undo(|folder| {
            write_report(dir, &recording, &predicted, &json)?;
            folder.record_new_entries()
        })?;
    }
    if args.json.json {
        print_line(&serde_json::to_string(&result)?)
    } else {
        print_text(&table(&result))
    }
}
