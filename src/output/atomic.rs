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
        let folder = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = path
            .file_name()
            .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"))?;
        let tmp = folder.join(format!(
            ".{}.tmp{}",
            name.to_string_lossy(),
            std::process::id()
        ));
        let staged = Self {
            tmp,
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

    #[test]
    fn replaces_whole_files_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("cs-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
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

    #[test]
    fn staged_files_appear_only_when_committed() {
        let dir = std::env::temp_dir().join(format!("cs-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
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
