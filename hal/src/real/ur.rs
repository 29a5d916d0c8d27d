//! The UR5 as the rig's [`Arm`]: state from RTDE (protocol 2, `actual_TCP_pose`, `timestamp`,
//! `robot_status_bits`), motion by URScript lines on the secondary interface.
//!
//! Reconnect policy: a lost connection is an error of the call that met it (the runner then
//! ends its trial). The next call reconnects both interfaces — up to
//! [`RECONNECT_ATTEMPTS`] tries, 0.25 s apart and doubling — and first sends `stopl`, since a
//! script the controller was running goes on without its client; only then does the call
//! proceed. A reconnect that fails is that call's error. Protocol errors do not reconnect.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use crate::wire::rtde::{
    decode_values, ClientMessage, Framer, RtdeError, ServerMessage, Value, VarType,
    PROTOCOL_VERSION,
};
use crate::wire::urscript::Command;
use crate::{Arm, ErrorKind, ErrorType, Pose};

/// Outputs the arm backend asks RTDE for.
pub const OUTPUTS: [&str; 3] = ["timestamp", "actual_TCP_pose", "robot_status_bits"];

#[derive(Debug, thiserror::Error)]
pub enum UrError {
    #[error("UR controller {addr}: {source}")]
    Io {
        addr: String,
        source: std::io::Error,
    },
    #[error("UR controller: RTDE: {0}")]
    Rtde(#[from] RtdeError),
    #[error("UR controller refused: {0}")]
    Refused(String),
    #[error("UR controller sent nothing for {0:.1} s")]
    Timeout(f64),
    #[error("UR controller closed the connection")]
    Closed,
    #[error("move refused before sending: {0}")]
    Limit(String),
}

impl crate::Error for UrError {
    fn kind(&self) -> ErrorKind {
        match self {
            UrError::Timeout(_) => ErrorKind::Timeout,
            UrError::Closed | UrError::Io { .. } => ErrorKind::Disconnected,
            UrError::Rtde(_) | UrError::Refused(_) => ErrorKind::Protocol,
            UrError::Limit(_) => ErrorKind::OutOfLimits,
        }
    }
}

/// One RTDE state sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmState {
    /// Controller time, s.
    pub timestamp_s: f64,
    /// Tool pose: metres and a rotation vector in radians.
    pub tcp_pose: [f64; 6],
    pub status_bits: u32,
}

/// An RTDE session that has negotiated protocol 2 and started the output recipe.
pub struct RtdeClient {
    stream: TcpStream,
    addr: String,
    framer: Framer,
    recipe: u8,
    types: Vec<VarType>,
    pub controller_version: (u32, u32, u32, u32),
    timeout: Duration,
}

fn io(addr: &str) -> impl Fn(std::io::Error) -> UrError + '_ {
    move |source| UrError::Io {
        addr: addr.to_string(),
        source,
    }
}

fn resolve(addr: &str) -> Result<SocketAddr, UrError> {
    addr.to_socket_addrs()
        .map_err(io(addr))?
        .next()
        .ok_or_else(|| UrError::Refused(format!("{addr} does not resolve")))
}

impl RtdeClient {
    pub fn connect(addr: &str, frequency_hz: f64, timeout: Duration) -> Result<Self, UrError> {
        let stream = TcpStream::connect_timeout(&resolve(addr)?, timeout).map_err(io(addr))?;
        stream.set_nodelay(true).map_err(io(addr))?;
        let mut c = RtdeClient {
            stream,
            addr: addr.to_string(),
            framer: Framer::default(),
            recipe: 0,
            types: Vec::new(),
            controller_version: (0, 0, 0, 0),
            timeout,
        };
        c.send(&ClientMessage::RequestProtocolVersion(PROTOCOL_VERSION))?;
        match c.reply()? {
            ServerMessage::ProtocolVersionAccepted(true) => {}
            other => return Err(UrError::Refused(format!("protocol version 2: {other:?}"))),
        }
        c.send(&ClientMessage::GetUrcontrolVersion)?;
        if let ServerMessage::UrcontrolVersion {
            major,
            minor,
            bugfix,
            build,
        } = c.reply()?
        {
            c.controller_version = (major, minor, bugfix, build);
        }
        c.send(&ClientMessage::SetupOutputs {
            frequency_hz,
            variables: OUTPUTS.iter().map(|s| s.to_string()).collect(),
        })?;
        match c.reply()? {
            ServerMessage::Recipe { id, types } => {
                c.recipe = id;
                c.types = types
                    .iter()
                    .zip(OUTPUTS)
                    .map(|(t, name)| {
                        t.parse()
                            .map_err(|_| UrError::Refused(format!("output {name}: {t}")))
                    })
                    .collect::<Result<_, _>>()?;
            }
            other => return Err(UrError::Refused(format!("output setup: {other:?}"))),
        }
        c.send(&ClientMessage::Start)?;
        match c.reply()? {
            ServerMessage::Started(true) => Ok(c),
            other => Err(UrError::Refused(format!("start: {other:?}"))),
        }
    }

