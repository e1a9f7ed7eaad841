//! The drive profile at run time: one [`Profile::tick`] per control-loop tick reads the
//! controlword and the feedback, runs the [`Fsa`], the active mode and the stop ramps, writes
//! the statusword and the actual values, and returns the [`Demand`] for the power stage.
//!
//! Modes: profile position (pp, 1; [`super::pp`]), profile velocity (pv, 3) and profile torque
//! (tq, 4). 6502h lists those the firmware enables ([`crate::od::DeviceInfo::drive_modes`]).
//!
//! Mode switching (CiA 402-2 §8.3, §8.4.10; this crate's policy): a new 6060h takes effect at once while the
//! drive function is disabled; in Operation enabled the axis first stops with the slow-down
//! ramp of the old mode, then the new mode starts from standstill, and statusword bit 10 is 1 in
//! the tick after the switch. 6061h shows a mode only once it is active.
//!
//! Stops (CiA 402-2 §8.4.4–§8.4.9): the slow-down ramp uses 6084h, the quick-stop ramp 6085h; "current limit"
//! and "voltage limit" stops are run as a ramp with the maximum deceleration 60C6h (this crate
//! has no current or voltage loop of its own). Every stop deceleration is limited to 60C6h. In
//! pp a stop is a trajectory (position demand, [`crate::motion::PositionPlanner::stop`]); in the
//! other modes a velocity ramp from the actual velocity. A stop is done when the velocity demand
//! reaches 0.
//!
//! Limits (every demand within the configured limits): velocity demands never exceed min(607Fh, 6080h), ramps never
//! exceed 60C5h/60C6h, torque demands never exceed min(6072h, 6073h) — the torque is taken as
//! proportional to the torque-producing current, rated torque at rated current, so 6078h
//! reports the torque sample as current.
//!
//! Units: positions, velocities and accelerations in the objects are user units (factor group,
//! [`super::factor`]); the trajectory, the hal and 6063h/60FCh use increments.
//!
//! Hardware faults become the CiA 402 error codes 2310h (over-current), 3210h (DC link
//! over-voltage), 3220h (DC link under-voltage), 4310h (drive over-temperature) and 7305h
//! (incremental sensor fault): EMCY, 603Fh, transition 13. A following error is 8611h when
//! [`ProfileConfig::following_error_fault`] is set. A fault reset is accepted once the hardware
//! reports the cause gone.
//!
//! Arithmetic: velocities are integers in increments/s; the ramps advance by `rate × dt` in
//! i64 µs arithmetic with the remainder carried, so a ramp does not drift.

use super::config::{DirectMode, ProfileConfig, StatusFlag, TravelLimit};
use super::cyclic::{Bridge, Cycle, CycleStart, Interpolator, Limiter, TickLimits, STREAM_LOST};
use super::factor::Factors;
use super::fsa::{Fsa, Options, State, Step, StopKind};
use super::hm::{self, HomeOffset, Homing};
use super::ip::{IpBuffer, Written};
use super::memo::{Memo, Revised};
use super::objects::*;
use super::pp;
#[cfg(feature = "pp")]
use super::pp::ProfilePosition;
use super::probe::{
    Changed, TouchProbe, TOUCH_PROBE_1_NEGATIVE_EDGE, TOUCH_PROBE_1_NEGATIVE_EDGE_COUNTER,
    TOUCH_PROBE_1_POSITIVE_EDGE, TOUCH_PROBE_1_POSITIVE_EDGE_COUNTER, TOUCH_PROBE_2_NEGATIVE_EDGE,
    TOUCH_PROBE_2_NEGATIVE_EDGE_COUNTER, TOUCH_PROBE_2_POSITIVE_EDGE, TOUCH_PROBE_2_POSITIVE_EDGE_COUNTER,
};
use super::pv;
use super::slots::Slots;
use super::tq;
use super::vl;
use super::words::{Controlword, Statusword};
use super::Axis;
use crate::comm::emcy::ErrorRegister;
use crate::comm::ConnectionEvent;
use crate::control::{Actual, Cascade, Parameters, Reference};
use crate::hal::{Demand, DigitalInputs, FeedForward, HardwareFaults, Sample, Setpoint};
use crate::motion::{Limits, MotionState, PositionPlanner};
use crate::od::{AbortCode, Dictionary};
use crate::time::{Duration, Instant};
use crate::wide::saturate_i32;

/// The longest time step a tick integrates (a stalled board must not cause a jump).
const MAX_STEP: Duration = Duration::from_millis(100);

/// What the profile asks the drive to report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Report {
    /// An error to raise (EMCY, 1003h): code and register bits.
    pub raise: Option<(u16, ErrorRegister)>,
    /// An error to clear.
    pub clear: Option<u16>,
    /// Conditions that come and go without a fault (code, present): EMCY while present.
    pub notices: [Option<(u16, bool)>; 2],
    /// The travel limit changed ([`ProfileConfig::travel_limit_emcy`]): the EMCY code and the
    /// limit now reached, if any.
    pub travel_limit: Option<(u16, Option<TravelLimit>)>,
    /// Motion was commanded into an active limit switch ([`ProfileConfig::travel_limit_emcy`]):
    /// the EMCY code and the switch, for the EMCY once more (the travel limit is active).
    pub limit_switch_touched: Option<(u16, TravelLimit)>,
}

/// What the communication side learnt about the SYNC cycle since the previous tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SyncInput {
    /// A SYNC arrived.
    pub sync: bool,
    /// An RPDO arrived in the cycle before that SYNC (the stream delivered).
    pub fresh: bool,
    /// A set-point arrived since the last tick ([`CycleStart::SetPoint`]).
    pub set_point: bool,
}

/// A quantity ramped towards a target at a rate per second, in integer steps with the
/// fractional remainder kept (no drift).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Ramp {
    value: i64,
    /// Remainder in value·µs.
    remainder: i64,
}

impl Ramp {
    fn toward(&mut self, target: i64, rate_per_s: u32, dt: Duration) {
        if self.value == target {
            self.remainder = 0;
            return;
        }
        let budget =
            i64::from(rate_per_s).saturating_mul(dt.as_micros() as i64).saturating_add(self.remainder);
        // A budget within 32 bits (most ticks: a rate below some 4 000 000 per s at 1 ms) is
        // divided in 32 bits, one instruction on a Cortex-M4 where a 64-bit division is a library
        // call; the same quotient and remainder.
        let (step, remainder) = match u32::try_from(budget) {
            Ok(budget) => (i64::from(budget / 1_000_000), i64::from(budget % 1_000_000)),
            Err(_) => (budget / 1_000_000, budget % 1_000_000),
        };
        self.remainder = remainder;
        let distance = target - self.value;
        if distance.abs() <= step {
            self.value = target;
            self.remainder = 0;
        } else {
            self.value += step * distance.signum();
        }
    }
}

/// The drive profile's run-time state.
#[derive(Clone, Debug)]
pub struct Profile {
    /// The factor group, re-read after [`Profile::invalidate`]: kept apart from the rest of the
    /// state, so that the tick borrows it while it changes the rest (a copy of some 90 bytes
    /// per tick otherwise).
    factors: Option<Factors>,
    /// Everything else.
    run: Runtime,
}

/// The profile's state but for its factor group ([`Profile`]): the tick's phases are its
/// methods, and get the factor group as an argument.
#[derive(Clone, Debug)]
struct Runtime {
    config: ProfileConfig,
    /// The logical device whose objects this profile runs ([`Profile::for_axis`]).
    axis: Axis,
    /// 6502h, a fact of the device ([`Profile::configure`]).
    supported_modes: u32,
    fsa: Fsa,
    /// The per-tick entries, resolved with the factors.
    slots: Slots,
    /// [`Self::slots`] resolved in the drive's dictionary.
    slots_resolved: bool,
    /// The core's own position/velocity loops ([`ProfileConfig::cascade`]).
    cascade: Option<Cascade>,
    /// The mode 6061h shows: the active mode's number ([`Self::mode`]), or the
    /// manufacturer-specific value whose direct mode runs as it (the two differ only then).
    display_mode: i8,
    /// Velocity demand (increments/s) of the velocity ramps (pv, stops outside pp).
    velocity: Ramp,
    /// Torque demand (‰).
    torque: Ramp,
    /// The homing procedure and the axis's homing result, which outlive homing mode (the run's
    /// trajectory is [`Active::Hm`]'s).
    homing: Homing,
    probe: TouchProbe,
    /// The stream is lost beyond the bridged cycles (EMCY 8700h sent).
    stream_lost: bool,
    /// A limit acted on the cyclic demand in this tick (statusword bit 11).
    cyclic_limited: bool,
    /// Feed-forward of this tick's demand.
    feed_forward: FeedForward,
    /// Interpolated position mode: the data-record buffer, an overflow not yet cleared, and
    /// whether interpolation is active (controlword bit 4).
    ip: IpBuffer,
    ip_overflow: bool,
    /// The state of the active mode, for the modes that keep it in their own variant.
    mode: Active,
    /// The trajectory of pp and hm (the two never run at once): built once when the profile
    /// is configured ([`Self::configure`], out of the tick), reset in place when either mode
    /// becomes active, so that no tick builds a planner of some 1.2 KiB on its stack. `None`
    /// only until then: a profile is built cheaply, in place (an NMT reset, a drive of
    /// several axes).
    #[cfg(any(feature = "pp", feature = "hm"))]
    planner: Option<PositionPlanner>,
    /// The encoder count at the user zero: moved by homing (CiA 402-2 §11.5.1, 607Ch).
    origin: i64,
    /// A homing error EMCY (8613h) is active.
    homing_error: bool,
    last_tick: Option<Instant>,
    fault: Option<u16>,
    stopping: bool,
    mode_changed: bool,
    previous_controlword: Controlword,
    following_error_since: Option<Instant>,
    forced: Option<Controlword>,
    /// The master uses a controlword function this configuration lacks (EMCY 6320h sent).
    unavailable_function: bool,
    /// When the brake was told to open (drive function enabled).
    released_at: Option<Instant>,
    /// When the brake was told to close at the end of a stop.
    engaging_since: Option<Instant>,
    /// A bit-4 edge that came while the brake was still opening.
    pending_edge: bool,
    /// The travel limit last reported ([`ProfileConfig::travel_limit_emcy`]).
    travel_limit: Option<TravelLimit>,
    /// The encoder direction (−1, 0, 1) motion is commanded in by this tick's mode: a pp
    /// set-point taken, the pv target velocity ([`ProfileConfig::travel_limit_emcy`]).
    commanded: i8,
    /// The limit switch motion was commanded into in the previous tick: a touch is reported
    /// once ([`ProfileConfig::travel_limit_emcy`]).
    touching: Option<TravelLimit>,
    /// A stop of option code −1 shorts the windings until the shaft is at rest (or the drive
    /// function is enabled again), whatever state the FSA moved on to.
    dynamic_braking: bool,
    /// A fault latched outside the tick (a connection loss, 6007h) whose EMCY the next tick
    /// raises.
    fault_unreported: bool,
    /// The encoder count at which 6063h reads 0 ([`hm::HomingConfig::rebase_internal_position`]).
    internal_origin: i64,
    /// Since when the shaft has rested (|606Ch| ≤ 606Fh without a break).
    resting_since: Option<Instant>,
    /// The encoder directions (positive, negative) an active limit switch blocks in this tick
    /// ([`ProfileConfig::limit_switches_stop`]).
    blocked: (bool, bool),
    /// [`Self::motion_limits`] for the raw values last seen (emptied with the factor group).
    limits: Revised<(u32, u32, u32, u32, u32, u32), MotionLimits>,
    /// The motion limits of this tick (from [`Self::motion_limits`], before the mode runs).
    motion: MotionLimits,
    /// The cyclic limiter's per-tick limits, with the maximum deceleration and with a halt's.
    tick_limits: Memo<LimiterInputs, (TickLimits, TickLimits)>,
    /// (Ticks per interpolation period, SYNC jitter tolerated in ticks) for 60C2h and 1007h.
    timing: Revised<(u8, i8, u32), (u32, u32)>,
    /// [`Self::pp_limits`] for the raw values last seen (emptied with the factor group).
    pp_limits: Revised<pp::LimitObjects, (Limits, u32)>,
    /// The option codes and the FSA's last step, kept while they stand ([`Steady`]).
    steady: Steady,
    /// The last tick left the axis idle: what it saw and answered ([`Self::quiet_tick`]).
    quiet: Quiet,
}

/// An idle axis's last full tick: while the dictionary and the sample stay as they were, the
/// next tick would compute the same values again ([`Profile::quiet_tick`]).
#[derive(Clone, Copy, Debug)]
struct Quiet {
    /// The last tick was idle (the rest is meaningless otherwise).
    idle: bool,
    sample: Sample,
    /// [`Dictionary::revision`] after the tick's own writes.
    revision: u32,
    demand: Demand,
}

impl Quiet {
    const NONE: Self = Quiet {
        idle: false,
        sample: Sample {
            position: 0,
            velocity: 0,
            torque: 0,
            dc_link_millivolts: 0,
            inputs: DigitalInputs::empty(),
            faults: HardwareFaults::empty(),
            warnings: HardwareFaults::empty(),
            local_control: false,
            captures: crate::hal::Capture::NONE,
        },
        revision: 0,
        demand: Demand::OFF,
    };
}

/// The state of the operation mode that runs, in that mode's variant: it exists while the mode
/// is active, is built when the mode becomes active ([`Runtime::start_mode`]) and starts over
/// when the drive enters Operation enabled ([`Active::restart`]).
///
/// What outlives a mode stays in [`Profile`]: the velocity and torque demands (the stop ramps
/// continue them), the homing result, an active EMCY of a mode (stream lost, homing error).
// A variant's state is the mode's whole state, and the core has no allocator to box it into: pp's
// and homing's planners make their variants the large ones.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Active {
    /// No mode (6060h = 0), or one this build does not run (the bus cannot select one): the
    /// axis holds still.
    Idle,
    /// Profile position mode ([`pp`]).
    #[cfg(feature = "pp")]
    Pp(ProfilePosition),
    /// Profile velocity mode ([`pv`]).
    Pv(pv::Run),
    /// Profile torque mode ([`tq`]).
    Tq,
    /// Homing mode ([`hm`]): the run is [`Runtime::homing`], its trajectory
    /// [`Runtime::planner`].
    #[cfg(feature = "hm")]
    Hm,
    /// Velocity mode ([`vl`]).
    Vl(vl::Vl),
    /// Interpolated position mode ([`super::ip`]).
    Ip(super::ip::Run),
    /// csp, csv or cst ([`super::cyclic`]).
    Cyclic(super::cyclic::Run),
}

impl Active {
    // The accessors of the optional modes test their feature first: a build without the mode
    // then has none of its code, though the variant exists.

