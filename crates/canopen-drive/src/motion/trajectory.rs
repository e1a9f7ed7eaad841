//! The executed profile: constant-jerk segments of whole ticks in 128-bit fixed point (64
//! fractional bits, per-tick units), stepped by integer additions.
//!
//! Invariants that make one tick exact: every segment's jerk is `6·jerk6` and every
//! acceleration is even, so `a/2` and `j/6` and `j/2` are integers.

use super::fixed::{div_floor, mul_small};
pub(crate) use super::ramps::Exact;

/// Segments of the longest plan: a ramp of the present acceleration, two S-curve velocity
/// changes on each side of the cruise (3 segments each), the cruise, and one more change for
/// the fallback plan that stops first (see `planner`).
pub(crate) const MAX_SEGMENTS: usize = 14;

impl Exact {
    /// The state `ticks` ticks later under jerk `6·jerk6`, `None` on overflow: the closed form
    /// of the per-tick step, `p + n·v + n²·a/2 + n³·j/6`, `v + n·a + n²·j/2`, `a + n·j`, in
    /// Horner form (four products by `n`).
    pub(crate) fn after(&self, ticks: u32, jerk6: i128) -> Option<Exact> {
        let nj = mul_small(jerk6, ticks)?;
        let nj3 = nj.checked_add(nj)?.checked_add(nj)?;
        let p = self.p.checked_add(mul_small(
            self.v.checked_add(mul_small((self.a >> 1).checked_add(nj)?, ticks)?)?,
            ticks,
        )?)?;
        let v = self.v.checked_add(mul_small(self.a.checked_add(nj3)?, ticks)?)?;
        let a = self.a.checked_add(nj3.checked_add(nj3)?)?;
        Some(Exact { p, v, a })
    }
}

/// One piece of a plan: its start state, its length, and its jerk: `6·jerk6` for the first
/// `split` ticks and `6·(jerk6 + late)` for the rest (`late` is -1, 0 or 1). Two jerks one unit
/// apart let a piece change the acceleration by any multiple of 6 units exactly.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Segment {
    pub(crate) start: Exact,
    pub(crate) ticks: u32,
    pub(crate) split: u32,
    pub(crate) late: i8,
    pub(crate) jerk6: i128,
}

impl Segment {
    /// A piece of `ticks` that changes the acceleration by `6·change6`, and which of the two
    /// jerks comes first: with `less` the larger one comes last, which gains less velocity
    /// than a uniform jerk would (by `3·m·(ticks − m)` units, `m` the ticks at the larger);
    /// otherwise it comes first and gains as much more. `None` if `ticks` is 0.
    pub(crate) fn ramp(start: Exact, ticks: u32, change6: i128, less: bool) -> Option<Segment> {
        let n = i128::from(ticks);
        if n == 0 {
            return None;
        }
        let q = div_floor(change6, n);
        let m = change6.checked_sub(mul_small(q, ticks)?)?;
        let m = u32::try_from(m).ok()?;
        Some(if m == 0 {
            Segment { start, ticks, split: ticks, late: 0, jerk6: q }
        } else if less {
            Segment { start, ticks, split: ticks - m, late: 1, jerk6: q }
        } else {
            Segment { start, ticks, split: m, late: -1, jerk6: q.checked_add(1)? }
        })
    }

    /// A piece of `ticks` at the one jerk `6·jerk6`.
    pub(crate) const fn uniform(start: Exact, ticks: u32, jerk6: i128) -> Segment {
        Segment { start, ticks, split: ticks, late: 0, jerk6 }
    }

    /// The jerk (in units of 6) after the split.
    pub(crate) fn late_jerk6(&self) -> i128 {
        self.jerk6.wrapping_add(i128::from(self.late))
    }

    /// The states at the split and at the end, `None` on overflow.
    pub(crate) fn states(&self) -> Option<(Exact, Exact)> {
        let split = self.split.min(self.ticks);
        let middle = self.start.after(split, self.jerk6)?;
        Some((middle, middle.after(self.ticks - split, self.late_jerk6())?))
    }
}

/// Steps a plan's segments one tick at a time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Trajectory {
    segments: [Segment; MAX_SEGMENTS],
    len: usize,
    next: usize,
    /// The state at the present tick.
    pub(crate) now: Exact,
    jerk: i128,
    jerk_half: i128,
    jerk_sixth: i128,
    /// The segment's jerk after its split, and the ticks left when it applies.
    late_jerk6: i128,
    switch_at: u32,
    left: u32,
    remaining: u64,
    end: Exact,
}

impl Trajectory {
    /// At rest at `p`.
    pub(crate) const fn at_rest(p: i128) -> Self {
        let now = Exact { p, v: 0, a: 0 };
        Trajectory {
            segments: [Segment::uniform(now, 0, 0); MAX_SEGMENTS],
            len: 0,
            next: 0,
            now,
            jerk: 0,
            jerk_half: 0,
            jerk_sixth: 0,
            late_jerk6: 0,
            switch_at: 0,
            left: 0,
            remaining: 0,
            end: now,
        }
    }

