//! The input language of the drive fuzz targets.
//!
//! An input is a sequence of ops; each op starts with a tag byte, mapped through the target's
//! tag table (so a target can weight the ops it cares about), followed by its fields. An
//! exhausted input reads as zeros, so every byte string decodes.
//!
//! | op | fields | what the rig does |
//! |---|---|---|
//! | `Frame` | id u16 (11 bits; bit 15: extended frame), flags u8 (len = low nibble ≤ 8, bit 4 = RTR), data | `on_frame` |
//! | `Advance` | u16 µs | ticks (1 kHz) and polls up to then |
//! | `Jump` | u16 × 100 ms | a stalled board: a few ticks, then one jump |
//! | `SdoWrite` | index u16, sub u8, size u8 (1–4), value u32 | expedited download |
//! | `SdoRead` | index u16, sub u8 | expedited upload request |
//! | `SdoRaw` | 8 bytes | any SDO client frame (segments, block protocol) |
//! | `Nmt` | command u8, node u8 | NMT node control |
//! | `Controlword` | u16 | 6040h by SDO |
//! | `Sync` | flags u8 (bit 7: with counter), counter u8 | SYNC on the configured COB-ID |
//! | `Rpdo` | n u8, len u8, data | a frame on RPDO n's configured COB-ID |
//! | `Remote` | n u8 | a remote frame on TPDO n's COB-ID |
//! | `PdoConfig` | which u8, sub u8, kind u8, raw u32 | an SDO write to a PDO record, value chosen from the dictionary's mappable entries |
//! | `Motor` | kind u8, arg u16 | hardware faults, inputs, load, local control |
//! | `CanState` | u8 | `on_can_state` |
//! | `Lss` | cs u8 (index into the request table), 7 bytes | an LSS request |
//! | `Heartbeat` | node u8, state u8 | a heartbeat of another node |

use crate::Reader;

/// Op kinds (the tag tables of the targets list these).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tag {
    /// A raw frame.
    Frame,
    /// Time passes.
    Advance,
    /// A long time passes.
    Jump,
    /// Expedited SDO download.
    SdoWrite,
    /// Expedited SDO upload request.
    SdoRead,
    /// Any SDO client frame.
    SdoRaw,
    /// NMT node control.
    Nmt,
    /// 6040h.
    Controlword,
    /// SYNC.
    Sync,
    /// A frame on an RPDO's COB-ID.
    Rpdo,
    /// A remote frame on a TPDO's COB-ID.
    Remote,
    /// A write to a PDO record.
    PdoConfig,
    /// The motor's hardware.
    Motor,
    /// The CAN controller's state.
    CanState,
    /// An LSS request.
    Lss,
    /// A heartbeat.
    Heartbeat,
}

/// Every op, equally weighted (target a: everything).
pub const ALL: [Tag; 16] = [
    Tag::Frame,
    Tag::Advance,
    Tag::Jump,
    Tag::SdoWrite,
    Tag::SdoRead,
    Tag::SdoRaw,
    Tag::Nmt,
    Tag::Controlword,
    Tag::Sync,
    Tag::Rpdo,
    Tag::Remote,
    Tag::PdoConfig,
    Tag::Motor,
    Tag::CanState,
    Tag::Lss,
    Tag::Heartbeat,
];

/// Target c: PDO mapping writes, then PDO traffic.
pub const PDO: [Tag; 16] = [
    Tag::PdoConfig,
    Tag::PdoConfig,
    Tag::PdoConfig,
    Tag::PdoConfig,
    Tag::Rpdo,
    Tag::Rpdo,
    Tag::Rpdo,
    Tag::Sync,
    Tag::Sync,
    Tag::Advance,
    Tag::Remote,
    Tag::Nmt,
    Tag::Controlword,
    Tag::SdoWrite,
    Tag::SdoRead,
    Tag::Frame,
];

