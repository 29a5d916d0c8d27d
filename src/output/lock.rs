//! One writer per output: a lock file (`<target>.lock`) created exclusively, holding the
//! writer's process id, removed when the writer is done. A second `tmo` aiming at the same
//! batch directory, sweep or reproduction is refused at once instead of interleaving its
//! files with the first's. A lock left by a process that no longer runs (killed with -9),
//! or whose process id now belongs to another program, is taken over.

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

/// Whether `pid` is a running tmo: alive, and (where `/proc` says) the same program as
/// this one. A lock's pid outlives its writer and is reused: a live pid of another program
/// (`1`, say) must not block every run for ever.
fn a_tmo_runs_as(pid: u32) -> bool {
    if !alive(pid) {
        return false;
    }
    let comm = |who: &str| std::fs::read_to_string(format!("/proc/{who}/comm")).ok();
    match (comm(&pid.to_string()), comm("self")) {
        (Some(theirs), Some(ours)) => {
            let theirs = theirs.trim();
            theirs == ours.trim() || theirs == "tmo"
        }
        // no /proc: a live process is taken to be the writer
        _ => true,
    }
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

/// Where `target`'s lock lives: `<name>.lock` beside it, for the target as it is on disk,
/// so that `d`, `d/`, `./d` and a symlink to `d` take the same lock, and the lock is never
/// inside the output (where `d/` + `.lock` would put it).
pub fn lock_path(target: &Path) -> PathBuf {
    // components() drops a trailing slash and `.`s
    let clean: PathBuf = target.components().collect();
    let on_disk = std::fs::canonicalize(&clean).ok().or_else(|| {
        // not there yet: its parent as it is on disk
        let parent = match clean.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        Some(std::fs::canonicalize(parent).ok()?.join(clean.file_name()?))
    });
    let target = on_disk.unwrap_or(clean);
    let mut name = target.as_os_str().to_owned();
    name.push(".lock");
    PathBuf::from(name)
}

impl OutputLock {
    /// Locks `target` (a directory or a file) for this process.
    pub fn acquire(target: &Path) -> Result<Self, LockError> {
        let path = lock_path(target);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| LockError::Io {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| LockError::Io { path, source }
        };
        // The lock appears with its process id already in it (a finished temporary linked
        // to its name, which fails if the name is taken): a second writer never reads a
        // lock half-written and takes it for a stale one.
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(format!(".{}.new", std::process::id()));
        let tmp = PathBuf::from(tmp);
        let _ = std::fs::remove_file(&tmp);
        std::fs::write(&tmp, std::process::id().to_string()).map_err(io(&tmp))?;
        let result = Self::link_in(target, &path, &tmp);
        let _ = std::fs::remove_file(&tmp);
        result
    }

    fn link_in(target: &Path, path: &Path, tmp: &Path) -> Result<Self, LockError> {
        for _ in 0..3 {
            match std::fs::hard_link(tmp, path) {
                Ok(()) => {
                    return Ok(Self {
                        path: path.to_path_buf(),
                    })
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let seen = std::fs::read_to_string(path).ok();
                    let pid = seen.as_deref().and_then(|t| t.trim().parse::<u32>().ok());
                    match pid {
                        Some(pid) if pid != std::process::id() && a_tmo_runs_as(pid) => {
                            return Err(LockError::Held {
                                target: target.to_path_buf(),
                                pid,
                            })
                        }
                        // stale (its writer is gone) or unreadable: moved aside under a
                        // name of this process's own, so that of two processes taking it
                        // over at once only one moves it; a lock that is not the one read
                        // (another process took it over meanwhile) is put back.
                        _ => {
                            let mut aside = path.as_os_str().to_owned();
                            aside.push(format!(".{}.stale", std::process::id()));
                            let aside = PathBuf::from(aside);
                            if std::fs::rename(path, &aside).is_ok() {
                                if std::fs::read_to_string(&aside).ok() != seen {
                                    let _ = std::fs::hard_link(&aside, path);
                                }
                                let _ = std::fs::remove_file(&aside);
                            }
                        }
                    }
                }
                Err(source) => {
                    return Err(LockError::Io {
                        path: path.to_path_buf(),
                        source,
                    })
                }
            }
        }
        Err(LockError::Io {
            path: path.to_path_buf(),
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
    fn a_target_named_with_a_slash_or_through_a_symlink_takes_the_lock_beside_it() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().canonicalize().unwrap();
        std::fs::create_dir(d.join("out")).unwrap();
        let beside = d.join("out.lock");
        assert_eq!(lock_path(&d.join("out")), beside);
        assert_eq!(
            lock_path(Path::new(&format!("{}/out/", d.display()))),
            beside
        );
        assert_eq!(lock_path(&d.join("./out")), beside);
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("out"), d.join("link")).unwrap();
            assert_eq!(lock_path(&d.join("link")), beside);
        }
        // not made yet: beside where it will be
        assert_eq!(lock_path(&d.join("new/")), d.join("new.lock"));
        let held = OutputLock::acquire(&d.join("out/")).unwrap();
        assert!(beside.exists() && !d.join("out/.lock").exists());
        drop(held);
        assert!(!beside.exists());
    }

    #[test]
    fn a_second_writer_is_refused_and_a_dead_ones_lock_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("batch");
        let first = OutputLock::acquire(&target).unwrap();
        // a live process of this program: refused (a copy of `sleep` under this program's
        // name stands in for a second tmo)
        let ours = std::fs::read_to_string("/proc/self/comm").unwrap();
        let twin = dir.path().join(ours.trim());
        std::fs::copy("/bin/sleep", &twin).unwrap();
        let mut other = std::process::Command::new(&twin).arg("30").spawn().unwrap();
        // until it has exec'd, the child still bears this thread's name
        let comm = format!("/proc/{}/comm", other.id());
        for _ in 0..500 {
            if std::fs::read_to_string(&comm).is_ok_and(|c| c == ours) {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        std::fs::write(dir.path().join("batch.lock"), other.id().to_string()).unwrap();
        let e = OutputLock::acquire(&target).unwrap_err();
        assert!(matches!(e, LockError::Held { .. }), "{e}");
        assert!(e.to_string().contains("another tmo"), "{e}");
        other.kill().unwrap();
        other.wait().unwrap();
        // issue 41: a live pid of another program (init) is no writer: taken over
        std::fs::write(dir.path().join("batch.lock"), "1").unwrap();
        drop(OutputLock::acquire(&target).unwrap());
        // a lock whose process is gone
        std::fs::write(dir.path().join("batch.lock"), "4000000000").unwrap();
        let taken = OutputLock::acquire(&target).unwrap();
        drop(first);
        drop(taken);
        assert!(!dir.path().join("batch.lock").exists());
    }
}