    /// The mode of operation (6060h value) this is the run of: the one source of the profile's
    /// active mode (6061h may show a manufacturer-specific mode that runs as a direct mode).
    fn number(&self) -> i8 {
        match self {
            Active::Idle => 0,
            #[cfg(feature = "pp")]
            Active::Pp(_) => mode::PROFILE_POSITION,
            Active::Pv(_) => mode::PROFILE_VELOCITY,
            Active::Tq => mode::PROFILE_TORQUE,
            #[cfg(feature = "hm")]
            Active::Hm => mode::HOMING,
            Active::Vl(_) => vl::MODE,
            Active::Ip(_) => mode::INTERPOLATED_POSITION,
            Active::Cyclic(run) => run.mode,
        }
    }

    fn is_pp(&self) -> bool {
        match self {
            #[cfg(feature = "pp")]
            Active::Pp(_) => true,
            _ => false,
        }
    }

    /// pt or cst: the modes whose demand is a torque.
    fn is_torque(&self) -> bool {
        match self {
            Active::Tq => true,
            Active::Cyclic(run) => run.mode == mode::CYCLIC_TORQUE,
            _ => false,
        }
    }

    #[cfg(feature = "pp")]
    fn pp_mut(&mut self) -> Option<&mut ProfilePosition> {
        match self {
            #[cfg(feature = "pp")]
            Active::Pp(pp) => Some(pp),
            _ => None,
        }
    }

    fn is_hm(&self) -> bool {
        match self {
            #[cfg(feature = "hm")]
            Active::Hm => true,
            _ => false,
        }
    }

    /// pp or hm: the modes that move [`Runtime::planner`].
    #[cfg(any(feature = "pp", feature = "hm"))]
    fn plans(&self) -> bool {
        match self {
            #[cfg(feature = "pp")]
            Active::Pp(_) => true,
            #[cfg(feature = "hm")]
            Active::Hm => true,
            _ => false,
        }
    }

    fn vl_mut(&mut self) -> Option<&mut vl::Vl> {
        match self {
            Active::Vl(vl) if super::VL => Some(vl),
            _ => None,
        }
    }

    fn ip_mut(&mut self) -> Option<&mut super::ip::Run> {
        match self {
            Active::Ip(run) if super::IP => Some(run),
            _ => None,
        }
    }

    /// The limiter whose position is the demand (csp, ip).
    fn position_limiter(&self) -> Option<&Limiter> {
        match self {
            Active::Ip(run) if super::IP => Some(&run.limiter),
            Active::Cyclic(run) if run.mode == mode::CYCLIC_POSITION => Some(&run.limiter),
            _ => None,
        }
    }

    fn position_limiter_mut(&mut self) -> Option<&mut Limiter> {
        match self {
            Active::Ip(run) if super::IP => Some(&mut run.limiter),
            Active::Cyclic(run) if run.mode == mode::CYCLIC_POSITION => Some(&mut run.limiter),
            _ => None,
        }
    }
}

fn fault_code(faults: HardwareFaults) -> Option<(u16, ErrorRegister)> {
    if faults.is_empty() {
        return None;
    }
    let table = [
        (HardwareFaults::OVER_CURRENT, 0x2310, ErrorRegister::CURRENT),
        (HardwareFaults::OVER_VOLTAGE, 0x3210, ErrorRegister::VOLTAGE),
        (HardwareFaults::UNDER_VOLTAGE, 0x3220, ErrorRegister::VOLTAGE),
        (HardwareFaults::OVER_TEMPERATURE, 0x4310, ErrorRegister::TEMPERATURE),
        (HardwareFaults::ENCODER, 0x7305, ErrorRegister::empty()),
    ];
    table
        .iter()
        .find(|(flag, _, _)| faults.contains(*flag))
        .map(|(_, code, register)| (*code, *register | ErrorRegister::DEVICE_PROFILE))
}

/// Following error (CiA 402-2 §7.1, 8611h).
const FOLLOWING_ERROR: u16 = 0x8611;
/// Communication error (8100h): the fault of a connection loss (6007h = 1, or NMT Stopped
/// with [`ProfileConfig::nmt_stopped_fault`]).
const COMMUNICATION_FAULT: u16 = 0x8100;
/// The commands a connection loss forces (6007h = 2, 3): Disable voltage, Quick stop.
const DISABLE_VOLTAGE: Controlword = Controlword::empty();
const QUICK_STOP: Controlword = Controlword::ENABLE_VOLTAGE;

/// Parameter error (6320h): a controlword function this configuration does not have.
const PARAMETER_ERROR: u16 = 0x6320;

/// What the cyclic limiter's per-tick limits come from: velocity, acceleration, deceleration
/// and a halt's deceleration in increments (per second, per second²), and the tick rate.
type LimiterInputs = (u32, u32, u32, u32, u32);

/// The motion limits in increments (per second, per second²): the objects through the factor
/// group.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MotionLimits {
    /// min(607Fh, 6080h).
    velocity: u32,
    /// 60C5h.
    acceleration: u32,
    /// 60C6h.
    deceleration: u32,
    /// 6084h, at most 60C6h.
    profile_deceleration: u32,
    /// 6085h, at most 60C6h.
    quick_stop_deceleration: u32,
}

impl MotionLimits {
    const ZERO: Self = MotionLimits {
        velocity: 0,
        acceleration: 0,
        deceleration: 0,
        profile_deceleration: 0,
        quick_stop_deceleration: 0,
    };

    /// From the raw values of 607Fh, 6080h, 60C5h, 60C6h, 6084h, 6085h.
    fn convert(raw: (u32, u32, u32, u32, u32, u32), factors: &Factors) -> Self {
        let (max_profile_velocity, max_motor_speed, acceleration, deceleration, profile, quick_stop) = raw;
        let deceleration = factors.limit_to_internal(deceleration);
        MotionLimits {
            velocity: factors
                .limit_to_internal(max_profile_velocity)
                .min(factors.motor_speed_to_internal(max_motor_speed)),
            acceleration: factors.limit_to_internal(acceleration),
            deceleration,
            profile_deceleration: factors.limit_to_internal(profile).min(deceleration),
            quick_stop_deceleration: factors.limit_to_internal(quick_stop).min(deceleration),
        }
    }

    /// The deceleration of a stop of `kind` (unlimited, but for 60C6h, where the ramp is not
    /// the profile's).
    fn stop_deceleration(&self, kind: StopKind) -> u32 {
        match kind {
            StopKind::SlowDown => self.profile_deceleration,
            StopKind::QuickStopRamp => self.quick_stop_deceleration,
            StopKind::CurrentLimit | StopKind::VoltageLimit | StopKind::Coast | StopKind::DynamicBrake => {
                self.deceleration
            }
        }
    }
}

impl Profile {
    /// A profile at power-on, of the first axis (objects at 6000h–67FFh).
    pub fn new(config: ProfileConfig) -> Self {
        Profile::for_axis(config, Axis::FIRST)
    }

    /// A profile at power-on for `axis`: every profile object it reads and writes is that axis's
    /// ([`Axis::index`]), the same description shifted by n × 800h.
    pub fn for_axis(config: ProfileConfig, axis: Axis) -> Self {
        Profile { factors: None, run: Runtime::for_axis(config, axis) }
    }

    /// The configuration.
    pub fn config(&self) -> &ProfileConfig {
        &self.run.config
    }

    /// The axis whose objects the profile runs.
    pub fn axis(&self) -> Axis {
        self.run.axis
    }

    /// The FSA state.
    pub fn state(&self) -> State {
        self.run.fsa.state()
    }

    /// Back to power-on (reset application): written in place, field by field, so that an NMT
    /// reset builds no profile of some 3.5 KiB on its stack. The planner is left as it is: it
    /// is reset when pp or homing starts, and nothing reads it before.
    pub fn reset(&mut self) {
        self.factors = None;
        // Every field named: a field added to the profile must be reset here too.
        let Runtime {
            slots,
            slots_resolved,
            config,
            axis,
            supported_modes: _,
            fsa,
            cascade,
            display_mode,
            velocity,
            torque,
            homing,
            probe,
            stream_lost,
            cyclic_limited,
            feed_forward,
            ip,
            ip_overflow,
            mode,
            #[cfg(any(feature = "pp", feature = "hm"))]
                planner: _,
            origin,
            homing_error,
            last_tick,
            fault,
            stopping,
            mode_changed,
            previous_controlword,
            following_error_since,
            forced,
            unavailable_function,
            released_at,
            engaging_since,
            pending_edge,
            travel_limit,
            commanded,
            touching,
            dynamic_braking,
            fault_unreported,
            internal_origin,
            resting_since,
            blocked,
            limits,
            motion,
            tick_limits,
            timing,
            pp_limits,
            steady,
            quiet,
        } = &mut self.run;
        *slots = Slots::UNRESOLVED;
        *slots_resolved = false;
        *fsa = Fsa::default();
        *cascade = None;
        *display_mode = 0;
        *velocity = Ramp::default();
        *torque = Ramp::default();
        *homing = Homing::new(config.homing);
        *probe = TouchProbe::new();
        *stream_lost = false;
        *cyclic_limited = false;
        *feed_forward = FeedForward::NONE;
        *ip = IpBuffer::for_axis(*axis);
        *ip_overflow = false;
        *mode = Active::Idle;
        *origin = 0;
        *homing_error = false;
        *last_tick = None;
        *fault = None;
        *stopping = false;
        *mode_changed = false;
        *previous_controlword = Controlword::empty();
        *following_error_since = None;
        *forced = None;
        *unavailable_function = false;
        *released_at = None;
        *engaging_since = None;
        *pending_edge = false;
        *travel_limit = None;
        *commanded = 0;
        *touching = None;
        *dynamic_braking = false;
        *fault_unreported = false;
        *internal_origin = 0;
        *resting_since = None;
        *blocked = (false, false);
        *limits = Revised::EMPTY;
        *motion = MotionLimits::ZERO;
        *tick_limits = Memo::EMPTY;
        *timing = Revised::EMPTY;
        *pp_limits = Revised::EMPTY;
        *steady = Steady::NONE;
        *quiet = Quiet::NONE;
    }

    /// Reads the facts of the device the profile keeps (6502h, fixed once the dictionary is
    /// built: 6060h accepts only the modes it lists).
    pub fn configure<const B: usize>(&mut self, od: &Dictionary<B>) {
        self.run.quiet.idle = false;
        self.run.supported_modes = od.get::<u32>(self.run.axis.index(SUPPORTED_DRIVE_MODES), 0).unwrap_or(0);
        self.run.build_planner();
    }

    /// Presets the position: from the next tick on 6064h reads `user` at the present position
    /// of the shaft (as after homing on the current position with 607Ch = −`user`). A profile
    /// position move in progress stops where it is.
    pub fn preset_position<const B: usize>(&mut self, od: &Dictionary<B>, user: i32) {
        self.run.quiet.idle = false;
        let Profile { factors, run } = self;
        let factors = factors.get_or_insert_with(|| run.refresh(od));
        // The encoder count of the last tick (6063h counts from `internal_origin`).
        let actual = i64::from(od.load(self.run.slots.position_actual_internal))
            .wrapping_add(self.run.internal_origin);
        self.run.origin =
            actual.saturating_sub(factors.to_internal(i64::from(user) * factors.position_sign()));
        self.run.hold_mode(actual, i64::from(user));
    }

    /// Parameters may have changed (an SDO write, a restore, the firmware's access): the factor
    /// group is read again at the next tick.
    pub fn invalidate(&mut self) {
        self.run.quiet.idle = false;
        self.factors = None;
        self.run.steady.codes_kept = false;
    }

    /// A connection loss, reacted to as 6007h says at the next tick. The reaction applies while
    /// the drive function is enabled (an idle axis has nothing to stop, and faulting it would
    /// make every NMT reset leave the drive in Fault).
    pub fn connection_lost<const B: usize>(&mut self, event: ConnectionEvent, od: &Dictionary<B>) {
        self.run.quiet.idle = false;
        if !self.run.fsa.state().drive_function_enabled() {
            return;
        }
        let fault = if event == ConnectionEvent::NmtStopped
            && self.run.config.nmt_stopped_fault
            && matches!(self.run.fsa.state(), State::OperationEnabled { .. })
        {
            true
        } else {
            // (The drive function was enabled: a tick has resolved the slots.)
            match od.load(self.run.slots.abort_connection) {
                1 => true,
                2 => {
                    self.run.forced = Some(DISABLE_VOLTAGE);
                    false
                }
                3 => {
                    self.run.forced = Some(QUICK_STOP);
                    false
                }
                _ => false,
            }
        };
        if fault && self.run.fault.is_none() {
            // Reported (EMCY, 1003h) at the next tick, so its fault reset sends 0000h.
            self.run.fault = Some(COMMUNICATION_FAULT);
            self.run.fault_unreported = true;
        }
    }

    /// The share of a pp or homing plan in progress for the next tick, after this one's
    /// [`Self::tick`] (the plan is made over several ticks, a bounded share in each). Its stack
    /// is then not under the tick's: a board's tick (e.g. [`crate::drive::Drive::tick_axes`])
    /// calls it once its demands are out.
    #[inline]
    pub fn plan_ahead(&mut self) {
        #[cfg(any(feature = "pp", feature = "hm"))]
        if let Some(planner) = self.run.planner.as_mut().filter(|_| self.run.mode.plans()) {
            planner.plan_ahead();
        }
    }

    /// The value rule of the profile's object `index`/`sub` ([`Rule`]); `pdo`: as an RPDO
    /// writes it.
    #[inline]
    pub fn rule(&self, index: u16, sub: u8, pdo: bool) -> Option<Rule> {
        super::registry::rule(&self.run.config, self.run.first_axis_index(index), sub, pdo)
    }

