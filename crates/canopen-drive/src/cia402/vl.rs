//! Velocity mode (vl, 6060h = 2; CiA 402-2 §16, controlword §8.4.1): the frequency-inverter mode.
//!
//! ```text
//!  6042h ──× 604Bh──▶ reference ──▶ |v| into [6046h.1, 6046h.2] ──▶ ramp (6048h / 6049h / 604Ah)
//!  (set-point units)  (user units)   (sign kept, 0 stays 0)           │ ramp output (user units)
//!                                                                     ├──÷ 604Bh──▶ 6043h
//!                                                                     └──× 604Ch × 608Fh / 60──▶ demand
//!  actual velocity (increments/s) ──× 60 / 608Fh ÷ 604Ch ÷ 604Bh──▶ 6044h         (increments/s)
//! ```
//!
//! [`Velocity::tick`] runs this chain once per control tick; the profile calls it while vl is
//! the active mode in Operation enabled, [`Velocity::stop`] for its quick stop / slow-down
//! ramps, and [`Velocity::reset`] when the drive enters Operation enabled.
//!
//! # Units
//!
//! Three units meet here:
//!
//! - **Set-point units**: 6042h, 6043h and 6044h. One set-point unit is 604Bh.1 / 604Bh.2 user
//!   units (the set-point factor changes the resolution or range of the set-point only).
//! - **User units**: the min/max amount 6046h and the delta speeds of the ramps. One user unit
//!   is 604Ch.1 / 604Ch.2 rpm (the dimension factor); with the default 1/1 user units are rpm.
//!   The limit and the ramp work here, so the set-point factor does not change them.
//! - **Increments/s**: the velocity demand for the power stage and the actual velocity, through
//!   the caller's [`Resolution`] (608Fh: increments per motor revolution): `increments/s = rpm ×
//!   608Fh.1 / (60 × 608Fh.2)`.
//!
//! A factor of negative sign reverses the direction. A 0 in a factor (refused by
//! [`check_write`]) counts as 1.
//!
//! # Arithmetic
//!
//! The ramp output is an integer in 2⁻¹⁶ user units. Every conversion is a single
//! multiplication and division of 128-bit integers from that value, rounded to nearest with
//! halves away from zero, never fed back: a value converted twice gives the same result, and
//! the reference 6042h comes back as 6043h unchanged once the ramp has arrived. The ramp
//! advances by `delta speed × dt / delta time` per tick with the remainder carried in
//! 2⁻¹⁶ user unit·µs, so after `n` ticks of a constant slope it has moved exactly the floor of
//! the exact distance: no drift, whatever the tick rate. The remainder restarts when the slope
//! or the direction changes (a loss below 2⁻¹⁶ user units). 6043h and 6044h saturate to the
//! INTEGER16 range, the demand to i64. O(1) per tick.
//!
//! # Choices where the standard leaves room
//!
//! - **Min/max amount** (6046h): a non-zero reference keeps its sign and has its magnitude
//!   clamped into `[min, max]`; 0 stays 0 (the motor may stand still even with a minimum
//!   speed). With min above max, max wins. The caller's velocity limit (6080h/607Fh in
//!   increments/s, which every demand of the drive respects) is a second maximum, and the demand is clamped to it once
//!   more after conversion. [`Output::limit_active`] (statusword bit 11) reports a clamped
//!   reference.
//! - **Ramps**: moving away from 0 uses the acceleration 6048h, towards 0 the deceleration
//!   6049h. A reference on the other side of 0 is approached by decelerating to 0 first, then
//!   accelerating (the tick that reaches 0 ends there). **6049h with delta speed 0, or absent,
//!   means "as 6048h"** (CiA 402-2 §16): the default of 6049h is 0, so a master that
//!   sets only 6048h gets symmetric ramps. Likewise 604Ah with delta speed 0 or absent means
//!   "as the deceleration". An acceleration of 0 holds the ramp (it cannot speed up); a
//!   deceleration of 0 (only reachable when the firmware stores 0 in 6048h past
//!   [`check_write`]) stops at once rather than never.
//! - **Controlword** (CiA 402-2 §8.4.1), in this order of priority:
//!   - a stop requested by the profile ([`Velocity::stop`]) ramps to 0 whatever the bits say;
//!   - bit 4 = 0 (ramp function generator disabled): the velocity demand is **0 at once**, and
//!     the ramp generator is set to 0, so it restarts from standstill when bit 4 returns. This
//!     is the usual inverter practice; the motor brakes as hard as its velocity loop allows. A
//!     controlled stop is bit 6 = 0 or halt;
//!   - bit 8 = 1 (halt): the ramp runs to 0 with the ramp 605Dh selects (slow down → 6049h,
//!     quick stop / current limit / voltage limit → 604Ah), whatever bits 5 and 6 say; when
//!     released, the ramp accelerates back to the reference;
//!   - bit 5 = 0 (ramp locked): the ramp output stays where it is;
//!   - bit 6 = 0: the ramp input is 0, and the ramp output decelerates to 0 with 6049h;
//!   - otherwise the ramp follows the limited reference.
//! - **0x000F vs 0x007F**: this build implements bits 4–6 and honours them (CiA 402-2 §16),
//!   so a running vl drive needs controlword **0x007F**. A master that sends 0x000F gets a
//!   demand of 0 (bit 4 = 0): the motor is held at standstill under power, never started. For
//!   masters written for drives without these bits, [`Config::ramp_bits`] = false reads bits
//!   4–6 as 1, as such drives behave.
//! - **Statusword** (Fig. 57 is lost): [`Output::target_reached`] (bit 10) is 1 when the ramp
//!   output equals the ramp input — the limited reference, or 0 under halt, a stop, or bit 6 = 0.
//! - **Stops** ([`Velocity::stop`]): slow down → 6049h (or 6048h), quick stop ramp, current
//!   limit and voltage limit → 604Ah (the steepest vl ramp; this crate has no current or voltage
//!   loop of its own), coast → demand 0 at once (the profile also cuts the power stage).
//! - **Entering Operation enabled** ([`Velocity::reset`]): the ramp starts from the actual
//!   velocity, so a coasting motor is caught without a jump.
//!
//! # Objects
//!
//! [`OBJECTS`] lists them in index order (also one `pub const` per object for the profile's
//! table). Defaults, where the standard leaves them to the manufacturer:
//!
//! | object | default |
//! |---|---|
//! | 6042h target velocity | 0 |
//! | 6046h min / max amount | 0 / FFFF FFFFh (no limit of its own: 6080h governs) |
//! | 6048h acceleration | 1000 user units per 1 s |
//! | 6049h deceleration | 0 per 1 s (= as 6048h) |
//! | 604Ah quick stop | 5000 user units per 1 s |
//! | 604Bh set-point factor, 604Ch dimension factor | +1 / +1 |
//!
//! 6046h is an ARRAY in the standard; it is declared as a RECORD of the same layout (as 607Bh
//! and 607Dh are in [`super::objects`]) because its two entries need different defaults.
//!
//! [`check_write`] refuses a 0 in 604Bh/604Ch subs 1 and 2 with [`AbortCode::InvalidValue`]
//! (0 lies inside the signed range, so "too low" would mislead), and a delta time of 0 in
//! 6048h/6049h/604Ah or a delta speed of 0 in 6048h with [`AbortCode::ValueTooLow`] (the
//! bottom of an unsigned range, as for the factor group's ratios).

use super::fsa::StopKind;
use super::memo::Memo;
use super::objects::Rule;
use super::objects::POSITION_ENCODER_RESOLUTION;
use super::words::Controlword;
use super::Axis;
use crate::od::{AbortCode, Access, DataType, DefaultValue, Dictionary, Object, PdoMapping, Slot, Var};
use crate::time::Duration;

/// 6060h value of velocity mode.
pub const MODE: i8 = 2;
/// 6502h bit of velocity mode.
pub const MODE_BIT: u32 = 1 << 1;

