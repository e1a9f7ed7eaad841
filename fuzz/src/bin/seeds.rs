//! Writes the seed corpora of the fuzz targets: `fuzz/corpus/<target>/seed-*`.
//!
//! Two sources:
//! - built-in scenarios in the op language (boot, every mode enabled and moved, a csp stream,
//!   PDO remapping, SDO segmented and block transfers, heartbeat and guarding, faults and fault
//!   reset, bus-off, storage commands, LSS configuration and fastscan);
//! - the frame traces the integration tests leave when run with `CANOPEN_DRIVE_TRACE_DIR=dir`
//!   (every frame the test's master sent, with its time; see `tests/tests/common/mod.rs`):
//!   each becomes a program of time steps and raw frames.
//!
//! Usage: `cargo run --manifest-path fuzz/Cargo.toml --features tools --bin seeds [-- TRACE_DIR]`.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};

use canopen_drive_fuzz::ops::{encode_program, Op, Tag, ALL, LSS, PDO};
use canopen_drive_fuzz::rig::NODE;

fn main() -> std::io::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus");
    let trace_dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("CANOPEN_DRIVE_TRACE_DIR").map(PathBuf::from));
    let mut written = [0usize; 4];

    let scenarios = scenarios();
    for (name, variant, ops) in &scenarios {
        written[0] += seed(&root, "drive_frames", name, *variant, &ops_for(ops, &ALL))?;
        written[1] += seed(&root, "pdo_mapping", name, variant & 1, &ops_for(ops, &PDO))?;
        written[2] += seed(&root, "sdo_server", name, 0, &sdo_program(ops))?;
    }
    for (name, configured, ops) in lss_scenarios() {
        written[3] += seed(&root, "lss", name, u8::from(configured), &ops_for(&ops, &LSS))?;
        written[0] +=
            seed(&root, "drive_frames", name, if configured { 0 } else { 3 }, &ops_for(&ops, &ALL))?;
    }
    if let Some(dir) = trace_dir {
        for (name, ops) in traces(&dir)? {
            written[0] += seed(&root, "drive_frames", &name, 0, &ops_for(&ops, &ALL))?;
            written[1] += seed(&root, "pdo_mapping", &name, 0, &ops_for(&ops, &PDO))?;
            written[2] += seed(&root, "sdo_server", &name, 0, &sdo_program(&ops))?;
            written[3] += seed(&root, "lss", &name, 1, &ops_for(&ops, &LSS))?;
        }
    }
    println!(
        "seeds written: drive_frames {}, pdo_mapping {}, sdo_server {}, lss {}",
        written[0], written[1], written[2], written[3]
    );
    Ok(())
}

/// The program bytes of `ops` for a target with tag table `tags`.
fn ops_for(ops: &[Op], tags: &[Tag]) -> Vec<u8> {
    encode_program(ops, tags, NODE)
}

/// Writes one seed (variant byte + program), named by its content; returns 1 if written.
fn seed(root: &Path, target: &str, name: &str, variant: u8, program: &[u8]) -> std::io::Result<usize> {
    if program.is_empty() {
        return Ok(0);
    }
    let dir = root.join(target);
    std::fs::create_dir_all(&dir)?;
    let mut bytes = vec![variant];
    bytes.extend_from_slice(program);
    // Long traces are cut: libFuzzer's default -max_len is a few kB.
    bytes.truncate(4096);
    let mut hasher = DefaultHasher::new();
    bytes.hash(&mut hasher);
    let clean: String = name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
    let file =
        dir.join(format!("seed-{}-{:016x}", clean.chars().take(60).collect::<String>(), hasher.finish()));
    std::fs::write(file, bytes)?;
    Ok(1)
}

// --- Helpers to write scenarios ------------------------------------------------------------

fn w(index: u16, sub: u8, size: u8, value: u32) -> Op {
    Op::SdoWrite { index, sub, size, value }
}

fn r(index: u16, sub: u8) -> Op {
    Op::SdoRead { index, sub }
}

fn ms(n: u64) -> Op {
    Op::Advance(n * 1000)
}

fn cw(value: u16) -> Op {
    Op::Controlword(value)
}

fn nmt(command: u8, node: u8) -> Op {
    // Index into NMT_COMMANDS: 0 start, 1 stop, 2 pre-operational, 3 reset node, 4 reset comm.
    Op::Nmt { command, node }
}

fn enable(mode: u8) -> Vec<Op> {
    vec![w(0x6060, 0, 1, u32::from(mode)), cw(0x06), ms(2), cw(0x07), ms(2), cw(0x0F), ms(2)]
}

