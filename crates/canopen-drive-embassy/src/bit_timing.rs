//! The nominal bit timing of an FDCAN (Bosch M_CAN) controller for a classic CAN bit rate:
//! chip-independent arithmetic, so that it is tested on the host; `fdcan` hands it to
//! embassy-stm32.
//!
//! A bit is `1 + seg1 + seg2` time quanta of `prescaler` kernel-clock cycles each (the
//! synchronisation segment, then the propagation and phase segment 1, the sample point, then
//! phase segment 2). The timing chosen:
//!
//! - gives the bit rate exactly: `prescaler × quanta × bit_rate = kernel clock`, or nothing;
//! - uses the smallest prescaler, so the most quanta per bit, whose segments fit the
//!   registers (as embassy-stm32 0.6 writes them: prescaler 1..=511, seg1 1..=255,
//!   seg2 1..=127, SJW 1..=127) and at least [`MIN_QUANTA`] quanta;
//! - puts the sample point as near 87.5 % as the quanta allow (phase segment 2 is an eighth
//!   of the bit, rounded; at least two quanta), the location CiA 301 recommends for every bit
//!   rate;
//! - makes the resynchronisation jump width as long as phase segment 2 (the largest
//!   oscillator tolerance the segments allow).

/// Fewest time quanta per bit accepted (ISO 11898-1 allows 8 to 25 for classic CAN
/// controllers; the M_CAN allows more).
pub(crate) const MIN_QUANTA: u32 = 8;
const MAX_PRESCALER: u32 = 511;
const MAX_SEG1: u32 = 255;
const MAX_SEG2: u32 = 127;
const MIN_SEG2: u32 = 2;

/// A nominal bit timing, in time quanta.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Timing {
    /// Kernel-clock cycles per time quantum.
    pub prescaler: u16,
    /// Propagation and phase segment 1.
    pub seg1: u8,
    /// Phase segment 2.
    pub seg2: u8,
    /// Resynchronisation jump width.
    pub sync_jump_width: u8,
}

impl Timing {
    /// Time quanta per bit.
    #[cfg(test)]
    pub fn quanta(&self) -> u32 {
        1 + u32::from(self.seg1) + u32::from(self.seg2)
    }
}

/// The timing for `bit_rate` (bit/s) from a kernel clock of `clock_hz`; `None` when no
/// prescaler gives the rate exactly with segments that fit.
pub(crate) fn nominal(clock_hz: u32, bit_rate: u32) -> Option<Timing> {
    if bit_rate == 0 {
        return None;
    }
    let clock = u64::from(clock_hz);
    for prescaler in 1..=MAX_PRESCALER {
        let per_bit = u64::from(prescaler) * u64::from(bit_rate);
        if clock % per_bit != 0 {
            continue;
        }
        let Ok(quanta) = u32::try_from(clock / per_bit) else { continue };
        if quanta < MIN_QUANTA {
            // A larger prescaler gives fewer quanta still.
            return None;
        }
        let seg2 = (quanta.saturating_add(4) / 8).clamp(MIN_SEG2, MAX_SEG2);
        let seg1 = quanta.saturating_sub(1).saturating_sub(seg2);
        if !(1..=MAX_SEG1).contains(&seg1) {
            continue;
        }
        return Some(Timing {
            prescaler: u16::try_from(prescaler).ok()?,
            seg1: u8::try_from(seg1).ok()?,
            seg2: u8::try_from(seg2).ok()?,
            sync_jump_width: u8::try_from(seg2).ok()?,
        });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The eight fixed rates of the CiA 305 standard table, bit/s.
    const FIXED_RATES: [u32; 8] = [1_000_000, 800_000, 500_000, 250_000, 125_000, 50_000, 20_000, 10_000];

    fn check(clock: u32, rate: u32, timing: Timing) {
        let quanta = timing.quanta();
        assert_eq!(
            u64::from(timing.prescaler) * u64::from(quanta) * u64::from(rate),
            u64::from(clock),
            "exact"
        );
        assert!((1..=511).contains(&timing.prescaler));
        assert!((1..=255).contains(&timing.seg1) && (2..=127).contains(&timing.seg2));
        assert_eq!(timing.sync_jump_width, timing.seg2);
        assert!(quanta >= MIN_QUANTA);
        // Within half a quantum of 87.5 % when phase segment 2 is not at its minimum.
        let permille = (1 + u32::from(timing.seg1)) * 1000 / quanta;
        let tolerance = 500 / quanta + 1;
        if quanta >= 16 {
            assert!(
                permille.abs_diff(875) <= tolerance,
                "sample point {permille} ‰ at {rate} bit/s from {clock} Hz"
            );
        }
    }

    #[test]
    fn the_standard_rates_from_the_b_g431b_esc1_kernel_clock() {
        // 85 MHz (PLL Q): every fixed rate but 800 kbit/s (85 MHz / 800 kbit/s = 106.25).
        for rate in FIXED_RATES {
            match nominal(85_000_000, rate) {
                Some(timing) => check(85_000_000, rate, timing),
                None => assert_eq!(rate, 800_000),
            }
        }
        // 1 Mbit/s: 85 quanta of one cycle, sample point 74/85.
        assert_eq!(
            nominal(85_000_000, 1_000_000),
            Some(Timing { prescaler: 1, seg1: 73, seg2: 11, sync_jump_width: 11 })
        );
    }

    #[test]
    fn clocks_that_divide_into_every_standard_rate() {
        for clock in [80_000_000, 40_000_000, 160_000_000, 16_000_000] {
            for rate in FIXED_RATES {
                let timing = nominal(clock, rate);
                assert!(timing.is_some(), "{rate} bit/s from {clock} Hz");
                check(clock, rate, timing.unwrap());
            }
        }
        // 500 kbit/s from 8 MHz: the textbook 16 quanta, 87.5 %.
        assert_eq!(
            nominal(8_000_000, 500_000),
            Some(Timing { prescaler: 1, seg1: 13, seg2: 2, sync_jump_width: 2 })
        );
    }

    #[test]
    fn no_timing_without_an_exact_one() {
        assert_eq!(nominal(170_000_000, 800_000), None, "212.5 cycles per bit");
        // 1 Mbit/s from 8 MHz: eight quanta, phase segment 2 at its minimum of two (75 %).
        assert_eq!(
            nominal(8_000_000, 1_000_000),
            Some(Timing { prescaler: 1, seg1: 5, seg2: 2, sync_jump_width: 2 })
        );
        assert_eq!(nominal(4_000_000, 1_000_000), None, "four quanta at most");
        assert_eq!(nominal(85_000_000, 0), None);
        assert_eq!(nominal(0, 500_000), None);
        assert_eq!(nominal(u32::MAX, 1), None, "more than 511 × 383 quanta");
        // 10 kbit/s from 170 MHz needs a prescaler above 44 (17 000 cycles per bit).
        check(170_000_000, 10_000, nominal(170_000_000, 10_000).unwrap());
    }
}
