//! Writing to standard output, where a reader that went away (`supine params | head -1`)
//! is not an error: the command ends quietly with exit 0, as `cat` and `grep` do under a
//! shell that ignores SIGPIPE. Any other write error (a full disk behind `>`) names
//! stdout and fails the command. Rust ignores SIGPIPE, so without this `print!` panics.

use std::io::Write as _;

use anyhow::anyhow;

/// The error that stands for "stdout's reader is gone": [`crate::cli::main`] ends the
/// command with exit 0 and no message when it sees it.
#[derive(Debug, thiserror::Error)]
#[error("stdout: the reader closed the pipe")]
pub struct ReaderGone;

/// Writes `text` to stdout and flushes it.
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(stdout_error)
}

/// Writes `line` and a line end to stdout.
pub fn print_line(line: &str) -> anyhow::Result<()> {
    print_text(&format!("{line}\n"))
}

/// An error writing stdout, as the command reports it.
pub fn stdout_error(error: std::io::Error) -> anyhow::Error {
    if error.kind() == std::io::ErrorKind::BrokenPipe {
        ReaderGone.into()
    } else {
        anyhow!("stdout: cannot write: {error}")
    }
}

/// Whether `error` (or any error it wraps) is stdout's reader going away. Only
/// [`ReaderGone`] counts: a closed pipe elsewhere (a QEMU's UART) is a real error.
pub fn is_reader_gone(error: &anyhow::Error) -> bool {
    error
        .chain()
        .any(|cause| cause.downcast_ref::<ReaderGone>().is_some())
}
