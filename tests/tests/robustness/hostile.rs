//! Item 4: hostile configuration. Every writable entry of the drive's dictionary — found by
//! walking the dictionary's own metadata (`Drive::od().objects()`), so a new object is covered
//! the day it is added — is written with boundary values of its type and declared limits (0, 1,
//! −1, min, max, limit ± 1, max + 1 as one byte too many, one byte too few, NaN and ∞ for reals,
//! empty / full / over-full strings) in six drive states, on a fresh drive per entry and state:
//!
//! - the answer is exactly one: success, or an abort whose code is the precise one where the
//!   metadata decides it (0601_0002h read only, 0800_0022h not in Operational, 0607_0012h /
//!   0607_0013h length, 0609_0031h / 0609_0032h outside the declared limits, 0609_0030h NaN), and
//!   otherwise one of the codes of a value rule;
//! - in NMT Stopped there is no answer and the dictionary does not change;
//! - an accepted value reads back as written (but for the command objects);
//! - no panic, the invariants hold at every tick after the write, and the dictionary is
//!   consistent afterwards (invariant 3).

use std::collections::BTreeMap;

use canopen_drive::cia402::fsa::State;
use canopen_drive::hal::HardwareFaults;
use canopen_drive::od::{Bound, DataType, Entry, WriteRule};
use canopen_drive::{AbortCode, Instant};
use canopen_drive_sim::invariants;

use super::board::{Answer, Board, VALUE_RULE_CODES};
use super::report::{Notes, Scenario};
use crate::common::NODE;

pub const SCENARIOS: [Scenario; 1] = [Scenario {
    name: "Every writable entry, boundary values, six states",
    checks: "NMT Pre-operational and Operational × FSA Switch on disabled, Operation enabled (pv turning), \
             Quick stop active, Fault, and NMT Stopped: exactly one answer with the precise abort code, \
             read-back of accepted values, invariants at every tick, dictionary consistent afterwards",
    run: walk,
}];

/// Drive states the writes are made in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Situation {
    PreOperational,
    OperationalSwitchOnDisabled,
    OperationEnabled,
    QuickStopActive,
    Fault,
    Stopped,
}

const SITUATIONS: [Situation; 6] = [
    Situation::PreOperational,
    Situation::OperationalSwitchOnDisabled,
    Situation::OperationEnabled,
    Situation::QuickStopActive,
    Situation::Fault,
    Situation::Stopped,
];

/// A fresh drive in `situation`.
fn prepare(situation: Situation) -> (Board, Instant) {
    let mut board = Board::new(Instant::ZERO, 1000);
    let mut next_tick = board.now;
    let cw = |board: &mut Board, next_tick: &mut Instant, value: u16| {
        board.sdo(0x6040, 0, &value.to_le_bytes());
        board.advance_ms(3, next_tick);
    };
    if situation != Situation::PreOperational {
        board.frame(0x000, &[0x01, NODE]);
    }
    match situation {
        Situation::OperationEnabled | Situation::QuickStopActive | Situation::Fault => {
            board.sdo(0x605A, 0, &6i16.to_le_bytes());
            board.sdo(0x6085, 0, &10_000_000u32.to_le_bytes());
            board.sdo(0x6060, 0, &[3]);
            for value in [0x06, 0x07, 0x0F] {
                cw(&mut board, &mut next_tick, value);
            }
            board.sdo(0x60FF, 0, &5_000i32.to_le_bytes());
            board.advance_ms(20, &mut next_tick);
            assert!(matches!(board.drive.state(), State::OperationEnabled { .. }));
            if situation == Situation::QuickStopActive {
                cw(&mut board, &mut next_tick, 0x02);
                board.advance_ms(20, &mut next_tick);
                assert_eq!(board.drive.state(), State::QuickStopActive);
            }
            if situation == Situation::Fault {
                board.motor.inject_fault(HardwareFaults::OVER_TEMPERATURE);
                board.advance_ms(20, &mut next_tick);
                assert_eq!(board.drive.state(), State::Fault);
            }
        }
        Situation::Stopped => board.frame(0x000, &[0x02, NODE]),
        _ => {}
    }
    board.sent.clear();
    // The walk writes the factor group, the home offset and the polarity.
    board.user_units_are_increments = false;
    (board, next_tick)
}

/// A value to write and the code the metadata alone says it gets (`None`: the value passes
/// size and limits; a value rule may still refuse it).
struct Probe {
    label: String,
    bytes: Vec<u8>,
    expected: Option<AbortCode>,
}

fn in_limits_signed(entry: &Entry, v: i128) -> Option<AbortCode> {
    match (entry.var.low(), entry.var.high()) {
        (Bound::Signed(low), _) if v < i128::from(low) => Some(AbortCode::ValueTooLow),
        (_, Bound::Signed(high)) if v > i128::from(high) => Some(AbortCode::ValueTooHigh),
        _ => None,
    }
}

