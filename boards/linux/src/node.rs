//! The drive of this board: its configuration, its EDS, and the real-time loop that runs it.
//!
//! ## The loop
//!
//! One thread owns the [`Drive`] and the simulated motor. It waits on the bus ([`Bus::receive`])
//! until the earliest of: a frame arrives, the drive's own deadline (`poll`), the next control
//! tick. So an SDO request is answered as soon as it arrives, not at the next tick.
//!
//! - every received frame goes to `on_frame`, and the frames it causes go out at once;
//! - `poll` runs after every wake-up and whenever its deadline has come;
//! - `tick` runs at 1 kHz: sample the motor, tick, hand the demand to the motor for the time
//!   that passed since the previous tick.
//!
//! Time is a monotonic clock in µs since the start of the process.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration as StdDuration;

use std::path::Path;

use canopen_drive::comm::program::ProgramRequest;
use canopen_drive::drive::ConnectionEvent;
use canopen_drive::hal::Sample;
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::storage::{device_signature, Persistence, Storage};
use canopen_drive::{Config, Drive, Duration, Instant};
use canopen_drive_sim::flash::{FileFlash, SimFlash};
use canopen_drive_sim::motor::SimMotor;

use crate::board_objects::{BoardHooks, Change};
use crate::bus::Bus;
use crate::monitor::{Direction, Monitor};
use crate::profiles::{Action, BoardProfile, Environment, Firmware, Update, OD_BYTES};
use crate::trace::Trace;

/// The drive of this board, with parameter storage `S` (a file, or none), `PDOS` + `PDOS` PDOs
/// and `AXES` axes ([`crate::axes`]).
pub type BoardDrive<S, const PDOS: usize = 4, const AXES: usize = 1> =
    Drive<BoardHooks, OD_BYTES, PDOS, PDOS, S, AXES>;

/// Layout number of the stored parameters (part of the storage signature): change it when a
/// firmware change gives stored parameters another meaning.
pub const STORAGE_LAYOUT: u16 = 1;

/// Period of the control loop (`tick`).
pub const TICK_PERIOD: Duration = Duration::from_micros(1000);

/// The configuration of `profile`'s drive at `node_id` whose 1021h serves its own EDS, and
/// that EDS; `storage`: the drive keeps parameters (`--storage`), which its EDS states in
/// 1010h/1011h.
///
/// The EDS text does not depend on what 1021h holds, so the EDS of a first drive without it is
/// the EDS of the final one. The text lives as long as the process (`Box::leak`), as 1021h
/// needs a `'static` slice.
pub fn config_with_eds(
    profile: &BoardProfile,
    node_id: u8,
    storage: bool,
) -> Result<(Config, &'static [u8]), String> {
    let mut config = profile.config(node_id);
    let eds: &'static [u8] = Box::leak(eds(profile, node_id, storage)?.into_boxed_str()).as_bytes();
    config.device.eds = eds;
    Ok((config, eds))
}

/// The EDS (CiA 306) of `profile`'s drive at `node_id`, with parameter storage or without.
pub fn eds(profile: &BoardProfile, node_id: u8, storage: bool) -> Result<String, String> {
    describe(profile, node_id, storage, |drive, w| drive.write_eds(&profile.eds, w))
        .map_err(|e| format!("cannot generate the EDS: {e}"))
}

/// The XDD (CiA 311) of `profile`'s drive at `node_id`, with parameter storage or without: the
/// EDS's objects and facts as XML.
pub fn xdd(profile: &BoardProfile, node_id: u8, storage: bool) -> Result<String, String> {
    describe(profile, node_id, storage, |drive, w| drive.write_xdd(&profile.eds, w))
        .map_err(|e| format!("cannot generate the XDD: {e}"))
}

/// What `write` writes of `profile`'s drive at `node_id` (a device description), with parameter
/// storage or without.
fn describe(
    profile: &BoardProfile,
    node_id: u8,
    storage: bool,
    write: impl Fn(&dyn Describe, &mut String) -> std::fmt::Result,
) -> Result<String, String> {
    crate::axes::with_axes!(profile.axes, describe_axes(profile, node_id, storage, &write))
}

