//! JeVois serial messages (the camera's "standardized serial messages"), as the real rig's
//! cameras send them, one per line (CRLF):
//!
//! - fingertip cameras, "Fine" 2D: `F2 <id> <n> x1 y1 ... xn yn [extra]` — the pin centres;
//! - the marker camera (DemoArUco, 3D, mm): `N3 <id> x y z w h d` or
//!   `D3 <id> x y z w h d q1 q2 q3 q4 [extra]`;
//! - either may carry a `serstamp` prefix (frame number and/or time) before the message
//!   type: any tokens before the first message-type token are kept as the stamp.
//!
//! [`LineReader`] turns arbitrary byte chunks from a serial port into messages: partial
//! lines wait for their end, and garbage (non-UTF-8, unknown types, wrong counts,
//! non-numbers, over-long lines) is counted by reason and dropped, never a panic.

use std::collections::BTreeMap;

/// One decoded message.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// `F2`: a contour or point set in 2D (standardized coordinates or pixels, as the
    /// module sends them).
    Fine2 {
        id: String,
        points: Vec<[f32; 2]>,
        extra: Option<String>,
    },
    /// `N3`: an object's centre and size in 3D, mm.
    Named3 {
        id: String,
        position_mm: [f64; 3],
        size_mm: [f64; 3],
    },
    /// `D3`: as `N3` plus the orientation quaternion.
    Detail3 {
        id: String,
        position_mm: [f64; 3],
        size_mm: [f64; 3],
        quaternion: [f64; 4],
        extra: Option<String>,
    },
}

/// A message and the `serstamp` prefix it came with.
#[derive(Debug, Clone, PartialEq)]
pub struct Stamped {
    pub stamp: Option<String>,
    pub message: Message,
}

/// Why a line was dropped.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, thiserror::Error)]
pub enum LineError {
    #[error("empty line")]
    Empty,
    #[error("no message type (expected F2, N3 or D3)")]
    NoType,
    #[error("message type {0} is not one tmo reads")]
    OtherType(String),
    #[error("missing {0}")]
    Missing(&'static str),
    #[error("{field}: `{token}` is not a number")]
    NotANumber { field: &'static str, token: String },
    #[error("F2 declares {declared} points but carries {found} coordinates")]
    CountMismatch { declared: usize, found: usize },
    #[error("line longer than {0} bytes")]
    TooLong(usize),
    #[error("not UTF-8")]
    NotUtf8,
}

impl LineError {
    /// Short name for the drop counters.
    pub fn reason(&self) -> &'static str {
        match self {
            LineError::Empty => "empty",
            LineError::NoType => "no_type",
            LineError::OtherType(_) => "other_type",
            LineError::Missing(_) => "missing_field",
            LineError::NotANumber { .. } => "not_a_number",
            LineError::CountMismatch { .. } => "count_mismatch",
            LineError::TooLong(_) => "too_long",
            LineError::NotUtf8 => "not_utf8",
        }
    }
}

const TYPES: [&str; 11] = [
    "T1", "N1", "D1", "T2", "N2", "D2", "F2", "T3", "N3", "D3", "F3",
];

fn number<T: std::str::FromStr>(field: &'static str, token: Option<&str>) -> Result<T, LineError> {
    let token = token.ok_or(LineError::Missing(field))?;
    let v = token.parse::<T>().map_err(|_| LineError::NotANumber {
        field,
        token: token.chars().take(32).collect(),
    })?;
    Ok(v)
}

fn finite(field: &'static str, token: Option<&str>) -> Result<f64, LineError> {
    let v: f64 = number(field, token)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(LineError::NotANumber {
            field,
            token: token.unwrap_or_default().into(),
        })
    }
}

fn rest(tokens: &mut std::str::SplitAsciiWhitespace<'_>) -> Option<String> {
    let v: Vec<&str> = tokens.collect();
    (!v.is_empty()).then(|| v.join(" "))
}

