//! Checks of the invariants the core promises (energy only in the enabled states, demands within
//! the configured limits, a consistent dictionary, one SDO answer per request) for fuzz targets and robustness tests, written against the
//! public API of `canopen-drive` only (an independent second reading of the rules, not a call
//! into the code under test where that can be avoided).
//!
//! - [`check_dictionary`]: invariant 3, "the object dictionary is not corrupted": every value
//!   has its type's size and lies within its type and declared limits, strings fit their
//!   capacity, the value rules of the profile and communication objects hold (modes 6502h
//!   lists, option codes the configuration supports, no zero factor, valid 1029h/1019h values,
//!   no heartbeat consumer twice for one node), and every valid PDO has a mapping that
//!   resolves.
//! - [`check_energy`]: invariant 1, energy only in Operation enabled, Quick stop active and
//!   Fault reaction active.
//! - [`DemandWatch`]: invariant 2 for velocity and torque: a velocity set-point within
//!   min(607Fh, 6080h) in increments/s (through the factor group) or ramping down to it, a
//!   torque set-point within min(6072h, 6073h); the same for the feed-forward; and for
//!   position: outside homing, a position set-point never moves out of the software position
//!   limits 607Dh (corrected by the home offset 607Ch), nor further out than it or the axis was.
//! - [`SdoWatch`]: at most one SDO answer per request.
//!
//! Each check returns `Err(description)` on the first violation found, so a fuzz target can
//! `panic!` with it and a test can `assert!` on it.

use canopen_drive::cia402::factor::Factors;
use canopen_drive::cia402::fsa::State;
use canopen_drive::cia402::objects::{
    HOME_OFFSET, MAX_CURRENT, MAX_MOTOR_SPEED, MAX_PROFILE_VELOCITY, MAX_TORQUE, MODES_OF_OPERATION_DISPLAY,
    POSITION_ACTUAL_INTERNAL_VALUE, POSITION_ACTUAL_VALUE, POSITION_RANGE_LIMIT, SOFTWARE_POSITION_LIMIT,
    STATUSWORD,
};
use canopen_drive::cia402::ProfileConfig;
use canopen_drive::comm::error_control::ErrorBehaviour;
use canopen_drive::hal::{Demand, Sample, Setpoint};
use canopen_drive::od::{le_u32, DataType, Dictionary, Entry, PdoMapping};
use canopen_drive::wire::cob_id::{self, CobId};

/// The first index of the data-record objects of ip (60C0h–60C4h), whose value rules depend
/// on the state of the input buffer (not visible from the dictionary).
const IP_OBJECTS: core::ops::RangeInclusive<u16> = 0x60C0..=0x60C4;

/// The whole value of `entry` as the SDO server would upload it.
pub fn value_bytes<const B: usize>(od: &Dictionary<B>, entry: &Entry) -> Vec<u8> {
    let mut bytes = vec![0u8; od.value_len(entry)];
    let n = od.read(entry, 0, &mut bytes);
    bytes.truncate(n);
    bytes
}

/// Every entry of every object of `od`, in ascending order (index, sub).
pub fn entries<const B: usize>(od: &Dictionary<B>) -> Vec<Entry> {
    let mut out = Vec::new();
    for object in od.objects() {
        for sub in 0..=object.highest_sub() {
            if object.sub(sub).is_some() {
                if let Ok(entry) = od.entry(object.index, sub) {
                    out.push(entry);
                }
            }
        }
    }
    out
}

/// Invariant 3: the dictionary is internally consistent (see the [module docs](self)).
/// `profile` is the drive's [`ProfileConfig`] (the option codes it supports).
pub fn check_dictionary<const B: usize>(od: &Dictionary<B>, profile: &ProfileConfig) -> Result<(), String> {
    check_entries(od, &entries(od), profile)
}

/// [`check_dictionary`] with the entries resolved once ([`entries`] of the same dictionary):
/// for checks after every step of a fuzz run.
pub fn check_entries<const B: usize>(
    od: &Dictionary<B>,
    entries: &[Entry],
    profile: &ProfileConfig,
) -> Result<(), String> {
    check_values(od, entries, profile)?;
    check_pdos(od)?;
    check_heartbeat_consumers(od)
}

