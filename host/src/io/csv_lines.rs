//! Reading a CSV file line by line with bounded memory, for the host's CSV inputs (the
//! recording format, telemetry): the file may be as large as the data, but no line may
//! grow a buffer without bound.
//!
//! Lines are found and split with `memchr` in a buffer of at most a line's limit plus one
//! read's worth: a line longer than the limit (a file of NUL bytes without a line end, a
//! megabyte-long field) is refused as soon as it is seen. A row is the line split at the
//! delimiter, nothing more: quoting is off (the host's CSV holds numbers and names, and a
//! stray quote would otherwise make the rest of the file one field), which is also why no
//! CSV parser's state machine is needed (it took a tenth of `supine fit`'s instructions).
//! A UTF-8 byte order mark at the start and CR before LF (CRLF line ends) are accepted and
//! dropped; blank lines (empty or only whitespace) are skipped.

use std::io::{ErrorKind, Read};
use std::path::Path;

use crate::io::small_file::UTF8_BOM;

/// Longest line the readers accept, bytes: a recording's line of 13 numbers takes a few
/// hundred.
pub const MAX_LINE_BYTES: usize = 4096;

/// Bytes asked of the source per read.
const READ_BYTES: usize = 64 * 1024;

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

/// A line that is no row: empty or only white space, and holding no delimiter (a line of
/// only delimiters is a row of empty cells). Every reader of these files skips the same
/// lines.
pub fn is_blank(line: &[u8], delimiter: u8) -> bool {
    line.iter().all(u8::is_ascii_whitespace) && !line.contains(&delimiter)
}

/// One non-blank line of the file, split at its delimiter.
#[derive(Debug)]
pub struct Row<'a> {
    /// 1-based line number in the file.
    pub line: u64,
    /// The line without its LF.
    text: &'a [u8],
    /// Where each cell ends in `text` (the next starts one byte further).
    ends: &'a [usize],
    first: bool,
}

impl Row<'_> {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// Whether the line has no cell (never, for a row that was returned).
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Cell `index` as it is in the file, without a byte order mark (first line) or the
    /// CR of a CRLF line end (last cell); empty past the last cell.
    pub fn cell(&self, index: usize) -> &[u8] {
        let Some(&end) = self.ends.get(index) else {
            return &[];
        };
        let start = if index == 0 {
            0
        } else {
            self.ends[index - 1] + 1
        };
        let mut cell = &self.text[start..end];
        if self.first && index == 0 {
            cell = cell.strip_prefix(UTF8_BOM).unwrap_or(cell);
        }
        if index + 1 == self.ends.len() {
            cell = cell.strip_suffix(b"\r").unwrap_or(cell);
        }
        cell
    }

    /// The cells in order, as [`cell`](Self::cell) gives them.
    pub fn cells(&self) -> impl Iterator<Item = &[u8]> + '_ {
        (0..self.len()).map(|i| self.cell(i))
    }
}

/// One non-blank line of the file, as it is in the file: a reader that recognizes the
/// line's form can take its text as it is, and [`split`](Self::split) it otherwise.
#[derive(Debug)]
pub struct Line<'a> {
    /// 1-based line number in the file.
    pub line: u64,
    /// The line without its LF (with a CRLF line end's CR, and on the first line a byte
    /// order mark).
    text: &'a [u8],
    /// The reader's buffer of cell ends, filled by `split`.
    ends: &'a mut Vec<usize>,
    first: bool,
    delimiter: u8,
}

impl<'a> Line<'a> {
    /// The line without its LF: on the file's first line with its byte order mark, if any,
    /// and with the CR of a CRLF line end.
    pub fn text(&self) -> &[u8] {
        self.text
    }

    /// Whether this is the file's first non-blank line (its text may start with a byte
    /// order mark).
    pub fn is_first(&self) -> bool {
        self.first
    }

    /// The line split at the delimiter.
    pub fn split(self) -> Row<'a> {
        self.ends.clear();
        self.ends
            .extend(memchr::memchr_iter(self.delimiter, self.text).chain([self.text.len()]));
        Row {
            line: self.line,
            text: self.text,
            ends: self.ends,
            first: self.first,
        }
    }
}

