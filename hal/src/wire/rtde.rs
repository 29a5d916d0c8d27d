//! Universal Robots RTDE, protocol version 2 (the UR "Real-Time Data Exchange" guide), both
//! directions: written in-project because no maintained crate on crates.io speaks it.
//!
//! Every package is `size: u16 | type: u8 | payload`, big-endian, `size` counting the
//! header. The same type code means a request from the client and a reply from the
//! controller, so messages are split by direction ([`ClientMessage`], [`ServerMessage`]).
//! Data packages carry a recipe id and the recipe's values packed in order;
//! [`decode_values`] unpacks them with the types the controller announced.

use std::fmt;
use std::str::FromStr;

/// Package type codes.
pub mod code {
    pub const REQUEST_PROTOCOL_VERSION: u8 = b'V';
    pub const GET_URCONTROL_VERSION: u8 = b'v';
    pub const TEXT_MESSAGE: u8 = b'M';
    pub const DATA_PACKAGE: u8 = b'U';
    pub const SETUP_OUTPUTS: u8 = b'O';
    pub const SETUP_INPUTS: u8 = b'I';
    pub const START: u8 = b'S';
    pub const PAUSE: u8 = b'P';
}

pub const PROTOCOL_VERSION: u16 = 2;
const HEADER_LEN: usize = 3;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RtdeError {
    #[error("package size {0} is smaller than its header")]
    Size(u16),
    #[error("package {code:?}: payload too short ({len} bytes)")]
    Short { code: char, len: usize },
    #[error("package type {0:?} is not one of RTDE's")]
    UnknownType(char),
    #[error("variable type `{0}` is not an RTDE type")]
    UnknownVariableType(String),
    #[error("text is not UTF-8")]
    Text,
    #[error("data package of {len} bytes does not fit its recipe of {expected}")]
    DataLength { len: usize, expected: usize },
    #[error("payload too long for one package ({0} bytes)")]
    TooLong(usize),
}

/// RTDE's variable types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    Bool,
    Uint8,
    Uint32,
    Uint64,
    Int32,
    Double,
    Vector3d,
    Vector6d,
    Vector6Int32,
    Vector6Uint32,
}

impl VarType {
    pub const ALL: [VarType; 10] = [
        VarType::Bool,
        VarType::Uint8,
        VarType::Uint32,
        VarType::Uint64,
        VarType::Int32,
        VarType::Double,
        VarType::Vector3d,
        VarType::Vector6d,
        VarType::Vector6Int32,
        VarType::Vector6Uint32,
    ];

    /// Bytes on the wire.
    pub fn size(self) -> usize {
        match self {
            VarType::Bool | VarType::Uint8 => 1,
            VarType::Uint32 | VarType::Int32 => 4,
            VarType::Uint64 | VarType::Double => 8,
            VarType::Vector3d => 24,
            VarType::Vector6d => 48,
            VarType::Vector6Int32 | VarType::Vector6Uint32 => 24,
        }
    }

    fn name(self) -> &'static str {
        match self {
            VarType::Bool => "BOOL",
            VarType::Uint8 => "UINT8",
            VarType::Uint32 => "UINT32",
            VarType::Uint64 => "UINT64",
            VarType::Int32 => "INT32",
            VarType::Double => "DOUBLE",
            VarType::Vector3d => "VECTOR3D",
            VarType::Vector6d => "VECTOR6D",
            VarType::Vector6Int32 => "VECTOR6INT32",
            VarType::Vector6Uint32 => "VECTOR6UINT32",
        }
    }
}

impl fmt::Display for VarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for VarType {
    type Err = RtdeError;
    fn from_str(s: &str) -> Result<Self, RtdeError> {
        VarType::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| RtdeError::UnknownVariableType(s.to_string()))
    }
}

/// One value of a data package.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    Bool(bool),
    Uint8(u8),
    Uint32(u32),
    Uint64(u64),
    Int32(i32),
    Double(f64),
    Vector3d([f64; 3]),
    Vector6d([f64; 6]),
    Vector6Int32([i32; 6]),
    Vector6Uint32([u32; 6]),
}