    /// Checks `data` as the new value of `index`/`sub` under `rule`: the configuration's rules
    /// and those of the drive's state (a new mode in Operation enabled, the ip buffer, the
    /// cascade's parameters at the tick rate).
    pub fn check<const B: usize>(
        &self,
        rule: Rule,
        od: &Dictionary<B>,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<(), AbortCode> {
        match rule {
            // A device that changes modes only outside Operation enabled refuses a new mode there.
            Rule::Mode
                if !self.run.config.mode_change_in_operation
                    && matches!(self.state(), State::OperationEnabled { .. })
                    && od.get::<i8>(index, sub).ok() != data.first().map(|b| *b as i8) =>
            {
                Err(AbortCode::CannotStoreDeviceState)
            }
            Rule::Interpolation | Rule::InterpolationRecord | Rule::InterpolationConfiguration => {
                super::ip::check_write(od, &self.run.ip, index, sub, data)
            }
            Rule::InterpolationRecordPdo => Ok(()),
            Rule::Cascade => {
                crate::control::check_write(od, index, sub, data, self.run.config.tick_rate.hz())
            }
            rule => {
                let index = self.run.first_axis_index(index);
                super::registry::check(rule, &self.run.config, self.run.supported_modes, index, sub, data)
            }
        }
    }

    /// `index`/`sub` was written under `rule` (SDO or RPDO): the ip buffer takes its records and
    /// its configuration.
    pub fn written<const B: usize>(&mut self, od: &mut Dictionary<B>, rule: Rule, index: u16, sub: u8) {
        self.run.quiet.idle = false;
        if rule.is_option_code() {
            // (An RPDO a vendor's description lets write an option code: an SDO write
            // invalidates the profile's parameters anyway.)
            self.run.steady.codes_kept = false;
        } else if rule.reacts() {
            self.ip_written(od, index, sub);
        }
    }

    /// An SDO download to `index` was stored: the parameters the tick derives are computed again;
    /// returns whether it was a set-point that counts for the cyclic stream as an RPDO would
    /// ([`CyclicConfig::sdo_set_points`](super::cyclic::CyclicConfig::sdo_set_points)).
    pub fn sdo_written(&mut self, index: u16) -> bool {
        // A set-point or a command changes nothing the profile derives from its configuration.
        if self.is_process_data(index) {
            self.run.quiet.idle = false;
        } else {
            self.invalidate();
        }
        self.run.config.cyclic.sdo_set_points
            && matches!(
                self.run.axis.relative(index),
                Some(TARGET_POSITION | TARGET_VELOCITY | TARGET_TORQUE)
            )
    }

    /// Whether this axis's object `index` is process data: a set-point or a command a master
    /// writes while the axis runs, which changes nothing the profile derives from its
    /// configuration ([`objects::is_process_data`](super::objects::is_process_data)).
    #[inline]
    pub fn is_process_data(&self, index: u16) -> bool {
        self.run.axis.relative(index).is_some_and(super::objects::is_process_data)
    }

    /// A 60C1h/60C4h entry was written (SDO or RPDO): the ip buffer takes it.
    pub fn ip_written<const B: usize>(&mut self, od: &mut Dictionary<B>, index: u16, sub: u8) {
        self.run.quiet.idle = false;
        if !super::IP {
            return;
        }
        match self.run.ip.written(od, index, sub) {
            Written::Overflow(_) => self.run.ip_overflow = true,
            Written::Cleared | Written::Reorganised => self.run.ip_overflow = false,
            _ => {}
        }
    }

    /// Stored parameters were loaded: the ip buffer takes its configuration again.
    pub fn parameters_loaded<const B: usize>(&mut self, od: &Dictionary<B>) {
        self.run.quiet.idle = false;
        self.factors = None;
        self.run.steady.codes_kept = false;
        if super::IP {
            self.run.ip.reload(od);
        }
    }

    /// Whether a homing run has completed (statusword bit 12 in hm).
    pub fn is_homed(&self) -> bool {
        self.run.homing.is_homed()
    }

    /// The tick of an idle axis whose inputs have not changed since the last tick: true when
    /// [`Self::quiet_demand`] is what [`Self::tick`] would return (its steady outputs are in the
    /// dictionary already), false when a full tick is needed. Idle: the drive function disabled, no
    /// homing, no stop, no transition, no report, no timed status bit running, the last tick
    /// without a SYNC or set-point; unchanged: the sample, and the dictionary by its
    /// [`Dictionary::revision`] (any write to it since, from the bus or the firmware, makes the
    /// next tick a full one, so a value written between ticks takes effect at the same tick as
    /// without this path).
    pub fn quiet_tick(&mut self, now: Instant, sample: &Sample, revision: u32) -> bool {
        if !self.is_quiet(sample, revision) {
            return false;
        }
        self.pass_quietly(now);
        true
    }

    /// Whether [`Self::quiet_tick`] would pass with these inputs (and change nothing): a
    /// node of several axes asks every axis before it lets any pass.
    #[inline]
    pub fn is_quiet(&self, sample: &Sample, revision: u32) -> bool {
        let quiet = &self.run.quiet;
        quiet.idle && quiet.revision == revision && quiet.sample == *sample
    }

    /// The quiet tick of an axis [`Self::is_quiet`] found idle.
    #[inline]
    pub fn pass_quietly(&mut self, now: Instant) {
        // What a full tick of an idle axis changes: the times it keeps.
        self.run.last_tick = Some(now);
        self.run.released_at = Some(now);
    }

    /// The demand of the last idle tick ([`Self::quiet_tick`]).
    #[inline]
    pub fn quiet_demand(&self) -> Demand {
        self.run.quiet.demand
    }

    /// One control tick, in phases: the inputs (`sense`), the state machine and the mode of
    /// operation (`command`), the active mode's step (`step_mode`), and the demands, the
    /// statusword and what the power stage gets (`output`). A caller calls
    /// [`Self::plan_ahead`] after it.
    #[inline]
    pub fn tick<const B: usize>(
        &mut self,
        now: Instant,
        sample: &Sample,
        od: &mut Dictionary<B>,
        cycle: SyncInput,
    ) -> (Demand, Report) {
        // The factor group borrowed beside the state the tick changes, not copied.
        let Profile { factors, run } = self;
        let factors = factors.get_or_insert_with(|| run.refresh(od));
        run.tick(now, sample, od, cycle, factors)
    }
}

impl Runtime {
    /// [`Profile::for_axis`]'s state.
    fn for_axis(config: ProfileConfig, axis: Axis) -> Self {
        Runtime {
            // The first axis's entries, by look-up, until the first tick's refresh resolves the
            // axis's own; nothing reads them before (`preset_position` refreshes first). A
            // constant: building or resetting a profile then copies a template instead of
            // computing 80 slots (1.7 KiB of flash).
            slots: Slots::UNRESOLVED,
            slots_resolved: false,
            config,
            axis,
            supported_modes: 0,
            fsa: Fsa::default(),
            cascade: None,
            display_mode: 0,
            velocity: Ramp::default(),
            torque: Ramp::default(),
            homing: Homing::new(config.homing),
            probe: TouchProbe::new(),
            stream_lost: false,
            cyclic_limited: false,
            feed_forward: FeedForward::NONE,
            ip: IpBuffer::for_axis(axis),
            ip_overflow: false,
            mode: Active::Idle,
            #[cfg(any(feature = "pp", feature = "hm"))]
            planner: None,
            origin: 0,
            homing_error: false,
            last_tick: None,
            fault: None,
            stopping: false,
            mode_changed: false,
            previous_controlword: Controlword::empty(),
            following_error_since: None,
            forced: None,
            unavailable_function: false,
            released_at: None,
            engaging_since: None,
            pending_edge: false,
            travel_limit: None,
            commanded: 0,
            touching: None,
            dynamic_braking: false,
            fault_unreported: false,
            internal_origin: 0,
            resting_since: None,
            blocked: (false, false),
            limits: Revised::EMPTY,
            motion: MotionLimits::ZERO,
            tick_limits: Memo::EMPTY,
            timing: Revised::EMPTY,
            pp_limits: Revised::EMPTY,
            steady: Steady::NONE,
            quiet: Quiet::NONE,
        }
    }

    /// [`Self::planner`] built where it is missing, in a frame of its own.
    #[inline(never)]
    fn build_planner(&mut self) {
        #[cfg(any(feature = "pp", feature = "hm"))]
        if self.planner.is_none() {
            self.planner = Some(PositionPlanner::new(self.config.tick_rate, 0));
        }
    }

    /// The software position limits 607Dh in user units as 6064h reads them (CiA 402-2 §10.5.3),
    /// `None` while they are off: min above max, or not yet valid
    /// ([`ProfileConfig::software_limits_after_homing`]).
    fn software_limits<const B: usize>(&self, od: &Dictionary<B>) -> Option<(i64, i64)> {
        if self.config.software_limits_after_homing && !self.homing.is_homed() {
            return None;
        }
        let offset = self.limit_offset(od);
        let low = i64::from(od.load(self.slots.software_position_limit_min)) - offset;
        let high = i64::from(od.load(self.slots.software_position_limit_max)) - offset;
        (low <= high).then_some((low, high))
    }

    /// What the software limits 607Dh count from, as 6064h reads it: 607Ch with CiA 402's
    /// home offset, nothing where 607Ch is the home's position value.
    fn limit_offset<const B: usize>(&self, od: &Dictionary<B>) -> i64 {
        match self.config.homing.home_offset {
            HomeOffset::ZeroBeforeHome => i64::from(od.load(self.slots.home_offset)),
            HomeOffset::HomeValue => 0,
        }
    }

    /// The range a pp target may take (user units): the software limits, narrowed to the
    /// present position on the side of an active limit switch
    /// ([`ProfileConfig::limit_switches_stop`]).
    #[cfg(feature = "pp")]
    fn target_range<const B: usize>(
        &self,
        od: &Dictionary<B>,
        actual_user: i64,
        inputs: DigitalInputs,
        position_sign: i64,
    ) -> Option<(i64, i64)> {
        let limits = self.software_limits(od);
        let (positive, negative) = self.blocked_directions(inputs);
        // The switches are on the encoder's sides; the user's are mirrored by polarity.
        let (above, below) = if position_sign < 0 { (negative, positive) } else { (positive, negative) };
        if !above && !below {
            return limits;
        }
        let (mut low, mut high) = limits.unwrap_or((i64::MIN, i64::MAX));
        if above {
            high = high.min(actual_user);
        }
        if below {
            low = low.max(actual_user);
        }
        Some((low.min(high), high))
    }

    /// The encoder directions (positive, negative) an active limit switch blocks outside
    /// homing ([`ProfileConfig::limit_switches_stop`]).
    fn blocked_directions(&self, inputs: DigitalInputs) -> (bool, bool) {
        if !self.config.limit_switches_stop || self.mode.is_hm() {
            return (false, false);
        }
        (inputs.contains(DigitalInputs::POSITIVE_LIMIT), inputs.contains(DigitalInputs::NEGATIVE_LIMIT))
    }

    /// Homing is complete only at rest on home (CiA 402-2 §11.4, Table 106): 6064h within the
    /// position window 6067h of the home position, the shaft resting (606Ch within the
    /// velocity threshold 606Fh) for the position window time 6068h; after a run without
    /// motion (method 35) a resting shaft is on home at once.
    fn rests_on_home<const B: usize>(
        &self,
        od: &Dictionary<B>,
        factors: &Factors,
        actual: i64,
        now: Instant,
    ) -> bool {
        let home = self.planner().map_or(actual, |planner| planner.state().position);
        let window = od.load(self.slots.position_window);
        let in_window = window == u32::MAX
            || factors.to_user(actual.saturating_sub(home)).unsigned_abs() <= u64::from(window);
        // Without motion (method 35) there is nothing to settle: resting now is enough.
        let time = if self.homing.was_motionless() {
            Duration::ZERO
        } else {
            Duration::from_millis(u64::from(od.load(self.slots.position_window_time)))
        };
        in_window && self.resting_since.is_some_and(|since| now - since >= time)
    }

    /// Transition 4 or 16: the mode starts over from the axis at `actual` (increments, `user`
    /// in user units) and `velocity` (increments/s).
    fn restart_mode(&mut self, actual: i64, user: i64, velocity: i64) {
        match &mut self.mode {
            Active::Vl(vl) if super::VL => vl.restart(velocity),
            _ => self.coast_mode(actual, user, velocity),
        }
    }

    /// The trajectories and streams start over from the axis as it is (a coasting stop with
    /// `velocity` 0).
    fn coast_mode(&mut self, actual: i64, user: i64, velocity: i64) {
        match &mut self.mode {
            #[cfg(feature = "hm")]
            Active::Hm => {
                if let Some(planner) = self.planner.as_mut() {
                    planner.reset(actual);
                }
            }
            Active::Ip(run) if super::IP => run.reset(actual),
            Active::Cyclic(run) => run.reset(actual, velocity),
            _ => self.hold_mode(actual, user),
        }
    }

    /// pp holds at `actual` and drops its set-points (the drive function disabled, the brake
    /// opening).
    fn hold_mode(&mut self, actual: i64, user: i64) {
        #[cfg(feature = "pp")]
        if let Active::Pp(pp) = &mut self.mode {
            if let Some(planner) = self.planner.as_mut() {
                pp.reset(planner, actual, user);
            }
        }
        let _ = (actual, user);
    }

    /// The trajectory planner while pp or hm runs.
    fn planner(&self) -> Option<&PositionPlanner> {
        #[cfg(any(feature = "pp", feature = "hm"))]
        if self.mode.plans() {
            return self.planner.as_ref();
        }
        None
    }

    /// pp's and hm's trajectory: its velocity fed forward, or, where it runs faster than `vmax`
    /// and faster than the tick before (`previous_velocity`), held where it is: a velocity
    /// limit lowered below the running motion with ramps no plan can follow (a factor group
    /// that turns them into 0 increments/s²) rather than run on faster than the limit (no
    /// demand exceeds the configured limits). Returns the held demand.
    fn trajectory_feed_forward(
        &mut self,
        drive_enabled: bool,
        vmax: u32,
        previous_velocity: i64,
    ) -> Option<Setpoint> {
        #[cfg(any(feature = "pp", feature = "hm"))]
        if let Some(planner) = self.planner.as_mut().filter(|_| drive_enabled && self.mode.plans()) {
            let mut state = planner.state();
            let velocity = state.velocity.unsigned_abs();
            let mut held = None;
            if velocity > u64::from(vmax) && velocity > previous_velocity.unsigned_abs() {
                planner.reset(state.position);
                held = Some(Setpoint::Position(saturate_i32(state.position)));
                state.velocity = 0;
            }
            self.feed_forward.velocity = saturate_i32(state.velocity);
            return held;
        }
        let _ = (drive_enabled, vmax, previous_velocity);
        None
    }

    /// The modes whose demand is a trajectory of positions (pp, hm, csp, ip): the modes with a
    /// [`Self::trajectory`].
    fn position_mode(&self) -> bool {
        match &self.mode {
            #[cfg(feature = "pp")]
            Active::Pp(_) => true,
            #[cfg(feature = "hm")]
            Active::Hm => true,
            Active::Ip(_) => super::IP,
            Active::Cyclic(run) => run.mode == mode::CYCLIC_POSITION,
            _ => false,
        }
    }

    /// The trajectory state of the position modes (pp, hm, csp, ip).
    fn trajectory(&self) -> Option<MotionState> {
        if let Some(planner) = self.planner() {
            return Some(planner.state());
        }
        self.mode.position_limiter().map(|limiter| MotionState {
            position: limiter.position(),
            velocity: limiter.velocity(self.config.tick_rate.hz()),
            acceleration: 0,
        })
    }

    /// Velocity demand of the running motion, increments/s: the trajectory's in a position
    /// mode, the velocity ramp's otherwise.
    fn velocity_demand(&self) -> i64 {
        if self.position_mode() {
            self.trajectory().map_or(0, |state| state.velocity)
        } else {
            self.velocity.value
        }
    }

    /// The first axis's index of `index` when it is one of this axis's profile objects (the
    /// rules are written for 6000h–67FFh); an index outside the profile areas as it is.
    #[inline]
    fn first_axis_index(&self, index: u16) -> u16 {
        if self.axis == Axis::FIRST {
            return index;
        }
        match self.axis.relative(index) {
            Some(relative) => relative,
            // Another axis's object: none of this profile's rules.
            None if Axis::containing(index).is_some() => 0,
            None => index,
        }
    }

