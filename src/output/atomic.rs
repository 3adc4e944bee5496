//! Atomic file writing: a temporary file in the destination folder, flushed, then renamed over
//! the destination, so a reader never sees a partly written file.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` atomically (temporary sibling + `fsync` + rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    Staged::write(path, bytes)?.commit()
}

/// A file written and flushed to a temporary sibling of its destination, not yet in place:
/// [`Staged::commit`] renames it over the destination, [`Staged::discard`] (or dropping it)
/// removes it. A sequence of files staged one by one and committed only when all were written
/// leaves the folder as it was if any fails.
#[derive(Debug)]
pub struct Staged {
    tmp: PathBuf,
    path: PathBuf,
}

impl Staged {
    /// Writes `bytes` to a temporary sibling of `path` and flushes it to disk.
    pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<Self> {
        let staged = Self {
            tmp: sibling(path, "tmp")?,
            path: path.to_path_buf(),
        };
        // On an error `staged` is dropped, which removes the temporary.
        let mut f = std::fs::File::create(&staged.tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        Ok(staged)
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renames the file over its destination.
    pub fn commit(mut self) -> std::io::Result<()> {
        let result = std::fs::rename(&self.tmp, &self.path);
        // Renamed: nothing left to remove; failed: the drop removes the temporary.
        if result.is_ok() {
            self.tmp = PathBuf::new();
        }
        result
    }

    /// Removes the temporary; the destination is untouched.
    pub fn discard(self) {
        drop(self);
    }
}

/// Commits a set of staged files all or none: each destination that exists is first moved
/// aside to a hidden backup sibling, then every file is renamed into place, then the backups
/// are removed. If a step fails (a destination that cannot be replaced, say), what was done is
/// undone, the staged files are removed and the error names the file: the folder is as it was
/// (until 2026-12-05 the files were renamed one by one, and a failure part way left a mix of
/// new and old frames). Should an undo fail too, the error says which files are left as what.
pub fn commit_all(staged: Vec<Staged>) -> std::io::Result<()> {
    if let Some(taken) = staged.iter().find(|s| s.path.is_dir()) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            format!(
                "{}: a folder is in the way (nothing written)",
                taken.path.display()
            ),
        ));
    }
    let mut moved_aside: Vec<(PathBuf, PathBuf)> = Vec::new();
    for s in &staged {
        if s.path.exists() {
            let aside = sibling(&s.path, "bak").and_then(|backup| {
                std::fs::rename(&s.path, &backup)?;
                Ok(backup)
            });
            match aside {
                Ok(backup) => moved_aside.push((s.path.clone(), backup)),
                Err(e) => return Err(failed(&s.path, e, restore(&moved_aside, &[]))),
            }
        }
    }
    let mut placed: Vec<PathBuf> = Vec::new();
    for s in staged {
        let path = s.path.clone();
        if let Err(e) = s.commit() {
            let undo = restore(&moved_aside, &placed);
            return Err(failed(&path, e, undo));
        }
        placed.push(path);
    }
    for (_, backup) in &moved_aside {
        let _ = std::fs::remove_file(backup);
    }
    Ok(())
}

/// A hidden sibling of `path` named for this process, `.NAME.KIND<pid>`: a [`Staged`] file's
/// temporary (`tmp`), an earlier version [`commit_all`] moved aside (`bak`).
fn sibling(path: &Path, kind: &str) -> std::io::Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"))?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok(folder.join(format!(
        ".{}.{kind}{}",
        name.to_string_lossy(),
        std::process::id()
    )))
}

/// Undoes a partial [`commit_all`]: removes the files `placed` that had no earlier version and
/// moves every backup back. The files it could not restore, if any.
fn restore(moved_aside: &[(PathBuf, PathBuf)], placed: &[PathBuf]) -> Vec<PathBuf> {
    let mut left = Vec::new();
    for path in placed {
        if !moved_aside.iter().any(|(p, _)| p == path) && std::fs::remove_file(path).is_err() {
            left.push(path.clone());
        }
    }
    for (path, backup) in moved_aside {
        if std::fs::rename(backup, path).is_err() {
            left.push(path.clone());
        }
    }
    left
}

/// What [`clear_interrupted`] did in a folder.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Cleared {
    /// Temporaries of an interrupted run, removed.
    pub removed: Vec<PathBuf>,
    /// Earlier versions moved aside by an interrupted [`commit_all`] whose destination was
    /// missing, moved back.
    pub restored: Vec<PathBuf>,
}

