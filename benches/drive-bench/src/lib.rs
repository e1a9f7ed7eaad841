//! # drive-bench: instruction counts of canopen-drive's entry points
//!
//! The scenarios of the benchmark (issue 8), shared by its two back-ends:
//!
//! - the host binary (x86-64), run under `valgrind --tool=callgrind`;
//! - the firmware (Cortex-M4F, thumbv7em-none-eabihf), run in `qemu-system-arm -machine
//!   mps2-an386` with the instruction-counting plugin.
//!
//! Each [`Measurement`] prepares a drive in a given state through the public API (SDO writes,
//! NMT commands, RPDOs, SYNCs and ticks against a simulated [`axis::Axis`]), checks that the state
//! is the one it claims (Operation enabled, moving, the expected reply, …), and then
//! [`run_repetitions`] repeats the measured operation `n` times.
//!
//! ## Method: copy, then operate; minus copy only
//!
//! Every repetition first copies the prepared drive into a scratch slot ([`Scratch`]) and then
//! makes the measured call on the copy, so every repetition starts from exactly the same state.
//! The *base* mode of the same measurement makes the same copies without the call. Each mode is
//! counted with `n` and with `2n` repetitions, and one call costs
//!
//! ```text
//! ((measured(2n) − measured(n)) − (base(2n) − base(n))) / n
//! ```
//!
//! instructions, callees included: start-up, set-up, the harness and the loop's entry and exit
//! cancel out, and the difference must divide exactly by `n` (identical repetitions), which the
//! script checks. Object dictionary look-ups do not change the drive and need no copy.
//!
//! ## Whole runs: the worst tick
//!
//! A [`Prepared::Run`] measurement (issue 32) drives the rig through a whole scripted move
//! instead, and makes each tick of it through [`counted_tick`], which calls two marker
//! functions around `Drive::tick`: [`drive_bench_tick_begin`] and [`drive_bench_tick_end`].
//! The QEMU plugin counts the instructions between the markers, tick by tick, and reports the
//! largest; [`run_whole`] first calls the markers once with nothing between
//! ([`calibrate`]), so the plugin's first interval is the markers' own share, which the script
//! subtracts from the largest.
#![no_std]
#![deny(missing_docs)]

use core::hint::black_box;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicU32, Ordering};

use canopen_drive::hal::{Demand, Sample};
use canopen_drive::{CanFrame, Drive, Instant};

#[cfg(all(feature = "two-axes", feature = "bootloader"))]
compile_error!("the features two-axes and bootloader are two builds of their own: one at a time");

pub mod axis;
#[cfg(feature = "bootloader")]
pub mod boot;
pub mod objects;
pub mod rig;
#[cfg_attr(any(feature = "two-axes", feature = "bootloader"), allow(dead_code, unused_imports))]
mod scenarios;

pub use rig::{BenchDrive, Rig, SetupError, TwoAxisDrive};

/// Size of the value store of the look-up drives (the large dictionary needs more than the
/// default).
pub const LOOKUP_BYTES: usize = 6144;

/// A drive with a large value store, for the look-up measurements.
pub type LookupDrive = Drive<(), LOOKUP_BYTES, 4, 4>;

/// One measurement: its name (command line, budgets), what it measures, how it is prepared.
pub struct Measurement {
    /// Short name, `[a-z0-9-]`.
    pub name: &'static str,
    /// What is measured, for the table.
    pub label: &'static str,
    /// Builds the prepared state.
    pub prepare: fn() -> Result<Prepared, SetupError>,
}

/// The state a measurement starts every repetition from, and the operation.
// One value per run, never moved while measured: the size difference does not matter.
#[allow(clippy::large_enum_variant)]
pub enum Prepared {
    /// `drive.tick(now, &sample)`.
    Tick {
        /// The drive before the tick.
        drive: BenchDrive,
        /// The time of the tick.
        now: Instant,
        /// The feedback of the tick.
        sample: Sample,
    },
    /// `drive.tick_axes(now, &samples)` of the two-axis drive.
    #[cfg(feature = "two-axes")]
    TickAxes {
        /// The drive before the tick.
        drive: TwoAxisDrive,
        /// The time of the tick.
        now: Instant,
        /// The feedback of each axis.
        samples: [Sample; 2],
    },
    /// `drive.on_frame(&frame, now)`, then `pop_tx` until the queue is empty.
    Frame {
        /// The drive before the frame.
        drive: BenchDrive,
        /// The received frame.
        frame: CanFrame,
        /// The time of reception.
        now: Instant,
    },
    /// The bootloader's `node.on_frame(&frame, now)`, then `pop_tx` until the queue is empty.
    #[cfg(feature = "bootloader")]
    BootFrame {
        /// The bootloader before the frame.
        node: boot::BenchBoot,
        /// The received frame.
        frame: CanFrame,
        /// The time of reception.
        now: Instant,
    },
    /// The bootloader's `node.poll(now)`, then `pop_tx` until the queue is empty.
    #[cfg(feature = "bootloader")]
    BootPoll {
        /// The bootloader before the call.
        node: boot::BenchBoot,
        /// The time of the call.
        now: Instant,
    },
    /// `drive.od().entry(index, sub)`.
    Lookup {
        /// The drive whose dictionary is searched.
        drive: LookupDrive,
        /// Index looked up.
        index: u16,
        /// Sub-index looked up.
        sub: u8,
    },
    /// A whole run, not repeated: `script` drives the rig from its prepared state through a
    /// scripted move, every tick of it through [`counted_tick`] (see [`run_whole`]).
    Run {
        /// The rig before the run.
        rig: Rig,
        /// The run; returns the number of ticks it counted.
        script: fn(&mut Rig) -> Result<u32, SetupError>,
    },
}

