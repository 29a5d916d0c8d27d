//! One writer per output: a lock file (`<target>.lock`) created exclusively, holding the
//! writer's process id, removed when the writer is done. A second `tmo` aiming at the same
//! batch directory, sweep or reproduction is refused at once instead of interleaving its
//! files with the first's. A lock left by a process that no longer runs (killed with -9) is
//! taken over.

use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("{target} is being written by another tmo (process {pid}); wait for it, or choose another --out")]
    Held { target: PathBuf, pid: u32 },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// Held while it lives.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
}

fn alive(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = i32::try_from(pid) else {
            return false;
        };
        // SAFETY: signal 0 only asks whether the process exists; nothing is sent.
        let r = unsafe { libc::kill(pid, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

impl OutputLock {
    /// Locks `target` (a directory or a file) for this process.
    pub fn acquire(target: &Path) -> Result<Self, LockError> {
        let mut name = target.as_os_str().to_owned();
        name.push(".lock");
        let path = PathBuf::from(name);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| LockError::Io {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    write!(f, "{}", std::process::id()).map_err(|source| LockError::Io {
                        path: path.clone(),
                        source,
                    })?;
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let pid = std::fs::read_to_string(&path)
                        .ok()
                        .and_then(|t| t.trim().parse::<u32>().ok());
                    match pid {
                        Some(pid) if pid != std::process::id() && alive(pid) => {
                            return Err(LockError::Held {
                                target: target.to_path_buf(),
                                pid,
                            })
                        }
                        // stale (its writer is gone) or half-written: take it over
                        _ => {
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(source) => return Err(LockError::Io { path, source }),
            }
        }
        Err(LockError::Io {
            path,
            source: std::io::Error::other("could not take over a stale lock"),
        })
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_and_a_dead_ones_lock_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("batch");
        let first = OutputLock::acquire(&target).unwrap();
        // this process's own lock is not "another tmo"; a live other process's is
        std::fs::write(dir.path().join("batch.lock"), "1").unwrap();
        let e = OutputLock::acquire(&target).unwrap_err();
        assert!(matches!(e, LockError::Held { pid: 1, .. }), "{e}");
        assert!(e.to_string().contains("another tmo"), "{e}");
        // a lock whose process is gone
        std::fs::write(dir.path().join("batch.lock"), "4000000000").unwrap();
        let taken = OutputLock::acquire(&target).unwrap();
        drop(first);
        drop(taken);
        assert!(!dir.path().join("batch.lock").exists());
    }
}