impl Value {
    pub fn var_type(&self) -> VarType {
        match self {
            Value::Bool(_) => VarType::Bool,
            Value::Uint8(_) => VarType::Uint8,
            Value::Uint32(_) => VarType::Uint32,
            Value::Uint64(_) => VarType::Uint64,
            Value::Int32(_) => VarType::Int32,
            Value::Double(_) => VarType::Double,
            Value::Vector3d(_) => VarType::Vector3d,
            Value::Vector6d(_) => VarType::Vector6d,
            Value::Vector6Int32(_) => VarType::Vector6Int32,
            Value::Vector6Uint32(_) => VarType::Vector6Uint32,
        }
    }

    fn put(&self, out: &mut Vec<u8>) {
        match self {
            Value::Bool(b) => out.push(u8::from(*b)),
            Value::Uint8(v) => out.push(*v),
            Value::Uint32(v) => out.extend(v.to_be_bytes()),
            Value::Uint64(v) => out.extend(v.to_be_bytes()),
            Value::Int32(v) => out.extend(v.to_be_bytes()),
            Value::Double(v) => out.extend(v.to_be_bytes()),
            Value::Vector3d(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
            Value::Vector6d(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
            Value::Vector6Int32(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
            Value::Vector6Uint32(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
        }
    }
}

fn be<const N: usize>(b: &[u8]) -> [u8; N] {
    b[..N].try_into().expect("length checked by the caller")
}

/// Unpacks a data package's values (after its recipe id) by the recipe's types.
pub fn decode_values(payload: &[u8], types: &[VarType]) -> Result<Vec<Value>, RtdeError> {
    let expected: usize = types.iter().map(|t| t.size()).sum();
    if payload.len() != expected {
        return Err(RtdeError::DataLength {
            len: payload.len(),
            expected,
        });
    }
    let mut at = 0;
    let mut out = Vec::with_capacity(types.len());
    for t in types {
        let b = &payload[at..at + t.size()];
        let f = |k: usize| f64::from_be_bytes(be(&b[8 * k..]));
        let i = |k: usize| i32::from_be_bytes(be(&b[4 * k..]));
        let u = |k: usize| u32::from_be_bytes(be(&b[4 * k..]));
        out.push(match t {
            VarType::Bool => Value::Bool(b[0] != 0),
            VarType::Uint8 => Value::Uint8(b[0]),
            VarType::Uint32 => Value::Uint32(u(0)),
            VarType::Uint64 => Value::Uint64(u64::from_be_bytes(be(b))),
            VarType::Int32 => Value::Int32(i(0)),
            VarType::Double => Value::Double(f(0)),
            VarType::Vector3d => Value::Vector3d([f(0), f(1), f(2)]),
            VarType::Vector6d => Value::Vector6d(std::array::from_fn(f)),
            VarType::Vector6Int32 => Value::Vector6Int32(std::array::from_fn(i)),
            VarType::Vector6Uint32 => Value::Vector6Uint32(std::array::from_fn(u)),
        });
        at += t.size();
    }
    Ok(out)
}

/// What the client (tmo) sends.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientMessage {
    RequestProtocolVersion(u16),
    GetUrcontrolVersion,
    SetupOutputs {
        frequency_hz: f64,
        variables: Vec<String>,
    },
    SetupInputs {
        variables: Vec<String>,
    },
    Start,
    Pause,
    /// Input registers for a recipe from `SetupInputs` (packed; see [`ClientMessage::data`]
    /// and [`decode_values`]).
    Data {
        recipe: u8,
        payload: Vec<u8>,
    },
}

/// What the controller sends.
#[derive(Debug, Clone, PartialEq)]
pub enum ServerMessage {
    ProtocolVersionAccepted(bool),
    UrcontrolVersion {
        major: u32,
        minor: u32,
        bugfix: u32,
        build: u32,
    },
    /// Reply to a setup: the recipe id and each variable's type (`NOT_FOUND` or `IN_USE`
    /// come back as the type names they are).
    Recipe {
        id: u8,
        types: Vec<String>,
    },
    Started(bool),
    Paused(bool),
    Text {
        message: String,
        source: String,
        level: u8,
    },
    /// Output values; decode with [`decode_values`].
    Data {
        recipe: u8,
        payload: Vec<u8>,
    },
}

fn package(code: u8, payload: &[u8]) -> Result<Vec<u8>, RtdeError> {
    let size = payload.len() + HEADER_LEN;
    let size16 = u16::try_from(size).map_err(|_| RtdeError::TooLong(payload.len()))?;
    let mut out = Vec::with_capacity(size);
    out.extend(size16.to_be_bytes());
    out.push(code);
    out.extend_from_slice(payload);
    Ok(out)
}

fn short(code: u8, len: usize) -> RtdeError {
    RtdeError::Short {
        code: code as char,
        len,
    }
}

fn text(b: &[u8]) -> Result<String, RtdeError> {
    String::from_utf8(b.to_vec()).map_err(|_| RtdeError::Text)
}

/// Packs values in order, as data packages carry them.
pub fn encode_values(values: &[Value]) -> Vec<u8> {
    let mut out = Vec::new();
    values.iter().for_each(|v| v.put(&mut out));
    out
}

impl ClientMessage {
    /// A data package of input values.
    pub fn data(recipe: u8, values: &[Value]) -> Self {
        ClientMessage::Data {
            recipe,
            payload: encode_values(values),
        }
    }

    pub fn encode(&self) -> Result<Vec<u8>, RtdeError> {
        match self {
            ClientMessage::RequestProtocolVersion(v) => {
                package(code::REQUEST_PROTOCOL_VERSION, &v.to_be_bytes())
            }
            ClientMessage::GetUrcontrolVersion => package(code::GET_URCONTROL_VERSION, &[]),
            ClientMessage::SetupOutputs {
                frequency_hz,
                variables,
            } => {
                let mut p = frequency_hz.to_be_bytes().to_vec();
                p.extend(variables.join(",").as_bytes());
                package(code::SETUP_OUTPUTS, &p)
            }
            ClientMessage::SetupInputs { variables } => {
                package(code::SETUP_INPUTS, variables.join(",").as_bytes())
            }
            ClientMessage::Start => package(code::START, &[]),
            ClientMessage::Pause => package(code::PAUSE, &[]),
            ClientMessage::Data { recipe, payload } => {
                let mut p = vec![*recipe];
                p.extend(payload);
                package(code::DATA_PACKAGE, &p)
            }
        }
    }

    /// Decodes a package the controller received (for the emulated controller).
    pub fn decode(code: u8, p: &[u8]) -> Result<Self, RtdeError> {
        let names = |b: &[u8]| -> Result<Vec<String>, RtdeError> {
            // Empty names are skipped: ur_rtde ends its lists with a comma, and the
            // controller it is written against accepts that.
            Ok(text(b)?
                .split(',')
                .filter(|n| !n.is_empty())
                .map(str::to_string)
                .collect())
        };
        Ok(match code {
            code::REQUEST_PROTOCOL_VERSION => {
                if p.len() < 2 {
                    return Err(short(code, p.len()));
                }
                ClientMessage::RequestProtocolVersion(u16::from_be_bytes(be(p)))
            }
            code::GET_URCONTROL_VERSION => ClientMessage::GetUrcontrolVersion,
            code::SETUP_OUTPUTS => {
                if p.len() < 8 {
                    return Err(short(code, p.len()));
                }
                ClientMessage::SetupOutputs {
                    frequency_hz: f64::from_be_bytes(be(p)),
                    variables: names(&p[8..])?,
                }
            }
            code::SETUP_INPUTS => ClientMessage::SetupInputs {
                variables: names(p)?,
            },
            code::START => ClientMessage::Start,
            code::PAUSE => ClientMessage::Pause,
            code::DATA_PACKAGE => {
                let (&recipe, rest) = p.split_first().ok_or_else(|| short(code, 0))?;
                ClientMessage::Data {
                    recipe,
                    payload: rest.to_vec(),
                }
            }
            other => return Err(RtdeError::UnknownType(other as char)),
        })
    }
}

impl ServerMessage {
    pub fn encode(&self) -> Result<Vec<u8>, RtdeError> {
        match self {
            ServerMessage::ProtocolVersionAccepted(ok) => {
                package(code::REQUEST_PROTOCOL_VERSION, &[u8::from(*ok)])
            }
            ServerMessage::UrcontrolVersion {
                major,
                minor,
                bugfix,
                build,
            } => {
                let mut p = Vec::with_capacity(16);
                for v in [major, minor, bugfix, build] {
                    p.extend(v.to_be_bytes());
                }
                package(code::GET_URCONTROL_VERSION, &p)
            }
            // The reply's type code depends on the request (outputs or inputs); outputs'
            // by default, see `encode_recipe`.
            ServerMessage::Recipe { .. } => self.encode_recipe(code::SETUP_OUTPUTS),
            ServerMessage::Started(ok) => package(code::START, &[u8::from(*ok)]),
            ServerMessage::Paused(ok) => package(code::PAUSE, &[u8::from(*ok)]),
            ServerMessage::Text {
                message,
                source,
                level,
            } => {
                let (m, s) = (message.as_bytes(), source.as_bytes());
                if m.len() > 255 || s.len() > 255 {
                    return Err(RtdeError::TooLong(m.len().max(s.len())));
                }
                let mut p = vec![m.len() as u8];
                p.extend(m);
                p.push(s.len() as u8);
                p.extend(s);
                p.push(*level);
                package(code::TEXT_MESSAGE, &p)
            }
            ServerMessage::Data { recipe, payload } => {
                let mut p = vec![*recipe];
                p.extend(payload);
                package(code::DATA_PACKAGE, &p)
            }
        }
    }

    /// A recipe reply under `code` (`SETUP_OUTPUTS` or `SETUP_INPUTS`).
    pub fn encode_recipe(&self, code: u8) -> Result<Vec<u8>, RtdeError> {
        let ServerMessage::Recipe { id, types } = self else {
            return self.encode();
        };
        let mut p = vec![*id];
        p.extend(types.join(",").as_bytes());
        package(code, &p)
    }

    pub fn decode(code: u8, p: &[u8]) -> Result<Self, RtdeError> {
        let flag = |p: &[u8]| p.first().map(|b| *b != 0).ok_or_else(|| short(code, 0));
        Ok(match code {
            code::REQUEST_PROTOCOL_VERSION => ServerMessage::ProtocolVersionAccepted(flag(p)?),
            code::GET_URCONTROL_VERSION => {
                if p.len() < 16 {
                    return Err(short(code, p.len()));
                }
                let u = |k: usize| u32::from_be_bytes(be(&p[4 * k..]));
                ServerMessage::UrcontrolVersion {
                    major: u(0),
                    minor: u(1),
                    bugfix: u(2),
                    build: u(3),
                }
            }
            code::SETUP_OUTPUTS | code::SETUP_INPUTS => {
                let (&id, rest) = p.split_first().ok_or_else(|| short(code, 0))?;
                let t = text(rest)?;
                ServerMessage::Recipe {
                    id,
                    types: t.split(',').map(str::to_string).collect(),
                }
            }
            code::START => ServerMessage::Started(flag(p)?),
            code::PAUSE => ServerMessage::Paused(flag(p)?),
            code::TEXT_MESSAGE => {
                let field = |at: usize| -> Result<(&[u8], usize), RtdeError> {
                    let n = usize::from(*p.get(at).ok_or_else(|| short(code, p.len()))?);
                    let b = p
                        .get(at + 1..at + 1 + n)
                        .ok_or_else(|| short(code, p.len()))?;
                    Ok((b, at + 1 + n))
                };
                let (m, at) = field(0)?;
                let (s, at) = field(at)?;
                ServerMessage::Text {
                    message: text(m)?,
                    source: text(s)?,
                    level: *p.get(at).ok_or_else(|| short(code, p.len()))?,
                }
            }
            code::DATA_PACKAGE => {
                let (&recipe, rest) = p.split_first().ok_or_else(|| short(code, 0))?;
                ServerMessage::Data {
                    recipe,
                    payload: rest.to_vec(),
                }
            }
            other => return Err(RtdeError::UnknownType(other as char)),
        })
    }
}

/// Splits a TCP byte stream into `(type, payload)` packages.
#[derive(Debug, Default, Clone)]
pub struct Framer {
    buf: Vec<u8>,
}

impl Framer {
    /// Takes bytes; returns the packages they completed. A size below the header is a
    /// broken stream: the error says so and the connection should be dropped.
    pub fn push(&mut self, bytes: &[u8]) -> Result<Vec<(u8, Vec<u8>)>, RtdeError> {
        self.buf.extend_from_slice(bytes);
        let mut out = Vec::new();
        loop {
            if self.buf.len() < HEADER_LEN {
                return Ok(out);
            }
            let size = u16::from_be_bytes([self.buf[0], self.buf[1]]);
            if usize::from(size) < HEADER_LEN {
                self.buf.clear();
                return Err(RtdeError::Size(size));
            }
            if self.buf.len() < usize::from(size) {
                return Ok(out);
            }
            let code = self.buf[2];
            out.push((code, self.buf[HEADER_LEN..usize::from(size)].to_vec()));
            self.buf.drain(..usize::from(size));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_session_round_trips() {
        let client = [
            ClientMessage::RequestProtocolVersion(PROTOCOL_VERSION),
            ClientMessage::GetUrcontrolVersion,
            ClientMessage::SetupOutputs {
                frequency_hz: 125.0,
                variables: vec!["timestamp".into(), "actual_TCP_pose".into()],
            },
            ClientMessage::Start,
        ];
        let mut f = Framer::default();
        let bytes: Vec<u8> = client.iter().flat_map(|m| m.encode().unwrap()).collect();
        let got: Vec<ClientMessage> = f
            .push(&bytes)
            .unwrap()
            .into_iter()
            .map(|(c, p)| ClientMessage::decode(c, &p).unwrap())
            .collect();
        assert_eq!(got, client);

        // the version request is 5 bytes: size 5, 'V', version 2
        assert_eq!(client[0].encode().unwrap(), [0, 5, b'V', 0, 2]);

        let values = [
            Value::Double(12.5),
            Value::Vector6d([0.4, 0.0, 0.3, 0.0, 3.0, 0.0]),
        ];
        let payload = encode_values(&values);
        let server = ServerMessage::Data { recipe: 1, payload };
        let bytes = server.encode().unwrap();
        let (c, p) = f.push(&bytes).unwrap().remove(0);
        let ServerMessage::Data { recipe, payload } = ServerMessage::decode(c, &p).unwrap() else {
            panic!()
        };
        assert_eq!(recipe, 1);
        let types = [VarType::Double, VarType::Vector6d];
        assert_eq!(decode_values(&payload, &types).unwrap(), values);
    }

    #[test]
    fn a_recipe_list_ending_in_a_comma_names_no_empty_variable() {
        // what ur_rtde sends (seen on the wire against `tmo sim serve`)
        let mut p = 125.0f64.to_be_bytes().to_vec();
        p.extend(b"timestamp,actual_TCP_pose,");
        assert_eq!(
            ClientMessage::decode(code::SETUP_OUTPUTS, &p).unwrap(),
            ClientMessage::SetupOutputs {
                frequency_hz: 125.0,
                variables: vec!["timestamp".into(), "actual_TCP_pose".into()],
            }
        );
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let mut f = Framer::default();
        assert_eq!(f.push(&[0, 1, b'V']), Err(RtdeError::Size(1)));
        assert!(ServerMessage::decode(code::GET_URCONTROL_VERSION, &[0; 3]).is_err());
        assert!(ServerMessage::decode(b'?', &[]).is_err());
        assert!(decode_values(&[0; 7], &[VarType::Double]).is_err());
        assert_eq!("VECTOR6D".parse::<VarType>(), Ok(VarType::Vector6d));
        assert!("NOT_FOUND".parse::<VarType>().is_err());
    }
}