/// Parses one line (without its line ending).
pub fn parse_line(line: &str) -> Result<Stamped, LineError> {
    let line = line.trim_matches(|c: char| c.is_ascii_whitespace());
    if line.is_empty() {
        return Err(LineError::Empty);
    }
    let all: Vec<&str> = line.split_ascii_whitespace().collect();
    let at = all
        .iter()
        .position(|t| TYPES.contains(t))
        .ok_or(LineError::NoType)?;
    let stamp = (at > 0).then(|| all[..at].join(" "));
    let kind = all[at];
    let body = all[at + 1..].join(" ");
    let mut t = body.split_ascii_whitespace();
    let message = match kind {
        "F2" => {
            let id = t.next().ok_or(LineError::Missing("id"))?.to_string();
            let n: usize = number("n", t.next())?;
            let values: Vec<&str> = t.collect();
            // Extra text after the coordinates is allowed; it must not be a number, or the
            // count would be ambiguous.
            let numeric = values
                .iter()
                .take_while(|v| v.parse::<f64>().is_ok())
                .count();
            if numeric != 2 * n {
                return Err(LineError::CountMismatch {
                    declared: n,
                    found: numeric,
                });
            }
            let mut points = Vec::with_capacity(n);
            for pair in values[..numeric].chunks_exact(2) {
                let x = finite("x", Some(pair[0]))?;
                let y = finite("y", Some(pair[1]))?;
                points.push([x as f32, y as f32]);
            }
            let extra = (values.len() > numeric).then(|| values[numeric..].join(" "));
            Message::Fine2 { id, points, extra }
        }
        "N3" | "D3" => {
            let id = t.next().ok_or(LineError::Missing("id"))?.to_string();
            let mut v = [0.0; 6];
            for (k, name) in ["x", "y", "z", "w", "h", "d"].iter().enumerate() {
                v[k] = finite(name, t.next())?;
            }
            let (position_mm, size_mm) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
            if kind == "N3" {
                Message::Named3 {
                    id,
                    position_mm,
                    size_mm,
                }
            } else {
                let mut q = [0.0; 4];
                for (k, name) in ["q1", "q2", "q3", "q4"].iter().enumerate() {
                    q[k] = finite(name, t.next())?;
                }
                Message::Detail3 {
                    id,
                    position_mm,
                    size_mm,
                    quaternion: q,
                    extra: rest(&mut t),
                }
            }
        }
        other => return Err(LineError::OtherType(other.to_string())),
    };
    Ok(Stamped { stamp, message })
}

/// Formats a fingertip frame as the camera sends it (for the emulated cameras and tests).
pub fn format_fine2(stamp: Option<&str>, id: &str, points: &[[f32; 2]]) -> String {
    let mut s = String::with_capacity(16 + points.len() * 16);
    if let Some(st) = stamp {
        s.push_str(st);
        s.push(' ');
    }
    s.push_str(&format!("F2 {id} {}", points.len()));
    for p in points {
        s.push_str(&format!(" {:.3} {:.3}", p[0], p[1]));
    }
    s.push_str("\r\n");
    s
}

/// Formats a marker pose as DemoArUco's `D3` (for the emulated camera and tests).
pub fn format_detail3(id: &str, position_mm: [f64; 3], size_mm: [f64; 3], q: [f64; 4]) -> String {
    format!(
        "D3 {id} {:.2} {:.2} {:.2} {:.1} {:.1} {:.1} {:.5} {:.5} {:.5} {:.5}\r\n",
        position_mm[0],
        position_mm[1],
        position_mm[2],
        size_mm[0],
        size_mm[1],
        size_mm[2],
        q[0],
        q[1],
        q[2],
        q[3]
    )
}

/// What a [`LineReader`] has seen.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct ReaderStats {
    pub lines: u64,
    pub messages: u64,
    /// Dropped lines by reason ([`LineError::reason`]).
    pub dropped: BTreeMap<&'static str, u64>,
}

impl ReaderStats {
    pub fn dropped_total(&self) -> u64 {
        self.dropped.values().sum()
    }
}

/// Splits a byte stream into lines and parses them.
#[derive(Debug, Clone)]
pub struct LineReader {
    pending: Vec<u8>,
    /// Bytes of an over-long line are skipped up to its end.
    skipping: bool,
    max_line: usize,
    stats: ReaderStats,
}

/// Longest line kept: a 30-pin F2 line is about 400 bytes; a DemoArUco D3 under 200.
pub const MAX_LINE: usize = 4096;

impl Default for LineReader {
    fn default() -> Self {
        Self::new(MAX_LINE)
    }
}

impl LineReader {
    pub fn new(max_line: usize) -> Self {
        Self {
            pending: Vec::new(),
            skipping: false,
            max_line,
            stats: ReaderStats::default(),
        }
    }

    pub fn stats(&self) -> &ReaderStats {
        &self.stats
    }