    /// [`Profile::tick`] with the factor group, read again if it was invalidated.
    fn tick<const B: usize>(
        &mut self,
        now: Instant,
        sample: &Sample,
        od: &mut Dictionary<B>,
        cycle: SyncInput,
        factors: &Factors,
    ) -> (Demand, Report) {
        let dt = self.last_tick.map_or(Duration::ZERO, |t| (now - t).min(MAX_STEP));
        self.last_tick = Some(now);
        self.quiet.idle = false;
        let mut report = Report::default();
        let mut sensed = self.sense(now, sample, od, factors, &mut report);
        let command = self.command(now, sample, od, factors, &sensed, &mut report);
        let stepped = self.step_mode(now, dt, sample, od, factors, &mut sensed, &command, cycle, &mut report);
        let demand = self.output(now, sample, od, factors, &sensed, &command, stepped, &mut report);
        // An idle axis: a tick with the same inputs would give the same outputs and leave the
        // same state (but for the times [`Self::quiet_tick`] keeps).
        let idle = !demand.drive_enabled
            && command.step.state == command.before
            && !command.switched
            && !self.mode.is_hm()
            && command.stop.is_none()
            && report == Report::default()
            && cycle == SyncInput::default()
            && !sensed.probe_changed
            && !self.dynamic_braking
            && self.forced.is_none()
            && !matches!(&self.mode, Active::Pv(run) if run.timing());
        if idle {
            self.quiet = Quiet { idle: true, sample: *sample, revision: od.revision(), demand };
        }
        (demand, report)
    }

    /// The tick's first phase: the actual values (stored for the bus), the shaft's rest, the
    /// limit switches, the touch probe and a new hardware fault.
    #[inline(always)]
    fn sense<const B: usize>(
        &mut self,
        now: Instant,
        sample: &Sample,
        od: &mut Dictionary<B>,
        factors: &Factors,
        report: &mut Report,
    ) -> Sensed {
        let actual = i64::from(sample.position);
        if sample.faults.contains(HardwareFaults::ENCODER) {
            self.homing.forget();
        }
        let actual_user = factors.to_user(actual.saturating_sub(self.origin)) * factors.position_sign();
        // 6063h: the encoder count, from the zero homing on the current position may have set.
        od.store(self.slots.position_actual_internal, actual.wrapping_sub(self.internal_origin) as i32);
        od.store(self.slots.position_actual, saturate_i32(actual_user));
        let velocity_user = factors.velocity_to_user(i64::from(sample.velocity)) * factors.velocity_sign();
        od.store(self.slots.velocity_actual, saturate_i32(velocity_user));
        // The shaft rests: |606Ch| within the velocity threshold 606Fh; with the configuration's
        // option, for longer than the velocity threshold time 6070h, so that a shaft that only
        // passes through 0 (a reversal of its settling) is not taken as resting.
        // Read only where asked for: homing's completion, halt with the configuration's option.
        let homing = self.mode.is_hm();
        let standstill = if homing || self.config.halt_reached_at_standstill {
            let resting = velocity_user.unsigned_abs() <= u64::from(od.load(self.slots.velocity_threshold));
            if !resting {
                self.resting_since = None;
            } else if self.resting_since.is_none() {
                self.resting_since = Some(now);
            }
            let time = || Duration::from_millis(u64::from(od.load(self.slots.velocity_threshold_time)));
            !self.config.halt_reached_at_standstill
                || self.resting_since.is_some_and(|since| now - since > time())
        } else {
            self.resting_since = None;
            true
        };
        self.blocked = self.blocked_directions(sample.inputs);
        let torque_user = factors.torque_to_user(i64::from(sample.torque));
        od.store_int(self.slots.torque_actual, torque_user);
        od.store_int(self.slots.current_actual, torque_user);
        od.store(self.slots.dc_link_voltage, sample.dc_link_millivolts);
        // 60FDh bits 0..3: negative/positive limit, home, interlock (the hal uses the same bits).
        od.store(self.slots.digital_inputs, sample.inputs.bits() & 0x0F);
        if let Some(code) = self.config.travel_limit_emcy {
            let limit = self.travel_limit(od, actual_user, sample.inputs);
            if limit != self.travel_limit {
                self.travel_limit = limit;
                report.travel_limit = Some((code, limit));
            }
        }

        // Touch probe (digest §10.6): latched in increments, reported in user units. Probe 1's
        // latch of this tick is for touch-probe homing (method 36).
        let (probe, probe_changed) = if super::PROBE {
            self.tick_probe(od, sample, factors, factors.position_sign())
        } else {
            (None, false)
        };

        // Faults: a new one is latched and reported; it stays until a fault reset succeeds.
        let hardware = fault_code(sample.faults);
        if self.fault.is_none() {
            if let Some((code, register)) = hardware {
                self.fault = Some(code);
                report.raise = Some((code, register));
            }
        }
        if core::mem::take(&mut self.fault_unreported) {
            if let Some(code) = self.fault {
                let register = ErrorRegister::COMMUNICATION | ErrorRegister::DEVICE_PROFILE;
                report.raise = report.raise.or(Some((code, register)));
            }
        }
        Sensed { actual, actual_user, velocity_user, standstill, probe, probe_changed, hardware }
    }

    /// The tick's second phase: the controlword (or the board's local control) through the
    /// state machine, a change of the mode of operation, and the stop the tick makes (the
    /// state machine's, a halt's or one for a mode change).
    #[inline(always)]
    fn command<const B: usize>(
        &mut self,
        now: Instant,
        sample: &Sample,
        od: &mut Dictionary<B>,
        factors: &Factors,
        sensed: &Sensed,
        report: &mut Report,
    ) -> Command {
        if !self.steady.codes_kept {
            self.read_option_codes(od);
        }
        // (Fields, not the kept codes as a whole: a copy of that is a library call.)
        let (quick_stop_option, halt_option) = (self.steady.options.quick_stop, self.steady.halt_option);
        let (controlword, commanded, bit4_rose) = self.controlword(sample, od, report);
        let before = self.fsa.state();
        let previous_velocity = self.velocity_demand();
        let at_rest = previous_velocity == 0;
        // A stop is complete once the brake has had its time to close.
        let stopped = at_rest
            && (self.config.brake_engage_delay == Duration::ZERO
                || self.engaging_since.is_some_and(|since| now - since >= self.config.brake_engage_delay));
        let fault = self.fault.is_some() && !before_fault_cleared(before, sensed.hardware);
        let step = self.step_fsa((commanded, fault, stopped));
        #[cfg(any(feature = "defmt", feature = "log"))]
        if step.state != before {
            if matches!(step.state, State::FaultReactionActive) {
                crate::fmt::warning!("cia402: fault {:#x}", self.fault.unwrap_or_default());
            }
            crate::fmt::info!("cia402: {:?} -> {:?}", before, step.state);
        }
        if matches!(before, State::Fault) && !matches!(step.state, State::Fault) {
            // Transition 15: the fault is gone.
            if let Some(code) = self.fault.take() {
                report.clear = Some(code);
            }
        }
        if let Some(code) = self.fault {
            od.store(self.slots.error_code, self.config.reported_code(code));
        }
        let enabled = step.state.drive_function_enabled();

        // Mode switching: at once while the drive function is disabled, after a stop otherwise.
        let requested: i8 = od.load(self.slots.modes_of_operation);
        let switching = requested != self.display_mode;
        // A device without mode changes in Operation enabled keeps the mode until it is left.
        let may_switch =
            self.config.mode_change_in_operation || !matches!(step.state, State::OperationEnabled { .. });
        let switched = switching && may_switch && (!enabled || at_rest);
        if switched {
            let direct = self.config.manufacturer_mode(requested);
            self.display_mode = requested;
            let number = direct.map_or(requested, DirectMode::cyclic_mode);
            self.mode_changed = true;
            crate::fmt::info!("cia402: mode of operation {}", requested);
            self.homing.interrupt();
            self.velocity = Ramp { value: i64::from(sample.velocity), remainder: 0 };
            self.start_mode(number, sensed.actual, sensed.actual_user, i64::from(sample.velocity));
        }
        od.store(self.slots.modes_of_operation_display, self.display_mode);

        let halt = controlword.contains(Controlword::HALT);
        if step.entered_operation {
            // Transition 4 (and 16) clear the internal set-points.
            self.velocity = Ramp { value: i64::from(sample.velocity), remainder: 0 };
            self.torque = Ramp::default();
            self.homing.interrupt();
            self.restart_mode(sensed.actual, sensed.actual_user, i64::from(sample.velocity));
        }
        let operation = matches!(step.state, State::OperationEnabled { leaving: None });
        let stop = step.stop.or_else(|| {
            // pp halts on its trajectory, tq ramps its torque to 0 (digest §4.1).
            let halting = halt
                && operation
                && !self.position_mode()
                && !self.mode.is_torque()
                && !matches!(self.mode, Active::Vl(_));
            // (hm halts on its own trajectory, like pp.)
            let for_switch = switching && may_switch && operation;
            if halting {
                halt_option
            } else if for_switch {
                Some(StopKind::SlowDown)
            } else {
                None
            }
        });
        let limits = self.motion_limits(od, factors);
        if let Some(kind) = stop.filter(|_| !self.stopping) {
            self.start_stop(od, factors, kind, i64::from(sample.velocity));
        }
        self.stopping = stop.is_some();
        Command {
            quick_stop_option,
            controlword,
            bit4_rose,
            before,
            previous_velocity,
            at_rest,
            step,
            enabled,
            switched,
            halt,
            operation,
            halt_kind: halt_option.unwrap_or(StopKind::SlowDown),
            stop,
            limits,
        }
    }

    /// The controlword as the tick takes it: none in local control, bit 9 removed where the
    /// configuration has no change on set-point (reported once), and what the state machine
    /// is commanded (a forced command first; the board's quick-stop and interlock inputs
    /// override bits 2 and 1); with whether bit 4 rose since the last tick.
    #[inline(always)]
    fn controlword<const B: usize>(
        &mut self,
        sample: &Sample,
        od: &Dictionary<B>,
        report: &mut Report,
    ) -> (Controlword, Option<Controlword>, bool) {
        // In local control the controlword is not processed: no command, no mode bits.
        let local = sample.local_control;
        let mut controlword =
            if local { Controlword::empty() } else { Controlword::from_raw(od.load(self.slots.controlword)) };
        let unavailable = self.mode.is_pp()
            && !self.config.change_on_setpoint
            && controlword.contains(Controlword::CHANGE_ON_SET_POINT);
        if unavailable != self.unavailable_function {
            self.unavailable_function = unavailable;
            report.notices[0] = Some((PARAMETER_ERROR, unavailable));
        }
        if unavailable {
            controlword.remove(Controlword::CHANGE_ON_SET_POINT);
        }
        let bit4_rose = controlword.contains(Controlword::MODE_SPECIFIC_4)
            && !self.previous_controlword.contains(Controlword::MODE_SPECIFIC_4);
        self.previous_controlword = controlword;
        let mut commanded = self.forced.take().or((!local).then_some(controlword));
        if let Some(command) = commanded.as_mut().filter(|c| !c.contains(Controlword::FAULT_RESET)) {
            // The board's inputs: quick stop (bit 2 = 0), interlock (disable voltage).
            if sample.inputs.contains(DigitalInputs::QUICK_STOP) {
                command.remove(Controlword::QUICK_STOP);
            }
            if sample.inputs.contains(DigitalInputs::INTERLOCK) {
                command.remove(Controlword::ENABLE_VOLTAGE);
            }
        }
        (controlword, commanded, bit4_rose)
    }

    /// The option codes 605Ah, 605Bh, 605Ch, 605Eh as the FSA takes them, and 605Dh, how a halt
    /// stops (`None`: a fault reaction), read into [`Self::steady`], where they are kept until
    /// they may have been written ([`Profile::invalidate`], [`Profile::written`]). Out of line:
    /// the steady tick holds only the test.
    #[inline(never)]
    fn read_option_codes<const B: usize>(&mut self, od: &Dictionary<B>) {
        self.steady.options = Options {
            quick_stop: od.load(self.slots.quick_stop_option),
            shutdown: od.load(self.slots.shutdown_option),
            disable_operation: od.load(self.slots.disable_operation_option),
            fault_reaction: od.load(self.slots.fault_reaction_option),
            transition_16: self.config.transition_16,
        };
        self.steady.halt_option = StopKind::halt_or_fault(od.load(self.slots.halt_option));
        self.steady.codes_kept = true;
        // The options may differ: the FSA's step is made again.
        self.steady.fixed = None;
    }

    /// The FSA's step of this tick with `inputs` (the command, a fault present, the stop at
    /// rest): the last tick's again where that step left the FSA as it was and the inputs and
    /// the option codes stand (the step is a function of them and the FSA alone), otherwise
    /// made anew.
    #[inline(always)]
    fn step_fsa(&mut self, inputs: (Option<Controlword>, bool, bool)) -> Step {
        if self.steady.fixed == Some(inputs) {
            return self.steady.step;
        }
        self.make_step(inputs)
    }

    /// [`Self::step_fsa`] made anew (out of line, as [`Self::read_option_codes`]).
    #[inline(never)]
    fn make_step(&mut self, inputs: (Option<Controlword>, bool, bool)) -> Step {
        let before = self.fsa;
        let (commanded, fault, stopped) = inputs;
        let step = self.fsa.step(commanded, fault, stopped, &self.steady.options);
        let fixed = self.fsa == before && !step.entered_operation && !step.dynamic_brake;
        self.steady.fixed = fixed.then_some(inputs);
        self.steady.step = step;
        step
    }

