//! Non-blocking TCP reads shared by the emulated UR controller and the control port.

use std::io::Read;
use std::net::TcpStream;

/// Reads what a non-blocking client has sent into `pending`, up to about `cap` bytes (the
/// rest waits in the socket); false once the client has gone.
pub(crate) fn read_available(stream: &mut TcpStream, pending: &mut Vec<u8>, cap: usize) -> bool {
    let mut buf = [0u8; 4096];
    while pending.len() < cap {
        match stream.read(&mut buf) {
            Ok(0) => return false,
            Ok(n) => pending.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return true,
            Err(_) => return false,
        }
    }
    true
}
