//! The link of the product image under QEMU: a replay's frames from a host file first,
//! then UART0 for everything else (see [`crate::host_file`] for why).
//!
//! The bytes read from the file go through the monitor's frame decoder exactly as bytes
//! from the UART would; replies always go out on the UART.

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};

use crate::host_file::HostFile;

/// Bytes read from the host file per semihosting call: a few frames, so the calls cost
/// little beside the pipeline, and little stack (the link lives in the monitor).
const BLOCK_LEN: usize = 64;

/// `link`, with the bytes of a host file read ahead of it.
pub struct ReplayLink<L> {
    link: L,
    file: Option<HostFile>,
    block: [u8; BLOCK_LEN],
    next: usize,
    end: usize,
}

impl<L> ReplayLink<L> {
    /// Reads `file` to its end, then `link`; writes go to `link`.
    pub fn new(link: L, file: Option<HostFile>) -> Self {
        Self {
            link,
            file,
            block: [0; BLOCK_LEN],
            next: 0,
            end: 0,
        }
    }

    /// Whether a file byte is waiting, reading the next block if needed; closes the file
    /// at its end.
    fn file_ready(&mut self) -> bool {
        if self.next < self.end {
            return true;
        }
        let Some(file) = &mut self.file else {
            return false;
        };
        self.next = 0;
        self.end = file.read(&mut self.block);
        if self.end == 0 {
            self.file = None;
        }
        self.end > 0
    }
}

impl<L: ErrorType> ErrorType for ReplayLink<L> {
    type Error = L::Error;
}

impl<L: Read> Read for ReplayLink<L> {
    /// One byte from the file while it lasts (the monitor reads one at a time, as the
    /// UARTs give them), then from the link.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if let Some(to) = buf.first_mut()
            && self.file_ready()
        {
            *to = self.block.get(self.next).copied().unwrap_or_default();
            self.next += 1;
            return Ok(1);
        }
        self.link.read(buf)
    }
}

impl<L: ReadReady> ReadReady for ReplayLink<L> {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        if self.file_ready() {
            return Ok(true);
        }
        self.link.read_ready()
    }
}

impl<L: Write> Write for ReplayLink<L> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.link.write(buf)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        self.link.flush()
    }
}

impl<L: WriteReady> WriteReady for ReplayLink<L> {
    fn write_ready(&mut self) -> Result<bool, Self::Error> {
        self.link.write_ready()
    }
}