    /// The tick's third phase: the brake, then the set-point of the tick's stop, of the active
    /// mode, or of a held axis; a limit switch touched by commanded motion.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn step_mode<const B: usize>(
        &mut self,
        now: Instant,
        dt: Duration,
        sample: &Sample,
        od: &mut Dictionary<B>,
        factors: &Factors,
        sensed: &mut Sensed,
        command: &Command,
        cycle: SyncInput,
        report: &mut Report,
    ) -> Stepped {
        let Command { step, enabled, stop, .. } = *command;
        let (actual, actual_user) = (sensed.actual, sensed.actual_user);
        let mut drive_enabled = enabled;
        let mut status = pp::Status::default();
        self.feed_forward = FeedForward::NONE;
        self.cyclic_limited = false;
        // Brake: opens when the drive function is enabled; the axis is held until it is open.
        // At the end of a ramped stop it closes while the motor still holds.
        if !enabled || step.entered_operation {
            self.released_at = None;
            self.engaging_since = None;
        }
        if stop.is_some_and(|kind| !kind.at_once()) && self.velocity_demand() == 0 {
            self.engaging_since.get_or_insert(now);
        } else if stop.is_none() {
            self.engaging_since = None;
        }
        let released_at = *self.released_at.get_or_insert(now);
        let opening = enabled && now - released_at < self.config.brake_release_delay;
        let bit4_rose = if opening {
            // The edge of the enabling command itself starts nothing (testable item 74).
            self.pending_edge |= command.bit4_rose && !step.entered_operation;
            false
        } else {
            command.bit4_rose
                || core::mem::take(&mut self.pending_edge)
                    && command.controlword.contains(Controlword::MODE_SPECIFIC_4)
        };
        let input = ModeInput {
            now,
            dt,
            sample,
            factors,
            controlword: command.controlword,
            cycle,
            halt: command.halt,
            halt_kind: command.halt_kind,
            bit4_rose,
            operation: command.operation,
            entered_operation: step.entered_operation,
            enabled: drive_enabled,
            actual,
            actual_user,
            standstill: sensed.standstill,
            probe: sensed.probe,
            limits: command.limits,
        };
        self.commanded = 0;
        let mut setpoint = match stop {
            None if opening => {
                self.hold_mode(actual, actual_user);
                self.velocity = Ramp::default();
                self.torque = Ramp::default();
                Setpoint::Position(sample.position)
            }
            Some(kind @ (StopKind::Coast | StopKind::DynamicBrake)) => {
                drive_enabled = false;
                self.dynamic_braking |= kind == StopKind::DynamicBrake;
                self.velocity = Ramp::default();
                self.homing.interrupt();
                self.coast_mode(actual, actual_user, 0);
                Setpoint::None
            }
            Some(kind) => self.step_stop(od, &input, kind),
            None if self.mode.is_hm() => {
                let (setpoint, homed) = self.run_homing(od, &input, report);
                sensed.actual_user = homed.unwrap_or(actual_user);
                setpoint
            }
            None if drive_enabled => {
                let (setpoint, mode_status) = self.run_active(od, &input, report);
                status = mode_status;
                setpoint
            }
            None => {
                self.velocity = Ramp::default();
                self.torque = Ramp::default();
                self.hold_mode(actual, actual_user);
                Setpoint::None
            }
        };
        if let Some(code) = self.config.travel_limit_emcy {
            // Motion commanded into an active limit switch: once per touch, and not again
            // where the switch's own EMCY goes in this tick (the axis ran into it).
            let touch = self.touched_switch(sample.inputs);
            let reported = matches!(report.travel_limit, Some((_, limit)) if limit == touch);
            if touch.is_some() && touch != self.touching && !reported {
                report.limit_switch_touched = touch.map(|switch| (code, switch));
            }
            self.touching = touch;
        }

        if cycle.set_point && !(drive_enabled && stop.is_none() && !opening) {
            if let Active::Cyclic(run) = &mut self.mode {
                // Written before Operation enabled (an SDO-driven cycle): kept for the mode.
                run.held_set_point = true;
            }
        }
        let vmax = command.limits.velocity;
        if let Some(held) = self.trajectory_feed_forward(drive_enabled, vmax, command.previous_velocity) {
            setpoint = held;
        }
        Stepped { setpoint, status, drive_enabled, opening }
    }

