//! 128-bit division, remainder and multiplication, compiled once; and the narrowing the
//! crate's 64-bit values take into 32-bit objects.
//!
//! Neither Cortex-M nor RISC-V has a 128-bit divide, and the compiler writes every 128-bit `/`
//! or `%` out in place as a shift-and-subtract sequence of about a kilobyte of code (a division
//! by a power-of-two constant excepted: that is a shift). The planner, the factor group and the
//! velocity ramps divide 128-bit values in dozens of places, so they call these functions
//! instead: one copy of the sequence for the whole crate, for the price of a call where the
//! division happens. Same results as the operators, including a panic on a zero divisor (the
//! callers never divide by zero).

/// `value` saturated to the i32 range: one test of the high word in the usual case (a
/// `clamp` compares both bounds in 64 bits, some ten instructions on a 32-bit core).
#[inline]
pub(crate) fn saturate_i32(value: i64) -> i32 {
    i32::try_from(value).unwrap_or(if value < 0 { i32::MIN } else { i32::MAX })
}

/// `(n / d, n % d)`. Operands that fit 64 bits (the usual case) take a 64-bit division, a
/// library call of about a hundred instructions on a Cortex-M4 instead of several hundred.
#[inline(never)]
pub(crate) fn udivrem(n: u128, d: u128) -> (u128, u128) {
    if let (Ok(n), Ok(d)) = (u64::try_from(n), u64::try_from(d)) {
        return (u128::from(n / d), u128::from(n % d));
    }
    udivrem_wide(n, d)
}

/// [`udivrem`] of operands beyond 64 bits, in a frame of its own (the 64-bit case, the usual
/// one, then needs little stack: it is at the bottom of the deepest tick).
#[inline(never)]
fn udivrem_wide(n: u128, d: u128) -> (u128, u128) {
    (n / d, n % d)
}

/// `n / d`.
pub(crate) fn udiv(n: u128, d: u128) -> u128 {
    udivrem(n, d).0
}

/// `n % d`.
pub(crate) fn urem(n: u128, d: u128) -> u128 {
    udivrem(n, d).1
}

/// `(n / d, n % d)` truncated toward zero, as the operators (the one overflowing case,
/// `i128::MIN / -1`, wraps).
pub(crate) fn sdivrem(n: i128, d: i128) -> (i128, i128) {
    let (q, r) = udivrem(n.unsigned_abs(), d.unsigned_abs());
    let (q, r) = (q as i128, r as i128);
    let q = if (n < 0) != (d < 0) { q.wrapping_neg() } else { q };
    let r = if n < 0 { r.wrapping_neg() } else { r };
    (q, r)
}

/// `n / d`, truncated toward zero.
pub(crate) fn sdiv(n: i128, d: i128) -> i128 {
    sdivrem(n, d).0
}

/// `n % d`, with the sign of `n`.
#[cfg(test)]
pub(crate) fn srem(n: i128, d: i128) -> i128 {
    sdivrem(n, d).1
}

/// `a·b`, `None` on overflow. Written out in place, a checked 128-bit product is some 150
/// bytes of Cortex-M4 code (ten 32×32-bit products and the overflow tests); the planner forms
/// such products in a few dozen places, at plan time only.
#[inline(never)]
pub(crate) fn mul(a: i128, b: i128) -> Option<i128> {
    a.checked_mul(b)
}

/// `a·b`, saturated at the ends of the range (one copy, as [`mul`]).
pub(crate) fn saturating_mul(a: i128, b: i128) -> i128 {
    mul(a, b).unwrap_or(if (a < 0) == (b < 0) { i128::MAX } else { i128::MIN })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_functions_answer_as_the_operators() {
        let values: [i128; 12] = [
            0,
            1,
            -1,
            6,
            -6,
            7,
            -7,
            1 << 70,
            -(1 << 70) + 3,
            i128::MAX,
            i128::MIN + 1,
            0x1234_5678_9ABC_DEF0_1111,
        ];
        for n in values {
            for d in values.iter().copied().filter(|d| *d != 0) {
                assert_eq!(sdivrem(n, d), (n / d, n % d), "{n} / {d}");
                let (un, ud) = (n.unsigned_abs(), d.unsigned_abs());
                assert_eq!(udivrem(un, ud), (un / ud, un % ud), "{un} / {ud}");
            }
        }
        assert_eq!(sdiv(i128::MIN, 3), i128::MIN / 3);
        assert_eq!(srem(i128::MIN, 10), -8);
        assert_eq!(sdiv(i128::MIN, -1), i128::MIN, "wraps where the operator overflows");
        for a in values {
            for b in values {
                assert_eq!(mul(a, b), a.checked_mul(b), "{a} * {b}");
                assert_eq!(saturating_mul(a, b), a.saturating_mul(b), "{a} * {b}");
            }
        }
    }
}