/// The part of [`check_entries`] that looks at each of `entries` alone (type, size, limits,
/// value rules), without the checks across entries ([`check_pdos`],
/// [`check_heartbeat_consumers`]): for a fuzz rig that re-checks only the entries that changed
/// since its last check.
pub fn check_values<const B: usize>(
    od: &Dictionary<B>,
    entries: &[Entry],
    profile: &ProfileConfig,
) -> Result<(), String> {
    for entry in entries {
        let (index, sub, var) = (entry.index(), entry.sub, entry.var);
        // Fixed-size values are read into a stack buffer (this runs after every fuzz step).
        let mut small = [0u8; 8];
        let len = od.value_len(entry);
        let bytes = match var.data_type.fixed_size() {
            Some(size) if size <= small.len() => {
                let n = od.read(entry, 0, &mut small);
                small.get(..n).unwrap_or(&[])
            }
            _ => &[][..],
        };
        let at = || format!("{index:04X}sub{sub} ({}) = {bytes:02X?}", var.name());
        match var.data_type.fixed_size() {
            Some(size) if len != size => {
                return Err(format!("{}: {len} bytes, its type has {size}", at()));
            }
            Some(_) => {
                od.check_write(entry, bytes)
                    .map_err(|code| format!("{}: outside its type or limits ({code:?})", at()))?;
            }
            None if !var.is_fixed() && len > usize::from(var.capacity) => {
                return Err(format!("{}: {len} bytes, longer than its capacity {}", at(), var.capacity));
            }
            None => {}
        }
        check_value_rules(od, profile, entry, bytes).map_err(|why| format!("{}: {why}", at()))?;
    }
    Ok(())
}

/// The value rules beyond type and limits that an SDO write must pass, for values at rest.
fn check_value_rules<const B: usize>(
    od: &Dictionary<B>,
    profile: &ProfileConfig,
    entry: &Entry,
    bytes: &[u8],
) -> Result<(), String> {
    let index = entry.index();
    let raw = le_u32(bytes);
    match index {
        0x1019 if raw == 1 || raw > 240 => Err("synchronous counter overflow 1 or above 240".into()),
        0x1029 if ErrorBehaviour::from_value(raw as u8).is_none() => Err("reserved error behaviour".into()),
        0x6000..=0x67FF if entry.var.access.writable() && !IP_OBJECTS.contains(&index) => {
            canopen_drive::cia402::registry::check_write(od, profile, index, entry.sub, bytes)
                .map_err(|code| format!("refused by the profile's value rules ({code:?})"))
        }
        _ => Ok(()),
    }
}

/// Every valid PDO has a COB-ID outside the restricted range, an allowed transmission type and
/// a mapping that resolves: at most 8 entries, each mappable in its direction with its exact
/// size (or a dummy entry, or one bit of a BOOLEAN), at most 64 bits.
pub fn check_pdos<const B: usize>(od: &Dictionary<B>) -> Result<(), String> {
    for object in od.objects() {
        let index = object.index;
        let rpdo = match index {
            0x1400..=0x15FF => true,
            0x1800..=0x19FF => false,
            _ => continue,
        };
        let raw = od.get::<u32>(index, 1).map_err(|c| format!("{index:04X}sub1: {c:?}"))?;
        let cob =
            CobId::parse(raw).map_err(|e| format!("{index:04X}sub1 = {raw:08X}: unparsable ({e:?})"))?;
        if !cob.valid {
            continue;
        }
        // Without a node-ID the `$NODEID` defaults mean nothing until LSS gives one (and the
        // node runs no PDO meanwhile).
        if cob_id::is_restricted(cob.can_id) && (1..=127).contains(&od.node_id()) {
            return Err(format!("{index:04X}: valid PDO on restricted CAN-ID {:03X}", cob.can_id));
        }
        let transmission = od.get::<u8>(index, 2).unwrap_or(0);
        let allowed = match transmission {
            0..=240 | 254 | 255 => true,
            252 | 253 => !rpdo,
            _ => false,
        };
        if !allowed {
            return Err(format!("{index:04X}: transmission type {transmission}"));
        }
        let mapping = index + 0x200;
        let count = od.get::<u8>(mapping, 0).map_err(|c| format!("{mapping:04X}sub0: {c:?}"))?;
        if count > 8 {
            return Err(format!("{mapping:04X}: {count} entries in a valid PDO"));
        }
        let mut bits = 0u32;
        for sub in 1..=count {
            let raw = od.get::<u32>(mapping, sub).map_err(|c| format!("{mapping:04X}sub{sub}: {c:?}"))?;
            let length = mapped_bits(od, raw, rpdo)
                .map_err(|why| format!("{mapping:04X}sub{sub} = {raw:08X} in a valid PDO: {why}"))?;
            bits += length;
        }
        if bits > 64 {
            return Err(format!("{mapping:04X}: {bits} bits mapped in a valid PDO"));
        }
    }
    Ok(())
}

