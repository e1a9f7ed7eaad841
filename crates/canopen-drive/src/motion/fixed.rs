//! Fixed-point helpers: 128-bit values with 64 fractional bits in per-tick units.
//!
//! `per_tick(rate, hz, k)` turns a rate in increments/sᵏ into increments/tickᵏ; `to_si` (tests) goes
//! back to `f32` in increments/sᵏ (for the shape planner). All divisions here run at plan time.

/// Fractional bits of every fixed-point value.
pub(crate) const FRAC: u32 = 64;

/// 2⁶⁴ as `f32`.
#[cfg(test)]
pub(crate) const ONE_F32: f32 = 18_446_744_073_709_551_616.0;

/// `hz^k` for `k` in 0..=3 (at most 2⁶⁰ for `hz` ≤ 10⁶).
pub(crate) fn hz_pow(hz: u32, k: u32) -> i128 {
    let hz = i128::from(hz);
    match k {
        0 => 1,
        1 => hz,
        2 => hz * hz,
        _ => hz * hz * hz,
    }
}

/// `rate` increments/sᵏ as fixed-point increments/tickᵏ (rounded down; `rate < 2³²` so the
/// shifted value fits).
pub(crate) fn per_tick(rate: u32, hz: u32, k: u32) -> i128 {
    let den = hz_pow(hz, k).max(1);
    // A long division in 32-bit digits when hzᵏ fits 32 bits (up to 65 535 Hz for k = 2).
    div_floor(i128::from(rate) << FRAC, den)
}

/// A fixed-point per-tickᵏ value as `f32` increments/sᵏ.
#[cfg(test)]
pub(crate) fn to_si(value: i128, hz: u32, k: u32) -> f32 {
    (value as f32 / ONE_F32) * (hz_pow(hz, k) as f32)
}

/// An `f32` in increments/sᵏ as fixed-point per-tickᵏ (saturating; NaN gives 0).
#[cfg(test)]
pub(crate) fn from_si(value: f32, hz: u32, k: u32) -> i128 {
    (value / hz_pow(hz, k) as f32 * ONE_F32) as i128
}

/// `⌊num / den⌋`; 0 if `den <= 0`.
#[inline(never)]
pub(crate) fn div_floor(num: i128, den: i128) -> i128 {
    if den <= 0 {
        return 0;
    }
    let (quotient, exact) = div_trunc(num, den);
    if num < 0 && !exact {
        quotient - 1
    } else {
        quotient
    }
}

/// `⌈num / den⌉`; 0 if `den <= 0`.
#[inline(never)]
pub(crate) fn div_ceil(num: i128, den: i128) -> i128 {
    if den <= 0 {
        return 0;
    }
    let (quotient, exact) = div_trunc(num, den);
    if num > 0 && !exact {
        quotient + 1
    } else {
        quotient
    }
}

/// `num / den` truncated, and whether it was exact, for `den > 0`. Divisors below 2³² (tick
/// counts, the usual case) take a long division in 32-bit digits: four 64-by-32-bit steps
/// instead of a 128-bit division, which neither Cortex-M has in hardware.
fn div_trunc(num: i128, den: i128) -> (i128, bool) {
    let Ok(small) = u32::try_from(den) else {
        let (quotient, remainder) = crate::wide::sdivrem(num, den);
        return (quotient, remainder == 0);
    };
    let magnitude = num.unsigned_abs();
    // Written out: constant shifts of a u128 are free, variable ones are not.
    // A digit below the divisor with nothing carried is its own remainder (the top digits of
    // the usual values: a 32-bit division is a library call on a Cortex-M0).
    let digit = |r: u32, d: u32| if r == 0 && d < small { (0, d) } else { div_digit(r, d, small) };
    let (q3, r) = digit(0, (magnitude >> 96) as u32);
    let (q2, r) = digit(r, (magnitude >> 64) as u32);
    let (q1, r) = digit(r, (magnitude >> 32) as u32);
    let (q0, remainder) = digit(r, magnitude as u32);
    let quotient = u128::from(q3) << 96 | u128::from(q2) << 64 | u128::from(q1) << 32 | u128::from(q0);
    // |num| ≤ 2¹²⁷, so the quotient fits unless num = i128::MIN and den = 1.
    let quotient = i128::try_from(quotient).unwrap_or(i128::MAX);
    (if num < 0 { quotient.wrapping_neg() } else { quotient }, remainder == 0)
}

