//! A CSV file's data lines read on every core, in the file's order: for the rides, whose
//! reading (splitting and parsing a line's numbers) is most of what `exposure` and
//! `report` spend on a long ride.
//!
//! The file is cut into blocks of whole lines (about [`BLOCK_BYTES`] each); a batch of
//! [`BATCH_BLOCKS`] blocks is parsed on rayon's threads, one block a job, each line by the
//! caller's function, which depends on the line alone; the rows then come out one at a
//! time in the file's order, with their line numbers. Memory holds one batch, whatever
//! the file's length. The lines are those [`CsvLines`](crate::io::csv_lines::CsvLines)
//! gives (blank lines skipped and counted, a line longer than its limit refused with its
//! number, a last line without an LF read), and a failure is the first in the file's
//! order: a block's parsing stops at its first bad line, and the blocks after it are not
//! looked at.
//!
//! Written here rather than taken from a crate: the CSV crates parse a stream on one
//! thread, and this is a cut at line ends and rayon's ordered map over the pieces.

use std::collections::VecDeque;
use std::io::{ErrorKind, Read};

use crate::io::csv_lines::{LineError, is_blank};
use crate::parallel::in_parallel;

/// Bytes of text in a block, about (a block ends at a line end).
pub const BLOCK_BYTES: usize = 256 * 1024;
/// Blocks parsed together, one a job on rayon's threads.
pub const BATCH_BLOCKS: usize = 4;
/// Bytes asked of the source per read.
const READ_BYTES: usize = 64 * 1024;

/// Why a data line could not be read.
#[derive(Debug, PartialEq)]
pub enum BlockError {
    /// The file could not be read, or a line is too long.
    Line(LineError),
    /// The caller's function refused the line: its message.
    Parse {
        /// 1-based line number in the file.
        line: u64,
        /// What the function said.
        message: String,
    },
}

/// One block's rows (their line's offset in the block, from 1) and how it ended.
struct Block<T> {
    rows: std::vec::IntoIter<(u64, T)>,
    /// Lines in the block (when it has no failure).
    lines: u64,
    /// The block's first bad line, after its rows.
    failure: Option<(u64, Failure)>,
}

enum Failure {
    TooLong,
    Parse(String),
}

/// The data lines of a CSV source, each parsed by `parse`, in order.
pub struct ParsedLines<R, T, F> {
    source: R,
    /// Read and not yet cut into a block.
    pending: Vec<u8>,
    /// The source has ended.
    finished: bool,
    read_error: Option<String>,
    parse: F,
    delimiter: u8,
    max_line_bytes: usize,
    /// Lines of the file before the current block.
    line: u64,
    current: Option<Block<T>>,
    ready: VecDeque<Block<T>>,
    /// A failure was returned: nothing more is read.
    stopped: bool,
}

impl<R, T, F> ParsedLines<R, T, F>
where
    R: Read,
    T: Send,
    F: Fn(&[u8]) -> Result<T, String> + Sync,
{
    /// The lines of `source` after `line` lines of the file (a header already read),
    /// `pending` its bytes already read past them; lines split at `delimiter` (for the
    /// blank-line rule), each at most `max_line_bytes`, parsed by `parse`.
    pub fn new(
        source: R,
        pending: Vec<u8>,
        line: u64,
        delimiter: u8,
        max_line_bytes: usize,
        parse: F,
    ) -> Self {
        Self {
            source,
            pending,
            finished: false,
            read_error: None,
            parse,
            delimiter,
            max_line_bytes,
            line,
            current: None,
            ready: VecDeque::new(),
            stopped: false,
        }
    }

    /// The next data line's number and value, `None` after the last or a failure.
    pub fn next_row(&mut self) -> Option<Result<(u64, T), BlockError>> {
        while !self.stopped {
            if let Some(block) = &mut self.current {
                if let Some((offset, value)) = block.rows.next() {
                    return Some(Ok((self.line + offset, value)));
                }
                if let Some((offset, failure)) = block.failure.take() {
                    self.stopped = true;
                    let line = self.line + offset;
                    return Some(Err(match failure {
                        Failure::TooLong => BlockError::Line(LineError::TooLong {
                            line,
                            max_bytes: self.max_line_bytes,
                        }),
                        Failure::Parse(message) => BlockError::Parse { line, message },
                    }));
                }
                self.line += block.lines;
                self.current = None;
            }
            if self.ready.is_empty() {
                self.fill();
            }
            match self.ready.pop_front() {
                Some(block) => self.current = Some(block),
                None => {
                    self.stopped = true;
                    return self
                        .read_error
                        .take()
                        .map(|e| Err(BlockError::Line(LineError::Read(e))));
                }
            }
        }
        None
    }

    /// Reads the next batch of blocks and parses them on rayon's threads.
    fn fill(&mut self) {
        let mut texts = Vec::with_capacity(BATCH_BLOCKS);
        while texts.len() < BATCH_BLOCKS {
            match self.read_block() {
                Some(text) => texts.push(text),
                None => break,
            }
        }
        let (parse, delimiter, max) = (&self.parse, self.delimiter, self.max_line_bytes);
        let blocks = in_parallel(texts.len(), 0, |k| {
            parse_block(&texts[k], delimiter, max, parse)
        });
        self.ready.extend(blocks);
    }

    /// The next block of whole lines (the last line may lack its LF; a line longer than
    /// a block is a block of its own, which the parsing refuses), `None` at the end of
    /// the source or after a read error (kept for after the blocks before it).
    fn read_block(&mut self) -> Option<Vec<u8>> {
        let block_bytes = BLOCK_BYTES.max(2 * self.max_line_bytes);
        while !self.finished && self.read_error.is_none() && self.pending.len() < block_bytes {
            let len = self.pending.len();
            self.pending.resize(len + READ_BYTES, 0);
            match self.source.read(&mut self.pending[len..]) {
                Ok(0) => {
                    self.pending.truncate(len);
                    self.finished = true;
                }
                Ok(n) => self.pending.truncate(len + n),
                Err(e) if e.kind() == ErrorKind::Interrupted => self.pending.truncate(len),
                Err(e) => {
                    self.pending.truncate(len);
                    self.read_error = Some(e.to_string());
                }
            }
        }
        if self.pending.is_empty() {
            return None;
        }
        let cut = match memchr::memrchr(b'\n', &self.pending) {
            _ if self.finished => self.pending.len(),
            Some(at) => at + 1,
            None if self.read_error.is_some() => return None,
            None => self.pending.len(),
        };
        let rest = self.pending.split_off(cut);
        Some(std::mem::replace(&mut self.pending, rest))
    }
}