/// [`describe`] for a node of `AXES` axes with `PDOS` + `PDOS` PDOs.
fn describe_axes<const PDOS: usize, const AXES: usize>(
    profile: &BoardProfile,
    node_id: u8,
    storage: bool,
    write: &impl Fn(&dyn Describe, &mut String) -> std::fmt::Result,
) -> Result<String, String> {
    let config = profile.config(node_id);
    let invalid = |e| format!("invalid drive configuration: {e:?}");
    let mut text = String::new();
    if storage {
        // An erased flash of the file's geometry stands in for the file: only whether the drive
        // stores parameters shows in a description.
        let flash = SimFlash::new(
            FileFlash::DEFAULT_CAPACITY,
            FileFlash::DEFAULT_ERASE_SIZE,
            FileFlash::DEFAULT_WRITE_SIZE,
        );
        let storage = Storage::new(flash, device_signature(&config.device, STORAGE_LAYOUT))
            .map_err(|e| format!("storage: {e:?}"))?;
        let drive =
            BoardDrive::<_, PDOS, AXES>::build(config, profile.hooks(true), storage).map_err(invalid)?;
        write(&drive, &mut text)
    } else {
        let drive = BoardDrive::<(), PDOS, AXES>::build(config, profile.hooks(false), ()).map_err(invalid)?;
        write(&drive, &mut text)
    }
    .map_err(|_| "the text could not be written".to_string())?;
    Ok(text)
}

/// A drive of this board with any storage, as far as its descriptions go.
trait Describe {
    fn write_eds(&self, info: &EdsInfo, w: &mut String) -> std::fmt::Result;
    fn write_xdd(&self, info: &EdsInfo, w: &mut String) -> std::fmt::Result;
}

impl<S: Persistence, const PDOS: usize, const AXES: usize> Describe for BoardDrive<S, PDOS, AXES> {
    fn write_eds(&self, info: &EdsInfo, w: &mut String) -> std::fmt::Result {
        Drive::write_eds(self, info, w)
    }
    fn write_xdd(&self, info: &EdsInfo, w: &mut String) -> std::fmt::Result {
        Drive::write_xdd(self, info, w)
    }
}

/// The monotonic clock of the loop.
struct Clock(std::time::Instant);

impl Clock {
    fn now(&self) -> Instant {
        Instant::from_micros(u64::try_from(self.0.elapsed().as_micros()).unwrap_or(u64::MAX))
    }
}

/// What the loop needs besides the drive: the axis, the firmware of the manufacturer objects,
/// and where the LSS configuration lives.
pub struct Board<'a> {
    /// The profile (its axis).
    pub profile: &'a BoardProfile,
    /// The file of the LSS configuration (`--storage`).
    pub lss_file: Option<&'a Path>,
    /// The bit rate the program runs at, kbit/s.
    pub bit_rate_kbit: u16,
    /// `-v`/`-vv` (0: neither).
    pub verbose: u8,
    /// `--trace`.
    pub trace: Option<&'a Trace>,
}

/// Where the frames of the loop are reported: the trace file and the `-v` monitor.
struct Observer<'a> {
    monitor: Monitor,
    trace: Option<&'a Trace>,
}

impl Observer<'_> {
    fn frame(&self, direction: Direction, frame: &canopen_drive::CanFrame) {
        if let Some(trace) = self.trace {
            trace.record(frame);
        }
        if self.monitor.active() {
            for line in self.monitor.frame(direction, frame) {
                log!("{line}");
            }
        }
    }

    fn states<S: Persistence, const PDOS: usize, const AXES: usize>(
        &mut self,
        drive: &BoardDrive<S, PDOS, AXES>,
    ) {
        if !self.monitor.active() {
            return;
        }
        let mode = drive
            .od()
            .entry(MODES_OF_OPERATION_DISPLAY, 0)
            .ok()
            .and_then(|entry| {
                let mut value = [0u8; 1];
                (drive.od().read(&entry, 0, &mut value) == 1).then(|| value[0] as i8)
            })
            .unwrap_or(0);
        for line in self.monitor.states(drive.nmt_state(), drive.state(), mode) {
            log!("{line}");
        }
    }
}

/// What a loop without a drive (the bootloader's) reports of its frames: the trace file and
/// the `-v` monitor, as the drive's loop does.
pub fn observer<'a>(board: &Board<'a>) -> impl Fn(Direction, &canopen_drive::CanFrame) + 'a {
    let observer = Observer { monitor: Monitor::new(board.verbose), trace: board.trace };
    move |direction, frame| observer.frame(direction, frame)
}

/// 6061h, modes of operation display.
const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;

