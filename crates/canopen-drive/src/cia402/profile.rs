//! The drive profile at run time: one [`Profile::tick`] per control-loop tick reads the
//! controlword and the feedback, runs the [`Fsa`], the active mode and the stop ramps, writes
//! the statusword and the actual values, and returns the [`Demand`] for the power stage.
//!
//! Modes in this build: profile velocity (pv, 3) and profile torque (tq, 4); 6502h says so.
//!
//! Stops (digest §6): the slow-down ramp uses 6084h, the quick-stop ramp 6085h; "current limit"
//! and "voltage limit" stops are run as a ramp with the maximum deceleration 60C6h (this build
//! has no current or voltage loop of its own). A stop starts from the actual velocity and is
//! done when the velocity demand reaches 0.
//!
//! Hardware faults become the CiA 402 error codes 2310h (over-current), 3210h (DC link
//! over-voltage), 3220h (DC link under-voltage), 4310h (drive over-temperature) and 7305h
//! (incremental sensor fault): EMCY, 603Fh, transition 13. A fault reset is accepted once the
//! hardware reports the cause gone.
//!
//! Arithmetic: velocities are integers in increments/s, ramps advance by `deceleration × dt`
//! computed in i64 µs arithmetic with the remainder carried, so a ramp does not drift.

use super::fsa::{Fsa, Options, State, StopKind};
use super::objects::*;
use crate::comm::emcy::ErrorRegister;
use crate::drive::ConnectionEvent;
use crate::hal::{Demand, HardwareFaults, Sample, Setpoint};
use crate::od::Dictionary;
use crate::time::{Duration, Instant};

/// The longest time step a tick integrates (a stalled board must not cause a jump).
const MAX_STEP: Duration = Duration::from_millis(100);

/// What the profile asks the drive to report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Report {
    /// An error to raise (EMCY, 1003h): code and register bits.
    pub raise: Option<(u16, ErrorRegister)>,
    /// An error to clear.
    pub clear: Option<u16>,
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
        let step = budget / 1_000_000;
        self.remainder = budget % 1_000_000;
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
#[derive(Clone, Debug, Default)]
pub struct Profile {
    fsa: Fsa,
    active_mode: i8,
    velocity: Ramp,
    torque: Ramp,
    last_tick: Option<Instant>,
    fault: Option<u16>,
    stopping: bool,
    mode_changed: bool,
    in_window_since: Option<Instant>,
    above_threshold_since: Option<Instant>,
    last_target_velocity: i32,
    forced: Option<u16>,
}