/// 6042h vl target velocity (set-point units).
pub const VL_TARGET_VELOCITY: u16 = 0x6042;
/// 6043h vl velocity demand (set-point units).
pub const VL_VELOCITY_DEMAND: u16 = 0x6043;
/// 6044h vl velocity actual value (set-point units).
pub const VL_VELOCITY_ACTUAL_VALUE: u16 = 0x6044;
/// 6046h vl velocity min max amount (sub 1 min, sub 2 max; user units).
pub const VL_VELOCITY_MIN_MAX_AMOUNT: u16 = 0x6046;
/// 6048h vl velocity acceleration (sub 1 delta speed, sub 2 delta time in s).
pub const VL_VELOCITY_ACCELERATION: u16 = 0x6048;
/// 6049h vl velocity deceleration (sub 1 delta speed, sub 2 delta time in s).
pub const VL_VELOCITY_DECELERATION: u16 = 0x6049;
/// 604Ah vl velocity quick stop (sub 1 delta speed, sub 2 delta time in s).
pub const VL_VELOCITY_QUICK_STOP: u16 = 0x604A;
/// 604Bh vl set-point factor (sub 1 numerator, sub 2 denominator).
pub const VL_SET_POINT_FACTOR: u16 = 0x604B;
/// 604Ch vl dimension factor (sub 1 numerator, sub 2 denominator: rpm per user unit).
pub const VL_DIMENSION_FACTOR: u16 = 0x604C;

/// The controlword of a running vl drive, as a master writes it: enable operation with bits 4,
/// 5 and 6 set ([`Controlword::RAMP_FUNCTION_GENERATOR_ENABLE`] and the next two).
pub const RUN: u16 = 0x007F;
const RAMP_BITS: Controlword = Controlword::RAMP_FUNCTION_GENERATOR_ENABLE
    .union(Controlword::RAMP_UNLOCK)
    .union(Controlword::RAMP_REFERENCE);

/// One ramp slope (6048h, 6049h, 604Ah): `delta_speed` user units per `delta_time` seconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Slope {
    /// Sub 1: the speed change, user units.
    pub delta_speed: u32,
    /// Sub 2: the time it takes, s.
    pub delta_time: u16,
}

impl Slope {
    /// `delta_speed` user units per `delta_time` s.
    pub const fn new(delta_speed: u32, delta_time: u16) -> Self {
        Slope { delta_speed, delta_time }
    }
}

/// Default of 6046h sub 1.
pub const DEFAULT_MIN_AMOUNT: u32 = 0;
/// Default of 6046h sub 2: no limit of vl's own.
pub const DEFAULT_MAX_AMOUNT: u32 = u32::MAX;
/// Default of 6048h: 1000 user units (rpm) per second.
pub const DEFAULT_ACCELERATION: Slope = Slope::new(1000, 1);
/// Default of 6049h: delta speed 0, i.e. the deceleration is 6048h.
pub const DEFAULT_DECELERATION: Slope = Slope::new(0, 1);
/// Default of 604Ah: 5000 user units (rpm) per second.
pub const DEFAULT_QUICK_STOP: Slope = Slope::new(5000, 1);

const fn highest_sub_two() -> Var {
    Var::new("Highest sub-index supported", DataType::Unsigned8)
        .access(Access::Const)
        .default(DefaultValue::Unsigned(2))
}

const fn amount(name: &'static str, default: u32) -> Var {
    Var::new(name, DataType::Unsigned32)
        .access(Access::ReadWrite)
        .default(DefaultValue::Unsigned(default as u64))
}

/// The subs of a record of type 0082h (delta speed U32, delta time U16; CiA 402-2 §16: U16).
const fn slope_subs(default: Slope) -> [(u8, Var); 3] {
    [
        (0, highest_sub_two()),
        (
            1,
            Var::new("Delta speed", DataType::Unsigned32)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(default.delta_speed as u64)),
        ),
        (
            2,
            Var::new("Delta time", DataType::Unsigned16)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(default.delta_time as u64)),
        ),
    ]
}

const MIN_MAX_SUBS: [(u8, Var); 3] = [
    (0, highest_sub_two()),
    (1, amount("vl velocity min amount", DEFAULT_MIN_AMOUNT)),
    (2, amount("vl velocity max amount", DEFAULT_MAX_AMOUNT)),
];
const ACCELERATION_SUBS: [(u8, Var); 3] = slope_subs(DEFAULT_ACCELERATION);
const DECELERATION_SUBS: [(u8, Var); 3] = slope_subs(DEFAULT_DECELERATION);
const QUICK_STOP_SUBS: [(u8, Var); 3] = slope_subs(DEFAULT_QUICK_STOP);

/// 6042h: INTEGER16, rw, RPDO-mappable, default 0.
pub const VL_TARGET_VELOCITY_OBJECT: Object = Object::var(
    VL_TARGET_VELOCITY,
    "vl target velocity",
    Var::new("vl target velocity", DataType::Integer16).access(Access::ReadWrite).pdo(PdoMapping::Rpdo),
);
/// 6043h: INTEGER16, ro, TPDO-mappable.
pub const VL_VELOCITY_DEMAND_OBJECT: Object = Object::var(
    VL_VELOCITY_DEMAND,
    "vl velocity demand",
    Var::new("vl velocity demand", DataType::Integer16).pdo(PdoMapping::Tpdo),
);
/// 6044h: INTEGER16, ro, TPDO-mappable.
pub const VL_VELOCITY_ACTUAL_VALUE_OBJECT: Object = Object::var(
    VL_VELOCITY_ACTUAL_VALUE,
    "vl velocity actual value",
    Var::new("vl velocity actual value", DataType::Integer16).pdo(PdoMapping::Tpdo),
);
/// 6046h: sub 0 const 2, subs 1/2 UNSIGNED32 rw (defaults [`DEFAULT_MIN_AMOUNT`],
/// [`DEFAULT_MAX_AMOUNT`]).
pub const VL_VELOCITY_MIN_MAX_AMOUNT_OBJECT: Object =
    Object::record(VL_VELOCITY_MIN_MAX_AMOUNT, "vl velocity min max amount", &MIN_MAX_SUBS);
/// 6048h: record 0082h, default [`DEFAULT_ACCELERATION`].
pub const VL_VELOCITY_ACCELERATION_OBJECT: Object =
    Object::record(VL_VELOCITY_ACCELERATION, "vl velocity acceleration", &ACCELERATION_SUBS);
/// 6049h: record 0082h, default [`DEFAULT_DECELERATION`].
pub const VL_VELOCITY_DECELERATION_OBJECT: Object =
    Object::record(VL_VELOCITY_DECELERATION, "vl velocity deceleration", &DECELERATION_SUBS);
/// 604Ah: record 0082h, default [`DEFAULT_QUICK_STOP`].
pub const VL_VELOCITY_QUICK_STOP_OBJECT: Object =
    Object::record(VL_VELOCITY_QUICK_STOP, "vl velocity quick stop", &QUICK_STOP_SUBS);
/// 604Bh: ARRAY of two INTEGER16 rw, both +1.
pub const VL_SET_POINT_FACTOR_OBJECT: Object = Object::array(
    VL_SET_POINT_FACTOR,
    "vl set-point factor",
    2,
    &Var::new("vl set-point factor", DataType::Integer16)
        .access(Access::ReadWrite)
        .default(DefaultValue::Signed(1)),
);
/// 604Ch: ARRAY of two INTEGER32 rw, both +1.
pub const VL_DIMENSION_FACTOR_OBJECT: Object = Object::array(
    VL_DIMENSION_FACTOR,
    "vl dimension factor",
    2,
    &Var::new("vl dimension factor", DataType::Integer32)
        .access(Access::ReadWrite)
        .default(DefaultValue::Signed(1)),
);