/// Runs `drive` on `bus` until `stop` is set, or until a master asks the program to stop or
/// reset (CiA 302-3, [`Config::program_download`]): that request is returned, once its answer
/// is on the bus. `started` runs once the node is on the bus: its boot-up frame has been sent,
/// so a master that connects afterwards never sees it.
pub fn run<S: Persistence, const PDOS: usize, const AXES: usize>(
    mut drive: BoardDrive<S, PDOS, AXES>,
    board: &Board<'_>,
    bus: &Bus,
    stop: &AtomicBool,
    started: impl FnOnce(),
) -> Option<ProgramRequest> {
    let clock = Clock(std::time::Instant::now());
    // One simulated motor per axis, all alike.
    let mut motors: [SimMotor; AXES] = std::array::from_fn(|_| SimMotor::with_params(board.profile.axis));
    let mut firmware = (board.profile.firmware)();
    let env = Environment { lss_file: board.lss_file, bit_rate_kbit: board.bit_rate_kbit };
    let mut updates = Vec::new();
    firmware.start(drive.od(), &env, &mut updates);
    apply_updates(&mut drive, &mut updates);
    let mut last_tick = clock.now();
    let mut next_tick = last_tick + TICK_PERIOD;
    let mut tx_dropped = 0;
    let mut observer = Observer { monitor: Monitor::new(board.verbose), trace: board.trace };
    let mut deadline = drive.poll(last_tick);
    transmit(&mut drive, bus, &observer);
    observer.states(&drive);
    started();

    while !stop.load(Ordering::Relaxed) {
        let now = clock.now();
        let wake = deadline.map_or(next_tick, |d| d.min(next_tick));
        let timeout = StdDuration::from_micros(wake.saturating_since(now).as_micros());
        // One frame per turn: the firmware's reaction to a write (below) lands before the next
        // request is served, however fast the master asks again (`receive` returns at once
        // while frames wait, so a burst is still taken without sleeping).
        if let Some(frame) = bus.receive(timeout) {
            observer.frame(Direction::Rx, &frame);
            drive.on_frame(&frame, clock.now());
            transmit(&mut drive, bus, &observer);
            if drive.take_connection_event() == Some(ConnectionEvent::ResetApplication) {
                firmware.reset(drive.od(), &env, &mut updates);
            }
        }
        lss_services(&mut drive, board.lss_file);
        for change in drive.hooks_mut().take_changes() {
            match change {
                Change::Written { index, sub, value } => {
                    firmware.written(index, sub, value, drive.od(), &env, &mut updates);
                }
                Change::Stored(sub) => firmware.stored(sub, drive.od(), &env),
                simulation => crate::board_objects::apply(simulation, &mut motors),
            }
        }
        apply_updates(&mut drive, &mut updates);
        take_actions(&mut drive, firmware.as_mut());

        let now = clock.now();
        if now >= next_tick {
            // The firmware sees the (first) motor's inputs as they are, the drive as configured.
            let raw: [Sample; AXES] =
                std::array::from_fn(|n| motors.get(n).map(SimMotor::sample).unwrap_or_default());
            let mut samples = raw;
            if let Some(sample) = samples.first_mut() {
                firmware.inputs(drive.od(), sample);
            }
            let demands = drive.tick_axes(now, &samples);
            for (motor, demand) in motors.iter_mut().zip(&demands) {
                motor.step(demand, now - last_tick);
            }
            if let Some(raw) = raw.first() {
                firmware.after_tick(drive.od(), raw, drive.state(), &mut updates);
            }
            apply_updates(&mut drive, &mut updates);
            take_actions(&mut drive, firmware.as_mut());
            last_tick = now;
            // Keep the 1 ms grid, but after a stall restart it instead of catching up in a burst.
            next_tick = next_tick + TICK_PERIOD;
            if next_tick <= now {
                next_tick = now + TICK_PERIOD;
            }
        }

        deadline = drive.poll(now);
        transmit(&mut drive, bus, &observer);
        observer.states(&drive);
        if let Some(request) = drive.take_program_request() {
            return Some(request);
        }

        if drive.tx_dropped() != tx_dropped {
            tx_dropped = drive.tx_dropped();
            log!("the drive's transmit queue overflowed ({tx_dropped} frames lost)");
        }
    }
    None
}

