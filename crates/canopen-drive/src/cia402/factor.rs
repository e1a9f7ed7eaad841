//! Factor group (608Fh–6092h) and polarity (607Eh): user units ↔ internal units (CiA 402-2 §9).
//!
//! ```text
//! user = increments × 6092.1 × 608F.2 × 6091.2 / (6092.2 × 608F.1 × 6091.1)
//! ```
//!
//! The ratio is kept as a reduced fraction `numerator / denominator` of two products of three
//! UNSIGNED32 values (each below 2⁹⁶), and every conversion is one multiplication and one
//! division in 128-bit integers from the absolute value — never accumulated — so converting a
//! position a million times gives the same result as converting it once, and nothing rounds
//! twice. Rounding: to the nearest integer, halves away from zero. Results beyond the i32
//! range saturate (a 32-bit object cannot show them). Where both terms of a ratio fit 32 bits
//! (most drives), each keeps its reciprocal, and a value below 2³² converts with
//! multiplications and one correction instead of a 64-bit division (a library call on a
//! Cortex-M): the same result, exactly.
//!
//! Velocities are user position units per second and accelerations per second² (CiA 402-2 §9.1),
//! so they use the same ratio — unless the configuration puts them in motor rpm
//! ([`VelocityUnit::MotorRpm`]): then their ratio is `60 × 608F.2 / 608F.1` (rpm per increment/s;
//! rpm/s, rpm/s² for accelerations and jerks), kept and applied the same way. 6090h (velocity encoder resolution) describes a separate velocity
//! sensor; the feedback of this crate ([`crate::hal::Sample::velocity`]) is in position-encoder
//! increments per second, so 6090h is kept and validated but does not enter a conversion.
//! 6080h max motor speed is in rpm and becomes increments/s through 608Fh alone.
//!
//! Torques (6071h, 6074h, 6077h, 60B2h) and the current 6078h are ‰ of rated, the core's own
//! unit, or mA ([`TorqueUnit::MilliAmps`]): `mA = ‰ × 6075h / 1000`, rounded the same way,
//! saturated to INTEGER16.
//!
//! Polarity (607Eh, CiA 402-2 §9.2.5, its recommended reading): position polarity (bit 7) negates
//! the commanded target 607Ah in profile position mode, and the reported positions 6062h,
//! 6064h and 60F4h in every mode, so that the master's frame stays one mirror image whatever
//! the mode; velocity polarity (bit 6) negates the target velocity 60FFh in profile velocity
//! mode and the reported velocities 606Bh/606Ch. Homing will ignore 607Eh for its search
//! directions (CiA 402-2 §9.2.5); torque modes ignore it.

use super::config::{MotorSpeedUnit, TorqueUnit, Units, VelocityUnit};
use super::objects::parameter;
use super::objects::Rule;
use super::objects::{
    FEED_CONSTANT, GEAR_RATIO, POLARITY, POSITION_ENCODER_RESOLUTION, VELOCITY_ENCODER_RESOLUTION,
};
use super::Axis;
use crate::od::{AbortCode, Dictionary};
use crate::od::{Access, DataType, DefaultValue, Object, Var};
use crate::wide::saturate_i32;

/// 607Eh bit 7: position polarity.
pub const POSITION_POLARITY: u8 = 0x80;
/// 607Eh bit 6: velocity polarity.
pub const VELOCITY_POLARITY: u8 = 0x40;

/// The conversion between user units and internal units (increments) of one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Factors {
    /// Positions: user = internal × numerator / denominator.
    position: Ratio,
    /// Velocities (accelerations, jerks), the same or in motor rpm ([`VelocityUnit`]).
    velocity: Ratio,
    /// 608Fh sub 1 / sub 2: increments per motor revolution.
    increments: u32,
    revolutions: u32,
    polarity: u8,
    torque_unit: TorqueUnit,
    motor_speed_unit: MotorSpeedUnit,
    /// 6075h motor rated current (mA).
    rated_current: u32,
}

