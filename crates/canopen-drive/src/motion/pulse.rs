//! The velocity change of a jerk-limited leg, in whole ticks and exact integers.
//!
//! # Units
//!
//! The acceleration is kept in *sixths*: `α = a/6` in 2⁻⁶⁴ increments/tick². With the
//! acceleration `6α_k` at the start of a tick and `6α_{k+1}` at its end (a constant jerk in the
//! tick), one tick is exactly
//!
//! ```text
//! p += v + 2α_k + α_{k+1}        v += 3·(α_k + α_{k+1})
//! ```
//!
//! so a profile made of integer sixths never rounds.
//!
//! # A pulse
//!
//! A leg's velocity change is a *pulse* of the acceleration over `L` ticks: from 0 it rises
//! over `n` ticks to a peak `P`, holds, and falls over `n` ticks back to 0, the fall the mirror
//! image of the rise (`α_k = α_{L−k}`). Its velocity change is `6·σ` with `σ = Σ α_k` over
//! the interior ticks `1 … L−1`, and — the property everything rests on — a mirror-image pulse
//! covers exactly `L·(u + w)/2` from `u` to `w`, whatever its shape: the velocity is
//! point-symmetric about the middle of the leg. So with the tick counts fixed, the distance of
//! a plan of pulses is affine in its peak velocity, as a trapezoid's is.
//!
//! The rise `P = q·n + r` runs `n` ticks at jerk `q`, of them `⌊r/2⌋` at its start and
//! `⌈r/2⌉` at its end at `q + 1` (so its sum stays within `n/2` of the straight line's, below
//! it); the peak is `⌊σ/(L − n)⌋`, which leaves `d = σ − Σ` in `0 … L−2`; the remainder is made
//! up by one sixth more on `d` interior ticks in the middle of the pulse (its *bump*). So a
//! pulse of any whole `σ` is exact, and it keeps the limits it was made for: jerk at most
//! `q + 1` sixths per tick plus the bump's one, acceleration at most `P + 1`.
//!
//! # A decay
//!
//! A plan that starts while the axis accelerates first ramps that acceleration to zero at the
//! jerk that ends a speed change, then runs its pulse: the [`Decay`] of the first leg. Its
//! velocity change and distance are closed forms of its length, so the first leg's distance
//! stays affine in its end velocity.

use super::fixed::{ceil_ticks, div_floor, exact_ticks, mul_small, mul_wide, real, sqrt, wide_product};

/// One leg's acceleration pulse (see the module docs); all values in sixths, magnitudes (the
/// sign is the leg's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Pulse {
    /// Length in ticks.
    ticks: u32,
    /// Ticks of the rise (and of the fall).
    rise: u32,
    /// The rise's jerk per tick and how many of its first and last ticks run one above it.
    jerk: i128,
    early: u32,
    late: u32,
    /// The peak of the acceleration.
    peak: i128,
    /// The bump: one more on the interior ticks `bump_from … bump_from + bump − 1`.
    bump_from: u32,
    bump: u32,
    /// The pulse's sign (the leg slows down, or speeds up, towards negative velocities).
    negative: bool,
    /// The interior sum (signed, for the tests).
    #[cfg(test)]
    sigma: i128,
}

/// `n(n − 1)/2` (exact for any `n`: below 2⁶³).
fn triangle(n: u32) -> u64 {
    wide_product(n, n.saturating_sub(1)) / 2
}

impl Pulse {
    /// No pulse (no velocity change).
    pub(crate) const NONE: Pulse = Pulse {
        ticks: 0,
        rise: 0,
        jerk: 0,
        early: 0,
        late: 0,
        peak: 0,
        bump_from: 0,
        bump: 0,
        negative: false,
        #[cfg(test)]
        sigma: 0,
    };

    /// The acceleration (in sixths, signed) at tick `t` of the pulse (0 at both ends).
    pub(crate) fn alpha(&self, t: u32) -> i128 {
        if t == 0 || t >= self.ticks {
            return 0;
        }
        let from_end = t.min(self.ticks - t);
        let mut value = if from_end >= self.rise {
            self.peak
        } else {
            // The rise: q per tick, one more in the first `early` and the last `late` ticks.
            let extra = from_end.min(self.early) + from_end.saturating_sub(self.rise - self.late);
            mul_small(self.jerk, from_end).unwrap_or(0).wrapping_add(i128::from(extra))
        };
        if t >= self.bump_from && t - self.bump_from < self.bump {
            value += 1;
        }
        if self.negative {
            -value
        } else {
            value
        }
    }