/// Carries out the firmware's actions on the drive.
fn take_actions<S: Persistence, const PDOS: usize, const AXES: usize>(
    drive: &mut BoardDrive<S, PDOS, AXES>,
    firmware: &mut dyn Firmware,
) {
    for action in firmware.take_actions() {
        match action {
            Action::PresetPosition(position) => drive.preset_position(position),
            Action::StoreEntries(entries) => {
                if let Err(e) = drive.store_entries(entries) {
                    log!("the firmware's store of {entries:x?} failed: {e:?}");
                }
            }
            Action::ConfigureNodeId(node_id) => {
                if let Err(e) = drive.configure_node_id(node_id) {
                    log!("the firmware's node-ID {node_id} was refused: {e:?}");
                }
            }
            Action::RemapWhileValid(on) => drive.set_remap_while_valid(on),
        }
    }
}

/// Writes the firmware's values into the dictionary (only those that changed, so the drive
/// re-reads its parameters only when one did).
fn apply_updates<S: Persistence, const PDOS: usize, const AXES: usize>(
    drive: &mut BoardDrive<S, PDOS, AXES>,
    updates: &mut Vec<Update>,
) {
    for update in updates.drain(..) {
        let Ok(entry) = drive.od().entry(update.index, update.sub) else { continue };
        let Some(size) = entry.var.data_type.fixed_size() else { continue };
        let bytes = update.value.to_le_bytes();
        let Some(new) = bytes.get(..size.min(8)) else { continue };
        let mut current = [0u8; 8];
        let n = drive.od().read(&entry, 0, &mut current);
        if current.get(..n) != Some(new) {
            drive.od_mut().commit(&entry, new);
        }
    }
}

/// What an LSS master asked of the board: a bit-rate change is reported on stdout (there is no
/// bit rate on SLCAN-over-TCP to switch), a stored configuration goes to the LSS file.
fn lss_services<S: Persistence, const PDOS: usize, const AXES: usize>(
    drive: &mut BoardDrive<S, PDOS, AXES>,
    lss_file: Option<&Path>,
) {
    if let Some(change) = drive.take_bit_rate_change() {
        let timing = change.bit_timing;
        let rate =
            timing.standard_rate().and_then(|r| r.kbit_per_s()).map_or("?".to_string(), |r| r.to_string());
        crate::output::line(format_args!(
            "bit-rate {rate} kbit/s (table {} index {})",
            timing.table_selector, timing.table_index
        ));
    }
    if let (Some((node_id, bit_timing)), Some(path)) = (drive.take_lss_store(), lss_file) {
        if let Err(e) = crate::lss_store::save(path, node_id, bit_timing) {
            log!("cannot store the LSS configuration in {}: {e}", path.display());
        }
    }
}

