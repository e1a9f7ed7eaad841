//! Two CiA 402 axes on one node (issue 23): axis n has its objects at 6000h + n × 800h, its own
//! state machine, mode, EMCYs and PDOs 4n + 1 … 4n + 4, and both run from the same SYNC. The test
//! is the master: it sees SDO answers, EMCY frames and the demands each power stage gets.

use canopen_drive::comm::pdo;
use canopen_drive::drive::{AXIS_OD_BYTES, STANDARD_OD_BYTES};
use canopen_drive::hal::{Demand, HardwareFaults, Setpoint};
use canopen_drive::od::{eds::EdsInfo, Object};
use canopen_drive::{AbortCode, CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::motor::SimMotor;
use embedded_can::{Frame, Id};

const NODE: u8 = 5;
const SDO_RX: u16 = 0x600 + NODE as u16;
const SDO_TX: u16 = 0x580 + NODE as u16;
/// A second axis's object: the first axis's index + 800h.
const AXIS1: u16 = 0x800;

static PDO_OBJECTS: [Object; 32] = canopen_drive::od::layout(pdo::objects::<32>(8));
const OD_BYTES: usize = STANDARD_OD_BYTES + AXIS_OD_BYTES + 1024;
type TwoAxes = Drive<(), OD_BYTES, 8, 8, (), 2>;

/// The node, its two motors and the time; ticked at 1 kHz.
struct Node {
    drive: TwoAxes,
    motors: [SimMotor; 2],
    demands: [Demand; 2],
    now: Instant,
    /// Frames the node sent, oldest first.
    sent: Vec<CanFrame>,
    /// A hardware fault injected into axis 1's sample.
    axis1_fault: HardwareFaults,
}

impl Node {
    fn new() -> Node {
        let config = Config { pdo_objects: &PDO_OBJECTS, ..Config::new(NODE) };
        let drive = TwoAxes::build(config, (), ()).expect("a two-axis drive");
        let mut node = Node {
            drive,
            motors: [SimMotor::new(), SimMotor::new()],
            demands: [Demand::OFF; 2],
            now: Instant::ZERO,
            sent: Vec::new(),
            axis1_fault: HardwareFaults::empty(),
        };
        node.run(1);
        node
    }

    /// `ms` ticks of 1 ms, each followed by a poll.
    fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            let mut samples = [self.motors[0].sample(), self.motors[1].sample()];
            samples[1].faults |= self.axis1_fault;
            self.demands = self.drive.tick_axes(self.now, &samples);
            for (motor, demand) in self.motors.iter_mut().zip(&self.demands) {
                motor.step(demand, Duration::from_millis(1));
            }
            self.now = self.now + Duration::from_millis(1);
            self.drive.poll(self.now);
            self.drain();
        }
    }

    fn drain(&mut self) {
        while let Some(frame) = self.drive.pop_tx() {
            self.sent.push(frame);
        }
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        let frame = CanFrame::new_standard(id, data).expect("a frame");
        self.drive.on_frame(&frame, self.now);
        self.drain();
    }

    /// The SDO server's answer to an expedited request.
    fn sdo(&mut self, request: [u8; 8]) -> [u8; 8] {
        self.sent.clear();
        self.send(SDO_RX, &request);
        let answer = self.sent.iter().find(|f| id(f) == SDO_TX).expect("an SDO answer");
        answer.data().try_into().expect("8 bytes")
    }

    fn read(&mut self, index: u16, sub: u8) -> Result<u32, u32> {
        let [lo, hi] = index.to_le_bytes();
        let answer = self.sdo([0x40, lo, hi, sub, 0, 0, 0, 0]);
        let value = u32::from_le_bytes([answer[4], answer[5], answer[6], answer[7]]);
        match answer[0] {
            0x80 => Err(value),
            _ => Ok(value),
        }
    }

    fn write(&mut self, index: u16, sub: u8, value: u32, bytes: u8) -> Result<(), u32> {
        let [lo, hi] = index.to_le_bytes();
        let [d0, d1, d2, d3] = value.to_le_bytes();
        let command = 0x23 | ((4 - bytes) << 2);
        let answer = self.sdo([command, lo, hi, sub, d0, d1, d2, d3]);
        match answer[0] {
            0x60 => Ok(()),
            _ => Err(u32::from_le_bytes([answer[4], answer[5], answer[6], answer[7]])),
        }
    }

    fn statusword(&mut self, axis: u16) -> u16 {
        self.read(0x6041 + axis, 0).expect("6041h") as u16
    }

    /// Maps `entries` into RPDO `number` (1-based) on identifier `cob_id` with `transmission`
    /// type, as a master does: invalid, cleared, mapped, counted, valid again.
    fn map_rpdo(&mut self, number: u16, cob_id: u32, transmission: u32, entries: &[u32]) {
        let (communication, mapping) = (0x1400 + number - 1, 0x1600 + number - 1);
        self.write(communication, 1, 0x8000_0000 | cob_id, 4).unwrap();
        self.write(mapping, 0, 0, 1).unwrap();
        for (sub, entry) in (1u8..).zip(entries) {
            self.write(mapping, sub, *entry, 4).unwrap();
        }
        self.write(mapping, 0, entries.len() as u32, 1).unwrap();
        self.write(communication, 2, transmission, 1).unwrap();
        self.write(communication, 1, cob_id, 4).unwrap();
    }

    /// Shutdown, switch on, enable operation for the axis whose controlword is `controlword`.
    fn enable(&mut self, controlword: u16) {
        for cw in [0x06, 0x07, 0x0F] {
            self.write(controlword, 0, cw, 2).expect("controlword");
            self.run(2);
        }
    }

    fn emcys(&self) -> Vec<[u8; 8]> {
        self.sent
            .iter()
            .filter(|f| id(f) == 0x080 + u16::from(NODE))
            .map(|f| f.data().try_into().expect("8 bytes"))
            .collect()
    }
}