impl Default for Factors {
    /// 1:1 in every object: user units are increments.
    fn default() -> Self {
        Factors {
            position: Ratio::ONE,
            velocity: Ratio::ONE,
            increments: 1,
            revolutions: 1,
            polarity: 0,
            torque_unit: TorqueUnit::PerMilleOfRated,
            motor_speed_unit: MotorSpeedUnit::Rpm,
            rated_current: 0,
        }
    }
}

fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        let r = crate::wide::urem(a, b);
        a = b;
        b = r;
    }
    a
}

/// `value × numerator / denominator`, rounded to nearest (halves away from zero), saturated to
/// i64. `numerator` and `denominator` are below 2⁹⁶ and not 0; |value| < 2⁶³, so the product
/// may exceed 128 bits only when it would saturate anyway, which is checked first.
///
/// The common cases take narrower arithmetic with the same result (a 128-bit division is a
/// library call of several hundred instructions on a 32-bit MCU, and this runs every tick): a
/// 1:1 ratio returns `value`, and operands below 2³² multiply and divide in 64 bits.
fn scale(value: i64, numerator: u128, denominator: u128) -> i64 {
    if numerator == denominator && value != i64::MIN {
        return value;
    }
    let magnitude = u128::from(value.unsigned_abs());
    if let (Ok(m), Ok(n), Ok(d)) =
        (u32::try_from(magnitude), u32::try_from(numerator), u32::try_from(denominator))
    {
        // (2³² − 1)² + 2³¹ < 2⁶⁴: no overflow; the result is below 2⁶⁴ / 1 but may exceed i64.
        let result = (u64::from(m) * u64::from(n) + u64::from(d) / 2) / u64::from(d.max(1));
        let result = i64::try_from(result).unwrap_or(i64::MAX);
        return if value < 0 { -result } else { result };
    }
    let result = match magnitude.checked_mul(numerator) {
        Some(product) => crate::wide::udiv(product + denominator / 2, denominator.max(1)),
        None => u128::MAX,
    };
    let result = i64::try_from(result).unwrap_or(i64::MAX);
    if value < 0 {
        -result
    } else {
        result
    }
}

/// One ratio of the factor group, both ways: user = internal × numerator / denominator
/// (reduced).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Ratio {
    numerator: u128,
    denominator: u128,
    /// 1:1 (user units are increments): every conversion tests this first, inline.
    unity: bool,
    /// Both terms below 2³²: the reciprocals of the numerator and of the denominator, so that a
    /// value below 2³² converts with multiplications alone ([`Reciprocal`]): the ticks of a
    /// drive in user units convert half a dozen values each.
    narrow: Option<(Reciprocal, Reciprocal)>,
}

impl Ratio {
    const ONE: Ratio = Ratio { numerator: 1, denominator: 1, unity: true, narrow: None };

    fn new(numerator: u128, denominator: u128) -> Self {
        let narrow = match (u32::try_from(numerator), u32::try_from(denominator)) {
            (Ok(n), Ok(d)) if n != d => Some((Reciprocal::of(n), Reciprocal::of(d))),
            _ => None,
        };
        Ratio { numerator, denominator, unity: numerator == denominator, narrow }
    }

    /// Internal to user units ([`scale`] by numerator / denominator).
    #[inline]
    fn forward(&self, value: i64) -> i64 {
        if self.unity && value != i64::MIN {
            return value;
        }
        self.forward_scaled(value)
    }

    /// User to internal units ([`scale`] by denominator / numerator).
    #[inline]
    fn backward(&self, value: i64) -> i64 {
        if self.unity && value != i64::MIN {
            return value;
        }
        self.backward_scaled(value)
    }

    /// [`Self::forward`] but 1:1, out of line: the places that convert hold only the test.
    #[inline(never)]
    fn forward_scaled(&self, value: i64) -> i64 {
        match self.narrow {
            Some((numerator, denominator)) => scale_narrow(value, numerator.divisor, denominator),
            None => None,
        }
        .unwrap_or_else(|| scale(value, self.numerator, self.denominator))
    }

    /// [`Self::backward`] but 1:1, out of line as [`Self::forward_scaled`].
    #[inline(never)]
    fn backward_scaled(&self, value: i64) -> i64 {
        match self.narrow {
            Some((numerator, denominator)) => scale_narrow(value, denominator.divisor, numerator),
            None => None,
        }
        .unwrap_or_else(|| scale(value, self.denominator, self.numerator))
    }
}

