//! How a device image is built: the one definition of the recipe `cargo fw` spells in
//! `.cargo/config.toml` (a test holds the alias to it), used by the build script that
//! embeds the product image (`host/build/firmware_image.rs`, which includes this file) and
//! by [`crate::device::firmware`] for the tests' images. Plain `std`, no `crate::` paths,
//! so the build script can compile it on its own.

use std::path::{Path, PathBuf};

/// The firmware's package name (also the product image's binary name).
pub const PACKAGE: &str = "supine-firmware";
/// The device's target triple (Cortex-M4F with hardware floats).
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The cargo profile of the device image (defined in the root `Cargo.toml`).
pub const PROFILE: &str = "fw";

/// The device's own target dir under the repository `root`: it keeps device builds off
/// the host build's lock.
pub fn target_dir(root: &Path) -> PathBuf {
    root.join("target").join("firmware")
}

/// Where the images' ELF files land under `root`.
pub fn output_dir(root: &Path) -> PathBuf {
    target_dir(root).join(TARGET).join(PROFILE)
}

/// The arguments of `cargo` that build `binary` (run from the repository root, so the
/// root `.cargo/config.toml`, the device's rustflags, applies); the target dir follows.
pub fn cargo_build_args(binary: &str) -> [&str; 9] {
    [
        "build",
        "--package",
        PACKAGE,
        "--profile",
        PROFILE,
        "--target",
        TARGET,
        "--bin",
        binary,
    ]
}
