//! Every test file runs: the integration tests are one binary per crate (`autotests =
//! false`), so a file added to `tests/` that its binary's root does not name as a module
//! would be compiled by nobody and pass by being absent. Each `*.rs` beside the root of
//! `host/tests`, `shared/tests` and `tests/tests` must be declared there (or be a binary of
//! its own in the crate's `Cargo.toml`).

use std::fs;
use std::path::Path;

fn repository() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("host/ sits in the repository")
}

/// The file stems in `dir` (`*.rs`) that neither `root` declares as `mod NAME;` nor the
/// crate's manifest names as a test binary's path.
fn undeclared(crate_dir: &str, root: &str) -> Vec<String> {
    let dir = repository().join(crate_dir).join("tests");
    let root_text = fs::read_to_string(dir.join(root)).expect("the test binary's root");
    let manifest = fs::read_to_string(repository().join(crate_dir).join("Cargo.toml"))
        .expect("the crate's manifest");
    let mut missing = Vec::new();
    for entry in fs::read_dir(&dir).expect("the tests folder") {
        let path = entry.expect("an entry").path();
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let file = format!("{stem}.rs");
        let declared = root_text
            .lines()
            .any(|l| l.trim() == format!("mod {stem};"));
        let own_binary = manifest.contains(&format!("path = \"tests/{file}\""));
        if !declared && !own_binary {
            missing.push(format!("{crate_dir}/tests/{file}"));
        }
    }
    missing.sort();
    missing
}

#[test]
fn every_test_file_is_a_module_of_its_crates_test_binary() {
    let mut missing = undeclared("host", "host.rs");
    missing.extend(undeclared("shared", "core.rs"));
    missing.extend(undeclared("tests", "qemu.rs"));
    assert!(
        missing.is_empty(),
        "test files no test binary compiles (add `mod NAME;` to the crate's tests root): {missing:?}"
    );
}
