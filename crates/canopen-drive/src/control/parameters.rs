//! Gains and limits of the cascade, their validation, and the manufacturer object that holds
//! them in the dictionary.
//!
//! # The parameter record
//!
//! [`object`] describes one RECORD at an index the firmware chooses in the manufacturer area
//! (2000h–5FFFh):
//!
//! | sub | name | type | unit | default |
//! |---|---|---|---|---|
//! | 0 | Highest sub-index supported | UNSIGNED8, const | — | 5 |
//! | 1 | Position loop gain | UNSIGNED32, rw | 1/s, Q16.16 | 20/s (`0x0014_0000`) |
//! | 2 | Velocity loop gain | UNSIGNED32, rw | ‰ of rated torque per increment/s, Q8.24 | 0.01 (`167_772`) |
//! | 3 | Velocity loop integral time | UNSIGNED32, rw | µs, 0 = no integral action | 20 000 |
//! | 4 | Velocity limit | UNSIGNED32, rw | increments/s, 1..=7FFF_FFFFh | 7FFF_FFFFh |
//! | 5 | Torque limit | UNSIGNED16, rw | ‰ of rated torque, 1..=7FFFh | 1000 |
//!
//! The dictionary refuses single values outside these ranges with 0609_0031h/0609_0032h. The
//! one rule that needs the tick rate (an integral time shorter than one tick) is checked by
//! [`check_write`], which a firmware calls from its
//! [`ObjectHooks::validate`](crate::od::ObjectHooks::validate).

use crate::od::{AbortCode, Access, DataType, DefaultValue, Dictionary, Object, Var};

/// Fractional bits of [`Parameters::position_gain`] (Q16.16: `1 << 16` is 1/s).
pub const POSITION_GAIN_FRAC: u32 = 16;

/// Fractional bits of [`Parameters::velocity_gain`] (Q8.24: `1 << 24` is 1 ‰ per increment/s).
pub const VELOCITY_GAIN_FRAC: u32 = 24;

/// Name of the parameter record in the dictionary and the EDS.
pub const OBJECT_NAME: &str = "Cascade controller parameters";

/// Sub-indices of the parameter record.
pub mod sub {
    /// Highest sub-index supported (constant 5).
    pub const HIGHEST: u8 = 0;
    /// [`Parameters::position_gain`](super::Parameters::position_gain).
    pub const POSITION_GAIN: u8 = 1;
    /// [`Parameters::velocity_gain`](super::Parameters::velocity_gain).
    pub const VELOCITY_GAIN: u8 = 2;
    /// [`Parameters::integral_time_us`](super::Parameters::integral_time_us).
    pub const INTEGRAL_TIME: u8 = 3;
    /// [`Parameters::velocity_limit`](super::Parameters::velocity_limit).
    pub const VELOCITY_LIMIT: u8 = 4;
    /// [`Parameters::torque_limit`](super::Parameters::torque_limit).
    pub const TORQUE_LIMIT: u8 = 5;
}

/// Largest velocity limit: the velocity command is an INTEGER32 (60FAh).
pub const MAX_VELOCITY_LIMIT: u32 = i32::MAX as u32;

/// Largest torque limit: the torque demand is an INTEGER16 (6074h).
pub const MAX_TORQUE_LIMIT: u16 = i16::MAX as u16;

/// Gains and limits of the cascade.
///
/// The gains are unsigned fixed-point numbers so that every value of the 32-bit dictionary
/// entry means something and no per-tick division is needed. Torque is in thousandths of the
/// rated torque (the unit of 6071h/6072h/6074h), positions in increments, velocities in
/// increments per second (the units of 6064h/606Ch after the factor group).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Parameters {
    /// Kp of the position loop: velocity command per position error, in 1/s as Q16.16
    /// (`100 << 16` turns 1 increment of error into 100 increments/s). Range 2⁻¹⁶ … 65 536 /s.
    pub position_gain: u32,
    /// Kp of the velocity loop: torque per velocity error, in ‰ of rated torque per
    /// increment/s as Q8.24 (`1 << 24` turns 1 increment/s of error into 1 ‰). Range
    /// 6·10⁻⁸ … 256.
    pub velocity_gain: u32,
    /// Tn of the velocity loop in µs: the time in which the integral part, for a constant
    /// error, grows by as much as the proportional part. 0 switches integral action off.
    pub integral_time_us: u32,
    /// Largest velocity command, increments/s, in 1..=[`MAX_VELOCITY_LIMIT`].
    pub velocity_limit: u32,
    /// Largest torque demand, ‰ of rated torque, in 1..=[`MAX_TORQUE_LIMIT`].
    pub torque_limit: u16,
}