    /// The tick's last phase: the demand values and the following error (stored for the bus),
    /// the statusword, the position and velocity loops and what the power stage gets.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn output<const B: usize>(
        &mut self,
        now: Instant,
        sample: &Sample,
        od: &mut Dictionary<B>,
        factors: &Factors,
        sensed: &Sensed,
        command: &Command,
        stepped: Stepped,
        report: &mut Report,
    ) -> Demand {
        let Stepped { setpoint, status, drive_enabled, opening } = stepped;
        let (actual, actual_user) = (sensed.actual, sensed.actual_user);
        let step = command.step;
        // Demands and the position control function (digest §11).
        // (The other modes have no trajectory to ask.)
        let position_mode = self.position_mode();
        let trajectory = if position_mode { self.trajectory() } else { None };
        let demand_position = trajectory.filter(|_| drive_enabled).map(|state| state.position);
        let demand_internal = demand_position.unwrap_or(actual).saturating_sub(self.origin);
        // Without a trajectory the demand is the actual position, 6064h already made (from the
        // origin homing may have moved in this tick).
        let demand_user = match demand_position {
            Some(_) => factors.to_user(demand_internal) * factors.position_sign(),
            None => actual_user,
        };
        od.store(self.slots.position_demand_internal, demand_internal as i32);
        od.store(self.slots.position_demand, saturate_i32(demand_user));
        let following_error = demand_user.saturating_sub(actual_user);
        od.store(self.slots.following_error_actual, saturate_i32(following_error));
        let velocity_demand_internal = match trajectory {
            _ if !position_mode => self.velocity.value,
            Some(state) => state.velocity,
            None => 0,
        };
        let velocity_demand = factors.velocity_to_user(velocity_demand_internal) * factors.velocity_sign();
        od.store(self.slots.velocity_demand, saturate_i32(velocity_demand));
        od.store_int(self.slots.torque_demand, factors.torque_to_user(self.torque.value));
        let following = position_mode && drive_enabled && self.following_error(od, following_error, now);
        if following && self.config.following_error_fault && self.fault.is_none() {
            self.fault = Some(FOLLOWING_ERROR);
            report.raise = report.raise.or(Some((FOLLOWING_ERROR, ErrorRegister::DEVICE_PROFILE)));
        }

        let status_input = StatusInput {
            state: step.state,
            sample,
            quick_stop_option: command.quick_stop_option,
            pp: status,
            halt: command.halt,
            standstill: sensed.standstill,
            operation: command.operation,
            drive_enabled,
            following,
            velocity_demand_internal,
            velocity_demand,
            velocity_user: sensed.velocity_user,
            opening,
            was_at_rest: command.at_rest,
            factors,
            actual,
        };
        let statusword = self.statusword(&status_input, od, now);
        od.store(self.slots.statusword, statusword.bits());
        // 60FEh: a master may engage the brake (sub 1 bit 0) where the mask (sub 2) enables it;
        // a drive described without the mask drives every output from sub 1.
        let outputs = od.load(self.slots.digital_outputs_physical)
            & od.load_or(self.slots.digital_outputs_mask, u32::MAX);
        let setpoint =
            if drive_enabled { self.close_loops(setpoint, sample, od, factors) } else { Setpoint::None };
        if !drive_enabled {
            if let Some(cascade) = self.cascade.as_mut() {
                cascade.reset(0);
            }
        }
        self.dynamic_braking |= step.dynamic_brake;
        if drive_enabled || sample.velocity == 0 {
            self.dynamic_braking = false;
        }
        Demand {
            high_voltage: step.state.high_voltage(),
            drive_enabled,
            brake_released: drive_enabled && outputs & 1 == 0 && self.engaging_since.is_none(),
            dynamic_brake: self.dynamic_braking,
            setpoint,
            feed_forward: if drive_enabled { self.feed_forward } else { FeedForward::NONE },
        }
    }

    /// The motion limits in increments, converted again only when one of their objects (or
    /// the factor group) has changed; also [`Self::motion`] for the rest of the tick.
    fn motion_limits<const B: usize>(&mut self, od: &Dictionary<B>, factors: &Factors) -> MotionLimits {
        if let Some(kept) = self.limits.kept(od.configuration_revision()) {
            self.motion = kept;
            return kept;
        }
        let raw = (
            od.load(self.slots.max_profile_velocity),
            od.load(self.slots.max_motor_speed),
            od.load(self.slots.max_acceleration),
            od.load(self.slots.max_deceleration),
            od.load(self.slots.profile_deceleration),
            od.load(self.slots.quick_stop_deceleration),
        );
        self.motion =
            self.limits.get(raw, od.configuration_revision(), || MotionLimits::convert(raw, factors));
        self.motion
    }

    /// pp's motion limits ([`pp::LimitObjects::limits`]) and its end velocity 6082h in increments, converted
    /// again only when one of their objects (or the factor group) has changed.
    fn pp_limits<const B: usize>(&mut self, od: &Dictionary<B>, factors: &Factors) -> (Limits, u32) {
        if let Some(kept) = self.pp_limits.kept(od.configuration_revision()) {
            return kept;
        }
        let objects = pp::LimitObjects::read(od, &self.slots);
        self.pp_limits.get(objects, od.configuration_revision(), || objects.limits(factors))
    }

    /// The cyclic limiter's per-tick limits: with the maximum deceleration, and with a halt's.
    fn cyclic_limits(&mut self, input: &ModeInput<'_>) -> (TickLimits, TickLimits) {
        let hz = self.config.tick_rate.hz();
        let limits = input.limits;
        let halt_deceleration = limits.stop_deceleration(input.halt_kind);
        let key = (limits.velocity, limits.acceleration, limits.deceleration, halt_deceleration, hz);
        self.tick_limits.get(key, || {
            (
                TickLimits::new(limits.velocity, limits.acceleration, limits.deceleration, hz),
                TickLimits::new(limits.velocity, limits.acceleration, halt_deceleration, hz),
            )
        })
    }

    /// Reads the parameters cached between writes: the factor group and the cascade's gains
    /// (the integrator is kept across a re-tuning).
    #[inline(never)]
    fn refresh<const B: usize>(&mut self, od: &Dictionary<B>) -> Factors {
        let factors = Factors::from_axis(od, self.config.units, self.axis);
        self.limits = Revised::EMPTY;
        self.pp_limits = Revised::EMPTY;
        if !self.slots_resolved {
            // The dictionary's layout is fixed when it is built: once is enough.
            self.resolve_slots(od);
        }
        if let Some(index) = self.config.cascade {
            self.tune_cascade(od, index);
        }
        factors
    }

    /// [`Self::slots`] resolved in `od` (out of line, like [`Self::tune_cascade`]: a tick that
    /// refreshes its parameters holds one of the two frames at a time, not both).
    #[inline(never)]
    fn resolve_slots<const B: usize>(&mut self, od: &Dictionary<B>) {
        self.slots.resolve(od, self.axis);
        self.slots_resolved = true;
    }

    /// The cascade's gains from the parameter record at `index` (the integrator is kept).
    #[inline(never)]
    fn tune_cascade<const B: usize>(&mut self, od: &Dictionary<B>, index: u16) {
        let parameters = Parameters::from_dictionary(od, index).unwrap_or(Parameters::DEFAULT);
        let hz = self.config.tick_rate.hz();
        match self.cascade.as_mut() {
            Some(cascade) => {
                let _ = cascade.set_parameters(parameters);
            }
            None => {
                self.cascade = Cascade::new(hz, parameters).or(Cascade::new(hz, Parameters::DEFAULT)).ok()
            }
        }
    }

    /// The travel limit the axis is at: a limit switch outside homing first, then 6064h
    /// outside the software limits 607Dh (off while min > max, as for pp targets).
    fn travel_limit<const B: usize>(
        &self,
        od: &Dictionary<B>,
        actual_user: i64,
        inputs: DigitalInputs,
    ) -> Option<TravelLimit> {
        if !self.mode.is_hm() {
            if inputs.contains(DigitalInputs::POSITIVE_LIMIT) {
                return Some(TravelLimit::PositiveSwitch);
            }
            if inputs.contains(DigitalInputs::NEGATIVE_LIMIT) {
                return Some(TravelLimit::NegativeSwitch);
            }
        }
        match self.software_limits(od) {
            Some((_, high)) if actual_user > high => Some(TravelLimit::PositiveSoftware),
            Some((low, _)) if actual_user < low => Some(TravelLimit::NegativeSoftware),
            _ => None,
        }
    }

    /// The limit switch this tick's mode commands motion into ([`Self::commanded`] towards an
    /// active switch); the modes that command it (pp, pv) are not homing.
    fn touched_switch(&self, inputs: DigitalInputs) -> Option<TravelLimit> {
        match self.commanded {
            1 if inputs.contains(DigitalInputs::POSITIVE_LIMIT) => Some(TravelLimit::PositiveSwitch),
            -1 if inputs.contains(DigitalInputs::NEGATIVE_LIMIT) => Some(TravelLimit::NegativeSwitch),
            _ => None,
        }
    }

    /// The core's loops turn a position or velocity demand into a torque demand (60FAh gets
    /// the velocity command). Without them, 60FAh reports 0.
    fn close_loops<const B: usize>(
        &mut self,
        setpoint: Setpoint,
        sample: &Sample,
        od: &mut Dictionary<B>,
        factors: &Factors,
    ) -> Setpoint {
        if self.cascade.is_none() {
            od.store(self.slots.control_effort, 0);
            return setpoint;
        }
        let velocity_limit = self.motion.velocity;
        // pp's trajectory feeds its velocity forward.
        let pp = self.mode.is_pp() && matches!(setpoint, Setpoint::Position(_));
        let velocity = self.planner().filter(|_| pp).map_or(0, |planner| planner.state().velocity);
        let Some(cascade) = self.cascade.as_mut() else { return setpoint };
        let torque_limit = od.load(self.slots.max_torque).min(od.load(self.slots.max_current));
        cascade.set_limits(velocity_limit, torque_limit);
        let actual = Actual::from(sample);
        let output = match setpoint {
            Setpoint::Position(position) => {
                let reference = Reference { position, velocity: saturate_i32(velocity), torque: 0 };
                cascade.step(reference, actual)
            }
            Setpoint::Velocity(velocity) => cascade.step_velocity(velocity, 0, actual.velocity),
            Setpoint::Torque(_) | Setpoint::None => {
                cascade.reset(0);
                od.store(self.slots.control_effort, 0);
                return setpoint;
            }
        };
        let effort = factors.velocity_to_user(i64::from(output.velocity)) * factors.velocity_sign();
        od.store(self.slots.control_effort, saturate_i32(effort));
        Setpoint::Torque(output.torque)
    }

    /// One tick of the touch probe: latches, 60B9h, the edge positions and counters. Returns
    /// probe 1's latch of this tick (increments), and whether anything of the probe changed.
    fn tick_probe<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        sample: &Sample,
        factors: &Factors,
        position_sign: i64,
    ) -> (Option<i64>, bool) {
        let function = od.load(self.slots.touch_probe_function);
        if self.probe.rest(function, sample.inputs) {
            // 60B9h holds the 0 of the tick that switched the probes off.
            return (None, false);
        }
        let probe = self.probe.tick(function, sample.inputs, sample.position, &sample.captures);
        od.store(self.slots.touch_probe_status, probe.status);
        if probe.changed.is_empty() {
            return (None, false);
        }
        let to_user =
            |p: i32| saturate_i32(factors.to_user(i64::from(p).saturating_sub(self.origin)) * position_sign);
        let latched = [
            (Changed::PROBE_1_POSITIVE, TOUCH_PROBE_1_POSITIVE_EDGE, probe.positive[0]),
            (Changed::PROBE_1_NEGATIVE, TOUCH_PROBE_1_NEGATIVE_EDGE, probe.negative[0]),
            (Changed::PROBE_2_POSITIVE, TOUCH_PROBE_2_POSITIVE_EDGE, probe.positive[1]),
            (Changed::PROBE_2_NEGATIVE, TOUCH_PROBE_2_NEGATIVE_EDGE, probe.negative[1]),
        ];
        for (flag, index, position) in latched {
            if probe.changed.contains(flag) {
                let _ = od.set::<i32>(self.axis.index(index), 0, to_user(position));
            }
        }
        if probe.changed.contains(Changed::COUNTERS) {
            let counters = [
                TOUCH_PROBE_1_POSITIVE_EDGE_COUNTER,
                TOUCH_PROBE_1_NEGATIVE_EDGE_COUNTER,
                TOUCH_PROBE_2_POSITIVE_EDGE_COUNTER,
                TOUCH_PROBE_2_NEGATIVE_EDGE_COUNTER,
            ];
            for (index, count) in counters.into_iter().zip(self.probe.counts()) {
                let _ = od.set::<u16>(self.axis.index(index), 0, count);
            }
        }
        let latch = if probe.changed.contains(Changed::PROBE_1_POSITIVE) {
            Some(i64::from(probe.positive[0]))
        } else if probe.changed.contains(Changed::PROBE_1_NEGATIVE) {
            Some(i64::from(probe.negative[0]))
        } else {
            None
        };
        (latch, !probe.changed.is_empty())
    }

    /// A stop of `kind` starts in the active mode, the shaft at `velocity` (increments/s): pp and
    /// hm plan it on their trajectory, csp and ip stop their limiter, vl its ramp; the others
    /// ramp the velocity demand down from the actual velocity.
    #[inline(never)]
    fn start_stop<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        factors: &Factors,
        kind: StopKind,
        velocity: i64,
    ) {
        let limits = self.motion;
        let deceleration = limits.stop_deceleration(kind);
        if self.planner().is_some() {
            let planner_limits = self.pp_limits(od, factors).0;
            self.stop_planner(deceleration, &planner_limits);
            return;
        }
        match &mut self.mode {
            Active::Vl(vl) if super::VL => vl.stop(kind),
            mode => match mode.position_limiter_mut() {
                Some(limiter) => {
                    let hz = self.config.tick_rate.hz();
                    limiter.stop(&TickLimits::new(limits.velocity, limits.acceleration, deceleration, hz))
                }
                None => self.velocity = Ramp { value: velocity, remainder: 0 },
            },
        }
    }

    /// pp's or hm's stop with `deceleration` under `limits` (their motion limits).
    fn stop_planner(&mut self, deceleration: u32, limits: &Limits) {
        #[cfg(any(feature = "pp", feature = "hm"))]
        if let Some(planner) = self.planner.as_mut() {
            match &mut self.mode {
                #[cfg(feature = "hm")]
                Active::Hm => self.homing.stop(planner, deceleration, limits),
                #[cfg(feature = "pp")]
                Active::Pp(pp) => pp.stop(planner, deceleration, limits),
                _ => {}
            }
        }
        let _ = (deceleration, limits);
    }

    /// One tick of a ramped stop (not a coasting one) in the active mode: pp and hm stop on
    /// their trajectory, csp and ip with the limiter, vl with its ramp, the others ramp the
    /// velocity demand down.
    #[inline(never)]
    fn step_stop<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        input: &ModeInput<'_>,
        kind: StopKind,
    ) -> Setpoint {
        let limits = input.limits;
        let hz = self.config.tick_rate.hz();
        if let Some(limiter) = self.mode.position_limiter_mut() {
            if !limiter.is_stopping() {
                // The mode was entered while the stop ran (a switch at rest resets the
                // limiter): the limiter stops from here, it does not chase a target.
                let deceleration = limits.stop_deceleration(kind);
                limiter.stop(&TickLimits::new(limits.velocity, limits.acceleration, deceleration, hz));
            }
            limiter.tick(0, &TickLimits::new(limits.velocity, limits.acceleration, limits.deceleration, hz));
            return Setpoint::Position(limiter.position() as i32);
        }
        #[cfg(any(feature = "pp", feature = "hm"))]
        if let Some(planner) = self.planner.as_mut().filter(|_| self.mode.plans()) {
            let state = planner.follow();
            return Setpoint::Position(state.position_demand());
        }
        match &mut self.mode {
            Active::Vl(_) if super::VL => self.run_vl(od, input),
            _ => {
                self.velocity.toward(0, limits.stop_deceleration(kind), input.dt);
                Setpoint::Velocity(self.velocity.value as i32)
            }
        }
    }

    /// One tick of the active mode other than hm, the drive function enabled and no stop
    /// running; with the bits pp or ip report.
    #[inline(never)]
    fn run_active<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        input: &ModeInput<'_>,
        report: &mut Report,
    ) -> (Setpoint, pp::Status) {
        match self.mode {
            Active::Vl(_) if super::VL => (self.run_vl(od, input), pp::Status::default()),
            Active::Ip(_) if super::IP => self.run_ip(od, input),
            Active::Cyclic(_) => (self.run_cyclic(od, input, report), pp::Status::default()),
            #[cfg(feature = "pp")]
            Active::Pp(_) => self.run_pp(od, input),
            _ => (self.run_mode(od, input), pp::Status::default()),
        }
    }

    /// One tick of homing mode (CiA 402-2 §11), also with the drive function disabled (method 35
    /// completes there). Returns the demand and, when home was found, 6064h from the new zero.
    #[inline(never)]
    fn run_homing<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        input: &ModeInput<'_>,
        report: &mut Report,
    ) -> (Setpoint, Option<i64>) {
        let ModeInput { now, sample, factors, controlword, actual, limits, .. } = *input;
        let position_sign = factors.position_sign();
        let (vmax, max_acceleration, max_deceleration) =
            (limits.velocity, limits.acceleration, limits.deceleration);
        let drive_enabled = input.enabled;
        let mut homed = None;
        // 607Fh/6080h and 60C5h/60C6h limit homing as every mode (digest §9.5).
        let speeds = (
            factors.limit_to_internal(od.load(self.slots.homing_speed_switch)).min(vmax),
            factors.limit_to_internal(od.load(self.slots.homing_speed_zero)).min(vmax),
            factors
                .limit_to_internal(od.load(self.slots.homing_acceleration))
                .min(max_acceleration)
                .min(max_deceleration),
        );
        // Method 35 may start outside Operation enabled (digest §10.2). Also in the tick of a
        // mode change: 6060h = 6 and bit 4 written between two ticks start homing.
        let start = input.bit4_rose && !input.entered_operation;
        let inputs = hm::Inputs {
            od,
            controlword,
            start,
            method: if start { od.load(self.slots.homing_method) } else { 0 },
            actual,
            torque: sample.torque,
            velocity: sample.velocity,
            inputs: sample.inputs,
            enabled: drive_enabled,
            speeds,
            probe: input.probe,
            following_error: self.following_error_since.is_some_and(|since| {
                let time = u64::from(od.load(self.slots.following_error_time_out));
                now - since > Duration::from_millis(time)
            }),
            now,
            axis: self.axis,
        };
        #[cfg(feature = "hm")]
        let planner = self.planner.as_mut().filter(|_| self.mode.is_hm());
        #[cfg(not(feature = "hm"))]
        let planner: Option<&mut crate::motion::PositionPlanner> = None;
        let (position, outcome) = match planner {
            Some(planner) => self.homing.tick(planner, &inputs, limits.stop_deceleration(input.halt_kind)),
            None => (actual, hm::Outcome::default()),
        };
        if let Some(home) = outcome.home {
            let home_offset = i64::from(od.load(self.slots.home_offset));
            // 6064h reads −607Ch at home (CiA 402), or +607Ch ([`HomeOffset::HomeValue`]).
            let offset = factors.to_internal(home_offset * position_sign);
            self.origin = match self.config.homing.home_offset {
                HomeOffset::ZeroBeforeHome => home.saturating_add(offset),
                HomeOffset::HomeValue => home.saturating_sub(offset),
            };
            if self.config.homing.rebase_internal_position && self.homing.was_motionless() {
                self.internal_origin = self.origin;
            }
        }
        if outcome.error != self.homing_error || (inputs.start && self.homing_error) {
            self.homing_error = outcome.error;
            report.notices[1] = Some((hm::HOMING_ERROR, outcome.error));
        }
        if outcome.home.is_some() {
            // Limits a method found become 607Dh (compared after the 607Ch correction):
            // what 607Ch adds to a position value read as 6064h.
            let limit_offset = self.limit_offset(od);
            for (count, sub) in [(outcome.limits.0, 1u8), (outcome.limits.1, 2u8)] {
                if let Some(count) = count {
                    let user = (factors.to_user(count.saturating_sub(self.origin)) * position_sign)
                        .saturating_add(limit_offset);
                    let sub = if position_sign < 0 { 3 - sub } else { sub };
                    let _ = od.set::<i32>(self.axis.index(SOFTWARE_POSITION_LIMIT), sub, saturate_i32(user));
                }
            }
            // The position values of this tick count from the new zero already: the
            // statusword that says "homed" must not come before them.
            let actual_user = factors.to_user(actual.saturating_sub(self.origin)) * position_sign;
            od.store(self.slots.position_actual, saturate_i32(actual_user));
            homed = Some(actual_user);
            let internal = actual.wrapping_sub(self.internal_origin) as i32;
            od.store(self.slots.position_actual_internal, internal);
        }
        let setpoint = if drive_enabled { Setpoint::Position(position as i32) } else { Setpoint::None };
        (setpoint, homed)
    }

    /// One tick of profile position mode ([`pp`]); with its status bits.
    #[cfg(feature = "pp")]
    #[inline(never)]
    fn run_pp<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        input: &ModeInput<'_>,
    ) -> (Setpoint, pp::Status) {
        let ModeInput {
            now,
            sample,
            factors,
            controlword,
            actual,
            actual_user,
            standstill,
            limits,
            bit4_rose,
            ..
        } = *input;
        let position_sign = factors.position_sign();
        let (positive_blocked, negative_blocked) = self.blocked;
        let (pp_limits, end_velocity) = self.pp_limits(od, factors);
        // (Needed only by a new set-point.)
        let target_range =
            if bit4_rose { self.target_range(od, actual_user, sample.inputs, position_sign) } else { None };
        match (self.mode.pp_mut(), self.planner.as_mut()) {
            (Some(pp), Some(planner)) => {
                let moving = if positive_blocked || negative_blocked { planner.state().velocity } else { 0 };
                if (positive_blocked && moving > 0) || (negative_blocked && moving < 0) {
                    // Running into an active limit switch: stopped on the quick-stop ramp.
                    pp.stop(planner, limits.stop_deceleration(StopKind::QuickStopRamp), &pp_limits);
                }
                let inputs = pp::Inputs {
                    od,
                    factors,
                    slots: &self.slots,
                    controlword,
                    // Also in the tick of a mode change: a master that writes 6060h and then
                    // raises bit 4 may land both between two ticks (the edge was lost before).
                    new_setpoint: bit4_rose && input.operation && !input.entered_operation,
                    actual,
                    origin: self.origin,
                    target_range,
                    standstill,
                    now,
                    limits: pp_limits,
                    end_velocity,
                    velocity_cap: limits.velocity,
                };
                let state = pp.tick(planner, &inputs, limits.stop_deceleration(input.halt_kind));
                self.commanded = pp.heading_taken();
                let status = pp.status(planner, &inputs);
                (Setpoint::Position(state.position_demand()), status)
            }
            _ => (Setpoint::None, pp::Status::default()),
        }
    }

    /// One tick of velocity mode (CiA 402-2 §16; [`vl`]), also while a stop ramps it down.
    fn run_vl<const B: usize>(&mut self, od: &mut Dictionary<B>, input: &ModeInput<'_>) -> Setpoint {
        let drive = vl::DriveInputs {
            controlword: input.controlword,
            halt: input.halt_kind,
            velocity_limit: input.limits.velocity,
            actual_velocity: i64::from(input.sample.velocity),
            dt: input.dt,
            axis: self.axis,
        };
        let Some(vl) = self.mode.vl_mut() else { return Setpoint::None };
        let demand = vl.step(od, drive);
        self.velocity = Ramp { value: demand, remainder: 0 };
        Setpoint::Velocity(saturate_i32(demand))
    }

    /// The mode `number` becomes active: its variant starts from the axis at
    /// `actual` (increments; `user` in user units) and `velocity` (increments/s). Out of line:
    /// the variants are built here, not in the tick's stack frame.
    #[inline(never)]
    fn start_mode(&mut self, number: i8, actual: i64, user: i64, velocity: i64) {
        // pp's and hm's trajectory is the profile's planner, reset in place (built on the stack
        // of this tick, it would make it the deepest by 1.2 KiB).
        match number {
            #[cfg(feature = "pp")]
            mode::PROFILE_POSITION => self.mode = Active::Pp(ProfilePosition::new(&self.config)),
            #[cfg(feature = "hm")]
            mode::HOMING => self.mode = Active::Hm,
            _ => self.start_other_mode(number, actual, velocity),
        }
        // (Built by `configure`: a profile never configured runs pp and hm without motion.)
        #[cfg(any(feature = "pp", feature = "hm"))]
        if let Some(planner) = self.planner.as_mut().filter(|_| self.mode.plans()) {
            planner.reset(actual);
        }
        // pp's relative moves count from here.
        self.hold_mode(actual, user);
    }

    /// [`Self::start_mode`] for the modes other than pp and hm.
    fn start_other_mode(&mut self, number: i8, actual: i64, velocity: i64) {
        self.mode = match number {
            mode::PROFILE_VELOCITY => Active::Pv(pv::Run::start()),
            mode::PROFILE_TORQUE => Active::Tq,
            vl::MODE if super::VL => Active::Vl(vl::Vl::start(self.config.vl, velocity)),
            mode::INTERPOLATED_POSITION if super::IP => Active::Ip(super::ip::Run::start(actual)),
            mode::CYCLIC_POSITION | mode::CYCLIC_VELOCITY | mode::CYCLIC_TORQUE => {
                Active::Cyclic(super::cyclic::Run::start(number, actual, velocity))
            }
            _ => Active::Idle,
        };
    }

    /// Ticks per interpolation period (60C2h) and the SYNC jitter tolerated.
    fn cycle_timing<const B: usize>(&mut self, od: &Dictionary<B>) -> (u32, u32) {
        if let Some(kept) = self.timing.kept(od.configuration_revision()) {
            return kept;
        }
        let hz = u64::from(self.config.tick_rate.hz());
        let value = od.load_or(self.slots.interpolation_period_value, 1);
        let index = od.load_or(self.slots.interpolation_period_index, -3);
        let window_us: u32 = od.load(self.slots.sync_window);
        self.timing.get((value, index, window_us), od.configuration_revision(), || {
            let period_us = period_micros(value, index);
            let period_ticks = ((period_us * hz + 500_000) / 1_000_000).clamp(1, u64::from(u32::MAX)) as u32;
            let window_ticks = (u64::from(window_us) * hz / 1_000_000).min(u64::from(u32::MAX)) as u32;
            (period_ticks, window_ticks.max(period_ticks / 2))
        })
    }

    /// One tick of interpolated position mode (CiA 402-2 §13): while controlword bit 4 is 1 each
    /// SYNC takes the next data record (60C1h sub 1, a position) and the demand moves linearly
    /// to it over 60C2h; with bit 4 = 0 or an empty buffer it holds.
    #[inline(never)]
    fn run_ip<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        input: &ModeInput<'_>,
    ) -> (Setpoint, pp::Status) {
        let factors = input.factors;
        let (limits, halt_limits) = self.cyclic_limits(input);
        let active = input.controlword.contains(Controlword::ENABLE_IP) && !input.halt;
        let timing = if active { Some(self.cycle_timing(od)) } else { None };
        let record = if active && input.cycle.sync { self.ip.next() } else { None };
        if active && !self.ip.is_full() {
            self.ip_overflow = false;
        }
        let origin = self.origin;
        let hz = self.config.tick_rate.hz();
        let Some(run) = self.mode.ip_mut() else { return (Setpoint::None, pp::Status::default()) };
        if active && !run.active {
            run.interpolator.reset(run.limiter.position());
        }
        run.active = active;
        if input.halt && !run.limiter.is_stopping() {
            run.limiter.stop(&halt_limits);
        } else if !input.halt && run.limiter.is_stopping() {
            run.limiter.resume();
            run.interpolator.reset(run.limiter.position());
        }
        if let Some((period_ticks, tolerance_ticks)) = timing {
            let target = record.map_or(0, |r| {
                let user = i64::from(r[0]) * factors.position_sign();
                factors.to_internal(user).saturating_add(origin)
            });
            let cycle =
                Cycle { sync: input.cycle.sync, fresh: record.is_some(), period_ticks, tolerance_ticks };
            // Underflow holds the last point (no extrapolation, no stream-loss reaction).
            run.interpolator.tick(&cycle, target, Bridge::Hold);
        }
        let limited = run.limiter.tick_fixed(run.interpolator.value_fixed(), &limits);
        let velocity = run.limiter.velocity(hz);
        let status = pp::Status {
            // Bit 12: interpolation active.
            setpoint_acknowledge: run.active,
            target_reached: if input.halt {
                velocity == 0
            } else {
                self.ip.is_empty() && run.interpolator.step() == 0 && !limited
            },
            internal_limit: false,
        };
        let position = run.limiter.position();
        self.cyclic_limited = limited;
        self.feed_forward.velocity = saturate_i32(velocity);
        (Setpoint::Position(position as i32), status)
    }

    /// One tick of csp, csv or cst (CiA 402-2 §17–§19; [`super::cyclic`]).
    #[inline(never)]
    fn run_cyclic<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        input: &ModeInput<'_>,
        report: &mut Report,
    ) -> Setpoint {
        let factors = input.factors;
        let (limits, halt_limits) = self.cyclic_limits(input);
        let hz = self.config.tick_rate.hz();
        let (period_ticks, tolerance_ticks) = self.cycle_timing(od);
        let cycle = match self.config.cyclic.cycle_start {
            // A direct mode: the target at every tick.
            _ if self.display_mode != self.mode.number() => {
                Cycle { sync: true, fresh: true, period_ticks: 1, tolerance_ticks: u32::MAX }
            }
            CycleStart::Sync => {
                Cycle { sync: input.cycle.sync, fresh: input.cycle.fresh, period_ticks, tolerance_ticks }
            }
            // Never late: without a new set-point the last one holds.
            // A set-point written before the mode ran counts as arriving now.
            CycleStart::SetPoint => {
                let held = match &mut self.mode {
                    Active::Cyclic(run) => core::mem::take(&mut run.held_set_point),
                    _ => false,
                };
                let sync = input.cycle.set_point || held;
                Cycle { sync, fresh: true, period_ticks, tolerance_ticks: u32::MAX }
            }
        };
        let velocity_offset = factors.velocity_to_internal(i64::from(od.load(self.slots.velocity_offset)));
        let torque_offset = factors.torque_to_internal(od.load_int(self.slots.torque_offset));
        // The offsets reach the power stage as feed-forward: within the limits of the demand
        // (DESIGN invariant 2), as the set-point is.
        let max_torque = i64::from(od.load(self.slots.max_torque).min(od.load(self.slots.max_current)));
        let torque_feed_forward = torque_offset.clamp(-max_torque, max_torque) as i16;
        let bridge: Bridge = self.config.cyclic.bridge;
        let number = self.mode.number();
        let target = match number {
            mode::CYCLIC_POSITION => {
                let user = i64::from(od.load(self.slots.target_position))
                    + i64::from(od.load(self.slots.position_offset));
                factors.to_internal(user * factors.position_sign()).saturating_add(self.origin)
            }
            mode::CYCLIC_VELOCITY => factors.velocity_to_internal(
                i64::from(od.load(self.slots.target_velocity)) * factors.velocity_sign(),
            ),
            _ => factors.torque_to_internal(od.load_int(self.slots.target_torque)),
        };
        let Active::Cyclic(run) = &mut self.mode else { return Setpoint::None };
        let stream = run.interpolator.tick(&cycle, target, bridge);
        let lost = stream.missed > u32::from(self.config.cyclic.max_missed_cycles);
        if lost != self.stream_lost {
            self.stream_lost = lost;
            report.notices[1] = Some((STREAM_LOST, lost));
            if lost {
                // As a lost connection (6007h).
                match od.load(self.slots.abort_connection) {
                    1 => self.fault = self.fault.or(Some(STREAM_LOST)),
                    2 => self.forced = Some(DISABLE_VOLTAGE),
                    3 => self.forced = Some(QUICK_STOP),
                    _ => {}
                }
            }
        }
        let fixed = run.interpolator.value_fixed();
        let value = Interpolator::whole(fixed);
        match run.mode {
            mode::CYCLIC_POSITION => {
                if input.halt && !run.limiter.is_stopping() {
                    run.limiter.stop(&halt_limits);
                } else if !input.halt && run.limiter.is_stopping() {
                    run.limiter.resume();
                }
                self.cyclic_limited = run.limiter.tick_fixed(fixed, &limits);
                let trajectory = run.limiter.velocity(hz);
                // (A limit lowered below the running velocity: the limiter ramps down to it.)
                let bound = i64::from(self.motion.velocity).max(trajectory.abs());
                let velocity = trajectory.saturating_add(velocity_offset).clamp(-bound, bound);
                self.feed_forward =
                    FeedForward { velocity: saturate_i32(velocity), torque: torque_feed_forward };
                Setpoint::Position(run.limiter.position() as i32)
            }
            mode::CYCLIC_VELOCITY => {
                let limit = i64::from(self.motion.velocity);
                let wanted = value.saturating_add(velocity_offset);
                let clamped = wanted.clamp(-limit, limit);
                let speeding_up = clamped.abs() > self.velocity.value.abs();
                let rate = if speeding_up {
                    factors.limit_to_internal(od.load(self.slots.max_acceleration))
                } else {
                    factors.limit_to_internal(od.load(self.slots.max_deceleration))
                };
                self.velocity.toward(clamped, rate, input.dt);
                self.cyclic_limited = clamped != wanted || self.velocity.value != clamped;
                self.feed_forward.torque = torque_feed_forward;
                Setpoint::Velocity(saturate_i32(self.velocity.value))
            }
            _ => {
                let max = i64::from(od.load(self.slots.max_torque).min(od.load(self.slots.max_current)));
                let wanted = value.saturating_add(torque_offset);
                let clamped = wanted.clamp(-max, max);
                if input.halt {
                    self.torque.toward(0, od.load(self.slots.torque_slope), input.dt);
                    // A limit lowered while halting holds at once.
                    self.torque.value = self.torque.value.clamp(-max, max);
                } else {
                    self.torque = Ramp { value: clamped, remainder: 0 };
                }
                self.cyclic_limited = clamped != wanted;
                Setpoint::Torque(self.torque.value as i16)
            }
        }
    }

    /// Following error (CiA 402-2 §12.2): |6062h − 6064h| > 6065h for longer than 6066h ms.
    fn following_error<const B: usize>(&mut self, od: &Dictionary<B>, error: i64, now: Instant) -> bool {
        let window: u32 = od.load(self.slots.following_error_window);
        let off = window == u32::MAX || (window == 0 && self.config.zero_following_error_window_off);
        if off || error.unsigned_abs() <= u64::from(window) {
            self.following_error_since = None;
            return false;
        }
        let since = *self.following_error_since.get_or_insert(now);
        now - since > Duration::from_millis(u64::from(od.load(self.slots.following_error_time_out)))
    }

    /// One tick of pv, tq or no mode with the drive function enabled.
    #[inline(never)]
    fn run_mode<const B: usize>(&mut self, od: &Dictionary<B>, input: &ModeInput<'_>) -> Setpoint {
        let ModeInput { factors, dt, halt, .. } = *input;
        match self.mode {
            Active::Pv(_) => {
                let current = self.velocity.value;
                let aim = pv::Run::aim(od, &self.slots, factors, self.motion.velocity, self.blocked, current);
                self.commanded = aim.wanted.signum() as i8;
                self.velocity.toward(aim.velocity, aim.rate, dt);
                Setpoint::Velocity(self.velocity.value as i32)
            }
            Active::Tq => {
                let max = tq::torque_limit(od, &self.slots);
                let target = if halt { 0 } else { tq::target(od, &self.slots, factors) };
                self.torque.toward(target, od.load(self.slots.torque_slope), dt);
                // The slope (6087h) shapes changes of the target; a limit lowered below the
                // running torque holds at once (DESIGN invariant 2).
                self.torque.value = self.torque.value.clamp(-max, max);
                Setpoint::Torque(self.torque.value as i16)
            }
            // No mode (or one this build does not run): hold still.
            _ => {
                let deceleration =
                    od.load(self.slots.quick_stop_deceleration).min(od.load(self.slots.max_deceleration));
                self.velocity.toward(0, factors.limit_to_internal(deceleration), dt);
                Setpoint::Velocity(self.velocity.value as i32)
            }
        }
    }

    /// The statusword 6041h of this tick, built here only: the state bits, the common bits,
    /// the active mode's bits 10–13 and the manufacturer-specific bits 14 and 15.
    #[inline(never)]
    fn statusword<const B: usize>(
        &mut self,
        input: &StatusInput<'_>,
        od: &Dictionary<B>,
        now: Instant,
    ) -> Statusword {
        let state = input.state;
        let mut sw = state.statusword();
        sw.set(Statusword::VOLTAGE_ENABLED, state.high_voltage() && input.sample.dc_link_millivolts > 0);
        // Bit 7: a warning of the hardware, or in ip a record dropped with the buffer full.
        let overflow = matches!(self.mode, Active::Ip(_)) && self.ip_overflow;
        sw.set(
            Statusword::WARNING,
            self.config.warning_bit && (!input.sample.warnings.is_empty() || overflow),
        );
        // Bit 9 remote: the controlword is processed.
        sw.set(Statusword::REMOTE, !input.sample.local_control);

        // Bits 10 to 13: the active mode's (bit 10 in Operation enabled; homing's below).
        let at_rest = input.velocity_demand_internal == 0;
        let enabled = matches!(state, State::OperationEnabled { .. });
        // Halt in a velocity mode: the demand has stopped (and the shaft rests).
        let halted = input.halt && at_rest && input.standstill;
        let switch = self.blocked.0 || self.blocked.1;
        let pp = input.pp;
        let (reached, limited, bit_12, bit_13) = match &mut self.mode {
            #[cfg(feature = "pp")]
            Active::Pp(_) => {
                (pp.target_reached, pp.internal_limit || switch, pp.setpoint_acknowledge, input.following)
            }
            Active::Ip(_) if super::IP => {
                (pp.target_reached, pp.internal_limit, pp.setpoint_acknowledge, input.following)
            }
            Active::Cyclic(run) => {
                // Bit 12: the target is used (Operation enabled, no halt, the stream alive).
                let used = input.operation && !input.halt && !self.stream_lost && input.drive_enabled;
                (false, self.cyclic_limited, used, input.following && run.mode == mode::CYCLIC_POSITION)
            }
            Active::Vl(vl) if super::VL => (vl.target_reached(), vl.limit_active(), false, false),
            Active::Pv(run) => {
                let reached =
                    if input.halt { halted } else { enabled && run.target_reached(od, &self.slots, now) };
                let slipping = pv::Run::slipping(od, &self.slots, input.velocity_demand, input.velocity_user);
                (reached, switch, run.speed_is_zero(od, &self.slots, now), slipping)
            }
            Active::Tq => {
                let reached = if input.halt {
                    self.torque.value == 0
                } else {
                    self.torque.value == tq::target(od, &self.slots, input.factors)
                };
                (reached, false, false, false)
            }
            // Homing sets bits 10, 12 and 13 itself.
            #[cfg(feature = "hm")]
            Active::Hm => (false, false, false, false),
            _ => (halted, false, false, false),
        };
        let target_reached = match state {
            State::QuickStopActive => {
                at_rest && StopKind::quick_stop(input.quick_stop_option).is_some_and(|(_, stay)| stay)
            }
            _ => enabled && reached,
        };
        sw.set(Statusword::TARGET_REACHED, target_reached || core::mem::take(&mut self.mode_changed));
        sw.set(Statusword::INTERNAL_LIMIT_ACTIVE, limited);
        sw.set(Statusword::MODE_SPECIFIC_12, bit_12);
        sw.set(Statusword::MODE_SPECIFIC_13, bit_13);

        if self.mode.is_hm() {
            // Bits 10, 12, 13 are the homing status in every state (digest §10.4).
            let on_home = self.homing.run_ended() && self.rests_on_home(od, input.factors, input.actual, now);
            let homing = Statusword::TARGET_REACHED | Statusword::HOMING_ATTAINED | Statusword::HOMING_ERROR;
            let moving = self.planner().is_some_and(|planner| planner.state().velocity != 0);
            sw = sw.difference(homing) | self.homing.status(moving, on_home).statusword();
        }

        // Bits 14 and 15, as the configuration defines them.
        let transition = input.opening || (matches!(state, State::QuickStopActive) && !input.was_at_rest);
        // The shaft's motion: the velocity demand, or in the torque modes (no velocity demand)
        // the velocity actual beyond the threshold 606Fh.
        let motion = if input.drive_enabled && self.mode.is_torque() {
            let threshold = i64::from(od.load(self.slots.velocity_threshold));
            Some(i64::from(input.sample.velocity)).filter(|v| v.abs() > threshold).unwrap_or(0)
        } else {
            input.velocity_demand_internal
        };
        let manufacturer = [
            (Statusword::MANUFACTURER_14, self.config.statusword_bit_14),
            (Statusword::MANUFACTURER_15, self.config.statusword_bit_15),
        ];
        for (bit, flag) in manufacturer {
            let on = match flag {
                StatusFlag::Off => false,
                StatusFlag::Moving => motion != 0,
                StatusFlag::Negative => motion < 0,
                StatusFlag::Transition => transition,
            };
            sw.set(bit, on);
        }
        sw
    }
}

