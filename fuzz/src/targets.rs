//! The bodies of the fuzz targets, callable without libFuzzer (the `replay` binary runs them on
//! corpus files with the stable toolchain).

use canopen_drive::comm::sdo_server::SdoServer;
use canopen_drive::{Duration, Instant};

use crate::ops::{Op, ALL, LSS, PDO};
use crate::rig::{run_program, Rig, Start, Variant};
use crate::sdo_model::{Model, BUFFER, MUXES};
use crate::Reader;

/// (a) Arbitrary frame sequences with arbitrary time steps into a whole drive with the
/// simulated motor (tick + on_frame + poll), every op of the language, in one of four drive
/// configurations (first byte % 4), booted or prepared in a mode (first byte / 4 % 5, see
/// [`Start`]). Invariants after every step: see `canopen_drive_fuzz::rig`.
pub fn drive_frames(data: &[u8]) {
    let Some((&selector, program)) = data.split_first() else { return };
    let mut rig = match Rig::prepared(Variant::from_byte(selector), Start::from_byte(selector / 4)) {
        Ok(rig) => rig,
        Err(e) => panic!("the rig does not start: {e}"),
    };
    run_program(&mut rig, program, &ALL, 400);
}

/// (c) PDO mapping writes followed by PDO traffic: writes to the communication and mapping
/// records (values drawn from the dictionary's own mappable entries, dummy entries and raw
/// values), NMT, RPDOs on whatever COB-IDs are configured, SYNCs and remote frames, in a
/// drive with the CiA defaults or a narrowed vendor configuration (first byte, bit 0), booted
/// or Operational and moving in pp (bit 1).
pub fn pdo_mapping(data: &[u8]) {
    let Some((&selector, program)) = data.split_first() else { return };
    let variant = if selector & 1 == 0 { Variant::Standard } else { Variant::Narrow };
    // Booted (Pre-operational) or started, moving in pp.
    let start = if selector & 2 == 0 { Start::Booted } else { Start::PpMoving };
    let mut rig = match Rig::prepared(variant, start) {
        Ok(rig) => rig,
        Err(e) => panic!("the rig does not start: {e}"),
    };
    run_program(&mut rig, program, &PDO, 400);
}

/// (d) LSS: requests of every command specifier (and unknown ones) with arbitrary parameters,
/// NMT resets that activate a configured node-ID, time and stray frames, on a node that starts
/// unconfigured (node-ID 255) or configured (first byte, bit 0), waiting or in the LSS
/// configuration state (bit 1). Beyond the rig's invariants: at most one LSS response per
/// request and none without one, an unconfigured node sends nothing but LSS responses, and the
/// node-ID is always 1..=127 or 255.
pub fn lss(data: &[u8]) {
    let Some((&selector, program)) = data.split_first() else { return };
    let variant = if selector & 1 == 0 { Variant::Unconfigured } else { Variant::Standard };
    let start = if selector & 2 == 0 { Start::Booted } else { Start::LssConfiguration };
    let mut rig = match Rig::prepared(variant, start) {
        Ok(rig) => rig,
        Err(e) => panic!("the rig does not start: {e}"),
    };
    let mut reader = Reader::new(program);
    let mut count = 0;
    while !reader.is_empty() && count < 400 {
        let op = Op::read(&mut reader, &LSS);
        if let Err(violation) = rig.run(&op) {
            panic!("invariant violated: {violation}");
        }
        let node = rig.drive.node_id();
        assert!((1..=127).contains(&node) || node == 0xFF, "node-ID {node}");
        let pending = rig.drive.lss().pending_node_id();
        assert!((1..=127).contains(&pending) || pending == 0xFF, "pending node-ID {pending}");
        if let Some(change) = rig.drive.take_bit_rate_change() {
            assert!(change.bit_timing.standard_rate().is_some(), "activated {change:?}");
        }
        count += 1;
    }
}

