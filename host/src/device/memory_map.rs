//! The device's memory map under QEMU, as `memory.x` defines it.
//!
//! `build.rs` reads the regions from the repository's `memory.x`, the file the QEMU images
//! link with, so the host has no second copy of an address: `PARAMS_ORIGIN` is where
//! QEMU's loader places a parameter blob and where the firmware reads its slots;
//! `RAM_ORIGIN` is where the image's statics and stack begin.

use supine_core::upload::{SLOT_COUNT, SLOT_LEN};

include!(concat!(env!("OUT_DIR"), "/memory_map.rs"));

// Checked when the map is read, so an edit of `memory.x` that breaks them fails the build:
// the firmware refuses a PARAMS region that does not hold its two slots, the code's flash
// ends where PARAMS begins, and RAM lies above both.
const _: () = assert!(PARAMS_LENGTH_BYTES as usize == SLOT_COUNT * SLOT_LEN);
const _: () = assert!(FLASH_ORIGIN + FLASH_LENGTH_BYTES == PARAMS_ORIGIN);
const _: () = assert!(PARAMS_ORIGIN + PARAMS_LENGTH_BYTES <= RAM_ORIGIN);
