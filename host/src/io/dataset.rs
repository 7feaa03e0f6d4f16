//! Datasets: a folder with `dataset.toml` naming each subject's anthropometry and recordings.
//!
//! ```toml
//! [[subject]]
//! id = "s1"
//! height_m = 1.80
//! mass_kg = 78.0
//! rigid = "s1_rigid.csv"     # relative to the dataset folder; either case may be absent
//! litter = "s1_litter.csv"
//! ```
//!
//! Errors are one line: `dataset.toml:LINE:COLUMN: field NAME: expected ...` (a recording's
//! errors name its file, line and column).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use serde::Deserialize;
use supine_core::model::params::ParamField;
use supine_core::model::{ModelParams, Preset, Subject};

use crate::io::excerpt::{self, bound_quoted_parts, excerpt, name};
use crate::io::output::write_atomically;
use crate::io::recording::Recording;
use crate::io::small_file::read_text;
use crate::io::text_position::line_column;

/// The dataset description's file name inside the dataset folder.
pub const DATASET_FILE: &str = "dataset.toml";

/// Longest `dataset.toml` read, bytes: a subject's table takes about 100 bytes, so a
/// megabyte describes ten thousand subjects, and refuses a wrong file (a recording, a
/// device) at no cost.
pub const MAX_DESCRIPTION_BYTES: u64 = 1 << 20;

/// Longest recording file name accepted, bytes: Linux's PATH_MAX, beyond which no file
/// opens (and the name would only flood the error).
pub const MAX_PATH_BYTES: usize = 4096;

/// Two recordings' sample rates agree when they differ by less than this fraction.
pub const SAMPLE_RATE_TOLERANCE: f64 = 1e-4;

/// Which support the subjects lay on: the paper's two experimental cases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Case {
    /// Directly on the rigid platform: fits all 42 parameters.
    Rigid,
    /// On a spinal board strapped to a litter: fits the 18 contact parameters.
    Litter,
}

impl Case {
    /// `rigid` or `litter`, as in `dataset.toml` and on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Case::Rigid => "rigid",
            Case::Litter => "litter",
        }
    }
}

/// One subject of a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct SubjectEntry {
    /// Identifier, unique in the dataset (e.g. `s3`).
    pub id: String,
    /// Height and mass.
    pub subject: Subject,
    /// The rigid-platform recording, resolved against the dataset folder.
    pub rigid: Option<PathBuf>,
    /// The litter-board recording, resolved against the dataset folder.
    pub litter: Option<PathBuf>,
    /// The line of `dataset.toml` where this subject's table starts (1-based).
    pub line: usize,
    /// The column of that line where the table starts (1-based).
    pub column: usize,
}

impl SubjectEntry {
    /// The recording of one case, if the dataset has it.
    pub fn recording(&self, case: Case) -> Option<&Path> {
        match case {
            Case::Rigid => self.rigid.as_deref(),
            Case::Litter => self.litter.as_deref(),
        }
    }
}

/// A dataset: where it lives and its subjects in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// The dataset folder.
    pub dir: PathBuf,
    /// The subjects, in the order of `dataset.toml`.
    pub subjects: Vec<SubjectEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DatasetRepr {
    subject: Vec<toml::Spanned<SubjectRepr>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SubjectRepr {
    id: toml::Spanned<String>,
    height_m: toml::Spanned<f64>,
    mass_kg: toml::Spanned<f64>,
    rigid: Option<toml::Spanned<String>>,
    litter: Option<toml::Spanned<String>>,
}

/// A subject's recordings of one case, read and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseRecording {
    /// The subject.
    pub entry: SubjectEntry,
    /// The recording.
    pub recording: Recording,
}

impl Dataset {
    /// Reads `DIR/dataset.toml` (not the recordings: [`Dataset::read_case`] does that).
    pub fn load(dir: &Path) -> Result<Self> {
        let path = dir.join(DATASET_FILE);
        let text = read_text(&path, "dataset description", MAX_DESCRIPTION_BYTES)?;
        Self::parse(&text, dir)
    }