/// Clears what a run killed part way (a kill, a power cut) left in `folder`: the hidden
/// temporaries `.NAME.tmpPID` of [`Staged`] files and the backups `.NAME.bakPID` of
/// [`commit_all`], for the destinations `NAME` that `ours` accepts and a process `PID` that
/// is no longer running (this process's own are left alone). A backup goes back to its
/// destination when that is missing (the commit stopped between its two steps), else it is
/// removed. Only where running processes can be listed (`/proc`); elsewhere nothing is done.
pub fn clear_interrupted(folder: &Path, ours: impl Fn(&str) -> bool) -> Cleared {
    let proc = Path::new("/proc");
    if !proc.is_dir() {
        return Cleared::default();
    }
    let own = std::process::id();
    clear_left_by(folder, ours, |pid| {
        pid != own && !proc.join(pid.to_string()).exists()
    })
}

/// [`clear_interrupted`] for this process's own files: what an interrupt (Ctrl-C) handler
/// clears before the process ends.
pub fn clear_own(folder: &Path, ours: impl Fn(&str) -> bool) -> Cleared {
    let own = std::process::id();
    clear_left_by(folder, ours, |pid| pid == own)
}

/// The temporaries and backups in `folder` of the destinations `ours` accepts and of the
/// processes `left_by` accepts, cleared as [`clear_interrupted`] says.
fn clear_left_by(
    folder: &Path,
    ours: impl Fn(&str) -> bool,
    left_by: impl Fn(u32) -> bool,
) -> Cleared {
    let mut cleared = Cleared::default();
    let Ok(entries) = std::fs::read_dir(folder) else {
        return cleared;
    };
    for entry in entries.flatten() {
        let Ok(name) = entry.file_name().into_string() else {
            continue;
        };
        let Some((target, kind, pid)) = interrupted_name(&name) else {
            continue;
        };
        if !(left_by(pid) && ours(target) && entry.file_type().is_ok_and(|t| t.is_file())) {
            continue;
        }
        let (path, destination) = (entry.path(), folder.join(target));
        if kind == "bak" && !destination.exists() {
            if std::fs::rename(&path, &destination).is_ok() {
                cleared.restored.push(destination);
            }
        } else if std::fs::remove_file(&path).is_ok() {
            cleared.removed.push(path);
        }
    }
    cleared.removed.sort();
    cleared.restored.sort();
    cleared
}

/// `.NAME.KINDPID` as `(NAME, KIND, PID)` for the kinds `tmp` and `bak`.
fn interrupted_name(name: &str) -> Option<(&str, &str, u32)> {
    let rest = name.strip_prefix('.')?;
    let digits = rest.len() - rest.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let (stem, pid) = rest.split_at(rest.len() - digits);
    let pid = pid.parse().ok()?;
    ["tmp", "bak"].into_iter().find_map(|kind| {
        let target = stem.strip_suffix(kind)?.strip_suffix('.')?;
        (!target.is_empty()).then_some((target, kind, pid))
    })
}

