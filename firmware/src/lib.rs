//! supine-firmware: the device side of supine on QEMU's mps2-an386 (Cortex-M4F).
//!
//! The library holds what every image shares; the images themselves are thin:
//! `src/main.rs` is the product, `src/bin/selftest.rs` runs the model core on the
//! built-in test vector for the QEMU tests, and `src/bin/panics.rs` and
//! `src/bin/hardfault.rs` prove that a panic and a fault end a run with a failing status.
//!
//! `src/main.rs` runs [`app::App`], the monitor's main loop, with replayed samples from
//! the UART; `src/bin/panic_reset.rs` is the same monitor that panics once at first boot,
//! to test the panic record across a reset; `src/bin/power_cut.rs` is the same monitor
//! whose power fails mid flash update, to test the A/B slots; `src/bin/blackpill.rs` (feature
//! `board-blackpill`, `cargo fw-board`) is the monitor on an STM32F411 with an LIS3DH.
//!
//! Each module has one job: [`board`] names the board's types, [`cmsdk_uart`] drives its
//! UART, [`console`] writes lines to the debugger's stdout (semihosting), [`exit`] ends a
//! run with a status, [`cycles`] counts instructions, [`stack`] measures the stack's
//! high-water mark, [`params`] loads the model parameters, [`param_flash`] reads and writes
//! their A/B slots, [`panic_record`] keeps the last panic across a reset and [`app`] is
//! the monitor (its per-sample frame encoder is `supine_core::protocol::telemetry_frame`).
#![no_std]

pub mod app;
pub mod board;
pub mod cmsdk_uart;
pub mod console;
pub mod cycles;
pub mod exit;
mod fault;
pub mod panic_record;
pub mod param_flash;
pub mod params;
pub mod stack;

pub use fault::reset_on_panic;

/// The firmware's version, reported in its greeting and in the self-test output.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
