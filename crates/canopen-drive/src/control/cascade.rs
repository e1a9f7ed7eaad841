//! The cascade itself: the per-tick arithmetic and the state it keeps (one integrator).

use super::parameters::{
    ParameterError, Parameters, MAX_TORQUE_LIMIT, MAX_VELOCITY_LIMIT, POSITION_GAIN_FRAC, VELOCITY_GAIN_FRAC,
};
use crate::hal::Sample;

/// Fractional bits of the torque sums inside the velocity loop (‰ as Q32).
const TORQUE_FRAC: u32 = 32;

/// Bound of the proportional torque before it is widened to Q32: 2⁴⁷ in Q24 is 2²³ ‰, far
/// beyond any torque limit, so the bound never changes a demand; it keeps the Q32 sum below
/// 2⁵⁶.
const PROPORTIONAL_BOUND: i64 = 1 << 47;

/// Largest fractional exponent of the integral gain's mantissa (the shift stays below 64).
const MAX_GAIN_EXPONENT: i32 = 71;

/// What the cascade should follow this tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reference {
    /// Position demand, increments (a wrapping 32-bit counter, like 6062h/60FCh).
    pub position: i32,
    /// Velocity feed-forward, increments/s (e.g. the trajectory's velocity or 60B1h).
    pub velocity: i32,
    /// Torque feed-forward, ‰ of rated torque (e.g. the trajectory's acceleration times the
    /// inertia, or 60B2h).
    pub torque: i16,
}

/// The measured state of the axis this tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Actual {
    /// Position actual value, increments (a wrapping 32-bit counter, like 6063h/6064h).
    pub position: i32,
    /// Velocity actual value, increments/s (606Ch).
    pub velocity: i32,
}

impl From<&Sample> for Actual {
    fn from(sample: &Sample) -> Self {
        Actual { position: sample.position, velocity: sample.velocity }
    }
}

/// The result of one tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Output {
    /// Torque demand for the current loop, ‰ of rated torque, within ± the torque limit
    /// (6074h).
    pub torque: i16,
    /// Velocity command of the velocity loop, increments/s, within ± the velocity limit: the
    /// position loop's output plus the velocity feed-forward (60FAh control effort).
    pub velocity: i32,
    /// The torque demand was cut to the torque limit (an internal limit is active).
    pub torque_limited: bool,
    /// The velocity command was cut to the velocity limit.
    pub velocity_limited: bool,
}

/// The velocity loop's integral gain per tick, as a mantissa and a binary exponent so that
/// both tiny gains (high-resolution encoders, long integral times, fast ticks) and large ones
/// keep 31 significant bits.
///
/// The integrator's increment in ‰ as Q32 is `error · mantissa · 2^-shift` (`shift < 0` is a
/// left shift, saturating).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct IntegralGain {
    mantissa: u32,
    shift: i8,
}

impl IntegralGain {
    const OFF: IntegralGain = IntegralGain { mantissa: 0, shift: 0 };

    /// `Ki` per tick = `Kp · T / Tn`. In Q32 ‰ per increment/s that is
    /// `velocity_gain · 10⁶ · 2⁸ / (Tn[µs] · f[Hz])` (the gain is Q24). Computed once, by long
    /// division in 64 bits: `numerator < 2⁵²`, `denominator < 2⁶⁴`.
    fn new(velocity_gain: u32, integral_time_us: u32, tick_hz: u32) -> Self {
        let numerator = u64::from(velocity_gain) * 1_000_000;
        let denominator = u64::from(integral_time_us) * u64::from(tick_hz);
        if numerator == 0 || denominator == 0 {
            return Self::OFF;
        }
        let quotient = numerator / denominator;
        let mut remainder = numerator % denominator;
        // `mantissa ≈ numerator / denominator · 2^exponent`.
        let (mantissa, exponent) = if quotient > u64::from(u32::MAX) {
            let excess = 32 - quotient.leading_zeros(); // 1..=20
            (quotient >> excess, -(excess as i32))
        } else {
            let mut mantissa = quotient;
            let mut exponent = 0;
            while mantissa < 1 << 31 && exponent < MAX_GAIN_EXPONENT {
                // One more quotient bit: compare 2·remainder with the denominator without
                // overflowing (remainder < denominator).
                let bit = remainder >= denominator - remainder;
                remainder = if bit { remainder - (denominator - remainder) } else { remainder << 1 };
                mantissa = mantissa << 1 | u64::from(bit);
                exponent += 1;
            }
            (mantissa, exponent)
        };
        // `Ki_q32 = numerator / denominator · 2⁸ = mantissa · 2^(8 - exponent)`.
        IntegralGain {
            mantissa: u32::try_from(mantissa).unwrap_or(u32::MAX),
            shift: i8::try_from(exponent - 8).unwrap_or(i8::MAX),
        }
    }