/// A 32-bit divisor with its reciprocal: `x / divisor` for any 64-bit `x` as a multiplication
/// and one correction (a 64-bit division is a library call of 100–200 instructions on a
/// Cortex-M, which divides 32 bits in hardware).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Reciprocal {
    divisor: u32,
    /// ⌊(2⁶⁴ − 1) / divisor⌋.
    inverse: u64,
}

impl Reciprocal {
    /// The reciprocal of `divisor` (0 counts as 1).
    const fn of(divisor: u32) -> Self {
        let divisor = if divisor == 0 { 1 } else { divisor };
        Reciprocal { divisor, inverse: u64::MAX / divisor as u64 }
    }

    /// ⌊x / divisor⌋. With q = x / d exactly, x · inverse / 2⁶⁴ lies in (q − 1, q): it is at
    /// least x (2⁶⁴ − d) / (d 2⁶⁴) = q − x / 2⁶⁴ > q − 1 and below q, so the estimate is the
    /// quotient or one below it, and the remainder tells which.
    #[inline]
    fn divide(self, x: u64) -> u64 {
        let divisor = u64::from(self.divisor);
        let estimate = ((u128::from(x) * u128::from(self.inverse)) >> 64) as u64;
        // estimate × divisor ≤ x: no overflow.
        let remainder = x.wrapping_sub(estimate.wrapping_mul(divisor));
        if remainder >= divisor {
            estimate.wrapping_add(1)
        } else {
            estimate
        }
    }
}

/// [`scale`] of a value whose magnitude is below 2³² by `multiplier / divisor` (both below
/// 2³²): `None` for a larger value.
#[inline]
fn scale_narrow(value: i64, multiplier: u32, divisor: Reciprocal) -> Option<i64> {
    let magnitude = u32::try_from(value.unsigned_abs()).ok()?;
    // (2³² − 1)² + 2³¹ < 2⁶⁴: no overflow; the result may exceed i64 (a divisor of 1).
    let rounded = u64::from(magnitude) * u64::from(multiplier) + u64::from(divisor.divisor / 2);
    let result = i64::try_from(divisor.divide(rounded)).unwrap_or(i64::MAX);
    Some(if value < 0 { -result } else { result })
}

/// `numerator / denominator` reduced (neither is 0 after).
fn reduced(numerator: u128, denominator: u128) -> (u128, u128) {
    let common = gcd(numerator, denominator).max(1);
    (crate::wide::udiv(numerator, common).max(1), crate::wide::udiv(denominator, common).max(1))
}

fn pair<const B: usize>(od: &Dictionary<B>, index: u16) -> (u32, u32) {
    let sub = |s| od.get::<u32>(index, s).ok().filter(|v| *v != 0).unwrap_or(1);
    (sub(1), sub(2))
}

impl Factors {
    /// The factors the dictionary holds now, in CiA 402's units (a 0 that slipped in counts
    /// as 1).
    pub fn from_od<const B: usize>(od: &Dictionary<B>) -> Self {
        Factors::from_od_in(od, Units::CIA_402)
    }

    /// The factors the dictionary holds now, for objects in `units`.
    pub fn from_od_in<const B: usize>(od: &Dictionary<B>, units: Units) -> Self {
        Factors::from_axis(od, units, Axis::FIRST)
    }