/// The bit length of one mapping entry, if it can be mapped.
fn mapped_bits<const B: usize>(od: &Dictionary<B>, raw: u32, rpdo: bool) -> Result<u32, String> {
    let index = (raw >> 16) as u16;
    let sub = (raw >> 8) as u8;
    let bits = raw & 0xFF;
    if (1..=7).contains(&index) {
        let size = match index {
            1 => 1,
            2 | 5 => 8,
            3 | 6 => 16,
            _ => 32,
        };
        return if sub == 0 && bits == size { Ok(bits) } else { Err("bad dummy entry".into()) };
    }
    let entry = od.entry(index, sub).map_err(|c| format!("maps a missing entry ({c:?})"))?;
    let var = entry.var;
    let direction = if rpdo {
        matches!(var.pdo, PdoMapping::Rpdo | PdoMapping::Both) && var.access.writable()
    } else {
        matches!(var.pdo, PdoMapping::Tpdo | PdoMapping::Both) && var.access.readable()
    };
    if !direction {
        return Err("entry not mappable in this direction".into());
    }
    let size = var.data_type.fixed_size().map(|n| n as u32 * 8);
    if size != Some(bits) && !(var.data_type == DataType::Boolean && bits == 1) {
        return Err(format!("length {bits} does not fit the entry's type"));
    }
    Ok(bits)
}

/// No two entries of 1016h supervise the same node.
pub fn check_heartbeat_consumers<const B: usize>(od: &Dictionary<B>) -> Result<(), String> {
    let Ok(count) = od.get::<u8>(0x1016, 0) else { return Ok(()) };
    let mut seen = std::collections::BTreeSet::new();
    for sub in 1..=count {
        let raw = od.get::<u32>(0x1016, sub).unwrap_or(0);
        let node = (raw >> 16) & 0xFF;
        let time = raw & 0xFFFF;
        if node == 0 || node > 127 || time == 0 {
            continue;
        }
        if !seen.insert(node) {
            return Err(format!("1016h: node {node} supervised twice"));
        }
    }
    Ok(())
}

/// Invariant 1: energy reaches the motor only in Operation enabled, Quick stop active and
/// Fault reaction active.
pub fn check_energy(state: State, demand: &Demand) -> Result<(), String> {
    let allowed =
        matches!(state, State::OperationEnabled { .. } | State::QuickStopActive | State::FaultReactionActive);
    if demand.drive_enabled && !allowed {
        return Err(format!("drive function enabled in {state:?}: {demand:?}"));
    }
    Ok(())
}

/// The statusword (6041h) reports `state` (after a tick).
pub fn check_statusword<const B: usize>(od: &Dictionary<B>, state: State) -> Result<(), String> {
    let statusword = od.get::<u16>(STATUSWORD, 0).map_err(|c| format!("6041h: {c:?}"))?;
    if statusword & 0x006F != state.statusword_bits() & 0x006F {
        return Err(format!("statusword {statusword:04X} does not report {state:?}"));
    }
    Ok(())
}

/// The limits a demand must respect, as the dictionary says now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DemandLimits {
    /// min(607Fh, 6080h), increments/s.
    pub velocity: u32,
    /// min(6072h, 6073h), ‰.
    pub torque: u16,
    /// The software position limits, while they apply to a position set-point.
    pub position: Option<PositionLimits>,
}

/// The software position limits 607Dh as they apply to a position set-point now: in user units,
/// corrected by the home offset (607Dh sub 1/2 − 607Ch), with what turns a set-point in
/// increments into user units.
///
/// They apply while they are on (corrected min ≤ max), outside homing (6061h ≠ 6: homing
/// searches the reference the limits are relative to) and on a linear axis (607Bh off: on a
/// modulo axis positions wrap).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PositionLimits {
    /// Corrected minimum, user units.
    pub low: i64,
    /// Corrected maximum, user units.
    pub high: i64,
    /// 6063h after the tick: the encoder count the sample gave.
    actual_internal: i32,
    /// 6064h after the tick: the same position in user units.
    actual_user: i64,
    factors: Factors,
}

