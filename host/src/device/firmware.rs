//! Building device images from the source tree, for the QEMU tests and development.
//!
//! The installed tool does not use this: it runs the image built into it
//! ([`crate::device::image`]). The tests need every image (self-test, fault images). This
//! module runs the build of [`crate::device::firmware_recipe`] (as `cargo fw` does) and
//! returns the path of a named binary. Cargo decides what is stale; an up-to-date image costs a fraction of a
//! second.

use std::ffi::OsString;
use std::io;
use std::path::{Path, PathBuf};
use std::process::Command;

use super::firmware_recipe;

pub use super::firmware_recipe::{PACKAGE, PROFILE, TARGET, output_dir};

/// The product image's binary name.
pub const PRODUCT_BINARY: &str = "supine-firmware";
/// The self-test image's binary name.
pub const SELFTEST_BINARY: &str = "selftest";

/// Environment variable that names the repository root, for a `supine` binary that runs
/// away from the source tree it was built from.
pub const ROOT_ENV: &str = "SUPINE_ROOT";

/// Why the firmware could not be built or found. Each message is one line that says what
/// to do.
#[derive(Debug, thiserror::Error)]
pub enum FirmwareError {
    /// The repository root has no `Cargo.toml` or no `firmware/` folder.
    #[error("{0} is not the supine repository root: set {ROOT_ENV} to it")]
    NoRepository(PathBuf),
    /// `cargo` could not be started.
    #[error("cannot run cargo ({0}): install Rust with rustup")]
    CargoMissing(io::Error),
    /// The Rust target for the device is not installed.
    #[error(
        "the Rust target {TARGET} is not installed: run `rustup target add {TARGET}` (or `bash .ci/setup`)"
    )]
    TargetMissing,
    /// Cargo ran and failed; the first error line it printed.
    #[error("building the firmware failed: {0}")]
    BuildFailed(String),
    /// The build succeeded but produced no binary of that name.
    #[error("the firmware has no binary `{name}` (looked for {path})")]
    NoSuchBinary {
        /// The binary asked for.
        name: String,
        /// Where it should have been.
        path: PathBuf,
    },
}

/// The repository root: `$SUPINE_ROOT` if set, else the folder above this crate's sources
/// (fixed when `supine-host` was compiled).
pub fn repository_root() -> PathBuf {
    match std::env::var_os(ROOT_ENV) {
        Some(root) if !root.is_empty() => PathBuf::from(root),
        _ => Path::new(env!("CARGO_MANIFEST_DIR")).join(".."),
    }
}

/// Builds binary `name` of the firmware (if stale) under the repository root and returns
/// its ELF path.
pub fn build_binary(name: &str) -> Result<PathBuf, FirmwareError> {
    build_binary_in(&repository_root(), name)
}

/// As [`build_binary`], with an explicit repository root.
pub fn build_binary_in(root: &Path, name: &str) -> Result<PathBuf, FirmwareError> {
    if !root.join("Cargo.toml").is_file() || !root.join("firmware").is_dir() {
        return Err(FirmwareError::NoRepository(root.to_path_buf()));
    }
    let output = Command::new(cargo_program())
        .current_dir(root)
        .args(firmware_recipe::cargo_build_args(name))
        .arg("--target-dir")
        .arg(firmware_recipe::target_dir(root))
        // The caller's cargo (e.g. `cargo test`) may have set a target dir for itself.
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .map_err(FirmwareError::CargoMissing)?;
    if !output.status.success() {
        return Err(classify_failure(&String::from_utf8_lossy(&output.stderr)));
    }
    let path = output_dir(root).join(name);
    if path.is_file() {
        Ok(path)
    } else {
        Err(FirmwareError::NoSuchBinary {
            name: name.to_owned(),
            path,
        })
    }
}

/// The cargo that runs us (`$CARGO` under `cargo test` and `cargo run`), else `cargo`.
fn cargo_program() -> OsString {
    std::env::var_os("CARGO")
        .filter(|cargo| !cargo.is_empty())
        .unwrap_or_else(|| OsString::from("cargo"))
}

/// Turns cargo's stderr into the one error that says what to do.
fn classify_failure(stderr: &str) -> FirmwareError {
    if stderr.contains("target may not be installed")
        || stderr.contains("can't find crate for `core`")
    {
        return FirmwareError::TargetMissing;
    }
    let first_error = stderr
        .lines()
        .map(str::trim)
        .find(|line| line.starts_with("error"))
        .or_else(|| stderr.lines().map(str::trim).rfind(|line| !line.is_empty()))
        .unwrap_or("cargo printed nothing");
    FirmwareError::BuildFailed(first_error.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_target_is_reported_with_the_command_that_installs_it() {
        let stderr = "error[E0463]: can't find crate for `core`\n  = note: the `thumbv7em-none-eabihf` target may not be installed\n";
        let err = classify_failure(stderr);
        assert!(matches!(err, FirmwareError::TargetMissing));
        assert!(
            err.to_string()
                .contains("rustup target add thumbv7em-none-eabihf")
        );
    }

    #[test]
    fn a_compile_error_is_reported_by_its_first_error_line() {
        let stderr = "   Compiling supine-firmware v0.1.0\nerror[E0425]: cannot find value `x` in this scope\n --> firmware/src/main.rs:3:5\nerror: could not compile `supine-firmware`\n";
        let err = classify_failure(stderr);
        assert_eq!(
            err.to_string(),
            "building the firmware failed: error[E0425]: cannot find value `x` in this scope"
        );
    }

    #[test]
    fn a_folder_that_is_not_the_repository_is_refused_before_running_cargo() {
        let dir = tempfile::tempdir().expect("temp dir");
        let err = build_binary_in(dir.path(), SELFTEST_BINARY).expect_err("not a repository");
        assert!(matches!(err, FirmwareError::NoRepository(_)));
        assert!(err.to_string().contains(ROOT_ENV));
    }

    #[test]
    fn cargo_fw_is_the_recipe_for_the_product_image() {
        let config = std::fs::read_to_string(repository_root().join(".cargo/config.toml"))
            .expect(".cargo/config.toml");
        let alias = config
            .lines()
            .find_map(|l| l.strip_prefix("fw = "))
            .expect("a `fw` alias")
            .trim_matches('"');
        let recipe = firmware_recipe::cargo_build_args(PRODUCT_BINARY);
        // The alias builds every binary of the package; the recipe names one.
        let expected = format!("{} --target-dir target/firmware", recipe[..7].join(" "));
        assert_eq!(alias, expected);
    }

    #[test]
    fn the_default_root_is_the_workspace_above_the_host_crate() {
        // Without SUPINE_ROOT (cargo test does not set it) the root holds the workspace.
        if std::env::var_os(ROOT_ENV).is_none() {
            let root = repository_root();
            assert!(root.join("Cargo.toml").is_file(), "{}", root.display());
            assert!(root.join("firmware").is_dir(), "{}", root.display());
        }
    }
}
