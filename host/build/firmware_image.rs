//! The product firmware image, built for the device and copied into `OUT_DIR`, so that
//! `src/device/firmware.rs` embeds it and the installed `supine` needs no source tree or
//! cargo at run time (issue 14, item 1).
//!
//! The nested cargo runs the build of `src/device/firmware_recipe.rs` (as `cargo fw` does)
//! from the repository root, so the root `.cargo/config.toml` (the device's rustflags)
//! applies and the team's `cargo fw` builds are reused. Its own target dir keeps it off the outer
//! build's lock. The environment cargo gives a build script describes the *host* build
//! (its rustflags, target dir, wrappers such as clippy-driver); passed on, it would build
//! the firmware with the wrong flags, or rebuild it for every outer profile, so it is
//! removed first.

use std::env;
use std::fs;
use std::path::Path;
use std::process::Command;

use crate::firmware_recipe::{self, PACKAGE, PROFILE, TARGET};

/// The name of the embedded copy in `OUT_DIR`.
const EMBEDDED_NAME: &str = "supine-firmware.elf";

/// Variables cargo sets (or a user sets) for the outer build that must not reach the
/// nested one: host rustflags would replace the device's, a target dir or build target
/// would redirect it, a rustc wrapper (clippy) would change how it compiles.
const OUTER_BUILD_ENV: &[&str] = &[
    "CARGO_ENCODED_RUSTFLAGS",
    "RUSTFLAGS",
    "CARGO_BUILD_RUSTFLAGS",
    "CARGO_TARGET_DIR",
    "CARGO_BUILD_TARGET_DIR",
    "CARGO_BUILD_TARGET",
    "RUSTC_WRAPPER",
    "RUSTC_WORKSPACE_WRAPPER",
    "CARGO_BUILD_RUSTC_WRAPPER",
    "CARGO_BUILD_RUSTC_WORKSPACE_WRAPPER",
    "CLIPPY_ARGS",
    "CLIPPY_CONF_DIR",
    // The embedded image is the QEMU development image: always the public development
    // key, which the host embeds beside it. A real device's key goes into `cargo fw-board`.
    "SUPINE_DEVICE_KEY_FILE",
];

/// The inputs of the firmware build under the repository root: a change to any of them
/// reruns this script (cargo then decides what is stale).
const INPUTS: &[&str] = &[
    "firmware",
    "shared/src",
    "shared/Cargo.toml",
    "memory.x",
    "Cargo.toml",
    "Cargo.lock",
    ".cargo/config.toml",
];

/// Builds the product image (if stale), copies it to `out_dir/EMBEDDED_NAME` and writes
/// `out_dir/firmware_image.rs`, which embeds it as `PRODUCT_ELF`.
pub fn build(root: &Path, out_dir: &Path) {
    println!("cargo:rerun-if-changed=build/firmware_image.rs");
    for input in INPUTS {
        println!("cargo:rerun-if-changed={}", root.join(input).display());
    }
    let cargo = env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(cargo);
    command
        .current_dir(root)
        .args(firmware_recipe::cargo_build_args(PACKAGE))
        .arg("--target-dir")
        .arg(firmware_recipe::target_dir(root));
    for name in OUTER_BUILD_ENV {
        command.env_remove(name);
    }
    let output = command
        .output()
        .unwrap_or_else(|err| panic!("cannot run cargo to build the firmware: {err}"));
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let hint = if stderr.contains("target may not be installed")
            || stderr.contains("can't find crate for `core`")
        {
            format!("\nrun `rustup target add {TARGET}` (or `bash .ci/setup`)")
        } else {
            String::new()
        };
        panic!("building the firmware image for {TARGET} failed:\n{stderr}{hint}");
    }
    let elf = firmware_recipe::output_dir(root).join(PACKAGE);
    let embedded = out_dir.join(EMBEDDED_NAME);
    fs::copy(&elf, &embedded).unwrap_or_else(|err| panic!("cannot copy {}: {err}", elf.display()));
    fs::write(
        out_dir.join("firmware_image.rs"),
        format!(
            "/// The product image (`{PACKAGE}`, profile `{PROFILE}`, {TARGET}), built with the tool.\n\
             pub static PRODUCT_ELF: &[u8] = include_bytes!({:?});\n",
            embedded.display().to_string()
        ),
    )
    .expect("cannot write firmware_image.rs to OUT_DIR");
}