    /// The integrator's increment for a velocity error, ‰ as Q32.
    fn increment(self, error: i32) -> i64 {
        // |error · mantissa| < 2³¹ · 2³² = 2⁶³: exact.
        let product = i64::from(error) * i64::from(self.mantissa);
        if self.shift >= 0 {
            product.checked_shr(u32::from(self.shift.unsigned_abs())).unwrap_or(0)
        } else {
            shl_saturating(product, u32::from(self.shift.unsigned_abs()))
        }
    }

    /// The gain as a real number in ‰ per increment/s per tick (tests only).
    #[cfg(test)]
    pub(super) fn value(self) -> f64 {
        f64::from(self.mantissa) * 2f64.powi(-i32::from(self.shift) - TORQUE_FRAC as i32)
    }
}

/// `value · 2^bits`, saturated to the i64 range.
fn shl_saturating(value: i64, bits: u32) -> i64 {
    let room = i64::MAX.checked_shr(bits).unwrap_or(0);
    if value > room {
        i64::MAX
    } else if value < -room {
        i64::MIN
    } else {
        value << bits.min(63)
    }
}

/// `value · 2^-bits` for `bits` in 1..=62, rounded to nearest (halves up). Every caller's
/// `value` is far enough from the i64 range's ends that adding the half is exact; it
/// saturates regardless.
fn round_shr(value: i64, bits: u32) -> i64 {
    let bits = bits.clamp(1, 62);
    value.saturating_add(1 << (bits - 1)) >> bits
}

/// `value` within `±limit` (`limit ≥ 0`), and whether it had to be cut.
fn limit(value: i64, limit: i64) -> (i64, bool) {
    if value > limit {
        (limit, true)
    } else if value < -limit {
        (-limit, true)
    } else {
        (value, false)
    }
}

/// Position P loop → velocity PI loop → torque demand, run once per tick. See the
/// [module documentation](super) for units, formats and the anti-windup rule.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cascade {
    tick_hz: u32,
    parameters: Parameters,
    integral_gain: IntegralGain,
    /// Limits from outside (the profile's 6072h, 6080h…); the effective limit is the smaller.
    external_velocity_limit: u32,
    external_torque_limit: u16,
    /// Effective limits, `0..=i32::MAX` and `0..=i16::MAX`.
    velocity_limit: i32,
    torque_limit: i16,
    /// Integral part of the torque demand, ‰ as Q32, within ± the torque limit.
    integral: i64,
}

impl Cascade {
    /// A cascade ticking at `tick_hz`, with its integrator at zero and no outside limits.
    pub fn new(tick_hz: u32, parameters: Parameters) -> Result<Self, ParameterError> {
        parameters.validate(tick_hz)?;
        let mut cascade = Cascade {
            tick_hz,
            parameters,
            integral_gain: IntegralGain::OFF,
            external_velocity_limit: MAX_VELOCITY_LIMIT,
            external_torque_limit: MAX_TORQUE_LIMIT,
            velocity_limit: 0,
            torque_limit: 0,
            integral: 0,
        };
        cascade.apply(parameters);
        Ok(cascade)
    }

    /// Replaces gains and limits (e.g. after an SDO write to the parameter record). The
    /// integrator keeps its torque, cut to the new limit, so a change of gains in motion does
    /// not step the demand. Invalid parameters are refused and the old ones stay.
    pub fn set_parameters(&mut self, parameters: Parameters) -> Result<(), ParameterError> {
        parameters.validate(self.tick_hz)?;
        self.apply(parameters);
        Ok(())
    }

    fn apply(&mut self, parameters: Parameters) {
        self.parameters = parameters;
        self.integral_gain =
            IntegralGain::new(parameters.velocity_gain, parameters.integral_time_us, self.tick_hz);
        self.update_limits();
    }

