//! A logger's rows parsed once: the scan ([`Conditioned::scan`](crate::ride::conditioned::Conditioned::scan))
//! writes each row it reads (line, time, x, y, z) in binary to an unnamed scratch file,
//! and every pass after reads them from there instead of parsing the text again
//! (parsing is most of a pass). Memory holds a buffer, whatever the ride's length; the
//! file takes [`RECORD_BYTES`] a row on disk (about the text's size; a ride of an hour
//! stays in the page cache) and is gone when the last handle is dropped or the process
//! ends. Where no scratch file can be made or written, the passes parse the text again
//! ([`ScratchWriter::finish`] gives `None`).
//!
//! The rows read back are those written, bit for bit (f64 and u64 in little-endian).
//! Written here rather than taken from a crate: a fixed-size record of five numbers, and
//! `tempfile`'s unnamed file.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::sync::Arc;

use anyhow::{Result, anyhow};

use crate::ride::conditioned::{FileRows, RawRows};

/// Bytes of one row: its line (u64), time, x, y, z (f64).
pub const RECORD_BYTES: usize = 40;
/// Rows read or written per system call.
const BUFFER_ROWS: usize = 4096;

/// The rows as the scan read them, written as it reads them.
pub struct ScratchWriter {
    out: Option<BufWriter<File>>,
    rows: u64,
}

impl ScratchWriter {
    /// A writer to a new unnamed scratch file; one that writes nothing where the
    /// platform has no positioned reads or no scratch file can be made.
    pub fn new() -> Self {
        let out = if cfg!(unix) {
            tempfile::tempfile()
                .ok()
                .map(|f| BufWriter::with_capacity(BUFFER_ROWS * RECORD_BYTES, f))
        } else {
            None
        };
        Self { out, rows: 0 }
    }

    /// A writer that keeps nothing.
    pub fn nowhere() -> Self {
        Self { out: None, rows: 0 }
    }

    /// Writes the row on `line` at `time_s` with `values` (m/s^2); a failure to write
    /// (a full disk) gives up the scratch copy, not the ride.
    pub fn push(&mut self, line: u64, time_s: f64, values: [f64; 3]) {
        let Some(out) = &mut self.out else {
            return;
        };
        let mut record = [0u8; RECORD_BYTES];
        record[..8].copy_from_slice(&line.to_le_bytes());
        for (k, v) in [time_s, values[0], values[1], values[2]].iter().enumerate() {
            record[8 + 8 * k..16 + 8 * k].copy_from_slice(&v.to_le_bytes());
        }
        if out.write_all(&record).is_ok() {
            self.rows += 1;
        } else {
            self.out = None;
        }
    }

    /// The rows written, to be read again; `None` when they could not all be written.
    pub fn finish(self) -> Option<ScratchRows> {
        let file = self.out?.into_inner().ok()?;
        Some(ScratchRows {
            file: Arc::new(file),
            rows: self.rows,
        })
    }
}

impl Default for ScratchWriter {
    fn default() -> Self {
        Self::new()
    }
}

/// Rows in a scratch file, read again on each pass (passes may run side by side: each
/// reads at its own offset).
#[derive(Clone, Debug)]
pub struct ScratchRows {
    file: Arc<File>,
    rows: u64,
}

impl ScratchRows {
    /// Number of rows.
    pub fn len(&self) -> u64 {
        self.rows
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.rows == 0
    }
}

impl RawRows for ScratchRows {
    fn open_rows(&self) -> Result<FileRows<'_>> {
        let mut buffer = Vec::new();
        let mut at = 0usize;
        let mut next = 0u64;
        Ok(Box::new(std::iter::from_fn(move || {
            if next == self.rows {
                return None;
            }
            if at == buffer.len() {
                let count = (self.rows - next).min(BUFFER_ROWS as u64) as usize;
                buffer.resize(count * RECORD_BYTES, 0);
                if let Err(e) = read_at(&self.file, &mut buffer, next * RECORD_BYTES as u64) {
                    next = self.rows;
                    return Some(Err(anyhow!("the ride's scratch copy: {e}")));
                }
                at = 0;
            }
            let record = &buffer[at..at + RECORD_BYTES];
            let number = |k: usize| -> [u8; 8] { std::array::from_fn(|i| record[8 * k + i]) };
            at += RECORD_BYTES;
            next += 1;
            let f = |k: usize| f64::from_le_bytes(number(k));
            Some(Ok((
                u64::from_le_bytes(number(0)),
                f(1),
                [f(2), f(3), f(4)],
            )))
        })))
    }
}

/// Fills `buffer` from `file` at `offset`, without moving a shared file position.
#[cfg(unix)]
fn read_at(file: &File, buffer: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buffer, offset)
}

/// Never called: [`ScratchWriter::new`] writes no scratch file without positioned reads.
#[cfg(not(unix))]
fn read_at(_: &File, _: &mut [u8], _: u64) -> std::io::Result<()> {
    Err(std::io::Error::other(
        "no positioned reads on this platform",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[cfg(unix)]
    fn rows_read_back_are_those_written_bit_for_bit_on_every_pass() {
        let rows: Vec<(u64, f64, [f64; 3])> = (0..3 * BUFFER_ROWS as u64 + 5)
            .map(|k| {
                let t = k as f64 * 0.002 + 1e-17 * k as f64;
                (
                    k + 2,
                    t,
                    [t.sin(), -0.1 * k as f64, f64::MIN_POSITIVE * k as f64],
                )
            })
            .collect();
        let mut writer = ScratchWriter::new();
        for &(line, t, v) in &rows {
            writer.push(line, t, v);
        }
        let scratch = writer.finish().expect("a scratch file");
        assert_eq!(scratch.len(), rows.len() as u64);
        let bits = |r: &(u64, f64, [f64; 3])| (r.0, r.1.to_bits(), r.2.map(f64::to_bits));
        let expected: Vec<_> = rows.iter().map(bits).collect();
        // Two passes side by side, and a third after.
        let mut first = scratch.open_rows().unwrap();
        let mut second = scratch.open_rows().unwrap();
        for e in &expected {
            assert_eq!(&bits(&first.next().unwrap().unwrap()), e);
            assert_eq!(&bits(&second.next().unwrap().unwrap()), e);
        }
        assert!(first.next().is_none() && second.next().is_none());
        let again: Vec<_> = scratch
            .open_rows()
            .unwrap()
            .map(|r| bits(&r.unwrap()))
            .collect();
        assert_eq!(again, expected);
        // No rows: an empty pass.
        let empty = ScratchWriter::new().finish().unwrap();
        assert!(empty.is_empty() && empty.open_rows().unwrap().next().is_none());
    }
}