    fn drop_line(&mut self, e: &LineError) {
        *self.stats.dropped.entry(e.reason()).or_default() += 1;
    }

    /// Takes the next chunk of bytes; returns the messages of the lines it completed.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Stamped> {
        let mut out = Vec::new();
        for &b in bytes {
            if b == b'\n' {
                self.stats.lines += 1;
                if self.skipping {
                    self.skipping = false;
                    self.drop_line(&LineError::TooLong(self.max_line));
                } else {
                    let line = std::mem::take(&mut self.pending);
                    let parsed = std::str::from_utf8(&line)
                        .map_err(|_| LineError::NotUtf8)
                        .and_then(parse_line);
                    match parsed {
                        Ok(m) => {
                            self.stats.messages += 1;
                            out.push(m);
                        }
                        // blank lines between messages are not errors worth counting
                        Err(LineError::Empty) => {}
                        Err(e) => self.drop_line(&e),
                    }
                }
            } else if !self.skipping {
                if self.pending.len() >= self.max_line {
                    self.pending.clear();
                    self.skipping = true;
                } else {
                    self.pending.push(b);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fine_2d_lines_with_and_without_stamps() {
        let m = parse_line("F2 pins 2 10.5 20 -3 4.25").unwrap();
        assert_eq!(m.stamp, None);
        assert_eq!(
            m.message,
            Message::Fine2 {
                id: "pins".into(),
                points: vec![[10.5, 20.0], [-3.0, 4.25]],
                extra: None
            }
        );
        let m = parse_line("1234 12:00:01.250 F2 0 1 1 2 tracked").unwrap();
        assert_eq!(m.stamp.as_deref(), Some("1234 12:00:01.250"));
        let Message::Fine2 { extra, .. } = m.message else {
            panic!()
        };
        assert_eq!(extra.as_deref(), Some("tracked"));
    }

    #[test]
    fn marker_poses() {
        let m = parse_line("D3 U42 10 -20 350.5 40 40 1 0.6 0 0.8 0").unwrap();
        let Message::Detail3 {
            id,
            position_mm,
            quaternion,
            ..
        } = m.message
        else {
            panic!()
        };
        assert_eq!(id, "U42");
        assert_eq!(position_mm, [10.0, -20.0, 350.5]);
        assert_eq!(quaternion, [0.6, 0.0, 0.8, 0.0]);
        assert!(matches!(
            parse_line("N3 U1 1 2 3 4 5 6").unwrap().message,
            Message::Named3 { .. }
        ));
    }

    #[test]
    fn bad_lines_say_why() {
        assert_eq!(parse_line("  \r"), Err(LineError::Empty));
        assert_eq!(parse_line("hello world"), Err(LineError::NoType));
        assert_eq!(parse_line("T2 3 4"), Err(LineError::OtherType("T2".into())));
        assert_eq!(
            parse_line("F2 p 3 1 2 3 4"),
            Err(LineError::CountMismatch {
                declared: 3,
                found: 4
            })
        );
        assert!(matches!(
            parse_line("F2 p x 1 2"),
            Err(LineError::NotANumber { field: "n", .. })
        ));
        assert!(matches!(
            parse_line("D3 U1 1 2 3 4 5 6 0 0 nan 1"),
            Err(LineError::NotANumber { field: "q3", .. })
        ));
        assert_eq!(parse_line("N3 U1 1 2"), Err(LineError::Missing("z")));
    }

    #[test]
    fn the_reader_joins_partial_lines_and_counts_garbage() {
        let mut r = LineReader::new(64);
        let line = format_fine2(None, "pins", &[[1.0, 2.0], [3.0, 4.0]]);
        let (a, b) = line.as_bytes().split_at(7);
        assert!(r.push(a).is_empty());
        assert_eq!(r.push(b).len(), 1);
        let junk = [
            b"F2 p 9 1 2\r\n".as_slice(),
            &[0xff, 0xfe, b'\n'],
            &[b'x'; 100],
            b"\n",
            b"\r\n",
        ];
        for j in junk {
            assert!(r.push(j).is_empty());
        }
        assert_eq!(r.push(line.as_bytes()).len(), 1, "recovers after garbage");
        let s = r.stats();
        assert_eq!(s.messages, 2);
        assert_eq!(s.dropped["count_mismatch"], 1);
        assert_eq!(s.dropped["not_utf8"], 1);
        assert_eq!(s.dropped["too_long"], 1);
        assert_eq!(s.dropped_total(), 3);
    }
}