/// The vl objects in index order (not laid out: splice them into a table given to
/// [`crate::od::layout`]).
pub const OBJECTS: [Object; 9] = [
    VL_TARGET_VELOCITY_OBJECT,
    VL_VELOCITY_DEMAND_OBJECT,
    VL_VELOCITY_ACTUAL_VALUE_OBJECT,
    VL_VELOCITY_MIN_MAX_AMOUNT_OBJECT,
    VL_VELOCITY_ACCELERATION_OBJECT,
    VL_VELOCITY_DECELERATION_OBJECT,
    VL_VELOCITY_QUICK_STOP_OBJECT,
    VL_SET_POINT_FACTOR_OBJECT,
    VL_DIMENSION_FACTOR_OBJECT,
];

/// Value rules of the vl objects beyond their types: no 0 in a factor (604Bh/604Ch subs 1 and
/// 2: [`AbortCode::InvalidValue`]), no delta time of 0 and no acceleration of 0 (6048h–604Ah
/// sub 2, 6048h sub 1: [`AbortCode::ValueTooLow`]). `raw` is the little-endian value whose size
/// the dictionary has already checked.
pub fn check_write(index: u16, sub: u8, raw: &[u8]) -> Result<(), AbortCode> {
    let zero = raw.iter().all(|b| *b == 0);
    match (index, sub) {
        (VL_SET_POINT_FACTOR | VL_DIMENSION_FACTOR, 1 | 2) if zero => Err(AbortCode::InvalidValue),
        (VL_VELOCITY_ACCELERATION | VL_VELOCITY_DECELERATION | VL_VELOCITY_QUICK_STOP, 2) if zero => {
            Err(AbortCode::ValueTooLow)
        }
        (VL_VELOCITY_ACCELERATION, 1) if zero => Err(AbortCode::ValueTooLow),
        _ => Ok(()),
    }
}

/// The vl parameters of one tick, as the objects hold them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Parameters {
    /// 6042h, set-point units.
    pub target: i16,
    /// 6046h sub 1, user units.
    pub min_amount: u32,
    /// 6046h sub 2, user units.
    pub max_amount: u32,
    /// 6048h.
    pub acceleration: Slope,
    /// 6049h (delta speed 0: as 6048h).
    pub deceleration: Slope,
    /// 604Ah (delta speed 0: as the deceleration).
    pub quick_stop: Slope,
    /// 604Bh (numerator, denominator): user units per set-point unit.
    pub setpoint_factor: (i16, i16),
    /// 604Ch (numerator, denominator): rpm per user unit.
    pub dimension_factor: (i32, i32),
}

impl Parameters {
    /// The object defaults.
    pub const DEFAULT: Parameters = Parameters {
        target: 0,
        min_amount: DEFAULT_MIN_AMOUNT,
        max_amount: DEFAULT_MAX_AMOUNT,
        acceleration: DEFAULT_ACCELERATION,
        deceleration: DEFAULT_DECELERATION,
        quick_stop: DEFAULT_QUICK_STOP,
        setpoint_factor: (1, 1),
        dimension_factor: (1, 1),
    };

    /// The values the dictionary holds now. An optional object the dictionary lacks counts as
    /// absent: 6049h and 604Ah fall back (delta speed 0), 604Bh and 604Ch are 1/1.
    pub fn from_od<const B: usize>(od: &Dictionary<B>) -> Self {
        Self::from_axis(od, Axis::FIRST)
    }

    /// [`Self::from_od`] from the objects of `axis`.
    pub fn from_axis<const B: usize>(od: &Dictionary<B>, axis: Axis) -> Self {
        let slope = |index: u16, absent: Slope| {
            Slope::new(
                od.get::<u32>(axis.index(index), 1).unwrap_or(absent.delta_speed),
                od.get::<u16>(axis.index(index), 2).unwrap_or(absent.delta_time),
            )
        };
        let absent = Slope::new(0, 1);
        Parameters {
            target: od.get::<i16>(axis.index(VL_TARGET_VELOCITY), 0).unwrap_or(0),
            min_amount: od
                .get::<u32>(axis.index(VL_VELOCITY_MIN_MAX_AMOUNT), 1)
                .unwrap_or(DEFAULT_MIN_AMOUNT),
            max_amount: od
                .get::<u32>(axis.index(VL_VELOCITY_MIN_MAX_AMOUNT), 2)
                .unwrap_or(DEFAULT_MAX_AMOUNT),
            acceleration: slope(VL_VELOCITY_ACCELERATION, DEFAULT_ACCELERATION),
            deceleration: slope(VL_VELOCITY_DECELERATION, absent),
            quick_stop: slope(VL_VELOCITY_QUICK_STOP, absent),
            setpoint_factor: (
                od.get::<i16>(axis.index(VL_SET_POINT_FACTOR), 1).unwrap_or(1),
                od.get::<i16>(axis.index(VL_SET_POINT_FACTOR), 2).unwrap_or(1),
            ),
            dimension_factor: (
                od.get::<i32>(axis.index(VL_DIMENSION_FACTOR), 1).unwrap_or(1),
                od.get::<i32>(axis.index(VL_DIMENSION_FACTOR), 2).unwrap_or(1),
            ),
        }
    }

    /// The deceleration in use: 6049h, or 6048h when 6049h's delta speed is 0.
    pub fn deceleration_slope(&self) -> Slope {
        if self.deceleration.delta_speed != 0 {
            self.deceleration
        } else {
            self.acceleration
        }
    }

    /// The quick-stop ramp in use: 604Ah, or the deceleration when 604Ah's delta speed is 0.
    pub fn quick_stop_slope(&self) -> Slope {
        if self.quick_stop.delta_speed != 0 {
            self.quick_stop
        } else {
            self.deceleration_slope()
        }
    }

    /// The ramp a stop of `kind` uses; `None` = at once (coast).
    fn stop_slope(&self, kind: StopKind) -> Option<Slope> {
        match kind {
            StopKind::Coast | StopKind::DynamicBrake => None,
            StopKind::SlowDown => Some(self.deceleration_slope()),
            StopKind::QuickStopRamp | StopKind::CurrentLimit | StopKind::VoltageLimit => {
                Some(self.quick_stop_slope())
            }
        }
    }
}

impl Default for Parameters {
    fn default() -> Self {
        Parameters::DEFAULT
    }
}

/// Increments per motor revolution (608Fh sub 1 / sub 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Resolution {
    /// 608Fh sub 1: encoder increments.
    pub increments: u32,
    /// 608Fh sub 2: motor revolutions.
    pub revolutions: u32,
}

impl Resolution {
    /// `increments` per `revolutions` motor revolutions.
    pub const fn new(increments: u32, revolutions: u32) -> Self {
        Resolution { increments, revolutions }
    }

    /// 608Fh as the dictionary holds it (a 0, or an absent object, counts as 1).
    pub fn from_od<const B: usize>(od: &Dictionary<B>) -> Self {
        Self::from_axis(od, Axis::FIRST)
    }

    /// [`Self::from_od`] from `axis`'s 608Fh.
    pub fn from_axis<const B: usize>(od: &Dictionary<B>, axis: Axis) -> Self {
        let index = axis.index(POSITION_ENCODER_RESOLUTION);
        let sub = |s| od.get::<u32>(index, s).ok().filter(|v| *v != 0).unwrap_or(1);
        Resolution::new(sub(1), sub(2))
    }
}

/// How this drive treats controlword bits 4–6 in vl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Honour bits 4–6 (the default). When false they read as 1, so 0x000F runs like 0x007F.
    pub ramp_bits: bool,
}

impl Config {
    /// Bits 4–6 honoured.
    pub const fn new() -> Self {
        Config { ramp_bits: true }
    }
}

impl Default for Config {
    fn default() -> Self {
        Config::new()
    }
}

