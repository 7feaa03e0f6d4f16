//! The parameter file: the TOML form of [`ModelParams`] plus an optional `[fit]` table of
//! provenance, read by every command that takes `--params` and written by `supine fit`.
//!
//! Errors name the file, the line and column, and the field, in one line. A file is at
//! most [`MAX_FILE_BYTES`] long (see [`crate::io::small_file`]).
//!
//! A file may start from a preset and give only what differs: `base = "paper-litter"`
//! at its top takes every table and key from the preset, and the file's own tables and
//! keys replace the preset's one by one ([`BASE_KEY`]).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use clap::{Args, ValueEnum};
use serde::{Deserialize, Serialize};
use supine_core::model::params::{Contacts, Joints, SensorOffsets};
use supine_core::model::{ModelParams, ParamError, Preset, Subject, device_realization};
use supine_core::mounting::Mounting;
use supine_core::sample_rate::SampleRate;

pub use crate::io::device_table::DeviceSection;
use crate::io::device_table::{check, locate};

use crate::io::excerpt::bound_quoted_parts;
use crate::io::output::write_atomically;
use crate::io::small_file::read_text;
use crate::io::text_position::line_column;

/// Longest parameter file read, bytes: a preset renders to under 2 KB and `supine fit`
/// adds a short `[fit]` table, so 64 KiB is far beyond any real one, and small enough
/// that a wrong file (a recording, a device) costs nothing to refuse.
pub const MAX_FILE_BYTES: u64 = 64 << 10;

/// A parameter set and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamFile {
    /// The model's parameters.
    pub params: ModelParams,
    /// Free-form provenance written by `supine fit` (case, dataset, cost, ...).
    pub fit: Option<toml::Table>,
    /// Device configuration (weighting, alerts, sensor checks, mounting, telemetry);
    /// the documented defaults where absent.
    pub device: Option<DeviceSection>,
}

/// The top-level key naming a preset the file starts from.
pub const BASE_KEY: &str = "base";

/// What a "missing field" error adds: how to give only what differs.
const MISSING_FIELD_HINT: &str = "a file may start from a preset and give only what differs: put base = \"paper-litter\" (or \"paper-rigid\") on its first line";

/// The on-disk layout: ModelParams' tables at top level, then `[fit]`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileRepr {
    subject: Subject,
    joints: Joints,
    contacts: Contacts,
    #[serde(default = "paper_sensors")]
    sensors: SensorOffsets,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    fit: Option<toml::Table>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    device: Option<DeviceSection>,
}

fn paper_sensors() -> SensorOffsets {
    SensorOffsets::PAPER
}

const HEADER: &str = "\
# supine parameter file: the supine-human model of Wang & Rahmatalla (2013).
# Units are in the key names: stiffness_n_per_m (N/m), damping_n_s_per_m (N s/m),
# stiffness_nm_per_rad (N m/rad), damping_nm_s_per_rad (N m s/rad), offsets in m.
# Axes: x longitudinal (toward the head), y lateral, z vertical (up).
# joints.head_torso is J1 (head-neck to torso-arms), joints.torso_pelvis is J2.
# contacts.* couple each segment's centre to the support (board, litter or platform).
# sensors.*_m place the forehead, sternum and pelvis sensors relative to segment centres.
";

impl ParamFile {
    /// A preset with no provenance.
    pub fn preset(preset: Preset) -> Self {
        Self {
            params: ModelParams::preset(preset),
            fit: None,
            device: None,
        }
    }

    /// Renders the file's text.
    pub fn to_toml(&self) -> Result<String> {
        let repr = FileRepr {
            subject: self.params.subject,
            joints: self.params.joints,
            contacts: self.params.contacts,
            sensors: self.params.sensors,
            fit: self.fit.clone(),
            device: self.device,
        };
        let body = toml::to_string_pretty(&repr).context("rendering the parameter file")?;
        Ok(format!("{HEADER}\n{body}"))
    }

    /// Parses and validates a file's text; `path` only names it in errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self> {
        let parse_error = |e: toml::de::Error| {
            let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
            let message = bound_quoted_parts(e.message().trim());
            let hint = if message.starts_with("missing field") {
                format!("; {MISSING_FIELD_HINT}")
            } else {
                String::new()
            };
            anyhow!(
                "{}: line {line}, column {column}: {message}{hint}",
                path.display(),
            )
        };
        let table: toml::Table = toml::from_str(text).map_err(parse_error)?;
        let repr: FileRepr = match table.get(BASE_KEY) {
            None => toml::from_str(text).map_err(parse_error)?,
            Some(base) => {
                let preset = base_preset(base).map_err(|why| {
                    let (line, column) = key_position(text, BASE_KEY);
                    anyhow!(
                        "{}: line {line}, column {column}: base: {why}",
                        path.display()
                    )
                })?;
                let mut merged = preset_table(preset)?;
                let mut own = table;
                own.remove(BASE_KEY);
                merge(&mut merged, own);
                FileRepr::deserialize(toml::Value::Table(merged)).map_err(|e| {
                    anyhow!(
                        "{}: {} (over base = \"{}\")",
                        path.display(),
                        bound_quoted_parts(e.message().trim()),
                        preset.name()
                    )
                })?
            }
        };
        let params = ModelParams {
            subject: repr.subject,
            joints: repr.joints,
            contacts: repr.contacts,
            sensors: repr.sensors,
        };
        params
            .validate()
            .map_err(|e| validation_error(text, path, &e))?;
        if let Some(device) = &repr.device {
            check_device(device, &params, text, path)?;
        }
        Ok(Self {
            params,
            fit: repr.fit,
            device: repr.device,
        })
    }
}

