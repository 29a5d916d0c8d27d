//! Dynamixel Protocol 2.0 packets (ROBOTIS e-Manual, "Protocol 2.0"): the framing both ends
//! of the hand's bus speak. The host side of the real backend is meant to use the
//! `dynamixel2` crate; this codec is for the emulated servos of `tmo sim serve` and for
//! checking what goes over the wire.
//!
//! Packet: `FF FF FD 00 | id | len (u16 LE) | instruction | params | crc (u16 LE)`, where `len`
//! counts instruction, params and CRC, params are byte-stuffed (`FF FF FD` gains a `FD`),
//! and the CRC is CRC-16/BUYPASS (poly 0x8005, init 0) over everything before it.

pub const HEADER: [u8; 4] = [0xFF, 0xFF, 0xFD, 0x00];
pub const BROADCAST_ID: u8 = 0xFE;

/// Instruction codes.
pub mod instruction {
    pub const PING: u8 = 0x01;
    pub const READ: u8 = 0x02;
    pub const WRITE: u8 = 0x03;
    pub const REBOOT: u8 = 0x08;
    pub const STATUS: u8 = 0x55;
    pub const SYNC_READ: u8 = 0x82;
    pub const SYNC_WRITE: u8 = 0x83;
}

/// X-series control table addresses the hand uses (XM430-W350, Protocol 2.0).
pub mod address {
    pub const MODEL_NUMBER: u16 = 0;
    pub const OPERATING_MODE: u16 = 11;
    pub const CURRENT_LIMIT: u16 = 38;
    pub const TORQUE_ENABLE: u16 = 64;
    pub const GOAL_CURRENT: u16 = 102;
    pub const GOAL_POSITION: u16 = 116;
    pub const PRESENT_CURRENT: u16 = 126;
    pub const PRESENT_POSITION: u16 = 132;
}

/// CRC-16/BUYPASS, bit by bit: the packets are short (under 100 bytes at 4 servos), so a
/// 512-byte table buys nothing measurable at the bus's 1 Mbaud at most.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &b in bytes {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x8005
            } else {
                crc << 1
            };
        }
    }
    crc
}

fn stuff(params: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(params.len() + 4);
    for &b in params {
        out.push(b);
        let n = out.len();
        if n >= 3 && out[n - 3..] == [0xFF, 0xFF, 0xFD] {
            out.push(0xFD);
        }
    }
    out
}

fn unstuff(params: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(params.len());
    let mut i = 0;
    while i < params.len() {
        out.push(params[i]);
        let n = out.len();
        if n >= 3 && out[n - 3..] == [0xFF, 0xFF, 0xFD] && params.get(i + 1) == Some(&0xFD) {
            i += 1; // the stuffing byte
        }
        i += 1;
    }
    out
}

/// One packet, params unstuffed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packet {
    pub id: u8,
    pub instruction: u8,
    pub params: Vec<u8>,
}

