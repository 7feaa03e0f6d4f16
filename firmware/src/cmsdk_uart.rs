//! Driver for the ARM CMSDK APB UART (the MPS2 boards' UART, modelled by QEMU).
//!
//! Polled, one byte deep in each direction; an empty receiver is polled with a short pause
//! in between ([`EMPTY_POLL_BACKOFF_CYCLES`]). Registers (offsets from the base): DATA +0x00,
//! STATE +0x04 (bit 0 TX full, bit 1 RX full), CTRL +0x08 (bit 0 TX enable, bit 1 RX
//! enable), BAUDDIV +0x10 (at least 16). Implements the `embedded-io` traits (embedded-hal
//! 1.0 left serial ports to `embedded-io`) and `core::fmt::Write`.

use core::convert::Infallible;
use core::ptr;

const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const BAUDDIV: usize = 0x10;

const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const CTRL_TX_ENABLE: u32 = 1 << 0;
const CTRL_RX_ENABLE: u32 = 1 << 1;

/// The smallest divider the CMSDK UART accepts.
const MIN_BAUDDIV: u32 = 16;

/// Cycles the driver waits after finding RX empty, before the main loop polls again.
///
/// Under QEMU every register access takes the emulator's global lock, and the thread that
/// moves the next received byte from the host's socket into the UART needs that lock too:
/// a main loop that polls STATE back to back starves it, and each byte waits (see
/// BENCHMARKS.md, "replay throughput"). A pause without register accesses leaves the lock
/// free. 1,000 cycles are 40 us at the board's 25 MHz, under half of one byte's time at
/// UART0's 115,200 baud (87 us), so the one-deep receiver cannot overrun during it.
const EMPTY_POLL_BACKOFF_CYCLES: u32 = 1000;

/// A CMSDK APB UART, enabled for transmit and receive.
pub struct CmsdkUart {
    base: usize,
}

impl CmsdkUart {
    /// Programs the baud divider (`pclk_hz / baud`, at least 16) and enables TX and RX.
    ///
    /// # Safety
    /// `base` must be the address of a CMSDK APB UART register block, and no other code may
    /// access that block while the returned driver exists.
    pub unsafe fn new(base: usize, pclk_hz: u32, baud: u32) -> Self {
        let uart = Self { base };
        let divider = (pclk_hz / baud.max(1)).max(MIN_BAUDDIV);
        uart.write_reg(BAUDDIV, divider);
        uart.write_reg(CTRL, CTRL_TX_ENABLE | CTRL_RX_ENABLE);
        uart
    }

    /// Sends one byte if the transmitter has room; returns whether it was sent.
    pub fn try_write_byte(&mut self, byte: u8) -> bool {
        if self.read_reg(STATE) & STATE_TX_FULL != 0 {
            return false;
        }
        self.write_reg(DATA, u32::from(byte));
        true
    }

    /// Sends one byte, waiting while the transmitter is full.
    pub fn write_byte(&mut self, byte: u8) {
        while !self.try_write_byte(byte) {}
    }

    /// Takes the received byte, if there is one.
    pub fn try_read_byte(&mut self) -> Option<u8> {
        if self.read_reg(STATE) & STATE_RX_FULL == 0 {
            return None;
        }
        // The data register holds the byte in its low 8 bits.
        Some((self.read_reg(DATA) & 0xFF) as u8)
    }

    fn read_reg(&self, offset: usize) -> u32 {
        // SAFETY: `new`'s contract makes base + offset a register of a UART this driver
        // owns; MMIO registers are 4-byte aligned and need volatile access.
        unsafe { ptr::read_volatile((self.base + offset) as *const u32) }
    }

    fn write_reg(&self, offset: usize, value: u32) {
        // SAFETY: as in `read_reg`.
        unsafe { ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }
}

impl embedded_io::ErrorType for CmsdkUart {
    type Error = Infallible;
}

impl embedded_io::Write for CmsdkUart {
    /// Sends all of `buf`, waiting for room byte by byte.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &byte in buf {
            self.write_byte(byte);
        }
        Ok(buf.len())
    }

    /// Nothing to do: a byte in DATA goes out on its own.
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl embedded_io::WriteReady for CmsdkUart {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_TX_FULL == 0)
    }
}

impl embedded_io::Read for CmsdkUart {
    /// Waits for the first byte, then takes what has arrived (at most one: RX is one deep).
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let Some(first) = buf.first_mut() else {
            return Ok(0);
        };
        *first = loop {
            if let Some(byte) = self.try_read_byte() {
                break byte;
            }
        };
        Ok(1)
    }
}

impl embedded_io::ReadReady for CmsdkUart {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        let ready = self.read_reg(STATE) & STATE_RX_FULL != 0;
        if !ready {
            cortex_m::asm::delay(EMPTY_POLL_BACKOFF_CYCLES);
        }
        Ok(ready)
    }
}

impl core::fmt::Write for CmsdkUart {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for &byte in s.as_bytes() {
            self.write_byte(byte);
        }
        Ok(())
    }
}