/// A CSV file read one line at a time.
pub struct CsvLines<R: Read> {
    source: R,
    max_line_bytes: usize,
    delimiter: u8,
    /// Bytes read and not yet returned are `buffer[start..end]`.
    buffer: Vec<u8>,
    start: usize,
    end: usize,
    /// `buffer[start..scanned]` holds no LF.
    scanned: usize,
    /// Whether the source has ended.
    finished: bool,
    /// 1-based number of the last line returned (0 before the first).
    line: u64,
    /// The current row's cell ends.
    ends: Vec<usize>,
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
        Self {
            source,
            max_line_bytes,
            delimiter,
            buffer: Vec::new(),
            start: 0,
            end: 0,
            scanned: 0,
            finished: false,
            line: 0,
            ends: Vec::new(),
            rows_read: 0,
        }
    }

    /// The next non-blank line, split, or `None` at the end of the file.
    pub fn next_row(&mut self) -> Result<Option<Row<'_>>, LineError> {
        Ok(self.next_line()?.map(Line::split))
    }

    /// The next non-blank line (empty or only white space after a first line's byte order
    /// mark, and holding no delimiter), not yet split, or `None` at the end of the file.
    pub fn next_line(&mut self) -> Result<Option<Line<'_>>, LineError> {
        loop {
            let Some((start, end)) = self.next_line_bounds()? else {
                return Ok(None);
            };
            let text = &self.buffer[start..end];
            let first = self.rows_read == 0;
            let body = match first {
                true => text.strip_prefix(UTF8_BOM).unwrap_or(text),
                false => text,
            };
            if is_blank(body, self.delimiter) {
                continue;
            }
            self.rows_read += 1;
            return Ok(Some(Line {
                line: self.line,
                text: &self.buffer[start..end],
                ends: &mut self.ends,
                first,
                delimiter: self.delimiter,
            }));
        }
    }

    /// The source, the bytes read from it and not yet returned, and the number of the
    /// last line returned: for a reader that goes on from here by other means
    /// ([`crate::io::csv_blocks`]).
    pub fn into_rest(self) -> (R, Vec<u8>, u64) {
        (
            self.source,
            self.buffer[self.start..self.end].to_vec(),
            self.line,
        )
    }

    /// The next line's bounds in `buffer` (without its LF; a last line without one
    /// counts), or `None` at the end of the file.
    fn next_line_bounds(&mut self) -> Result<Option<(usize, usize)>, LineError> {
        loop {
            if let Some(at) = memchr::memchr(b'\n', &self.buffer[self.scanned..self.end]) {
                let (start, end) = (self.start, self.scanned + at);
                self.line += 1;
                self.check_length(end - start)?;
                (self.start, self.scanned) = (end + 1, end + 1);
                return Ok(Some((start, end)));
            }
            self.scanned = self.end;
            self.check_length(self.end - self.start)
                .map_err(|_| self.too_long(self.line + 1))?;
            if self.finished {
                if self.start == self.end {
                    return Ok(None);
                }
                let (start, end) = (self.start, self.end);
                self.line += 1;
                self.start = end;
                return Ok(Some((start, end)));
            }
            self.fill()?;
        }
    }

    /// Refuses a line of `bytes` over the limit (the line is `self.line`).
    fn check_length(&self, bytes: usize) -> Result<(), LineError> {
        if bytes > self.max_line_bytes {
            return Err(self.too_long(self.line));
        }
        Ok(())
    }

    fn too_long(&self, line: u64) -> LineError {
        LineError::TooLong {
            line,
            max_bytes: self.max_line_bytes,
        }
    }

    /// Moves the unreturned bytes to the front and reads more after them.
    fn fill(&mut self) -> Result<(), LineError> {
        if self.start > 0 {
            self.buffer.copy_within(self.start..self.end, 0);
            (self.end, self.scanned) = (self.end - self.start, self.scanned - self.start);
            self.start = 0;
        }
        if self.buffer.len() < self.end + READ_BYTES {
            self.buffer.resize(self.end + READ_BYTES, 0);
        }
        loop {
            match self.source.read(&mut self.buffer[self.end..]) {
                Ok(0) => self.finished = true,
                Ok(n) => self.end += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) => return Err(LineError::Read(e.to_string())),
            }
            return Ok(());
        }
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
