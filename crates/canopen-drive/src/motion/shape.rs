//! The profile's shape in `f32` SI units (increments, seconds): durations of the velocity
//! changes and the cruise, and the peak velocity. Only the tick counts derived from these
//! durations reach the executed profile; the exact values are fitted in fixed point
//! ([`super::trajectory`]).

use super::fixed::{abs, sqrt};

/// Longest duration the shape planner works with, in seconds. Longer segments are clamped here
/// (and refused later as too long); it keeps every `f32` distance finite.
const MAX_SECONDS: f32 = 1.0e8;

/// Bisection steps over the peak velocity, over the ordered bit patterns of `f32` (a range of
/// about 2³¹ patterns): 24 steps leave a few hundred patterns, a relative error of about 2·10⁻⁵,
/// which the integer fit makes up (the exact peak is searched there). Each step is one shape,
/// and on a core without FPU one shape is some 15 000 instructions.
const BISECTION_STEPS: u32 = 24;

/// Which velocity a velocity change ends at; the fit supplies the exact value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum VelocityEnd {
    /// Zero (the first half of a change that crosses zero, or a stop).
    #[default]
    Zero,
    /// The peak velocity of a position plan.
    Peak,
    /// The plan's end velocity (target velocity of a ramp, end velocity of a move).
    Final,
}

/// One velocity change: durations of jerk-up, constant acceleration, jerk-down (S-curve), or of
/// the constant-acceleration ramp in `times[0]` (trapezoid).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Change {
    pub(crate) times: [f32; 3],
    pub(crate) end: VelocityEnd,
    /// True if the change increases the speed (acceleration and jerks A/B apply), false if it
    /// decreases it (deceleration and jerks C/D).
    pub(crate) speed_up: bool,
}

/// Limits in `f32` SI units.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShapeLimits {
    pub(crate) velocity: f32,
    pub(crate) acceleration: f32,
    pub(crate) deceleration: f32,
    /// Jerks A, B, C, D; `None` for the trapezoidal profile.
    pub(crate) jerk: Option<[f32; 4]>,
}

/// Up to four velocity changes (two per phase, a phase crossing zero needing two).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Changes {
    items: [Change; 4],
    len: usize,
}

impl Changes {
    fn push(&mut self, change: Change) {
        if let Some(slot) = self.items.get_mut(self.len) {
            *slot = change;
            self.len += 1;
        }
    }

    /// The changes pushed so far.
    pub(crate) fn as_slice(&self) -> &[Change] {
        self.items.get(..self.len).unwrap_or(&[])
    }
}

/// A position plan's shape: the changes before the cruise (`before` of them), the cruise at the
/// peak velocity, the changes after it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PositionShape {
    pub(crate) changes: Changes,
    pub(crate) before: usize,
    pub(crate) cruise: f32,
    pub(crate) peak: f32,
}

