//! Writing output files so that a failure never leaves a partial file that looks complete.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::{Result, anyhow};

/// Writes `path` through a temporary file beside it, renamed into place only on success.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
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
            .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))?;
        std::fs::rename(&tmp, path).map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