/// What the tick's command phase keeps while it stands: the option codes until they may have
/// been written ([`Runtime::read_option_codes`]), the FSA's last step while its inputs stand
/// ([`Runtime::step_fsa`]).
#[derive(Clone, Copy, Debug)]
struct Steady {
    /// The option codes below are kept (false: to be read).
    codes_kept: bool,
    /// 605Ah, 605Bh, 605Ch, 605Eh.
    options: Options,
    /// 605Dh.
    halt_option: Option<StopKind>,
    /// The inputs of [`Self::step`] (command, fault present, stop at rest) where that step left
    /// the FSA as it found it, under the kept option codes: the same inputs give the same step
    /// again.
    fixed: Option<(Option<Controlword>, bool, bool)>,
    /// The FSA's last step.
    step: Step,
}

impl Steady {
    const NONE: Self = Steady {
        codes_kept: false,
        options: Options {
            quick_stop: 0,
            shutdown: 0,
            disable_operation: 0,
            fault_reaction: 0,
            transition_16: false,
        },
        halt_option: None,
        fixed: None,
        step: Step {
            state: State::NotReadyToSwitchOn,
            entered_operation: false,
            stop: None,
            dynamic_brake: false,
        },
    };
}

/// What the statusword of a tick is built from ([`Runtime::statusword`]), besides the
/// profile's own state.
struct StatusInput<'a> {
    state: State,
    sample: &'a Sample,
    /// 605Ah.
    quick_stop_option: i16,
    /// The bits pp or ip reported in this tick.
    pp: pp::Status,
    halt: bool,
    /// The shaft rests (for a halt's target reached).
    standstill: bool,
    /// Operation enabled, no ramped exit running.
    operation: bool,
    drive_enabled: bool,
    /// The following error is beyond its window for longer than its time.
    following: bool,
    /// The velocity demand of this tick (increments/s).
    velocity_demand_internal: i64,
    /// 606Bh and 606Ch of this tick (user units).
    velocity_demand: i64,
    velocity_user: i64,
    /// The brake is opening.
    opening: bool,
    /// The velocity demand was 0 at the start of the tick.
    was_at_rest: bool,
    factors: &'a Factors,
    /// The encoder count.
    actual: i64,
}