/// Target d: LSS.
pub const LSS: [Tag; 12] = [
    Tag::Lss,
    Tag::Lss,
    Tag::Lss,
    Tag::Lss,
    Tag::Lss,
    Tag::Lss,
    Tag::Nmt,
    Tag::Advance,
    Tag::Jump,
    Tag::SdoRead,
    Tag::Heartbeat,
    Tag::Frame,
];

/// The LSS request command specifiers, indexed by the `Lss` op's first field.
pub const LSS_COMMANDS: [u8; 26] = [
    0x04, 0x40, 0x41, 0x42, 0x43, 0x11, 0x13, 0x15, 0x17, 0x46, 0x47, 0x48, 0x49, 0x4A, 0x4B, 0x4C, 0x51,
    0x5A, 0x5B, 0x5C, 0x5D, 0x5E, 0x44, 0x4F, 0x50, 0x00,
];

/// NMT command specifiers, indexed by the `Nmt` op's first field (other values are sent raw).
pub const NMT_COMMANDS: [u8; 5] = [0x01, 0x02, 0x80, 0x81, 0x82];

/// One step of a fuzz program.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Op {
    /// A raw frame.
    Frame {
        /// 11-bit identifier.
        id: u16,
        /// Remote frame.
        rtr: bool,
        /// Data (remote frames: only the length counts).
        data: Vec<u8>,
    },
    /// Time passes, in µs (at most 65 535).
    Advance(u64),
    /// A long time passes, in µs (multiple of 100 ms).
    Jump(u64),
    /// Expedited SDO download of `size` bytes of `value`.
    SdoWrite {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// 1..=4 bytes.
        size: u8,
        /// The value (low `size` bytes sent).
        value: u32,
    },
    /// Expedited SDO upload request.
    SdoRead {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// Any SDO client frame.
    SdoRaw([u8; 8]),
    /// NMT node control.
    Nmt {
        /// Index into [`NMT_COMMANDS`], or a raw command.
        command: u8,
        /// Addressed node (0 = all).
        node: u8,
    },
    /// 6040h by SDO.
    Controlword(u16),
    /// SYNC, with a counter.
    Sync(Option<u8>),
    /// Data on RPDO `n`'s COB-ID.
    Rpdo {
        /// RPDO number − 1.
        n: u8,
        /// Data.
        data: Vec<u8>,
    },
    /// A remote frame on TPDO `n`'s COB-ID.
    Remote(u8),
    /// A write to a PDO record.
    PdoConfig {
        /// Bit 0: TPDO; bits 1–2: number − 1; bit 3: mapping record.
        which: u8,
        /// Sub-index (modulo the record's highest).
        sub: u8,
        /// How the value is chosen (see the rig).
        kind: u8,
        /// Raw material of the value.
        raw: u32,
    },
    /// Motor hardware.
    Motor {
        /// What changes.
        kind: u8,
        /// Its argument.
        arg: u16,
    },
    /// The CAN controller's state.
    CanState(u8),
    /// An LSS request.
    Lss {
        /// Index into [`LSS_COMMANDS`] (raw value beyond it).
        command: u8,
        /// Bytes 1..=7.
        data: [u8; 7],
    },
    /// A heartbeat of `node` in `state`.
    Heartbeat {
        /// Node-ID.
        node: u8,
        /// State byte.
        state: u8,
    },
}

impl Op {
    /// The op's kind.
    pub fn tag(&self) -> Tag {
        match self {
            Op::Frame { .. } => Tag::Frame,
            Op::Advance(_) => Tag::Advance,
            Op::Jump(_) => Tag::Jump,
            Op::SdoWrite { .. } => Tag::SdoWrite,
            Op::SdoRead { .. } => Tag::SdoRead,
            Op::SdoRaw(_) => Tag::SdoRaw,
            Op::Nmt { .. } => Tag::Nmt,
            Op::Controlword(_) => Tag::Controlword,
            Op::Sync(_) => Tag::Sync,
            Op::Rpdo { .. } => Tag::Rpdo,
            Op::Remote(_) => Tag::Remote,
            Op::PdoConfig { .. } => Tag::PdoConfig,
            Op::Motor { .. } => Tag::Motor,
            Op::CanState(_) => Tag::CanState,
            Op::Lss { .. } => Tag::Lss,
            Op::Heartbeat { .. } => Tag::Heartbeat,
        }
    }