fn id(frame: &CanFrame) -> u16 {
    match frame.id() {
        Id::Standard(id) => id.as_raw(),
        Id::Extended(_) => 0,
    }
}

const OPERATION_ENABLED: u16 = 0x27;
const SWITCH_ON_DISABLED: u16 = 0x40;
const FAULT: u16 = 0x08;

#[test]
fn each_axis_identifies_itself_and_the_node_is_a_multi_device() {
    let mut node = Node::new();
    assert_eq!(
        node.read(0x1000, 0),
        Ok(0xFFFF_0192),
        "FFFFh: several logical devices, the first a 402 drive"
    );
    assert_eq!(node.read(0x67FF, 0), Ok(0x0002_0192), "axis 0's own device type");
    assert_eq!(node.read(0x6FFF, 0), Ok(0x0002_0192), "axis 1's own device type");
    assert_eq!(node.read(0x77FF, 0), Err(AbortCode::ObjectDoesNotExist.code()), "no third axis");
    assert_eq!(node.read(0x6502, 0), node.read(0x6D02, 0), "6502h per axis");
    assert_eq!(node.write(0x6FFF, 0, 1, 4), Err(AbortCode::WriteOfReadOnly.code()));

    // A single-axis drive keeps the CiA 402 device type and has no 67FFh.
    let mut single = Drive::new(Config::new(NODE)).unwrap();
    assert_eq!(single.od().get::<u32>(0x1000, 0), Ok(0x0002_0192));
    assert_eq!(single.od_mut().get::<u32>(0x67FF, 0), Err(AbortCode::ObjectDoesNotExist));
}

#[test]
fn the_axes_run_their_state_machines_independently() {
    let mut node = Node::new();
    assert_eq!(node.statusword(0) & 0x6F, SWITCH_ON_DISABLED);
    assert_eq!(node.statusword(AXIS1) & 0x6F, SWITCH_ON_DISABLED);
    node.enable(0x6840);
    assert_eq!(node.statusword(AXIS1) & 0x6F, OPERATION_ENABLED, "axis 1 enabled");
    assert_eq!(node.statusword(0) & 0x6F, SWITCH_ON_DISABLED, "axis 0 untouched");
    assert!(node.demands[1].drive_enabled && !node.demands[0].drive_enabled);
    node.enable(0x6040);
    node.write(0x6840, 0, 0x06, 2).unwrap();
    node.run(2);
    assert_eq!(node.statusword(0) & 0x6F, OPERATION_ENABLED, "axis 0 stays enabled");
    assert_eq!(node.statusword(AXIS1) & 0x6F, 0x21, "axis 1 ready to switch on");
    assert!(node.demands[0].drive_enabled && !node.demands[1].drive_enabled);
}

