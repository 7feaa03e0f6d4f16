//! Output folders that never overwrite a user's files: a command that writes a folder
//! (`demo --out`, `synth --out`, `fit --report`, `validate --report`) first claims it, and
//! is refused a folder holding anything it did not write, unless `--force`.
//!
//! How it knows what it wrote: after writing, it leaves a manifest ([`MANIFEST`]) in the
//! folder naming every file and folder it wrote there. A later run may replace exactly
//! those; any other entry (a user's `ride.csv`, notes, another tool's output) is named
//! in the refusal. An empty or missing folder needs no manifest.
//!
//! What a killed run leaves is supine's own too: a listed file's live-log name
//! (`device.csv.partial`, `crate::monitor::log`) and a dead run's staging file
//! (`.NAME.PID.partial`, [`is_stale_staging`]); the claim removes the staging files.
//! A run that fails calls [`OutputFolder::undo`], which removes what it added, so a
//! failure leaves nothing half-made.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};

use crate::io::output::{is_stale_staging, write_atomically};
use crate::io::small_file::read_text;

/// The manifest's file name (hidden: it is bookkeeping, not output).
pub const MANIFEST: &str = ".supine-files";
/// Largest manifest read, bytes: a run lists a few dozen names, so a larger file is not
/// one `supine` wrote (and reading it whole could cost the machine's memory).
pub const MAX_MANIFEST_BYTES: u64 = 64 * 1024;

/// A folder a command may write into.
#[derive(Clone, Debug)]
pub struct OutputFolder {
    dir: PathBuf,
    command: String,
    /// What the manifest listed when the folder was claimed.
    listed_before: BTreeSet<String>,
    /// Every entry when the folder was claimed.
    entries_before: BTreeSet<String>,
    /// Whether the claim created the folder.
    created: bool,
}

/// Creates `dir` if missing, and refuses it (naming the first foreign entry) when it
/// holds an entry that no earlier `supine` run recorded in its manifest, unless `force`.
/// `command` (`supine demo`) and `flag` (`--out`) name it in messages.
pub fn claim(dir: &Path, command: &str, flag: &str, force: bool) -> Result<OutputFolder> {
    let created = !dir.exists();
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow!("{}: {flag}: cannot create: {e}", dir.display()))?;
    let listed_before = listed(dir)?;
    for stale in entries(dir)?.iter().filter(|name| is_stale_staging(name)) {
        let _ = std::fs::remove_file(dir.join(stale));
    }
    let entries_before = entries(dir)?;
    let own = |name: &String| {
        name == MANIFEST
            || listed_before.contains(name)
            || name
                .strip_suffix(".partial")
                .is_some_and(|stem| listed_before.contains(stem))
    };
    if !force && let Some(foreign) = entries_before.iter().find(|name| !own(name)) {
        bail!(
            "{flag} {}: the folder holds {}, which supine did not write there; choose an empty or new folder, or give --force to write beside it",
            dir.display(),
            foreign
        );
    }
    Ok(OutputFolder {
        dir: dir.to_path_buf(),
        command: command.to_string(),
        listed_before,
        entries_before,
        created,
    })
}

