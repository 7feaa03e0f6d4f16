//! Reading a CSV file line by line with bounded memory, for the host's CSV inputs (the
//! recording format, telemetry): the file may be as large as the data, but no line may
//! grow a buffer without bound.
//!
//! The `csv` crate's streaming reader splits the cells, over a reader that refuses a line
//! longer than a limit (a file of NUL bytes without a line end, a megabyte-long field)
//! before the `csv` buffer can grow past it. Quoting is off: the host's CSV holds numbers
//! and names, and a stray quote would otherwise make the rest of the file one field.
//! A UTF-8 byte order mark at the start and CR before LF (CRLF line ends) are accepted
//! and dropped; blank lines (empty or only whitespace) are skipped.

use std::io::Read;
use std::path::Path;

use crate::io::small_file::UTF8_BOM;

/// Longest line the readers accept, bytes: a recording's line of 13 numbers takes a few
/// hundred.
pub const MAX_LINE_BYTES: usize = 4096;

/// Why the next line could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LineError {
    /// A line is longer than [`MAX_LINE_BYTES`].
    #[error("line {line}: expected a line of at most {max_bytes} bytes, found a longer one")]
    TooLong {
        /// 1-based line number.
        line: u64,
        /// The limit, bytes.
        max_bytes: usize,
    },
    /// The operating system's error while reading.
    #[error("{0}")]
    Read(String),
}

/// One non-blank line of the file, split at its delimiter.
#[derive(Debug)]
pub struct Row<'a> {
    /// 1-based line number in the file.
    pub line: u64,
    record: &'a csv::ByteRecord,
    first: bool,
}

impl Row<'_> {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.record.len()
    }

    /// Whether the line has no cell (never, for a row that was returned).
    pub fn is_empty(&self) -> bool {
        self.record.is_empty()
    }

    /// Cell `index` as it is in the file, without a byte order mark (first line) or the
    /// CR of a CRLF line end (last cell); empty past the last cell.
    pub fn cell(&self, index: usize) -> &[u8] {
        let mut cell = self.record.get(index).unwrap_or_default();
        if self.first && index == 0 {
            cell = cell.strip_prefix(UTF8_BOM).unwrap_or(cell);
        }
        if index + 1 == self.record.len() {
            cell = cell.strip_suffix(b"\r").unwrap_or(cell);
        }
        cell
    }

    /// The cells in order, as [`cell`](Self::cell) gives them.
    pub fn cells(&self) -> impl Iterator<Item = &[u8]> + '_ {
        (0..self.len()).map(|i| self.cell(i))
    }
}

/// A CSV file read one line at a time.
pub struct CsvLines<R: Read> {
    reader: csv::Reader<BoundedLines<R>>,
    record: csv::ByteRecord,
    rows_read: u64,
}

impl CsvLines<std::fs::File> {
    /// Opens the file at `path`.
    pub fn open(path: &Path) -> std::io::Result<Self> {
        Ok(Self::new(std::fs::File::open(path)?))
    }
}

impl<R: Read> CsvLines<R> {
    /// Lines of `source`, at most [`MAX_LINE_BYTES`] each.
    pub fn new(source: R) -> Self {
        Self::with_max_line_bytes(source, MAX_LINE_BYTES)
    }

    /// Lines of `source`, at most `max_line_bytes` each.
    pub fn with_max_line_bytes(source: R, max_line_bytes: usize) -> Self {
        Self::with_delimiter(source, max_line_bytes, b',')
    }

    /// Lines of `source`, at most `max_line_bytes` each, split at `delimiter` (other
    /// loggers write `;` where a decimal comma is the custom).
    pub fn with_delimiter(source: R, max_line_bytes: usize, delimiter: u8) -> Self {
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .delimiter(delimiter)
            .flexible(true)
            .quoting(false)
            // One record per line: `\r` stays in the last cell and `Row::cell` drops it.
            .terminator(csv::Terminator::Any(b'\n'))
            .from_reader(BoundedLines::new(source, max_line_bytes));
        Self {
            reader,
            record: csv::ByteRecord::new(),
            rows_read: 0,
        }
    }

    /// The next non-blank line, or `None` at the end of the file.
    pub fn next_row(&mut self) -> Result<Option<Row<'_>>, LineError> {
        loop {
            let more = self
                .reader
                .read_byte_record(&mut self.record)
                .map_err(|e| line_error(e, self.reader.get_ref()))?;
            if !more {
                return Ok(None);
            }
            let first = self.rows_read == 0;
            let row = Row {
                line: 0,
                record: &self.record,
                first,
            };
            let blank = row.len() == 1 && row.cell(0).iter().all(u8::is_ascii_whitespace);
            if blank {
                continue;
            }
            // Every line ends with a LF (`BoundedLines` adds a missing last one), so after
            // a record the reader stands at the start of the next line.
            let line = self.reader.position().line() - 1;
            self.rows_read += 1;
            return Ok(Some(Row {
                line,
                record: &self.record,
                first,
            }));
        }
    }
}