#[test]
fn one_axis_positions_while_the_other_runs_at_a_velocity() {
    let mut node = Node::new();
    // Axis 0: pp to 20 000 increments; axis 1: pv at 3 000 increments/s.
    node.write(0x6060, 0, 1, 1).unwrap();
    node.write(0x6081, 0, 50_000, 4).unwrap();
    node.write(0x6083, 0, 500_000, 4).unwrap();
    node.write(0x6084, 0, 500_000, 4).unwrap();
    node.write(0x6860, 0, 3, 1).unwrap();
    node.write(0x6883, 0, 100_000, 4).unwrap();
    node.write(0x68FF, 0, 3_000, 4).unwrap();
    node.run(2);
    assert_eq!(node.read(0x6061, 0), Ok(1));
    assert_eq!(node.read(0x6861, 0), Ok(3));
    node.enable(0x6040);
    node.enable(0x6840);
    node.write(0x607A, 0, 20_000, 4).unwrap();
    node.write(0x6040, 0, 0x1F, 2).unwrap();
    node.run(100);
    assert!(matches!(node.demands[0].setpoint, Setpoint::Position(_)), "{:?}", node.demands[0]);
    assert_eq!(node.demands[1].setpoint, Setpoint::Velocity(3_000), "pv reached its target");
    node.run(1000);
    assert_eq!(node.statusword(0) & 0x0400, 0x0400, "axis 0 reached its target");
    let position = node.read(0x6064, 0).unwrap() as i32;
    assert!((position - 20_000).abs() <= 20, "axis 0 at {position}");
    assert_eq!(node.read(0x686C, 0).map(|v| (v as i32 - 3_000).abs() < 100), Ok(true), "axis 1 turning");
    assert_eq!(node.read(0x606C, 0).map(|v| (v as i32).abs() < 100), Ok(true), "axis 0 at rest");
    assert_eq!(node.read(0x687A, 0), Ok(0), "axis 1's target position untouched");
}

#[test]
fn a_fault_of_one_axis_leaves_the_other_moving() {
    let mut node = Node::new();
    for index in [0x6060, 0x6860] {
        node.write(index, 0, 3, 1).unwrap();
        node.write(index + 0x23, 0, 100_000, 4).unwrap();
        node.write(index + 0x9F, 0, 2_000, 4).unwrap();
    }
    // NMT Operational: the EMCYs go out.
    node.send(0x000, &[0x01, NODE]);
    node.enable(0x6040);
    node.enable(0x6840);
    node.run(50);
    node.sent.clear();
    node.axis1_fault = HardwareFaults::OVER_CURRENT;
    node.run(100);
    let emcys = node.emcys();
    assert_eq!(node.statusword(AXIS1) & 0x4F, FAULT, "axis 1 in Fault");
    assert_eq!(node.statusword(0) & 0x6F, OPERATION_ENABLED, "axis 0 still enabled");
    assert_eq!(node.demands[0].setpoint, Setpoint::Velocity(2_000));
    assert!(node.demands[0].drive_enabled && !node.demands[1].drive_enabled);
    assert_eq!(emcys.len(), 1, "{emcys:x?}");
    let emcy = emcys[0];
    let code = u16::from_le_bytes([emcy[0], emcy[1]]);
    assert_eq!(code, 0x2310, "over-current");
    assert_eq!(emcy[7], 1, "axis 1 in byte 7");
    assert_eq!(node.read(0x683F, 0), Ok(u32::from(code)), "683Fh, axis 1's error code");
    assert_eq!(node.read(0x603F, 0), Ok(0), "axis 0 has none");
    assert_eq!(node.read(0x1003, 1), Ok(u32::from(code)), "the node's history");

    // The same error on axis 0 is its own: a second EMCY, and clearing axis 1's keeps it.
    node.sent.clear();
    node.drive.raise_axis_error(0, 0x2310, canopen_drive::comm::emcy::ErrorRegister::CURRENT, [0; 5]);
    node.run(1);
    assert_eq!(node.emcys().len(), 1, "raised again for axis 0");
    node.drive.clear_axis_error(1, 0x2310);
    assert_ne!(node.drive.error_register().bits() & 0x02, 0, "axis 0's over-current stays active");
    node.drive.clear_axis_error(0, 0x2310);
    assert_eq!(node.drive.error_register().bits(), 0);
}