impl PositionLimits {
    /// The limits `od` configures (the axis's position not filled in yet: see
    /// [`DemandLimits::at`]), if they are on on a linear axis.
    fn configured<const B: usize>(od: &Dictionary<B>) -> Option<Self> {
        let get = |index: u16, sub: u8| od.get::<i32>(index, sub).ok().map(i64::from);
        if let (Some(min), Some(max)) = (get(POSITION_RANGE_LIMIT, 1), get(POSITION_RANGE_LIMIT, 2)) {
            if min < max {
                return None;
            }
        }
        let offset = get(HOME_OFFSET, 0).unwrap_or(0);
        let low = get(SOFTWARE_POSITION_LIMIT, 1)? - offset;
        let high = get(SOFTWARE_POSITION_LIMIT, 2)? - offset;
        (low <= high).then_some(PositionLimits {
            low,
            high,
            actual_internal: 0,
            actual_user: 0,
            factors: Factors::from_od(od),
        })
    }

    /// A position in increments in user units, measured from the actual position (so that the
    /// origin the drive chose by homing or by a preset needs no knowing).
    pub fn to_user(&self, internal: i32) -> i64 {
        let from_actual = i64::from(internal.wrapping_sub(self.actual_internal));
        self.actual_user + self.factors.position_sign() * self.factors.to_user(from_actual)
    }

    /// How far `user` lies outside the limits (0 within).
    pub fn beyond(&self, user: i64) -> i64 {
        (self.low - user).max(user - self.high).max(0)
    }
}

impl DemandLimits {
    /// The limits of `od` ([`Self::configured`] [`at`](Self::at) the axis's state now).
    pub fn of<const B: usize>(od: &Dictionary<B>) -> Self {
        Self::configured(od).at(od)
    }

    /// The limits the parameters of `od` configure: they change only when a parameter does,
    /// so a caller that knows none changed may keep them and only call [`Self::at`] each tick.
    pub fn configured<const B: usize>(od: &Dictionary<B>) -> Self {
        let factors = Factors::from_od(od);
        let max_profile = od.get::<u32>(MAX_PROFILE_VELOCITY, 0).unwrap_or(u32::MAX);
        let max_motor = od.get::<u32>(MAX_MOTOR_SPEED, 0).unwrap_or(u32::MAX);
        let velocity = factors.limit_to_internal(max_profile).min(factors.rpm_to_internal(max_motor));
        let torque = od
            .get::<u16>(MAX_TORQUE, 0)
            .unwrap_or(u16::MAX)
            .min(od.get::<u16>(MAX_CURRENT, 0).unwrap_or(u16::MAX));
        DemandLimits { velocity, torque, position: PositionLimits::configured(od) }
    }

    /// The configured limits as they apply in the axis's state after a tick: the software
    /// position limits not while homing (6061h), and measured from the actual position
    /// (6063h, 6064h).
    pub fn at<const B: usize>(self, od: &Dictionary<B>) -> Self {
        let homing = od.get::<i8>(MODES_OF_OPERATION_DISPLAY, 0) == Ok(6);
        let actual = od
            .get::<i32>(POSITION_ACTUAL_INTERNAL_VALUE, 0)
            .ok()
            .zip(od.get::<i32>(POSITION_ACTUAL_VALUE, 0).ok());
        let position = match (self.position, actual) {
            (Some(limits), Some((internal, user))) if !homing => {
                Some(PositionLimits { actual_internal: internal, actual_user: i64::from(user), ..limits })
            }
            _ => None,
        };
        DemandLimits { position, ..self }
    }
}

/// Invariant 2 for velocity and torque, tick by tick (see [`DemandWatch::check`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DemandWatch {
    previous: Option<Demand>,
}