    /// The interior sum in sixths (signed): the velocity change is six times it.
    #[cfg(test)]
    pub(crate) fn sigma(&self) -> i128 {
        self.sigma
    }

    /// Ticks of the pulse.
    pub(crate) fn ticks(&self) -> u32 {
        self.ticks
    }

    /// The first tick that is not part of the rise (or of a bump).
    pub(crate) fn rise_end(&self) -> u32 {
        if self.bump > 0 {
            self.rise.min(self.bump_from)
        } else {
            self.rise
        }
    }

    /// The interior sum of a rise of `rise` ticks to `peak` held over a pulse of `ticks`, and
    /// the rise's parameters.
    fn sum(ticks: u32, rise: u32, peak: i128) -> Option<(i128, i128, u32, u32)> {
        let jerk = div_floor(peak, i128::from(rise));
        let r = u32::try_from(peak.checked_sub(mul_small(jerk, rise)?)?).ok()?;
        let (early, late) = (r / 2, r - r / 2);
        // Σ_{k=1}^{n−1} (q·k + min(k, e) + max(0, k − n + l)), twice, and the hold. The corner
        // terms in 64 bits (e, l ≤ n < 2³²), the products by tick counts as `mul_small`: a
        // 128-bit product is a long library call on a Cortex-M0.
        let corners = wide_product(early, rise.saturating_sub(1))
            .checked_sub(triangle(early))?
            .checked_add(triangle(late))?;
        let rise_sum = mul_wide(jerk, triangle(rise))?.checked_add(i128::from(corners))?;
        let hold = ticks.checked_sub(2 * rise)?.checked_add(1)?;
        let total = rise_sum.checked_add(rise_sum)?.checked_add(mul_small(peak, hold)?)?;
        Some((total, jerk, early, late))
    }

    /// The pulse of `ticks` ticks whose interior sums to `sigma` sixths (signed), within `jerk`
    /// sixths per tick (plus the bump's one) and `accel` sixths, rising over at least
    /// `min_rise` ticks; `None` if it does not fit.
    pub(crate) fn fit(sigma: i128, ticks: u32, jerk: i128, accel: i128, min_rise: u32) -> Option<Pulse> {
        let negative = sigma < 0;
        let sigma = sigma.checked_abs()?;
        if sigma == 0 {
            return Some(Pulse { ticks, ..Pulse::default() });
        }
        if ticks < 2 {
            return None;
        }
        let (jerk, accel) = (jerk.max(1), accel.max(1));
        // The rise from the continuous shape: P·(L − P/j) = σ, the smaller root, at most the
        // acceleration limit.
        let (s, l, j) = (real(sigma), ticks as f32, real(jerk));
        let disc = l * l - 4.0 * s / j;
        let peak = if disc <= 0.0 { j * l * 0.5 } else { j * (l - sqrt(disc)) * 0.5 };
        let peak = peak.min(real(accel));
        let half = ticks / 2;
        if min_rise > half {
            return None;
        }
        let estimate = ceil_ticks(peak / j * (1.0 + 1.0 / 1_048_576.0)).unwrap_or(half);
        let mut rise = estimate.max(min_rise).clamp(1, half);
        for _ in 0..3 {
            let width = ticks - rise;
            let peak = div_floor(sigma, i128::from(width));
            let (total, q, early, late) = Pulse::sum(ticks, rise, peak)?;
            let bump = sigma.checked_sub(total)?;
            let too_steep = q + i128::from(early + late > 0) > jerk;
            if too_steep && rise < half {
                rise += 1;
                continue;
            }
            if too_steep || peak + i128::from(bump > 0) > accel || bump < 0 || bump > i128::from(ticks - 1) {
                return None;
            }
            let bump = bump as u32;
            return Some(Pulse {
                ticks,
                rise,
                jerk: q,
                early,
                late,
                peak,
                bump_from: 1 + (ticks - 1 - bump) / 2,
                bump,
                negative,
                #[cfg(test)]
                sigma: if negative { -sigma } else { sigma },
            });
        }
        None
    }