#[test]
fn each_axis_has_its_pdos_and_both_follow_one_sync() {
    let mut node = Node::new();
    // The pre-defined mapping, shifted: PDOs 5–8 are axis 1's, without identifiers.
    assert_eq!(node.read(0x1604, 1), Ok(0x6840_0010));
    assert_eq!(node.read(0x1607, 2), Ok(0x68FF_0020));
    assert_eq!(node.read(0x1A05, 2), Ok(0x6861_0008));
    assert_eq!(node.read(0x1404, 1).map(|id| id >> 31), Ok(1), "RPDO5 not valid until given an identifier");
    assert_eq!(node.read(0x1806, 2), Ok(1), "TPDO7 on every SYNC as TPDO3");
    assert_eq!(node.read(0x1600, 1), Ok(0x6040_0010), "axis 0 keeps PDOs 1–4");

    // csp on both: RPDO1 = 6040h + 607Ah, RPDO5 = 6840h + 687Ah, both synchronous.
    for (number, cob, axis) in [(1, 0x205u32, 0u32), (5, 0x285, 0x800)] {
        node.map_rpdo(number, cob, 1, &[(0x6040 + axis) << 16 | 0x10, (0x607A + axis) << 16 | 0x20]);
        node.write(0x6060 + axis as u16, 0, 8, 1).unwrap();
        node.write(0x60C5 + axis as u16, 0, u32::MAX, 4).unwrap();
        node.write(0x60C6 + axis as u16, 0, u32::MAX, 4).unwrap();
    }
    node.send(0x000, &[0x01, NODE]);
    node.enable(0x6040);
    node.enable(0x6840);
    // 1 ms SYNC period: each axis's RPDO, then the SYNC.
    let mut seen = [Vec::new(), Vec::new()];
    for k in 1..=40i32 {
        let [a, b] = [10 * k, -20 * k];
        let frame = |target: i32| {
            let mut data = vec![0x0F, 0x00];
            data.extend_from_slice(&target.to_le_bytes());
            data
        };
        node.send(0x205, &frame(a));
        node.send(0x285, &frame(b));
        node.run(1);
        for (axis, seen) in seen.iter_mut().enumerate() {
            if let Setpoint::Position(p) = node.demands[axis].setpoint {
                seen.push(p);
            }
        }
        assert!(seen[0].iter().all(|p| *p >= 0), "axis 0 follows its own stream");
        node.send(0x080, &[]);
        node.run(1);
    }
    assert_eq!(node.statusword(0) & 0x6F, OPERATION_ENABLED);
    assert_eq!(node.statusword(AXIS1) & 0x6F, OPERATION_ENABLED);
    // Each axis took its stream at the SYNCs: axis 0 at 10 × k, axis 1 at −20 × k.
    assert_eq!(node.read(0x6062, 0).map(|p| p as i32), Ok(400));
    assert_eq!(node.read(0x6862, 0).map(|p| p as i32), Ok(-800));
    assert!(seen[0].contains(&200) && seen[1].contains(&-400), "{seen:?}");
}

#[test]
fn the_eds_lists_both_axes_and_storage_keeps_each_axis_apart() {
    let node = Node::new();
    let mut eds = String::new();
    node.drive.write_eds(&EdsInfo::default(), &mut eds).unwrap();
    for section in ["[6040]", "[6840]", "[67FF]", "[6FFF]", "[6D02]", "[1604sub1]"] {
        assert!(eds.contains(section), "{section} missing");
    }
    assert!(!eds.contains("[7040]"));
    assert!(eds.contains("[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0xFFFF0192"));
    assert!(eds.contains("DefaultValue=0x68400010"), "RPDO5's preset mapping");
    // A master that finds objects by name tells the axes apart; the first axis's names are CiA 402's.
    assert!(eds.contains("[6040]\nParameterName=Controlword\n"));
    assert!(eds.contains("[6840]\nParameterName=Controlword (axis 1)\n"));
    assert!(eds.contains("[6FFF]\nParameterName=Device type (axis 1)\n"));

    // Every parameter of axis 1 is a parameter of its own (store and restore see it).
    let od = node.drive.od();
    let axis1: Vec<u16> = od.parameters(0x6800..=0x6FFF).map(|e| e.index()).collect();
    assert!(axis1.contains(&0x6883) && axis1.contains(&0x6860), "{axis1:x?}");
    let axis0 = od.parameters(0x6000..=0x67FF).count();
    assert_eq!(axis0, axis1.len(), "the same parameters for each axis");
}

