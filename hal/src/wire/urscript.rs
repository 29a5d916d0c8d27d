//! The URScript lines the arm backend sends on the controller's secondary interface (TCP
//! 30002), and a parser for them (the emulated controller's side). Units are URScript's:
//! metres, radians, seconds.

/// One motion command.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// `movel(p[x, y, z, rx, ry, rz], a=..., v=...)`: a straight line to a tool pose.
    Movel {
        pose: [f64; 6],
        accel_m_s2: f64,
        speed_m_s: f64,
    },
    /// `speedl([vx, vy, vz, wx, wy, wz], a=..., t=...)`: tool speed for `t` seconds.
    Speedl {
        velocity: [f64; 6],
        accel_m_s2: f64,
        time_s: f64,
    },
    /// `stopl(a)`: decelerate to a stop.
    Stopl { accel_m_s2: f64 },
}

fn list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.6}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Command {
    /// The line as sent, newline-terminated.
    pub fn to_line(&self) -> String {
        match self {
            Command::Movel {
                pose,
                accel_m_s2,
                speed_m_s,
            } => format!(
                "movel(p[{}], a={accel_m_s2:.4}, v={speed_m_s:.6})\n",
                list(pose)
            ),
            Command::Speedl {
                velocity,
                accel_m_s2,
                time_s,
            } => format!(
                "speedl([{}], a={accel_m_s2:.4}, t={time_s:.3})\n",
                list(velocity)
            ),
            Command::Stopl { accel_m_s2 } => format!("stopl({accel_m_s2:.4})\n"),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScriptError {
    #[error("not a call: `{0}`")]
    NotACall(String),
    #[error("`{0}` is not a motion this controller emulates (movel, speedl, stopl)")]
    Unknown(String),
    #[error("{0}: expected a list of 6 numbers")]
    Vector(&'static str),
    #[error("{function}: argument `{argument}` is not a finite number")]
    Number {
        function: &'static str,
        argument: String,
    },
}

fn numbers(inner: &str, function: &'static str) -> Result<[f64; 6], ScriptError> {
    let v: Vec<f64> = inner
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| ScriptError::Vector(function))?;
    if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
        return Err(ScriptError::Vector(function));
    }
    Ok([v[0], v[1], v[2], v[3], v[4], v[5]])
}

/// Named (`a=1.2`) or positional arguments after the vector, by name with a default.
fn argument(
    rest: &[&str],
    name: &str,
    position: usize,
    default: f64,
    function: &'static str,
) -> Result<f64, ScriptError> {
    let bad = |a: &str| ScriptError::Number {
        function,
        argument: a.to_string(),
    };
    let named = rest
        .iter()
        .find_map(|a| a.split_once('=').filter(|(k, _)| k.trim() == name));
    let text = match named {
        Some((_, v)) => v.trim(),
        None => match rest.get(position) {
            Some(a) if !a.contains('=') => a.trim(),
            _ => return Ok(default),
        },
    };
    let v: f64 = text.parse().map_err(|_| bad(text))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(bad(text))
    }
}

/// Parses one line of URScript (a single motion call).
pub fn parse_line(line: &str) -> Result<Command, ScriptError> {
    let line = line.trim();
    let open = line
        .find('(')
        .ok_or_else(|| ScriptError::NotACall(line.into()))?;
    if !line.ends_with(')') {
        return Err(ScriptError::NotACall(line.into()));
    }
    let name = line[..open].trim();
    let args = &line[open + 1..line.len() - 1];
    let split_vector = |function: &'static str| -> Result<([f64; 6], Vec<&str>), ScriptError> {
        let start = args.find('[').ok_or(ScriptError::Vector(function))?;
        let end = args.find(']').ok_or(ScriptError::Vector(function))?;
        if end < start {
            return Err(ScriptError::Vector(function));
        }
        let v = numbers(&args[start + 1..end], function)?;
        let rest: Vec<&str> = args[end + 1..]
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        Ok((v, rest))
    };
    match name {
        "movel" => {
            let (pose, rest) = split_vector("movel")?;
            Ok(Command::Movel {
                pose,
                accel_m_s2: argument(&rest, "a", 0, 1.2, "movel")?,
                speed_m_s: argument(&rest, "v", 1, 0.25, "movel")?,
            })
        }
        "speedl" => {
            let (velocity, rest) = split_vector("speedl")?;
            Ok(Command::Speedl {
                velocity,
                accel_m_s2: argument(&rest, "a", 0, 1.2, "speedl")?,
                time_s: argument(&rest, "t", 1, 0.0, "speedl")?,
            })
        }
        "stopl" => {
            let rest: Vec<&str> = args
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .collect();
            Ok(Command::Stopl {
                accel_m_s2: argument(&rest, "a", 0, 1.2, "stopl")?,
            })
        }
        other => Err(ScriptError::Unknown(other.chars().take(40).collect())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_round_trip_and_accept_urscript_spellings() {
        let c = Command::Movel {
            pose: [0.4, -0.1, 0.3, 0.0, 3.0, 0.25],
            accel_m_s2: 1.2,
            speed_m_s: 0.017,
        };
        assert_eq!(parse_line(&c.to_line()).unwrap(), c);
        assert_eq!(
            parse_line("speedl([0,0,0.01,0,0,0], 0.5, 2)").unwrap(),
            Command::Speedl {
                velocity: [0.0, 0.0, 0.01, 0.0, 0.0, 0.0],
                accel_m_s2: 0.5,
                time_s: 2.0
            }
        );
        assert_eq!(
            parse_line("stopl(a=3)").unwrap(),
            Command::Stopl { accel_m_s2: 3.0 }
        );
        assert!(matches!(
            parse_line("movej([1,2,3,4,5,6])"),
            Err(ScriptError::Unknown(_))
        ));
        assert!(matches!(
            parse_line("movel(p[1,2,3])"),
            Err(ScriptError::Vector(_))
        ));
        assert!(matches!(
            parse_line("movel(p[1,2,3,4,5,6], v=fast)"),
            Err(ScriptError::Number { .. })
        ));
        assert!(matches!(parse_line("popup"), Err(ScriptError::NotACall(_))));
    }
}