fn line_error<R>(e: csv::Error, source: &BoundedLines<R>) -> LineError {
    match e.into_kind() {
        csv::ErrorKind::Io(io) if io.get_ref().is_some_and(|i| i.is::<TooLongMarker>()) => {
            LineError::TooLong {
                line: source.line,
                max_bytes: source.max_line_bytes,
            }
        }
        csv::ErrorKind::Io(io) => LineError::Read(io.to_string()),
        // Byte records without quoting have no other error; keep its words if one comes.
        other => LineError::Read(format!("{other:?}")),
    }
}

/// The error [`BoundedLines`] returns for a line over the limit (its position is read
/// from the reader).
#[derive(Debug, thiserror::Error)]
#[error("line too long")]
struct TooLongMarker;

/// A reader that fails once a line exceeds a length, counts lines, and ends the input
/// with a LF if it does not end with one.
struct BoundedLines<R> {
    inner: R,
    max_line_bytes: usize,
    /// 1-based number of the line being read.
    line: u64,
    /// Bytes of that line so far.
    line_bytes: usize,
    /// Whether the last byte passed on was a LF (or nothing was passed on yet).
    at_line_start: bool,
    finished: bool,
}

impl<R> BoundedLines<R> {
    fn new(inner: R, max_line_bytes: usize) -> Self {
        Self {
            inner,
            max_line_bytes,
            line: 1,
            line_bytes: 0,
            at_line_start: true,
            finished: false,
        }
    }
}

impl<R: Read> Read for BoundedLines<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.finished || buf.is_empty() {
            return Ok(0);
        }
        let n = self.inner.read(buf)?;
        if n == 0 {
            self.finished = true;
            if self.at_line_start {
                return Ok(0);
            }
            buf[0] = b'\n';
            return Ok(1);
        }
        for (k, segment) in buf[..n].split(|b| *b == b'\n').enumerate() {
            if k > 0 {
                self.line += 1;
                self.line_bytes = 0;
            }
            self.line_bytes += segment.len();
            if self.line_bytes > self.max_line_bytes {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    TooLongMarker,
                ));
            }
        }
        self.at_line_start = buf[n - 1] == b'\n';
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(text: &[u8], max: usize) -> Result<Vec<(u64, Vec<String>)>, LineError> {
        let mut lines = CsvLines::with_max_line_bytes(text, max);
        let mut out = Vec::new();
        while let Some(row) = lines.next_row()? {
            let cells = row
                .cells()
                .map(|c| String::from_utf8_lossy(c).into_owned())
                .collect();
            out.push((row.line, cells));
        }
        Ok(out)
    }

    fn owned(line: u64, cells: &[&str]) -> (u64, Vec<String>) {
        (line, cells.iter().map(|c| c.to_string()).collect())
    }

    #[test]
    fn lines_keep_their_numbers_across_blank_lines_crlf_and_a_missing_last_lf() {
        let text = b"\xef\xbb\xbfa,b\r\n\r\n  \n1,2\r\n\n\n3,4\n5";
        assert_eq!(
            rows(text, 100).unwrap(),
            vec![
                owned(1, &["a", "b"]),
                owned(4, &["1", "2"]),
                owned(7, &["3", "4"]),
                owned(8, &["5"]),
            ]
        );
        assert_eq!(rows(b"", 100).unwrap(), vec![]);
        assert_eq!(rows(b"\n\n", 100).unwrap(), vec![]);
    }

    #[test]
    fn quotes_are_cells_like_any_other_text() {
        assert_eq!(
            rows(b"\"1,2\nx\n", 100).unwrap(),
            vec![owned(1, &["\"1", "2"]), owned(2, &["x"])]
        );
    }

    #[test]
    fn a_line_over_the_limit_is_refused_with_its_number_at_any_position() {
        // The limit is on each line, wherever it sits in the reader's buffer.
        let mut text = b"a,b\n1,2\n".to_vec();
        text.extend(std::iter::repeat_n(b'7', 33));
        text.extend(b"\n3,4\n");
        assert_eq!(
            rows(&text, 32),
            Err(LineError::TooLong {
                line: 3,
                max_bytes: 32
            })
        );
        assert_eq!(rows(&text, 33).unwrap().len(), 4);
        // No line end at all: 64 MiB of NUL never reaches the CSV buffer.
        let nul = std::io::repeat(0).take(64 << 20);
        let mut lines = CsvLines::new(nul);
        assert_eq!(
            lines.next_row().unwrap_err(),
            LineError::TooLong {
                line: 1,
                max_bytes: MAX_LINE_BYTES
            }
        );
    }
}