fn sdo_raw(bytes: [u8; 8]) -> Op {
    Op::SdoRaw(bytes)
}

fn frame(id: u16, data: &[u8]) -> Op {
    Op::Frame { id, rtr: false, data: data.to_vec() }
}

/// Built-in scenarios for a configured drive: (name, variant byte, ops).
fn scenarios() -> Vec<(&'static str, u8, Vec<Op>)> {
    let mut out = Vec::new();
    out.push((
        "identity",
        0,
        vec![r(0x1000, 0), r(0x1018, 1), r(0x1018, 4), r(0x1008, 0), sdo_raw([0x60, 0, 0, 0, 0, 0, 0, 0])],
    ));

    let mut pp = vec![nmt(0, NODE)];
    pp.extend(enable(1));
    pp.extend([
        w(0x6081, 0, 4, 20_000),
        w(0x6083, 0, 4, 100_000),
        w(0x6084, 0, 4, 100_000),
        w(0x607A, 0, 4, 30_000),
        cw(0x1F),
        ms(5),
        cw(0x0F),
        ms(100),
        w(0x607A, 0, 4, (-5_000i32) as u32),
        cw(0x5F),
        ms(50),
        cw(0x10F),
        ms(20),
        cw(0x0F),
        ms(300),
        cw(0x02),
        ms(50),
        cw(0x00),
    ]);
    out.push(("pp_move", 0, pp.clone()));
    out.push(("pp_move_cascade", 1, pp));

    let mut pv = vec![nmt(0, NODE)];
    pv.extend(enable(3));
    pv.extend([
        w(0x60FF, 0, 4, 50_000),
        ms(100),
        w(0x607F, 0, 4, 10_000),
        ms(50),
        w(0x6080, 0, 4, 120),
        ms(50),
        w(0x60FF, 0, 4, (-80_000i32) as u32),
        ms(100),
        cw(0x0B),
        ms(100),
        cw(0x0F),
        ms(20),
        cw(0x00),
    ]);
    out.push(("pv_limits", 0, pv.clone()));
    out.push(("pv_narrow", 2, pv));

    let mut tq = vec![nmt(0, NODE)];
    tq.extend(enable(4));
    tq.extend([
        w(0x6087, 0, 4, 100_000),
        w(0x6071, 0, 2, 800),
        ms(50),
        w(0x6072, 0, 2, 200),
        ms(20),
        w(0x6073, 0, 2, 100),
        ms(20),
        w(0x60B2, 0, 2, 0x7FFF),
        ms(20),
        cw(0x10F),
        ms(20),
    ]);
    out.push(("tq_limits", 0, tq));

    // csp: RPDO3 (6040h + 607Ah) synchronous, SYNC every millisecond.
    let mut csp = vec![
        Op::PdoConfig { which: 0b0100, sub: 1, kind: 0, raw: 0 },
        Op::PdoConfig { which: 0b0100, sub: 2, kind: 2, raw: 1 },
        Op::PdoConfig { which: 0b0100, sub: 1, kind: 1, raw: 0 },
        w(0x1006, 0, 4, 1000),
        w(0x60C2, 1, 1, 1),
        w(0x60C2, 2, 1, (-3i8) as u8 as u32),
        nmt(0, NODE),
    ];
    csp.extend(enable(8));
    for k in 0..200i32 {
        let target = (k * k * 3) as u32;
        let t = target.to_le_bytes();
        csp.push(Op::Rpdo { n: 2, data: vec![0x0F, 0x00, t[0], t[1], t[2], t[3]] });
        if k % 17 != 5 {
            csp.push(Op::Sync(None));
        }
        csp.push(ms(1));
    }
    csp.push(ms(30));
    out.push(("csp_stream", 0, csp.clone()));
    out.push(("csp_stream_cascade", 1, csp));

    let mut csv = vec![
        Op::PdoConfig { which: 0b0110, sub: 1, kind: 0, raw: 0 },
        Op::PdoConfig { which: 0b0110, sub: 2, kind: 2, raw: 1 },
        Op::PdoConfig { which: 0b0110, sub: 1, kind: 1, raw: 0 },
        nmt(0, NODE),
    ];
    csv.extend(enable(9));
    for k in 0..100i32 {
        let t = (k * 500).to_le_bytes();
        csv.push(Op::Rpdo { n: 3, data: vec![0x0F, 0x00, t[0], t[1], t[2], t[3]] });
        csv.push(Op::Sync(None));
        csv.push(ms(1));
    }
    out.push(("csv_stream", 0, csv));

    let mut hm = vec![nmt(0, NODE)];
    hm.extend(enable(6));
    hm.extend([w(0x6098, 0, 1, 35), cw(0x1F), ms(20), w(0x6098, 0, 1, 17), cw(0x0F), cw(0x1F), ms(300)]);
    out.push(("homing", 0, hm));

    let mut ip = vec![nmt(0, NODE)];
    ip.extend(enable(7));
    ip.extend([cw(0x1F)]);
    for k in 0..20u32 {
        ip.push(w(0x60C1, 1, 4, k * 100));
        ip.push(Op::Sync(None));
        ip.push(ms(1));
    }
    ip.extend([w(0x60C4, 6, 1, 1), ms(10)]);
    out.push(("ip_records", 0, ip));

    let mut vl = vec![nmt(0, NODE)];
    vl.extend(enable(2));
    vl.extend([w(0x6042, 0, 2, 300), cw(0x7F), ms(100), w(0x6046, 2, 4, 100), ms(50), cw(0x0F), ms(50)]);
    out.push(("vl", 0, vl));

    // Remapping: RPDO1 to 2001h (u8) + 2002h (bit) + 6040h; TPDO1 with event timer and inhibit.
    out.push((
        "remap",
        0,
        vec![
            Op::PdoConfig { which: 0b0000, sub: 1, kind: 0, raw: 0 },
            w(0x1600, 0, 1, 0),
            w(0x1600, 1, 4, 0x2001_0008),
            w(0x1600, 2, 4, 0x2002_0001),
            w(0x1600, 3, 4, 0x0001_0001),
            w(0x1600, 4, 4, 0x6040_0010),
            w(0x1600, 0, 1, 4),
            Op::PdoConfig { which: 0b0000, sub: 1, kind: 1, raw: 0 },
            Op::PdoConfig { which: 0b0001, sub: 1, kind: 0, raw: 0 },
            w(0x1800, 3, 2, 50),
            w(0x1800, 5, 2, 20),
            w(0x1A00, 0, 1, 0),
            w(0x1A00, 1, 4, 0x6041_0010),
            w(0x1A00, 2, 4, 0x2001_0008),
            w(0x1A00, 0, 1, 2),
            Op::PdoConfig { which: 0b0001, sub: 1, kind: 1, raw: 0 },
            nmt(0, NODE),
            Op::Rpdo { n: 0, data: vec![15, 0x03, 0x06, 0x00] },
            ms(30),
            Op::Rpdo { n: 0, data: vec![25, 0x01, 0x0F, 0x00] },
            Op::Rpdo { n: 0, data: vec![12] },
            Op::Rpdo { n: 0, data: vec![12, 1, 0x0F, 0, 9, 9] },
            Op::Remote(0),
            ms(50),
            w(0x1600, 1, 4, 0x6060_0008),
        ],
    ));

    // SDO: segmented download and upload, block download and upload of 2000h (text).
    out.push((
        "sdo_segmented",
        0,
        vec![
            sdo_raw([0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0]),
            sdo_raw([0x00, b'a', b'b', b'c', b'd', b'e', b'f', b'g']),
            sdo_raw([0x1B, b'h', b'i', b'j', 0, 0, 0, 0]),
            sdo_raw([0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0]),
            sdo_raw([0x60, 0, 0, 0, 0, 0, 0, 0]),
            sdo_raw([0x70, 0, 0, 0, 0, 0, 0, 0]),
            sdo_raw([0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
            ms(1500),
        ],
    ));
    out.push((
        "sdo_block",
        0,
        vec![
            sdo_raw([0xC6, 0x00, 0x20, 0x00, 9, 0, 0, 0]),
            sdo_raw([0x01, b'b', b'l', b'o', b'c', b'k', b' ', b'd']),
            sdo_raw([0x82, b'l', b'!', 0, 0, 0, 0, 0]),
            sdo_raw([0xD5, 0x00, 0x00, 0, 0, 0, 0, 0]),
            sdo_raw([0xA4, 0x00, 0x20, 0x00, 0x7F, 0x00, 0, 0]),
            sdo_raw([0xA3, 0, 0, 0, 0, 0, 0, 0]),
            sdo_raw([0xA2, 0x02, 0x7F, 0, 0, 0, 0, 0]),
            sdo_raw([0xA1, 0, 0, 0, 0, 0, 0, 0]),
            sdo_raw([0xA4, 0x21, 0x10, 0x00, 0x04, 0x00, 0, 0]),
            sdo_raw([0xA3, 0, 0, 0, 0, 0, 0, 0]),
            ms(1200),
        ],
    ));

    // Error control: heartbeat consumer of node 1, lost; producer; node guarding.
    out.push((
        "heartbeat_loss",
        0,
        vec![
            w(0x1016, 1, 4, 0x0001_0064),
            w(0x1017, 0, 2, 50),
            w(0x6007, 0, 2, 2),
            nmt(0, NODE),
            Op::Heartbeat { node: 1, state: 5 },
            ms(50),
            Op::Heartbeat { node: 1, state: 5 },
            ms(300),
            Op::Heartbeat { node: 1, state: 0 },
            w(0x1029, 1, 1, 2),
            Op::Heartbeat { node: 1, state: 5 },
            ms(500),
        ],
    ));
    out.push((
        "guarding",
        0,
        vec![
            w(0x100C, 0, 2, 100),
            w(0x100D, 0, 1, 3),
            Op::Frame { id: 0x700 + u16::from(NODE), rtr: true, data: vec![] },
            ms(90),
            Op::Frame { id: 0x700 + u16::from(NODE), rtr: true, data: vec![] },
            Op::Jump(2_000_000),
        ],
    ));
    out.push((
        "sync_producer",
        0,
        vec![w(0x1019, 0, 1, 10), w(0x1005, 0, 4, 0x4000_0080), w(0x1006, 0, 4, 2000), nmt(0, NODE), ms(40)],
    ));

    let mut fault = vec![nmt(0, NODE)];
    fault.extend(enable(3));
    fault.extend([
        w(0x60FF, 0, 4, 30_000),
        ms(50),
        Op::Motor { kind: 0, arg: 1 },
        ms(20),
        cw(0x80),
        Op::Motor { kind: 1, arg: 0 },
        ms(5),
        cw(0x00),
        cw(0x80),
        ms(5),
        cw(0x06),
        Op::Motor { kind: 2, arg: 0x20 },
        ms(5),
        Op::Motor { kind: 3, arg: 0 },
        Op::CanState(0),
        ms(10),
        Op::CanState(1),
        ms(10),
        Op::Motor { kind: 5, arg: 1 },
        ms(5),
    ]);
    out.push(("fault_reset", 0, fault));

    out.push((
        "storage_commands",
        1,
        vec![
            w(0x1010, 1, 4, u32::from_le_bytes(*b"save")),
            w(0x1011, 1, 4, u32::from_le_bytes(*b"load")),
            w(0x1003, 0, 1, 0),
            r(0x1003, 1),
            w(0x1014, 0, 4, 0x8000_0085),
            w(0x1015, 0, 2, 100),
            nmt(4, 0),
            ms(5),
            nmt(3, NODE),
            ms(5),
        ],
    ));
    out
}

fn lss(command: u8, data: [u8; 7]) -> Op {
    // The Lss op takes an index into LSS_COMMANDS.
    let index = canopen_drive_fuzz::ops::LSS_COMMANDS.iter().position(|c| *c == command).unwrap_or(0);
    Op::Lss { command: index as u8, data }
}

fn u32_field(value: u32) -> [u8; 7] {
    let v = value.to_le_bytes();
    [v[0], v[1], v[2], v[3], 0, 0, 0]
}

/// Built-in LSS scenarios: (name, configured, ops).
fn lss_scenarios() -> Vec<(&'static str, bool, Vec<Op>)> {
    let selective = vec![
        lss(0x40, u32_field(0x0ABC)),
        lss(0x41, u32_field(0x0004_0002)),
        lss(0x42, u32_field(0x0001_0003)),
        lss(0x43, u32_field(0x1234_5678)),
    ];
    let mut configure = selective.clone();
    configure.extend([
        lss(0x5E, [0; 7]),
        lss(0x11, [10, 0, 0, 0, 0, 0, 0]),
        lss(0x13, [0, 2, 0, 0, 0, 0, 0]),
        lss(0x17, [0; 7]),
        lss(0x15, [50, 0, 0, 0, 0, 0, 0]),
        lss(0x04, [0; 7]),
        ms(200),
        nmt(4, 0),
        ms(5),
        r(0x1000, 0),
    ]);
    let mut global = vec![
        lss(0x04, [1, 0, 0, 0, 0, 0, 0]),
        lss(0x5A, [0; 7]),
        lss(0x5D, [0; 7]),
        lss(0x11, [0x7F, 0, 0, 0, 0, 0, 0]),
        lss(0x11, [0x80, 0, 0, 0, 0, 0, 0]),
        lss(0x04, [0; 7]),
        nmt(4, 0),
        ms(5),
    ];
    global.extend([lss(0x4C, [0; 7]), lss(0x46, u32_field(0x0ABC)), lss(0x47, u32_field(0x0004_0002))]);
    global.extend([
        lss(0x48, u32_field(0)),
        lss(0x49, u32_field(0xFFFF_FFFF)),
        lss(0x4A, u32_field(0)),
        lss(0x4B, u32_field(0xFFFF_FFFF)),
    ]);
    // Fastscan: reset, then the vendor-ID bit by bit from the top (the first steps).
    let mut fastscan = vec![lss(0x51, [0, 0, 0, 0, 0x80, 0, 0])];
    let vendor = 0x0ABCu32;
    for bit in (24..32).rev() {
        let id = (vendor >> bit) << bit;
        let v = id.to_le_bytes();
        fastscan.push(lss(0x51, [v[0], v[1], v[2], v[3], bit as u8, 0, 0]));
    }
    let v = vendor.to_le_bytes();
    fastscan.push(lss(0x51, [v[0], v[1], v[2], v[3], 0, 0, 1]));
    vec![
        ("lss_configure", false, configure.clone()),
        ("lss_configure_configured", true, configure),
        ("lss_global", false, global),
        ("lss_fastscan", false, fastscan),
    ]
}

/// The SDO server target's program for the SDO frames of `ops`: raw requests (tag 1) and time
/// steps (tag 2). Initiate frames are pointed at the model's entries: downloads at 2001h (a
/// variable value), uploads at 2002h (1000 bytes), so that the protocol sequences go on.
fn sdo_program(ops: &[Op]) -> Vec<u8> {
    let sdo_rx = 0x600 + u16::from(NODE);
    let mut out = Vec::new();
    for op in ops {
        let frame = match op {
            Op::Advance(us) | Op::Jump(us) => {
                let ms = (us / 1000).min(0xFFFF) as u16;
                if ms > 0 {
                    out.push(2);
                    out.extend_from_slice(&ms.to_le_bytes());
                }
                continue;
            }
            other => other.as_frame(NODE).or_else(|| Some(other.clone())),
        };
        let Some(Op::Frame { id, rtr: false, data }) = frame else { continue };
        if id != sdo_rx {
            continue;
        }
        let mut data = data.clone();
        let command = data.first().copied().unwrap_or(0);
        let target: Option<u16> = match command >> 5 {
            1 | 6 => Some(0x2001),
            2 | 5 => Some(0x2002),
            _ => None,
        };
        if let (Some(index), true) = (target, data.len() >= 4) {
            let [lo, hi] = index.to_le_bytes();
            data[1] = lo;
            data[2] = hi;
            data[3] = 0;
        }
        out.push(1);
        out.push(data.len() as u8);
        out.extend_from_slice(&data);
    }
    out
}

/// The traces in `dir` (`*.trace`: lines `time_us id flags hex`, flags `D<len>` or `R<len>`),
/// each as time steps and raw frames.
fn traces(dir: &Path) -> std::io::Result<Vec<(String, Vec<Op>)>> {
    let mut out = Vec::new();
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "trace"))
        .collect();
    paths.sort();
    for path in paths {
        let text = std::fs::read_to_string(&path)?;
        let mut ops = Vec::new();
        let mut last = 0u64;
        for line in text.lines() {
            let mut fields = line.split_whitespace();
            let (Some(time), Some(id), Some(flags)) = (fields.next(), fields.next(), fields.next()) else {
                continue;
            };
            let (Ok(time), Ok(id)) = (time.parse::<u64>(), u16::from_str_radix(id, 16)) else { continue };
            let rtr = flags.starts_with('R');
            let len: usize = flags.get(1..).and_then(|n| n.parse().ok()).unwrap_or(0);
            let hex = fields.next().unwrap_or("");
            let data: Vec<u8> = if rtr {
                vec![0; len.min(8)]
            } else {
                (0..hex.len() / 2)
                    .filter_map(|i| u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok())
                    .collect()
            };
            if time > last {
                ops.push(Op::Advance(time - last));
                last = time;
            }
            ops.push(frame_op(id, rtr, data));
        }
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        out.push((name, ops));
    }
    Ok(out)
}

fn frame_op(id: u16, rtr: bool, data: Vec<u8>) -> Op {
    if rtr {
        Op::Frame { id, rtr, data }
    } else {
        frame(id, &data)
    }
}
