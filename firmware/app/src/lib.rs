//! supine-app: the monitor's application logic, apart from any board.
//!
//! [`App`] is the device's main loop: protocol frames in over a byte link, the pipeline,
//! telemetry, alerts and answers out, authenticated parameter updates into flash. It
//! depends on nothing Cortex-M: the link is any `embedded-io` reader and writer
//! ([`Link`]), time is a [`TickCounter`], the stack's depth a [`StackGauge`] and the
//! parameter slots a `supine_core::upload::ParamFlash`. The firmware supplies its UARTs,
//! SysTick, painted stack and flash; the host tests (`tests/`) drive the same code with
//! buffers and a simulated flash and compare its output with `supine_core::pipeline`.
//!
//! Each module has one job: [`Boot`] says what the device starts with, `link` moves single
//! bytes over the link, `tx_ring` queues outgoing frames (encoded by
//! `supine_core::protocol::telemetry_frame`), `input_stream` keeps and sends the model's input on request, `updates` holds the parameter slots and the upload in progress, and
//! `monitor` is the loop itself.
#![no_std]

mod boot;
mod counter;
mod input_stream;
mod link;
mod monitor;
mod stack_gauge;
mod tx_ring;
mod updates;

pub use boot::Boot;
pub use counter::{TickCounter, ticks_in_ms};
pub use link::Link;
pub use monitor::{App, IDLE_FLUSH_MS, MAX_LOST_SPAN_S};
pub use stack_gauge::StackGauge;
pub use updates::NoUpdates;

/// The firmware's version, reported in its greeting: the workspace's, which the firmware
/// crate and this one share.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
