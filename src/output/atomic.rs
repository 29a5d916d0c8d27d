//! Every output file written whole or not at all: bytes go to a temporary file beside the
//! target, which is renamed over it once complete. A reader, a crash or a full disk then
//! leaves the old file or the new one, never a truncated one (issue 41: dataset exports and
//! figures were left half-written by a full disk). One helper, so no writer does it its own
//! way.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary beside `path`: `<name>.partial`, which no reader of tmo's outputs lists.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    path.with_file_name(name)
}

/// A new file at `path`, never opened through what was there: a temporary left by a
/// crash (or planted as a link to another file) is removed, not truncated.
pub fn create_fresh(path: &Path) -> io::Result<File> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(e),
        _ => {}
    }
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
}

/// Writes `bytes` to `path` whole or not at all.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

/// A file being written: [`Write`] into it, then [`AtomicFile::commit`] puts it in place.
/// Dropped uncommitted (an error on the way), its temporary is removed and the target is
/// untouched.
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Refuses a target that is not absent or a regular file ([`super::target::check_file`]):
    /// the rename at commit would replace a device node or a link.
    pub fn create(path: &Path) -> io::Result<Self> {
        super::target::check_file(path)?;
        let tmp = partial_path(path);
        let file = BufWriter::new(create_fresh(&tmp)?);
        Ok(Self {
            path: path.to_path_buf(),
            tmp,
            file: Some(file),
        })
    }

    /// Flushes what was written and renames it over the target.
    pub fn commit(mut self) -> io::Result<()> {
        let file = self.file.take().expect("a file is committed once");
        // no fsync: the rename makes the whole file visible at once, which is what readers
        // and a full disk need; durability across power loss is the file system's
        file.into_inner().map_err(|e| e.into_error())?;
        std::fs::rename(&self.tmp, &self.path)
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.as_mut().expect("not committed").write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.as_mut().expect("not committed").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_replaced_whole_or_left_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("table.csv");
        write_atomic(&path, b"old").unwrap();
        // a write that fails part way leaves the old file and no temporary
        {
            let mut f = AtomicFile::create(&path).unwrap();
            f.write_all(b"new, but not fin").unwrap();
        }
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert!(!partial_path(&path).exists());
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn a_link_or_a_device_is_never_written_through_or_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let precious = dir.path().join("precious");
        std::fs::write(&precious, "keep").unwrap();
        // the output itself a link: refused, the link and its target as they were
        let link = dir.path().join("out.csv");
        std::os::unix::fs::symlink(&precious, &link).unwrap();
        let e = write_atomic(&link, b"new").unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        // a stale temporary that links elsewhere is removed, not truncated through
        let out = dir.path().join("t.csv");
        std::os::unix::fs::symlink(&precious, partial_path(&out)).unwrap();
        write_atomic(&out, b"new").unwrap();
        assert_eq!(std::fs::read(&precious).unwrap(), b"keep");
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        // a node that is not a file (a FIFO here: no test touches the machine's devices)
        let fifo = dir.path().join("fifo");
        let name = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
        // SAFETY: a valid C string; mkfifo only creates the node
        assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
        let e = write_atomic(&fifo, b"x").unwrap_err();
        assert!(e.to_string().contains("FIFO"), "{e}");
        assert!(!std::fs::metadata(&fifo).unwrap().is_file());
    }
}
