//! The simulated arm served as a UR controller (for `tmo sim serve`): RTDE protocol 2 on one
//! TCP listener, URScript motion lines on another, the simulation advanced in real time.
//! One thread, non-blocking sockets: the rig's handles are not `Send`, and a 1 ms loop
//! serves a handful of connections easily.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};

use super::tcp::read_available;
use tmo_hal::wire::rtde::{encode_values, ClientMessage, Framer, ServerMessage, Value};
use tmo_hal::wire::urscript::{parse_line, Command};
use tmo_hal::Arm;

/// What the emulated controller says it is (a CB3 at 125 Hz).
pub const CONTROLLER_VERSION: (u32, u32, u32, u32) = (3, 15, 7, 0);

/// Counters of what the emulator did, for tests and the serve command's summary.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct UrServeStats {
    pub rtde_clients: u32,
    pub script_clients: u32,
    pub data_packages: u64,
    pub script_lines: u64,
    pub script_errors: u64,
}

struct RtdeConn {
    stream: TcpStream,
    framer: Framer,
    /// Output recipe: variable names, period, next send time (sim s).
    outputs: Vec<String>,
    period_s: f64,
    next_s: f64,
    started: bool,
    open: bool,
}

struct ScriptConn {
    stream: TcpStream,
    pending: Vec<u8>,
    open: bool,
}

fn output_type(name: &str) -> &'static str {
    match name {
        "timestamp" => "DOUBLE",
        "actual_TCP_pose" | "target_TCP_pose" | "actual_TCP_speed" => "VECTOR6D",
        "robot_status_bits" | "safety_status_bits" | "runtime_state" => "UINT32",
        "robot_mode" | "safety_mode" => "INT32",
        _ => "NOT_FOUND",
    }
}

fn input_type(name: &str) -> &'static str {
    let register = |prefix: &str| {
        name.strip_prefix(prefix)
            .and_then(|n| n.parse::<u32>().ok())
            .is_some_and(|n| n < 48)
    };
    if register("input_double_register_") {
        "DOUBLE"
    } else if register("input_int_register_") {
        "INT32"
    } else {
        "NOT_FOUND"
    }
}

fn write(stream: &mut TcpStream, m: &ServerMessage, code: Option<u8>) -> bool {
    let bytes = match code {
        Some(c) => m.encode_recipe(c),
        None => m.encode(),
    };
    bytes.is_ok_and(|b| stream.write_all(&b).is_ok())
}

/// The emulated UR controller: listeners, connections and what it has done.
pub struct UrEmulator {
    rtde: TcpListener,
    script: TcpListener,
    rtde_conns: Vec<RtdeConn>,
    script_conns: Vec<ScriptConn>,
    pub stats: UrServeStats,
}

impl UrEmulator {
    pub fn new(rtde: TcpListener, script: TcpListener) -> std::io::Result<Self> {
        rtde.set_nonblocking(true)?;
        script.set_nonblocking(true)?;
        Ok(Self {
            rtde,
            script,
            rtde_conns: Vec::new(),
            script_conns: Vec::new(),
            stats: UrServeStats::default(),
        })
    }

