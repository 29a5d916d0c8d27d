//! The control port of `tmo sim serve`: what an operator does to a real rig between trials
//! (put the object back, set the next one up), done to the served simulator by a request.
//!
//! One JSON object per line on a loopback TCP connection:
//! `{"reset": <SimConfig>}` builds a new world from that configuration (the object where the
//! trial starts it, the hand and arm at their start) behind the same served devices; the
//! answer is `{"ok": true}` or `{"error": "<why>"}`. The served ports, sockets and the UR
//! controller's clock carry on, as a real rig's do while the operator works.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream, ToSocketAddrs};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::tcp::read_available;
use crate::SimConfig;

#[derive(Debug, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Request {
    Reset(Box<SimConfig>),
}

#[derive(Debug, Serialize, Deserialize)]
struct Answer {
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    ok: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    error: Option<String>,
}

/// Longest request line the server takes (a SimConfig is a few kB).
const MAX_LINE: usize = 1 << 20;

/// The server side, polled by the serve loop (one thread, non-blocking like the others).
pub struct ControlPort {
    listener: TcpListener,
    clients: Vec<Client>,
    pub resets: u64,
}

struct Client {
    stream: TcpStream,
    pending: Vec<u8>,
    /// Answers not yet taken by the client's socket.
    outgoing: Vec<u8>,
    open: bool,
}

/// Requests read from one client in one poll.
const MAX_LINES_PER_POLL: usize = 1000;

/// Most answer bytes kept for a client that does not read them: past this it is not
/// reading, and is dropped rather than let it stall the loop (or grow without bound).
const MAX_OUTGOING: usize = 64 * 1024;

impl Client {
    /// Writes what the socket takes now, never waiting: one client that sends and never
    /// reads must not stop the control port, the served devices or the other clients.
    fn flush(&mut self) {
        while !self.outgoing.is_empty() {
            match self.stream.write(&self.outgoing) {
                Ok(0) => self.open = false,
                Ok(n) => {
                    self.outgoing.drain(..n);
                    continue;
                }
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(_) => self.open = false,
            }
            break;
        }
        if self.outgoing.len() > MAX_OUTGOING {
            self.open = false;
        }
    }
}

impl ControlPort {
    pub fn new(listener: TcpListener) -> std::io::Result<Self> {
        listener.set_nonblocking(true)?;
        Ok(Self {
            listener,
            clients: Vec::new(),
            resets: 0,
        })
    }

    /// The next reset asked for, if one has arrived; its answer goes back through
    /// [`ControlPort::answer`]. Malformed requests are answered here with their error.
    pub fn poll(&mut self) -> std::io::Result<Option<(usize, SimConfig)>> {
        self.clients.iter_mut().for_each(Client::flush);
        self.clients.retain(|c| c.open);
        while let Ok((stream, _)) = self.listener.accept() {
            stream.set_nonblocking(true)?;
            self.clients.push(Client {
                stream,
                pending: Vec::new(),
                outgoing: Vec::new(),
                open: true,
            });
        }
        for k in 0..self.clients.len() {
            let c = &mut self.clients[k];
            c.open &= read_available(&mut c.stream, &mut c.pending, MAX_LINE + 1);
            if c.pending.len() > MAX_LINE && !c.pending[..=MAX_LINE].contains(&b'\n') {
                c.pending.clear();
                self.answer(k, Err("request longer than 1 MiB".into()))?;
                // what follows is the rest of that request, not a new one
                self.clients[k].open = false;
                continue;
            }
            // a bounded number of lines a poll, so one client cannot hold the loop
            for _ in 0..MAX_LINES_PER_POLL {
                let c = &mut self.clients[k];
                if !c.open {
                    break;
                }
                let Some(end) = c.pending.iter().position(|&b| b == b'\n') else {
                    break;
                };
                let line: Vec<u8> = c.pending.drain(..=end).collect();
                match serde_json::from_slice::<Request>(&line) {
                    Ok(Request::Reset(config)) => return Ok(Some((k, *config))),
                    Err(e) => {
                        self.answer(k, Err(format!("expected {{\"reset\": <SimConfig>}}: {e}")))?
                    }
                }
            }
        }
        Ok(None)
    }