    /// Decodes the next op; `tags` is the target's tag table (not empty).
    pub fn read(r: &mut Reader<'_>, tags: &[Tag]) -> Op {
        let tag = tags.get(usize::from(r.u8()) % tags.len().max(1)).copied().unwrap_or(Tag::Frame);
        match tag {
            Tag::Frame => {
                // Bit 15: an extended frame (with the same low 11 bits).
                let id = r.u16() & 0x87FF;
                let flags = r.u8();
                let len = usize::from(flags & 0x0F).min(8);
                Op::Frame { id, rtr: flags & 0x10 != 0, data: r.bytes(len) }
            }
            Tag::Advance => Op::Advance(u64::from(r.u16())),
            Tag::Jump => Op::Jump(u64::from(r.u16()) * 100_000),
            Tag::SdoWrite => {
                let index = r.u16();
                let sub = r.u8();
                let size = r.u8() % 4 + 1;
                Op::SdoWrite { index, sub, size, value: r.u32() }
            }
            Tag::SdoRead => Op::SdoRead { index: r.u16(), sub: r.u8() },
            Tag::SdoRaw => {
                let mut data = [0u8; 8];
                for b in &mut data {
                    *b = r.u8();
                }
                Op::SdoRaw(data)
            }
            Tag::Nmt => Op::Nmt { command: r.u8(), node: r.u8() },
            Tag::Controlword => Op::Controlword(r.u16()),
            Tag::Sync => {
                let flags = r.u8();
                let counter = r.u8();
                Op::Sync((flags & 0x80 != 0).then_some(counter))
            }
            Tag::Rpdo => {
                let n = r.u8();
                let len = usize::from(r.u8() & 0x0F).min(8);
                Op::Rpdo { n, data: r.bytes(len) }
            }
            Tag::Remote => Op::Remote(r.u8()),
            Tag::PdoConfig => Op::PdoConfig { which: r.u8(), sub: r.u8(), kind: r.u8(), raw: r.u32() },
            Tag::Motor => Op::Motor { kind: r.u8(), arg: r.u16() },
            Tag::CanState => Op::CanState(r.u8()),
            Tag::Lss => {
                let command = r.u8();
                let mut data = [0u8; 7];
                for b in &mut data {
                    *b = r.u8();
                }
                Op::Lss { command, data }
            }
            Tag::Heartbeat => Op::Heartbeat { node: r.u8(), state: r.u8() },
        }
    }