    /// Accepts, reads and answers what arrived, and streams state due at `now` (sim s).
    pub fn step(&mut self, now: f64, arm: &mut crate::SimArm) -> std::io::Result<()> {
        let mut buf = [0u8; 4096];
        let stats = &mut self.stats;
        while let Ok((s, _)) = self.rtde.accept() {
            s.set_nonblocking(true)?;
            s.set_nodelay(true)?;
            stats.rtde_clients += 1;
            self.rtde_conns.push(RtdeConn {
                stream: s,
                framer: Framer::default(),
                outputs: Vec::new(),
                period_s: 1.0 / 125.0,
                next_s: 0.0,
                started: false,
                open: true,
            });
        }
        while let Ok((s, _)) = self.script.accept() {
            s.set_nonblocking(true)?;
            stats.script_clients += 1;
            self.script_conns.push(ScriptConn {
                stream: s,
                pending: Vec::new(),
                open: true,
            });
        }
        let rtde_conns = &mut self.rtde_conns;
        let script_conns = &mut self.script_conns;
        for c in rtde_conns.iter_mut() {
            loop {
                match c.stream.read(&mut buf) {
                    Ok(0) => {
                        c.open = false;
                        break;
                    }
                    Ok(n) => {
                        let Ok(packages) = c.framer.push(&buf[..n]) else {
                            c.open = false;
                            break;
                        };
                        for (code, p) in packages {
                            let Ok(m) = ClientMessage::decode(code, &p) else {
                                continue;
                            };
                            let ok = match m {
                                ClientMessage::RequestProtocolVersion(v) => write(
                                    &mut c.stream,
                                    &ServerMessage::ProtocolVersionAccepted(v == 2 || v == 1),
                                    None,
                                ),
                                ClientMessage::GetUrcontrolVersion => {
                                    let (major, minor, bugfix, build) = CONTROLLER_VERSION;
                                    let v = ServerMessage::UrcontrolVersion {
                                        major,
                                        minor,
                                        bugfix,
                                        build,
                                    };
                                    write(&mut c.stream, &v, None)
                                }
                                ClientMessage::SetupOutputs {
                                    frequency_hz,
                                    variables,
                                } => {
                                    c.period_s = 1.0 / frequency_hz.clamp(1.0, 500.0);
                                    let types = variables
                                        .iter()
                                        .map(|v| output_type(v).to_string())
                                        .collect();
                                    c.outputs = variables;
                                    let r = ServerMessage::Recipe { id: 1, types };
                                    write(&mut c.stream, &r, Some(b'O'))
                                }
                                ClientMessage::SetupInputs { variables } => {
                                    let types = variables
                                        .iter()
                                        .map(|v| input_type(v).to_string())
                                        .collect();
                                    let r = ServerMessage::Recipe { id: 2, types };
                                    write(&mut c.stream, &r, Some(b'I'))
                                }
                                ClientMessage::Start => {
                                    let ok =
                                        c.outputs.iter().all(|v| output_type(v) != "NOT_FOUND");
                                    c.started = ok;
                                    c.next_s = now;
                                    write(&mut c.stream, &ServerMessage::Started(ok), None)
                                }
                                ClientMessage::Pause => {
                                    c.started = false;
                                    write(&mut c.stream, &ServerMessage::Paused(true), None)
                                }
                                // input registers: accepted, nothing in the sim reads them
                                ClientMessage::Data { .. } => true,
                            };
                            c.open &= ok;
                        }
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                    Err(_) => {
                        c.open = false;
                        break;
                    }
                }
            }
            if c.open && c.started && now >= c.next_s {
                c.next_s += c.period_s;
                let pose = arm.tcp_pose().unwrap_or_default();
                let values: Vec<Value> = c
                    .outputs
                    .iter()
                    .map(|v| match v.as_str() {
                        "timestamp" => Value::Double(now),
                        "actual_TCP_pose" | "target_TCP_pose" => Value::Vector6d([
                            pose.position_mm[0] / 1000.0,
                            pose.position_mm[1] / 1000.0,
                            pose.position_mm[2] / 1000.0,
                            pose.rotation_rad[0],
                            pose.rotation_rad[1],
                            pose.rotation_rad[2],
                        ]),
                        "actual_TCP_speed" => Value::Vector6d([0.0; 6]),
                        // power on, program running
                        "robot_status_bits" => Value::Uint32(0b11),
                        "safety_status_bits" => Value::Uint32(1),
                        "runtime_state" => Value::Uint32(2),
                        // ROBOT_MODE_RUNNING, NORMAL
                        "robot_mode" => Value::Int32(7),
                        _ => Value::Int32(1),
                    })
                    .collect();
                let m = ServerMessage::Data {
                    recipe: 1,
                    payload: encode_values(&values),
                };
                c.open &= write(&mut c.stream, &m, None);
                stats.data_packages += 1;
            }
        }
        rtde_conns.retain(|c| c.open);

        for c in script_conns.iter_mut() {
            c.open &= read_available(&mut c.stream, &mut c.pending, MAX_SCRIPT_LINE);
            if c.pending.len() >= MAX_SCRIPT_LINE && !c.pending.contains(&b'\n') {
                // No command is this long: a controller stops the program and the client
                // is dropped, rather than the server buffering without end.
                stats.script_errors += 1;
                let _ = arm.stop();
                c.pending.clear();
                c.open = false;
                continue;
            }
            while let Some(end) = c.pending.iter().position(|b| *b == b'\n') {
                let line: Vec<u8> = c.pending.drain(..=end).collect();
                stats.script_lines += 1;
                let parsed = std::str::from_utf8(&line)
                    .ok()
                    .and_then(|l| parse_line(l).ok());
                let done = match parsed {
                    Some(Command::Movel {
                        pose, speed_m_s, ..
                    }) => {
                        let at = arm.tcp_pose().unwrap_or_default().position_mm;
                        let offset = [0, 1, 2].map(|i| pose[i] * 1000.0 - at[i]);
                        arm.move_linear(offset, speed_m_s * 1000.0).is_ok()
                    }
                    Some(Command::Speedl { velocity, .. }) => arm
                        .move_velocity([0, 1, 2].map(|i| velocity[i] * 1000.0))
                        .is_ok(),
                    Some(Command::Stopl { .. }) => arm.stop().is_ok(),
                    None => false,
                };
                if !done {
                    // A real controller stops the program on a script error.
                    stats.script_errors += 1;
                    let _ = arm.stop();
                }
            }
        }
        script_conns.retain(|c| c.open);
        Ok(())
    }
}

/// Longest URScript line the emulated controller takes; real commands are under 200 bytes.
pub(crate) const MAX_SCRIPT_LINE: usize = 64 * 1024;