    /// The fewest ticks of a pulse for `sigma` sixths within `jerk` and `accel` (see
    /// [`Self::fit`]), with the pulse; `None` past `u32::MAX` ticks.
    pub(crate) fn shortest(sigma: i128, jerk: i128, accel: i128) -> Option<Pulse> {
        if sigma == 0 {
            return Some(Pulse::default());
        }
        let mut ticks = Pulse::estimate(sigma, jerk, accel)?;
        for _ in 0..Pulse::TRIES {
            if let Some(pulse) = Pulse::fit(sigma, ticks, jerk, accel, 0) {
                return Some(pulse);
            }
            ticks = Pulse::longer(ticks)?;
        }
        None
    }

    /// Tries of [`Self::shortest`] from the estimate: it may be a tick or two short (whole
    /// ticks, the rounding of the rise).
    pub(crate) const TRIES: u32 = 4;

    /// The next length [`Self::shortest`] tries after `ticks`.
    pub(crate) fn longer(ticks: u32) -> Option<u32> {
        ticks.checked_add(1 + ticks / 1024)
    }

    /// The first length [`Self::shortest`] tries: the continuous optimum rounded up to whole
    /// ticks (at least 2).
    pub(crate) fn estimate(sigma: i128, jerk: i128, accel: i128) -> Option<u32> {
        let magnitude = sigma.checked_abs()?;
        let (jerk, accel) = (jerk.max(1), accel.max(1));
        let (s, j, a) = (real(magnitude), real(jerk), real(accel.max(2) - 1));
        // Continuous: σ/a + a/j with a ramp to the limit, else 2·√(σ/j); in whole ticks the
        // rise is whole too (one tick more on each side at most).
        let estimate =
            if s / a >= a / j { s / a + ceil_ticks(a / j)? as f32 } else { 2.0 * sqrt(s / j) + 1.0 };
        Some(ceil_ticks(estimate * (1.0 + 1.0 / 262_144.0))?.max(2))
    }
}

/// The decay of the present acceleration at the start of a plan: from `α₀` to zero by `jerk`
/// sixths per tick (the last tick by what is left).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Decay {
    /// The starting acceleration in sixths (signed) and the jerk (magnitude).
    start: i128,
    jerk: i128,
    /// Its length in ticks.
    ticks: u32,
}

impl Decay {
    /// No decay (a plan from zero acceleration).
    pub(crate) const NONE: Decay = Decay { start: 0, jerk: 1, ticks: 0 };

    /// The decay of the acceleration `start` (in sixths, signed) at `jerk` sixths per tick.
    pub(crate) fn new(start: i128, jerk: i128) -> Option<Decay> {
        let jerk = jerk.max(1);
        let ticks = exact_ticks(start, jerk)?;
        Some(Decay { start, jerk, ticks })
    }

    /// `a` (2⁻⁶⁴ increments/tick²) in sixths, rounded away from zero.
    pub(crate) fn sixths(a: i128) -> Option<i128> {
        if a == 0 {
            return Some(0);
        }
        let magnitude = div_floor(a.checked_abs()?.checked_add(5)?, 6);
        Some(if a < 0 { -magnitude } else { magnitude })
    }

    /// Ticks of the decay.
    pub(crate) fn ticks(&self) -> u32 {
        self.ticks
    }

    /// The acceleration it starts from, in sixths (signed).
    pub(crate) fn start(&self) -> i128 {
        self.start
    }

    /// The acceleration in sixths at tick `k` of the decay.
    pub(crate) fn alpha(&self, k: u32) -> i128 {
        if k >= self.ticks {
            return 0;
        }
        let left = self.start.abs() - mul_small(self.jerk, k).unwrap_or(0);
        if self.start < 0 {
            -left
        } else {
            left
        }
    }

