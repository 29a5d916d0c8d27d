//! The OpenHand Model O on a Dynamixel Protocol 2.0 bus as the rig's [`Hand`], through the
//! `dynamixel2` crate. Positions are normalised per servo: 0 at `min` (open), 1 at `max`
//! (closed), so a servo mounted the other way round simply has `max < min`.

use crate::wire::dynamixel::address;
use crate::{ErrorKind, ErrorType, Hand, HandPositions, HAND_ACTUATORS};

/// Current units of the X series, mA per count.
pub const MA_PER_CURRENT_UNIT: f64 = 2.69;

#[derive(Debug, Clone, PartialEq)]
pub struct ModelOConfig {
    pub port: String,
    pub baud: u32,
    /// Fingers (thumb first), then the thumb's rotation.
    pub ids: [u8; HAND_ACTUATORS],
    pub min: [u32; HAND_ACTUATORS],
    pub max: [u32; HAND_ACTUATORS],
    pub current_limit_ma: u32,
}

impl ModelOConfig {
    /// Encoder counts for normalised position `q` of servo `i` (clamped to 0..1).
    pub fn counts(&self, i: usize, q: f64) -> u32 {
        let (lo, hi) = (f64::from(self.min[i]), f64::from(self.max[i]));
        (lo + q.clamp(0.0, 1.0) * (hi - lo)).round() as u32
    }

    /// Normalised position of servo `i` at `counts`, within 0..=1: a servo resting a count
    /// or two past its calibrated open or closed end reads as that end, since the runner
    /// holds and ramps from readings and a target outside the range is refused.
    pub fn position(&self, i: usize, counts: u32) -> f64 {
        let (lo, hi) = (f64::from(self.min[i]), f64::from(self.max[i]));
        ((f64::from(counts) - lo) / (hi - lo)).clamp(0.0, 1.0)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum HandError {
    #[error("hand bus {port}: {message}")]
    Bus { port: String, message: String },
    #[error("hand bus {port}: servo {id} did not answer: {message}")]
    NoAnswer {
        port: String,
        id: u8,
        message: String,
    },
}

impl crate::Error for HandError {
    fn kind(&self) -> ErrorKind {
        match self {
            HandError::Bus { .. } => ErrorKind::Disconnected,
            HandError::NoAnswer { .. } => ErrorKind::Timeout,
        }
    }
}

pub struct ModelOHand {
    bus: dynamixel2::Bus<Vec<u8>, Vec<u8>>,
    cfg: ModelOConfig,
}

impl ModelOHand {
    /// Opens the bus, pings every servo, writes the current limit and enables torque.
    pub fn open(cfg: ModelOConfig) -> Result<Self, HandError> {
        let bus = dynamixel2::Bus::open(&cfg.port, cfg.baud).map_err(|e| HandError::Bus {
            port: cfg.port.clone(),
            message: e.to_string(),
        })?;
        let mut hand = Self { bus, cfg };
        let units = (f64::from(hand.cfg.current_limit_ma) / MA_PER_CURRENT_UNIT).round() as u16;
        for &id in &hand.cfg.ids.clone() {
            let port = hand.cfg.port.clone();
            let no_answer = |e: dynamixel2::TransferError| HandError::NoAnswer {
                port: port.clone(),
                id,
                message: e.to_string(),
            };
            // A servo can miss the first ping after power-up (or a busy host can miss its
            // reply window): three tries before giving up.
            let mut ping = hand.bus.ping(id);
            for _ in 0..2 {
                if ping.is_ok() {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(20));
                ping = hand.bus.ping(id);
            }
            ping.map_err(no_answer)?;
            hand.bus
                .write_u16(id, address::CURRENT_LIMIT, units)
                .map_err(no_answer)?;
            hand.bus
                .write_u8(id, address::TORQUE_ENABLE, 1)
                .map_err(no_answer)?;
        }
        Ok(hand)
    }

    fn bus_error(&self, e: impl std::fmt::Display) -> HandError {
        HandError::Bus {
            port: self.cfg.port.clone(),
            message: e.to_string(),
        }
    }
}

impl ErrorType for ModelOHand {
    type Error = HandError;
}

impl Hand for ModelOHand {
    fn set_targets(&mut self, targets: HandPositions) -> Result<(), HandError> {
        let data: Vec<dynamixel2::instructions::SyncWriteData<u32>> = (0..HAND_ACTUATORS)
            .map(|i| dynamixel2::instructions::SyncWriteData {
                motor_id: self.cfg.ids[i],
                data: self.cfg.counts(i, targets[i]),
            })
            .collect();
        self.bus
            .sync_write_u32(address::GOAL_POSITION, &data)
            .map_err(|e| self.bus_error(e))
    }

    fn set_torque_limit(&mut self, fraction: f64) -> Result<(), HandError> {
        let units = (fraction.clamp(0.0, 1.0) * f64::from(self.cfg.current_limit_ma)
            / MA_PER_CURRENT_UNIT)
            .round() as u16;
        let data: Vec<dynamixel2::instructions::SyncWriteData<u16>> = self
            .cfg
            .ids
            .iter()
            .map(|&motor_id| dynamixel2::instructions::SyncWriteData {
                motor_id,
                data: units,
            })
            .collect();
        self.bus
            .sync_write_u16(address::GOAL_CURRENT, &data)
            .map_err(|e| self.bus_error(e))
    }

    fn present_positions(&mut self) -> Result<HandPositions, HandError> {
        let ids = self.cfg.ids;
        let replies = self
            .bus
            .sync_read_u32(&ids, address::PRESENT_POSITION)
            .map_err(|e| self.bus_error(e))?;
        let mut out = [0.0; HAND_ACTUATORS];
        for r in replies {
            let i = ids.iter().position(|&id| id == r.motor_id).ok_or_else(|| {
                self.bus_error(format!("reply from unknown servo {}", r.motor_id))
            })?;
            out[i] = self.cfg.position(i, r.data);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_normalise_through_min_and_max_either_way_round() {
        let cfg = ModelOConfig {
            port: String::new(),
            baud: 57600,
            ids: [1, 2, 3, 4],
            min: [1000, 1000, 3000, 0],
            max: [3000, 3000, 1000, 4095],
            current_limit_ma: 300,
        };
        assert_eq!(cfg.counts(0, 0.25), 1500);
        assert_eq!(cfg.counts(2, 0.25), 2500, "a reversed servo counts down");
        assert_eq!(cfg.counts(0, 2.0), 3000, "clamped");
        assert!((cfg.position(2, 2500) - 0.25).abs() < 1e-12);
        // a count or two past an end reads as that end, either way round
        assert_eq!(cfg.position(0, 998), 0.0);
        assert_eq!(cfg.position(0, 3002), 1.0);
        assert_eq!(cfg.position(2, 3001), 0.0);
        assert_eq!(cfg.position(2, 999), 1.0);
    }
}
