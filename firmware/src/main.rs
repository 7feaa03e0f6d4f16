//! The supine device image.
//!
//! Today it boots, checks its built-in model parameters and the parameter blob in the
//! PARAMS region, greets the host on UART0 with its version, the parameters' identity and
//! the blob's state, and then polls the UART. The protocol (replay,
//! exposure, alerts) grows from the polling loop.
#![no_std]
#![no_main]

use core::fmt::Write;

use cortex_m_rt::entry;
use supine_firmware::board::Board;
use supine_firmware::{VERSION, exit, params};

#[entry]
fn main() -> ! {
    let Some(board) = Board::take() else {
        // Only reachable if something took the peripherals before main: a build error.
        exit::exit(exit::FAILURE)
    };
    let mut uart = board.uart0;

    let bytes = params::builtin_bytes();
    let status = match params::decode(bytes) {
        Ok(_) => "ok",
        Err(_) => "invalid",
    };
    // Writing to the UART cannot fail (it waits for room).
    let _ = write!(
        uart,
        "supine-firmware {VERSION} params builtin crc32 {:08x} {status} fs_hz {} blob ",
        params::identity(bytes),
        params::SAMPLE_RATE_HZ,
    );
    let _ = match params::stored_blob() {
        Ok(_) => writeln!(uart, "ok"),
        Err(err) => writeln!(uart, "refused: {err}"),
    };

    loop {
        // Nothing is understood yet: take each byte so the one-deep RX never stalls the host.
        let _ = uart.try_read_byte();
    }
}