/// What the profile hands vl each tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Inputs {
    /// The vl objects ([`Parameters::from_od`]).
    pub parameters: Parameters,
    /// 608Fh ([`Resolution::from_od`]).
    pub resolution: Resolution,
    /// The controlword 6040h.
    pub controlword: Controlword,
    /// The stop a halt (bit 8) makes: 605Dh through [`StopKind::halt_or_fault`].
    pub halt: StopKind,
    /// The highest velocity the demand may have, increments/s (min(607Fh, 6080h) converted).
    pub velocity_limit: u32,
    /// The actual velocity, increments/s.
    pub actual_velocity: i64,
    /// Time since the previous tick.
    pub dt: Duration,
}

/// What one vl tick gives back.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Output {
    /// The velocity demand for the power stage, increments/s.
    pub demand: i64,
    /// 6043h: the ramp output in set-point units.
    pub demand_value: i16,
    /// 6044h: the actual velocity in set-point units.
    pub actual_value: i16,
    /// Statusword bit 10: the ramp output equals the ramp input.
    pub target_reached: bool,
    /// Statusword bit 11: the reference is clamped by 6046h or the velocity limit.
    pub limit_active: bool,
}

impl Output {
    /// Writes 6043h and 6044h (a dictionary without them is left alone).
    pub fn publish<const B: usize>(&self, od: &mut Dictionary<B>) {
        self.publish_to(od, Axis::FIRST);
    }

    /// [`Self::publish`] to the objects of `axis`.
    pub fn publish_to<const B: usize>(&self, od: &mut Dictionary<B>, axis: Axis) {
        let _ = od.set::<i16>(axis.index(VL_VELOCITY_DEMAND), 0, self.demand_value);
        let _ = od.set::<i16>(axis.index(VL_VELOCITY_ACTUAL_VALUE), 0, self.actual_value);
    }
}

/// 6044h from an actual velocity in increments/s (the reverse factor function), for the ticks
/// in which vl does not run.
pub fn actual_value(parameters: &Parameters, resolution: Resolution, velocity: i64) -> i16 {
    saturate_i16(Scale::new(parameters, resolution).internal_to_setpoint(velocity))
}

/// 2⁻¹⁶ user units: the resolution of the ramp.
const FINE: i128 = 1 << 16;
/// Bound of every ramp value (fine units), so that differences fit an i64.
const MAX_FINE: i128 = 1 << 62;
const MICROS_PER_SECOND: i128 = 1_000_000;
const SECONDS_PER_MINUTE: i128 = 60;

fn saturate_i16(value: i128) -> i16 {
    value.clamp(i128::from(i16::MIN), i128::from(i16::MAX)) as i16
}

fn saturate_i64(value: i128) -> i64 {
    value.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64
}

fn fine(value: i128) -> i64 {
    value.clamp(-MAX_FINE, MAX_FINE) as i64
}

/// `value × numerator / denominator`, rounded to nearest with halves away from zero; a
/// product beyond 128 bits saturates (the result would saturate anyway).
fn rescale(value: i128, numerator: i128, denominator: i128) -> i128 {
    let negative = (value < 0) ^ (numerator < 0) ^ (denominator < 0);
    let divisor = denominator.unsigned_abs().max(1);
    let (value, numerator) = (value.unsigned_abs(), numerator.unsigned_abs());
    // Factors within 64 bits (the usual case) multiply without the overflow check of a
    // 128 × 128-bit product, a library call on a 32-bit MCU.
    let product = match (u64::try_from(value), u64::try_from(numerator)) {
        (Ok(value), Ok(numerator)) => Some(u128::from(value) * u128::from(numerator)),
        _ => value.checked_mul(numerator),
    };
    let magnitude = match product {
        Some(product) => {
            let (quotient, remainder) = crate::wide::udivrem(product, divisor);
            if remainder >= divisor - remainder {
                quotient.saturating_add(1)
            } else {
                quotient
            }
        }
        None => u128::MAX,
    };
    let magnitude = i128::try_from(magnitude).unwrap_or(i128::MAX);
    if negative {
        -magnitude
    } else {
        magnitude
    }
}

/// The factors of one tick as 128-bit integers, none 0.
struct Scale {
    setpoint: (i128, i128),
    dimension: (i128, i128),
    resolution: (i128, i128),
}

fn nonzero(value: i128) -> i128 {
    if value == 0 {
        1
    } else {
        value
    }
}

impl Scale {
    fn new(parameters: &Parameters, resolution: Resolution) -> Self {
        let (s1, s2) = parameters.setpoint_factor;
        let (d1, d2) = parameters.dimension_factor;
        Scale {
            setpoint: (nonzero(i128::from(s1)), nonzero(i128::from(s2))),
            dimension: (nonzero(i128::from(d1)), nonzero(i128::from(d2))),
            resolution: (
                nonzero(i128::from(resolution.increments)),
                nonzero(i128::from(resolution.revolutions)),
            ),
        }
    }

    fn setpoint_to_fine(&self, setpoint: i64) -> i64 {
        let (s1, s2) = self.setpoint;
        fine(rescale(i128::from(setpoint), s1 * FINE, s2))
    }

    fn fine_to_setpoint(&self, value: i64) -> i128 {
        let (s1, s2) = self.setpoint;
        rescale(i128::from(value), s2, s1 * FINE)
    }

    fn fine_to_internal(&self, value: i64) -> i128 {
        let ((d1, d2), (r1, r2)) = (self.dimension, self.resolution);
        rescale(i128::from(value), d1 * r1, FINE * d2 * SECONDS_PER_MINUTE * r2)
    }

    fn internal_to_fine(&self, velocity: i64) -> i128 {
        let ((d1, d2), (r1, r2)) = (self.dimension, self.resolution);
        rescale(i128::from(velocity), FINE * SECONDS_PER_MINUTE * r2 * d2, d1 * r1)
    }

    fn internal_to_setpoint(&self, velocity: i64) -> i128 {
        let ((s1, s2), (d1, d2), (r1, r2)) = (self.setpoint, self.dimension, self.resolution);
        rescale(i128::from(velocity), SECONDS_PER_MINUTE * r2 * d2 * s2, r1 * d1 * s1)
    }

    /// The reference (fine units) after the min/max amount and the velocity limit, and whether
    /// either changed it.
    fn reference(&self, parameters: &Parameters, velocity_limit: u32) -> (i64, bool) {
        let wanted = self.setpoint_to_fine(i64::from(parameters.target));
        if wanted == 0 {
            return (0, false);
        }
        let ceiling = (i128::from(parameters.max_amount) * FINE)
            .min(self.internal_to_fine(i64::from(velocity_limit)).abs());
        let floor = (i128::from(parameters.min_amount) * FINE).min(ceiling);
        let magnitude = i128::from(wanted).abs();
        let limited = magnitude.clamp(floor, ceiling);
        (fine(limited * i128::from(wanted.signum())), limited != magnitude)
    }
}

/// The ramp function generator: its output in fine units, moved at a slope with the remainder
/// carried.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Ramp {
    value: i64,
    /// Fine unit·µs not yet moved, below `delta_time` × 10⁶.
    remainder: i64,
    /// The slope and direction (up = true) the remainder belongs to.
    segment: Option<(bool, Slope)>,
}

impl Ramp {
    fn at(value: i64) -> Self {
        Ramp { value, remainder: 0, segment: None }
    }

    /// Towards `goal`: accelerating away from 0, decelerating towards it (through 0 first when
    /// the goal lies on the other side). A zero deceleration stops at once.
    fn follow(&mut self, goal: i64, accelerate: Slope, decelerate: Slope, dt: Duration) {
        let value = self.value;
        if value == goal {
            *self = Ramp::at(goal);
            return;
        }
        let away = value == 0 || (goal.signum() == value.signum() && goal.abs() > value.abs());
        if away {
            self.toward(goal, accelerate, dt);
        } else {
            let goal = if goal.signum() == -value.signum() { 0 } else { goal };
            if decelerate.delta_speed == 0 {
                *self = Ramp::at(goal);
            } else {
                self.toward(goal, decelerate, dt);
            }
        }
    }