/// The preset `base = "NAME"` names.
fn base_preset(value: &toml::Value) -> Result<Preset, String> {
    let names = Preset::ALL.map(Preset::name).join(", ");
    match value.as_str() {
        Some(name) => Preset::from_name(name).ok_or_else(|| {
            format!(
                "expected a preset ({names}), found \"{}\"",
                crate::io::excerpt::name(name)
            )
        }),
        None => Err(format!("expected a preset's name in quotes ({names})")),
    }
}

/// The preset's file as a TOML table (what `supine params --preset NAME` prints).
fn preset_table(preset: Preset) -> Result<toml::Table> {
    let text = ParamFile::preset(preset).to_toml()?;
    toml::from_str(&text).context("reading back a preset's parameter file")
}

/// Replaces `into`'s keys with `over`'s, table by table: a table in both is merged, any
/// other value replaced.
fn merge(into: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (into.get_mut(&key), value) {
            (Some(toml::Value::Table(inner)), toml::Value::Table(value)) => merge(inner, value),
            (_, value) => {
                into.insert(key, value);
            }
        }
    }
}

/// Line and column of the top-level `key = ...` (1, 1 when not found).
fn key_position(text: &str, key: &str) -> (usize, usize) {
    text.lines()
        .position(|l| {
            l.trim_start()
                .strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map_or((1, 1), |i| (i + 1, 1))
}

/// Reads and validates a parameter file.
pub fn load(path: &Path) -> Result<ParamFile> {
    let text = read_text(path, "parameter file", MAX_FILE_BYTES)?;
    ParamFile::from_toml(&text, path)
}

/// Writes a parameter file, complete or not at all.
pub fn save(path: &Path, file: &ParamFile) -> Result<()> {
    let text = file.to_toml()?;
    write_atomically(path, |w| Ok(w.write_all(text.as_bytes())?))
}

/// `mounting` as the `[device.mounting]` table of a parameter file (what `supine
/// calibrate` prints, to paste into one).
pub fn mounting_toml(mounting: Mounting) -> Result<String> {
    #[derive(Serialize)]
    struct MountingTable {
        device: DeviceTable,
    }
    #[derive(Serialize)]
    struct DeviceTable {
        mounting: Mounting,
    }
    Ok(toml::to_string(&MountingTable {
        device: DeviceTable { mounting },
    })?)
}

/// Checks the `[device]` table as the device will (`supine-core`'s rules, through
/// [`check`]) and names the file, line, column and key of a value it refuses.
///
/// The blob is built later, for a recording's or a device's sample rate; here the table is
/// checked at the highest rate the device runs at, where the one rate-dependent rule (a
/// running-rms time constant of at least two samples) is loosest, so that no file is
/// refused here that some rate accepts. [`crate::device::device_params::build`] checks
/// again at the blob's own rate.
fn check_device(
    device: &DeviceSection,
    params: &ModelParams,
    text: &str,
    path: &Path,
) -> Result<()> {
    let realization = device_realization(params, LOOSEST_RATE.hz_f64()).ok();
    let Err(refusals) = check(device, LOOSEST_RATE, realization.as_ref()) else {
        return Ok(());
    };
    // The refused key written first in the file; every refusal has a key or the table.
    let first = refusals
        .iter()
        .filter_map(|r| locate(text, &r.key).map(|at| (at, r)))
        .min_by_key(|((line, column, _), _)| (*line, *column));
    let key = |r: &crate::io::device_table::Refusal| {
        if r.key.is_empty() {
            "device".to_string()
        } else {
            format!("device.{}", r.key)
        }
    };
    Err(match first {
        Some(((line, column, value), r)) if !r.key.is_empty() => anyhow!(
            "{}: line {line}, column {column}: {}: {}, found {value}",
            path.display(),
            key(r),
            r.reason
        ),
        Some(((line, column, _), r)) => anyhow!(
            "{}: line {line}, column {column}: {}: {}",
            path.display(),
            key(r),
            r.reason
        ),
        None => anyhow!(
            "{}: {}: {}",
            path.display(),
            key(&refusals[0]),
            refusals[0].reason
        ),
    })
}

/// The highest rate the device runs at, where the `[device]` table is checked at load.
const LOOSEST_RATE: SampleRate = match SampleRate::new(SampleRate::MAX_HZ) {
    Ok(rate) => rate,
    Err(_) => panic!("the highest supported rate is supported"),
};

/// Names the line of the offending key: the table header, then the key under it.
fn validation_error(text: &str, path: &Path, err: &ParamError) -> anyhow::Error {
    let field = err.field.to_string();
    let parts: Vec<&str> = field.split('.').collect();
    let mut line_no = None;
    // e.g. joints.head_torso.translational.stiffness_n_per_m.x: header is all but 2 parts.
    for header_len in (1..parts.len()).rev() {
        let header = format!("[{}]", parts[..header_len].join("."));
        if let Some(start) = text.lines().position(|l| l.trim() == header) {
            let key = parts[header_len];
            line_no = text
                .lines()
                .enumerate()
                .skip(start + 1)
                .take_while(|(_, l)| !l.trim_start().starts_with('['))
                .find(|(_, l)| l.trim_start().starts_with(key))
                .map(|(i, _)| i + 1)
                .or(Some(start + 1));
            break;
        }
    }
    let mut msg = format!("{}: ", path.display());
    if let Some(line) = line_no {
        let _ = write!(msg, "line {line}: ");
    }
    let _ = write!(msg, "{err}");
    anyhow!(msg)
}

/// The model presets, as the command line spells them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// Subjects directly on the rigid platform (paper Tables 3-4, rigid case).
    PaperRigid,
    /// Subjects on a spinal board on a litter (paper Tables 3-4, litter-board case).
    PaperLitter,
}

impl From<PresetArg> for Preset {
    fn from(p: PresetArg) -> Self {
        match p {
            PresetArg::PaperRigid => Preset::PaperRigid,
            PresetArg::PaperLitter => Preset::PaperLitter,
        }
    }
}

/// `--preset NAME | --params FILE`: where a command's model parameters come from.
#[derive(Clone, Debug, Args)]
pub struct ModelSource {
    /// One of the paper's parameter sets.
    /// (Commands that take a ride default to the litter-board preset; the others need one.)
    #[arg(long, value_enum, conflicts_with = "params")]
    pub preset: Option<PresetArg>,
    /// A parameter file (TOML), as `supine params` prints and `supine fit` writes.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
}

impl ModelSource {
    /// The name the model is reported by: the parameter file, the preset, or the
    /// litter-board preset a command that takes a ride defaults to.
    pub fn model_name(&self) -> String {
        match (&self.params, self.preset) {
            (Some(p), _) => p.display().to_string(),
            (None, Some(p)) => p
                .to_possible_value()
                .map_or_else(|| format!("{p:?}"), |v| v.get_name().to_string()),
            (None, None) => "paper-litter".to_string(),
        }
    }

    /// Loads the parameters the user named.
    pub fn load(&self) -> Result<ParamFile> {
        match (&self.params, self.preset) {
            (Some(path), _) => load(path),
            (None, Some(preset)) => Ok(ParamFile::preset(preset.into())),
            (None, None) => Err(anyhow!("give --preset NAME or --params FILE")),
        }
    }

    /// Loads the parameters the user named, or, for a command that takes a ride, the
    /// litter-board preset (a patient on a spinal board on a litter: how patients ride),
    /// said on standard error.
    pub fn load_for_ride(&self) -> Result<ParamFile> {
        if self.params.is_none() && self.preset.is_none() {
            eprintln!(
                "no --preset or --params: using the litter-board preset (--preset paper-litter)"
            );
            return Ok(ParamFile::preset(Preset::PaperLitter));
        }
        self.load()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_on_a_base_preset_gives_only_what_differs() {
        let text = "base = \"paper-litter\"\n\n[subject]\nheight_m = 1.6\n\n\
                    [device.joint_alerts]\nneck_z = { excursion_m = 0.01 }\n";
        let file = ParamFile::from_toml(text, Path::new("p.toml")).unwrap();
        let mut want = ModelParams::preset(Preset::PaperLitter);
        want.subject.height_m = 1.6;
        assert_eq!(file.params, want);
        assert_eq!(
            file.device.unwrap().joint_alerts.outputs[2].excursion_m,
            Some(0.01)
        );
        // The same file without the base is refused, and the error says how.
        let err = ParamFile::from_toml(
            &text.replace("base = \"paper-litter\"\n", ""),
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("missing field `mass_kg`"), "{err}");
        assert!(err.contains("base = \"paper-litter\""), "{err}");
    }

    #[test]
    fn an_unknown_base_or_key_is_refused_with_its_place() {
        let err = ParamFile::from_toml("\nbase = \"paper-boat\"\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "p.toml: line 2, column 1: base: expected a preset (paper-rigid, paper-litter), found \"paper-boat\""
        );
        let err = ParamFile::from_toml(
            "base = \"paper-rigid\"\n[subject]\nheight_mm = 1.6\n",
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("p.toml: unknown field `height_mm`"),
            "{err}"
        );
        assert!(err.ends_with("(over base = \"paper-rigid\")"), "{err}");
    }
}