impl Packet {
    pub fn encode(&self) -> Vec<u8> {
        let body = stuff(&self.params);
        let len = (body.len() + 3) as u16;
        let mut out = Vec::with_capacity(body.len() + 10);
        out.extend_from_slice(&HEADER);
        out.push(self.id);
        out.extend_from_slice(&len.to_le_bytes());
        out.push(self.instruction);
        out.extend_from_slice(&body);
        let crc = crc16(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// A status packet: `error` byte first, then `data`.
    pub fn status(id: u8, error: u8, data: &[u8]) -> Self {
        let mut params = vec![error];
        params.extend_from_slice(data);
        Packet {
            id,
            instruction: instruction::STATUS,
            params,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    #[error("CRC {found:#06x}, expected {expected:#06x}")]
    Crc { found: u16, expected: u16 },
    #[error("length field {0} is too short for a packet")]
    Length(u16),
}

/// What the decoder has thrown away.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct DecoderStats {
    pub packets: u64,
    /// Bytes skipped while looking for a header.
    pub skipped_bytes: u64,
    pub bad_crc: u64,
    pub bad_length: u64,
}

/// Finds packets in a byte stream from the bus.
#[derive(Debug, Default, Clone)]
pub struct Decoder {
    buf: Vec<u8>,
    stats: DecoderStats,
}

/// Longest packet accepted: a sync write of 4 servos x 4 bytes is 32 bytes; the X series'
/// buffer is 1 KiB.
pub const MAX_PACKET: usize = 1024;

impl Decoder {
    pub fn stats(&self) -> &DecoderStats {
        &self.stats
    }

    /// Takes bytes; returns the packets they completed (bad ones are counted and skipped).
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Packet> {
        self.buf.extend_from_slice(bytes);
        let mut out = Vec::new();
        loop {
            // Align on a header.
            let Some(start) = self.buf.windows(4).position(|w| w == HEADER) else {
                // keep a possible partial header at the end
                let keep = (1..=3)
                    .rev()
                    .find(|&k| self.buf.len() >= k && self.buf[self.buf.len() - k..] == HEADER[..k])
                    .unwrap_or(0);
                let drop = self.buf.len() - keep;
                self.stats.skipped_bytes += drop as u64;
                self.buf.drain(..drop);
                return out;
            };
            self.stats.skipped_bytes += start as u64;
            self.buf.drain(..start);
            if self.buf.len() < 7 {
                return out;
            }
            let len = u16::from_le_bytes([self.buf[5], self.buf[6]]);
            if len < 3 || usize::from(len) + 7 > MAX_PACKET {
                self.stats.bad_length += 1;
                self.buf.drain(..1);
                continue;
            }
            let total = 7 + usize::from(len);
            if self.buf.len() < total {
                return out;
            }
            let crc = u16::from_le_bytes([self.buf[total - 2], self.buf[total - 1]]);
            if crc16(&self.buf[..total - 2]) != crc {
                self.stats.bad_crc += 1;
                self.buf.drain(..1);
                continue;
            }
            out.push(Packet {
                id: self.buf[4],
                instruction: self.buf[7],
                params: unstuff(&self.buf[8..total - 2]),
            });
            self.stats.packets += 1;
            self.buf.drain(..total);
        }
    }
}

/// Sync write of `len`-byte values at `address`, one per servo.
pub fn sync_write(address: u16, len: u16, values: &[(u8, u32)]) -> Packet {
    let mut params = Vec::new();
    params.extend_from_slice(&address.to_le_bytes());
    params.extend_from_slice(&len.to_le_bytes());
    for (id, v) in values {
        params.push(*id);
        params.extend_from_slice(&v.to_le_bytes()[..usize::from(len)]);
    }
    Packet {
        id: BROADCAST_ID,
        instruction: instruction::SYNC_WRITE,
        params,
    }
}

/// Sync read of `len` bytes at `address` from each servo.
pub fn sync_read(address: u16, len: u16, ids: &[u8]) -> Packet {
    let mut params = Vec::new();
    params.extend_from_slice(&address.to_le_bytes());
    params.extend_from_slice(&len.to_le_bytes());
    params.extend_from_slice(ids);
    Packet {
        id: BROADCAST_ID,
        instruction: instruction::SYNC_READ,
        params,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value_and_the_manuals_ping() {
        // CRC-16/BUYPASS check value
        assert_eq!(crc16(b"123456789"), 0xFEE8);
        // e-Manual: Ping to id 1 is FF FF FD 00 01 03 00 01 19 4E
        let ping = Packet {
            id: 1,
            instruction: instruction::PING,
            params: vec![],
        };
        assert_eq!(
            ping.encode(),
            [0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E]
        );
    }

    #[test]
    fn stuffing_round_trips() {
        let p = Packet {
            id: 3,
            instruction: instruction::WRITE,
            params: vec![0x74, 0x00, 0xFF, 0xFF, 0xFD, 0x01],
        };
        let bytes = p.encode();
        assert_eq!(&bytes[8..15], [0x74, 0x00, 0xFF, 0xFF, 0xFD, 0xFD, 0x01]);
        let mut d = Decoder::default();
        assert_eq!(d.push(&bytes), vec![p]);
    }

    #[test]
    fn the_decoder_resynchronises_after_garbage_and_bad_crcs() {
        let p = sync_write(address::GOAL_POSITION, 4, &[(1, 2048), (2, 1000)]);
        let mut bad = p.encode();
        let n = bad.len();
        bad[n - 1] ^= 0xFF;
        let mut stream = vec![0x00, 0xFF, 0x12];
        stream.extend(&bad);
        stream.extend(p.encode());
        let mut d = Decoder::default();
        let (a, b) = stream.split_at(9);
        let mut got = d.push(a);
        got.extend(d.push(b));
        assert_eq!(got, vec![p]);
        assert_eq!(d.stats().bad_crc, 1);
        assert!(d.stats().skipped_bytes >= 3);
    }
}
