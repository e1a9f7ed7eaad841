//! Fixed-point helpers: 128-bit values with 64 fractional bits in per-tick units.
//!
//! `per_tick(rate, hz, k)` turns a rate in increments/sᵏ into increments/tickᵏ; `to_si` goes
//! back to `f32` in increments/sᵏ (for the shape planner). All divisions here run at plan time.

/// Fractional bits of every fixed-point value.
pub(crate) const FRAC: u32 = 64;

/// 2⁶⁴ as `f32`.
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
    (i128::from(rate) << FRAC) / den
}

/// A fixed-point per-tickᵏ value as `f32` increments/sᵏ.
pub(crate) fn to_si(value: i128, hz: u32, k: u32) -> f32 {
    (value as f32 / ONE_F32) * (hz_pow(hz, k) as f32)
}

/// An `f32` in increments/sᵏ as fixed-point per-tickᵏ (saturating; NaN gives 0).
pub(crate) fn from_si(value: f32, hz: u32, k: u32) -> i128 {
    (value / hz_pow(hz, k) as f32 * ONE_F32) as i128
}

/// Rounds `num / den` to the nearest integer (halves away from zero); 0 if `den <= 0`.
pub(crate) fn div_round(num: i128, den: i128) -> i128 {
    if den <= 0 {
        return 0;
    }
    let quotient = num / den;
    let remainder = num % den;
    if remainder.unsigned_abs() >= den.unsigned_abs() - remainder.unsigned_abs() {
        if num < 0 {
            quotient - 1
        } else {
            quotient + 1
        }
    } else {
        quotient
    }
}

/// Rounds a fixed-point value to the nearest integer (halves up).
pub(crate) fn round_to_int(value: i128) -> i128 {
    value.saturating_add(1 << (FRAC - 1)) >> FRAC
}

/// A fixed-point per-tickᵏ value as whole increments/sᵏ, rounded, clamped to i64.
pub(crate) fn to_whole_si(value: i128, hz: u32, k: u32) -> i64 {
    let scaled = value.saturating_mul(hz_pow(hz, k));
    let whole = round_to_int(scaled);
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

/// `√x` for `f32` without `std`: a bit-level first guess and four Newton steps (relative
/// error below 10⁻⁷ for every positive normal input). 0 for `x <= 0` or NaN; `x` for +∞.
pub(crate) fn sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    let mut y = f32::from_bits((x.to_bits() >> 1).wrapping_add(0x1fbd_1df5));
    for _ in 0..4 {
        y = 0.5 * (y + x / y);
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

#[cfg(test)]
mod unit_tests {
    use super::*;

    #[test]
    fn rounding_division() {
        assert_eq!(div_round(7, 2), 4);
        assert_eq!(div_round(-7, 2), -4);
        assert_eq!(div_round(5, 3), 2);
        assert_eq!(div_round(-5, 3), -2);
        assert_eq!(div_round(4, 3), 1);
        assert_eq!(div_round(1, 0), 0);
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
    fn ticks() {
        assert_eq!(ceil_ticks(0.0), Some(0));
        assert_eq!(ceil_ticks(0.1), Some(1));
        assert_eq!(ceil_ticks(3.0), Some(3));
        assert_eq!(ceil_ticks(1e10), None);
        assert_eq!(ceil_ticks(f32::NAN), None);
    }

    #[test]
    fn conversions() {
        assert_eq!(per_tick(1000, 1000, 1), 1 << FRAC);
        assert_eq!(to_whole_si(per_tick(123_456, 4000, 2), 4000, 2), 123_456);
        assert!((to_si(per_tick(5000, 1000, 1), 1000, 1) - 5000.0).abs() < 1e-3);
    }
}