fn sign(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// A key that orders like the `f32` it came from (finite values).
fn order_key(x: f32) -> i32 {
    let bits = x.to_bits();
    let magnitude = (bits & 0x7fff_ffff) as i32;
    if bits >> 31 == 1 {
        -magnitude
    } else {
        magnitude
    }
}

/// The `f32` of an [`order_key`].
fn from_order_key(key: i32) -> f32 {
    if key < 0 {
        f32::from_bits(key.unsigned_abs() | 0x8000_0000)
    } else {
        f32::from_bits(key as u32)
    }
}

fn clamp_time(t: f32) -> f32 {
    if t.is_nan() || t <= 0.0 {
        0.0
    } else if t > MAX_SECONDS {
        MAX_SECONDS
    } else {
        t
    }
}

/// Distance covered by constant-jerk pieces `(jerk, duration)` from `(v, a)`.
fn distance(mut v: f32, mut a: f32, pieces: &[(f32, f32)]) -> f32 {
    let mut x = 0.0;
    for &(j, t) in pieces {
        x += t * (v + t * (a * 0.5 + t * j * (1.0 / 6.0)));
        v += t * (a + t * j * 0.5);
        a += t * j;
    }
    x
}

/// Changes the velocity from `(v0, a0)` to `(v1, 0)`, split at zero if it crosses zero; pushes
/// the changes and returns the distance covered.
pub(crate) fn velocity_change(
    v0: f32,
    a0: f32,
    v1: f32,
    end: VelocityEnd,
    limits: &ShapeLimits,
    out: &mut Changes,
) -> f32 {
    if (v0 < 0.0 && v1 > 0.0) || (v0 > 0.0 && v1 < 0.0) {
        let stop = single_change(v0, a0, 0.0, false, VelocityEnd::Zero, limits, out);
        stop + single_change(0.0, 0.0, v1, true, end, limits, out)
    } else {
        let speed_up = abs(v1) > abs(v0) || (v1 == v0 && a0 * v0 >= 0.0);
        single_change(v0, a0, v1, speed_up, end, limits, out)
    }
}

#[allow(clippy::too_many_arguments)]
fn single_change(
    v0: f32,
    a0: f32,
    v1: f32,
    speed_up: bool,
    end: VelocityEnd,
    limits: &ShapeLimits,
    out: &mut Changes,
) -> f32 {
    let amax = if speed_up { limits.acceleration } else { limits.deceleration };
    let dv = v1 - v0;
    let Some(jerks) = limits.jerk else {
        let t = clamp_time(abs(dv) / amax);
        out.push(Change { times: [t, 0.0, 0.0], end, speed_up });
        return 0.5 * (v0 + v1) * t;
    };
    let [j1, j3] = if speed_up { [jerks[0], jerks[1]] } else { [jerks[2], jerks[3]] };
    let pieces = scurve_pieces(v0, a0, v1, amax, j1, j3);
    out.push(Change { times: [pieces[0].1, pieces[1].1, pieces[2].1], end, speed_up });
    distance(v0, a0, &pieces)
}

/// The three constant-jerk pieces `(jerk, duration)` from `(v0, a0)` to `(v1, 0)` with peak
/// acceleration `amax`, jerk `j1` towards the peak and `j3` back to zero.
pub(crate) fn scurve_pieces(v0: f32, a0: f32, v1: f32, amax: f32, j1: f32, j3: f32) -> [(f32, f32); 3] {
    let dv = v1 - v0;
    // Velocity gained by ramping the present acceleration straight to zero.
    let dv_stop = a0 * abs(a0) / (2.0 * j3);
    let s = sign(dv - dv_stop);
    // Peak acceleration of a profile without a constant-acceleration part.
    let peak2 = (s * dv + a0 * a0 / (2.0 * j1)) * (2.0 * j1 * j3 / (j1 + j3));
    let peak = sqrt(peak2).min(amax);
    let ap = s * peak;
    let t1 = clamp_time(abs(ap - a0) / j1);
    let t3 = clamp_time(peak / j3);
    let gain1 = 0.5 * (a0 + ap) * t1;
    let gain3 = 0.5 * ap * t3;
    let t2 = if peak > 0.0 { clamp_time((dv - gain1 - gain3) / ap) } else { 0.0 };
    let first_jerk = if ap >= a0 { j1 } else { -j1 };
    [(first_jerk, t1), (0.0, t2), (-s * j3, t3)]
}

/// The shape of a move over `distance` from `(v0, a0)` ending at `v_end` (signed), or `None`
/// when the velocity limit is zero.
pub(crate) fn position_shape(
    distance_to_go: f32,
    v0: f32,
    a0: f32,
    v_end: f32,
    limits: &ShapeLimits,
) -> Option<PositionShape> {
    let vmax = limits.velocity;
    if vmax.is_nan() || vmax <= 0.0 {
        return None;
    }
    let covered = |vp: f32, out: &mut Changes| -> (f32, usize) {
        let first = velocity_change(v0, a0, vp, VelocityEnd::Peak, limits, out);
        let before = out.len;
        (first + velocity_change(vp, 0.0, v_end, VelocityEnd::Final, limits, out), before)
    };
    let d = distance_to_go;
    let mut out = Changes::default();
    let (up, before) = covered(vmax, &mut out);
    if up <= d {
        let cruise = clamp_time((d - up) / vmax);
        return Some(PositionShape { changes: out, before, cruise, peak: vmax });
    }
    out = Changes::default();
    let (down, before) = covered(-vmax, &mut out);
    if down >= d {
        let cruise = clamp_time((down - d) / vmax);
        return Some(PositionShape { changes: out, before, cruise, peak: -vmax });
    }
    // Bisection over the ordered bit patterns of f32: the same relative precision at any
    // magnitude, so a peak of 0.5 increments/s is found as precisely as one of 4·10⁹.
    let (mut lo, mut hi) = (order_key(-vmax), order_key(vmax));
    for _ in 0..BISECTION_STEPS {
        let mid = ((i64::from(lo) + i64::from(hi)) / 2) as i32;
        let (x, _) = covered(from_order_key(mid), &mut Changes::default());
        if x < d {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (lo, hi) = (from_order_key(lo), from_order_key(hi));
    let peak = 0.5 * (lo + hi);
    out = Changes::default();
    let (_, before) = covered(peak, &mut out);
    Some(PositionShape { changes: out, before, cruise: 0.0, peak })
}

#[cfg(test)]
mod unit_tests {
    use super::*;

    fn trapezoid() -> ShapeLimits {
        ShapeLimits { velocity: 100.0, acceleration: 10.0, deceleration: 20.0, jerk: None }
    }

    #[test]
    fn trapezoid_from_rest_reaches_cruise() {
        let shape = position_shape(1000.0, 0.0, 0.0, 0.0, &trapezoid()).unwrap();
        assert_eq!(shape.peak, 100.0);
        // 500 while accelerating, 250 while decelerating, 250 cruising.
        assert!((shape.cruise - 2.5).abs() < 1e-4);
    }

    #[test]
    fn trapezoid_short_move_is_triangular() {
        let shape = position_shape(30.0, 0.0, 0.0, 0.0, &trapezoid()).unwrap();
        assert_eq!(shape.cruise, 0.0);
        // vp²/20 + vp²/40 = 30
        assert!((shape.peak - 20.0).abs() < 1e-3, "{}", shape.peak);
    }

    #[test]
    fn scurve_change_ends_at_the_velocity() {
        for &(v0, a0, v1) in &[
            (0.0, 0.0, 100.0),
            (10.0, 5.0, 0.0),
            (50.0, -10.0, 60.0),
            (-30.0, 8.0, -10.0),
            (0.0, 10.0, 0.0),
            (0.0, 30.0, 5.0),
        ] {
            let pieces = scurve_pieces(v0, a0, v1, 10.0, 50.0, 40.0);
            let (mut v, mut a) = (v0, a0);
            for (j, t) in pieces {
                assert!(t >= 0.0);
                v += t * (a + t * j * 0.5);
                a += t * j;
            }
            assert!((v - v1).abs() < 1e-3 && a.abs() < 1e-3, "{v0} {a0} {v1}: {v} {a} {pieces:?}");
        }
    }
}