    /// Holds still at `p`, as [`Self::at_rest`] builds it, without rewriting the segment
    /// table (only the first `len` segments are ever read, and `len` becomes 0): the cheap
    /// reset a drive makes on every tick while its power stage is off.
    pub(crate) fn hold(&mut self, p: i128) {
        let now = Exact { p, v: 0, a: 0 };
        self.len = 0;
        self.next = 0;
        self.now = now;
        self.jerk = 0;
        self.jerk_half = 0;
        self.jerk_sixth = 0;
        self.late_jerk6 = 0;
        self.switch_at = 0;
        self.left = 0;
        self.remaining = 0;
        self.end = now;
    }

    /// Starts executing the first `len` of `segments`, then holds `end` (the fitted end with
    /// the position and velocity set exactly to the plan's target).
    pub(crate) fn start(&mut self, segments: &[Segment; MAX_SEGMENTS], len: usize, end: Exact) {
        self.segments = *segments;
        self.len = len.min(MAX_SEGMENTS);
        self.next = 0;
        self.end = end;
        self.remaining = segments.iter().take(self.len).map(|s| u64::from(s.ticks)).sum();
        self.enter_next();
    }

    fn set_jerk(&mut self, jerk6: i128) {
        self.jerk_sixth = jerk6;
        self.jerk_half = jerk6.wrapping_mul(3);
        self.jerk = jerk6.wrapping_mul(6);
    }

    fn enter_next(&mut self) {
        match self.segments.get(self.next).filter(|_| self.next < self.len).copied() {
            Some(segment) => {
                self.now = segment.start;
                self.left = segment.ticks;
                self.late_jerk6 = segment.late_jerk6();
                // The switch happens when `left` falls to the ticks after the split; a split at
                // 0 starts with the late jerk.
                self.switch_at = segment.ticks.saturating_sub(segment.split);
                if segment.split == 0 {
                    self.set_jerk(self.late_jerk6);
                } else {
                    self.set_jerk(segment.jerk6);
                }
                self.next += 1;
            }
            None => {
                self.now = self.end;
                self.left = 0;
                self.switch_at = 0;
                self.set_jerk(0);
            }
        }
    }

    /// Advances one tick. After the plan the state moves on at its end velocity (zero for a
    /// stop or a move with end velocity 0).
    pub(crate) fn step(&mut self) {
        if self.left == 0 {
            self.now.p = self.now.p.saturating_add(self.now.v);
            return;
        }
        // Exact: a is even, the jerk is a multiple of 6; the fit bounded every value.
        let Exact { p, v, a } = self.now;
        self.now.p = p.wrapping_add(v).wrapping_add(a >> 1).wrapping_add(self.jerk_sixth);
        self.now.v = v.wrapping_add(a).wrapping_add(self.jerk_half);
        self.now.a = a.wrapping_add(self.jerk);
        self.left -= 1;
        self.remaining = self.remaining.saturating_sub(1);
        if self.left == 0 {
            self.enter_next();
        } else if self.left == self.switch_at {
            self.set_jerk(self.late_jerk6);
        }
    }

    /// True when every segment has been stepped.
    pub(crate) fn is_finished(&self) -> bool {
        self.left == 0
    }

    /// Ticks until the plan is finished.
    pub(crate) fn remaining(&self) -> u64 {
        self.remaining
    }
}

#[cfg(test)]
mod unit_tests {
    use super::*;

    #[test]
    fn two_jerk_segment_changes_the_acceleration_exactly() {
        let start = Exact { p: 123 << 64, v: -(7 << 60), a: 6 * 1_000_003 };
        for &(ticks, change6) in &[(1u32, 5i128), (7, 0), (7, 22), (7, -22), (1000, 123_456_789), (1000, -1)]
        {
            for less in [true, false] {
                let segment = Segment::ramp(start, ticks, change6, less).unwrap();
                let (_, end) = segment.states().unwrap();
                assert_eq!(end.a - start.a, 6 * change6, "{ticks} {change6}");
                // Stepping agrees with the closed form, tick by tick to the end.
                let mut trajectory = Trajectory::at_rest(0);
                let mut segments = [Segment::default(); MAX_SEGMENTS];
                segments[0] = segment;
                trajectory.start(&segments, 1, end);
                for _ in 0..ticks - 1 {
                    trajectory.step();
                    assert!(!trajectory.is_finished());
                }
                trajectory.step();
                assert!(trajectory.is_finished());
                assert_eq!(trajectory.now, end);
                let uniform_gain = i128::from(ticks) * start.a + 3 * change6 * i128::from(ticks);
                let gain = end.v - start.v;
                // With `less` the larger jerk comes last and gains no more than a uniform jerk.
                if less {
                    assert!(gain <= uniform_gain, "{ticks} {change6}");
                } else {
                    assert!(gain >= uniform_gain, "{ticks} {change6}");
                }
            }
        }
        assert_eq!(Segment::ramp(start, 0, 5, true), None);
    }
}
