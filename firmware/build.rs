//! Build script of the device image.
//!
//! 1. Links with the repository's one `memory.x` (copied to `OUT_DIR`, which is put on the
//!    linker search path) and cortex-m-rt's `link.x`. The link arguments live here, not in a
//!    `.cargo/config.toml`, so they apply however cargo is invoked (`cargo fw` from the root).
//! 2. Bakes the default model realization into the image: the paper's litter-board preset,
//!    discretized at the device's default sample rate on the build machine in f64 by
//!    `supine-core` (the same code the host runs) and stored as postcard bytes that the
//!    firmware decodes and validates at boot.
//! 3. Provisions the device key for authenticated parameter uploads: the file named by
//!    `SUPINE_DEVICE_KEY_FILE` (64 hex digits), by default the committed development key
//!    `keys/dev-device.key` (for QEMU and the tests only; see `keys/README.md`).

use std::env;
use std::fs;
use std::path::PathBuf;

use supine_core::blob::{DeviceParams, MAX_BLOB_LEN, Patient};
use supine_core::model::{
    DEFAULT_SAMPLE_RATE_HZ, ModelParams, Preset, device_model, device_realization,
};
use supine_core::sample_rate::SampleRate;

/// Identity of the built-in default parameters (not a SHA-256: a fixed, readable name that
/// the host prints as "built-in").
const BUILTIN_IDENTITY: [u8; 16] = *b"builtin-litter\0\0";

/// Upper bound of the encoded realization; it must also fit the 64 KiB parameter region.
const MAX_ENCODED_BYTES: usize = 64 * 1024;

fn main() {
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest_dir =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));

    link_with_root_memory_map(&manifest_dir, &out_dir);
    write_builtin_realization(&out_dir);
    write_default_blob(&out_dir);
    write_device_key(&manifest_dir, &out_dir);

    println!("cargo:rerun-if-changed=build.rs");
}

/// Copies `<root>/memory.x` next to the build outputs and adds the link arguments.
fn link_with_root_memory_map(manifest_dir: &std::path::Path, out_dir: &std::path::Path) {
    // The real board has its own map; every QEMU image uses the repository's one.
    let board = env::var_os("CARGO_FEATURE_BOARD_BLACKPILL").is_some();
    let memory_x = if board {
        manifest_dir.join("boards").join("blackpill-memory.x")
    } else {
        manifest_dir.join("..").join("memory.x")
    };
    fs::copy(&memory_x, out_dir.join("memory.x"))
        .unwrap_or_else(|err| panic!("cannot copy {}: {err}", memory_x.display()));
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rustc-link-search={}", out_dir.display());

    // Only the bare-metal target links with cortex-m-rt's script.
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-arg=--nmagic");
        println!("cargo:rustc-link-arg=-Tlink.x");
        if board {
            // defmt's symbol table for the board's diagnostics (defmt-rtt).
            println!("cargo:rustc-link-arg=-Tdefmt.x");
        }
    }
}

/// Computes the default realization and writes `realization.postcard` and
/// `realization.rs` (its sample rate as a constant) to `OUT_DIR`.
fn write_builtin_realization(out_dir: &std::path::Path) {
    // The device's default rate, a whole number of Hz: the firmware prints it as an
    // integer (formatting floats would cost it some 17 KiB of flash).
    let sample_rate_hz = DEFAULT_SAMPLE_RATE_HZ as u32;
    assert_eq!(
        f64::from(sample_rate_hz),
        DEFAULT_SAMPLE_RATE_HZ,
        "the default sample rate must be a whole number of Hz"
    );
    let params = ModelParams::preset(Preset::PaperLitter);
    let realization = device_realization(&params, f64::from(sample_rate_hz))
        .unwrap_or_else(|err| panic!("the paper-litter preset does not discretize: {err}"));

    let mut buf = vec![0u8; MAX_ENCODED_BYTES];
    let used = postcard::to_slice(&realization, &mut buf)
        .unwrap_or_else(|err| {
            panic!("the realization does not encode in {MAX_ENCODED_BYTES} bytes: {err}")
        })
        .len();
    fs::write(out_dir.join("realization.postcard"), &buf[..used])
        .expect("cannot write realization.postcard to OUT_DIR");
    fs::write(
        out_dir.join("realization.rs"),
        format!(
            "/// Sample rate the built-in realization was discretized for, Hz.\n\
             pub const SAMPLE_RATE_HZ: u32 = {sample_rate_hz};\n"
        ),
    )
    .expect("cannot write realization.rs to OUT_DIR");
}

/// Writes `default_blob.bin` to `OUT_DIR`: the full parameter blob of the built-in default
/// (paper litter-board preset at the default rate, default exposure, alert and sensor
/// settings, level mounting, telemetry at 100 Hz). The firmware decodes and validates it
/// at boot exactly like a blob in flash.
fn write_default_blob(out_dir: &std::path::Path) {
    let model = ModelParams::preset(Preset::PaperLitter);
    let (realization, joints) = device_model(&model, DEFAULT_SAMPLE_RATE_HZ)
        .unwrap_or_else(|err| panic!("the paper-litter preset does not discretize: {err}"));
    let sample_rate = SampleRate::from_hz_f64(DEFAULT_SAMPLE_RATE_HZ)
        .unwrap_or_else(|err| panic!("the default sample rate: {err}"));
    let patient = Patient::of(&model.subject);
    let params =
        DeviceParams::with_defaults(BUILTIN_IDENTITY, patient, sample_rate, realization, joints)
            .unwrap_or_else(|err| panic!("the default device parameters are refused: {err}"));
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let len = params
        .encode(&mut buf)
        .unwrap_or_else(|err| panic!("the default blob does not encode: {err}"));
    fs::write(out_dir.join("default_blob.bin"), &buf[..len])
        .expect("cannot write default_blob.bin to OUT_DIR");
}

/// Environment variable naming the device key file.
const KEY_FILE_ENV: &str = "SUPINE_DEVICE_KEY_FILE";

/// Writes `device_key.rs` to `OUT_DIR`: the key from `$SUPINE_DEVICE_KEY_FILE`, or the
/// development key. Parsed by `supine_core::upload::parse_key`, as the host reads it.
fn write_device_key(manifest_dir: &std::path::Path, out_dir: &std::path::Path) {
    println!("cargo:rerun-if-env-changed={KEY_FILE_ENV}");
    let (path, development) = match env::var_os(KEY_FILE_ENV).filter(|p| !p.is_empty()) {
        Some(path) => (PathBuf::from(path), false),
        None => (manifest_dir.join("keys").join("dev-device.key"), true),
    };
    println!("cargo:rerun-if-changed={}", path.display());
    let text = fs::read_to_string(&path)
        .unwrap_or_else(|err| panic!("{KEY_FILE_ENV}: cannot read {}: {err}", path.display()));
    let key = supine_core::upload::parse_key(&text)
        .unwrap_or_else(|err| panic!("{KEY_FILE_ENV}: {}: {err}", path.display()));
    fs::write(
        out_dir.join("device_key.rs"),
        format!(
            "/// The key uploads must be signed with (provisioned at build time).\n\
             pub(crate) static DEVICE_KEY: [u8; {}] = {key:?};\n\
             /// Whether it is the public development key (QEMU and tests only).\n\
             pub const DEVELOPMENT_KEY: bool = {development};\n",
            key.len()
        ),
    )
    .expect("cannot write device_key.rs to OUT_DIR");
}