/// The rows of one block of whole lines, up to its first bad line.
fn parse_block<T>(
    text: &[u8],
    delimiter: u8,
    max_line_bytes: usize,
    parse: &impl Fn(&[u8]) -> Result<T, String>,
) -> Block<T> {
    let mut rows = Vec::new();
    let mut offset = 0u64;
    let mut start = 0usize;
    let ends =
        memchr::memchr_iter(b'\n', text).chain((!text.ends_with(b"\n")).then_some(text.len()));
    for end in ends {
        offset += 1;
        let line = &text[start..end];
        start = end + 1;
        let failure = if line.len() > max_line_bytes {
            Some(Failure::TooLong)
        } else if is_blank(line, delimiter) {
            continue;
        } else {
            match parse(line) {
                Ok(value) => {
                    rows.push((offset, value));
                    None
                }
                Err(message) => Some(Failure::Parse(message)),
            }
        };
        if let Some(failure) = failure {
            return Block {
                rows: rows.into_iter(),
                lines: offset,
                failure: Some((offset, failure)),
            };
        }
    }
    Block {
        rows: rows.into_iter(),
        lines: offset,
        failure: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each line's number and its text, or the failure, as the reader gives them.
    fn read(text: &[u8], line: u64, max: usize) -> Vec<Result<(u64, String), BlockError>> {
        let parse = |l: &[u8]| {
            if l.starts_with(b"bad") {
                Err(format!(", column a: found {}", String::from_utf8_lossy(l)))
            } else {
                Ok(String::from_utf8_lossy(l).into_owned())
            }
        };
        let mut lines = ParsedLines::new(text, Vec::new(), line, b',', max, parse);
        std::iter::from_fn(|| lines.next_row()).collect()
    }

    #[test]
    fn lines_keep_their_numbers_across_blocks_blank_lines_and_a_missing_last_lf() {
        // Enough lines for several batches of blocks, blank ones among them.
        let mut text = Vec::new();
        let mut expected = Vec::new();
        let mut line = 3;
        for k in 0..400_000u64 {
            line += 1;
            if k % 7 == 3 {
                text.extend(b"  \r\n");
                continue;
            }
            let row = format!("{k},{}", k * 3);
            text.extend(row.as_bytes());
            text.push(b'\n');
            expected.push(Ok((line, row)));
        }
        assert!(text.len() > 2 * BATCH_BLOCKS * BLOCK_BYTES);
        text.extend(b"7,8");
        expected.push(Ok((line + 1, "7,8".to_string())));
        assert_eq!(read(&text, 3, 100), expected);
        // A line of only a delimiter is a row; an empty file has none.
        assert_eq!(read(b" , \n", 0, 100), vec![Ok((1, " , ".to_string()))]);
        assert_eq!(read(b"", 0, 100), vec![]);
    }

    #[test]
    fn the_first_failure_in_the_file_stops_the_reading_with_its_line() {
        let mut text = Vec::new();
        for k in 0..100_000 {
            text.extend(format!("{k},1\n").as_bytes());
        }
        text.extend(b"bad one\n");
        // A later block's failures are never reached.
        for _ in 0..100_000 {
            text.extend(b"bad two\n");
        }
        let rows = read(&text, 1, 100);
        assert_eq!(rows.len(), 100_001);
        assert_eq!(
            rows[100_000],
            Err(BlockError::Parse {
                line: 100_002,
                message: ", column a: found bad one".to_string()
            })
        );
    }

    #[test]
    fn a_line_over_the_limit_is_refused_with_its_number_without_reading_it_whole() {
        let mut text = b"1,2\n3,4\n".to_vec();
        text.extend(std::iter::repeat_n(b'7', 33));
        text.extend(b"\n5,6\n");
        let rows = read(&text, 0, 32);
        assert_eq!(
            rows.last(),
            Some(&Err(BlockError::Line(LineError::TooLong {
                line: 3,
                max_bytes: 32
            })))
        );
        assert_eq!(read(&text, 0, 33).len(), 4);
        // No line end at all: 64 MiB of NUL is refused after a block.
        let nul = std::io::repeat(0).take(64 << 20);
        let mut lines = ParsedLines::new(nul, Vec::new(), 1, b',', 4096, |_: &[u8]| {
            Ok::<_, String>(())
        });
        assert_eq!(
            lines.next_row(),
            Some(Err(BlockError::Line(LineError::TooLong {
                line: 2,
                max_bytes: 4096
            })))
        );
        assert_eq!(lines.next_row(), None);
    }
}