    /// Sets the limits that come from outside the controller, e.g. the profile's max torque
    /// (6072h) and max motor speed (6080h) converted to increments/s. The effective limits
    /// are the smaller of these and the parameters' own. Any value is accepted: 0 holds the
    /// output at 0, values beyond the output range mean "no outside limit". O(1); cheap enough
    /// to call every tick.
    pub fn set_limits(&mut self, velocity: u32, torque: u16) {
        self.external_velocity_limit = velocity;
        self.external_torque_limit = torque;
        self.update_limits();
    }

    fn update_limits(&mut self) {
        let velocity =
            self.parameters.velocity_limit.min(self.external_velocity_limit).min(MAX_VELOCITY_LIMIT);
        let torque = self.parameters.torque_limit.min(self.external_torque_limit).min(MAX_TORQUE_LIMIT);
        self.velocity_limit = i32::try_from(velocity).unwrap_or(i32::MAX);
        self.torque_limit = i16::try_from(torque).unwrap_or(i16::MAX);
        let bound = i64::from(self.torque_limit) << TORQUE_FRAC;
        self.integral = limit(self.integral, bound).0;
    }

    /// Clears the integrator for a bumpless start: call it when the drive function is enabled
    /// (or the loop is taken over from another one) with the torque the axis needs now — 0
    /// after a disable, the present torque demand when switching from a torque mode, a known
    /// holding torque for a vertical axis. With the position demand starting at the actual
    /// position, the first torque demand is then `torque` plus the velocity loop's reaction to
    /// the actual velocity, whatever the integrator held before. `torque` is cut to the
    /// torque limit.
    pub fn reset(&mut self, torque: i16) {
        let bound = i64::from(self.torque_limit) << TORQUE_FRAC;
        self.integral = limit(i64::from(torque) << TORQUE_FRAC, bound).0;
    }

    /// One tick of the whole cascade (cyclic synchronous position, profile position, homing):
    /// the position error `reference.position − actual.position` (wrapping), times the
    /// position gain, plus the velocity feed-forward, cut to the velocity limit, is the
    /// velocity command of [`step_velocity`](Self::step_velocity).
    pub fn step(&mut self, reference: Reference, actual: Actual) -> Output {
        // The shortest way round the 32-bit counter: exact across the i32::MAX/i32::MIN wrap.
        let error = reference.position.wrapping_sub(actual.position);
        // |error · gain| ≤ 2³¹ · (2³² − 1) < 2⁶³ − 2³¹: exact, and rounding cannot overflow.
        let correction =
            round_shr(i64::from(error) * i64::from(self.parameters.position_gain), POSITION_GAIN_FRAC);
        // |correction| < 2⁴⁷, |feed-forward| ≤ 2³¹.
        let wanted = correction + i64::from(reference.velocity);
        self.velocity_loop(wanted, reference.torque, actual.velocity)
    }

    /// One tick of the velocity loop alone (cyclic synchronous velocity, profile velocity):
    /// `velocity` (increments/s, cut to the velocity limit) and a torque feed-forward in, a
    /// torque demand out. The integrator is shared with [`step`](Self::step), so switching
    /// between the two is bumpless.
    pub fn step_velocity(&mut self, velocity: i32, torque_feed_forward: i16, actual_velocity: i32) -> Output {
        self.velocity_loop(i64::from(velocity), torque_feed_forward, actual_velocity)
    }

    fn velocity_loop(&mut self, wanted: i64, torque_feed_forward: i16, actual_velocity: i32) -> Output {
        let (command, velocity_limited) = limit(wanted, i64::from(self.velocity_limit));
        // Within ±i32::MAX after the limit, so the conversion always succeeds.
        let command = i32::try_from(command).unwrap_or(0);
        // Beyond ±2³¹ increments/s the error saturates; the torque is at its limit long before.
        let error = command.saturating_sub(actual_velocity);

        // All three parts in ‰ as Q32; each below 2⁵⁶ in magnitude, so their sum is exact.
        let proportional =
            limit(i64::from(error) * i64::from(self.parameters.velocity_gain), PROPORTIONAL_BOUND).0
                << (TORQUE_FRAC - VELOCITY_GAIN_FRAC);
        let feed_forward = i64::from(torque_feed_forward) << TORQUE_FRAC;
        let bound = i64::from(self.torque_limit) << TORQUE_FRAC;

        // Anti-windup by conditional integration: while the demand is at the limit, the
        // integrator does not move further in the direction the error pushes it.
        let unlimited = proportional + self.integral + feed_forward;
        let winding_up = (unlimited >= bound && error > 0) || (unlimited <= -bound && error < 0);
        if !winding_up {
            let integral = self.integral.saturating_add(self.integral_gain.increment(error));
            self.integral = limit(integral, bound).0;
        }

        let torque = round_shr(proportional + self.integral + feed_forward, TORQUE_FRAC);
        let (torque, torque_limited) = limit(torque, i64::from(self.torque_limit));
        Output {
            torque: i16::try_from(torque).unwrap_or(0), // within ±i16::MAX after the limit
            velocity: command,
            torque_limited,
            velocity_limited,
        }
    }