    fn send(&mut self, m: &ClientMessage) -> Result<(), UrError> {
        let bytes = m.encode()?;
        self.stream.write_all(&bytes).map_err(io(&self.addr))
    }

    /// Reads until at least one package arrived, or the timeout.
    /// Everything the socket holds now, without waiting.
    fn drain(&mut self) -> Result<Vec<(u8, Vec<u8>)>, UrError> {
        let mut buf = [0u8; 4096];
        let mut out = Vec::new();
        self.stream.set_nonblocking(true).map_err(io(&self.addr))?;
        let drained = loop {
            match self.stream.read(&mut buf) {
                Ok(0) => break Err(UrError::Closed),
                Ok(n) => match self.framer.push(&buf[..n]) {
                    Ok(more) => out.extend(more),
                    Err(e) => break Err(e.into()),
                },
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break Ok(()),
                Err(e) => break Err(io(&self.addr)(e)),
            }
        };
        self.stream.set_nonblocking(false).map_err(io(&self.addr))?;
        drained.map(|()| out)
    }

    /// Every package already buffered (after a pause the socket holds seconds of state, and
    /// the newest is what counts); if there are none, waits up to `wait` for some.
    fn read_packages(&mut self, wait: Duration) -> Result<Vec<(u8, Vec<u8>)>, UrError> {
        let now = self.drain()?;
        if !now.is_empty() || wait.is_zero() {
            return Ok(now);
        }
        let deadline = Instant::now() + wait;
        let mut buf = [0u8; 4096];
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(Vec::new());
            }
            self.stream
                .set_read_timeout(Some(left))
                .map_err(io(&self.addr))?;
            match self.stream.read(&mut buf) {
                Ok(0) => return Err(UrError::Closed),
                Ok(n) => {
                    let mut p = self.framer.push(&buf[..n])?;
                    if !p.is_empty() {
                        p.extend(self.drain()?);
                        return Ok(p);
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    return Ok(Vec::new())
                }
                Err(e) => return Err(io(&self.addr)(e)),
            }
        }
    }

    /// The next reply during setup (text messages are skipped).
    fn reply(&mut self) -> Result<ServerMessage, UrError> {
        let deadline = Instant::now() + self.timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(UrError::Timeout(self.timeout.as_secs_f64()));
            }
            for (code, p) in self.read_packages(left)? {
                match ServerMessage::decode(code, &p)? {
                    ServerMessage::Text { .. } => {}
                    m => return Ok(m),
                }
            }
        }
    }

    /// The newest state that arrived within `wait` (older ones are skipped).
    pub fn latest(&mut self, wait: Duration) -> Result<Option<ArmState>, UrError> {
        let mut newest = None;
        for (code, p) in self.read_packages(wait)? {
            if let ServerMessage::Data { recipe, payload } = ServerMessage::decode(code, &p)? {
                if recipe != self.recipe {
                    continue;
                }
                let v = decode_values(&payload, &self.types)?;
                if let [Value::Double(t), Value::Vector6d(pose), Value::Uint32(bits)] = v[..] {
                    newest = Some(ArmState {
                        timestamp_s: t,
                        tcp_pose: pose,
                        status_bits: bits,
                    });
                }
            }
        }
        Ok(newest)
    }
}

/// URScript lines to the secondary interface.
pub struct ScriptClient {
    stream: TcpStream,
    addr: String,
}

impl ScriptClient {
    pub fn connect(addr: &str, timeout: Duration) -> Result<Self, UrError> {
        let stream = TcpStream::connect_timeout(&resolve(addr)?, timeout).map_err(io(addr))?;
        stream.set_nodelay(true).map_err(io(addr))?;
        Ok(Self {
            stream,
            addr: addr.to_string(),
        })
    }

    pub fn send(&mut self, c: &Command) -> Result<(), UrError> {
        self.stream
            .write_all(c.to_line().as_bytes())
            .map_err(io(&self.addr))
    }
}

/// Tries of a reconnect before the call fails.
pub const RECONNECT_ATTEMPTS: u32 = 3;

/// Where the controller is.
#[derive(Debug, Clone)]
struct Endpoint {
    host: String,
    rtde_port: u16,
    script_port: u16,
    frequency_hz: f64,
}

impl Endpoint {
    fn connect(&self) -> Result<(RtdeClient, ScriptClient), UrError> {
        let timeout = Duration::from_secs(2);
        let (h, r, s) = (&self.host, self.rtde_port, self.script_port);
        let rtde = RtdeClient::connect(&format!("{h}:{r}"), self.frequency_hz, timeout)?;
        let script = ScriptClient::connect(&format!("{h}:{s}"), timeout)?;
        Ok((rtde, script))
    }
}

