//! The simulated hand served as a Dynamixel Protocol 2.0 bus of X-series servos on a
//! pseudo-terminal: ping, read, write, sync read and sync write on the control-table
//! addresses the Model O uses; goal positions drive the simulated fingers, present
//! positions come from them.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::path::PathBuf;

use crate::SimHand;
use tmo_hal::real::model_o::{ModelOConfig, MA_PER_CURRENT_UNIT};
use tmo_hal::wire::dynamixel::{address, instruction, Decoder, Packet, BROADCAST_ID};
use tmo_hal::{Hand, HAND_ACTUATORS};

/// XM430-W350's model number, as a ping reports it.
pub const MODEL_NUMBER: u16 = 1020;
const FIRMWARE: u8 = 52;
/// Status error: the instruction or address is not supported.
const ERROR_INSTRUCTION: u8 = 0x02;

#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct BusStats {
    pub packets: u64,
    pub replies: u64,
    pub goal_writes: u64,
    pub unsupported: u64,
}

pub struct PtyServoBus {
    master: File,
    _slave: OwnedFd,
    pub path: PathBuf,
    hand: SimHand,
    cfg: ModelOConfig,
    decoder: Decoder,
    /// Other control-table bytes written (torque enable, limits), per servo and address.
    table: BTreeMap<(u8, u16), Vec<u8>>,
    targets: [f64; HAND_ACTUATORS],
    pub stats: BusStats,
}

impl PtyServoBus {
    pub fn open(mut hand: SimHand, cfg: ModelOConfig) -> std::io::Result<Self> {
        let (master, slave, path) = super::pty::open_pty()?;
        let targets = hand.present_positions().unwrap_or_default();
        Ok(Self {
            master,
            _slave: slave,
            path,
            hand,
            cfg,
            decoder: Decoder::default(),
            table: BTreeMap::new(),
            targets,
            stats: BusStats::default(),
        })
    }

    /// Serves another world's hand (after a reset) on the same bus: the servos keep the
    /// settings written to them (torque enable, current limits); the goals are where the
    /// new hand stands.
    pub fn rebind(&mut self, mut hand: SimHand) {
        self.targets = hand.present_positions().unwrap_or_default();
        if let Some(f) = self.torque_limit() {
            let _ = hand.set_torque_limit(f);
        }
        self.hand = hand;
    }

    /// The torque limit the servos' goal currents set, as a fraction of the current limit.
    fn torque_limit(&self) -> Option<f64> {
        let units = self
            .cfg
            .ids
            .iter()
            .filter_map(|&id| self.table.get(&(id, address::GOAL_CURRENT)))
            .filter_map(|b| b.get(..2).map(|b| u16::from_le_bytes([b[0], b[1]])))
            .max()?;
        let ma = f64::from(units) * MA_PER_CURRENT_UNIT;
        Some((ma / f64::from(self.cfg.current_limit_ma.max(1))).clamp(0.0, 1.0))
    }

    fn servo(&self, id: u8) -> Option<usize> {
        self.cfg.ids.iter().position(|&s| s == id)
    }

    fn read_value(&mut self, i: usize, addr: u16, len: usize) -> Vec<u8> {
        let id = self.cfg.ids[i];
        let mut v = match addr {
            address::PRESENT_POSITION => {
                let q = self.hand.present_positions().unwrap_or_default()[i];
                self.cfg.counts(i, q).to_le_bytes().to_vec()
            }
            address::GOAL_POSITION => self.cfg.counts(i, self.targets[i]).to_le_bytes().to_vec(),
            address::MODEL_NUMBER => MODEL_NUMBER.to_le_bytes().to_vec(),
            a => self.table.get(&(id, a)).cloned().unwrap_or_default(),
        };
        v.resize(len, 0);
        v
    }

    fn write_value(&mut self, i: usize, addr: u16, data: &[u8]) {
        if addr == address::GOAL_POSITION && data.len() >= 4 {
            let counts = u32::from_le_bytes([data[0], data[1], data[2], data[3]]);
            self.targets[i] = self.cfg.position(i, counts).clamp(0.0, 1.0);
            self.stats.goal_writes += 1;
            let _ = self.hand.set_targets(self.targets);
        } else {
            self.table.insert((self.cfg.ids[i], addr), data.to_vec());
            if addr == address::GOAL_CURRENT {
                // The simulated hand has one torque limit for its fingers: the strongest
                // goal current written sets it.
                if let Some(f) = self.torque_limit() {
                    let _ = self.hand.set_torque_limit(f);
                }
            }
        }
    }

    fn reply(&mut self, p: Packet) -> std::io::Result<()> {
        self.stats.replies += 1;
        // The host reads replies within its timeout (34 ms and up); the terminal holds far
        // more than one, so a full buffer means nobody is listening.
        match self.master.write_all(&p.encode()) {
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => Ok(()),
            r => r,
        }
    }

    fn handle(&mut self, p: Packet) -> std::io::Result<()> {
        self.stats.packets += 1;
        let u16_at = |b: &[u8], k: usize| b.get(k..k + 2).map(|s| u16::from_le_bytes([s[0], s[1]]));
        match p.instruction {
            instruction::PING => {
                if let Some(_i) = self.servo(p.id) {
                    let mut d = MODEL_NUMBER.to_le_bytes().to_vec();
                    d.push(FIRMWARE);
                    self.reply(Packet::status(p.id, 0, &d))?;
                }
            }
            instruction::READ => {
                if let (Some(i), Some(addr), Some(len)) =
                    (self.servo(p.id), u16_at(&p.params, 0), u16_at(&p.params, 2))
                {
                    let v = self.read_value(i, addr, usize::from(len));
                    self.reply(Packet::status(p.id, 0, &v))?;
                }
            }
            instruction::WRITE => {
                if let (Some(i), Some(addr)) = (self.servo(p.id), u16_at(&p.params, 0)) {
                    self.write_value(i, addr, &p.params[2..]);
                    self.reply(Packet::status(p.id, 0, &[]))?;
                }
            }
            instruction::SYNC_WRITE if p.id == BROADCAST_ID => {
                if let (Some(addr), Some(len)) = (u16_at(&p.params, 0), u16_at(&p.params, 2)) {
                    let stride = 1 + usize::from(len);
                    for chunk in p.params[4..].chunks_exact(stride) {
                        if let Some(i) = self.servo(chunk[0]) {
                            self.write_value(i, addr, &chunk[1..]);
                        }
                    }
                }
            }
            instruction::SYNC_READ if p.id == BROADCAST_ID => {
                if let (Some(addr), Some(len)) = (u16_at(&p.params, 0), u16_at(&p.params, 2)) {
                    for &id in &p.params[4..] {
                        if let Some(i) = self.servo(id) {
                            let v = self.read_value(i, addr, usize::from(len));
                            self.reply(Packet::status(id, 0, &v))?;
                        }
                    }
                }
            }
            _ => {
                self.stats.unsupported += 1;
                if self.servo(p.id).is_some() {
                    self.reply(Packet::status(p.id, ERROR_INSTRUCTION, &[]))?;
                }
            }
        }
        Ok(())
    }

    /// Answers every instruction that arrived.
    pub fn step(&mut self) -> std::io::Result<()> {
        let mut buf = [0u8; 1024];
        loop {
            match self.master.read(&mut buf) {
                Ok(0) => return Ok(()),
                Ok(n) => {
                    for p in self.decoder.push(&buf[..n]) {
                        self.handle(p)?;
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(()),
                // no client has the terminal open
                Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => return Ok(()),
                Err(e) => return Err(e),
            }
        }
    }
}