    /// The velocity the decay adds and the distance it covers beyond the start velocity over
    /// its ticks (2⁻⁶⁴ units, signed).
    pub(crate) fn change(&self) -> Option<(i128, i128)> {
        let (g, j, m) = (self.start.abs(), self.jerk, self.ticks);
        if m == 0 {
            return Some((0, 0));
        }
        // Σ_{k=1}^{m−1} α_k, the velocity 3·(α₀ + 2·Σ), and the distance
        // Σ_{k<m} V_k + 2α₀ + 3·Σ with Σ_{k<m} V_k = 3g·m(m−1) − j·m(m−1)(2m−1)/2.
        // Products by tick counts as `mul_small` (a 128-bit product is a long library call on a
        // Cortex-M0).
        let t = triangle(m);
        let jt = mul_wide(j, t)?;
        let sum = mul_small(g, m - 1)?.checked_sub(jt)?;
        let dv = mul_small(g.checked_add(mul_small(sum, 2)?)?, 3)?;
        let velocities = mul_wide(mul_small(g, 6)?, t)?.checked_sub(mul_small(jt, 2 * m - 1)?)?;
        let dp = velocities.checked_add(mul_small(g, 2)?)?.checked_add(mul_small(sum, 3)?)?;
        Some(if self.start < 0 { (-dv, -dp) } else { (dv, dp) })
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    /// Steps a sequence of sixths: the velocity change and distance from velocity 0.
    fn run(alphas: impl Iterator<Item = i128>) -> (i128, i128) {
        let (mut p, mut v) = (0i128, 0i128);
        let mut previous: Option<i128> = None;
        for alpha in alphas {
            if let Some(a) = previous {
                p += v + 2 * a + alpha;
                v += 3 * (a + alpha);
            }
            previous = Some(alpha);
        }
        (v, p)
    }

    #[test]
    fn pulses_are_exact_and_within_their_limits() {
        let mut rng = super::super::tests::Rng(0x2545_F491_4F6C_DD1D);
        let mut next = || rng.next();
        for case in 0..4000 {
            let jerk = 1 + i128::from(next() % 1_000_000);
            let accel = 2 + i128::from(next() % 100_000_000);
            let ticks = 2 + (next() % 3000) as u32;
            let sigma = (next() % 1_000_000_000_000) as i128 * if case % 3 == 0 { -1 } else { 1 };
            let Some(pulse) = Pulse::shortest(sigma, jerk, accel) else { continue };
            if pulse.ticks() > 20_000 {
                continue;
            }
            for ticks in [pulse.ticks(), pulse.ticks() + ticks] {
                let pulse = Pulse::fit(sigma, ticks, jerk, accel, 0).expect("a longer pulse fits too");
                let alphas = (0..=ticks).map(|t| pulse.alpha(t));
                let (dv, dp) = run(alphas.clone());
                assert_eq!(dv, 6 * sigma, "case {case}: {pulse:?}");
                // Distance L·(u + w)/2 from u = 0, up to the bump's asymmetry (at most 3 per bumped tick).
                assert!(
                    (dp - i128::from(ticks) * dv / 2).abs() <= 3 * i128::from(ticks),
                    "case {case}: {pulse:?} {dp}"
                );
                let list: std::vec::Vec<i128> = alphas.collect();
                for pair in list.windows(2) {
                    assert!((pair[1] - pair[0]).abs() <= jerk + 1, "case {case}: jerk {pair:?} {pulse:?}");
                }
                assert!(list.iter().all(|a| a.abs() <= accel), "case {case}: {pulse:?}");
            }
        }
    }

    #[test]
    fn shortest_pulses_are_near_the_continuous_optimum() {
        // σ = 10⁶ sixths with jerk 10 and accel 1000: σ/a + a/j = 1000 + 100 ticks.
        let pulse = Pulse::shortest(1_000_000, 10, 1000).unwrap();
        assert!((1100..=1103).contains(&pulse.ticks()), "{pulse:?}");
        // Short: 2·√(σ/j) = 2·√(10⁴) = 200 ticks.
        let pulse = Pulse::shortest(100_000, 10, 1_000_000).unwrap();
        assert!((200..=202).contains(&pulse.ticks()), "{pulse:?}");
    }

    #[test]
    fn decays_match_their_closed_form() {
        for (a0, jerk) in [(600i128, 7i128), (-6001, 13), (5, 1), (123_456_789, 1000), (-42, 100)] {
            let decay = Decay::new(Decay::sixths(a0).unwrap(), jerk).unwrap();
            let (dv, dp) = run((0..=decay.ticks()).map(|k| decay.alpha(k)));
            assert_eq!(decay.change(), Some((dv, dp)), "{a0} {jerk}");
            assert_eq!(decay.alpha(decay.ticks()), 0);
            assert!((decay.alpha(0) * 6 - a0).abs() < 6);
        }
    }
}