/// `(high·2³² + low) / divisor` and the remainder, for `high < divisor` (so the quotient fits
/// 32 bits): the schoolbook division in 16-bit half-digits, each estimated by one 32-bit
/// division and corrected at most twice. A Cortex-M4 divides 32 bits in hardware but has no
/// 64-bit division; the library's general one costs several times more.
#[inline(never)]
fn div_digit(high: u32, low: u32, divisor: u32) -> (u32, u32) {
    if divisor == 0 {
        return (u32::MAX, 0);
    }
    const HALF: u32 = 1 << 16;
    // Normalized: the divisor's top bit set, the dividend shifted alike (high < divisor, so
    // nothing is lost at the top).
    let shift = divisor.leading_zeros();
    let d = divisor << shift;
    let (d1, d0) = (d >> 16, d & 0xffff);
    let n32 = if shift == 0 { high } else { (high << shift) | (low >> (32 - shift)) };
    let n10 = low << shift;
    let (n1, n0) = (n10 >> 16, n10 & 0xffff);
    // One half-digit of the quotient from the remainder `top` and the next half-digit `next`.
    let half_digit = |top: u32, next: u32| {
        let mut q = top / d1;
        let mut rest = top - q * d1;
        // `q < HALF` is tested first, so the products below fit 32 bits.
        while q >= HALF || q * d0 > (rest << 16 | next) {
            q -= 1;
            rest += d1;
            if rest >= HALF {
                break;
            }
        }
        (q, (top << 16 | next).wrapping_sub(q.wrapping_mul(d)))
    };
    let (q1, r) = half_digit(n32, n1);
    let (q0, r) = half_digit(r, n0);
    (q1 << 16 | q0, r >> shift)
}

/// `x·n`, `None` on overflow: four 32×32-bit products (the multiplier is a tick count)
/// instead of a 128×128-bit multiplication.
#[inline(never)]
pub(crate) fn mul_small(x: i128, n: u32) -> Option<i128> {
    if x == 0 || n == 0 {
        return Some(0);
    }
    let magnitude = x.unsigned_abs();
    // Written out: constant shifts of a u128 are free, variable ones are not.
    let d0 = wide_product(magnitude as u32, n);
    let d1 = wide_product((magnitude >> 32) as u32, n) + (d0 >> 32);
    let d2 = wide_product((magnitude >> 64) as u32, n) + (d1 >> 32);
    let d3 = wide_product((magnitude >> 96) as u32, n) + (d2 >> 32);
    if d3 >> 32 != 0 {
        return None;
    }
    let product = u128::from(d0 as u32)
        | u128::from(d1 as u32) << 32
        | u128::from(d2 as u32) << 64
        | u128::from(d3 as u32) << 96;
    let product = i128::try_from(product).ok()?;
    Some(if x < 0 { -product } else { product })
}

/// `x·n` for a 64-bit `n` (a sum of tick counts), `None` on overflow: [`mul_small`] once when
/// `n` fits 32 bits, else twice.
pub(crate) fn mul_wide(x: i128, n: u64) -> Option<i128> {
    let low = mul_small(x, n as u32)?;
    let high = (n >> 32) as u32;
    if high == 0 {
        return Some(low);
    }
    let high = mul_small(x, high)?;
    if high.unsigned_abs() >> 95 != 0 {
        return None;
    }
    (high << 32).checked_add(low)
}

/// `a·b` in 64 bits: one instruction where the core multiplies 32×32 → 64 bits (UMULL).
#[cfg(target_has_atomic = "32")]
pub(crate) fn wide_product(a: u32, b: u32) -> u64 {
    u64::from(a) * u64::from(b)
}

/// `a·b` in 64 bits from four 16×16-bit products, on a core without a 32×32 → 64-bit
/// multiply. ARMv6-M is such a core, and the one without 32-bit atomics that this crate builds
/// for (the proxy this `cfg` uses); there the compiler calls a general 64×64-bit multiply of
/// some 80 instructions, this is about fifteen.
#[cfg(not(target_has_atomic = "32"))]
pub(crate) fn wide_product(a: u32, b: u32) -> u64 {
    let (a0, a1) = (a & 0xffff, a >> 16);
    let (b0, b1) = (b & 0xffff, b >> 16);
    let middle = u64::from(a0 * b1) + u64::from(a1 * b0);
    (u64::from(a1 * b1) << 32) + (middle << 16) + u64::from(a0 * b0)
}

