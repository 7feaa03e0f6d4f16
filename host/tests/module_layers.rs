//! The host library's layers, as `docs/architecture.md` ("The host library") draws them:
//! a folder of `host/src` uses only the folders its row names (and `supine-core`), and
//! inside `report/` the numbers import no chart or markup, the charts no section, and the
//! markup leaf nothing of `report`. The core's own rule is `shared/tests/module_layers.rs`.
//!
//! Checked on the source text: every `crate::<module>` path outside a comment and outside
//! a file's `#[cfg(test)]` tests.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// Each folder (or top file) of `host/src` and what it may use besides itself.
const ALLOWED: &[(&str, &[&str])] = &[
    ("cli", &["commands", "io"]),
    (
        "commands",
        &[
            "archive", "demo", "report", "monitor", "exposure", "identify", "device", "io", "plot",
            "parallel", "ride", "verify", "schema",
        ],
    ),
    ("archive", &["report", "ride", "io"]),
    ("verify", &["report", "device", "io"]),
    (
        "demo",
        &[
            "report", "monitor", "exposure", "device", "plot", "io", "schema", "ride",
        ],
    ),
    (
        "report",
        &[
            "exposure", "identify", "device", "plot", "io", "parallel", "ride", "schema",
        ],
    ),
    ("monitor", &["exposure", "device", "io", "schema"]),
    ("exposure", &["device", "io", "parallel", "ride", "schema"]),
    ("identify", &["plot", "io", "parallel"]),
    ("device", &["io", "schema"]),
    ("plot", &[]),
    ("io", &["parallel", "ride", "schema"]),
    ("ride", &[]),
    ("schema", &[]),
    ("parallel", &[]),
];

/// `report/`'s layers from the bottom up: a file may use files of its own layer or below.
const REPORT_LAYERS: &[&[&str]] = &[
    &["markup"],
    &[
        "mod",
        "mission",
        "spectrum",
        "mission_joints",
        "prediction_band",
        "device_check",
        "device_pass",
        "device_series",
        "monitor_log",
        "third_octave",
        "route",
        "level_time",
        "calibration",
    ],
    &["charts", "device_charts", "route_charts"],
    &[
        "page",
        "joints_section",
        "band_section",
        "device_section",
        "quality_section",
        "route_section",
        "calibration_section",
    ],
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The code of a file: comments and the `#[cfg(test)] mod tests` block left out.
fn code_of(path: &Path) -> String {
    let text = fs::read_to_string(path).expect("readable");
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(at) => &text[..at],
        None => &text[..],
    };
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The names that follow `prefix` in `code` (`crate::report::{a, b}` gives `a` and `b`).
fn names_after(code: &str, prefix: &str) -> BTreeSet<String> {
    let mut used = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (at, _) in code.match_indices(prefix) {
        let rest = &code[at + prefix.len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let group = &group[..group.find('}').unwrap_or(group.len())];
            used.extend(group.split(',').map(|p| ident(p.trim())));
        } else {
            used.insert(ident(rest));
        }
    }
    used.retain(|n| !n.is_empty() && n.chars().next().is_some_and(|c| c.is_lowercase()));
    used
}

fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for entry in fs::read_dir(&d).expect("readable") {
            let p = entry.expect("an entry").path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn each_folder_uses_only_the_folders_below_it() {
    let mut broken = Vec::new();
    for path in rust_files(&src()) {
        let relative = path.strip_prefix(src()).expect("under src");
        let first = relative.components().next().expect("a component");
        let module = first
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if module == "lib" || module == "bin" {
            continue;
        }
        let allowed = ALLOWED
            .iter()
            .find(|(m, _)| *m == module)
            .unwrap_or_else(|| panic!("{}: a module the layers do not place", relative.display()))
            .1;
        for used in names_after(&code_of(&path), "crate::") {
            if used != module && !allowed.contains(&used.as_str()) {
                broken.push(format!("{} uses crate::{used}", relative.display()));
            }
        }
    }
    assert!(
        broken.is_empty(),
        "against docs/architecture.md's layers:\n{}",
        broken.join("\n")
    );
}

#[test]
fn report_numbers_import_no_chart_and_charts_no_section() {
    let layer_of = |name: &str| REPORT_LAYERS.iter().position(|l| l.contains(&name));
    let mut broken = Vec::new();
    for path in rust_files(&src().join("report")) {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let own =
            layer_of(&name).unwrap_or_else(|| panic!("report/{name}.rs: place it in a layer"));
        let code = code_of(&path);
        let used: BTreeSet<String> = names_after(&code, "crate::report::")
            .into_iter()
            .chain(names_after(&code, "super::"))
            .filter(|u| layer_of(u).is_some())
            .collect();
        for u in used {
            if u != name && layer_of(&u) > Some(own) {
                broken.push(format!("report/{name}.rs uses {u}, a layer above it"));
            }
        }
    }
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}
