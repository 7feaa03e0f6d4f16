//! Private temporary folders for device runs (QEMU's sockets, parameter blobs, region
//! images) that a later run can tell are abandoned, and removes.
//!
//! A `kill -9` or an out-of-memory kill ends `supine` without running a destructor, so the
//! folders of that run stay behind in the temporary directory. Each folder therefore holds
//! a lock file, [`LOCK_FILE`], that its run keeps locked (`flock`) for as long as the
//! folder is in use; the kernel releases the lock when the process ends, however it ends.
//! Every new folder first [`sweep`]s: a `supine-*` folder whose lock can be taken belongs
//! to no living run and is removed.
//!
//! The lock file is created under a temporary name, locked, then renamed into place, so a
//! concurrent sweep never sees an unlocked lock file of a live run.

use std::fs::{self, File};
use std::io;
use std::path::{Path, PathBuf};

use nix::fcntl::{Flock, FlockArg};
use tempfile::TempDir;

/// Every scratch folder's name starts with this (then the kind, e.g. `supine-qemu-`).
pub const PREFIX: &str = "supine-";
/// The lock file inside a scratch folder that its run holds locked.
pub const LOCK_FILE: &str = "owner.lock";

/// A scratch folder, removed when dropped; abandoned ones are swept by later runs.
#[derive(Debug)]
pub struct ScratchDir {
    // Field order matters: the lock is released only after the folder is gone.
    dir: TempDir,
    _lock: Flock<File>,
}

impl ScratchDir {
    /// Creates `$TMPDIR/supine-<kind>-XXXXXX`, after sweeping abandoned folders.
    pub fn new(kind: &str) -> io::Result<Self> {
        sweep(&std::env::temp_dir());
        Self::new_in(&std::env::temp_dir(), kind)
    }

    /// Creates the folder in `parent` (no sweep): for tests.
    pub fn new_in(parent: &Path, kind: &str) -> io::Result<Self> {
        let dir = tempfile::Builder::new()
            .prefix(&format!("{PREFIX}{kind}-"))
            .tempdir_in(parent)?;
        let staging = dir.path().join(".owner.lock.new");
        let lock = Flock::lock(File::create(&staging)?, FlockArg::LockExclusive)
            .map_err(|(_, errno)| io::Error::from(errno))?;
        fs::rename(&staging, dir.path().join(LOCK_FILE))?;
        Ok(Self { dir, _lock: lock })
    }

    /// The folder's path.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

/// Removes the `supine-*` folders in `parent` whose owner has died; returns them.
///
/// Folders of live runs (their lock is held), folders without a lock file (not made by
/// [`ScratchDir`], or made by a run that died in the instant before locking) and anything
/// that cannot be read are left alone: a sweep never fails the run that starts it.
pub fn sweep(parent: &Path) -> Vec<PathBuf> {
    let Ok(entries) = fs::read_dir(parent) else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(PREFIX))
        .map(|e| e.path())
        .filter(|path| is_abandoned(path) && fs::remove_dir_all(path).is_ok())
        .collect()
}

fn is_abandoned(dir: &Path) -> bool {
    let Ok(lock) = File::open(dir.join(LOCK_FILE)) else {
        return false;
    };
    // A lock taken here is held until the end of this call; a new run never adopts an
    // existing folder, so nothing can claim it before the caller removes it.
    Flock::lock(lock, FlockArg::LockExclusiveNonblock).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_live_folder_is_kept_and_a_dropped_one_is_gone() {
        let parent = tempfile::tempdir().expect("temp dir");
        let live = ScratchDir::new_in(parent.path(), "qemu").expect("scratch");
        assert!(live.path().join(LOCK_FILE).is_file());
        assert!(sweep(parent.path()).is_empty());
        assert!(live.path().is_dir());
        let path = live.path().to_path_buf();
        drop(live);
        assert!(!path.exists());
    }

    #[test]
    fn a_folder_whose_lock_is_free_is_swept_and_others_are_not() {
        let parent = tempfile::tempdir().expect("temp dir");
        // What a killed run leaves: the folder and its lock file, with no lock held.
        let dead = parent.path().join("supine-qemu-dead");
        fs::create_dir(&dead).expect("mkdir");
        fs::write(dead.join(LOCK_FILE), b"").expect("lock file");
        fs::write(dead.join("uart.sock"), b"").expect("leftover");
        // Not ours: no lock file, or another prefix.
        let foreign = parent.path().join("supine-notes");
        fs::create_dir(&foreign).expect("mkdir");
        let other = parent.path().join("other-qemu-x");
        fs::create_dir(&other).expect("mkdir");
        fs::write(other.join(LOCK_FILE), b"").expect("lock file");
        let live = ScratchDir::new_in(parent.path(), "blob").expect("scratch");

        assert_eq!(sweep(parent.path()), vec![dead.clone()]);
        assert!(!dead.exists());
        assert!(foreign.is_dir() && other.is_dir() && live.path().is_dir());
    }
}
