//! The firmware in QEMU against the host's reference, one module per file, in one binary.
//! Each file's own documentation says what it checks; `cargo test -p supine-qemu-tests
//! --test qemu NAME::` runs one file's tests.

mod demo;
mod harness;
mod hostile_device;
mod image_size;
mod monitor;
mod monitor_cli;
mod monitor_reanalysis;
mod replay_cli;
mod selftest;
mod upload;
mod verify;