    /// Answers client `k`'s request.
    pub fn answer(&mut self, k: usize, result: Result<(), String>) -> std::io::Result<()> {
        if result.is_ok() {
            self.resets += 1;
        }
        let answer = match result {
            Ok(()) => Answer {
                ok: true,
                error: None,
            },
            Err(e) => Answer {
                ok: false,
                error: Some(e),
            },
        };
        let mut line = serde_json::to_vec(&answer).map_err(std::io::Error::other)?;
        line.push(b'\n');
        // queued and written as the socket takes it; a client that cannot be answered, or
        // lets its answers pile up, is dropped at the next poll
        let c = &mut self.clients[k];
        c.outgoing.extend_from_slice(&line);
        c.flush();
        Ok(())
    }
}

/// Why a reset was not done.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    #[error("cannot reach the served simulator's control port {addr}: {source}")]
    Connect {
        addr: String,
        source: std::io::Error,
    },
    #[error("the served simulator's control port stopped answering: {0}")]
    Io(#[from] std::io::Error),
    #[error(
        "the served simulator did not answer a reset within {seconds} s (is `tmo sim serve` \
         stopped or overloaded?)"
    )]
    Timeout { seconds: f64 },
    #[error("the served simulator refused the reset: {0}")]
    Refused(String),
    #[error("the served simulator answered {0:?}, not {{\"ok\": true}} or {{\"error\": ...}}")]
    Garbled(String),
}

/// How long a reset may take: building a world takes milliseconds; a loaded machine gets
/// ample room.
const RESET_TIMEOUT_S: u64 = 10;

/// The client a batch uses to set up each trial on the served simulator.
pub struct SimControlClient {
    reader: BufReader<TcpStream>,
    timeout: Duration,
}

impl SimControlClient {
    pub fn connect(addr: &str) -> Result<Self, ControlError> {
        Self::connect_with_timeout(addr, Duration::from_secs(RESET_TIMEOUT_S))
    }

    /// [`Self::connect`] with another limit on the wait for an answer.
    pub fn connect_with_timeout(addr: &str, timeout: Duration) -> Result<Self, ControlError> {
        let connect = || -> std::io::Result<TcpStream> {
            let a = addr.to_socket_addrs()?.next().ok_or_else(|| {
                std::io::Error::new(std::io::ErrorKind::InvalidInput, "no address")
            })?;
            let s = TcpStream::connect_timeout(&a, Duration::from_secs(2))?;
            s.set_read_timeout(Some(timeout))?;
            s.set_nodelay(true)?;
            Ok(s)
        };
        let stream = connect().map_err(|source| ControlError::Connect {
            addr: addr.to_string(),
            source,
        })?;
        Ok(Self {
            reader: BufReader::new(stream),
            timeout,
        })
    }

    /// Sets the served world up as `config` describes and waits until it is.
    pub fn reset(&mut self, config: &SimConfig) -> Result<(), ControlError> {
        let mut line = serde_json::to_vec(&Request::Reset(Box::new(config.clone())))
            .map_err(std::io::Error::other)?;
        line.push(b'\n');
        self.reader.get_mut().write_all(&line)?;
        let mut answer = String::new();
        self.reader
            .read_line(&mut answer)
            .map_err(|e| match e.kind() {
                // A read timeout shows as WouldBlock on Unix and TimedOut on Windows.
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => {
                    ControlError::Timeout {
                        seconds: self.timeout.as_secs_f64(),
                    }
                }
                _ => ControlError::Io(e),
            })?;
        match serde_json::from_str::<Answer>(&answer) {
            Ok(Answer { ok: true, .. }) => Ok(()),
            Ok(Answer { error: Some(e), .. }) => Err(ControlError::Refused(e)),
            _ => Err(ControlError::Garbled(answer.trim_end().to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_server_that_never_answers_is_a_timeout_said_once() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        // Accepts and reads, never answers (a stopped `sim serve`).
        let server = std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            let mut buf = [0u8; 4096];
            while matches!(std::io::Read::read(&mut s, &mut buf), Ok(n) if n > 0) {}
        });
        let mut client =
            SimControlClient::connect_with_timeout(&addr, Duration::from_millis(200)).unwrap();
        let e = client.reset(&SimConfig::default()).unwrap_err();
        assert!(matches!(e, ControlError::Timeout { .. }), "{e:?}");
        let text = e.to_string();
        assert!(
            text.contains("did not answer a reset within 0.2 s"),
            "{text}"
        );
        assert!(!text.contains("os error"), "{text}");
        drop(client);
        server.join().unwrap();
    }
}