impl OutputFolder {
    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// For a run that failed: removes every entry that appeared in the folder since the
    /// claim (files and folders this run began; the manifest too if this run wrote the
    /// first), and the folder if this claim created it and it is then empty, so that a
    /// failure leaves nothing half-made. A file an earlier run wrote and this one
    /// replaced stays: each file is written whole ([`write_atomically`]).
    pub fn undo(self) {
        if let Ok(now) = entries(&self.dir) {
            for name in now.difference(&self.entries_before) {
                let path = self.dir.join(name);
                let is_dir = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir());
                let _ = if is_dir {
                    std::fs::remove_dir_all(&path)
                } else {
                    std::fs::remove_file(&path)
                };
            }
        }
        if self.created {
            // Fails, and keeps the folder, when something is in it.
            let _ = std::fs::remove_dir(&self.dir);
        }
    }

    /// Runs `write` (this run's writing into the folder); on failure [`undo`](Self::undo)s
    /// what it added, and returns the error.
    pub fn write_or_undo<T>(self, write: impl FnOnce(&Self) -> Result<T>) -> Result<T> {
        match write(&self) {
            Ok(value) => Ok(value),
            Err(e) => {
                self.undo();
                Err(e)
            }
        }
    }

    /// Records what this run wrote (paths in the folder, files or folders), so that the
    /// next run may replace them.
    pub fn record(&self, written: &[PathBuf]) -> Result<()> {
        let mut names = BTreeSet::new();
        for path in written {
            let relative = path.strip_prefix(&self.dir).unwrap_or(path);
            if let Some(first) = relative.components().next() {
                names.insert(first.as_os_str().to_string_lossy().into_owned());
            }
        }
        self.write_manifest(&names)
    }

    /// Records, for a command that does not list its files, every entry that appeared
    /// since the folder was claimed, with those an earlier run recorded (a user's file
    /// kept beside them under `--force` stays unlisted).
    pub fn record_new_entries(&self) -> Result<()> {
        let mut names: BTreeSet<String> = entries(&self.dir)?
            .into_iter()
            .filter(|name| name != MANIFEST)
            .filter(|name| !self.entries_before.contains(name) || self.listed_before.contains(name))
            .collect();
        names.extend(self.listed_before.iter().cloned());
        self.write_manifest(&names)
    }

    fn write_manifest(&self, names: &BTreeSet<String>) -> Result<()> {
        let mut text = format!(
            "# Written by {}: the files it wrote in this folder. supine writes into a folder\n\
             # only what this list names, unless given --force.\n",
            self.command
        );
        for name in names {
            text.push_str(name);
            text.push('\n');
        }
        write_atomically(&self.dir.join(MANIFEST), |w| {
            Ok(std::io::Write::write_all(w, text.as_bytes())?)
        })
    }
}

/// What the manifest of `dir` lists (nothing without one), read with a size limit.
fn listed(dir: &Path) -> Result<BTreeSet<String>> {
    let path = dir.join(MANIFEST);
    match std::fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(BTreeSet::new()),
        Err(e) => bail!("{}: cannot read: {e}", path.display()),
        Ok(_) => {}
    }
    Ok(
        read_text(&path, "list of the files supine wrote", MAX_MANIFEST_BYTES)?
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .map(str::to_string)
            .collect(),
    )
}

