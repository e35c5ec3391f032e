//! Atomic file output: every file the tools write whole (run.json,
//! summaries, report files) is written to a temporary file beside it,
//! fsynced, then renamed over the target. A kill or a full disk leaves the
//! previous file or the new one, never half of one, and no temporary file
//! behind.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The temporary name for `path`: hidden, in the same directory (a rename
/// across file systems is not atomic), and unique per process.
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Write `bytes` to a temporary file next to `path` and fsync it; the
/// caller renames it with [`Staged::commit`]. On failure nothing is left.
pub fn stage(path: &Path, bytes: &[u8]) -> std::io::Result<Staged> {
    let tmp = temp_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })();
    match result {
        Ok(()) => Ok(Staged { tmp: Some(tmp), target: path.to_path_buf() }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// A fully written temporary file waiting to replace its target. Dropped
/// without [`Staged::commit`], it is removed.
#[derive(Debug)]
pub struct Staged {
    tmp: Option<PathBuf>,
    pub target: PathBuf,
}

impl Staged {
    pub fn commit(mut self) -> std::io::Result<()> {
        let tmp = self.tmp.take().expect("committed once");
        std::fs::rename(&tmp, &self.target).inspect_err(|_| {
            let _ = std::fs::remove_file(&tmp);
        })
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Write one file atomically.
pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    stage(path, bytes)?.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("negotiator-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn write_replaces_whole_and_leaves_no_temporary() {
        let d = dir("replace");
        let p = d.join("run.json");
        std::fs::write(&p, "old").unwrap();
        write(&p, b"new contents").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new contents");
        let names: Vec<_> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("run.json")]);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_dropped_stage_leaves_the_old_file_and_no_temporary() {
        let d = dir("drop");
        let p = d.join("report.html");
        std::fs::write(&p, "old").unwrap();
        let staged = stage(&p, b"new").unwrap();
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2);
        drop(staged);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        // A target in a missing directory fails, naming nothing left over.
        assert!(write(&d.join("missing/x.json"), b"x").is_err());
        let _ = std::fs::remove_dir_all(&d);
    }
}