/// Rounds a fixed-point value to the nearest integer (halves up).
pub(crate) fn round_to_int(value: i128) -> i128 {
    value.saturating_add(1 << (FRAC - 1)) >> FRAC
}

/// A fixed-point per-tickᵏ value as whole increments/sᵏ, rounded, clamped to i64.
///
/// Runs every tick (the demand of [`super::MotionState`]), so the usual case avoids 128-bit
/// multiplications: with `value = high·2⁶⁴ + low`, the result is `high·hzᵏ` plus the rounded
/// high half of `low·hzᵏ`, here in 32-bit limbs when `high` and `hzᵏ` fit 32 bits (three
/// 32×32-bit products, cheap on a Cortex-M0 too).
pub(crate) fn to_whole_si(value: i128, hz: u32, k: u32) -> i64 {
    let scale = hz_pow(hz, k);
    let high = value >> FRAC;
    let low = value as u64;
    if let (Ok(scale), Ok(high)) = (u32::try_from(scale), i32::try_from(high)) {
        // 32×32 → 64-bit products (`wide_product`: a 64-bit multiply is a library call on a
        // Cortex-M0).
        let lower = wide_product(low as u32, scale);
        // low·scale = upper·2³² + (lower mod 2³²), upper < 2⁶⁴ − 2³².
        let upper = wide_product((low >> 32) as u32, scale) + (lower >> 32);
        let carry = (upper + (1 << 31)) >> 32;
        // |high·scale| < 2⁶³ − 2³², carry ≤ 2³².
        let whole = wide_product(high.unsigned_abs(), scale) as i64;
        return if high < 0 { carry as i64 - whole } else { whole + carry as i64 };
    }
    if let (Ok(scale), Ok(high)) = (i64::try_from(scale), i64::try_from(high)) {
        let carry = (u128::from(low) * scale.unsigned_abs() as u128 + (1 << (FRAC - 1))) >> FRAC;
        if let Some(whole) = high.checked_mul(scale).and_then(|w| w.checked_add(carry as i64)) {
            return whole;
        }
    }
    let whole = round_to_int(crate::wide::saturating_mul(value, scale));
    whole.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64
}

/// `|x|` for `f32` without `std`.
pub(crate) fn abs(x: f32) -> f32 {
    if x < 0.0 {
        -x
    } else {
        x
    }
}

/// `√x` for `f32` without `std`: a bit-level first guess (within 3.5 %) and three Newton
/// steps, each squaring the relative error (to 6·10⁻⁴, 2·10⁻⁷, the rounding of `f32`). 0 for
/// `x <= 0` or NaN; `x` for +∞.
pub(crate) fn sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    let mut y = f32::from_bits((x.to_bits() >> 1).wrapping_add(0x1fbd_1df5));
    for _ in 0..3 {
        y = 0.5 * (y + x / y);
    }
    y
}

/// `∛x` for `f32` without `std` (`x > 0`; 0 otherwise): a bit-level first guess (within some
/// 10 %) and four Newton steps.
pub(crate) fn cbrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    let mut y = f32::from_bits(x.to_bits() / 3 + 0x2a51_37a0);
    for _ in 0..4 {
        y = (2.0 * y + x / (y * y)) * (1.0 / 3.0);
    }
    y
}

/// `⌈x⌉` as a tick count; `None` if `x` is NaN, negative beyond rounding, or above `u32::MAX`.
pub(crate) fn ceil_ticks(x: f32) -> Option<u32> {
    if x.is_nan() || x > 4_294_967_295.0 {
        return None;
    }
    if x <= 0.0 {
        return Some(0);
    }
    let whole = x as u32;
    if (whole as f32) < x {
        whole.checked_add(1)
    } else {
        Some(whole)
    }
}

/// `⌈|dv| / rate⌉` exactly, as a tick count: an `f32` estimate corrected by products (a
/// 128-bit division costs some ten times more).
pub(crate) fn exact_ticks(dv: i128, rate: i128) -> Option<u32> {
    let dv = dv.checked_abs()?;
    let estimate = ceil_ticks(real(dv) / real(rate))?;
    if estimate > 1 << 20 {
        // Past 2²⁰ ticks the estimate may be off by more than a tick.
        return u32::try_from(div_ceil(dv, rate)).ok();
    }
    // Within a tick of the answer: check the estimate, then its neighbour.
    let reaches = |ticks: u32| mul_small(rate, ticks).is_none_or(|reach| reach >= dv);
    if reaches(estimate) {
        Some(if estimate > 0 && reaches(estimate - 1) { estimate - 1 } else { estimate })
    } else {
        Some(estimate.checked_add(1)?)
    }
}

