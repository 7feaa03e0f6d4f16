//! `supine monitor`: follow a device's telemetry and alerts live.
//!
//! - [`state`]: what the monitor knows ([`Monitor`]), fed one message at a time; pure, so
//!   it is tested without a terminal and reused by `supine demo`.
//! - [`view`]: the terminal rendering (a redrawn panel on a terminal, plain lines otherwise).
//! - [`color`]: whether the panel uses colour (`--color`, NO_COLOR).
//! - [`json`]: `--jsonl` (a JSON object per record and event) and the `--json` summary.
//! - [`log`]: the CSV log of every telemetry record and event.
//! - [`session`]: the loop that reads the link and drives the three, and the sources that
//!   feed it (QEMU with a streamed ride, or a serial port).

pub mod color;
pub mod json;
pub mod log;
pub mod session;
pub mod state;
pub mod view;

pub use state::{
    Counters, Monitor, Notice, Severity, criterion_text, describe_event, device_line, fault_names,
    params_source_text, patient_text,
};
