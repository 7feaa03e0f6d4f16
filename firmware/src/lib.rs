//! supine-firmware: the device side of supine, on QEMU's mps2-an386 (Cortex-M4F) and on
//! the STM32F411 Black Pill.
//!
//! The library holds the boards, the drivers and the startup that every image shares; the
//! monitor itself, independent of any board, is the `supine-app` crate ([`supine_app::App`]),
//! which these images run. The images are thin: `src/main.rs` is the product, running the
//! monitor with replayed samples from UART0; `src/bin/selftest.rs` runs the model core on
//! the built-in test vector for the QEMU tests; `src/bin/panics.rs` and
//! `src/bin/hardfault.rs` prove that a panic and a fault end a run with a failing status;
//! `src/bin/panic_reset.rs` is the monitor that panics once at first boot, to test the
//! panic record across a reset; `src/bin/power_cut.rs` is the monitor whose power fails
//! mid flash update, to test the A/B slots; `src/bin/blackpill.rs` (feature
//! `board-blackpill`, `cargo fw-board`) is the monitor on an STM32F411 with an LIS3DH.
//!
//! Each module has one job: [`boards`] holds one module per board (peripherals, clocks,
//! writing the parameter slots, what a fault does), [`cmsdk_uart`] drives the mps2 UART,
//! [`console`] writes lines to the debugger's stdout (semihosting), [`exit`] ends a run
//! with a status, [`cycles`] counts instructions (the monitor's clock), [`stack`] measures
//! the stack's high-water mark, [`params`] loads the model parameters, [`param_flash`]
//! owns and reads their A/B slots, [`panic_record`] keeps the last panic across a reset,
//! [`host_file`] reads the host's files and command line (semihosting), and
//! [`replay_link`] puts a replay's frames from such a file ahead of the UART.
#![no_std]

pub mod boards;
pub mod cmsdk_uart;
pub mod console;
pub mod cycles;
pub mod exit;
mod fault;
pub mod host_file;
pub mod panic_record;
pub mod param_flash;
pub mod params;
pub mod replay_link;
pub mod stack;

pub use fault::reset_on_panic;
pub use supine_app::VERSION;