    /// [`Self::from_od_in`] from the objects of `axis`.
    pub fn from_axis<const B: usize>(od: &Dictionary<B>, units: Units, axis: Axis) -> Self {
        let (increments, revolutions) = pair(od, axis.index(POSITION_ENCODER_RESOLUTION));
        let (motor, shaft) = pair(od, axis.index(GEAR_RATIO));
        let (feed, feed_shaft) = pair(od, axis.index(FEED_CONSTANT));
        let (numerator, denominator) = reduced(
            u128::from(feed) * u128::from(revolutions) * u128::from(shaft),
            u128::from(feed_shaft) * u128::from(increments) * u128::from(motor),
        );
        let (velocity_numerator, velocity_denominator) = match units.velocity {
            VelocityUnit::PositionUnitsPerSecond => (numerator, denominator),
            VelocityUnit::MotorRpm => reduced(60 * u128::from(revolutions), u128::from(increments)),
        };
        Factors {
            position: Ratio::new(numerator, denominator),
            velocity: Ratio::new(velocity_numerator, velocity_denominator),
            increments,
            revolutions,
            polarity: od.get::<u8>(axis.index(POLARITY), 0).unwrap_or(0),
            torque_unit: units.torque,
            motor_speed_unit: units.motor_speed,
            rated_current: od.get::<u32>(axis.index(MOTOR_RATED_CURRENT), 0).unwrap_or(0),
        }
    }

    /// Internal (increments, increments/s, …) to user units, without polarity.
    #[inline]
    pub fn to_user(&self, internal: i64) -> i64 {
        self.position.forward(internal)
    }

    /// User units to internal units, without polarity.
    #[inline]
    pub fn to_internal(&self, user: i64) -> i64 {
        self.position.backward(user)
    }

    /// [`Self::to_user`] saturated to an INTEGER32 object.
    pub fn to_user_i32(&self, internal: i64) -> i32 {
        saturate_i32(self.to_user(internal))
    }

    /// A velocity (acceleration, jerk) in increments/s (/s², /s³) to the velocity unit, without
    /// polarity.
    #[inline]
    pub fn velocity_to_user(&self, internal: i64) -> i64 {
        self.velocity.forward(internal)
    }

    /// A velocity (acceleration, jerk) in the velocity unit to increments/s (/s², /s³), without
    /// polarity.
    #[inline]
    pub fn velocity_to_internal(&self, user: i64) -> i64 {
        self.velocity.backward(user)
    }

    /// An UNSIGNED32 limit in the velocity unit (velocity, acceleration, jerk) in internal
    /// units, saturated to u32.
    pub fn limit_to_internal(&self, user: u32) -> u32 {
        u32::try_from(self.velocity_to_internal(i64::from(user))).unwrap_or(u32::MAX)
    }

    /// A torque (or current) in ‰ of rated to the torque unit (the entry it is stored in
    /// saturates it to its width: INTEGER16, or what a firmware widened it to).
    pub fn torque_to_user(&self, permille: i64) -> i64 {
        match self.torque_unit {
            TorqueUnit::PerMilleOfRated => permille,
            TorqueUnit::MilliAmps => scale(permille, u128::from(self.rated_current), 1000),
        }
    }

    /// A torque (or current) in the torque unit to ‰ of rated (0 in mA while 6075h is 0).
    pub fn torque_to_internal(&self, user: i64) -> i64 {
        match self.torque_unit {
            TorqueUnit::PerMilleOfRated => user,
            TorqueUnit::MilliAmps if self.rated_current == 0 => 0,
            TorqueUnit::MilliAmps => scale(user, 1000, u128::from(self.rated_current)),
        }
    }

    /// The maximum motor speed 6080h in increments/s, saturated to u32, in its unit
    /// ([`MotorSpeedUnit`]).
    pub fn motor_speed_to_internal(&self, value: u32) -> u32 {
        match self.motor_speed_unit {
            MotorSpeedUnit::Rpm => self.rpm_to_internal(value),
            MotorSpeedUnit::VelocityUnit => self.limit_to_internal(value),
        }
    }

    /// A speed in rpm in increments/s, saturated to u32.
    pub fn rpm_to_internal(&self, rpm: u32) -> u32 {
        // Below 2⁶⁴ both: 64-bit arithmetic, not 128 (see `scale`).
        let per_minute = u64::from(rpm) * u64::from(self.increments);
        let divisor = 60 * u64::from(self.revolutions);
        u32::try_from(per_minute / divisor.max(1)).unwrap_or(u32::MAX)
    }

    /// −1 when position polarity (607Eh bit 7) is set, else 1.
    pub fn position_sign(&self) -> i64 {
        if self.polarity & POSITION_POLARITY != 0 {
            -1
        } else {
            1
        }
    }

