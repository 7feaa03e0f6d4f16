//! Writing output files so that a failure never leaves a partial file that looks complete.
//!
//! Every file the host writes in one go goes through here, so all of them get the same
//! guarantee and the same permissions (those of any file the user creates: `File::create`
//! under the umask). The monitor's live log is the one exception: it streams for the whole
//! session under a visible `.partial` name (see `crate::monitor::log`).
//!
//! Only a regular file is ever replaced: a path naming a character device or a FIFO
//! (`/dev/null`, `/dev/stdout`, a named pipe) is written directly, and its write errors
//! reported (`/dev/full` fails); a folder, a block device or a socket is refused. A path
//! that is a symbolic link writes the file it points to, and the link stays.
//!
//! The staging file is `.<name>.<pid>.partial` beside the target. One left by a run that
//! was killed (its process gone) is supine's own: [`is_stale_staging`] recognizes it and
//! the next write beside it removes it.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::os::unix::fs::FileTypeExt as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};

/// Where the bytes for a path go.
enum Target {
    /// A regular file (or none yet) at this path, after any symbolic links: staged
    /// beside it and renamed into place.
    File(PathBuf),
    /// A character device or a FIFO: written directly, never replaced.
    Stream,
}

/// What `path` names, refusing what may neither be replaced nor written.
fn target(path: &Path) -> Result<Target> {
    let kind = match std::fs::metadata(path) {
        Ok(m) => m.file_type(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if std::fs::symlink_metadata(path).is_ok() {
                bail!(
                    "{}: a symbolic link to nothing; expected a file to write",
                    path.display()
                );
            }
            return Ok(Target::File(path.to_path_buf()));
        }
        Err(e) => bail!("{}: cannot write: {e}", path.display()),
    };
    if kind.is_file() {
        let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
        let real = if is_link {
            std::fs::canonicalize(path)
                .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))?
        } else {
            path.to_path_buf()
        };
        return Ok(Target::File(real));
    }
    if kind.is_char_device() || kind.is_fifo() {
        return Ok(Target::Stream);
    }
    let what = if kind.is_dir() {
        "a folder"
    } else if kind.is_block_device() {
        "a disk device"
    } else {
        "a socket"
    };
    bail!(
        "{}: is {what}; expected a file, a character device or a named pipe to write",
        path.display()
    )
}

/// `error` from writing `path`, named with it when it is an I/O error, bare or inside a
/// CSV writer's (those say only what failed, not where).
fn named(path: &Path, error: anyhow::Error) -> anyhow::Error {
    let io = error.chain().any(|cause| {
        cause.downcast_ref::<std::io::Error>().is_some()
            || cause
                .downcast_ref::<csv::Error>()
                .is_some_and(csv::Error::is_io_error)
    });
    if io {
        anyhow!("{}: cannot write: {error}", path.display())
    } else {
        error
    }
}

/// Writes `path` through a temporary file beside it, renamed into place only on success
/// (a device or a FIFO is written directly).
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let real = match target(path)? {
        Target::Stream => return write_stream(path, write),
        Target::File(real) => real,
    };
    let tmp = stage(&real, path, write)?;
    std::fs::rename(&tmp, &real).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow!("{}: cannot write: {e}", path.display())
    })
}

/// Writes a character device or a FIFO in place; a write or flush error names it.
fn write_stream(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<()> {
    let file = OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(|e| anyhow!("{}: cannot open to write: {e}", path.display()))?;
    let mut w = BufWriter::new(file);
    write(&mut w).map_err(|e| named(path, e))?;
    w.flush()
        .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))
}

/// Writes several files as one output: every file is first staged beside its target, and
/// only when all are staged are they renamed into place, in the given order. A failure
/// while staging leaves no file at all; put the file whose presence means "complete" last
/// (a rename that fails then leaves it unwritten). A device or FIFO among them is written
/// when its turn to be renamed comes.
pub fn write_all_atomically(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    // (staged file or None for a stream, where it goes, the path as given, bytes)
    let mut staged: Vec<(Option<PathBuf>, PathBuf, &Path, &[u8])> = Vec::with_capacity(files.len());
    let discard = |staged: &[(Option<PathBuf>, PathBuf, &Path, &[u8])]| {
        for (tmp, ..) in staged {
            if let Some(tmp) = tmp {
                let _ = std::fs::remove_file(tmp);
            }
        }
    };
    for (path, bytes) in files {
        let staging = target(path).and_then(|t| match t {
            Target::Stream => Ok((None, path.clone())),
            Target::File(real) => {
                stage(&real, path, |w| Ok(w.write_all(bytes)?)).map(|tmp| (Some(tmp), real))
            }
        });
        match staging {
            Ok((tmp, real)) => staged.push((tmp, real, path, bytes)),
            Err(e) => {
                discard(&staged);
                return Err(e);
            }
        }
    }
    for (k, (tmp, real, path, bytes)) in staged.iter().enumerate() {
        let done = match tmp {
            Some(tmp) => std::fs::rename(tmp, real)
                .map_err(|e| anyhow!("{}: cannot write: {e}", path.display())),
            None => write_stream(path, |w| Ok(w.write_all(bytes)?)),
        };
        if let Err(e) = done {
            discard(&staged[k..]);
            return Err(e);
        }
    }
    Ok(())
}