/// The arm backend: RTDE for state, URScript for motion.
pub struct UrArm {
    rtde: RtdeClient,
    script: ScriptClient,
    endpoint: Endpoint,
    /// A call lost the connection; the next one reconnects.
    lost: bool,
    /// Reconnects made so far.
    pub reconnects: u32,
    last: Option<ArmState>,
    /// Tool acceleration for every move, m/s^2.
    pub accel_m_s2: f64,
    /// RTDE silent this long is a fault.
    pub state_timeout: Duration,
}

impl UrArm {
    pub fn connect(
        host: &str,
        rtde_port: u16,
        script_port: u16,
        frequency_hz: f64,
    ) -> Result<Self, UrError> {
        let endpoint = Endpoint {
            host: host.to_string(),
            rtde_port,
            script_port,
            frequency_hz,
        };
        let (rtde, script) = endpoint.connect()?;
        Ok(Self {
            rtde,
            script,
            endpoint,
            lost: false,
            reconnects: 0,
            last: None,
            accel_m_s2: 1.2,
            state_timeout: Duration::from_millis(500),
        })
    }

    /// Reconnects after a lost connection and stops whatever the controller was doing.
    fn reconnect(&mut self) -> Result<(), UrError> {
        let mut pause = Duration::from_millis(250);
        let mut attempt = 1;
        let (rtde, script) = loop {
            match self.endpoint.connect() {
                Ok(c) => break c,
                Err(e) if attempt >= RECONNECT_ATTEMPTS => return Err(e),
                Err(_) => {
                    std::thread::sleep(pause);
                    pause *= 2;
                    attempt += 1;
                }
            }
        };
        (self.rtde, self.script, self.last) = (rtde, script, None);
        self.script.send(&Command::Stopl { accel_m_s2: 2.0 })?;
        self.lost = false;
        self.reconnects += 1;
        Ok(())
    }

    /// Runs a call on a connected arm, reconnecting first if the last call lost it.
    fn connected<T>(
        &mut self,
        call: impl FnOnce(&mut Self) -> Result<T, UrError>,
    ) -> Result<T, UrError> {
        if self.lost {
            self.reconnect()?;
        }
        let result = call(self);
        if let Err(e) = &result {
            self.lost = crate::Error::kind(e) == ErrorKind::Disconnected;
        }
        result
    }

    /// The newest state, waiting for one if none arrived yet.
    pub fn state(&mut self) -> Result<ArmState, UrError> {
        self.connected(Self::read_state)
    }

    fn read_state(&mut self) -> Result<ArmState, UrError> {
        let wait = if self.last.is_some() {
            Duration::ZERO
        } else {
            self.state_timeout
        };
        if let Some(s) = self.rtde.latest(wait)? {
            self.last = Some(s);
        }
        self.last
            .ok_or(UrError::Timeout(self.state_timeout.as_secs_f64()))
    }
}

impl ErrorType for UrArm {
    type Error = UrError;
}

impl Arm for UrArm {
    fn tcp_pose(&mut self) -> Result<Pose, UrError> {
        let s = self.state()?;
        Ok(Pose {
            position_mm: [0, 1, 2].map(|i| s.tcp_pose[i] * 1000.0),
            rotation_rad: [s.tcp_pose[3], s.tcp_pose[4], s.tcp_pose[5]],
        })
    }

    fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), UrError> {
        if !(speed_mm_s.is_finite() && speed_mm_s > 0.0) {
            return Err(UrError::Limit(format!("speed {speed_mm_s} mm/s")));
        }
        self.connected(|arm| {
            let mut pose = arm.read_state()?.tcp_pose;
            for i in 0..3 {
                pose[i] += offset_mm[i] / 1000.0;
            }
            arm.script.send(&Command::Movel {
                pose,
                accel_m_s2: arm.accel_m_s2,
                speed_m_s: speed_mm_s / 1000.0,
            })
        })
    }

    fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), UrError> {
        let v = velocity_mm_s.map(|x| x / 1000.0);
        // speedl holds the speed for t seconds; one minute outlasts any trial phase and the
        // runner always ends with stop.
        self.connected(|arm| {
            arm.script.send(&Command::Speedl {
                velocity: [v[0], v[1], v[2], 0.0, 0.0, 0.0],
                accel_m_s2: arm.accel_m_s2,
                time_s: 60.0,
            })
        })
    }

    fn stop(&mut self) -> Result<(), UrError> {
        // after a lost connection, reconnecting sends the stop
        let was_lost = self.lost;
        self.connected(|arm| {
            if was_lost {
                Ok(())
            } else {
                arm.script.send(&Command::Stopl { accel_m_s2: 2.0 })
            }
        })
    }
}