/// Eight axes, the most CiA 402 gives a node: the last one's objects end at 9FFFh, its PDOs are
/// 29–32.
#[test]
fn eight_axes_reach_9fffh() {
    static PDOS_32: [Object; 128] = canopen_drive::od::layout(pdo::objects::<128>(32));
    const BYTES: usize = STANDARD_OD_BYTES + 7 * AXIS_OD_BYTES + 8192;
    let config = Config { pdo_objects: &PDOS_32, ..Config::new(NODE) };
    let mut drive = Drive::<(), BYTES, 32, 32, (), 8>::build(config, (), ()).expect("an eight-axis drive");
    let od = drive.od();
    assert_eq!(od.get::<u32>(0x9FFF, 0), Ok(0x0002_0192));
    assert_eq!(od.get::<u32>(0x1A1C, 1), Ok(0x9841_0010), "TPDO29: the eighth axis's statusword");
    assert_eq!(od.get::<u32>(0x1A20, 1), Err(AbortCode::ObjectDoesNotExist));
    drive.od_mut().set::<u16>(0x9840, 0, 0x06).unwrap();
    let samples = [SimMotor::new().sample(); 8];
    let mut now = Instant::ZERO;
    for _ in 0..3 {
        drive.tick_axes(now, &samples);
        now = now + Duration::from_millis(1);
    }
    let states: Vec<u16> =
        (0..8u16).map(|n| drive.od().get::<u16>(0x6041 + n * 0x800, 0).unwrap() & 0x6F).collect();
    assert_eq!(states, [SWITCH_ON_DISABLED, 0x40, 0x40, 0x40, 0x40, 0x40, 0x40, 0x21]);
    assert_eq!(drive.axis_state(7), canopen_drive::cia402::fsa::State::ReadyToSwitchOn);
}

/// Store and restore keep each axis's parameters apart: a value of axis 1 survives a power cycle
/// at its own index, and restoring the defaults resets both axes.
#[test]
fn stored_parameters_of_each_axis() {
    use canopen_drive::od::DeviceInfo;
    use canopen_drive::storage::{device_signature, Group, Storage};
    use canopen_drive_sim::flash::SimFlash;
    type Stored = Drive<(), OD_BYTES, 8, 8, Storage<SimFlash>, 2>;
    let power_on = |flash: SimFlash| {
        let storage = Storage::new(flash, device_signature(&DeviceInfo::servo_drive(), 1)).unwrap();
        let config = Config { pdo_objects: &PDO_OBJECTS, ..Config::new(NODE) };
        Stored::build(config, (), storage).unwrap()
    };
    let mut drive = power_on(SimFlash::new(16384, 512, 4));
    drive.od_mut().set::<u32>(0x6883, 0, 123_456).unwrap();
    drive.od_mut().set::<u32>(0x6083, 0, 7_000).unwrap();
    assert_eq!(drive.store_parameters(Group::All), Ok(()));
    let flash = drive.storage_mut().area().clone();
    let mut drive = power_on(flash);
    assert_eq!(drive.od().get::<u32>(0x6883, 0), Ok(123_456), "axis 1's 6083h after power-on");
    assert_eq!(drive.od().get::<u32>(0x6083, 0), Ok(7_000), "axis 0's own");
    drive.storage_mut().restore_defaults(Group::All).unwrap();
    let flash = drive.storage_mut().area().clone();
    let drive = power_on(flash);
    assert_eq!(drive.od().get::<u32>(0x6883, 0), Ok(10_000), "the default again");
    assert_eq!(drive.od().get::<u32>(0x6083, 0), Ok(10_000));
}

/// One RPDO may carry both axes' controlwords: each goes to its own state machine.
#[test]
fn one_rpdo_with_both_controlwords() {
    let mut node = Node::new();
    node.map_rpdo(1, 0x205, 255, &[0x6040_0010, 0x6840_0010]);
    node.send(0x000, &[0x01, NODE]);
    for (first, second) in [(0x06u16, 0x06u16), (0x07, 0x06), (0x0F, 0x07)] {
        let [a, b] = first.to_le_bytes();
        let [c, d] = second.to_le_bytes();
        node.send(0x205, &[a, b, c, d]);
        node.run(2);
    }
    assert_eq!(node.statusword(0) & 0x6F, OPERATION_ENABLED);
    assert_eq!(node.statusword(AXIS1) & 0x6F, 0x23, "axis 1 switched on, not enabled");
}
