//! The device as the host sees it: what it runs, how it is built and started, and how the
//! host talks to it.
//!
//! - [`device_params`]: a parameter file turned into the device's blob and its identity.
//! - [`image`]: the firmware image and development key built into the tool.
//! - [`firmware_recipe`]: how a device image is built (package, profile, target, folders).
//! - [`firmware`]: building device images from the source tree (the QEMU tests).
//! - [`qemu`]: running the image in QEMU (mps2-an386).
//! - [`link`]: the host's end of the wire protocol.
//! - [`memory_map`]: the device's memory regions, read from `memory.x` at build time.
//! - [`upload_client`]: the authenticated parameter upload.
//! - [`flash`]: getting parameters onto a device (region image, upload, probe-rs).
//! - [`replay`]: a recording streamed through the image in QEMU.
//! - [`signals`]: Ctrl-C and friends stop QEMU cleanly.
//! - [`scratch`]: private temporary folders that abandoned runs leave for the next to sweep.

pub mod device_params;
pub mod device_records;
pub mod firmware;
pub mod firmware_recipe;
pub mod flash;
pub mod image;
pub mod link;
pub mod memory_map;
pub mod qemu;
pub mod replay;
pub mod scratch;
pub mod signals;
pub mod upload_client;