/// `x` fixed point (2⁻⁶⁴ units) as `f32` units.
pub(crate) fn real(x: i128) -> f32 {
    // The top 32 significant bits, converted by the FPU, and their scale as an exponent: an
    // i128 → f32 conversion is a long library call.
    let magnitude = x.unsigned_abs();
    // In 64-bit halves: a 128-bit count of leading zeros or variable shift is a long sequence
    // on a Cortex-M0.
    let (high, low) = ((magnitude >> 64) as u64, magnitude as u64);
    let zeros = if high != 0 { high.leading_zeros() } else { 64 + low.leading_zeros() };
    let shift = (128 - zeros).saturating_sub(32);
    let top = match shift {
        0 => low as u32,
        1..=63 => ((low >> shift) | (high << (64 - shift))) as u32,
        _ => (high >> (shift - 64)) as u32,
    } as f32;
    // 2^(shift − 64) as f32 bits (shift ≤ 96: the exponent stays in the normal range).
    let scale = f32::from_bits((127 + shift - 64) << 23);
    let value = top * scale;
    if x < 0 {
        -value
    } else {
        value
    }
}

#[cfg(test)]
mod unit_tests {
    use super::*;

    #[test]
    fn jerk_sixths_rounded_up_without_division() {
        for hz in [100, 1000, 4000, 16_000, 65_535, 1_000_000] {
            let rate = crate::motion::TickRate::new(hz).unwrap();
            for jerk in [0u32, 1, 5, 6, 7, 1000, 123_456_789, u32::MAX] {
                let exact = div_floor(rate.scale(jerk, 3) + 5, 6);
                assert_eq!(rate.sixths_up3(jerk), exact, "{hz} Hz, {jerk}");
            }
        }
    }