/// Puts every frame the drive has queued on the bus.
fn transmit<S: Persistence, const PDOS: usize, const AXES: usize>(
    drive: &mut BoardDrive<S, PDOS, AXES>,
    bus: &Bus,
    observer: &Observer<'_>,
) {
    while let Some(frame) = drive.pop_tx() {
        observer.frame(Direction::Tx, &frame);
        bus.send_from_drive(&frame);
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use crate::bus::{Delivery, Sink};
    use crate::profiles::ProfileName;
    use canopen_drive::CanFrame;
    use std::sync::mpsc::{sync_channel, TrySendError};
    use std::sync::Arc;
    use std::thread;

    #[test]
    fn eds_is_served_and_independent_of_its_own_contents() {
        for name in ProfileName::ALL {
            let profile = BoardProfile::of(name);
            let (config, eds) = config_with_eds(&profile, 5, false).unwrap();
            assert_eq!(config.device.eds, eds);
            let text = std::str::from_utf8(eds).unwrap();
            assert!(text.starts_with("[FileInfo]"));
            assert!(text.contains("\n[1021]\n"));
            // Its storage format: 0, plain ASCII (CiA 301).
            assert!(text.contains("\n[1022]\nParameterName=Store format\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0x0\n"));
            let drive = BoardDrive::<()>::create(config, profile.hooks(false)).unwrap();
            let mut again = String::new();
            drive.write_eds(&profile.eds, &mut again).unwrap();
            assert_eq!(again.as_bytes(), eds, "{}", name.name());
        }
    }

    #[test]
    fn the_sub_indices_of_an_object_have_names_of_their_own() {
        // Masters look entries up by name (python-canopen: `node.sdo[0x1600]["Mapping entry 2"]`).
        for name in ProfileName::ALL {
            let (_, eds) = config_with_eds(&BoardProfile::of(name), 5, false).unwrap();
            let mut seen = std::collections::HashSet::new();
            for section in std::str::from_utf8(eds).unwrap().split("\n\n") {
                let mut lines = section.trim().lines();
                let header = lines.next().unwrap_or_default();
                let Some((index, _)) = header.trim_start_matches('[').split_once("sub") else { continue };
                let parameter = lines.find_map(|l| l.strip_prefix("ParameterName=")).unwrap();
                assert!(seen.insert((index, parameter)), "{}: {header} {parameter:?} twice", name.name());
            }
            assert!(seen.contains(&("1600", "Mapping entry 2")), "{}", name.name());
        }
    }

    #[test]
    fn the_descriptions_say_whether_the_drive_stores_parameters() {
        // 1010h/1011h subs 1-4 read 1 for the groups the drive stores, 0 without storage.
        let sub = |text: &str, section: &str| {
            let at = text.find(&format!("\n[{section}]\n")).unwrap();
            text[at..].lines().find_map(|l| l.strip_prefix("DefaultValue=")).unwrap().to_string()
        };
        for name in ProfileName::ALL {
            let profile = BoardProfile::of(name);
            let (with, without) = (eds(&profile, 5, true).unwrap(), eds(&profile, 5, false).unwrap());
            for index in ["1010", "1011"] {
                for n in 1..=4 {
                    let section = format!("{index}sub{n}");
                    // The Harmonic Drive actuator does not store group 3 (`Config::store_groups`).
                    let stored = !(name == ProfileName::HarmonicDrive && n == 3);
                    assert_eq!(sub(&with, &section), if stored { "0x1" } else { "0x0" }, "{section}");
                    assert_eq!(sub(&without, &section), "0x0", "{section}");
                }
            }
            let xdd = xdd(&profile, 5, true).unwrap();
            assert!(xdd.contains(r#"name="Store parameters 1" objectType="7" dataType="0007" accessType="rw" defaultValue="0x1""#));
        }
    }

    #[test]
    fn every_profile_signs_its_stored_parameters_differently() {
        let signatures: Vec<u32> = ProfileName::ALL
            .iter()
            .map(|name| {
                let device = BoardProfile::of(*name).config(5).device;
                canopen_drive::storage::device_signature(&device, STORAGE_LAYOUT)
            })
            .collect();
        for (i, a) in signatures.iter().enumerate() {
            for (j, b) in signatures.iter().enumerate() {
                assert!(i == j || a != b, "{:?} and {:?}", ProfileName::ALL[i], ProfileName::ALL[j]);
            }
        }
    }

    #[test]
    fn loop_boots_answers_and_stops() {
        let profile = BoardProfile::of(ProfileName::Generic);
        let (config, _) = config_with_eds(&profile, 3, false).unwrap();
        let drive = BoardDrive::<()>::create(config, profile.hooks(false)).unwrap();
        let bus = Bus::new();
        let (tx, rx) = sync_channel(64);
        let sink: Sink = Box::new(move |f: &CanFrame| match tx.try_send(*f) {
            Ok(()) => Delivery::Queued,
            Err(TrySendError::Full(_)) => Delivery::Dropped,
            Err(TrySendError::Disconnected(_)) => Delivery::Gone,
        });
        let client = bus.attach("test".into(), sink);
        let stop = Arc::new(AtomicBool::new(false));
        let runner = {
            let (bus, stop) = (bus.clone(), Arc::clone(&stop));
            thread::spawn(move || {
                let board =
                    Board { profile: &profile, lss_file: None, bit_rate_kbit: 1000, verbose: 0, trace: None };
                run(drive, &board, &bus, &stop, || {});
            })
        };
        let timeout = StdDuration::from_secs(5);
        assert_eq!(rx.recv_timeout(timeout).unwrap(), CanFrame::new_standard(0x703, &[0]).unwrap());
        let request = CanFrame::new_standard(0x603, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap();
        bus.send_from_endpoint(client, &request);
        let response = rx.recv_timeout(timeout).unwrap();
        assert_eq!(response.standard_id(), Some(0x583));
        assert_eq!(embedded_can::Frame::data(&response), &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]);
        stop.store(true, Ordering::Relaxed);
        runner.join().unwrap();
    }
}