fn in_limits_unsigned(entry: &Entry, v: u128) -> Option<AbortCode> {
    if entry.var.data_type == DataType::Boolean && v > 1 {
        return Some(AbortCode::ValueTooHigh);
    }
    match (entry.var.low(), entry.var.high()) {
        (Bound::Unsigned(low), _) if v < u128::from(low) => Some(AbortCode::ValueTooLow),
        (_, Bound::Unsigned(high)) if v > u128::from(high) => Some(AbortCode::ValueTooHigh),
        _ => None,
    }
}

/// The boundary values of `entry`'s type and limits.
fn probes(entry: &Entry) -> Vec<Probe> {
    let var = entry.var;
    let ty = var.data_type;
    let mut out = Vec::new();
    let Some(n) = ty.fixed_size() else {
        // Strings and DOMAIN: empty, one byte, full, one byte over.
        let capacity = usize::from(var.capacity);
        for (label, len) in [("empty", 0), ("1 byte", 1), ("full", capacity), ("capacity + 1", capacity + 1)]
        {
            let expected = if len > capacity { Some(AbortCode::LengthTooHigh) } else { None };
            out.push(Probe { label: label.into(), bytes: vec![b'x'; len], expected });
        }
        return out;
    };
    let bits = 8 * n as u32;
    let le = |v: u128| v.to_le_bytes()[..n].to_vec();
    if ty.is_signed() {
        let min = -(1i128 << (bits - 1));
        let max = (1i128 << (bits - 1)) - 1;
        let mut values = vec![("0", 0i128), ("1", 1), ("-1", -1), ("min", min), ("max", max)];
        if let Bound::Signed(low) = var.low() {
            values.push(("low", i128::from(low)));
            if i128::from(low) > min {
                values.push(("low - 1", i128::from(low) - 1));
            }
        }
        if let Bound::Signed(high) = var.high() {
            values.push(("high", i128::from(high)));
            if i128::from(high) < max {
                values.push(("high + 1", i128::from(high) + 1));
            }
        }
        for (label, v) in values {
            out.push(Probe {
                label: format!("{label} ({v})"),
                bytes: le(v as u128),
                expected: in_limits_signed(entry, v),
            });
        }
    } else if ty.is_unsigned() {
        let max = if bits >= 128 { u128::MAX } else { (1u128 << bits) - 1 };
        let mut values = vec![("0", 0u128), ("1", 1), ("2", 2), ("max", max)];
        if let Bound::Unsigned(low) = var.low() {
            values.push(("low", u128::from(low)));
            if low > 0 {
                values.push(("low - 1", u128::from(low) - 1));
            }
        }
        if let Bound::Unsigned(high) = var.high() {
            values.push(("high", u128::from(high)));
            if u128::from(high) < max {
                values.push(("high + 1", u128::from(high) + 1));
            }
        }
        for (label, v) in values {
            out.push(Probe {
                label: format!("{label} ({v})"),
                bytes: le(v),
                expected: in_limits_unsigned(entry, v),
            });
        }
    } else if ty == DataType::Real32 {
        for (label, v) in
            [("0.0", 0.0f32), ("1.0", 1.0), ("-1.0", -1.0), ("inf", f32::INFINITY), ("max", f32::MAX)]
        {
            out.push(Probe { label: label.into(), bytes: v.to_le_bytes().to_vec(), expected: None });
        }
        out.push(Probe {
            label: "NaN".into(),
            bytes: f32::NAN.to_le_bytes().to_vec(),
            expected: Some(AbortCode::InvalidValue),
        });
    } else {
        // REAL64, TIME_OF_DAY, TIME_DIFFERENCE: all zeros, all ones.
        out.push(Probe { label: "zeros".into(), bytes: vec![0; n], expected: None });
        out.push(Probe {
            label: "ones".into(),
            bytes: vec![0xFF; n],
            expected: if ty == DataType::Real64 { Some(AbortCode::InvalidValue) } else { None },
        });
    }
    // max + 1: one byte more than the type has; and one byte less.
    let mut long = vec![0u8; n];
    long.push(1);
    out.push(Probe {
        label: "max + 1 (a byte too many)".into(),
        bytes: long,
        expected: Some(AbortCode::LengthTooHigh),
    });
    if n > 1 {
        out.push(Probe {
            label: "a byte too few".into(),
            bytes: vec![0; n - 1],
            expected: Some(AbortCode::LengthTooLow),
        });
    }
    out
}

/// Entries whose read value is not what was written, by design.
fn reads_differently(index: u16, sub: u8) -> bool {
    match index {
        // Store/restore commands: the read value is the capability, the write a signature.
        0x1010 | 0x1011 => true,
        // The ip buffer's clear command and data records are consumed by the buffer.
        0x60C1 => true,
        0x60C4 => sub == 6,
        _ => false,
    }
}

#[derive(Default)]
struct Tally {
    writes: usize,
    accepted: usize,
    aborts: BTreeMap<u32, usize>,
    silent: usize,
}