    #[test]
    fn rounding_division() {
        assert_eq!((div_floor(7, 2), div_floor(-7, 2), div_floor(-6, 2)), (3, -4, -3));
        assert_eq!((div_ceil(7, 2), div_ceil(-7, 2), div_ceil(6, 2)), (4, -3, 3));
        assert_eq!((div_floor(1, 0), div_ceil(1, 0)), (0, 0));
        // The digit-wise division agrees with the 128-bit one, both signs, all sizes.
        let mut x: u128 = 0x2545_F491_4F6C_DD1D_9E37_79B9_7F4A_7C15;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let num = (x as i128) >> (x % 127);
            for den in [1i128, 6, 7, (x >> 100) as i128 + 1, u32::MAX.into(), 1 << 32, (x >> 20) as i128 + 1]
            {
                for n in [num, -num] {
                    let floor = n.div_euclid(den) - if n.rem_euclid(den) != 0 && den < 0 { 1 } else { 0 };
                    assert_eq!(div_floor(n, den), floor, "{n} {den}");
                    assert_eq!(div_ceil(n, den), -((-n).div_euclid(den)), "{n} {den}");
                }
            }
        }
    }

    #[test]
    fn digit_division_agrees_with_the_64_bit_one() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for round in 0..200_000u32 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let divisor = match round % 4 {
                0 => (x >> 32) as u32 | 1,
                1 => (x >> (32 + x % 32)) as u32 | 1,
                2 => u32::MAX - (x % 3) as u32,
                _ => 1 + (x % 70_000) as u32,
            };
            let high = (x as u32) % divisor;
            let low = (x >> 17) as u32;
            let n = u64::from(high) << 32 | u64::from(low);
            let d = u64::from(divisor);
            assert_eq!(div_digit(high, low, divisor), ((n / d) as u32, (n % d) as u32), "{n} {d}");
        }
        for (high, low, divisor) in
            [(0, 0, 1), (0, u32::MAX, 1), (u32::MAX - 1, u32::MAX, u32::MAX), (0x7fff, 0xffff_ffff, 0x8000)]
        {
            let n = u64::from(high) << 32 | u64::from(low);
            let d = u64::from(divisor);
            assert_eq!(div_digit(high, low, divisor), ((n / d) as u32, (n % d) as u32), "{n} {d}");
        }
    }

    #[test]
    fn reals_are_the_fixed_point_values_to_f32_precision() {
        extern crate std;
        let mut x: i128 = 1;
        let mut values = std::vec::Vec::new();
        for shift in 0..127 {
            values.extend([x << shift, (x << shift) - 1, (x << shift) + 12_345, -(x << shift)]);
        }
        x = 0x1234_5678_9abc_def0_1357_9bdf_2468_ace0;
        values.extend([0, 1, -1, x, -x, x >> 40, x >> 70, i128::MAX, i128::MIN + 1]);
        for value in values {
            let exact = value as f64 / 18_446_744_073_709_551_616.0;
            let got = f64::from(real(value));
            assert!((got - exact).abs() <= exact.abs() * 1.2e-7, "{value}: {got} for {exact}");
        }
    }

    #[test]
    fn wide_products() {
        for (a, b) in
            [(0u32, 0u32), (1, u32::MAX), (u32::MAX, u32::MAX), (0x1234_5678, 0x9abc_def0), (65_535, 65_537)]
        {
            assert_eq!(wide_product(a, b), u64::from(a) * u64::from(b));
        }
    }

    #[test]
    fn small_products() {
        for x in [0i128, 1, -1, 12345, -(1 << 90) + 7, i128::MAX / 5, i128::MIN / 7] {
            for n in [0u32, 1, 2, 3, 4_000_000, u32::MAX] {
                assert_eq!(mul_small(x, n), x.checked_mul(i128::from(n)), "{x} {n}");
            }
        }
        assert_eq!(mul_small(i128::MIN, 1), None);
    }

    #[test]
    fn square_root() {
        for &x in &[1e-30_f32, 1e-6, 0.25, 2.0, 1e6, 4.3e9, 1.8e19, 3e38] {
            let y = sqrt(x);
            assert!(abs(y * y - x) <= x * 1e-6, "{x} {y}");
        }
        assert_eq!(sqrt(-1.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
    }

    #[test]
    fn cube_root() {
        for x in [1.0e-30f32, 3.0e-7, 0.001, 0.5, 1.0, 2.0, 27.0, 1.0e6, 3.0e30] {
            let y = cbrt(x);
            assert!(((y * y * y - x) / x).abs() < 1.0e-5, "{x}: {y}");
        }
        assert_eq!(cbrt(0.0), 0.0);
        assert_eq!(cbrt(-1.0), 0.0);
    }

    #[test]
    fn ticks() {
        assert_eq!(ceil_ticks(0.0), Some(0));
        assert_eq!(ceil_ticks(0.1), Some(1));
        assert_eq!(ceil_ticks(3.0), Some(3));
        assert_eq!(ceil_ticks(1e10), None);
        assert_eq!(ceil_ticks(f32::NAN), None);
    }

    #[test]
    fn whole_units_match_the_128_bit_rounding() {
        let slow = |value: i128, hz: u32, k: u32| {
            let whole = round_to_int(value.saturating_mul(hz_pow(hz, k)));
            whole.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64
        };
        let mut x: u128 = 0x9E37_79B9_7F4A_7C15_F39C_C060_5CED_C834;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let value = (x as i128) >> (x % 100);
            for (hz, k) in [
                (100, 1),
                (4000, 1),
                (1_000_000, 1),
                (16_000, 2),
                (65_535, 2),
                (65_536, 2),
                (1_000_000, 2),
                (8000, 3),
                (1_000_000, 3),
            ] {
                assert_eq!(to_whole_si(value, hz, k), slow(value, hz, k), "{value} {hz} {k}");
                assert_eq!(to_whole_si(-value, hz, k), slow(-value, hz, k), "{value} {hz} {k}");
            }
        }
        for value in [0, 1, -1, 1 << 63, -(1 << 63), i128::MAX, i128::MIN, i128::MIN + 1] {
            assert_eq!(to_whole_si(value, 4000, 2), slow(value, 4000, 2), "{value}");
        }
    }

    #[test]
    fn conversions() {
        assert_eq!(per_tick(1000, 1000, 1), 1 << FRAC);
        assert_eq!(to_whole_si(per_tick(123_456, 4000, 2), 4000, 2), 123_456);
        assert!((to_si(per_tick(5000, 1000, 1), 1000, 1) - 5000.0).abs() < 1e-3);
    }
}