impl DemandWatch {
    /// Checks the demand of one tick against the limits the dictionary holds after it, with the
    /// sample the tick was given:
    ///
    /// - a torque set-point and the torque feed-forward lie within min(6072h, 6073h): a torque
    ///   limit is a hard limit, lowered or not;
    /// - a velocity set-point and the velocity feed-forward lie within min(607Fh, 6080h), or,
    ///   when the master lowered the limit below the running velocity, they come down to it and
    ///   never rise above both their previous value and the actual velocity: the deceleration
    ///   limits (6084h, 60C6h) also hold, so a drop to the new limit takes a ramp;
    /// - a position set-point lies within the software position limits ([`PositionLimits`]), or
    ///   no further beyond them than the previous position set-point or the axis (limits
    ///   narrowed under a standing axis, an axis pushed out): it may stay or come back, never
    ///   leave. One user unit of rounding is allowed (a target converted to increments and back).
    pub fn check(&mut self, demand: &Demand, limits: DemandLimits, sample: &Sample) -> Result<(), String> {
        let previous = self.previous.replace(*demand);
        let vmax = u64::from(limits.velocity);
        let actual = u64::from(sample.velocity.unsigned_abs());
        let velocity_ok = |now: i32, before: Option<i32>| {
            let now = u64::from(now.unsigned_abs());
            now <= vmax || now <= actual.max(before.map_or(0, |b| u64::from(b.unsigned_abs())))
        };
        let torque_ok = |t: i16| t.unsigned_abs() <= limits.torque;
        let previous_velocity = previous.and_then(|p| match p.setpoint {
            Setpoint::Velocity(v) => Some(v),
            _ => None,
        });
        let setpoint_ok = match demand.setpoint {
            Setpoint::Velocity(v) => velocity_ok(v, previous_velocity),
            Setpoint::Torque(t) => torque_ok(t),
            Setpoint::Position(p) => limits.position.is_none_or(|limits| {
                let before = match previous.map(|p| p.setpoint) {
                    Some(Setpoint::Position(q)) => limits.beyond(limits.to_user(q)),
                    _ => 0,
                };
                let allowed = before.max(limits.beyond(limits.actual_user)).saturating_add(1);
                limits.beyond(limits.to_user(p)) <= allowed
            }),
            Setpoint::None => true,
        };
        if !setpoint_ok {
            return Err(format!(
                "{:?} beyond {limits:?} (previous {:?}, actual velocity {})",
                demand.setpoint,
                previous.map(|p| p.setpoint),
                sample.velocity
            ));
        }
        let feed_forward = demand.feed_forward;
        let previous_feed_forward = previous.map(|p| p.feed_forward.velocity);
        if !velocity_ok(feed_forward.velocity, previous_feed_forward) || !torque_ok(feed_forward.torque) {
            return Err(format!("feed-forward {feed_forward:?} beyond {limits:?}"));
        }
        Ok(())
    }
}

/// Counts the answers of an SDO server to each request: a request may get at most one answer,
/// except the requests after which the server sends a block-upload sub-block (start `A3`, and
/// an acknowledgement `A2` that asks for the next one; with any value of the bits CiA 301
/// leaves unused, 4–2, which a server ignores).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SdoWatch {
    /// The last request may be answered by a sub-block.
    block: bool,
    answers: usize,
    timed_out: bool,
    requests: usize,
    total_answers: usize,
}

impl SdoWatch {
    /// A request was sent (its data).
    pub fn request(&mut self, data: &[u8]) {
        self.block = data.first().is_some_and(|b| matches!(b & 0xE3, 0xA3 | 0xA2));
        self.answers = 0;
        self.timed_out = false;
        self.requests += 1;
    }

    /// The server answered (frames on its response channel since the request).
    pub fn answered(&mut self, frames: usize) -> Result<(), String> {
        self.answers += frames;
        self.total_answers += frames;
        if self.answers > 1 && !self.block {
            return Err(format!("{} SDO answers to one request", self.answers));
        }
        Ok(())
    }

    /// The server sent `data` on its own (from `poll`, not in reaction to a request): only
    /// block-upload segments after a block request, or one timeout abort (0x0504_0000) per
    /// transfer.
    pub fn unsolicited(&mut self, data: &[u8]) -> Result<(), String> {
        let timeout = data.len() == 8
            && data.first() == Some(&0x80)
            && le_u32(data.get(4..).unwrap_or(&[])) == 0x0504_0000;
        if timeout && !std::mem::replace(&mut self.timed_out, true) {
            self.block = false;
            return Ok(());
        }
        if self.block && !timeout {
            self.total_answers += 1;
            return Ok(());
        }
        Err(format!("unsolicited SDO frame {data:02X?}"))
    }

    /// Requests and answers so far.
    pub fn counts(&self) -> (usize, usize) {
        (self.requests, self.total_answers)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block-upload start with the unused bits set (`AF`, found by `drive_frames`) is still a
    /// start: the server answers it with a whole sub-block, as it does `A3`. Any other request
    /// gets one answer.
    #[test]
    fn a_sub_block_answers_a_start_whatever_its_unused_bits() {
        let mut watch = SdoWatch::default();
        for start in [0xA3u8, 0xAF, 0xA2, 0xBE] {
            watch.request(&[start, 0, 0, 0, 0, 0, 0, 0]);
            assert_eq!(watch.answered(2), Ok(()), "{start:02X}");
        }
        watch.request(&[0x40, 0x08, 0x10, 0, 0, 0, 0, 0]);
        assert!(watch.answered(2).is_err());
    }
}