/// Room for one copy of a [`BenchDrive`] (and one of a [`TwoAxisDrive`] with `two-axes`, of a
/// [`boot::BenchBoot`] with `bootloader`).
pub struct Scratch {
    slot: MaybeUninit<BenchDrive>,
    #[cfg(feature = "two-axes")]
    axes: MaybeUninit<TwoAxisDrive>,
    #[cfg(feature = "bootloader")]
    boot: MaybeUninit<boot::BenchBoot>,
}

impl Scratch {
    /// An empty slot.
    pub const fn new() -> Self {
        Scratch {
            slot: MaybeUninit::uninit(),
            #[cfg(feature = "two-axes")]
            axes: MaybeUninit::uninit(),
            #[cfg(feature = "bootloader")]
            boot: MaybeUninit::uninit(),
        }
    }

    /// Overwrites the slot with a byte copy of `drive` and returns the copy.
    ///
    /// `Drive` is not `Clone`. A `Drive<(), _, _, _, ()>` of this `no_std`, allocation-free crate
    /// holds values inline (arrays, integers, heapless queues of `Copy` frames) and shared
    /// `&'static` tables: no heap, no `&mut`, no pointer into itself. Its bytes are therefore a
    /// second, independent drive. Copies are never dropped (the slot is `MaybeUninit`): their
    /// destructors (heapless containers have one, for their elements; frames need none) are
    /// simply not run, which leaks nothing here.
    #[inline(always)]
    pub fn copy_of(&mut self, drive: &BenchDrive) -> &mut BenchDrive {
        copy_into(&mut self.slot, drive)
    }

    /// [`Self::copy_of`] for the two-axis drive.
    #[cfg(feature = "two-axes")]
    #[inline(always)]
    pub fn copy_of_axes(&mut self, drive: &TwoAxisDrive) -> &mut TwoAxisDrive {
        copy_into(&mut self.axes, drive)
    }

    /// [`Self::copy_of`] for the bootloader (plain data too: its dictionary, SDO server,
    /// program service and the RAM program area are held inline).
    #[cfg(feature = "bootloader")]
    #[inline(always)]
    pub fn copy_of_boot(&mut self, node: &boot::BenchBoot) -> &mut boot::BenchBoot {
        copy_into(&mut self.boot, node)
    }
}

/// Overwrites `slot` with a byte copy of `drive` (a plain-data drive: see [`Scratch::copy_of`]).
#[inline(always)]
#[allow(unsafe_code)]
fn copy_into<'a, D>(slot: &'a mut MaybeUninit<D>, drive: &D) -> &'a mut D {
    let slot = slot.as_mut_ptr();
    // SAFETY: `slot` is valid for one `D` and does not overlap `drive` (it is owned by the
    // scratch, borrowed mutably here); the bytes of a plain-data value are a valid value of its
    // type; the returned borrow keeps the scratch borrowed for as long as it lives.
    unsafe {
        core::ptr::copy_nonoverlapping(drive, slot, 1);
        &mut *slot
    }
}

impl Default for Scratch {
    fn default() -> Self {
        Scratch::new()
    }
}