/// The error of a failed [`commit_all`] at `path`.
fn failed(path: &Path, e: std::io::Error, not_restored: Vec<PathBuf>) -> std::io::Error {
    let state = if not_restored.is_empty() {
        "nothing written: the folder is as it was".to_owned()
    } else {
        let names: Vec<String> = not_restored
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        format!("and could not restore {}", names.join(", "))
    };
    std::io::Error::new(e.kind(), format!("{}: {e} ({state})", path.display()))
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An empty temporary folder `NAME-PID`.
    fn fresh_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        dir
    }

    #[test]
    fn replaces_whole_files_and_leaves_no_temporary() {
        let dir = fresh_dir("cs-atomic");
        let path = dir.join("out.obj");
        write_atomic(&path, b"first version, longer").expect("write");
        write_atomic(&path, b"second").expect("overwrite");
        assert_eq!(std::fs::read(&path).expect("read"), b"second");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .expect("list")
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(names.len(), 1, "no temporary left: {names:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_failed_write_leaves_nothing() {
        let missing = std::env::temp_dir()
            .join(format!("cs-atomic-missing-{}", std::process::id()))
            .join("x.obj");
        assert!(write_atomic(&missing, b"data").is_err());
        assert!(!missing.exists());
    }

    /// A rename failing part way through a set (here the second file's temporary is gone):
    /// the first file's earlier version is back, the third never appears, no hidden file is
    /// left, and the error names the file.
    #[test]
    fn a_set_is_committed_all_or_none() {
        let dir = fresh_dir("cs-commit-all");
        let [a, b, c] = ["a.obj", "b.obj", "c.obj"].map(|n| dir.join(n));
        std::fs::write(&a, b"old a").expect("old a");
        std::fs::write(&b, b"old b").expect("old b");
        let stage_all = || -> Vec<Staged> {
            [&a, &b, &c]
                .iter()
                .map(|p| Staged::write(p, b"new").expect("stage"))
                .collect()
        };
        let staged = stage_all();
        std::fs::remove_file(&staged[1].tmp).expect("lose b's temporary");
        let e = commit_all(staged).expect_err("b cannot be committed");
        assert!(e.to_string().contains("b.obj"), "{e}");
        assert!(e.to_string().contains("as it was"), "{e}");
        assert_eq!(std::fs::read(&a).expect("a"), b"old a");
        assert_eq!(std::fs::read(&b).expect("b"), b"old b");
        assert!(!c.exists());
        assert_eq!(std::fs::read_dir(&dir).expect("list").count(), 2);
        // A folder in the way is refused before anything moves.
        std::fs::create_dir(&c).expect("folder c");
        let staged = vec![
            Staged::write(&a, b"new").expect("a"),
            Staged::write(&c, b"new").expect("c"),
        ];
        assert!(commit_all(staged).is_err());
        assert_eq!(std::fs::read(&a).expect("a"), b"old a");
        // And a set that can be committed is.
        std::fs::remove_dir(&c).expect("remove folder c");
        commit_all(stage_all()).expect("commits");
        for p in [&a, &b, &c] {
            assert_eq!(std::fs::read(p).expect("read"), b"new");
        }
        assert_eq!(std::fs::read_dir(&dir).expect("list").count(), 3);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// What a killed run left is cleared by the next: temporaries removed, a backup whose
    /// destination is missing moved back, another's removed; a live process's files, this
    /// process's and names not ours are left.
    #[test]
    fn what_an_interrupted_run_left_is_cleared() {
        let dir = fresh_dir("cs-interrupted");
        if !Path::new("/proc").is_dir() {
            return;
        }
        // Above the largest Linux pid_max (2^22): no such process.
        let gone = 4_194_305_u32;
        let ours = |name: &str| name.starts_with("frame_");
        let put = |name: &str, text: &str| std::fs::write(dir.join(name), text).expect("write");
        put(&format!(".frame_0001.obj.tmp{gone}"), "partial");
        put(&format!(".frame_0002.obj.bak{gone}"), "old 2");
        put("frame_0003.obj", "new 3");
        put(&format!(".frame_0003.obj.bak{gone}"), "old 3");
        put(
            &format!(".frame_0004.obj.tmp{}", std::process::id()),
            "this run's",
        );
        put(&format!(".notes.txt.tmp{gone}"), "not ours");
        put(&format!(".frame_0005.obj.tmp{}", 1), "pid 1 runs");
        let cleared = clear_interrupted(&dir, ours);
        assert_eq!(
            cleared.removed,
            vec![
                dir.join(format!(".frame_0001.obj.tmp{gone}")),
                dir.join(format!(".frame_0003.obj.bak{gone}")),
            ]
        );
        assert_eq!(cleared.restored, vec![dir.join("frame_0002.obj")]);
        assert_eq!(
            std::fs::read(dir.join("frame_0002.obj")).expect("2"),
            b"old 2"
        );
        assert_eq!(
            std::fs::read(dir.join("frame_0003.obj")).expect("3"),
            b"new 3"
        );
        assert_eq!(std::fs::read_dir(&dir).expect("list").count(), 5);
        assert_eq!(interrupted_name(".a.tmp12"), Some(("a", "tmp", 12)));
        assert_eq!(interrupted_name(".a.tmp"), None);
        assert_eq!(interrupted_name(".tmp12"), None);
        assert_eq!(interrupted_name("a.tmp12"), None);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn staged_files_appear_only_when_committed() {
        let dir = fresh_dir("cs-staged");
        let (a, b) = (dir.join("a.obj"), dir.join("b.obj"));
        std::fs::write(&b, b"old").expect("old b");
        let sa = Staged::write(&a, b"new a").expect("stage a");
        let sb = Staged::write(&b, b"new b").expect("stage b");
        assert!(!a.exists());
        assert_eq!(std::fs::read(&b).expect("b"), b"old");
        sa.discard();
        sb.commit().expect("commit b");
        assert!(!a.exists());
        assert_eq!(std::fs::read(&b).expect("b"), b"new b");
        let names = std::fs::read_dir(&dir).expect("list").count();
        assert_eq!(names, 1, "no temporary left");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
