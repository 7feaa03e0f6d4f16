//! Reading a file that cannot legitimately be large (a parameter file, a dataset
//! description, a key) whole, with a size limit, so that a wrong path (a 2 GiB recording,
//! `/dev/zero`, a FIFO) costs an error instead of the machine's memory.
//!
//! The limit is checked twice: against the file's length before reading (a regular file
//! that is too large is refused without reading it), and while reading, through
//! `Read::take(limit + 1)`, which a file that grows meanwhile, a device or a FIFO cannot
//! get past. A UTF-8 byte order mark at the start is dropped (editors on Windows write
//! one); CRLF line ends are left to the format's parser.

use std::io::Read as _;
use std::path::Path;

use anyhow::{Result, anyhow};

use crate::io::excerpt::excerpt;
use crate::io::text_position::line_column;

/// The UTF-8 byte order mark.
pub const UTF8_BOM: &[u8] = b"\xef\xbb\xbf";

/// The text of the file at `path`, at most `max_bytes` long, read as UTF-8 without a
/// leading byte order mark; `what` names the file in errors ("parameter file").
pub fn read_text(path: &Path, what: &str, max_bytes: u64) -> Result<String> {
    let cannot = |e: std::io::Error| anyhow!("{}: cannot read the {what}: {e}", path.display());
    let too_large = |found: &str| {
        anyhow!(
            "{}: expected a {what} of at most {max_bytes} bytes, found {found}",
            path.display()
        )
    };
    let metadata = std::fs::metadata(path).map_err(cannot)?;
    if metadata.is_file() && metadata.len() > max_bytes {
        return Err(too_large(&format!("{} bytes", metadata.len())));
    }
    let file = std::fs::File::open(path).map_err(cannot)?;
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large("more"));
    }
    let body = bytes.strip_prefix(UTF8_BOM).unwrap_or(&bytes);
    match std::str::from_utf8(body) {
        Ok(text) => Ok(text.to_string()),
        Err(e) => {
            let valid = &body[..e.valid_up_to()];
            // The prefix is valid UTF-8 by definition of `valid_up_to`.
            let prefix = std::str::from_utf8(valid).unwrap_or_default();
            let (line, column) = line_column(prefix, prefix.len());
            let end = (e.valid_up_to() + e.error_len().unwrap_or(1)).min(body.len());
            Err(anyhow!(
                "{}: line {line}, column {column}: expected UTF-8 text, found {}",
                path.display(),
                excerpt(&body[e.valid_up_to()..end])
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_file_is_read_without_its_byte_order_mark() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, b"\xef\xbb\xbfa = 1\r\n").unwrap();
        assert_eq!(
            read_text(&path, "parameter file", 100).unwrap(),
            "a = 1\r\n"
        );
    }

    #[test]
    fn a_file_over_the_limit_is_refused_before_and_while_reading() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        let file = std::fs::File::create(&path).unwrap();
        // Sparse: 2 GiB of NUL bytes on no disk space.
        file.set_len(2 << 30).unwrap();
        let e = read_text(&path, "parameter file", 1024)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with(
                "big.toml: expected a parameter file of at most 1024 bytes, found 2147483648 bytes"
            ),
            "{e}"
        );
        // A device has no length: the read itself stops one byte past the limit.
        let e = read_text(Path::new("/dev/zero"), "key file", 64)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "/dev/zero: expected a key file of at most 64 bytes, found more"
        );
    }

    #[test]
    fn bytes_that_are_not_utf8_are_located_and_escaped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, b"a = 1\nb = \xff\xfe\n").unwrap();
        let e = read_text(&path, "parameter file", 100)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("bad.toml: line 2, column 5: expected UTF-8 text, found \"\\xff\""),
            "{e}"
        );
    }
}
