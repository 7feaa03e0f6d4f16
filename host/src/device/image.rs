//! What the installed tool carries for the device: the product firmware image and the
//! public development key it accepts uploads signed with.
//!
//! `build.rs` builds the image for the device with the tool (see
//! `host/build/firmware_image.rs`), so `supine demo`, `replay`, `monitor` and `flash --qemu`
//! run from any folder with nothing but `qemu-system-arm`: no source tree, no cargo. QEMU
//! loads a kernel from a file, so each run writes the embedded ELF to a private scratch
//! folder that goes when the run is done. `--firmware ELF` runs a developer's image instead.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context as _, Result, bail};
use supine_core::upload::KEY_LEN;

use crate::device::scratch::ScratchDir;

include!(concat!(env!("OUT_DIR"), "/firmware_image.rs"));

/// The public development key (64 hex digits), the one the embedded image is provisioned
/// with. It proves nothing: anyone can sign with it. A real device has its own key.
pub const DEVELOPMENT_KEY_HEX: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../firmware/keys/dev-device.key"
));

/// What every use of [`development_key`] tells the user.
pub const DEVELOPMENT_KEY_NOTICE: &str = "signing with the public development key built into supine (it \
     protects nothing; give a real device's key with --key)";

/// The public development key's bytes.
pub fn development_key() -> Result<[u8; KEY_LEN]> {
    supine_core::upload::parse_key(DEVELOPMENT_KEY_HEX)
        .map_err(|e| anyhow::anyhow!("the built-in development key: {e}"))
}

/// The product image a run starts: the embedded one (written to a scratch file that lives
/// as long as the last clone of this value) or a developer's ELF.
#[derive(Clone, Debug)]
pub struct ProductImage {
    path: PathBuf,
    embedded: Option<Arc<ScratchDir>>,
}

impl ProductImage {
    /// `elf` if given (`--firmware`), else the embedded image.
    pub fn select(elf: Option<&Path>) -> Result<Self> {
        match elf {
            Some(path) => Self::file(path),
            None => Self::embedded(),
        }
    }

    /// The image built with the tool, written to a private scratch folder.
    pub fn embedded() -> Result<Self> {
        let dir = ScratchDir::new("firmware").context("preparing the firmware image")?;
        let path = dir.path().join("supine-firmware.elf");
        std::fs::write(&path, PRODUCT_ELF)
            .with_context(|| format!("{}: cannot write the firmware image", path.display()))?;
        Ok(Self {
            path,
            embedded: Some(Arc::new(dir)),
        })
    }

    /// A developer's image (`--firmware ELF`): it must be a readable ELF file.
    pub fn file(path: &Path) -> Result<Self> {
        let mut magic = [0u8; 4];
        let read = std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic));
        if let Err(e) = read {
            bail!(
                "--firmware {}: cannot read an ELF file: {e}",
                path.display()
            );
        }
        if magic != *b"\x7fELF" {
            bail!(
                "--firmware {}: expected an ELF file (the device image), found other bytes",
                path.display()
            );
        }
        Ok(Self {
            path: path.to_path_buf(),
            embedded: None,
        })
    }

    /// The ELF file QEMU loads.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether this is the image built with the tool (not `--firmware`).
    pub fn is_embedded(&self) -> bool {
        self.embedded.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_image_is_an_arm_elf_and_its_file_goes_with_the_last_clone() {
        // e_machine (offset 18, little-endian) 40 is ARM: the device's image, not the host's.
        assert_eq!(&PRODUCT_ELF[..4], b"\x7fELF");
        assert_eq!(u16::from_le_bytes([PRODUCT_ELF[18], PRODUCT_ELF[19]]), 40);
        let image = ProductImage::select(None).expect("embedded image");
        assert!(image.is_embedded());
        assert_eq!(std::fs::read(image.path()).expect("written"), PRODUCT_ELF);
        let path = image.path().to_path_buf();
        let clone = image.clone();
        drop(image);
        assert!(path.is_file(), "a clone still uses it");
        drop(clone);
        assert!(!path.exists());
    }

    #[test]
    fn a_firmware_that_is_not_an_elf_is_refused_with_its_path() {
        let dir = tempfile::tempdir().expect("temp dir");
        let text = dir.path().join("notes.txt");
        std::fs::write(&text, "not an image").expect("write");
        let err = ProductImage::select(Some(&text)).expect_err("not an ELF");
        assert!(err.to_string().contains("notes.txt"), "{err}");
        assert!(err.to_string().contains("expected an ELF file"), "{err}");
        let missing = dir.path().join("missing.elf");
        let err = ProductImage::select(Some(&missing)).expect_err("missing");
        assert!(err.to_string().contains("missing.elf"), "{err}");
    }

    #[test]
    fn the_built_in_development_key_parses() {
        let key = development_key().expect("parses");
        assert_eq!(key.len(), KEY_LEN);
    }
}