fn walk(notes: &mut Notes) {
    let (reference, _) = prepare(Situation::PreOperational);
    let entries = invariants::entries(reference.drive.od());
    let writable: Vec<Entry> = entries.iter().copied().filter(|e| e.var.access.writable()).collect();
    let objects: std::collections::BTreeSet<u16> = writable.iter().map(|e| e.index()).collect();
    let mut failures = Vec::new();
    let mut tallies: BTreeMap<Situation, Tally> = BTreeMap::new();
    let mut total = 0usize;
    for situation in SITUATIONS {
        let tally = tallies.entry(situation).or_default();
        // Also every read-only entry once: refused with 0601_0002h.
        for entry in
            entries.iter().filter(|e| e.var.access.writable() || situation == Situation::PreOperational)
        {
            let index = entry.index();
            let sub = entry.sub;
            // A fresh drive per entry; its probes one after the other.
            let (mut board, mut next_tick) = prepare(situation);
            for probe in probes(entry) {
                let operational =
                    matches!(board.drive.nmt_state(), canopen_drive::comm::NmtState::Operational);
                let before: Vec<Vec<u8>> =
                    entries.iter().map(|e| invariants::value_bytes(board.drive.od(), e)).collect();
                let answer = board.download(index, sub, &probe.bytes);
                tally.writes += 1;
                total += 1;
                // The precise code where the metadata decides it, in the server's order.
                let fixed = if !entry.var.access.writable() {
                    Some(AbortCode::WriteOfReadOnly)
                } else if entry.var.rule == WriteRule::NotOperational && operational {
                    Some(AbortCode::CannotStoreDeviceState)
                } else {
                    probe.expected
                };
                let what =
                    format!("{situation:?} {index:04X}sub{sub} ({}) <- {}", entry.var.name(), probe.label);
                let verdict = match (situation, answer, fixed) {
                    (Situation::Stopped, Answer::Silent, _) => Ok(()),
                    (Situation::Stopped, other, _) => Err(format!("answered {other:?} in Stopped")),
                    (_, Answer::Silent, _) => Err("no answer".to_string()),
                    (_, Answer::Done, None) => Ok(()),
                    (_, Answer::Done, Some(code)) => Err(format!("accepted, expected {code:?}")),
                    (_, Answer::Abort(got), Some(code)) if got == code.code() => Ok(()),
                    // Beyond the SDO buffer the server refuses before the dictionary looks.
                    (_, Answer::Abort(0x0504_0005), _)
                        if probe.bytes.len() > canopen_drive::drive::SDO_BUFFER =>
                    {
                        Ok(())
                    }
                    (_, Answer::Abort(got), Some(code)) => {
                        Err(format!("abort {got:08X}, expected {:08X}", code.code()))
                    }
                    (_, Answer::Abort(got), None) if VALUE_RULE_CODES.iter().any(|c| c.code() == got) => {
                        Ok(())
                    }
                    (_, Answer::Abort(got), None) => Err(format!("abort {got:08X} from no value rule")),
                };
                match answer {
                    Answer::Done => tally.accepted += 1,
                    Answer::Abort(code) => *tally.aborts.entry(code).or_default() += 1,
                    Answer::Silent => tally.silent += 1,
                }
                if let Err(why) = verdict {
                    failures.push(format!("{what}: {why}"));
                    continue;
                }
                if answer == Answer::Done && entry.var.access.readable() && !reads_differently(index, sub) {
                    let back = board.upload(index, sub);
                    if back.as_deref() != Ok(&probe.bytes[..]) {
                        failures.push(format!("{what}: reads back {back:02X?}"));
                    }
                }
                if situation == Situation::Stopped {
                    let after: Vec<Vec<u8>> =
                        entries.iter().map(|e| invariants::value_bytes(board.drive.od(), e)).collect();
                    // Only what the tick itself reports may change (nothing ticks here yet).
                    if after != before {
                        failures.push(format!("{what}: the dictionary changed in Stopped"));
                    }
                }
                // The drive lives on with the value: ticks with their invariants, then invariant 3.
                board.advance_ms(2, &mut next_tick);
                board.check_dictionary();
            }
        }
    }
    for (situation, t) in &tallies {
        let codes: Vec<String> = t.aborts.iter().map(|(c, n)| format!("{c:08X}×{n}")).collect();
        notes.note(format!(
            "{situation:?}: {} writes, {} accepted, {} unanswered, aborts {}",
            t.writes,
            t.accepted,
            t.silent,
            codes.join(" ")
        ));
    }
    notes.note(format!(
        "{total} writes to {} writable entries of {} objects (and every read-only entry once), a fresh drive per \
         entry and state",
        writable.len(),
        objects.len()
    ));
    assert!(
        failures.is_empty(),
        "{} findings, first: {:#?}",
        failures.len(),
        &failures[..failures.len().min(15)]
    );
}
