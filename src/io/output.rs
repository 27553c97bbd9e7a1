//! Outputs that never destroy a user's files.
//!
//! Two rules, one mechanism for every command that writes:
//! - **A single output file** ([`check_new_file`]) is written only where no
//!   file is, where the file already holds exactly the bytes about to be
//!   written (a re-run), or with `--force`.
//! - **A results folder** ([`ResultsFolder`]) is written as a whole: into a
//!   fresh hidden sibling folder, which replaces the target by rename once
//!   every file is in it. A crash or `kill -9` before that leaves the old
//!   set untouched (and a hidden `.NAME.tdeploy-new-PID` folder, removed by
//!   the next run into the same target); after it, the new set. The target
//!   is written only if it is missing or empty; a folder holding anything
//!   (an earlier results set, which the marker file [`RESULTS_MARKER`]
//!   names, or a user's own files) is replaced, whole, only with `--force`.
//!   Every command that writes a results folder (`deploy`, `plan`,
//!   `cycles`, `replay`, `evaluate`, …) follows the one rule: a result of
//!   another seed or policy is never lost to a re-run by accident.
//!
//! Between the two renames of a replacement the old set sits, complete, in
//! a hidden `.NAME.tdeploy-old-PID` sibling for an instant: never a mix.

use std::path::{Path, PathBuf};

use super::{write_atomically, FileError};

/// The file every results folder holds, naming the command that wrote it;
/// its presence is what lets a later run replace the folder.
pub const RESULTS_MARKER: &str = ".tdeploy-results";

/// Checks that `path` may be written: it does not exist, it holds exactly
/// `bytes`, or `force` is set. The error names the file and says how to
/// go on.
pub fn check_new_file(path: &Path, bytes: &[u8], force: bool) -> Result<(), FileError> {
    if force {
        return Ok(());
    }
    match std::fs::read(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Ok(existing) if existing == bytes => Ok(()),
        Ok(_) => Err(FileError::Invalid {
            path: path.to_path_buf(),
            entry: "file".into(),
            message: "already exists with other contents; choose another output or pass --force to overwrite it".into(),
        }),
        Err(e) => Err(FileError::read(path, e)),
    }
}

/// Checks that `path` may be written whatever it will hold: it does not
/// exist, or `force` is set (for an output whose bytes are known only after
/// the work, checked before the work starts).
pub fn check_absent(path: &Path, force: bool) -> Result<(), FileError> {
    if force || !path.exists() {
        Ok(())
    } else {
        Err(FileError::Invalid {
            path: path.to_path_buf(),
            entry: "file".into(),
            message: "already exists; choose another output or pass --force to overwrite it".into(),
        })
    }
}

/// Creates the folder `dir` with its parents, if missing: the plain
/// output folder of a command whose files are written one by one
/// (`tdeploy plan`, the experiments), not as a [`ResultsFolder`].
pub fn create_folder(dir: &Path) -> Result<(), FileError> {
    std::fs::create_dir_all(dir).map_err(|cause| FileError::Create {
        path: dir.to_path_buf(),
        cause,
    })
}

/// A results folder being written: files go into [`ResultsFolder::path`],
/// and [`ResultsFolder::commit`] puts the whole set in place. Dropped
/// uncommitted (an error on the way), it removes what it wrote and leaves
/// the target as it was.
#[derive(Debug)]
pub struct ResultsFolder {
    target: PathBuf,
    staging: PathBuf,
    command: String,
    committed: bool,
}

