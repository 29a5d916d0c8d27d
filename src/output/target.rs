//! What an output path may name, checked in one place before anything is written there.
//!
//! tmo replaces an output file by renaming a finished temporary over it ([`super::atomic`]).
//! A rename replaces whatever the path names: a device node (`/dev/null`, `/dev/full`),
//! a FIFO or a symbolic link would become a regular file, which as root breaks the machine
//! for every other process. So a file output must be absent or a regular file, never a
//! link; a directory output must be absent or a directory; no output is empty (an unset
//! `"$OUT"` would otherwise write into the current directory); and an output that joins
//! inputs (a merge) must lie apart from every one of them, or it would write into what it
//! is reading.

use std::path::{Component, Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error("the output path is empty (an unset variable?): give a file or directory")]
    Empty,
    #[error("{path} is {what}, not a regular file: tmo writes outputs only as regular files and will not replace it; choose another --out")]
    NotRegular { path: PathBuf, what: &'static str },
    #[error("{} is a folder; expected the output file's path (e.g. {})", .0.display(), .0.join("<name>").display())]
    IsFolder(PathBuf),
    #[error("{path} is a symbolic link (to {to}): an output is replaced whole, which would replace the link itself; give the path it points to, or another --out")]
    Link { path: PathBuf, to: PathBuf },
    #[error("{path} is {what}, not a directory: this output is a directory; choose another --out")]
    NotADirectory { path: PathBuf, what: &'static str },
    #[error("the output {out} lies inside the input {input}: it would write into what it reads; choose an --out outside every input")]
    InsideInput { out: PathBuf, input: PathBuf },
    #[error("the input {input} lies inside the output {out}: choose an --out that holds no input")]
    HoldsInput { out: PathBuf, input: PathBuf },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl From<TargetError> for std::io::Error {
    fn from(e: TargetError) -> Self {
        match e {
            TargetError::Io { source, .. } => source,
            other => std::io::Error::new(std::io::ErrorKind::InvalidInput, other.to_string()),
        }
    }
}

/// What a file type is, in words, for a path that is neither a regular file nor a
/// directory (nor a link: the caller looks at the link itself).
fn kind(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else if t.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// `path` may be written as a file: it is not empty, and it is absent or a regular file
/// (not a link to one: renaming over the link would replace it).
pub fn check_file(path: &Path) -> Result<(), TargetError> {
    if path.as_os_str().is_empty() {
        return Err(TargetError::Empty);
    }
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(TargetError::Io {
            path: path.to_path_buf(),
            source,
        }),
        Ok(m) if m.file_type().is_symlink() => Err(TargetError::Link {
            path: path.to_path_buf(),
            to: std::fs::read_link(path).unwrap_or_default(),
        }),
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) if m.file_type().is_dir() => Err(TargetError::IsFolder(path.to_path_buf())),
        Ok(m) => Err(TargetError::NotRegular {
            path: path.to_path_buf(),
            what: kind(&m.file_type()),
        }),
    }
}

/// `path` may be written as a directory of outputs: not empty, and absent or a directory
/// (a link to a directory is followed: files are written inside it, never over it).
pub fn check_dir(path: &Path) -> Result<(), TargetError> {
    if path.as_os_str().is_empty() {
        return Err(TargetError::Empty);
    }
    match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // a dangling link would be created through; refuse it as a link
            match std::fs::symlink_metadata(path) {
                Ok(m) if m.file_type().is_symlink() => Err(TargetError::Link {
                    path: path.to_path_buf(),
                    to: std::fs::read_link(path).unwrap_or_default(),
                }),
                _ => Ok(()),
            }
        }
        Err(source) => Err(TargetError::Io {
            path: path.to_path_buf(),
            source,
        }),
        Ok(m) if m.is_dir() => Ok(()),
        Ok(m) => Err(TargetError::NotADirectory {
            path: path.to_path_buf(),
            what: kind(&m.file_type()),
        }),
    }
}

/// `path` made absolute with its links resolved as far as it exists; the rest (not yet
/// created) is appended with `.` and `..` taken lexically.
fn resolved(path: &Path) -> Result<PathBuf, TargetError> {
    let absolute = std::path::absolute(path).map_err(|source| TargetError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut existing = absolute.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(real) = existing.canonicalize() {
            let mut out = real;
            for part in rest.iter().rev() {
                match part {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::CurDir => {}
                    other => out.push(other.as_os_str()),
                }
            }
            return Ok(out);
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                rest.push(last);
                existing = parent;
            }
            _ => return Ok(absolute),
        }
    }
}

