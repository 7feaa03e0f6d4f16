//! Writing output files so that a failure never leaves a partial file that looks complete.
//!
//! Every file the host writes in one go goes through here, so all of them get the same
//! guarantee and the same permissions (those of any file the user creates: `File::create`
//! under the umask). The monitor's live log is the one exception: it streams for the whole
//! session under a visible `.partial` name (see `crate::monitor::log`).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};

/// Writes `path` through a temporary file beside it, renamed into place only on success.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let tmp = stage(path, write)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow!("{}: cannot write: {e}", path.display())
    })
}

/// Writes several files as one output: every file is first staged beside its target, and
/// only when all are staged are they renamed into place, in the given order. A failure
/// while staging leaves no file at all; put the file whose presence means "complete" last
/// (a rename that fails then leaves it unwritten).
pub fn write_all_atomically(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    let mut staged: Vec<(PathBuf, &Path)> = Vec::with_capacity(files.len());
    let discard = |staged: &[(PathBuf, &Path)]| {
        for (tmp, _) in staged {
            let _ = std::fs::remove_file(tmp);
        }
    };
    for (path, bytes) in files {
        match stage(path, |w| Ok(w.write_all(bytes)?)) {
            Ok(tmp) => staged.push((tmp, path)),
            Err(e) => {
                discard(&staged);
                return Err(e);
            }
        }
    }
    for (k, (tmp, path)) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            discard(&staged[k..]);
            return Err(anyhow!("{}: cannot write: {e}", path.display()));
        }
    }
    Ok(())
}

/// Writes the temporary file beside `path` and returns its name; removes it on failure.
fn stage(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<PathBuf> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a file name", path.display()))?
        .to_string_lossy();
    let tmp = dir.join(format!(".{name}.{}.partial", std::process::id()));
    let result = (|| {
        let file =
            File::create(&tmp).map_err(|e| anyhow!("{}: cannot create: {e}", path.display()))?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        w.flush()
            .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))
    })();
    match result {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}