    /// Parses the text of `dataset.toml` of the dataset in `dir`.
    pub fn parse(text: &str, dir: &Path) -> Result<Self> {
        let path = dir.join(DATASET_FILE);
        let at = |offset: usize, field: &str, message: &str| -> anyhow::Error {
            let (line, column) = line_column(text, offset);
            anyhow!(
                "{}:{line}:{column}: field {field}: {message}",
                path.display()
            )
        };
        let repr: DatasetRepr = toml::from_str(text).map_err(|e| {
            let offset = e.span().map_or(0, |s| s.start);
            let message = bound_quoted_parts(&e.message().trim().replace('\n', " "));
            at(offset, &toml_error_field(text, offset, &message), &message)
        })?;
        let mut subjects: Vec<SubjectEntry> = Vec::with_capacity(repr.subject.len());
        for spanned in repr.subject {
            let (line, column) = line_column(text, spanned.span().start);
            let s = spanned.into_inner();
            let id_offset = s.id.span().start;
            let id = s.id.into_inner();
            if id.trim().is_empty() {
                return Err(at(id_offset, "id", "expected a non-empty subject id"));
            }
            if let Some(first) = subjects.iter().find(|e| e.id == id) {
                return Err(at(
                    id_offset,
                    "id",
                    &format!(
                        "expected unique subject ids, found {} again (its first table starts on line {})",
                        excerpt(&id),
                        first.line
                    ),
                ));
            }
            for (field, value) in [("height_m", &s.height_m), ("mass_kg", &s.mass_kg)] {
                let v = *value.get_ref();
                if !(v.is_finite() && v > 0.0) {
                    return Err(at(
                        value.span().start,
                        &format!("{field} (subject {})", name(&id)),
                        &format!(
                            "expected a positive finite number, found {}",
                            excerpt::number(v)
                        ),
                    ));
                }
            }
            // The model's own plausible ranges (a height of 1e300 m is finite and positive).
            let subject = Subject {
                height_m: *s.height_m.get_ref(),
                mass_kg: *s.mass_kg.get_ref(),
            };
            let mut with_subject = ModelParams::preset(Preset::PaperRigid);
            with_subject.subject = subject;
            if let Err(e) = with_subject.validate() {
                let (field, value) = match e.field {
                    ParamField::MassKg => ("mass_kg", &s.mass_kg),
                    _ => ("height_m", &s.height_m),
                };
                return Err(at(
                    value.span().start,
                    &format!("{field} (subject {})", name(&id)),
                    &format!(
                        "expected what the model accepts ({e}), found {}",
                        excerpt::number(*value.get_ref())
                    ),
                ));
            }
            for (field, file) in [("rigid", &s.rigid), ("litter", &s.litter)] {
                if let Some(file) = file.as_ref().filter(|f| f.get_ref().len() > MAX_PATH_BYTES) {
                    return Err(at(
                        file.span().start,
                        &format!("{field} (subject {})", name(&id)),
                        &format!(
                            "expected a file name of at most {MAX_PATH_BYTES} bytes, found {} bytes",
                            file.get_ref().len()
                        ),
                    ));
                }
            }
            subjects.push(SubjectEntry {
                id,
                subject,
                rigid: s.rigid.map(|r| dir.join(r.into_inner())),
                litter: s.litter.map(|r| dir.join(r.into_inner())),
                line,
                column,
            });
        }
        if subjects.is_empty() {
            return Err(at(0, "subject", "expected at least one [[subject]] table"));
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            subjects,
        })
    }

    /// The subjects a command works on: `only` if given, else all but `exclude`; each must
    /// have a recording of `case`.
    pub fn select(
        &self,
        case: Case,
        only: Option<&str>,
        exclude: &[String],
    ) -> Result<Vec<&SubjectEntry>> {
        let path = self.dir.join(DATASET_FILE);
        let known = |id: &str| -> Result<&SubjectEntry> {
            self.subjects.iter().find(|e| e.id == id).ok_or_else(|| {
                let ids: Vec<_> = self.subjects.iter().map(|e| name(&e.id)).collect();
                anyhow!(
                    "{}: expected a subject id among {}, found {}",
                    path.display(),
                    ids.join(", "),
                    excerpt(id)
                )
            })
        };
        for id in exclude {
            known(id)?;
        }
        let chosen: Vec<&SubjectEntry> = match only {
            Some(id) => vec![known(id)?],
            None => self
                .subjects
                .iter()
                .filter(|e| !exclude.contains(&e.id))
                .collect(),
        };
        if chosen.is_empty() {
            bail!(
                "{}: expected at least one subject after excluding {}",
                path.display(),
                exclude.join(",")
            );
        }
        for entry in &chosen {
            if entry.recording(case).is_none() {
                bail!(
                    "{}:{}:{}: field {} (subject {}): expected a `{}` recording for --case {}, found none",
                    path.display(),
                    entry.line,
                    entry.column,
                    case.name(),
                    name(&entry.id),
                    case.name(),
                    case.name()
                );
            }
        }
        Ok(chosen)
    }

    /// Reads the `case` recordings of the selected subjects and checks that they share one
    /// sample rate (within [`SAMPLE_RATE_TOLERANCE`]). The files are parsed in parallel
    /// (one thread per core); the first error in the subjects' order is reported.
    pub fn read_case(&self, case: Case, selected: &[&SubjectEntry]) -> Result<Vec<CaseRecording>> {
        let files = selected
            .iter()
            .map(|entry| {
                entry.recording(case).ok_or_else(|| {
                    anyhow!(
                        "subject {}: no `{}` recording",
                        name(&entry.id),
                        case.name()
                    )
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let read = crate::parallel::in_parallel(files.len(), 0, |i| {
            Recording::read(files[i]).map_err(anyhow::Error::from)
        });
        let mut out: Vec<CaseRecording> = Vec::with_capacity(selected.len());
        for ((entry, file), recording) in selected.iter().zip(&files).zip(read) {
            let recording = recording?;
            if let Some(first) = out.first() {
                let (f0, f1) = (first.recording.sample_rate_hz(), recording.sample_rate_hz());
                if ((f1 - f0) / f0).abs() > SAMPLE_RATE_TOLERANCE {
                    bail!(
                        "{}: column time_s: expected the sample rate of {} ({f0:.6} Hz), found {f1:.6} Hz (all recordings of a case must share one rate)",
                        file.display(),
                        first.recording.path.display()
                    );
                }
            }
            out.push(CaseRecording {
                entry: (*entry).clone(),
                recording,
            });
        }
        Ok(out)
    }

    /// Writes `DIR/dataset.toml` (recording paths relative to `DIR`), complete or not at all.
    pub fn write_description(&self) -> Result<()> {
        let mut text = String::from(
            "# supine dataset: one [[subject]] per subject; recordings are CSV files\n\
             # relative to this folder, with the header of supine's docs/model.md#recording-format.\n",
        );
        for e in &self.subjects {
            let _ = write!(
                text,
                "\n[[subject]]\nid = {}\nheight_m = {}\nmass_kg = {}\n",
                toml_string(&e.id),
                e.subject.height_m,
                e.subject.mass_kg
            );
            for (key, file) in [("rigid", &e.rigid), ("litter", &e.litter)] {
                if let Some(file) = file {
                    let rel = file.strip_prefix(&self.dir).unwrap_or(file);
                    let _ = writeln!(text, "{key} = {}", toml_string(&rel.to_string_lossy()));
                }
            }
        }
        write_atomically(&self.dir.join(DATASET_FILE), |w| {
            Ok(w.write_all(text.as_bytes())?)
        })
    }
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// The field a TOML error is about: the one a serde message names in backquotes (missing or
/// unknown field), else the key of the line the error points into, else the table header.
fn toml_error_field(text: &str, offset: usize, message: &str) -> String {
    if message.contains("field `")
        && let Some(quoted) = message.split('`').nth(1).filter(|n| !n.is_empty())
    {
        return name(quoted).into_owned();
    }
    let (line, _) = line_column(text, offset);
    let line_text = text.lines().nth(line - 1).unwrap_or("").trim();
    if let Some((key, _)) = line_text.split_once('=') {
        return name(key.trim()).into_owned();
    }
    let header = line_text.trim_matches(|c| c == '[' || c == ']').trim();
    if header.is_empty() {
        "(none)".to_string()
    } else {
        name(header).into_owned()
    }
}
