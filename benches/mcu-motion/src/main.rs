//! Counts the instructions the motion planner executes on Cortex-M. QEMU runs this firmware
//! with the instruction-counting plugin, once per measurement (see `run.sh`).
//!
//! The semihosting command line names the measurement and a repetition count:
//! `mcu-motion <measurement> <repetitions>`. Every run first prepares the same planners (at rest,
//! accelerating, cruising); each repetition then copies one of them and makes the measured call
//! on the copy. `base` only copies, so one call costs
//! `(total(measurement, n) − total(base, n)) / n` instructions.

#![no_std]
#![no_main]

use core::hint::black_box;

use canopen_drive::motion::{Limits, MotionError, PositionPlanner, ProfileType, TickRate};
use cortex_m as _; // the critical-section implementation
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln, nr, syscall1};

const HZ: u32 = 4000;
const FAR: i64 = 1_000_000;

fn trapezoid() -> Limits {
    Limits::new(100_000, 500_000, 500_000)
}

fn s_curve() -> Limits {
    trapezoid().with_jerk(ProfileType::JerkLimited, 10_000_000)
}

/// The planners every run prepares.
struct Prepared {
    rest: PositionPlanner,
    /// 100 ticks into a move to [`FAR`]: accelerating (the S-curve with its acceleration rising).
    accelerating: [PositionPlanner; 2],
    /// 2100 ticks into a move to [`FAR`]: cruising at the velocity limit.
    cruising: [PositionPlanner; 2],
}

fn moving(limits: &Limits, ticks: u32) -> Result<PositionPlanner, MotionError> {
    let mut planner = PositionPlanner::new(TickRate::new(HZ)?, 0);
    planner.plan(FAR, 0, limits)?;
    for _ in 0..ticks {
        planner.step();
    }
    Ok(planner)
}

fn prepare() -> Result<Prepared, MotionError> {
    Ok(Prepared {
        rest: PositionPlanner::new(TickRate::new(HZ)?, 0),
        accelerating: [moving(&trapezoid(), 100)?, moving(&s_curve(), 100)?],
        cruising: [moving(&trapezoid(), 2100)?, moving(&s_curve(), 2100)?],
    })
}

/// Copies `planner` and plans on the copy.
#[inline(never)]
fn plan(planner: &PositionPlanner, target: i64, limits: &Limits) -> Result<u32, MotionError> {
    let mut copy = black_box(planner).clone();
    let ticks = copy.plan(black_box(target), 0, black_box(limits));
    black_box(&copy);
    ticks
}

/// Copies `planner` and steps the copy once.
#[inline(never)]
fn step(planner: &PositionPlanner) {
    let mut copy = black_box(planner).clone();
    black_box(copy.step());
    black_box(&copy);
}

/// Copies `planner` only, as the measured calls do (a copy kept in place and handed to
/// `black_box` by reference: moving it into `black_box` would copy it a second time).
#[inline(never)]
fn base(planner: &PositionPlanner) {
    let copy = black_box(planner).clone();
    black_box(&copy);
}

/// What a run measures.
#[derive(Clone, Copy)]
enum Measurement {
    Base,
    PlanRest(ProfileType),
    PlanShort(ProfileType),
    Replan(ProfileType),
    Fallback(ProfileType),
    Step(ProfileType),
}

fn measurement(name: &str) -> Option<Measurement> {
    use Measurement::*;
    use ProfileType::{JerkLimited, Trapezoidal};
    Some(match name {
        "base" => Base,
        "plan-trapezoid-rest" => PlanRest(Trapezoidal),
        "plan-s-curve-rest" => PlanRest(JerkLimited),
        "plan-trapezoid-short" => PlanShort(Trapezoidal),
        "plan-s-curve-short" => PlanShort(JerkLimited),
        "replan-trapezoid" => Replan(Trapezoidal),
        "replan-s-curve" => Replan(JerkLimited),
        "fallback-trapezoid" => Fallback(Trapezoidal),
        "fallback-s-curve" => Fallback(JerkLimited),
        "step-trapezoid" => Step(Trapezoidal),
        "step-s-curve" => Step(JerkLimited),
        _ => return None,
    })
}

fn measure(which: Measurement, prepared: &Prepared) -> Result<(), MotionError> {
    let index = |profile| usize::from(matches!(profile, ProfileType::JerkLimited));
    let limits = |profile| if matches!(profile, ProfileType::JerkLimited) { s_curve() } else { trapezoid() };
    match which {
        Measurement::Base => base(&prepared.rest),
        // From standstill to 100 000 increments: accelerate, cruise, decelerate.
        Measurement::PlanRest(profile) => {
            plan(&prepared.rest, 100_000, &limits(profile))?;
        }
        // From standstill to 5 000 increments, too short to reach the velocity limit: the peak
        // velocity is found by the bisection of the shape.
        Measurement::PlanShort(profile) => {
            plan(&prepared.rest, 5_000, &limits(profile))?;
        }
        // While accelerating, to a nearer target (the S-curve carries its acceleration).
        Measurement::Replan(profile) => {
            plan(&prepared.accelerating[index(profile)], 30_000, &limits(profile))?;
        }
        // Cruising at the limit, to a target at exactly the stopping distance: whole ticks
        // cannot stop there, so the plan takes the fallback (stop past it and come back).
        Measurement::Fallback(profile) => {
            let cruising = &prepared.cruising[index(profile)];
            let stopping = if matches!(profile, ProfileType::JerkLimited) { 12_499 } else { 10_000 };
            plan(cruising, cruising.state().position + stopping, &limits(profile))?;
        }
        // One tick in a constant-acceleration ramp, or in a jerk segment.
        Measurement::Step(profile) => step(&prepared.accelerating[index(profile)]),
    }
    Ok(())
}

/// The semihosting command line (QEMU's `-semihosting-config ...,arg=...`).
fn command_line(buffer: &mut [u8; 128]) -> &str {
    let mut block = [buffer.as_mut_ptr() as usize, buffer.len()];
    // SYS_GET_CMDLINE writes the line into the buffer and its length into the block.
    // SAFETY: the block points at a live buffer of the length it gives.
    let failed = unsafe { syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) } != 0;
    let length = if failed { 0 } else { block[1].min(buffer.len()) };
    core::str::from_utf8(&buffer[..length]).unwrap_or("")
}

#[entry]
fn main() -> ! {
    let mut buffer = [0u8; 128];
    let mut words = command_line(&mut buffer).split_ascii_whitespace().skip(1);
    let name = words.next().unwrap_or("base");
    let repetitions: u32 = words.next().and_then(|w| w.parse().ok()).unwrap_or(1);
    let Some(which) = measurement(name) else {
        hprintln!("unknown measurement {}", name);
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    };
    let outcome = prepare().and_then(|prepared| {
        for _ in 0..repetitions {
            measure(black_box(which), &prepared)?;
        }
        Ok(())
    });
    match outcome {
        Ok(()) => debug::exit(debug::EXIT_SUCCESS),
        Err(error) => {
            hprintln!("{}: {}", name, error);
            debug::exit(debug::EXIT_FAILURE);
        }
    }
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