    fn toward(&mut self, goal: i64, slope: Slope, dt: Duration) {
        let distance = i128::from(goal) - i128::from(self.value);
        if distance == 0 {
            *self = Ramp::at(goal);
            return;
        }
        let segment = (distance > 0, slope);
        if self.segment != Some(segment) {
            self.segment = Some(segment);
            self.remainder = 0;
        }
        let per = i128::from(slope.delta_time.max(1)) * MICROS_PER_SECOND;
        let budget =
            i128::from(slope.delta_speed) * FINE * i128::from(dt.as_micros()) + i128::from(self.remainder);
        let (step, remainder) = crate::wide::sdivrem(budget, per);
        if step >= distance.abs() {
            *self = Ramp::at(goal);
        } else {
            self.remainder = i64::try_from(remainder).unwrap_or(0);
            self.value = fine(i128::from(self.value) + step * distance.signum());
        }
    }
}

/// What the ramp does this tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    /// To 0 with a stop's ramp (profile stop or halt).
    Stop(StopKind),
    /// Bit 4 = 0: demand 0, generator set to 0.
    Zero,
    /// Bit 5 = 0: output frozen.
    Hold,
    /// Towards the ramp input.
    Follow,
}

/// Velocity mode run-time state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Velocity {
    config: Config,
    ramp: Ramp,
    /// A stop the profile asked for, until [`Velocity::reset`].
    stop: Option<StopKind>,
    /// Start velocity (increments/s) from [`Velocity::reset`], converted at the next tick.
    start: Option<i64>,
}

impl Velocity {
    /// At rest.
    pub const fn new(config: Config) -> Self {
        Velocity { config, ramp: Ramp { value: 0, remainder: 0, segment: None }, stop: None, start: None }
    }

    /// Entering Operation enabled (or vl): drops a stop, and the ramp starts at the next tick
    /// from `actual_velocity` (increments/s).
    pub fn reset(&mut self, actual_velocity: i64) {
        self.stop = None;
        self.start = Some(actual_velocity);
    }

    /// Brings the ramp to 0 as `kind` says (quick stop, fault reaction, disable operation,
    /// shutdown), ignoring the controlword until [`Velocity::reset`]. May be called every tick;
    /// the latest kind counts. Steps are made by [`Velocity::tick`].
    pub fn stop(&mut self, kind: StopKind) {
        self.stop = Some(kind);
    }

    /// A stop asked for by [`Velocity::stop`] is running or done.
    pub fn is_stopping(&self) -> bool {
        self.stop.is_some()
    }

    /// The ramp output is 0.
    pub fn is_at_rest(&self) -> bool {
        self.ramp.value == 0 && self.start.is_none_or(|v| v == 0)
    }

    /// One tick: the chain from 6042h to the demand, and 6044h.
    pub fn tick(&mut self, input: &Inputs) -> Output {
        let parameters = &input.parameters;
        let scale = Scale::new(parameters, input.resolution);
        if let Some(actual) = self.start.take() {
            self.ramp = Ramp::at(fine(scale.internal_to_fine(actual)));
        }
        let (reference, limit_active) = scale.reference(parameters, input.velocity_limit);
        let controlword =
            if self.config.ramp_bits { input.controlword } else { input.controlword | RAMP_BITS };
        let action = match self.stop {
            Some(kind) => Action::Stop(kind),
            None if !controlword.contains(Controlword::RAMP_FUNCTION_GENERATOR_ENABLE) => Action::Zero,
            None if controlword.contains(Controlword::HALT) => Action::Stop(input.halt),
            None if !controlword.contains(Controlword::RAMP_UNLOCK) => Action::Hold,
            None => Action::Follow,
        };
        let ramp_input = match action {
            Action::Stop(_) => 0,
            Action::Zero | Action::Hold | Action::Follow
                if !controlword.contains(Controlword::RAMP_REFERENCE) =>
            {
                0
            }
            Action::Zero | Action::Hold | Action::Follow => reference,
        };
        match action {
            Action::Stop(kind) => match parameters.stop_slope(kind) {
                Some(slope) => self.ramp.follow(0, parameters.acceleration, slope, input.dt),
                None => self.ramp = Ramp::at(0),
            },
            Action::Zero => self.ramp = Ramp::at(0),
            Action::Hold => {}
            Action::Follow => self.ramp.follow(
                ramp_input,
                parameters.acceleration,
                parameters.deceleration_slope(),
                input.dt,
            ),
        }
        let limit = i128::from(input.velocity_limit);
        Output {
            demand: saturate_i64(scale.fine_to_internal(self.ramp.value).clamp(-limit, limit)),
            demand_value: saturate_i16(scale.fine_to_setpoint(self.ramp.value)),
            actual_value: saturate_i16(scale.internal_to_setpoint(input.actual_velocity)),
            target_reached: self.ramp.value == ramp_input,
            limit_active,
        }
    }
}

impl Default for Velocity {
    fn default() -> Self {
        Velocity::new(Config::new())
    }
}

/// vl as the running mode of a profile ([`crate::cia402::profile`]): its ramp and the status
/// bits of its last tick. It exists while vl is the active mode.
#[derive(Clone, Debug)]
pub struct Vl {
    velocity: Velocity,
    /// Statusword bit 10 of the last tick: the ramp output equals its input.
    target_reached: bool,
    /// Statusword bit 11 of the last tick: the reference is clamped.
    limit_active: bool,
    /// The objects as last read, keyed on the dictionary's revision then: read again only after
    /// a write (each is a look-up of a few hundred instructions).
    kept: Memo<u32, (Parameters, Resolution)>,
    /// 6043h and 6044h, resolved at the first step.
    outputs: Option<(Slot<i16>, Slot<i16>)>,
}

impl Vl {
    /// vl becomes the mode, the ramp starting from `actual_velocity` (increments/s).
    pub fn start(config: Config, actual_velocity: i64) -> Self {
        let mut velocity = Velocity::new(config);
        velocity.reset(actual_velocity);
        Vl { velocity, target_reached: false, limit_active: false, kept: Memo::EMPTY, outputs: None }
    }

    /// The drive enters Operation enabled: a stop is dropped, the ramp starts again from
    /// `actual_velocity`.
    pub fn restart(&mut self, actual_velocity: i64) {
        self.velocity.reset(actual_velocity);
    }

    /// A stop of `kind` ([`Velocity::stop`]).
    pub fn stop(&mut self, kind: StopKind) {
        self.velocity.stop(kind);
    }

    /// One tick ([`Velocity::tick`] with the objects of `od`), 6043h and 6044h published: the
    /// velocity demand in increments/s.
    pub fn step<const B: usize>(&mut self, od: &mut Dictionary<B>, drive: DriveInputs) -> i64 {
        let revision = od.revision();
        let (parameters, resolution) = self
            .kept
            .get(revision, || (Parameters::from_axis(od, drive.axis), Resolution::from_axis(od, drive.axis)));
        let input = Inputs {
            parameters,
            resolution,
            controlword: drive.controlword,
            halt: drive.halt,
            velocity_limit: drive.velocity_limit,
            actual_velocity: drive.actual_velocity,
            dt: drive.dt,
        };
        let output = self.velocity.tick(&input);
        // Through slots, which do not count as writes: the next step keeps the parameters.
        let (demand, actual) = *self.outputs.get_or_insert_with(|| {
            (
                od.slot(drive.axis.index(VL_VELOCITY_DEMAND), 0),
                od.slot(drive.axis.index(VL_VELOCITY_ACTUAL_VALUE), 0),
            )
        });
        od.store(demand, output.demand_value);
        od.store(actual, output.actual_value);
        self.target_reached = output.target_reached;
        self.limit_active = output.limit_active;
        output.demand
    }