fn fault_code(faults: HardwareFaults) -> Option<(u16, ErrorRegister)> {
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

fn get<const B: usize, T: crate::od::Scalar + Default>(od: &Dictionary<B>, index: u16) -> T {
    od.get::<T>(index, 0).unwrap_or_default()
}

impl Profile {
    /// The FSA state.
    pub fn state(&self) -> State {
        self.fsa.state()
    }

    /// Back to power-on (reset application).
    pub fn reset(&mut self) {
        *self = Profile::default();
    }

    /// A connection loss, reacted to as 6007h says at the next tick. The reaction applies while
    /// the drive function is enabled (an idle axis has nothing to stop, and faulting it would
    /// make every NMT reset leave the drive in Fault).
    pub fn connection_lost<const B: usize>(&mut self, event: ConnectionEvent, od: &Dictionary<B>) {
        let _ = event;
        if !self.fsa.state().drive_function_enabled() {
            return;
        }
        match get::<B, i16>(od, ABORT_CONNECTION_OPTION_CODE) {
            1 => self.fault = self.fault.or(Some(0x8100)),
            2 => self.forced = Some(0x0000),
            3 => self.forced = Some(0x0002),
            _ => {}
        }
    }

    /// One control tick.
    pub fn tick<const B: usize>(
        &mut self,
        now: Instant,
        sample: &Sample,
        od: &mut Dictionary<B>,
    ) -> (Demand, Report) {
        let dt = self.last_tick.map_or(Duration::ZERO, |t| (now - t).min(MAX_STEP));
        self.last_tick = Some(now);
        let mut report = Report::default();

        // Actual values.
        let _ = od.set::<i32>(POSITION_ACTUAL_VALUE, 0, sample.position);
        let _ = od.set::<i32>(VELOCITY_ACTUAL_VALUE, 0, sample.velocity);
        let _ = od.set::<i16>(TORQUE_ACTUAL_VALUE, 0, sample.torque);
        let _ = od.set::<u32>(DC_LINK_VOLTAGE, 0, sample.dc_link_millivolts);
        // 60FDh bits 0..3: negative/positive limit, home, interlock (the hal uses the same bits).
        let _ = od.set::<u32>(DIGITAL_INPUTS, 0, sample.inputs.bits() & 0x0F);

        // Faults: a new one is latched and reported; it stays until a fault reset succeeds.
        let hardware = fault_code(sample.faults);
        if self.fault.is_none() {
            if let Some((code, register)) = hardware {
                self.fault = Some(code);
                report.raise = Some((code, register));
            }
        }
        if let Some(code) = self.fault {
            let _ = od.set::<u16>(ERROR_CODE, 0, code);
        }

        let options = Options {
            quick_stop: get(od, QUICK_STOP_OPTION_CODE),
            shutdown: get(od, SHUTDOWN_OPTION_CODE),
            disable_operation: get(od, DISABLE_OPERATION_OPTION_CODE),
            fault_reaction: get(od, FAULT_REACTION_OPTION_CODE),
            transition_16: true,
        };
        let controlword: u16 = get(od, CONTROLWORD);
        let commanded = self.forced.take().unwrap_or(controlword);
        let before = self.fsa.state();
        let at_rest = self.velocity.value == 0;
        let step = self.fsa.step(
            Some(commanded),
            self.fault.is_some() && !before_fault_cleared(before, hardware),
            at_rest,
            &options,
        );
        if matches!(before, State::Fault) && !matches!(step.state, State::Fault) {
            // Transition 15: the fault is gone.
            if let Some(code) = self.fault.take() {
                report.clear = Some(code);
            }
        }

        // Mode switching: at once while the drive function is disabled, at rest otherwise.
        let requested: i8 = get(od, MODES_OF_OPERATION);
        if requested != self.active_mode && (!step.state.drive_function_enabled() || self.velocity.value == 0)
        {
            self.active_mode = requested;
            self.mode_changed = true;
        }
        let _ = od.set::<i8>(MODES_OF_OPERATION_DISPLAY, 0, self.active_mode);

        let halt = controlword & 0x0100 != 0;
        if step.entered_operation {
            // Transition 4 clears the internal set-points.
            self.velocity = Ramp { value: i64::from(sample.velocity), remainder: 0 };
            self.torque = Ramp::default();
        }
        let stop = step.stop.or_else(|| {
            (halt && matches!(step.state, State::OperationEnabled { .. }))
                .then(|| StopKind::halt_or_fault(get(od, HALT_OPTION_CODE)))
                .flatten()
        });
        if stop.is_some() && !self.stopping {
            self.velocity = Ramp { value: i64::from(sample.velocity), remainder: 0 };
        }
        self.stopping = stop.is_some();

        let mut drive_enabled = step.state.drive_function_enabled();
        let setpoint = match stop {
            Some(StopKind::Coast) => {
                drive_enabled = false;
                self.velocity = Ramp::default();
                Setpoint::None
            }
            Some(kind) => {
                let deceleration = match kind {
                    StopKind::SlowDown => get::<B, u32>(od, PROFILE_DECELERATION),
                    StopKind::QuickStopRamp => get(od, QUICK_STOP_DECELERATION),
                    StopKind::CurrentLimit | StopKind::VoltageLimit | StopKind::Coast => {
                        get(od, MAX_DECELERATION)
                    }
                };
                self.velocity.toward(0, deceleration, dt);
                Setpoint::Velocity(self.velocity.value as i32)
            }
            None if drive_enabled => self.run_mode(od, dt),
            None => {
                self.velocity = Ramp::default();
                self.torque = Ramp::default();
                Setpoint::None
            }
        };
        let _ = od.set::<i32>(VELOCITY_DEMAND_VALUE, 0, self.velocity.value as i32);
        let _ = od.set::<i16>(TORQUE_DEMAND, 0, self.torque.value as i16);

        let statusword = self.statusword(step.state, sample, od, now, halt, options);
        let _ = od.set::<u16>(STATUSWORD, 0, statusword);
        // 60FEh: a master may engage the brake (sub 1 bit 0) where the mask (sub 2) enables it.
        let outputs =
            od.get::<u32>(DIGITAL_OUTPUTS, 1).unwrap_or(0) & od.get::<u32>(DIGITAL_OUTPUTS, 2).unwrap_or(0);
        let demand = Demand {
            high_voltage: step.state.high_voltage(),
            drive_enabled,
            brake_released: drive_enabled && outputs & 1 == 0,
            setpoint: if drive_enabled { setpoint } else { Setpoint::None },
        };
        (demand, report)
    }

    fn run_mode<const B: usize>(&mut self, od: &Dictionary<B>, dt: Duration) -> Setpoint {
        match self.active_mode {
            mode::PROFILE_VELOCITY => {
                let target: i32 = get(od, TARGET_VELOCITY);
                let current = self.velocity.value;
                // Accelerating away from zero uses 6083h, approaching zero 6084h.
                let accelerating = (i64::from(target) - current).signum() == current.signum() || current == 0;
                let rate = if accelerating {
                    get::<B, u32>(od, PROFILE_ACCELERATION)
                } else {
                    get(od, PROFILE_DECELERATION)
                };
                self.velocity.toward(i64::from(target), rate, dt);
                Setpoint::Velocity(self.velocity.value as i32)
            }
            mode::PROFILE_TORQUE => {
                let max = i64::from(get::<B, u16>(od, MAX_TORQUE));
                let target = i64::from(get::<B, i16>(od, TARGET_TORQUE)).clamp(-max, max);
                self.torque.toward(target, get(od, TORQUE_SLOPE), dt);
                Setpoint::Torque(self.torque.value as i16)
            }
            // No mode (or one this build does not run): hold still.
            _ => {
                self.velocity.toward(0, get(od, QUICK_STOP_DECELERATION), dt);
                Setpoint::Velocity(self.velocity.value as i32)
            }
        }
    }

    fn statusword<const B: usize>(
        &mut self,
        state: State,
        sample: &Sample,
        od: &Dictionary<B>,
        now: Instant,
        halt: bool,
        options: Options,
    ) -> u16 {
        let mut sw = state.statusword_bits();
        if state.high_voltage() && sample.dc_link_millivolts > 0 {
            sw |= 1 << 4;
        }
        // Bit 9 remote: the controlword is processed.
        sw |= 1 << 9;
        let at_rest = self.velocity.value == 0;
        let target_reached = match state {
            State::QuickStopActive => {
                at_rest && StopKind::quick_stop(options.quick_stop).is_some_and(|(_, stay)| stay)
            }
            State::OperationEnabled { .. } if halt => at_rest,
            State::OperationEnabled { .. } => self.mode_target_reached(od, now),
            _ => false,
        };
        if target_reached || core::mem::take(&mut self.mode_changed) {
            sw |= 1 << 10;
        }
        if self.active_mode == mode::PROFILE_VELOCITY && self.speed_is_zero(od, sample, now) {
            sw |= 1 << 12;
        }
        sw
    }

    fn mode_target_reached<const B: usize>(&mut self, od: &Dictionary<B>, now: Instant) -> bool {
        match self.active_mode {
            mode::PROFILE_VELOCITY => {
                let target: i32 = get(od, TARGET_VELOCITY);
                if target != self.last_target_velocity {
                    self.last_target_velocity = target;
                    self.in_window_since = None;
                }
                let actual: i32 = get(od, VELOCITY_ACTUAL_VALUE);
                let window = i64::from(get::<B, u16>(od, VELOCITY_WINDOW));
                if (i64::from(target) - i64::from(actual)).abs() <= window {
                    let since = *self.in_window_since.get_or_insert(now);
                    let time = Duration::from_millis(u64::from(get::<B, u16>(od, VELOCITY_WINDOW_TIME)));
                    now - since >= time
                } else {
                    self.in_window_since = None;
                    false
                }
            }
            mode::PROFILE_TORQUE => self.torque.value == i64::from(get::<B, i16>(od, TARGET_TORQUE)),
            _ => false,
        }
    }

    fn speed_is_zero<const B: usize>(&mut self, od: &Dictionary<B>, sample: &Sample, now: Instant) -> bool {
        let threshold = i64::from(get::<B, u16>(od, VELOCITY_THRESHOLD));
        if i64::from(sample.velocity).abs() <= threshold {
            self.above_threshold_since = None;
            return true;
        }
        let since = *self.above_threshold_since.get_or_insert(now);
        now - since <= Duration::from_millis(u64::from(get::<B, u16>(od, VELOCITY_THRESHOLD_TIME)))
    }
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
