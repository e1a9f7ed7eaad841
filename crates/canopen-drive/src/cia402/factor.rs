//! Factor group (608Fh–6092h) and polarity (607Eh): user units ↔ internal units (digest §8).
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
//! range saturate (a 32-bit object cannot show them).
//!
//! Velocities are user position units per second and accelerations per second² (digest §8.1),
//! so they use the same ratio. 6090h (velocity encoder resolution) describes a separate velocity
//! sensor; the feedback of this crate ([`crate::hal::Sample::velocity`]) is in position-encoder
//! increments per second, so 6090h is kept and validated but does not enter a conversion.
//! 6080h max motor speed is in rpm and becomes increments/s through 608Fh alone.
//!
//! Polarity (607Eh, digest §8.2, its recommended reading): position polarity (bit 7) negates
//! the commanded target 607Ah in profile position mode, and the reported positions 6062h,
//! 6064h and 60F4h in every mode, so that the master's frame stays one mirror image whatever
//! the mode; velocity polarity (bit 6) negates the target velocity 60FFh in profile velocity
//! mode and the reported velocities 606Bh/606Ch. Homing will ignore 607Eh for its search
//! directions (digest §8.2); torque modes ignore it.

use super::objects::{
    FEED_CONSTANT, GEAR_RATIO, POLARITY, POSITION_ENCODER_RESOLUTION, VELOCITY_ENCODER_RESOLUTION,
};
use crate::od::{AbortCode, Dictionary};

/// 607Eh bit 7: position polarity.
pub const POSITION_POLARITY: u8 = 0x80;
/// 607Eh bit 6: velocity polarity.
pub const VELOCITY_POLARITY: u8 = 0x40;

/// The conversion between user units and internal units (increments) of one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Factors {
    /// user = internal × numerator / denominator.
    numerator: u128,
    denominator: u128,
    /// 608Fh sub 1 / sub 2: increments per motor revolution.
    increments: u32,
    revolutions: u32,
    polarity: u8,
}

impl Default for Factors {
    /// 1:1 in every object: user units are increments.
    fn default() -> Self {
        Factors { numerator: 1, denominator: 1, increments: 1, revolutions: 1, polarity: 0 }
    }
}

const fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        let r = a % b;
        a = b;
        b = r;
    }
    a
}

/// `value × numerator / denominator`, rounded to nearest (halves away from zero), saturated to
/// i64. `numerator` and `denominator` are below 2⁹⁶ and not 0; |value| < 2⁶³, so the product
/// may exceed 128 bits only when it would saturate anyway, which is checked first.
fn scale(value: i64, numerator: u128, denominator: u128) -> i64 {
    let magnitude = u128::from(value.unsigned_abs());
    let result = match magnitude.checked_mul(numerator) {
        Some(product) => (product + denominator / 2) / denominator.max(1),
        None => u128::MAX,
    };
    let result = i64::try_from(result).unwrap_or(i64::MAX);
    if value < 0 {
        -result
    } else {
        result
    }
}

fn saturate(value: i64) -> i32 {
    value.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

fn pair<const B: usize>(od: &Dictionary<B>, index: u16) -> (u32, u32) {
    let sub = |s| od.get::<u32>(index, s).ok().filter(|v| *v != 0).unwrap_or(1);
    (sub(1), sub(2))
}

impl Factors {
    /// The factors the dictionary holds now (a 0 that slipped in counts as 1).
    pub fn from_od<const B: usize>(od: &Dictionary<B>) -> Self {
        let (increments, revolutions) = pair(od, POSITION_ENCODER_RESOLUTION);
        let (motor, shaft) = pair(od, GEAR_RATIO);
        let (feed, feed_shaft) = pair(od, FEED_CONSTANT);
        let numerator = u128::from(feed) * u128::from(revolutions) * u128::from(shaft);
        let denominator = u128::from(feed_shaft) * u128::from(increments) * u128::from(motor);
        let common = gcd(numerator, denominator).max(1);
        Factors {
            numerator: numerator / common,
            denominator: denominator / common,
            increments,
            revolutions,
            polarity: od.get::<u8>(POLARITY, 0).unwrap_or(0),
        }
    }

    /// Internal (increments, increments/s, …) to user units, without polarity.
    pub fn to_user(&self, internal: i64) -> i64 {
        scale(internal, self.numerator, self.denominator)
    }

    /// User units to internal units, without polarity.
    pub fn to_internal(&self, user: i64) -> i64 {
        scale(user, self.denominator, self.numerator)
    }

    /// [`Self::to_user`] saturated to an INTEGER32 object.
    pub fn to_user_i32(&self, internal: i64) -> i32 {
        saturate(self.to_user(internal))
    }

    /// An UNSIGNED32 user-unit limit (velocity, acceleration, jerk) in internal units,
    /// saturated to u32.
    pub fn limit_to_internal(&self, user: u32) -> u32 {
        u32::try_from(self.to_internal(i64::from(user))).unwrap_or(u32::MAX)
    }

    /// 6080h (rpm) in increments/s, saturated to u32.
    pub fn rpm_to_internal(&self, rpm: u32) -> u32 {
        let per_minute = u128::from(rpm) * u128::from(self.increments);
        let divisor = 60 * u128::from(self.revolutions);
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

/// Value rules of the factor group: no 0 in a ratio (digest §8.1), no reserved polarity bit.
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

#[cfg(test)]
mod tests {
    use super::*;

    fn factors(increments: u32, revolutions: u32, gear: (u32, u32), feed: (u32, u32)) -> Factors {
        let numerator = u128::from(feed.0) * u128::from(revolutions) * u128::from(gear.1);
        let denominator = u128::from(feed.1) * u128::from(increments) * u128::from(gear.0);
        let common = gcd(numerator, denominator);
        Factors {
            numerator: numerator / common,
            denominator: denominator / common,
            increments,
            revolutions,
            polarity: 0,
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
    fn max_motor_speed_in_increments_per_second() {
        let f = factors(4096, 1, (1, 1), (1, 1));
        assert_eq!(f.rpm_to_internal(3000), 204_800);
        assert_eq!(f.rpm_to_internal(u32::MAX), u32::MAX);
    }
}
