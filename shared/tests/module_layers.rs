//! The core's data path reads one way (docs/architecture.md): model, weighting and mounting,
//! then exposure, alerts, blob, pipeline, protocol, upload. A module may use only modules
//! to its left, and the leaf utilities (no `crate::` use of their own) anywhere; so no two
//! top-level modules can import each other, directly or round a cycle.
//!
//! Checked on the source text: every `crate::<module>` path outside a comment.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// Top-level modules from the bottom of the data path up; modules in one inner slice
/// stand side by side and may not use each other.
const LAYERS: &[&[&str]] = &[
    &["model", "weighting", "mounting"],
    &["exposure", "calibration"],
    &["alerts"],
    &["joint_exposure"],
    &["blob"],
    &["pipeline"],
    &["protocol"],
    &["upload"],
];

/// Utilities any module may use; each uses only the utilities before it in this list.
const LEAVES: &[&str] = &[
    "fpu",
    "gain_bound",
    "input_resolution",
    "sample_rate",
    "test_vector",
    "timing",
];

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

/// The top-level module each source file belongs to, with the file's path.
fn source_files() -> Vec<(String, PathBuf)> {
    let mut files = Vec::new();
    let mut dirs = vec![src_dir()];
    while let Some(dir) = dirs.pop() {
        for entry in fs::read_dir(&dir).expect("src readable") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let relative = path.strip_prefix(src_dir()).expect("under src");
                let first = relative.components().next().expect("a component");
                let name = first.as_os_str().to_string_lossy();
                files.push((name.trim_end_matches(".rs").to_string(), path));
            }
        }
    }
    files.sort();
    files
}

/// The modules `text` names as `crate::<module>` in code (comments skipped).
fn crate_uses(text: &str) -> BTreeSet<String> {
    let mut used = BTreeSet::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        for (at, _) in code.match_indices("crate::") {
            let rest = &code[at + "crate::".len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            // `$crate::` in a macro, or `crate::{a, b}` (not used here): keep what follows.
            if !name.is_empty() {
                used.insert(name);
            }
        }
    }
    used
}

#[test]
fn every_top_level_module_has_a_place_in_the_data_path() {
    for (module, path) in source_files() {
        if module == "lib" {
            continue;
        }
        assert!(
            layer_of(&module).is_some() || LEAVES.contains(&module.as_str()),
            "{}: module `{module}` is in neither LAYERS nor LEAVES",
            path.display()
        );
    }
}

#[test]
fn modules_use_only_modules_to_their_left_and_leaves() {
    let mut violations = Vec::new();
    for (module, path) in source_files() {
        let text = fs::read_to_string(&path).expect("readable");
        for used in crate_uses(&text) {
            if used == module {
                continue;
            }
            let leaf_position = |m: &str| LEAVES.iter().position(|&l| l == m);
            let allowed = if let Some(own) = leaf_position(&module) {
                leaf_position(&used).is_some_and(|other| other < own)
            } else if LEAVES.contains(&used.as_str()) {
                true
            } else {
                match (layer_of(&module), layer_of(&used)) {
                    (Some(own), Some(other)) => other < own,
                    _ => module == "lib",
                }
            };
            if !allowed {
                violations.push(format!("{}: {module} uses crate::{used}", path.display()));
            }
        }
    }
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_scan_sees_a_use_and_ignores_comments() {
    let text = "use crate::blob::DeviceParams;\n// crate::upload in a comment\n/// [`crate::protocol`]\nlet x = crate::fpu::sqrt_f32(2.0); // crate::model\n";
    let found: Vec<String> = crate_uses(text).into_iter().collect();
    assert_eq!(found, ["blob", "fpu"]);
}