/// Repeats the operation of `prepared` `n` times on fresh copies of its drive (`measured`), or
/// only makes the copies (the base run). The benchmark counts the instructions of this function,
/// callees included.
#[inline(never)]
pub fn run_repetitions(prepared: &Prepared, scratch: &mut Scratch, n: u32, measured: bool) {
    match prepared {
        Prepared::Tick { drive, now, sample } => {
            for _ in 0..n {
                let copy = scratch.copy_of(black_box(drive));
                if measured {
                    black_box(copy.tick(*now, sample));
                }
                black_box(copy);
            }
        }
        #[cfg(feature = "two-axes")]
        Prepared::TickAxes { drive, now, samples } => {
            for _ in 0..n {
                let copy = scratch.copy_of_axes(black_box(drive));
                if measured {
                    black_box(copy.tick_axes(*now, samples));
                }
                black_box(copy);
            }
        }
        Prepared::Frame { drive, frame, now } => {
            for _ in 0..n {
                let copy = scratch.copy_of(black_box(drive));
                if measured {
                    copy.on_frame(frame, *now);
                    while let Some(reply) = copy.pop_tx() {
                        black_box(reply);
                    }
                }
                black_box(copy);
            }
        }
        #[cfg(feature = "bootloader")]
        Prepared::BootFrame { node, frame, now } => {
            for _ in 0..n {
                let copy = scratch.copy_of_boot(black_box(node));
                if measured {
                    copy.on_frame(frame, *now);
                    while let Some(reply) = copy.pop_tx() {
                        black_box(reply);
                    }
                }
                black_box(copy);
            }
        }
        #[cfg(feature = "bootloader")]
        Prepared::BootPoll { node, now } => {
            for _ in 0..n {
                let copy = scratch.copy_of_boot(black_box(node));
                if measured {
                    black_box(copy.poll(*now));
                    while let Some(frame) = copy.pop_tx() {
                        black_box(frame);
                    }
                }
                black_box(copy);
            }
        }
        Prepared::Lookup { drive, index, sub } => {
            for _ in 0..n {
                if measured {
                    let _ = black_box(drive.od().entry(black_box(*index), black_box(*sub)));
                }
                black_box(drive);
            }
        }
        // Counted tick by tick, once: `run_whole`.
        Prepared::Run { .. } => {}
    }
}

/// Marker ticks begun (the body that makes the marker a function of its own).
static TICKS_BEGUN: AtomicU32 = AtomicU32::new(0);
/// Marker ticks ended.
static TICKS_ENDED: AtomicU32 = AtomicU32::new(0);

/// Marks the beginning of a counted tick: the QEMU plugin watches this function's address
/// (`begin=`, from the symbol table). Counts the calls, so that its body differs from
/// [`drive_bench_tick_end`]'s (identical functions could be merged into one address).
// `no_mangle`: `scripts/bench.sh` finds the markers by these names; nothing else defines them.
#[allow(unsafe_code)]
#[no_mangle]
#[inline(never)]
pub extern "C" fn drive_bench_tick_begin() {
    TICKS_BEGUN.store(TICKS_BEGUN.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
}

/// Marks the end of a counted tick (the plugin's `end=`).
#[allow(unsafe_code)]
#[no_mangle]
#[inline(never)]
pub extern "C" fn drive_bench_tick_end() {
    TICKS_ENDED.store(TICKS_ENDED.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
}

/// `drive.tick(now, sample)` between the two markers: one interval of the plugin per call. On
/// the host, callgrind counts each call of this function (one dump per call).
#[inline(never)]
pub fn counted_tick(drive: &mut BenchDrive, now: Instant, sample: &Sample) -> Demand {
    drive_bench_tick_begin();
    let demand = drive.tick(now, sample);
    drive_bench_tick_end();
    demand
}

/// The two markers with nothing between: the first interval of every whole run, the markers'
/// own share of every interval.
#[inline(never)]
pub fn calibrate() {
    drive_bench_tick_begin();
    drive_bench_tick_end();
}

/// Runs a [`Prepared::Run`] measurement: [`calibrate`], then its script. Returns the ticks the
/// script counted, which must be the marked intervals less the first; the markers must have
/// been called in pairs. `None` for the other measurements.
pub fn run_whole(prepared: Prepared) -> Option<Result<u32, SetupError>> {
    let Prepared::Run { mut rig, script } = prepared else { return None };
    let before = (TICKS_BEGUN.load(Ordering::Relaxed), TICKS_ENDED.load(Ordering::Relaxed));
    calibrate();
    let outcome = script(&mut rig);
    let marked = (
        TICKS_BEGUN.load(Ordering::Relaxed).wrapping_sub(before.0),
        TICKS_ENDED.load(Ordering::Relaxed).wrapping_sub(before.1),
    );
    Some(outcome.and_then(|ticks| {
        if marked == (ticks + 1, ticks + 1) {
            Ok(ticks)
        } else {
            Err(SetupError::Unexpected("marked ticks and counted ticks differ"))
        }
    }))
}

/// Every measurement, in table order.
pub static MEASUREMENTS: &[Measurement] = scenarios::ALL;

/// The measurement called `name`.
pub fn measurement(name: &str) -> Option<&'static Measurement> {
    MEASUREMENTS.iter().find(|m| m.name == name)
}

/// Objects and entries (sub-indices) of the dictionary of a look-up measurement's drive.
pub fn dictionary_size(prepared: &Prepared) -> Option<(usize, usize)> {
    match prepared {
        Prepared::Lookup { drive, .. } => {
            let objects = drive.od().objects();
            Some(objects.fold((0, 0), |(o, e), object| {
                let entries = (0..=object.highest_sub()).filter(|&s| object.sub(s).is_some()).count();
                (o + 1, e + entries)
            }))
        }
        _ => None,
    }
}