    /// −1 when velocity polarity (607Eh bit 6) is set, else 1.
    pub fn velocity_sign(&self) -> i64 {
        if self.polarity & VELOCITY_POLARITY != 0 {
            -1
        } else {
            1
        }
    }
}

/// 6075h motor rated current (mA).
const MOTOR_RATED_CURRENT: u16 = 0x6075;

/// Value rules of the factor group: no 0 in a ratio (CiA 402-2 §9.1), no reserved polarity bit.
pub fn check_write(index: u16, sub: u8, raw: u32) -> Result<(), AbortCode> {
    match index {
        POSITION_ENCODER_RESOLUTION | VELOCITY_ENCODER_RESOLUTION | GEAR_RATIO | FEED_CONSTANT
            if sub != 0 && raw == 0 =>
        {
            Err(AbortCode::ValueTooLow)
        }
        POLARITY if raw & 0x3F != 0 => Err(AbortCode::InvalidValue),
        _ => Ok(()),
    }
}

/// A two-entry ratio of the factor group (608Fh–6092h), both entries 1 by default (CiA 402-2 §9.1:
/// never 0).
const fn ratio(index: u16, name: &'static str, element: &'static Var) -> Object {
    Object::array(index, name, 2, element)
}

/// The element of a ratio (in the table, `&ratio_entry(..)` is a `'static` reference).
const fn ratio_entry(name: &'static str) -> Var {
    Var::new(name, DataType::Unsigned32).access(Access::ReadWrite).default(DefaultValue::Unsigned(1))
}

/// The factor group's objects (607Eh, 608Fh–6092h), in every build.
pub(crate) const OBJECTS: [Object; 5] = [
    parameter(POLARITY, "Polarity", DataType::Unsigned8, DefaultValue::Zero),
    ratio(
        POSITION_ENCODER_RESOLUTION,
        "Position encoder resolution",
        &ratio_entry("Position encoder resolution"),
    ),
    ratio(
        VELOCITY_ENCODER_RESOLUTION,
        "Velocity encoder resolution",
        &ratio_entry("Velocity encoder resolution"),
    ),
    ratio(GEAR_RATIO, "Gear ratio", &ratio_entry("Gear ratio")),
    ratio(FEED_CONSTANT, "Feed constant", &ratio_entry("Feed constant")),
];