/// The names in `dir`, sorted.
fn entries(dir: &Path) -> Result<BTreeSet<String>> {
    Ok(std::fs::read_dir(dir)
        .map_err(|e| anyhow!("{}: cannot list the folder: {e}", dir.display()))?
        .filter_map(|entry| entry.ok())
        .map(|entry| entry.file_name().to_string_lossy().into_owned())
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_undone_claim_removes_what_it_added_and_the_folder_it_created() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("report");
        claim(&dir, "supine fit", "--report", false).unwrap().undo();
        assert!(!dir.exists(), "the empty folder it created stays");
        std::fs::create_dir(&dir).unwrap();
        claim(&dir, "supine fit", "--report", false).unwrap().undo();
        assert!(dir.is_dir(), "a folder that was there is removed");
        std::fs::remove_dir(&dir).unwrap();
        let folder = claim(&dir, "supine fit", "--report", false).unwrap();
        std::fs::write(dir.join("fit.html"), "written").unwrap();
        std::fs::create_dir(dir.join("plots")).unwrap();
        std::fs::write(dir.join("plots").join("a.svg"), "half").unwrap();
        folder.undo();
        assert!(!dir.exists(), "a half-made folder stays");
        // In a folder of an earlier run's: its files stay, this run's new ones go.
        let folder = claim(&dir, "supine fit", "--report", false).unwrap();
        std::fs::write(dir.join("fit.html"), "whole").unwrap();
        folder.record(&[dir.join("fit.html")]).unwrap();
        let err = claim(&dir, "supine fit", "--report", false)
            .unwrap()
            .write_or_undo(|f| -> Result<()> {
                std::fs::write(f.dir().join("extra.csv"), "half").unwrap();
                bail!("disk full")
            })
            .unwrap_err();
        assert_eq!(err.to_string(), "disk full");
        let mut left: Vec<String> = entries(&dir).unwrap().into_iter().collect();
        left.sort();
        assert_eq!(left, [MANIFEST, "fit.html"]);
    }

    #[test]
    fn what_a_killed_run_left_is_recognized_as_supines_own() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let folder = claim(dir, "supine demo", "--out", false).unwrap();
        folder.record(&[dir.join("device.csv")]).unwrap();
        // A killed monitor's live log of a listed file, and a dead run's staging file.
        std::fs::write(dir.join("device.csv.partial"), "half").unwrap();
        let stale = ".report.html.2147483647.partial";
        std::fs::write(dir.join(stale), "half").unwrap();
        claim(dir, "supine demo", "--out", false).unwrap();
        assert!(!dir.join(stale).exists(), "the stale staging file stays");
        // A user's file of the same shape but unlisted is still foreign.
        std::fs::write(dir.join("notes.csv.partial"), "mine").unwrap();
        let err = claim(dir, "supine demo", "--out", false)
            .unwrap_err()
            .to_string();
        assert!(err.contains("holds notes.csv.partial"), "{err}");
    }

    #[test]
    fn a_folder_with_a_users_file_is_refused_by_name_unless_forced() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("out");
        // Missing: created and claimed; then the run records what it wrote.
        let folder = claim(&dir, "supine demo", "--out", false).unwrap();
        std::fs::write(dir.join("report.html"), "r").unwrap();
        std::fs::create_dir(dir.join("truth")).unwrap();
        folder
            .record(&[dir.join("report.html"), dir.join("truth").join("s1.toml")])
            .unwrap();
        // Its own files: claimed again.
        claim(&dir, "supine demo", "--out", false).unwrap();
        // A user's file: refused, and named.
        std::fs::write(dir.join("ride.csv"), "mine").unwrap();
        let err = claim(&dir, "supine demo", "--out", false)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("holds ride.csv, which supine did not write"),
            "{err}"
        );
        assert!(
            err.starts_with(&format!("--out {}", dir.display())),
            "{err}"
        );
        claim(&dir, "supine demo", "--out", true).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("ride.csv")).unwrap(),
            "mine"
        );
    }

    #[test]
    fn new_entries_are_recorded_and_a_forced_users_file_is_not() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::write(dir.join("mine.txt"), "m").unwrap();
        let folder = claim(dir, "supine synth", "--out", true).unwrap();
        std::fs::write(dir.join("dataset.toml"), "d").unwrap();
        folder.record_new_entries().unwrap();
        std::fs::remove_file(dir.join("mine.txt")).unwrap();
        // A second run in its own folder: nothing foreign, and its files stay listed.
        let folder = claim(dir, "supine synth", "--out", false).unwrap();
        folder.record_new_entries().unwrap();
        claim(dir, "supine synth", "--out", false).unwrap();
        std::fs::write(dir.join("mine.txt"), "m").unwrap();
        assert!(claim(dir, "supine synth", "--out", false).is_err());
    }

    #[test]
    fn a_folder_without_a_manifest_is_claimed_only_when_empty() {
        let tmp = tempfile::tempdir().unwrap();
        claim(tmp.path(), "supine synth", "--out", false).unwrap();
        std::fs::write(tmp.path().join("notes.txt"), "n").unwrap();
        assert!(claim(tmp.path(), "supine synth", "--out", false).is_err());
    }
}
