//! Build script of the host library: the device's memory map, read from the repository's
//! `memory.x`, and the product firmware image the tool embeds (see `build/firmware_image.rs`).
//!
//! `memory.x` is what the QEMU images link with (`firmware/build.rs` copies it), so it is
//! the one place the regions are defined. This reads each region's origin and length from
//! its `MEMORY` block and writes them as constants to `OUT_DIR/memory_map.rs`, which
//! `src/device/memory_map.rs` includes: the host loads parameter blobs where the firmware reads
//! them, and the tests check the image against the same map.

use std::env;
use std::fs;
use std::path::PathBuf;

#[path = "build/firmware_image.rs"]
mod firmware_image;
#[path = "src/device/firmware_recipe.rs"]
mod firmware_recipe;

fn main() {
    let manifest_dir =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory_x = manifest_dir.join("..").join("memory.x");
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");

    let text = fs::read_to_string(&memory_x)
        .unwrap_or_else(|err| panic!("cannot read {}: {err}", memory_x.display()));
    let regions =
        memory_regions(&text).unwrap_or_else(|err| panic!("{}: {err}", memory_x.display()));
    let mut out = String::new();
    for region in &regions {
        let name = region.name.to_ascii_uppercase();
        out.push_str(&format!(
            "/// Start of the {name} region of `memory.x`.\n\
             pub const {name}_ORIGIN: u32 = {:#010x};\n\
             /// Size of the {name} region of `memory.x`, bytes.\n\
             pub const {name}_LENGTH_BYTES: u32 = {};\n",
            region.origin, region.length_bytes
        ));
    }
    fs::write(out_dir.join("memory_map.rs"), out).expect("cannot write memory_map.rs to OUT_DIR");

    firmware_image::build(&manifest_dir.join(".."), &out_dir);
}

/// One line of a `MEMORY` block: `NAME : ORIGIN = <number>, LENGTH = <number>`.
struct Region {
    name: String,
    origin: u32,
    length_bytes: u32,
}

/// The regions of the `MEMORY { ... }` block, in order (comments removed first).
fn memory_regions(text: &str) -> Result<Vec<Region>, String> {
    let text = without_comments(text);
    let start = text.find("MEMORY").ok_or("no MEMORY block")?;
    let body = text[start..]
        .split_once('{')
        .and_then(|(_, rest)| rest.split_once('}'))
        .map(|(body, _)| body)
        .ok_or("the MEMORY block has no braces")?;
    let regions = body
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .map(region)
        .collect::<Result<Vec<_>, _>>()?;
    if regions.is_empty() {
        return Err("the MEMORY block names no region".into());
    }
    Ok(regions)
}

/// Parses `NAME : ORIGIN = 0x0007_0000, LENGTH = 64K` (attributes in parentheses after the
/// name are allowed and ignored).
fn region(line: &str) -> Result<Region, String> {
    let bad = || format!("cannot read the region line `{line}`");
    let (name, rest) = line.split_once(':').ok_or_else(bad)?;
    let name = name.split('(').next().unwrap_or(name).trim();
    let mut origin = None;
    let mut length_bytes = None;
    for field in rest.split(',') {
        let (key, value) = field.split_once('=').ok_or_else(bad)?;
        let value = number(value.trim()).ok_or_else(bad)?;
        match key.trim() {
            "ORIGIN" | "org" | "o" => origin = Some(value),
            "LENGTH" | "len" | "l" => length_bytes = Some(value),
            _ => return Err(bad()),
        }
    }
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(bad());
    }
    Ok(Region {
        name: name.to_string(),
        origin: origin.ok_or_else(bad)?,
        length_bytes: length_bytes.ok_or_else(bad)?,
    })
}

/// A linker-script number: decimal, `0x` hexadecimal or octal with a leading 0, with an
/// optional `K` or `M` suffix (times 1024 or 1024 * 1024).
fn number(text: &str) -> Option<u32> {
    let (digits, scale) = match text.as_bytes().last()? {
        b'K' | b'k' => (&text[..text.len() - 1], 1024),
        b'M' | b'm' => (&text[..text.len() - 1], 1024 * 1024),
        _ => (text, 1),
    };
    let value = if let Some(hex) = digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
    {
        u32::from_str_radix(hex, 16).ok()?
    } else if digits.len() > 1 && digits.starts_with('0') {
        u32::from_str_radix(&digits[1..], 8).ok()?
    } else {
        digits.parse().ok()?
    };
    value.checked_mul(scale)
}

/// The text with `/* ... */` comments removed.
fn without_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("/*") {
        out.push_str(&rest[..start]);
        rest = rest[start + 2..]
            .split_once("*/")
            .map_or("", |(_, after)| after);
    }
    out.push_str(rest);
    out
}