/// The staging file's name for `name` in this process.
fn staging_name(name: &str) -> String {
    format!(".{name}.{}.partial", std::process::id())
}

/// Whether `entry` (a name in a folder) is a staging file that a supine process now gone
/// left behind: `.<name>.<pid>.partial`, `pid` not running. A live run's is not stale.
pub fn is_stale_staging(entry: &str) -> bool {
    let Some(inner) = entry
        .strip_prefix('.')
        .and_then(|e| e.strip_suffix(".partial"))
    else {
        return false;
    };
    let Some((name, pid)) = inner.rsplit_once('.') else {
        return false;
    };
    let Ok(pid) = pid.parse::<u32>() else {
        return false;
    };
    !name.is_empty() && pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes the stale staging files for `name` in `dir` (see [`is_stale_staging`]).
fn sweep(dir: &Path, name: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let entry_name = entry.file_name().to_string_lossy().into_owned();
        if entry_name.starts_with(&prefix) && is_stale_staging(&entry_name) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Writes the temporary file beside `real` (the regular file `shown` names) and returns
/// its name; removes it on failure. Errors name `shown`, the path the user gave.
fn stage(
    real: &Path,
    shown: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<PathBuf> {
    let dir = match real.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = real
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a file name", shown.display()))?
        .to_string_lossy();
    sweep(dir, &name);
    let tmp = dir.join(staging_name(&name));
    let result = (|| {
        let file =
            File::create(&tmp).map_err(|e| anyhow!("{}: cannot create: {e}", shown.display()))?;
        let mut w = BufWriter::new(file);
        write(&mut w).map_err(|e| named(shown, e))?;
        w.flush()
            .map_err(|e| anyhow!("{}: cannot write: {e}", shown.display()))
    })();
    match result {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_text(path: &Path, text: &str) -> Result<()> {
        write_atomically(path, |w| Ok(w.write_all(text.as_bytes())?))
    }

    #[test]
    fn a_character_device_is_written_in_place_and_its_errors_reported() {
        write_text(Path::new("/dev/null"), "x").unwrap();
        let null = std::fs::metadata("/dev/null").unwrap();
        assert!(null.file_type().is_char_device(), "/dev/null replaced");
        let err = write_text(Path::new("/dev/full"), &"x".repeat(100_000))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("/dev/full: cannot write: "), "{err}");
        assert!(
            std::fs::metadata("/dev/full")
                .unwrap()
                .file_type()
                .is_char_device()
        );
    }

    #[test]
    fn a_fifo_is_written_in_place() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        write_text(&fifo, "through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), "through the pipe");
        let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(kind.is_fifo(), "the FIFO was replaced");
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        write_all_atomically(&[(fifo.clone(), b"second".to_vec())]).unwrap();
        assert_eq!(reader.join().unwrap(), b"second");
        assert!(
            std::fs::symlink_metadata(&fifo)
                .unwrap()
                .file_type()
                .is_fifo()
        );
    }

    #[test]
    fn a_folder_is_refused_and_a_link_writes_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let err = write_text(dir.path(), "x").unwrap_err().to_string();
        assert!(err.contains("is a folder"), "{err}");
        let file = dir.path().join("real.csv");
        std::fs::write(&file, "old").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&file, &link).unwrap();
        write_text(&link, "new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "new");
    }

    #[test]
    fn a_failed_write_names_the_file_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        let err = write_atomically(&path, |_| {
            Err(std::io::Error::new(std::io::ErrorKind::StorageFull, "disk full").into())
        })
        .unwrap_err();
        let text = crate::cli::one_line(&err);
        assert!(
            text.starts_with(&format!("{}: cannot write: disk full", path.display())),
            "{text}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn a_dead_runs_staging_file_is_recognized_and_swept() {
        let dir = tempfile::tempdir().unwrap();
        // No process has pid 2^31-1 (the kernel's limit is 2^22).
        let stale = ".out.csv.2147483647.partial";
        std::fs::write(dir.path().join(stale), "half").unwrap();
        let live = format!(".out.csv.{}.partial", std::process::id());
        assert!(is_stale_staging(stale));
        assert!(!is_stale_staging(&live), "this run's own is not stale");
        assert!(!is_stale_staging(".out.csv.1.partial"), "pid 1 is running");
        assert!(!is_stale_staging("out.csv.partial"));
        assert!(!is_stale_staging(".notes.partial"));
        write_text(&dir.path().join("out.csv"), "whole").unwrap();
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["out.csv"]);
    }
}