    /// Encodes the op for a target with tag table `tags`; `None` when the table lacks the op's
    /// kind (the seed generator then falls back to a raw frame).
    pub fn encode(&self, tags: &[Tag], out: &mut Vec<u8>) -> Option<()> {
        let position = tags.iter().position(|t| *t == self.tag())?;
        out.push(position as u8);
        match self {
            Op::Frame { id, rtr, data } => {
                out.extend_from_slice(&id.to_le_bytes());
                out.push(data.len().min(8) as u8 | if *rtr { 0x10 } else { 0 });
                out.extend(data.iter().take(8));
            }
            Op::Advance(us) => out.extend_from_slice(&((*us).min(0xFFFF) as u16).to_le_bytes()),
            Op::Jump(us) => out.extend_from_slice(&((us / 100_000).min(0xFFFF) as u16).to_le_bytes()),
            Op::SdoWrite { index, sub, size, value } => {
                out.extend_from_slice(&index.to_le_bytes());
                out.push(*sub);
                out.push(size.saturating_sub(1) % 4);
                out.extend_from_slice(&value.to_le_bytes());
            }
            Op::SdoRead { index, sub } => {
                out.extend_from_slice(&index.to_le_bytes());
                out.push(*sub);
            }
            Op::SdoRaw(data) => out.extend_from_slice(data),
            Op::Nmt { command, node } => out.extend_from_slice(&[*command, *node]),
            Op::Controlword(value) => out.extend_from_slice(&value.to_le_bytes()),
            Op::Sync(counter) => match counter {
                Some(c) => out.extend_from_slice(&[0x80, *c]),
                None => out.extend_from_slice(&[0, 0]),
            },
            Op::Rpdo { n, data } => {
                out.push(*n);
                out.push(data.len().min(8) as u8);
                out.extend(data.iter().take(8));
            }
            Op::Remote(n) => out.push(*n),
            Op::PdoConfig { which, sub, kind, raw } => {
                out.extend_from_slice(&[*which, *sub, *kind]);
                out.extend_from_slice(&raw.to_le_bytes());
            }
            Op::Motor { kind, arg } => {
                out.push(*kind);
                out.extend_from_slice(&arg.to_le_bytes());
            }
            Op::CanState(state) => out.push(*state),
            Op::Lss { command, data } => {
                out.push(*command);
                out.extend_from_slice(data);
            }
            Op::Heartbeat { node, state } => out.extend_from_slice(&[*node, *state]),
        }
        Some(())
    }
}

/// Encodes `ops` for a target with tag table `tags`. Ops whose kind the table lacks are
/// encoded as the raw frame they stand for when that is possible (`node` is the drive's
/// node-ID), and dropped otherwise.
pub fn encode_program(ops: &[Op], tags: &[Tag], node: u8) -> Vec<u8> {
    let mut out = Vec::new();
    for op in ops {
        if let Op::Advance(us) = op {
            // Longer spans than one op holds: several ops.
            let mut left = *us;
            while left > 0xFFFF {
                let _ = Op::Advance(0xFFFF).encode(tags, &mut out);
                left -= 0xFFFF;
            }
            let _ = Op::Advance(left).encode(tags, &mut out);
            continue;
        }
        if op.encode(tags, &mut out).is_some() {
            continue;
        }
        if let Some(frame) = op.as_frame(node) {
            let _ = frame.encode(tags, &mut out);
        }
    }
    out
}

impl Op {
    /// The raw frame an op stands for, when it does not depend on the drive's configuration.
    pub fn as_frame(&self, node: u8) -> Option<Op> {
        let sdo_rx = 0x600 + u16::from(node);
        let frame = |id: u16, data: Vec<u8>| Some(Op::Frame { id, rtr: false, data });
        match self {
            Op::SdoWrite { index, sub, size, value } => {
                let command = 0x23 | ((4 - size.clamp(&1, &4)) << 2);
                let [lo, hi] = index.to_le_bytes();
                let v = value.to_le_bytes();
                frame(sdo_rx, vec![command, lo, hi, *sub, v[0], v[1], v[2], v[3]])
            }
            Op::SdoRead { index, sub } => {
                let [lo, hi] = index.to_le_bytes();
                frame(sdo_rx, vec![0x40, lo, hi, *sub, 0, 0, 0, 0])
            }
            Op::SdoRaw(data) => frame(sdo_rx, data.to_vec()),
            Op::Nmt { command, node } => {
                let command = NMT_COMMANDS.get(usize::from(*command)).copied().unwrap_or(*command);
                frame(0x000, vec![command, *node])
            }
            Op::Sync(counter) => frame(0x080, counter.iter().copied().collect()),
            Op::Lss { command, data } => {
                let cs = LSS_COMMANDS.get(usize::from(*command)).copied().unwrap_or(*command);
                let mut bytes = vec![cs];
                bytes.extend_from_slice(data);
                frame(0x7E5, bytes)
            }
            Op::Heartbeat { node, state } => frame(0x700 + u16::from(*node & 0x7F), vec![*state]),
            _ => None,
        }
    }
}