    /// Statusword bit 10 (in Operation enabled) of the last tick.
    pub fn target_reached(&self) -> bool {
        self.target_reached
    }

    /// Statusword bit 11 of the last tick.
    pub fn limit_active(&self) -> bool {
        self.limit_active
    }
}

/// What the profile hands [`Vl::step`]: [`Inputs`] without the vl objects, which it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriveInputs {
    /// The controlword 6040h.
    pub controlword: Controlword,
    /// The stop a halt (bit 8) makes.
    pub halt: StopKind,
    /// The highest velocity the demand may have, increments/s.
    pub velocity_limit: u32,
    /// The actual velocity, increments/s.
    pub actual_velocity: i64,
    /// Time since the previous tick.
    pub dt: Duration,
    /// The axis whose objects these are.
    pub axis: Axis,
}

/// The value rule of vl's object `index` ([`super::registry::rule`]): the factors and ramps
/// ([`check_write`]).
pub(crate) fn rule(index: u16) -> Option<Rule> {
    let ruled = matches!(
        index,
        VL_VELOCITY_ACCELERATION
            | VL_VELOCITY_DECELERATION
            | VL_VELOCITY_QUICK_STOP
            | VL_SET_POINT_FACTOR
            | VL_DIMENSION_FACTOR
    );
    (super::VL && ruled).then_some(Rule::Velocity)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{layout, DeviceInfo};

    const TICK: Duration = Duration::from_millis(1);
    /// 4096 increments per revolution: 1500 rpm = 102 400 increments/s.
    const ENCODER: Resolution = Resolution::new(4096, 1);

    static TABLE: [Object; 9] = layout(OBJECTS);
    /// A drive without 6049h.
    static NO_DECELERATION: [Object; 8] = layout([
        VL_TARGET_VELOCITY_OBJECT,
        VL_VELOCITY_DEMAND_OBJECT,
        VL_VELOCITY_ACTUAL_VALUE_OBJECT,
        VL_VELOCITY_MIN_MAX_AMOUNT_OBJECT,
        VL_VELOCITY_ACCELERATION_OBJECT,
        VL_VELOCITY_QUICK_STOP_OBJECT,
        VL_SET_POINT_FACTOR_OBJECT,
        VL_DIMENSION_FACTOR_OBJECT,
    ]);

    fn dictionary(table: &'static [Object]) -> Dictionary<128> {
        Dictionary::new(&[table], DeviceInfo::servo_drive(), 1).unwrap()
    }

    /// 6042h = 1500 rpm, 6048h = 15000 rpm per 37 s (1500 rpm in 3.7 s).
    fn example() -> Parameters {
        Parameters { target: 1500, acceleration: Slope::new(15_000, 37), ..Parameters::DEFAULT }
    }

    /// Controlword bits as a master writes them.
    const RAMP_UNLOCK: u16 = Controlword::RAMP_UNLOCK.bits();
    const HALT: u16 = Controlword::HALT.bits();

    fn inputs(parameters: Parameters, controlword: u16) -> Inputs {
        Inputs {
            parameters,
            resolution: ENCODER,
            controlword: Controlword::from_raw(controlword),
            halt: StopKind::SlowDown,
            velocity_limit: u32::MAX,
            actual_velocity: 0,
            dt: TICK,
        }
    }

    fn run(vl: &mut Velocity, input: &Inputs, ticks: u32) -> Output {
        let mut output = Output::default();
        for _ in 0..ticks {
            output = vl.tick(input);
        }
        output
    }

    /// 6043h after `ms` ms of the example's acceleration from 0: round(1500·ms/3700).
    fn accelerated(ms: i64) -> i16 {
        ((30 * ms + 37) / 74).min(1500) as i16
    }

    #[test]
    fn q_165_demand_rises_at_delta_speed_over_delta_time_until_the_target() {
        let mut vl = Velocity::default();
        let input = inputs(example(), RUN);
        for ms in 1..=3800 {
            let out = vl.tick(&input);
            assert_eq!(out.demand_value, accelerated(ms), "{ms} ms");
            assert_eq!(out.target_reached, ms >= 3700, "{ms} ms");
            if ms == 1850 {
                // 750 rpm exactly, × 4096 / 60.
                assert_eq!(out.demand, 51_200);
            }
        }
        let out = vl.tick(&input);
        assert_eq!((out.demand_value, out.demand), (1500, 102_400));
        assert!(!out.limit_active);
    }

    #[test]
    fn q_166_bit_6_clear_forces_the_ramp_input_to_zero() {
        let mut vl = Velocity::default();
        let parameters = Parameters { deceleration: Slope::new(3000, 1), ..example() };
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 3700).demand_value, 1500);
        let input = inputs(parameters, 0x003F);
        // 3 rpm per ms with 6049h.
        let out = run(&mut vl, &input, 100);
        assert_eq!(out.demand_value, 1200);
        assert!(!out.target_reached);
        let out = run(&mut vl, &input, 400);
        assert_eq!((out.demand_value, out.demand), (0, 0));
        assert!(out.target_reached);
        assert_eq!(run(&mut vl, &input, 100).demand_value, 0);
        // Bit 6 back: the ramp accelerates again from 0.
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 37).demand_value, 15);
    }

    #[test]
    fn q_167_bit_5_clear_freezes_the_ramp_output() {
        let mut vl = Velocity::default();
        assert_eq!(run(&mut vl, &inputs(example(), RUN), 1000).demand_value, accelerated(1000));
        let frozen = run(&mut vl, &inputs(example(), 0x005F), 1);
        for _ in 0..2000 {
            assert_eq!(vl.tick(&inputs(example(), 0x005F)), frozen);
        }
        assert_eq!(frozen.demand_value, 405);
        assert!(!frozen.target_reached);
        // Unlocked, the ramp goes on from where it stood, remainder included.
        for ms in 1001..=1500 {
            assert_eq!(vl.tick(&inputs(example(), RUN)).demand_value, accelerated(ms));
        }
    }

    #[test]
    fn q_168_bit_4_clear_the_demand_no_longer_follows_the_ramp() {
        let mut vl = Velocity::default();
        run(&mut vl, &inputs(example(), RUN), 2000);
        // This build's source while the generator is disabled: 0 at once.
        let input = inputs(example(), 0x006F);
        for _ in 0..500 {
            let out = vl.tick(&input);
            assert_eq!((out.demand_value, out.demand), (0, 0));
            assert!(!out.target_reached);
        }
        // Enabled again, the generator starts from standstill.
        assert_eq!(run(&mut vl, &inputs(example(), RUN), 37).demand_value, 15);
    }

    #[test]
    fn controlword_000f_holds_standstill_unless_configured_without_ramp_bits() {
        let mut vl = Velocity::default();
        assert_eq!(run(&mut vl, &inputs(example(), 0x000F), 1000).demand, 0);
        let mut lenient = Velocity::new(Config { ramp_bits: false });
        assert_eq!(run(&mut lenient, &inputs(example(), 0x000F), 1000).demand_value, accelerated(1000));
    }

    #[test]
    fn q_169_target_above_max_amount_converges_to_the_max_with_its_sign() {
        for (target, expected) in [(1500, 1000), (-1500, -1000), (800, 800), (50, 100), (-50, -100), (0, 0)] {
            let mut vl = Velocity::default();
            let parameters = Parameters { target, min_amount: 100, max_amount: 1000, ..example() };
            let out = run(&mut vl, &inputs(parameters, RUN), 5000);
            assert_eq!(out.demand_value, expected, "{target}");
            assert_eq!(out.limit_active, target != expected, "{target}");
            assert!(out.target_reached);
        }
        // Min above max: max wins.
        let parameters = Parameters { min_amount: 2000, max_amount: 1000, ..example() };
        assert_eq!(run(&mut Velocity::default(), &inputs(parameters, RUN), 5000).demand_value, 1000);
    }

    #[test]
    fn the_velocity_limit_caps_the_reference_and_the_demand() {
        let mut vl = Velocity::default();
        // 51 200 increments/s = 750 rpm.
        let input = Inputs { velocity_limit: 51_200, ..inputs(example(), RUN) };
        let out = run(&mut vl, &input, 4000);
        assert_eq!((out.demand_value, out.demand), (750, 51_200));
        assert!(out.limit_active);
    }

    #[test]
    fn q_170_a_zero_factor_or_delta_time_is_refused() {
        let od = dictionary(&TABLE);
        for (index, sub, zero) in [
            (VL_SET_POINT_FACTOR, 1, &[0u8, 0][..]),
            (VL_SET_POINT_FACTOR, 2, &[0, 0]),
            (VL_DIMENSION_FACTOR, 1, &[0, 0, 0, 0]),
            (VL_DIMENSION_FACTOR, 2, &[0, 0, 0, 0]),
        ] {
            // The size is right; the value rule refuses.
            assert_eq!(od.check_write(&od.entry(index, sub).unwrap(), zero), Ok(()));
            assert_eq!(check_write(index, sub, zero), Err(AbortCode::InvalidValue));
        }
        assert_eq!(check_write(VL_SET_POINT_FACTOR, 2, &(-3i16).to_le_bytes()), Ok(()));
        assert_eq!(check_write(VL_DIMENSION_FACTOR, 1, &12i32.to_le_bytes()), Ok(()));
        for index in [VL_VELOCITY_ACCELERATION, VL_VELOCITY_DECELERATION, VL_VELOCITY_QUICK_STOP] {
            assert_eq!(check_write(index, 2, &[0, 0]), Err(AbortCode::ValueTooLow));
            assert_eq!(check_write(index, 2, &[37, 0]), Ok(()));
        }
        assert_eq!(check_write(VL_VELOCITY_ACCELERATION, 1, &[0; 4]), Err(AbortCode::ValueTooLow));
        // 0 in 6049h/604Ah delta speed means "use the next ramp".
        assert_eq!(check_write(VL_VELOCITY_DECELERATION, 1, &[0; 4]), Ok(()));
        assert_eq!(check_write(VL_VELOCITY_QUICK_STOP, 1, &[0; 4]), Ok(()));
        assert_eq!(check_write(VL_VELOCITY_MIN_MAX_AMOUNT, 2, &[0; 4]), Ok(()));
    }

    #[test]
    fn q_171_without_6049h_the_deceleration_is_6048h() {
        let mut od = dictionary(&NO_DECELERATION);
        od.set::<i16>(VL_TARGET_VELOCITY, 0, 1500).unwrap();
        od.set::<u32>(VL_VELOCITY_ACCELERATION, 1, 15_000).unwrap();
        od.set::<u16>(VL_VELOCITY_ACCELERATION, 2, 37).unwrap();
        let parameters = Parameters::from_od(&od);
        assert_eq!(parameters.deceleration_slope(), Slope::new(15_000, 37));
        let mut vl = Velocity::default();
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 3700).demand_value, 1500);
        let stopping = inputs(Parameters { target: 0, ..parameters }, RUN);
        for ms in 1..=3700 {
            assert_eq!(vl.tick(&stopping).demand_value, 1500 - accelerated(ms), "{ms} ms");
        }
        // The same with 6049h present at its default (delta speed 0).
        let od = dictionary(&TABLE);
        assert_eq!(Parameters::from_od(&od).deceleration_slope(), DEFAULT_ACCELERATION);
    }

    #[test]
    fn the_objects_have_their_types_access_and_defaults() {
        let mut od = dictionary(&TABLE);
        assert_eq!(Parameters::from_od(&od), Parameters::DEFAULT);
        let var = |index, sub| od.entry(index, sub).unwrap().var;
        let target = var(VL_TARGET_VELOCITY, 0);
        assert_eq!(
            (target.data_type, target.access, target.pdo),
            (DataType::Integer16, Access::ReadWrite, PdoMapping::Rpdo)
        );
        for index in [VL_VELOCITY_DEMAND, VL_VELOCITY_ACTUAL_VALUE] {
            let v = var(index, 0);
            assert_eq!(
                (v.data_type, v.access, v.pdo),
                (DataType::Integer16, Access::ReadOnly, PdoMapping::Tpdo)
            );
        }
        for (index, types) in [
            (VL_VELOCITY_MIN_MAX_AMOUNT, [DataType::Unsigned32, DataType::Unsigned32]),
            (VL_VELOCITY_ACCELERATION, [DataType::Unsigned32, DataType::Unsigned16]),
            (VL_VELOCITY_DECELERATION, [DataType::Unsigned32, DataType::Unsigned16]),
            (VL_VELOCITY_QUICK_STOP, [DataType::Unsigned32, DataType::Unsigned16]),
            (VL_SET_POINT_FACTOR, [DataType::Integer16, DataType::Integer16]),
            (VL_DIMENSION_FACTOR, [DataType::Integer32, DataType::Integer32]),
        ] {
            assert_eq!(od.get::<u8>(index, 0), Ok(2), "{index:04X}");
            assert!(!var(index, 0).access.writable());
            for (sub, data_type) in [1, 2].into_iter().zip(types) {
                let v = var(index, sub);
                assert_eq!((v.data_type, v.access), (data_type, Access::ReadWrite), "{index:04X}.{sub}");
            }
            assert_eq!(od.entry(index, 3).err(), Some(AbortCode::SubIndexDoesNotExist));
        }
        assert_eq!(od.get::<u32>(VL_VELOCITY_MIN_MAX_AMOUNT, 2), Ok(u32::MAX));
        assert_eq!(od.get::<i32>(VL_DIMENSION_FACTOR, 2), Ok(1));
        // 6043h/6044h written from a tick.
        Output { demand_value: -7, actual_value: 9, ..Output::default() }.publish(&mut od);
        assert_eq!(
            (od.get::<i16>(VL_VELOCITY_DEMAND, 0), od.get::<i16>(VL_VELOCITY_ACTUAL_VALUE, 0)),
            (Ok(-7), Ok(9))
        );
    }

    #[test]
    fn factors_scale_the_target_the_demand_and_the_actual_value() {
        // 604Ch for a unit of 0.1 Hz stator frequency on a 4-pole motor: n = 120·f/p rpm with
        // f = 0.1·v Hz gives 12·v/4 = 3 rpm per unit (numerator 12, denominator = pole count).
        let dimension = Parameters {
            target: 500, // 50.0 Hz
            acceleration: Slope::new(500, 1),
            dimension_factor: (12, 4),
            ..Parameters::DEFAULT
        };
        let mut vl = Velocity::default();
        let input = Inputs { actual_velocity: 102_400, ..inputs(dimension, RUN) };
        // 500 units per s = 1500 rpm per s: half-way after 500 ms.
        let out = run(&mut vl, &input, 500);
        assert_eq!((out.demand_value, out.demand), (250, 51_200));
        let out = run(&mut vl, &input, 500);
        assert_eq!((out.demand_value, out.demand, out.actual_value), (500, 102_400, 500));

        // 604Bh = 1/10: 6042h in 0.01 Hz; the limit and the ramp stay in 0.1 Hz.
        let fine_setpoint = Parameters {
            target: 5000,
            max_amount: 400, // 40.0 Hz
            setpoint_factor: (1, 10),
            ..dimension
        };
        let mut vl = Velocity::default();
        let input = Inputs { actual_velocity: 81_920, ..inputs(fine_setpoint, RUN) };
        let out = run(&mut vl, &input, 400);
        assert_eq!((out.demand_value, out.demand, out.actual_value), (2000, 40_960, 4000));
        let out = run(&mut vl, &input, 1000);
        assert_eq!((out.demand_value, out.demand, out.actual_value), (4000, 81_920, 4000));
        assert!(out.limit_active);

        // Negative factors reverse the direction.
        let reversed = Parameters { setpoint_factor: (-1, 1), ..example() };
        let out = run(&mut Velocity::default(), &inputs(reversed, RUN), 4000);
        assert_eq!((out.demand_value, out.demand), (1500, -102_400));
        assert_eq!(actual_value(&reversed, ENCODER, -102_400), 1500);
    }

    #[test]
    fn the_conversion_to_increments_per_second_is_exact_without_drift() {
        // 10 000 increments per 3 revolutions: 1500 rpm = 83 333.3… increments/s.
        let parameters = Parameters { target: 1500, ..Parameters::DEFAULT };
        let input = Inputs {
            resolution: Resolution::new(10_000, 3),
            dt: Duration::from_micros(333),
            ..inputs(parameters, RUN)
        };
        let mut vl = Velocity::default();
        let mut ticks = 0u32;
        let out = loop {
            let out = vl.tick(&input);
            ticks += 1;
            if out.target_reached {
                break out;
            }
            assert!(ticks < 10_000);
        };
        // 1000 rpm/s: 1.5 s / 333 µs = 4504.5 → 4505 ticks.
        assert_eq!(ticks, 4505);
        assert_eq!((out.demand_value, out.demand), (1500, 83_333));
        // 6 ticks of 333 µs: 1.998 rpm (to 2⁻¹⁶ rpm below) → 110.999… increments/s → 111.
        let mut vl = Velocity::default();
        assert_eq!(run(&mut vl, &input, 6).demand, 111);
        assert_eq!(actual_value(&parameters, Resolution::new(10_000, 3), 83_333), 1500);
    }

    #[test]
    fn reversal_decelerates_to_zero_then_accelerates() {
        let parameters = Parameters { deceleration: Slope::new(3000, 1), ..example() };
        let mut vl = Velocity::default();
        run(&mut vl, &inputs(parameters, RUN), 3700);
        let reverse = inputs(Parameters { target: -1500, ..parameters }, RUN);
        assert_eq!(run(&mut vl, &reverse, 250).demand_value, 750);
        assert_eq!(run(&mut vl, &reverse, 250).demand_value, 0);
        assert_eq!(run(&mut vl, &reverse, 1850).demand_value, -750);
        assert_eq!(run(&mut vl, &reverse, 2000).demand_value, -1500);
    }

    #[test]
    fn halt_ramps_to_zero_with_the_605d_ramp_and_resumes() {
        let parameters =
            Parameters { deceleration: Slope::new(3000, 1), quick_stop: Slope::new(15_000, 1), ..example() };
        let mut vl = Velocity::default();
        run(&mut vl, &inputs(parameters, RUN), 3700);
        // Halt wins over a locked ramp (bit 5 = 0).
        let slow = inputs(parameters, (RUN & !RAMP_UNLOCK) | HALT);
        let out = run(&mut vl, &slow, 100);
        assert_eq!(out.demand_value, 1200);
        assert!(!out.target_reached);
        let out = run(&mut vl, &slow, 400);
        assert_eq!(out.demand_value, 0);
        assert!(out.target_reached);
        // Released: back towards 1500 with 6048h.
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 37).demand_value, 15);

        let mut vl = Velocity::default();
        run(&mut vl, &inputs(parameters, RUN), 3700);
        let quick = Inputs { halt: StopKind::QuickStopRamp, ..inputs(parameters, RUN | HALT) };
        assert_eq!(run(&mut vl, &quick, 50).demand_value, 750);
        assert_eq!(run(&mut vl, &quick, 50).demand_value, 0);
    }

    #[test]
    fn a_profile_stop_ignores_the_controlword_until_reset() {
        let parameters = Parameters { quick_stop: Slope::new(15_000, 1), ..example() };
        let mut vl = Velocity::default();
        run(&mut vl, &inputs(parameters, RUN), 3700);
        vl.stop(StopKind::QuickStopRamp);
        assert!(vl.is_stopping());
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 50).demand_value, 750);
        assert_eq!(run(&mut vl, &inputs(parameters, 0x006F), 50).demand_value, 0);
        assert!(vl.is_at_rest());
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 50).demand_value, 0);
        // A slow-down stop uses 6049h, or 6048h when 6049h is 0.
        vl.reset(102_400);
        vl.stop(StopKind::SlowDown);
        assert_eq!(run(&mut vl, &inputs(parameters, RUN), 1850).demand_value, 750);
        // Coast: 0 at once.
        vl.stop(StopKind::Coast);
        assert_eq!(vl.tick(&inputs(parameters, RUN)).demand, 0);
        // A 604Ah of 0 falls back to the deceleration.
        let fallback =
            Parameters { quick_stop: Slope::new(0, 1), deceleration: Slope::new(3000, 1), ..example() };
        assert_eq!(fallback.quick_stop_slope(), Slope::new(3000, 1));
    }

    #[test]
    fn reset_starts_the_ramp_from_the_actual_velocity() {
        let mut vl = Velocity::default();
        vl.reset(51_200);
        assert!(!vl.is_at_rest());
        // 750 rpm, then on towards 1500 at 15000/37 rpm/s: 750 + 0.405 after one tick.
        let out = vl.tick(&inputs(example(), RUN));
        assert_eq!((out.demand_value, out.demand), (750, 51_228));
        assert_eq!(run(&mut vl, &inputs(example(), RUN), 1850).demand_value, 1500);
    }

    #[test]
    fn extreme_values_saturate_without_overflow() {
        // A start far beyond INTEGER16 and the velocity limit: both saturate.
        let mut vl = Velocity::default();
        vl.reset(i64::MAX);
        let out = vl.tick(&inputs(Parameters::DEFAULT, RUN));
        assert_eq!((out.demand_value, out.demand), (i16::MAX, i64::from(u32::MAX)));
        assert_eq!(actual_value(&Parameters::DEFAULT, ENCODER, i64::MAX), i16::MAX);
        assert_eq!(actual_value(&Parameters::DEFAULT, ENCODER, i64::MIN), i16::MIN);
        // Every factor, slope and time at its extreme: no overflow, the demand within its limit.
        for (setpoint_factor, dimension_factor) in
            [((i16::MIN, 1), (i32::MIN, 1)), ((1, i16::MIN), (1, i32::MIN)), ((i16::MAX, 1), (i32::MAX, 1))]
        {
            let parameters = Parameters {
                target: i16::MIN,
                min_amount: u32::MAX,
                max_amount: u32::MAX,
                acceleration: Slope::new(u32::MAX, 1),
                deceleration: Slope::new(u32::MAX, 1),
                quick_stop: Slope::new(u32::MAX, 1),
                setpoint_factor,
                dimension_factor,
            };
            for resolution in [Resolution::new(u32::MAX, 1), Resolution::new(1, u32::MAX)] {
                for start in [i64::MIN, i64::MAX] {
                    let input = Inputs {
                        resolution,
                        actual_velocity: start,
                        dt: Duration::from_micros(u64::MAX),
                        ..inputs(parameters, RUN)
                    };
                    let mut vl = Velocity::default();
                    vl.reset(start);
                    for _ in 0..3 {
                        assert!(vl.tick(&input).demand.unsigned_abs() <= u64::from(u32::MAX));
                    }
                    vl.stop(StopKind::QuickStopRamp);
                    assert_eq!(vl.tick(&input).demand, 0);
                }
            }
        }
        // Zeros that slipped past check_write count as 1: 1500 rpm at 1 increment/revolution.
        let zeros = Parameters { setpoint_factor: (0, 0), dimension_factor: (0, 0), ..example() };
        let input = Inputs { resolution: Resolution::new(0, 0), ..inputs(zeros, RUN) };
        assert_eq!(run(&mut Velocity::default(), &input, 4000).demand, 25);
    }
}