/// The output `out` lies apart from every input: neither inside one nor holding one.
pub fn check_apart(out: &Path, inputs: &[PathBuf]) -> Result<(), TargetError> {
    let out_real = resolved(out)?;
    for input in inputs {
        let input_real = resolved(input)?;
        if out_real.starts_with(&input_real) {
            return Err(TargetError::InsideInput {
                out: out.to_path_buf(),
                input: input.clone(),
            });
        }
        if input_real.starts_with(&out_real) {
            return Err(TargetError::HoldsInput {
                out: out.to_path_buf(),
                input: input.clone(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_output_is_absent_or_a_regular_file_never_a_device_fifo_link_or_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.csv");
        check_file(&file).unwrap();
        std::fs::write(&file, "x").unwrap();
        check_file(&file).unwrap();
        assert!(matches!(check_file(Path::new("")), Err(TargetError::Empty)));
        let e = check_file(dir.path()).unwrap_err();
        assert!(e.to_string().contains("is a folder; expected"), "{e}");
        // a device is only looked at, never opened
        let e = check_file(Path::new("/dev/null")).unwrap_err();
        assert!(
            matches!(&e, TargetError::NotRegular { what, .. } if *what == "a character device"),
            "{e}"
        );
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::os::unix::fs::symlink(&file, &link).unwrap();
            let e = check_file(&link).unwrap_err();
            assert!(matches!(e, TargetError::Link { .. }), "{e}");
            let fifo = dir.path().join("fifo");
            let name = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
            // SAFETY: a valid C string; mkfifo only creates the node
            assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
            let e = check_file(&fifo).unwrap_err();
            assert!(e.to_string().contains("FIFO"), "{e}");
        }
    }

    #[test]
    fn a_directory_output_is_absent_or_a_directory_links_to_one_followed() {
        let dir = tempfile::tempdir().unwrap();
        check_dir(&dir.path().join("new")).unwrap();
        check_dir(dir.path()).unwrap();
        assert!(matches!(check_dir(Path::new("")), Err(TargetError::Empty)));
        let file = dir.path().join("f");
        std::fs::write(&file, "x").unwrap();
        assert!(matches!(
            check_dir(&file),
            Err(TargetError::NotADirectory { .. })
        ));
        assert!(check_dir(Path::new("/dev/null")).is_err());
        #[cfg(unix)]
        {
            let link = dir.path().join("l");
            std::os::unix::fs::symlink(dir.path(), &link).unwrap();
            check_dir(&link).unwrap();
            let dangling = dir.path().join("d");
            std::os::unix::fs::symlink(dir.path().join("nowhere"), &dangling).unwrap();
            assert!(matches!(
                check_dir(&dangling),
                Err(TargetError::Link { .. })
            ));
        }
    }

    #[test]
    fn an_output_inside_an_input_or_holding_one_is_refused_however_it_is_spelled() {
        let dir = tempfile::tempdir().unwrap();
        let shard = dir.path().join("s1");
        std::fs::create_dir_all(shard.join("replicate-01")).unwrap();
        let inputs = [shard.clone()];
        check_apart(&dir.path().join("merged"), &inputs).unwrap();
        // a sibling whose name starts with the input's is apart
        check_apart(&dir.path().join("s10"), &inputs).unwrap();
        let e = check_apart(&shard.join("replicate-01/sub"), &inputs).unwrap_err();
        assert!(matches!(e, TargetError::InsideInput { .. }), "{e}");
        let e = check_apart(&dir.path().join("merged/../s1/x"), &inputs).unwrap_err();
        assert!(matches!(e, TargetError::InsideInput { .. }), "{e}");
        let e = check_apart(dir.path(), &inputs).unwrap_err();
        assert!(matches!(e, TargetError::HoldsInput { .. }), "{e}");
        #[cfg(unix)]
        {
            let link = dir.path().join("alias");
            std::os::unix::fs::symlink(&shard, &link).unwrap();
            let e = check_apart(&link.join("out"), &inputs).unwrap_err();
            assert!(matches!(e, TargetError::InsideInput { .. }), "{e}");
        }
    }
}
