//! Lines of text to the debugger's (QEMU's) stdout through semihosting.
//!
//! The self-test reports through here rather than the UART so its output needs no
//! connection and no decoder: QEMU prints it on its own stdout, one line per `writeln!`.
//! A line is buffered and sent in a single semihosting call, so output is cheap and lines
//! never interleave with the panic handler's stderr.

use core::fmt;

use cortex_m_semihosting::hio::{self, HostStream};

/// Longest line sent in one piece; longer lines are sent in pieces of this size.
const LINE_BYTES: usize = 128;

/// Semihosting stdout with a one-line buffer.
pub struct Console {
    stream: HostStream,
    line: [u8; LINE_BYTES],
    len: usize,
}

/// The debugger refused to open its stdout or to write to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConsoleError;

impl fmt::Display for ConsoleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("semihosting stdout is not available")
    }
}

impl core::error::Error for ConsoleError {}

impl Console {
    /// Opens the debugger's stdout (QEMU needs `-semihosting-config enable=on`).
    pub fn stdout() -> Result<Self, ConsoleError> {
        let stream = hio::hstdout().map_err(|()| ConsoleError)?;
        Ok(Self {
            stream,
            line: [0; LINE_BYTES],
            len: 0,
        })
    }

    /// Sends what is buffered.
    pub fn flush(&mut self) -> Result<(), ConsoleError> {
        let pending = &self.line[..self.len];
        self.len = 0;
        self.stream.write_all(pending).map_err(|()| ConsoleError)
    }
}

impl fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for &byte in s.as_bytes() {
            if self.len == LINE_BYTES {
                self.flush().map_err(|_| fmt::Error)?;
            }
            self.line[self.len] = byte;
            self.len += 1;
            if byte == b'\n' {
                self.flush().map_err(|_| fmt::Error)?;
            }
        }
        Ok(())
    }
}