/// (b) The SDO server alone, against a model dictionary (`canopen_drive_fuzz::sdo_model`), with
/// arbitrary client frames (structured: a client command specifier and a known multiplexer; or
/// raw, of any length) and arbitrary time steps.
///
/// Ops (tag byte % 4): 0 structured request (command index, mux index, 4 bytes), 1 raw request
/// (length byte, bytes), 2 time passes (u16 ms) then poll, 3 poll now.
///
/// Invariants after every step:
/// - a request gets at most one response (by type), and `poll` sends only block-upload
///   segments (at most one sub-block of at most 127 segments between two client frames) or one
///   timeout abort, and the timeout abort only once the deadline has passed;
/// - a value reaches the dictionary only together with a success response, never with an
///   abort, and at most once per request;
/// - the server never reads beyond a value, never writes more than its buffer;
/// - after an abort (sent or received) and after a timeout, the server is idle; a server has a
///   deadline exactly while a transfer is in progress.
pub fn sdo_server(data: &[u8]) {
    let mut server = SdoServer::<BUFFER>::new(TIMEOUT);
    let mut model = Model::new();
    let mut now = Instant::ZERO;
    let mut r = Reader::new(data);
    let mut steps = 0;
    while !r.is_empty() && steps < 2000 {
        steps += 1;
        match r.u8() % 4 {
            tag @ (0 | 1) => {
                let frame: Vec<u8> = if tag == 0 {
                    let command = COMMANDS[usize::from(r.u8()) % COMMANDS.len()];
                    let (index, sub) = MUXES[usize::from(r.u8()) % MUXES.len()];
                    let [lo, hi] = index.to_le_bytes();
                    let tail = r.bytes(4);
                    [command, lo, hi, sub, tail[0], tail[1], tail[2], tail[3]].to_vec()
                } else {
                    let len = usize::from(r.u8() % 10);
                    r.bytes(len)
                };
                let writes = model.writes.len();
                let response = server.on_request(&frame, now, &mut model);
                let written = model.writes.len() - writes;
                assert!(written <= 1, "{written} writes for one request {frame:02X?}");
                let aborted = response.is_some_and(|r| r[0] == 0x80);
                if written == 1 {
                    assert!(response.is_some() && !aborted, "a write answered with {response:02X?}");
                }
                let abort_received = frame.len() == 8 && frame[0] == 0x80;
                if aborted || abort_received {
                    assert!(server.is_idle(), "not idle after an abort");
                }
                if abort_received {
                    assert!(response.is_none(), "an abort answered with {response:02X?}");
                }
                drain(&mut server, &mut model, now);
            }
            2 => {
                now = now + Duration::from_millis(u64::from(r.u16()));
                drain(&mut server, &mut model, now);
            }
            _ => drain(&mut server, &mut model, now),
        }
        assert!(model.violations.is_empty(), "{:?}", model.violations);
        assert_eq!(
            server.is_idle(),
            server.deadline().is_none(),
            "deadline without a transfer or vice versa"
        );
    }
}

/// Client command bytes the structured requests start with.
const COMMANDS: [u8; 24] = [
    0x40, 0x23, 0x27, 0x2B, 0x2F, 0x22, 0x21, 0x20, 0x00, 0x10, 0x01, 0x11, 0x60, 0x70, 0xA4, 0xA0, 0xA3,
    0xA2, 0xA1, 0xC6, 0xC2, 0xC1, 0xC0, 0x80,
];
const TIMEOUT: Duration = Duration::from_millis(1000);

/// Polls the server until it has nothing more to send; checks what it sends on its own.
fn drain(server: &mut SdoServer<BUFFER>, model: &mut Model, now: Instant) {
    let expired = server.deadline().is_some_and(|d| now >= d);
    let mut segments = 0;
    let mut timeouts = 0;
    while let Some(frame) = server.poll(now, model) {
        if frame[0] == 0x80 {
            assert_eq!(frame[4..], 0x0504_0000u32.to_le_bytes(), "poll sent abort {frame:02X?}");
            timeouts += 1;
        } else {
            segments += 1;
        }
        assert!(segments <= 127 && timeouts <= 1, "poll keeps sending: {frame:02X?}");
    }
    if timeouts == 1 {
        assert!(expired, "timeout abort before the deadline");
        assert!(server.is_idle(), "not idle after a timeout");
    }
}