impl Parameters {
    /// Cautious defaults for an untuned axis: position gain 20/s, velocity gain 0.01 ‰ per
    /// increment/s, integral time 20 ms, no velocity limit of its own (the profile's limits
    /// apply through [`Cascade::set_limits`](super::Cascade::set_limits)), torque limit the
    /// rated torque.
    pub const DEFAULT: Parameters = Parameters {
        position_gain: 20 << POSITION_GAIN_FRAC,
        velocity_gain: 167_772, // 0.01 × 2²⁴
        integral_time_us: 20_000,
        velocity_limit: MAX_VELOCITY_LIMIT,
        torque_limit: 1000,
    };

    /// Checks that the parameters make a controller at a tick rate of `tick_hz`.
    ///
    /// Refused: a tick rate of 0; a gain of 0 (the loop would be open); an integral time
    /// shorter than one tick (the integral part would outgrow the proportional part within a
    /// single tick, which the discrete loop cannot follow); limits of 0 or beyond the range of
    /// the outputs. Large gains are accepted: whether they are stable depends on the axis.
    pub const fn validate(&self, tick_hz: u32) -> Result<(), ParameterError> {
        if tick_hz == 0 {
            return Err(ParameterError::TickRateZero);
        }
        if self.position_gain == 0 {
            return Err(ParameterError::PositionGainZero);
        }
        if self.velocity_gain == 0 {
            return Err(ParameterError::VelocityGainZero);
        }
        // Tn ≥ one tick ⇔ Tn[µs] · f[Hz] ≥ 10⁶ (exact: both factors are below 2³²).
        if self.integral_time_us != 0 && (self.integral_time_us as u64) * (tick_hz as u64) < 1_000_000 {
            return Err(ParameterError::IntegralTimeBelowTick);
        }
        if self.velocity_limit == 0 {
            return Err(ParameterError::VelocityLimitZero);
        }
        if self.velocity_limit > MAX_VELOCITY_LIMIT {
            return Err(ParameterError::VelocityLimitTooHigh);
        }
        if self.torque_limit == 0 {
            return Err(ParameterError::TorqueLimitZero);
        }
        if self.torque_limit > MAX_TORQUE_LIMIT {
            return Err(ParameterError::TorqueLimitTooHigh);
        }
        Ok(())
    }

    /// Reads the parameter record at `index` (laid out by [`object`] or [`object_with`]).
    /// Refuses a missing object or sub-index, or an entry of another size, with its code.
    pub fn from_dictionary<const BYTES: usize>(
        od: &Dictionary<BYTES>,
        index: u16,
    ) -> Result<Self, AbortCode> {
        Ok(Parameters {
            position_gain: od.get::<u32>(index, sub::POSITION_GAIN)?,
            velocity_gain: od.get::<u32>(index, sub::VELOCITY_GAIN)?,
            integral_time_us: od.get::<u32>(index, sub::INTEGRAL_TIME)?,
            velocity_limit: od.get::<u32>(index, sub::VELOCITY_LIMIT)?,
            torque_limit: od.get::<u16>(index, sub::TORQUE_LIMIT)?,
        })
    }

    /// Writes the parameters into the record at `index` (device side, no access check), e.g.
    /// to install board-specific tuning at start-up.
    pub fn to_dictionary<const BYTES: usize>(
        &self,
        od: &mut Dictionary<BYTES>,
        index: u16,
    ) -> Result<(), AbortCode> {
        od.set::<u32>(index, sub::POSITION_GAIN, self.position_gain)?;
        od.set::<u32>(index, sub::VELOCITY_GAIN, self.velocity_gain)?;
        od.set::<u32>(index, sub::INTEGRAL_TIME, self.integral_time_us)?;
        od.set::<u32>(index, sub::VELOCITY_LIMIT, self.velocity_limit)?;
        od.set::<u16>(index, sub::TORQUE_LIMIT, self.torque_limit)
    }

