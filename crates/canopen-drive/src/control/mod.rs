//! Optional cascaded position and velocity loops (after the position control function of CiA 402-2 §12), for boards whose
//! power stage closes only a current (torque) loop.
//!
//! ```text
//!                   velocity feed-forward           torque feed-forward
//!                            │                              │
//! position demand ─(+)─ Kp_pos ─(+)─ limit ─(+)─ Kp_vel + ∫ ─(+)─ limit ─→ torque demand
//!                   │−          velocity command  │−                          (6074h)
//! position actual ──┘           (60FAh)           └── velocity actual
//! ```
//!
//! [`Cascade::step`] runs the whole chain once per tick (csp, pp, homing);
//! [`Cascade::step_velocity`] runs the velocity loop alone (csv, pv). The tick rate is fixed
//! when the cascade is made; nothing here reads a clock.
//!
//! # Units
//!
//! | quantity | unit | type |
//! |---|---|---|
//! | position demand, actual position | increments (wrapping 32-bit counter) | `i32` |
//! | velocity feed-forward, actual velocity, velocity command | increments/s | `i32` |
//! | torque feed-forward, torque demand | ‰ of rated torque (as 6071h/6074h) | `i16` |
//! | velocity limit | increments/s | `u32` ≤ 2³¹ − 1 |
//! | torque limit | ‰ of rated torque (as 6072h) | `u16` ≤ 2¹⁵ − 1 |
//!
//! # Fixed point
//!
//! The per-tick path has no floating point and no division, so it runs on a Cortex-M0 without
//! an FPU. The gains are unsigned fixed-point numbers ([`Parameters`]):
//!
//! | value | format | meaning of one LSB | range |
//! |---|---|---|---|
//! | position gain Kp_pos | Q16.16 `u32` | 2⁻¹⁶ /s | 1.5·10⁻⁵ … 65 536 /s |
//! | velocity gain Kp_vel | Q8.24 `u32` | 2⁻²⁴ ‰ per increment/s | 6·10⁻⁸ … 256 |
//! | integral time Tn | `u32` µs | 1 µs | 0 (off), one tick … 71 min |
//! | integrator, torque sums | Q32 `i64` | 2⁻³² ‰ | ± the torque limit |
//! | integral gain per tick | 32-bit mantissa × 2ᵉ | 31 significant bits | any |
//!
//! Each tick computes, with `T` the tick period:
//!
//! ```text
//! e_pos  = demand − actual position            (wrapping_sub: the shortest way round)
//! v_cmd  = limit_v( round(Kp_pos · e_pos) + v_ff )
//! e_vel  = v_cmd − actual velocity             (saturating at the i32 range)
//! P      = Kp_vel · e_vel
//! I     += Kp_vel · T / Tn · e_vel             (unless winding up, see below), |I| ≤ limit_t
//! torque = limit_t( round(P + I + t_ff) )
//! ```
//!
//! The integral gain `Kp_vel · T / Tn` is computed once, when the parameters are set, by a
//! 64-bit long division into a 32-bit mantissa and a shift, so a 24-bit encoder at 16 kHz
//! with a long Tn keeps as many significant bits as a Hall sensor at 1 kHz.
//!
//! ## Why nothing overflows
//!
//! Every product is an `i32` times a `u32` widened to `i64`, below 2⁶³ in magnitude. The
//! position correction is below 2⁴⁷; the proportional torque is bounded to 2²³ ‰ (far beyond
//! any torque limit) before it is widened to Q32; the integrator is held within ± the torque
//! limit (< 2⁴⁷ in Q32); the feed-forward is an `i16` (< 2⁴⁷ in Q32). So the sums stay below
//! 2⁵⁷ and are exact; the integrator's increment saturates. A position error is the wrapping
//! difference of the two counters: exact across the i32::MAX → i32::MIN wrap, and it aliases
//! only beyond ±2³¹ increments, far outside any following-error window (6065h). A velocity
//! error beyond the i32 range saturates (the torque demand is at its limit long before).
//! The outputs are always within ± the effective limits, whatever the inputs, gains and limits.
//!
//! # Anti-windup: conditional integration
//!
//! While the unlimited torque `P + I + t_ff` is at or beyond the torque limit *and* the
//! velocity error pushes it further out, the integrator holds its value; otherwise it
//! integrates. It is also never beyond ± the torque limit itself.
//!
//! Chosen over the alternatives because:
//!
//! - it needs no tuning parameter (back-calculation needs a tracking time constant, and a
//!   wrong one either winds up or fights the proportional part);
//! - the integrator keeps what it had learnt when the limit was hit — in a cascade that is the
//!   load torque (friction, gravity) — instead of being dragged towards `limit − P` as a
//!   dynamic clamp or fast back-calculation would do during a large transient, which would make
//!   the axis sag at the end of a saturated move;
//! - it costs two comparisons per tick.
//!
//! So after any time at the limit, the demand leaves the limit on the first tick in which the
//! error's reversal makes `P + I + t_ff` fall inside it: there is no stored excess to unwind.
//! The position loop is proportional only and its velocity command is simply limited: it has
//! no state to wind up.
//!
//! # Cost per step
//!
//! [`Cascade::step`]: three 32 × 32 → 64-bit multiplications (position P, velocity P,
//! integral), about fifteen 64-bit additions, comparisons and shifts, and a few branches; no
//! loop, no division, no floating point. [`Cascade::step_velocity`] saves one multiplication.
//! The Cortex-M0 has no 32 × 32 → 64 multiply, so each multiplication is a call to
//! `__aeabi_lmul`. Counted with QEMU's instruction-count plugin on a thumbv6m build
//! (`opt-level = "s"`, LTO, everything included): about 200 instructions per `step` and 170
//! per `step_velocity`, i.e. some 250–300 cycles on an M0 — about 6 µs at 48 MHz, 2.5 % of
//! the CPU at a 4 kHz tick. On a Cortex-M4 the multiplications are single `smull`
//! instructions. Setting parameters runs a bounded long division (at most 71 steps); do it
//! outside the tick when the tick budget is tight.
//!
//! # How a board uses it
//!
//! The board builds the cascade once with its tick rate and tuning, feeds it the profile's
//! limits, resets it when the drive function is enabled, and runs it in the tick after the
//! drive has produced its demand:
//!
//! ```
//! use canopen_drive::control::{Actual, Cascade, Parameters, Reference};
//!
//! let tuning = Parameters {
//!     position_gain: 100 << 16,   // 100/s
//!     velocity_gain: 1 << 23,     // 0.5 ‰ per increment/s
//!     integral_time_us: 8_000,    // 8 ms
//!     velocity_limit: 200_000,    // increments/s
//!     torque_limit: 3000,         // 300 % of rated torque
//! };
//! let mut cascade = Cascade::new(10_000, tuning)?;
//! cascade.set_limits(150_000, 2000); // e.g. 6080h in increments/s and 6072h
//!
//! // Enable: the position demand starts at the actual position, the integrator at zero.
//! let actual = Actual { position: 4096, velocity: 0 };
//! cascade.reset(0);
//! let out = cascade.step(Reference { position: 4096, velocity: 0, torque: 0 }, actual);
//! assert_eq!(out.torque, 0);
//!
//! // Every tick: demand (and feed-forwards) from the profile, actual values from the sensors;
//! // `out.torque` goes to the current loop, `out.velocity` to 60FAh.
//! let out = cascade.step(Reference { position: 4196, velocity: 0, torque: 0 }, actual);
//! assert_eq!(out.velocity, 10_000);
//! assert_eq!(out.torque, 2000); // 0.5 ‰ · 10 000 increments/s, cut to the 6072h limit
//! assert!(out.torque_limited);
//! # Ok::<(), canopen_drive::control::ParameterError>(())
//! ```
//!
//! The gains live in a manufacturer RECORD that the firmware places in its own table with
//! [`object`] (layout in [`parameters`]); [`Parameters::from_dictionary`] reads them back and
//! [`check_write`] refuses SDO writes that would make them invalid.

mod cascade;
pub mod parameters;

#[cfg(test)]
mod tests;

pub use cascade::{Actual, Cascade, Output, Reference};
pub use parameters::{
    check_write, object, object_with, record_subs, ParameterError, Parameters, OBJECT_NAME,
};