    /// The parameters in use.
    pub fn parameters(&self) -> &Parameters {
        &self.parameters
    }

    /// The tick rate given at construction, Hz.
    pub fn tick_hz(&self) -> u32 {
        self.tick_hz
    }

    /// The effective velocity limit, increments/s.
    pub fn velocity_limit(&self) -> u32 {
        self.velocity_limit.unsigned_abs()
    }

    /// The effective torque limit, ‰ of rated torque.
    pub fn torque_limit(&self) -> u16 {
        self.torque_limit.unsigned_abs()
    }

    /// The integral part of the torque demand, ‰ of rated torque (rounded): in steady state
    /// the load torque the loop has learnt (friction, gravity).
    pub fn integral(&self) -> i16 {
        let torque = round_shr(self.integral, TORQUE_FRAC);
        i16::try_from(torque).unwrap_or(if torque < 0 { i16::MIN } else { i16::MAX })
    }

    #[cfg(test)]
    pub(super) fn integral_gain_value(&self) -> f64 {
        self.integral_gain.value()
    }
}

#[cfg(test)]
mod unit_tests {
    use super::*;

    #[test]
    fn integral_gain_keeps_its_precision_over_the_whole_range() {
        let gains = [1, 7, 167_772, 1 << 24, 0x8000_0000, u32::MAX];
        let times = [1, 100, 125, 20_000, 1_000_000, u32::MAX];
        let rates = [1, 1_000, 16_000, 1_000_000, u32::MAX];
        for kp in gains {
            for tn in times {
                for hz in rates {
                    let gain = IntegralGain::new(kp, tn, hz);
                    let exact = f64::from(kp) / 16_777_216.0 * 1e6 / (f64::from(tn) * f64::from(hz));
                    let got = gain.value();
                    // 31 significant bits, unless the value is below 2⁻⁶³ of a Q32 unit.
                    let tolerance = exact * 1e-9 + 2f64.powi(-32 - 63);
                    assert!((got - exact).abs() <= tolerance, "kp {kp} tn {tn} hz {hz}: {got} vs {exact}");
                    assert!(got <= exact * (1.0 + 1e-15), "rounded down");
                }
            }
        }
        assert_eq!(IntegralGain::new(1 << 24, 0, 1000), IntegralGain::OFF);
    }

    #[test]
    fn integral_increment_saturates_instead_of_overflowing() {
        // The largest gain: Kp = 256, Tn = 1 µs, f = 1 Hz (not a valid parameter set, but the
        // arithmetic must hold anyway).
        let gain = IntegralGain::new(u32::MAX, 1, 1);
        assert!(gain.shift < 0);
        assert_eq!(gain.increment(i32::MAX), i64::MAX);
        assert_eq!(gain.increment(i32::MIN), i64::MIN);
        assert_eq!(gain.increment(0), 0);
        assert!(gain.increment(1) > 0);
        assert!(gain.increment(-1) < 0);
    }

    #[test]
    fn helpers_at_their_edges() {
        assert_eq!(shl_saturating(1, 62), 1 << 62);
        assert_eq!(shl_saturating(2, 62), i64::MAX);
        assert_eq!(shl_saturating(-2, 62), i64::MIN);
        assert_eq!(shl_saturating(-1, 63), i64::MIN);
        assert_eq!(shl_saturating(0, 200), 0);
        assert_eq!(round_shr(3 << 15, 16), 2); // 1.5 rounds up
        assert_eq!(round_shr(-(3 << 15), 16), -1); // -1.5 rounds up too
        assert_eq!(round_shr(i64::MAX, 32), i64::MAX >> 32);
        assert_eq!(limit(5, 0), (0, true));
        assert_eq!(limit(-5, 3), (-3, true));
        assert_eq!(limit(2, 3), (2, false));
    }
}