    /// The same parameters with sub-index `sub` replaced by the little-endian value `data`
    /// (as an SDO download carries it).
    pub fn with_entry(mut self, sub: u8, data: &[u8]) -> Result<Self, AbortCode> {
        match sub {
            sub::HIGHEST => return Err(AbortCode::WriteOfReadOnly),
            sub::POSITION_GAIN => self.position_gain = u32_from(data)?,
            sub::VELOCITY_GAIN => self.velocity_gain = u32_from(data)?,
            sub::INTEGRAL_TIME => self.integral_time_us = u32_from(data)?,
            sub::VELOCITY_LIMIT => self.velocity_limit = u32_from(data)?,
            sub::TORQUE_LIMIT => {
                let bytes: [u8; 2] = exact(data)?;
                self.torque_limit = u16::from_le_bytes(bytes);
            }
            _ => return Err(AbortCode::SubIndexDoesNotExist),
        }
        Ok(self)
    }
}

impl Default for Parameters {
    fn default() -> Self {
        Self::DEFAULT
    }
}

fn exact<const N: usize>(data: &[u8]) -> Result<[u8; N], AbortCode> {
    match data.len() {
        n if n > N => Err(AbortCode::LengthTooHigh),
        n if n < N => Err(AbortCode::LengthTooLow),
        _ => data.try_into().map_err(|_| AbortCode::LengthMismatch),
    }
}

fn u32_from(data: &[u8]) -> Result<u32, AbortCode> {
    exact::<4>(data).map(u32::from_le_bytes)
}

/// Why a set of [`Parameters`] (with a tick rate) does not make a controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ParameterError {
    /// The tick rate is 0 Hz.
    TickRateZero,
    /// The position loop gain is 0.
    PositionGainZero,
    /// The velocity loop gain is 0.
    VelocityGainZero,
    /// The integral time is not 0 but shorter than one tick.
    IntegralTimeBelowTick,
    /// The velocity limit is 0.
    VelocityLimitZero,
    /// The velocity limit exceeds [`MAX_VELOCITY_LIMIT`].
    VelocityLimitTooHigh,
    /// The torque limit is 0.
    TorqueLimitZero,
    /// The torque limit exceeds [`MAX_TORQUE_LIMIT`].
    TorqueLimitTooHigh,
}

impl ParameterError {
    /// The sub-index of the parameter record at fault (`None` for the tick rate).
    pub const fn sub_index(self) -> Option<u8> {
        match self {
            ParameterError::TickRateZero => None,
            ParameterError::PositionGainZero => Some(sub::POSITION_GAIN),
            ParameterError::VelocityGainZero => Some(sub::VELOCITY_GAIN),
            ParameterError::IntegralTimeBelowTick => Some(sub::INTEGRAL_TIME),
            ParameterError::VelocityLimitZero | ParameterError::VelocityLimitTooHigh => {
                Some(sub::VELOCITY_LIMIT)
            }
            ParameterError::TorqueLimitZero | ParameterError::TorqueLimitTooHigh => Some(sub::TORQUE_LIMIT),
        }
    }

    /// The SDO abort code that refuses a write producing this error.
    pub const fn abort_code(self) -> AbortCode {
        match self {
            ParameterError::TickRateZero => AbortCode::InternalIncompatibility,
            ParameterError::PositionGainZero
            | ParameterError::VelocityGainZero
            | ParameterError::IntegralTimeBelowTick
            | ParameterError::VelocityLimitZero
            | ParameterError::TorqueLimitZero => AbortCode::ValueTooLow,
            ParameterError::VelocityLimitTooHigh | ParameterError::TorqueLimitTooHigh => {
                AbortCode::ValueTooHigh
            }
        }
    }
}

impl From<ParameterError> for AbortCode {
    fn from(error: ParameterError) -> Self {
        error.abort_code()
    }
}

/// Checks an SDO write of `data` to `sub` of the parameter record at `index` against the
/// other values in the dictionary and the tick rate. Call it from
/// [`ObjectHooks::validate`](crate::od::ObjectHooks::validate) for that index; after the
/// write, read the record again with [`Parameters::from_dictionary`] and hand it to
/// [`Cascade::set_parameters`](super::Cascade::set_parameters).
pub fn check_write<const BYTES: usize>(
    od: &Dictionary<BYTES>,
    index: u16,
    sub: u8,
    data: &[u8],
    tick_hz: u32,
) -> Result<(), AbortCode> {
    let candidate = Parameters::from_dictionary(od, index)?.with_entry(sub, data)?;
    candidate.validate(tick_hz).map_err(ParameterError::abort_code)
}

const fn gain(name: &'static str, default: u32) -> Var {
    Var::new(name, DataType::Unsigned32)
        .access(Access::ReadWrite)
        .limits_unsigned(1, u32::MAX as u64)
        .default(DefaultValue::Unsigned(default as u64))
}