/// What the tick's first phase ([`Runtime::sense`]) read from the sample.
struct Sensed {
    /// The encoder count.
    actual: i64,
    /// 6064h (homing may set it anew in the mode's step).
    actual_user: i64,
    /// 606Ch.
    velocity_user: i64,
    /// The shaft rests as a halt and homing's completion need it.
    standstill: bool,
    /// Probe 1's latch of this tick (increments).
    probe: Option<i64>,
    /// A touch probe latched or changed its status in this tick.
    probe_changed: bool,
    /// The hardware fault of the sample, if any.
    hardware: Option<(u16, ErrorRegister)>,
}

/// What the tick's second phase ([`Runtime::command`]) decided.
#[derive(Clone, Copy)]
struct Command {
    /// 605Ah.
    quick_stop_option: i16,
    /// The controlword as the modes see it.
    controlword: Controlword,
    /// Controlword bit 4 rose since the last tick.
    bit4_rose: bool,
    /// The state before the tick.
    before: State,
    /// The velocity demand at the start of the tick, and whether it was 0.
    previous_velocity: i64,
    at_rest: bool,
    step: Step,
    /// The drive function is enabled.
    enabled: bool,
    /// The mode of operation changed in this tick.
    switched: bool,
    /// Controlword bit 8.
    halt: bool,
    /// Operation enabled, no ramped exit running.
    operation: bool,
    /// The stop a halt makes (605Dh).
    halt_kind: StopKind,
    /// The stop the tick makes, if any.
    stop: Option<StopKind>,
    /// The motion limits in increments.
    limits: MotionLimits,
}

/// What the tick's third phase ([`Runtime::step_mode`]) produced.
struct Stepped {
    setpoint: Setpoint,
    /// The bits pp or ip reported.
    status: pp::Status,
    /// The drive function stays enabled (a coasting stop disables it).
    drive_enabled: bool,
    /// The brake is opening.
    opening: bool,
}

/// The tick's inputs as the active mode's step sees them ([`Runtime::run_active`],
/// [`Runtime::step_stop`], [`Runtime::run_homing`]).
#[derive(Clone, Copy)]
struct ModeInput<'a> {
    now: Instant,
    dt: Duration,
    sample: &'a Sample,
    factors: &'a Factors,
    controlword: Controlword,
    cycle: SyncInput,
    /// Controlword bit 8.
    halt: bool,
    /// The stop a halt makes (605Dh).
    halt_kind: StopKind,
    /// Controlword bit 4 rose since the last tick (once the brake is open).
    bit4_rose: bool,
    /// Operation enabled, no ramped exit running.
    #[cfg_attr(not(feature = "pp"), allow(dead_code))]
    operation: bool,
    /// This tick entered Operation enabled.
    entered_operation: bool,
    /// The drive function is enabled.
    enabled: bool,
    /// The encoder count, and 6064h.
    actual: i64,
    #[cfg_attr(not(feature = "pp"), allow(dead_code))]
    actual_user: i64,
    /// The shaft rests as a halt needs it.
    #[cfg_attr(not(feature = "pp"), allow(dead_code))]
    standstill: bool,
    /// Probe 1's latch of this tick (increments).
    probe: Option<i64>,
    /// The motion limits in increments.
    limits: MotionLimits,
}

/// 60C2h as µs: `value × 10^index` s, at least 1 µs, at most an hour.
fn period_micros(value: u8, index: i8) -> u64 {
    let mut micros = u64::from(value);
    let exponent = i32::from(index) + 6;
    for _ in 0..exponent.clamp(0, 12) {
        micros = micros.saturating_mul(10);
    }
    for _ in 0..(-exponent).clamp(0, 12) {
        micros /= 10;
    }
    micros.clamp(1, 3_600_000_000)
}

/// While in Fault, the fault counts as present only while the hardware still reports it (so a
/// fault reset can succeed once the cause is gone); before, any latched fault counts.
fn before_fault_cleared(state: State, hardware: Option<(u16, ErrorRegister)>) -> bool {
    matches!(state, State::Fault) && hardware.is_none()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_reaches_its_target_without_drift() {
        let mut r = Ramp::default();
        // 1000 units/s in 333 µs steps: exactly 1000 after 1 s worth of steps (rounded up).
        let mut ticks = 0;
        while r.value != 1000 {
            r.toward(1000, 1000, Duration::from_micros(333));
            ticks += 1;
            assert!(ticks < 10_000);
        }
        assert_eq!(ticks, 3004);
        r.toward(-5, 2_000_000, Duration::from_millis(1));
        assert_eq!(r.value, -5);
    }
}

/// Halt's statusword bit 10 with `ProfileConfig::halt_reached_at_standstill`.
#[cfg(all(test, feature = "pp"))]
mod standstill_tests {
    use super::*;
    use crate::cia402::registry::PROFILE;
    use crate::od::DeviceInfo;

    fn tick(profile: &mut Profile, od: &mut Dictionary<4096>, ms: u64, velocity: i32) -> u16 {
        let sample = Sample { dc_link_millivolts: 48_000, velocity, ..Sample::default() };
        profile.tick(Instant::from_millis(ms), &sample, od, SyncInput::default());
        profile.plan_ahead();
        od.get::<u16>(STATUSWORD, 0).unwrap_or(0)
    }

    /// A shaft that passes through 0 (606Ch 0 on one tick of its settling) does not rest: bit
    /// 10 comes once 606Ch ≤ 606Fh has held for longer than 6070h.
    #[test]
    fn a_shaft_passing_through_zero_does_not_rest() {
        for threshold_time in [0u16, 3] {
            let mut od = Dictionary::<4096>::new(&[&PROFILE], DeviceInfo::servo_drive(), 1).unwrap();
            let config = ProfileConfig { halt_reached_at_standstill: true, ..ProfileConfig::default() };
            let mut profile = Profile::new(config);
            profile.configure(&od);
            od.set::<i8>(MODES_OF_OPERATION, 0, 1).unwrap();
            od.set::<u16>(VELOCITY_THRESHOLD_TIME, 0, threshold_time).unwrap();
            tick(&mut profile, &mut od, 0, 0);
            for (ms, controlword) in [(1, 0x06), (2, 0x07), (3, 0x0F)] {
                od.set::<u16>(CONTROLWORD, 0, controlword).unwrap();
                tick(&mut profile, &mut od, ms, 0);
            }
            // Halt, the demand at rest; the shaft still settles.
            od.set::<u16>(CONTROLWORD, 0, 0x010F).unwrap();
            let mut ms = 4;
            for velocity in [40, 0, -25, 0, -3] {
                let statusword = tick(&mut profile, &mut od, ms, velocity);
                assert_eq!(statusword & 0x0400, 0, "606Ch {velocity} at {ms} ms: not resting");
                ms += 1;
            }
            // At rest from `ms` on: bit 10 once the rest has lasted longer than 6070h.
            let rest = ms;
            loop {
                let statusword = tick(&mut profile, &mut od, ms, 0);
                let rested = ms - rest > u64::from(threshold_time);
                assert_eq!(statusword & 0x0400 != 0, rested, "{ms} ms, 6070h = {threshold_time}");
                if rested {
                    break;
                }
                ms += 1;
            }
        }
    }
}

/// A profile of another axis than the first runs the same description shifted by n × 800h.
#[cfg(test)]
mod axis_tests {
    use super::*;
    use crate::cia402::registry::{PROFILE, PROFILE_LEN};
    use crate::od::{DeviceInfo, Object};

    const SECOND: Axis = match Axis::new(1) {
        Some(axis) => axis,
        None => Axis::FIRST,
    };

    const fn shifted<const N: usize>(table: &[Object; N], axis: Axis) -> [Object; N] {
        let mut out = *table;
        let mut k = 0;
        while k < N {
            out[k].index = axis.index(out[k].index);
            k += 1;
        }
        out
    }

    /// The profile objects of the second axis only (6800h–6FFFh): nothing at 6000h–67FFh.
    static SECOND_AXIS: [Object; PROFILE_LEN] = shifted(&PROFILE, SECOND);

    fn tick(profile: &mut Profile, od: &mut Dictionary<4096>, ms: u64) -> Demand {
        let sample = Sample { dc_link_millivolts: 48_000, ..Sample::default() };
        let demand = profile.tick(Instant::from_millis(ms), &sample, od, SyncInput::default()).0;
        profile.plan_ahead();
        demand
    }

    #[test]
    fn axis_numbers_and_indices() {
        assert_eq!(Axis::new(7).map(Axis::number), Some(7));
        assert_eq!(Axis::new(8), None);
        assert_eq!(SECOND.index(CONTROLWORD), 0x6840);
        assert_eq!(Axis::new(7).map(|a| a.index(0x67FF)), Some(0x9FFF));
        assert_eq!(SECOND.index(0x1007), 0x1007, "communication objects are the node's");
        assert_eq!(SECOND.index(0x2000), 0x2000, "manufacturer objects are the firmware's");
        assert_eq!(SECOND.relative(0x6841), Some(STATUSWORD));
        assert_eq!(SECOND.relative(0x6041), None);
        assert_eq!(SECOND.relative(0x7000), None);
        assert_eq!(Axis::FIRST.relative(0x67FF), Some(0x67FF));
        assert_eq!(Axis::FIRST.relative(0x6800), None);
        assert_eq!(Axis::containing(0x6041), Some(Axis::FIRST));
        assert_eq!(Axis::containing(0x6841), Some(SECOND));
        assert_eq!(Axis::containing(0x9FFF).map(Axis::number), Some(7));
        assert_eq!(Axis::containing(0x5FFF), None);
        assert_eq!(Axis::containing(0xA000), None);
    }

    #[test]
    #[cfg(feature = "ip")]
    fn the_second_axis_has_its_own_ip_buffer() {
        let mut od = Dictionary::<4096>::new(&[&SECOND_AXIS], DeviceInfo::servo_drive(), 1).unwrap();
        let mut buffer = IpBuffer::for_axis(SECOND);
        buffer.reload(&od);
        od.set::<i32>(0x68C1, 1, 1234).unwrap();
        assert_eq!(buffer.written(&mut od, 0x60C1, 1), Written::Ignored, "the first axis's record");
        assert_eq!(buffer.written(&mut od, 0x68C1, 1), Written::Stored);
        assert_eq!(buffer.next().map(|record| record[0]), Some(1234));
        let size = [0u8, 0, 0, 0];
        assert_eq!(
            super::super::ip::check_write(&od, &buffer, 0x68C4, 5, &size),
            Err(AbortCode::ValueTooLow),
            "68C4h.5 = 0 is refused as 60C4h.5 = 0 is"
        );
    }

    #[test]
    fn the_second_axis_runs_its_own_objects() {
        let mut od = Dictionary::<4096>::new(&[&SECOND_AXIS], DeviceInfo::servo_drive(), 1).unwrap();
        let mut profile = Profile::for_axis(ProfileConfig::default(), SECOND);
        profile.configure(&od);
        assert_eq!(profile.axis(), SECOND);
        assert_eq!(tick(&mut profile, &mut od, 0), Demand::OFF);
        assert_eq!(od.get::<u16>(0x6841, 0).map(|sw| sw & 0x6F), Ok(0x40), "Switch on disabled");
        assert_eq!(od.get::<u16>(STATUSWORD, 0), Err(AbortCode::ObjectDoesNotExist));

        // The rules of 6060h, at 6860h: pv is a mode of 6502h (at 6D02h); 77 is none.
        let rule = profile.rule(0x6860, 0, false);
        assert_eq!(rule, Some(Rule::Mode));
        assert_eq!(rule.map(|r| profile.check(r, &od, 0x6860, 0, &[77])), Some(Err(AbortCode::InvalidValue)));
        assert_eq!(rule.map(|r| profile.check(r, &od, 0x6860, 0, &[3])), Some(Ok(())));
        assert_eq!(profile.rule(MODES_OF_OPERATION, 0, false), None, "the first axis's 6060h is not its own");

        od.set::<i8>(0x6860, 0, 3).unwrap();
        od.set::<u32>(0x6883, 0, 100_000).unwrap();
        od.set::<i32>(0x68FF, 0, 5_000).unwrap();
        for (ms, controlword, state) in [(1, 0x06, 0x21), (2, 0x07, 0x23), (3, 0x0F, 0x27)] {
            od.set::<u16>(0x6840, 0, controlword).unwrap();
            tick(&mut profile, &mut od, ms);
            assert_eq!(od.get::<u16>(0x6841, 0).map(|sw| sw & 0x6F), Ok(state), "{controlword:#x}");
        }
        assert_eq!(od.get::<i8>(0x6861, 0), Ok(3));
        // pv ramps at 6883h = 100 000 increments/s² from the enabling tick (3 ms) on: 100
        // increments/s per 1 ms tick, reported in 686Bh.
        for ms in 4..14 {
            let demand = tick(&mut profile, &mut od, ms);
            let expected = 100 * (ms as i32 - 2);
            assert!(demand.drive_enabled);
            assert_eq!(demand.setpoint, Setpoint::Velocity(expected), "{ms} ms");
            assert_eq!(od.get::<i32>(0x686B, 0), Ok(expected), "606Bh of the second axis");
        }
    }
}