/// The value rule of the factor group's object `index` ([`super::registry::rule`]):
/// [`check_write`].
pub(crate) fn rule(index: u16) -> Option<Rule> {
    matches!(
        index,
        POSITION_ENCODER_RESOLUTION | VELOCITY_ENCODER_RESOLUTION | GEAR_RATIO | FEED_CONSTANT | POLARITY
    )
    .then_some(Rule::Factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factors(increments: u32, revolutions: u32, gear: (u32, u32), feed: (u32, u32)) -> Factors {
        let numerator = u128::from(feed.0) * u128::from(revolutions) * u128::from(gear.1);
        let denominator = u128::from(feed.1) * u128::from(increments) * u128::from(gear.0);
        let common = gcd(numerator, denominator);
        let ratio = Ratio::new(numerator / common, denominator / common);
        Factors {
            position: ratio,
            velocity: ratio,
            increments,
            revolutions,
            polarity: 0,
            torque_unit: TorqueUnit::PerMilleOfRated,
            motor_speed_unit: MotorSpeedUnit::Rpm,
            rated_current: 0,
        }
    }

    #[test]
    fn digest_example_converts_both_ways() {
        // 4096 increments per revolution, gear 10:1, 360 000 user units per output turn.
        let f = factors(4096, 1, (10, 1), (360_000, 1));
        assert_eq!(f.to_user(40_960), 360_000);
        assert_eq!(f.to_internal(180_000), 20_480);
    }

    #[test]
    fn extremes_saturate_and_round_half_away_from_zero() {
        let f = factors(4096, 1, (10, 1), (360_000, 1));
        // 2³¹ − 1 increments × 360000/40960 does not fit in i32.
        assert_eq!(f.to_user_i32(i64::from(i32::MAX)), i32::MAX);
        assert_eq!(f.to_user_i32(i64::from(i32::MIN)), i32::MIN);
        assert_eq!(f.to_user(i64::from(i32::MAX)), 18_874_367_991);
        // 1 user unit = 40960/360000 = 0.1137… increments → 0; 5 → 0.568… → 1; −5 → −1.
        assert_eq!(f.to_internal(1), 0);
        assert_eq!(f.to_internal(5), 1);
        assert_eq!(f.to_internal(-5), -1);
        // Largest ratios do not overflow.
        let big = factors(1, u32::MAX, (1, u32::MAX), (u32::MAX, 1));
        assert_eq!(big.to_user(i64::MAX), i64::MAX);
        assert_eq!(big.to_user(i64::MIN + 1), -i64::MAX);
        assert_eq!(big.to_internal(i64::MAX), 0);
    }

    /// The 1:1 and 64-bit paths of `scale` give what the 128-bit arithmetic gives.
    #[test]
    fn narrow_paths_of_scale_agree_with_128_bit_arithmetic() {
        let reference = |value: i64, n: u128, d: u128| -> i64 {
            let magnitude = u128::from(value.unsigned_abs());
            let result = magnitude.checked_mul(n).map_or(u128::MAX, |p| (p + d / 2) / d);
            let result = i64::try_from(result).unwrap_or(i64::MAX);
            if value < 0 {
                -result
            } else {
                result
            }
        };
        let values = [
            0,
            1,
            -1,
            2,
            -3,
            7,
            499,
            -500,
            65_535,
            1 << 31,
            -(1 << 31),
            i64::from(i32::MAX),
            i64::from(u32::MAX),
        ];
        let values = values.iter().copied().chain([i64::from(u32::MAX) + 1, i64::MAX, -i64::MAX, i64::MIN]);
        let ratios = [
            (1, 1),
            (1, 2),
            (2, 1),
            (3, 7),
            (1000, 2000),
            (u128::from(u32::MAX), 1),
            (1, u128::from(u32::MAX)),
            (u128::from(u32::MAX), u128::from(u32::MAX) - 1),
            (1 << 40, 3),
            (5, 1 << 40),
        ];
        for value in values {
            for (n, d) in ratios {
                assert_eq!(scale(value, n, d), reference(value, n, d), "{value} × {n} / {d}");
            }
        }
    }

    /// The reciprocal's quotient is the division's, for divisors and dividends at the edges
    /// and in between.
    #[test]
    fn a_reciprocal_divides_exactly() {
        extern crate std;
        use std::vec;
        let mut divisors =
            vec![1u32, 2, 3, 7, 10, 360, 1000, 3600, 4096, 65_535, 65_536, 1 << 31, u32::MAX - 1, u32::MAX];
        let mut dividends =
            vec![0u64, 1, 2, 3, 359, 360, 361, u64::from(u32::MAX), 1 << 32, u64::MAX - 1, u64::MAX];
        let mut rng = crate::testing::Rng(0x9E37_79B9_7F4A_7C15);
        let mut next = || rng.next();
        for _ in 0..200 {
            divisors.push(next() as u32 >> (next() % 32));
            dividends.push(next() >> (next() % 64));
        }
        for &d in &divisors {
            let reciprocal = Reciprocal::of(d);
            let d = u64::from(d.max(1));
            for &x in &dividends {
                assert_eq!(reciprocal.divide(x), x / d, "{x} / {d}");
                // Around the multiples of the divisor, where an estimate one short shows.
                let q = x / d;
                for y in [q * d, (q * d).saturating_sub(1), (q * d).saturating_add(d - 1)] {
                    assert_eq!(reciprocal.divide(y), y / d, "{y} / {d}");
                }
            }
        }
    }

    /// Both ways, a ratio converts as [`scale`] does, through its reciprocals or not.
    #[test]
    fn a_ratio_converts_as_scale_does() {
        let values =
            [0, 1, -1, 179, -180, 65_535, i64::from(i32::MAX), i64::from(u32::MAX), -i64::from(u32::MAX)];
        let values = values.iter().copied().chain([i64::from(u32::MAX) + 1, i64::MAX, -i64::MAX, i64::MIN]);
        let ratios = [(1, 1), (9, 25), (3600, 10_000), (u128::from(u32::MAX), 1), (1, 3), (1 << 40, 3)];
        for value in values {
            for (n, d) in ratios {
                let ratio = Ratio::new(n, d);
                assert_eq!(ratio.forward(value), scale(value, n, d), "{value} × {n} / {d}");
                assert_eq!(ratio.backward(value), scale(value, d, n), "{value} × {d} / {n}");
            }
        }
    }

    #[test]
    fn conversions_do_not_accumulate() {
        // 10000 increments per 3 motor turns, gear 7:2, 1000 user units per output turn: about
        // 11.7 increments per user unit, so user → increments → user is exact.
        let f = factors(10_000, 3, (7, 2), (1000, 1));
        for user in [-1_000_003i64, -7, 0, 1, 999_999, i64::from(i32::MAX)] {
            assert_eq!(f.to_user(f.to_internal(user)), user, "{user}");
        }
        // Converting the same value again gives the same result (no state, no drift).
        assert_eq!(f.to_internal(123_457), f.to_internal(123_457));
        assert_eq!(f.to_internal(123_457), 1_440_332);
    }

    #[test]
    fn zero_in_a_ratio_is_refused() {
        assert_eq!(check_write(GEAR_RATIO, 1, 0), Err(AbortCode::ValueTooLow));
        assert_eq!(check_write(FEED_CONSTANT, 2, 0), Err(AbortCode::ValueTooLow));
        assert_eq!(check_write(POLARITY, 0, 0x01), Err(AbortCode::InvalidValue));
        assert_eq!(check_write(POLARITY, 0, 0xC0), Ok(()));
    }

    #[test]
    fn motor_rpm_converts_exactly_through_the_encoder_resolution() {
        // 4000 increments per revolution, a gear and feed that do not enter rpm.
        let position = factors(4000, 1, (7, 2), (1000, 1));
        let (n, d) = reduced(60, 4000);
        let rpm = Factors { velocity: Ratio::new(n, d), ..position };
        assert_eq!(rpm.velocity_to_internal(60), 4000);
        assert_eq!(rpm.velocity_to_user(4000), 60);
        assert_eq!(rpm.limit_to_internal(3000), 200_000);
        // 1 rpm = 66.67 increments/s → 67; −1 → −67; 100 increments/s = 1.5 rpm → 2.
        assert_eq!(rpm.velocity_to_internal(1), 67);
        assert_eq!(rpm.velocity_to_internal(-1), -67);
        assert_eq!(rpm.velocity_to_user(100), 2);
        assert_eq!(rpm.velocity_to_user(-100), -2);
        assert_eq!(rpm.limit_to_internal(u32::MAX), u32::MAX);
        // Positions keep the factor group.
        assert_eq!(rpm.to_internal(1000), position.to_internal(1000));
    }

    #[test]
    fn torque_in_milliamps_through_the_rated_current() {
        let ma = Factors { torque_unit: TorqueUnit::MilliAmps, rated_current: 2000, ..Factors::default() };
        assert_eq!(ma.torque_to_internal(1000), 500);
        assert_eq!(ma.torque_to_user(500), 1000);
        assert_eq!(ma.torque_to_internal(-3), -2); // −1.5 ‰ rounds away from zero
                                                   // Beyond INTEGER16: the entry saturates (or holds it, widened to INTEGER32).
        assert_eq!(ma.torque_to_user(i64::from(i16::MAX)), 65_534);
        let unknown = Factors { rated_current: 0, ..ma };
        assert_eq!((unknown.torque_to_internal(1000), unknown.torque_to_user(700)), (0, 0));
        let permille = Factors::default();
        assert_eq!((permille.torque_to_internal(-700), permille.torque_to_user(-700)), (-700, -700));
    }

    #[test]
    fn max_motor_speed_in_increments_per_second() {
        let f = factors(4096, 1, (1, 1), (1, 1));
        assert_eq!(f.rpm_to_internal(3000), 204_800);
        assert_eq!(f.rpm_to_internal(u32::MAX), u32::MAX);
    }
}
