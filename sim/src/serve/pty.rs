//! Pseudo-terminals for the emulated serial devices (the fingertip and marker cameras, the
//! servo bus).

use std::fs::File;
use std::os::fd::{AsFd, OwnedFd};
use std::path::PathBuf;

use nix::fcntl::{fcntl, FcntlArg, FdFlag, OFlag};
use nix::sys::termios;

fn io(e: nix::Error) -> std::io::Error {
    std::io::Error::from(e)
}

/// A raw pseudo-terminal (like a USB serial port: no echo, no line editing, no CR/LF
/// translation) with a non-blocking master: the master, the slave (kept open so the
/// terminal does not hang up between clients) and the slave's path. Both ends are closed
/// on exec, as Rust's own files are: a child process holding the master would keep the
/// terminal from hanging up when its owner closes it.
pub fn open_pty() -> std::io::Result<(File, OwnedFd, PathBuf)> {
    let pty = nix::pty::openpty(None, None).map_err(io)?;
    for fd in [pty.master.as_fd(), pty.slave.as_fd()] {
        fcntl(fd, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).map_err(io)?;
    }
    let mut t = termios::tcgetattr(pty.slave.as_fd()).map_err(io)?;
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(pty.slave.as_fd(), termios::SetArg::TCSANOW, &t).map_err(io)?;
    let path = nix::unistd::ttyname(pty.slave.as_fd()).map_err(io)?;
    let flags = fcntl(pty.master.as_fd(), FcntlArg::F_GETFL).map_err(io)?;
    fcntl(
        pty.master.as_fd(),
        FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK),
    )
    .map_err(io)?;
    Ok((File::from(pty.master), pty.slave, path))
}