/// The sub-indices of a parameter record whose defaults are `defaults`, for a firmware that
/// ships its own tuning:
///
/// ```
/// use canopen_drive::control::{object_with, record_subs, Parameters};
/// use canopen_drive::od::{layout, Object, Var};
///
/// static TUNED: [(u8, Var); 6] =
///     record_subs(&Parameters { position_gain: 80 << 16, ..Parameters::DEFAULT });
/// static VENDOR: [Object; 1] = layout([object_with(0x2400, &TUNED)]);
/// # assert_eq!(VENDOR[0].index, 0x2400);
/// ```
pub const fn record_subs(defaults: &Parameters) -> [(u8, Var); 6] {
    [
        (
            sub::HIGHEST,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(sub::TORQUE_LIMIT as u64)),
        ),
        (sub::POSITION_GAIN, gain("Position loop gain", defaults.position_gain)),
        (sub::VELOCITY_GAIN, gain("Velocity loop gain", defaults.velocity_gain)),
        (
            sub::INTEGRAL_TIME,
            Var::new("Velocity loop integral time", DataType::Unsigned32)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(defaults.integral_time_us as u64)),
        ),
        (
            sub::VELOCITY_LIMIT,
            Var::new("Velocity limit", DataType::Unsigned32)
                .access(Access::ReadWrite)
                .limits_unsigned(1, MAX_VELOCITY_LIMIT as u64)
                .default(DefaultValue::Unsigned(defaults.velocity_limit as u64)),
        ),
        (
            sub::TORQUE_LIMIT,
            Var::new("Torque limit", DataType::Unsigned16)
                .access(Access::ReadWrite)
                .limits_unsigned(1, MAX_TORQUE_LIMIT as u64)
                .default(DefaultValue::Unsigned(defaults.torque_limit as u64)),
        ),
    ]
}

/// The record's sub-indices with [`Parameters::DEFAULT`].
pub static DEFAULT_SUBS: [(u8, Var); 6] = record_subs(&Parameters::DEFAULT);

/// The parameter record at `index` (manufacturer area 2000h–5FFFh) with
/// [`Parameters::DEFAULT`], for the firmware's manufacturer table:
///
/// ```
/// use canopen_drive::control;
/// use canopen_drive::od::{layout, Object};
///
/// const CASCADE_PARAMETERS: u16 = 0x2400;
/// static VENDOR: [Object; 1] = layout([control::object(CASCADE_PARAMETERS)]);
/// # assert_eq!(VENDOR[0].name(), control::OBJECT_NAME);
/// ```
pub const fn object(index: u16) -> Object {
    object_with(index, &DEFAULT_SUBS)
}

/// The parameter record at `index` with sub-indices built by [`record_subs`].
pub const fn object_with(index: u16, subs: &'static [(u8, Var); 6]) -> Object {
    // The drive profile checks its values (`check_write`) for the index its configuration names.
    Object::record(index, OBJECT_NAME, subs).owned_by(crate::od::Owner::Profile)
}

#[cfg(test)]
mod unit_tests {
    use super::*;
    use crate::od::{layout, DeviceInfo};

    const INDEX: u16 = 0x2400;
    static TABLE: [Object; 1] = layout([object(INDEX)]);

    fn dictionary() -> Dictionary<64> {
        Dictionary::new(&[&TABLE], DeviceInfo::servo_drive(), 1).unwrap()
    }

    #[test]
    fn defaults_are_valid_and_read_back() {
        let od = dictionary();
        assert_eq!(Parameters::from_dictionary(&od, INDEX), Ok(Parameters::DEFAULT));
        assert_eq!(od.get::<u8>(INDEX, 0), Ok(5));
        for hz in [1_000, 4_000, 16_000] {
            assert_eq!(Parameters::DEFAULT.validate(hz), Ok(()));
        }
        assert_eq!(od.used_bytes(), 4 * 4 + 2);
    }

    #[test]
    fn round_trip_through_the_dictionary() {
        let mut od = dictionary();
        let tuned = Parameters {
            position_gain: 123 << 16,
            velocity_gain: 1 << 24,
            integral_time_us: 0,
            velocity_limit: 99_999,
            torque_limit: 2500,
        };
        tuned.to_dictionary(&mut od, INDEX).unwrap();
        assert_eq!(Parameters::from_dictionary(&od, INDEX), Ok(tuned));
        assert_eq!(Parameters::from_dictionary(&od, 0x2401), Err(AbortCode::ObjectDoesNotExist));
    }