impl ResultsFolder {
    /// Claims `target` for the results of `command` (e.g. `simulate`):
    /// refuses a target that is not a folder, or a non-empty folder unless
    /// `force` (the message says whose results it holds, from
    /// [`RESULTS_MARKER`]); then creates the staging folder. Call it before
    /// the work, so that a refusal costs nothing.
    pub fn claim(target: &Path, command: &str, force: bool) -> Result<Self, FileError> {
        let refuse = |message: &str| FileError::Invalid {
            path: target.to_path_buf(),
            entry: "output folder".into(),
            message: message.into(),
        };
        match std::fs::symlink_metadata(target) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(FileError::read(target, e)),
            Ok(meta) if !meta.is_dir() => {
                return Err(refuse(
                    "exists and is not a folder; choose another output folder",
                ))
            }
            Ok(_) => {
                let mut entries =
                    std::fs::read_dir(target).map_err(|e| FileError::read(target, e))?;
                let empty = entries.next().is_none();
                if !empty && !force {
                    let marker = std::fs::read_to_string(target.join(RESULTS_MARKER)).ok();
                    let writer = marker
                        .as_deref()
                        .and_then(|m| m.trim().strip_prefix("written by "));
                    return Err(refuse(&match writer {
                        Some(w) => format!(
                            "holds the results of an earlier run of `{w}`; pass --force to replace them, or choose another output folder"
                        ),
                        None => "holds files tdeploy did not write; choose another output folder or pass --force to replace it".into(),
                    }));
                }
            }
        }
        let parent = parent_of(target);
        std::fs::create_dir_all(&parent).map_err(|e| FileError::write(&parent, e))?;
        remove_stale_siblings(target);
        let staging = sibling(target, "new");
        // A folder left by an earlier process with our pid (pids recycle).
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir(&staging).map_err(|e| FileError::write(&staging, e))?;
        Ok(ResultsFolder {
            target: target.to_path_buf(),
            staging,
            command: command.to_string(),
            committed: false,
        })
    }

    /// Where to write the files of the set.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The folder the set will have once committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Writes the marker and puts the set in place of the target.
    pub fn commit(mut self) -> Result<(), FileError> {
        write_atomically(
            &self.staging.join(RESULTS_MARKER),
            format!("written by tdeploy {}\n", self.command).as_bytes(),
        )?;
        let old = sibling(&self.target, "old");
        let had_old = self.target.exists();
        if had_old {
            let _ = std::fs::remove_dir_all(&old);
            std::fs::rename(&self.target, &old).map_err(|e| FileError::write(&self.target, e))?;
        }
        if let Err(e) = std::fs::rename(&self.staging, &self.target) {
            if had_old {
                // Put the old set back: the target keeps a whole set.
                let _ = std::fs::rename(&old, &self.target);
            }
            return Err(FileError::write(&self.target, e));
        }
        self.committed = true;
        if had_old {
            let _ = std::fs::remove_dir_all(&old);
        }
        Ok(())
    }
}

impl Drop for ResultsFolder {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// The folder `path` lies in (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Hidden sibling `.NAME.tdeploy-ROLE-PID` of `target`.
fn sibling(target: &Path, role: &str) -> PathBuf {
    parent_of(target).join(format!(
        ".{}.tdeploy-{role}-{}",
        file_name(target),
        std::process::id()
    ))
}

fn file_name(target: &Path) -> String {
    target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into())
}

/// Removes staging folders of `target` left by runs that were killed: those
/// whose process no longer runs (known where `/proc` is; elsewhere none are
/// removed, since a live run's folder must not be).
fn remove_stale_siblings(target: &Path) {
    let proc_fs = Path::new("/proc/self");
    if !proc_fs.exists() {
        return;
    }
    let prefix = format!(".{}.tdeploy-new-", file_name(target));
    let Ok(entries) = std::fs::read_dir(parent_of(target)) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = name.strip_prefix(&prefix) else {
            continue;
        };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_existing_folder_is_replaced_whole_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("results");
        // Fresh target: written, marked.
        let set = ResultsFolder::claim(&target, "test", false).unwrap();
        std::fs::write(set.path().join("a.csv"), "1").unwrap();
        set.commit().unwrap();
        assert!(target.join(RESULTS_MARKER).is_file());
        // Our own earlier set: refused, naming the command and the flag;
        // with force, replaced whole (the old file goes).
        let e = ResultsFolder::claim(&target, "test", false).unwrap_err();
        assert!(
            e.to_string()
                .contains("holds the results of an earlier run of `tdeploy test`; pass --force"),
            "{e}"
        );
        assert!(target.join("a.csv").is_file());
        let set = ResultsFolder::claim(&target, "test", true).unwrap();
        std::fs::write(set.path().join("b.csv"), "2").unwrap();
        set.commit().unwrap();
        assert!(!target.join("a.csv").exists() && target.join("b.csv").is_file());
        // A user's folder: refused, untouched; with force, replaced.
        let user = dir.path().join("mine");
        std::fs::create_dir(&user).unwrap();
        std::fs::write(user.join("thesis.tex"), "x").unwrap();
        let e = ResultsFolder::claim(&user, "test", false).unwrap_err();
        assert!(e.to_string().contains("--force"), "{e}");
        assert!(user.join("thesis.tex").is_file());
        ResultsFolder::claim(&user, "test", true)
            .unwrap()
            .commit()
            .unwrap();
        assert!(!user.join("thesis.tex").exists());
        // An uncommitted set leaves nothing behind and the target as it was.
        let set = ResultsFolder::claim(&target, "test", true).unwrap();
        std::fs::write(set.path().join("c.csv"), "3").unwrap();
        drop(set);
        assert!(target.join("b.csv").is_file() && !target.join("c.csv").exists());
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.contains("tdeploy-")), "{names:?}");
    }

    #[test]
    fn a_file_is_overwritten_only_by_the_same_bytes_or_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.json");
        check_new_file(&path, b"a", false).unwrap();
        std::fs::write(&path, "a").unwrap();
        check_new_file(&path, b"a", false).unwrap();
        assert!(check_new_file(&path, b"b", false).is_err());
        check_new_file(&path, b"b", true).unwrap();
        assert!(check_absent(&path, false).is_err());
        check_absent(&path, true).unwrap();
    }
}