    #[test]
    fn dictionary_bounds_refuse_single_values() {
        let od = dictionary();
        let limit = od.entry(INDEX, sub::VELOCITY_LIMIT).unwrap();
        assert_eq!(od.check_write(&limit, &0u32.to_le_bytes()), Err(AbortCode::ValueTooLow));
        assert_eq!(od.check_write(&limit, &0x8000_0000u32.to_le_bytes()), Err(AbortCode::ValueTooHigh));
        let torque = od.entry(INDEX, sub::TORQUE_LIMIT).unwrap();
        assert_eq!(od.check_write(&torque, &0x8000u16.to_le_bytes()), Err(AbortCode::ValueTooHigh));
        let gain = od.entry(INDEX, sub::VELOCITY_GAIN).unwrap();
        assert_eq!(od.check_write(&gain, &0u32.to_le_bytes()), Err(AbortCode::ValueTooLow));
        assert_eq!(od.check_write(&gain, &u32::MAX.to_le_bytes()), Ok(()));
        assert!(!od.entry(INDEX, sub::HIGHEST).unwrap().var.access.writable());
    }

    #[test]
    fn check_write_applies_the_tick_rate() {
        let od = dictionary();
        // 100 µs is one tick at 10 kHz, too short at 4 kHz.
        let data = 100u32.to_le_bytes();
        assert_eq!(check_write(&od, INDEX, sub::INTEGRAL_TIME, &data, 10_000), Ok(()));
        assert_eq!(check_write(&od, INDEX, sub::INTEGRAL_TIME, &data, 4_000), Err(AbortCode::ValueTooLow));
        assert_eq!(check_write(&od, INDEX, sub::INTEGRAL_TIME, &0u32.to_le_bytes(), 4_000), Ok(()));
        assert_eq!(check_write(&od, INDEX, sub::TORQUE_LIMIT, &[1], 4_000), Err(AbortCode::LengthTooLow));
        assert_eq!(
            check_write(&od, INDEX, sub::TORQUE_LIMIT, &[1, 0, 0], 4_000),
            Err(AbortCode::LengthTooHigh)
        );
        assert_eq!(check_write(&od, INDEX, 6, &[1, 0, 0, 0], 4_000), Err(AbortCode::SubIndexDoesNotExist));
        assert_eq!(check_write(&od, INDEX, 0, &[5], 4_000), Err(AbortCode::WriteOfReadOnly));
        assert_eq!(check_write(&od, INDEX, sub::POSITION_GAIN, &[0; 4], 4_000), Err(AbortCode::ValueTooLow));
    }

    #[test]
    fn validation_names_the_sub_index() {
        let base = Parameters::DEFAULT;
        let cases = [
            (base, 0, ParameterError::TickRateZero),
            (Parameters { position_gain: 0, ..base }, 1000, ParameterError::PositionGainZero),
            (Parameters { velocity_gain: 0, ..base }, 1000, ParameterError::VelocityGainZero),
            (Parameters { integral_time_us: 999, ..base }, 1000, ParameterError::IntegralTimeBelowTick),
            (Parameters { velocity_limit: 0, ..base }, 1000, ParameterError::VelocityLimitZero),
            (Parameters { velocity_limit: u32::MAX, ..base }, 1000, ParameterError::VelocityLimitTooHigh),
            (Parameters { torque_limit: 0, ..base }, 1000, ParameterError::TorqueLimitZero),
            (Parameters { torque_limit: u16::MAX, ..base }, 1000, ParameterError::TorqueLimitTooHigh),
        ];
        for (parameters, hz, error) in cases {
            assert_eq!(parameters.validate(hz), Err(error));
            assert_eq!(error.sub_index().is_none(), error == ParameterError::TickRateZero);
        }
        assert_eq!(Parameters { integral_time_us: 1000, ..base }.validate(1000), Ok(()));
        assert_eq!(Parameters { integral_time_us: 1, ..base }.validate(u32::MAX), Ok(()));
        let extreme = Parameters {
            position_gain: u32::MAX,
            velocity_gain: u32::MAX,
            integral_time_us: u32::MAX,
            velocity_limit: MAX_VELOCITY_LIMIT,
            torque_limit: MAX_TORQUE_LIMIT,
        };
        assert_eq!(extreme.validate(u32::MAX), Ok(()));
    }
}
