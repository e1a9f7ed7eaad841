//! Item 2: fault injection on the virtual bus. Every scenario runs the test drive as a
//! [`Watched`] node, so invariants 1–3 are checked at every tick (and the dictionary every
//! 100 ticks) while the bus misbehaves.

use canopen_drive::cia402::fsa::State;
use canopen_drive::drive::CanState;
use canopen_drive::hal::Setpoint;
use canopen_drive::wire::nmt::NmtCommand;
use canopen_drive::{CanFrame, Duration, Instant};
use canopen_drive_sim::bus::{NodeHandle, VirtualBus};
use canopen_drive_sim::fault::XorShift64;
use canopen_drive_sim::{FaultRule, Master, Port, SdoError};
use embedded_can::Frame;

use super::report::{Notes, Scenario};
use super::watched::Watched;
use crate::common::{LIMITED, NODE, TEXT};

const EMCY: u16 = 0x80 + NODE as u16;
const RPDO1: u16 = 0x200 + NODE as u16;

pub const SCENARIOS: [Scenario; 9] = [
    Scenario {
        name: "SDO through loss, duplication, delay and reordering",
        checks: "200 write/read-back pairs (expedited 2001h, segmented 2000h) at 5 % drop, 5 % duplication, \
                 5 % delay by 3 ms (overtaken by later frames) and all three at once; the master retries; \
                 every value read back is the last one written, the server never wedges",
        run: sdo_through_faults,
    },
    Scenario {
        name: "csp stream through loss, duplication and reordering",
        checks: "a csp sine stream (SYNC and RPDO at 1 kHz, tick 4 kHz) with 2 % of the RPDOs delayed past \
                 their SYNC, 1 % of the SYNCs duplicated and 1 % dropped: the gaps are bridged (a stream lost \
                 to three misses in a row is reset by the master), the axis ends on the target, limits hold",
        run: csp_through_faults,
    },
    Scenario {
        name: "Babbling node at 100 % bus load",
        checks: "20 floods of 200 ms of random frames back to back (1 Mbit/s: one every 47–111 bit times) \
                 while the drive turns in pv: every tick on time, no frame lost by the drive, SDO served in \
                 every 50 ms pause between floods",
        run: babbling_node,
    },
    Scenario {
        name: "Bus-off and recovery",
        checks: "bus-off reported by the board during a move, for 6007h = 0, 1, 2, 3: the 1029h reaction \
                 (Pre-operational), the 6007h reaction on the motor, frames lost while off the bus, EMCY \
                 8140h once error active again",
        run: bus_off_and_recovery,
    },
    Scenario {
        name: "SYNC jitter in csp",
        checks:
            "SYNC at 1 kHz with ±250 µs of jitter: no missed cycle, no EMCY, tracking as good as without \
                 jitter",
        run: sync_jitter,
    },
    Scenario {
        name: "SYNC loss in csp",
        checks: "1 and 2 SYNCs lost: bridged, still Operation enabled; 3 lost: EMCY 8700h and the 6007h \
                 reaction (fault, quick-stop ramp); SYNC stopping with 1006h set: EMCY 8100h",
        run: sync_loss,
    },
    Scenario {
        name: "Heartbeat loss of the master during a move",
        checks: "1016h supervises the master (250 ms); the master's heartbeat stops during a pv move, for \
                 6007h = 0, 1, 2, 3: EMCY 8130h within the consumer time, the motor stops as 6007h says",
        run: heartbeat_loss,
    },
    Scenario {
        name: "Master disappears mid-SDO",
        checks: "segmented download, segmented upload, block download and block upload abandoned by the \
                 client: abort 05040000h after the SDO timeout (1 s), the old value kept, the server free",
        run: master_disappears_mid_sdo,
    },
    Scenario {
        name: "RPDO value rules (regression of the fuzzer's first find)",
        checks: "an RPDO (6040h + 6060h) carrying a 6060h mode the drive lacks, a reserved or a \
                 manufacturer mode is not applied at all (6040h neither), a supported mode is",
        run: rpdo_value_rules,
    },
];

// --- The rig ------------------------------------------------------------------------------

struct Rig {
    master: Master,
    node: NodeHandle,
}

impl Rig {
    fn new(adjust: impl FnOnce(canopen_drive::Config) -> canopen_drive::Config) -> Rig {
        Rig::with_tick(adjust, 1000)
    }

    /// The drive ticked at `hz`.
    fn with_tick(adjust: impl FnOnce(canopen_drive::Config) -> canopen_drive::Config, hz: u32) -> Rig {
        let mut bus = VirtualBus::new();
        let adjust = move |c: canopen_drive::Config| {
            let mut c = adjust(c);
            c.profile.tick_rate = canopen_drive::motion::TickRate::new(hz).expect("a tick rate");
            c
        };
        let node = bus.add_node(Watched::new(adjust, Duration::from_micros(1_000_000 / u64::from(hz))));
        let mut master = Master::new(bus);
        master.advance(Duration::ZERO).expect("boot");
        master.bus_mut().drain_received();
        Rig { master, node }
    }

    fn standard() -> Rig {
        Rig::new(|c| c)
    }

    fn node(&mut self) -> &mut Watched {
        self.master.bus_mut().node_mut::<Watched>(self.node).expect("the watched node")
    }

    fn now(&self) -> Instant {
        self.master.now()
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) {
        if let Err(e) = self.master.sdo_download(NODE, index, sub, data) {
            panic!("write {index:04X}sub{sub} {data:02X?}: {e}");
        }
    }

    fn read(&mut self, index: u16, sub: u8) -> Vec<u8> {
        match self.master.sdo_upload(NODE, index, sub) {
            Ok(data) => data,
            Err(e) => panic!("read {index:04X}sub{sub}: {e}"),
        }
    }

    fn advance(&mut self, ms: u64) {
        self.master.advance(Duration::from_millis(ms)).expect("the bus settles");
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        self.master.send(CanFrame::new_standard(id, data).expect("a frame"));
    }

    fn nmt(&mut self, command: NmtCommand) {
        self.master.nmt(command, NODE).expect("the bus settles");
    }

    /// Operational, `mode` selected, Operation enabled.
    fn enable(&mut self, mode: u8) {
        self.nmt(NmtCommand::Start);
        self.write(0x6060, 0, &[mode]);
        for cw in [0x0006u16, 0x0007, 0x000F] {
            self.write(0x6040, 0, &cw.to_le_bytes());
            self.advance(2);
        }
        assert!(matches!(self.node().drive.state(), State::OperationEnabled { .. }), "enabled");
    }

    /// pv at `velocity` increments/s, settled.
    fn turning(&mut self, velocity: i32) {
        self.write(0x6083, 0, &1_000_000u32.to_le_bytes());
        self.write(0x6084, 0, &1_000_000u32.to_le_bytes());
        self.enable(3);
        self.write(0x60FF, 0, &velocity.to_le_bytes());
        self.advance(200);
        let actual = self.node().motor.sample().velocity;
        assert!((actual - velocity).abs() < velocity / 20, "turning at {actual}, not {velocity}");
    }

    /// EMCY codes the drive sent since the last call.
    fn emcy_codes(&mut self) -> Vec<u16> {
        self.master
            .bus_mut()
            .drain_received()
            .into_iter()
            .filter(|r| r.frame.standard_id() == Some(EMCY))
            .map(|r| u16::from_le_bytes([r.frame.data()[0], r.frame.data()[1]]))
            .collect()
    }

    fn finish(&mut self) {
        let node = self.node();
        node.check_dictionary();
        assert_eq!(node.drive.tx_dropped(), 0, "frames dropped by the drive's queue");
    }
}

/// An SDO transfer repeated until it succeeds (at most `tries` times); returns the retries.
fn retry<T>(tries: usize, mut f: impl FnMut() -> Result<T, SdoError>) -> (T, usize) {
    let mut errors = Vec::new();
    for attempt in 0..tries {
        match f() {
            Ok(v) => return (v, attempt),
            Err(e) => errors.push(e),
        }
    }
    panic!("no success in {tries} tries: {errors:?}");
}

// --- 2a SDO --------------------------------------------------------------------------------

fn sdo_through_faults(notes: &mut Notes) {
    type Rules = fn() -> Vec<FaultRule>;
    let cases: [(&str, Rules); 4] = [
        ("5 % drop", || vec![FaultRule::drop().rate(0.05, 11)]),
        ("5 % duplication", || vec![FaultRule::duplicate().rate(0.05, 12)]),
        ("5 % delay 3 ms", || vec![FaultRule::delay(Duration::from_millis(3)).rate(0.05, 13)]),
        ("all three", || {
            vec![
                FaultRule::drop().rate(0.05, 21),
                FaultRule::duplicate().rate(0.05, 22),
                FaultRule::delay(Duration::from_millis(3)).rate(0.05, 23),
            ]
        }),
    ];
    for (name, rules) in cases {
        let mut rig = Rig::standard();
        let positions: Vec<usize> = rules().into_iter().map(|r| rig.master.bus_mut().add_fault(r)).collect();
        let mut retries = 0;
        for k in 0..100u32 {
            let limited = [10 + (k % 11) as u8];
            let text: Vec<u8> = (0..(20 + k % 20)).map(|i| b'a' + ((i + k) % 26) as u8).collect();
            retries += retry(40, || rig.master.sdo_download(NODE, LIMITED, 0, &limited)).1;
            retries += retry(40, || rig.master.sdo_download(NODE, TEXT, 0, &text)).1;
            let (back, r1) = retry(40, || rig.master.sdo_upload(NODE, LIMITED, 0));
            let (back_text, r2) = retry(40, || rig.master.sdo_upload(NODE, TEXT, 0));
            retries += r1 + r2;
            assert_eq!(back, limited, "{name}: 2001h after write {k}");
            assert_eq!(back_text, text, "{name}: 2000h after write {k}");
        }
        let hit: usize =
            positions.iter().filter_map(|p| rig.master.bus().fault(*p)).map(|r| r.applied()).sum();
        rig.finish();
        notes.note(format!(
            "{name}: 400 transfers, {hit} frames hit, {retries} retries, all values read back"
        ));
    }
}

// --- 2b csp ---------------------------------------------------------------------------------

/// A drive ticked at 4 kHz with RPDO1 = controlword + 607Ah, synchronous; csp enabled;
/// acceleration limits out of the way.
fn csp_rig() -> Rig {
    let mut rig = Rig::with_tick(|c| c, 4000);
    rig.write(0x1400, 1, &(0x8000_0000u32 | u32::from(RPDO1)).to_le_bytes());
    rig.write(0x1600, 0, &[0]);
    rig.write(0x1600, 1, &0x6040_0010u32.to_le_bytes());
    rig.write(0x1600, 2, &0x607A_0020u32.to_le_bytes());
    rig.write(0x1600, 0, &[2]);
    rig.write(0x1400, 2, &[1]);
    rig.write(0x1400, 1, &u32::from(RPDO1).to_le_bytes());
    rig.write(0x60C5, 0, &10_000_000u32.to_le_bytes());
    rig.write(0x60C6, 0, &10_000_000u32.to_le_bytes());
    rig.enable(8);
    rig
}

fn sine(k: u64) -> i32 {
    (20_000.0 * (k as f64 * 2.0 * std::f64::consts::PI / 1000.0).sin()).round() as i32
}

/// One 1 ms cycle of a csp stream: RPDO `lead_us` before the SYNC, SYNC at `sync_us` into the
/// cycle (0..1000), the rest of the millisecond. Ticks run at whole milliseconds.
fn csp_cycle(rig: &mut Rig, target: i32, sync_us: u64) {
    let start = rig.now();
    let mut data = 0x000Fu16.to_le_bytes().to_vec();
    data.extend_from_slice(&target.to_le_bytes());
    rig.master.bus_mut().run_until(start + Duration::from_micros(sync_us.saturating_sub(200))).unwrap();
    rig.send(RPDO1, &data);
    rig.master.bus_mut().run_until(start + Duration::from_micros(sync_us)).unwrap();
    rig.send(0x080, &[]);
    rig.master.bus_mut().run_until(start + Duration::from_millis(1)).unwrap();
}

fn csp_through_faults(notes: &mut Notes) {
    let mut rig = csp_rig();
    let positions = [
        rig.master.bus_mut().add_fault(
            FaultRule::delay(Duration::from_micros(400))
                .from_port(Port::Master)
                .with_id(RPDO1)
                .rate(0.02, 31),
        ),
        rig.master
            .bus_mut()
            .add_fault(FaultRule::duplicate().from_port(Port::Master).with_id(0x080).rate(0.01, 32)),
        rig.master
            .bus_mut()
            .add_fault(FaultRule::drop().from_port(Port::Master).with_id(0x080).rate(0.01, 33)),
    ];
    let mut worst = 0i64;
    let mut recoveries = 0;
    let mut since_recovery = 1000;
    // 3000 cycles of the sine, then 1 s on its last target (the motor settles).
    for k in 0..4000u64 {
        let target = sine(k.min(3000));
        csp_cycle(&mut rig, target, 500);
        since_recovery += 1;
        // The master watches the statusword (as from a TPDO): after a fault (three cycles in a
        // row missed: the 6007h reaction) it resets it and enables again; the stream goes on.
        if rig.node().drive.state() == State::Fault {
            recoveries += 1;
            since_recovery = 0;
            for cw in [0x0080u16, 0x0006, 0x0007, 0x000F] {
                rig.write(0x6040, 0, &cw.to_le_bytes());
                rig.advance(1);
            }
        }
        // Tracking while the sine runs (not while the axis brakes at its abrupt end).
        if (100..=3000).contains(&k) && since_recovery > 1000 {
            let actual = i64::from(rig.node().drive.od().get::<i32>(0x6064, 0).unwrap());
            worst = worst.max((actual - i64::from(sine(k - 3))).abs());
        }
    }
    let hit: Vec<usize> = positions.iter().map(|p| rig.master.bus().fault(*p).unwrap().applied()).collect();
    let emcy = rig.emcy_codes();
    let state = rig.node().drive.state();
    let actual = rig.node().drive.od().get::<i32>(0x6064, 0).unwrap();
    let demand = rig.node().drive.od().get::<i32>(0x6062, 0).unwrap();
    assert!(matches!(state, State::OperationEnabled { .. }), "{state:?}, EMCY {emcy:04X?}");
    assert_eq!(demand, sine(3000), "the demand ends on the stream's last target");
    assert!((actual - demand).abs() <= 2, "ends at {actual}, target {demand}");
    rig.finish();
    notes.note(format!(
        "4000 cycles: {} RPDOs delayed past their SYNC, {} SYNCs duplicated, {} SYNCs dropped; \
         {recoveries} stream losses (3 missed cycles in a row: fault 8700h, reset by the master); \
         worst |6064h - target 3 cycles earlier| away from them {worst}; final error {}",
        hit[0],
        hit[1],
        hit[2],
        actual - demand
    ));
}

// --- 2c babbling node -----------------------------------------------------------------------

/// A node that sends random frames back to back during its flood windows.
struct Babbler {
    rng: XorShift64,
    floods: Vec<(Instant, Instant)>,
    next: Instant,
    queue: Option<CanFrame>,
    sent: u64,
    /// Frames on identifiers node 5 acts on (NMT, SYNC, its RPDOs, its SDO server, LSS).
    meaningful: u64,
}

impl Babbler {
    fn random_frame(&mut self) -> (CanFrame, Duration) {
        let bits = self.rng.next_u64();
        let id = (bits & 0x7FF) as u16;
        let len = ((bits >> 11) % 9) as usize;
        let bytes = self.rng.next_u64().to_le_bytes();
        let frame = CanFrame::new_standard(id, &bytes[..len]).expect("a frame");
        // 1 Mbit/s: 47 bits of frame overhead + 8 per byte, back to back.
        (frame, Duration::from_micros(47 + 8 * len as u64))
    }
}

impl canopen_drive_sim::bus::Node for Babbler {
    fn on_frame(&mut self, _: &CanFrame, _: Instant) {}

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let flood = self.floods.iter().find(|(from, to)| now >= *from && now < *to).copied();
        if let Some((_, to)) = flood {
            if now >= self.next && self.queue.is_none() {
                let (frame, time) = self.random_frame();
                let id = frame.standard_id().unwrap_or(0);
                if matches!(id, 0x000 | 0x080 | 0x205 | 0x305 | 0x405 | 0x505 | 0x605 | 0x7E5) {
                    self.meaningful += 1;
                }
                self.queue = Some(frame);
                self.sent += 1;
                self.next = now + time;
            }
            if self.next < to {
                return Some(self.next);
            }
        }
        let next = self.floods.iter().map(|(from, _)| *from).filter(|from| *from > now).min();
        if let Some(from) = next {
            self.next = from;
        }
        next
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.queue.take()
    }

    fn name(&self) -> String {
        "babbler".into()
    }
}

fn babbling_node(notes: &mut Notes) {
    let mut rig = Rig::standard();
    rig.turning(20_000);
    rig.node().record = true;
    let start = rig.now() + Duration::from_millis(10);
    let floods: Vec<(Instant, Instant)> = (0..20u64)
        .map(|i| {
            let from = start + Duration::from_millis(i * 250);
            (from, from + Duration::from_millis(200))
        })
        .collect();
    let babbler = Babbler {
        rng: XorShift64::new(0xBABB1E),
        floods: floods.clone(),
        next: start,
        queue: None,
        sent: 0,
        meaningful: 0,
    };
    let handle = rig.master.bus_mut().add_node(babbler);
    let ticks_before = rig.node().ticks;
    let t0 = rig.now();
    let mut sdo_retries = 0;
    for (i, (_, to)) in floods.iter().enumerate() {
        rig.master.bus_mut().run_until(*to).unwrap();
        // The pause: back to a known NMT state, then SDO must be served.
        rig.master.bus_mut().drain_received();
        rig.nmt(NmtCommand::EnterPreOperational);
        let (device_type, r1) = retry(3, || rig.master.sdo_upload(NODE, 0x1000, 0));
        assert_eq!(device_type, [0x92, 0x01, 0x02, 0x00]);
        let value = [10 + (i % 10) as u8];
        let (_, r2) = retry(3, || rig.master.sdo_download(NODE, LIMITED, 0, &value));
        let (back, r3) = retry(3, || rig.master.sdo_upload(NODE, LIMITED, 0));
        assert_eq!(back, value, "2001h after flood {i}");
        sdo_retries += r1 + r2 + r3;
        rig.nmt(NmtCommand::Start);
        assert!(rig.now() < *to + Duration::from_millis(50), "the SDO exchange fits the pause");
    }
    let babbler = rig.master.bus().node::<Babbler>(handle).unwrap();
    let (sent, meaningful) = (babbler.sent, babbler.meaningful);
    let elapsed = rig.now() - t0;
    let node = rig.node();
    let ticks = node.ticks - ticks_before;
    // Every tick at its instant: the records are exactly 1 ms apart.
    let late = node.records.windows(2).filter(|w| w[1].at - w[0].at != Duration::from_millis(1)).count();
    assert_eq!(late, 0, "ticks off their period during the floods");
    assert!(ticks >= elapsed.as_micros() / 1000, "{ticks} ticks in {elapsed:?}");
    let wall = (node.max_frame_wall, node.max_tick_wall);
    let state = node.drive.state();
    rig.finish();
    notes.note(format!(
        "{sent} random frames in 20 floods ({:.0} frames/s while flooding); {ticks} ticks in {} ms, none late; \
         SDO served in all 20 pauses ({sdo_retries} retries after a babbled frame had opened a transfer); \
         {meaningful} babbled frames were NMT, SYNC, RPDOs, SDO requests or LSS for the drive, which it \
         obeyed like any (state at the end {state:?})",
        sent as f64 / 4.0,
        elapsed.as_micros() / 1000
    ));
    println!(
        "    wall clock (debug build, this machine): longest on_frame {:?}, longest tick {:?}",
        wall.0, wall.1
    );
}

// --- 2d bus-off -----------------------------------------------------------------------------

fn bus_off_and_recovery(notes: &mut Notes) {
    for option in 0..=3i16 {
        let mut rig = Rig::standard();
        rig.write(0x1017, 0, &100u16.to_le_bytes());
        rig.write(0x6007, 0, &option.to_le_bytes());
        rig.turning(20_000);
        rig.node().record = true;
        rig.emcy_codes();
        let now = rig.now();
        {
            let node = rig.node();
            node.bus_off = true;
            node.drive.on_can_state(CanState::BusOff, now);
        }
        rig.advance(500);
        let lost = rig.node().lost_frames;
        let nmt = rig.node().drive.nmt_state();
        let state = rig.node().drive.state();
        let velocity = rig.node().motor.sample().velocity;
        let records = std::mem::take(&mut rig.node().records);
        let energised_after = records.iter().filter(|r| r.demand.drive_enabled).count();
        let now = rig.now();
        {
            let node = rig.node();
            node.bus_off = false;
            node.drive.on_can_state(CanState::ErrorActive, now);
        }
        rig.advance(5);
        let emcy = rig.emcy_codes();
        assert!(emcy.contains(&0x8140), "6007h = {option}: EMCY after recovery {emcy:04X?}");
        assert_eq!(nmt, canopen_drive::comm::NmtState::PreOperational, "1029h reaction");
        assert!(lost > 0, "frames lost while bus-off");
        match option {
            0 => assert!(matches!(state, State::OperationEnabled { .. }) && velocity > 15_000, "{state:?}"),
            1 => assert!(state == State::Fault && velocity.abs() < 50, "{state:?} {velocity}"),
            2 => {
                assert_eq!(state, State::SwitchOnDisabled);
                assert!(energised_after <= 1, "coasting: energy off at once ({energised_after} ticks)");
            }
            _ => assert!(
                matches!(state, State::SwitchOnDisabled | State::QuickStopActive) && velocity.abs() < 50,
                "{state:?} {velocity}"
            ),
        }
        rig.finish();
        notes.note(format!(
            "6007h = {option}: NMT {nmt:?}, {state:?}, velocity {velocity} after 500 ms, {energised_after} \
             energised ticks, {lost} frames lost while bus-off, EMCY after recovery {emcy:04X?}"
        ));
    }
}

// --- 2e/2f SYNC -----------------------------------------------------------------------------

fn sync_jitter(notes: &mut Notes) {
    let mut worst = [0i64; 2];
    for (case, jitter) in [(0usize, false), (1, true)] {
        let mut rig = csp_rig();
        let mut rng = XorShift64::new(0x5EED);
        for k in 0..2000u64 {
            let offset = if jitter { 250 + rng.next_u64() % 501 } else { 500 };
            csp_cycle(&mut rig, sine(k), offset);
            if k > 100 {
                let actual = i64::from(rig.node().drive.od().get::<i32>(0x6064, 0).unwrap());
                worst[case] = worst[case].max((actual - i64::from(sine(k.saturating_sub(3)))).abs());
            }
        }
        let emcy = rig.emcy_codes();
        assert!(emcy.is_empty(), "jitter {jitter}: EMCY {emcy:04X?}");
        assert!(matches!(rig.node().drive.state(), State::OperationEnabled { .. }));
        rig.finish();
    }
    assert!(worst[1] <= worst[0] + worst[0] / 2 + 10, "jitter degrades tracking: {worst:?}");
    notes.note(format!(
        "2000 cycles each: worst |6064h - target 3 cycles earlier| {} without jitter, {} with ±250 µs",
        worst[0], worst[1]
    ));
}

fn sync_loss(notes: &mut Notes) {
    for lost in 1..=3u64 {
        let mut rig = csp_rig();
        for k in 0..200u64 {
            csp_cycle(&mut rig, sine(k), 500);
        }
        rig.emcy_codes();
        // `lost` cycles whose SYNC never comes (the RPDOs still do).
        for k in 200..200 + lost {
            let start = rig.now();
            let mut data = 0x000Fu16.to_le_bytes().to_vec();
            data.extend_from_slice(&sine(k).to_le_bytes());
            rig.master.bus_mut().run_until(start + Duration::from_micros(300)).unwrap();
            rig.send(RPDO1, &data);
            rig.master.bus_mut().run_until(start + Duration::from_millis(1)).unwrap();
        }
        for k in 200 + lost..600 {
            csp_cycle(&mut rig, sine(k), 500);
        }
        let emcy = rig.emcy_codes();
        let state = rig.node().drive.state();
        if lost < 3 {
            assert!(matches!(state, State::OperationEnabled { .. }), "{lost} lost: {state:?}");
            assert!(!emcy.contains(&0x8700), "{lost} lost: EMCY {emcy:04X?}");
        } else {
            assert!(emcy.contains(&0x8700), "3 lost: EMCY {emcy:04X?}");
            // 6007h = 1 (default): a fault; its reaction (605Eh = 2) ramps down with 6085h.
            assert!(matches!(state, State::FaultReactionActive | State::Fault), "{state:?}");
            rig.advance(4000);
            assert_eq!(rig.node().drive.state(), State::Fault);
            assert!(rig.node().motor.sample().velocity.abs() < 50, "stopped");
        }
        rig.finish();
        notes.note(format!("{lost} consecutive SYNCs lost: {state:?}, EMCY {emcy:04X?}"));
    }
    // SYNC stops altogether with a communication cycle period: EMCY 8100h, cleared on return.
    let mut rig = csp_rig();
    rig.write(0x1006, 0, &1000u32.to_le_bytes());
    for k in 0..100u64 {
        csp_cycle(&mut rig, sine(k), 500);
    }
    rig.emcy_codes();
    rig.advance(20);
    let silent = rig.emcy_codes();
    assert!(silent.contains(&0x8100), "SYNC lost: EMCY {silent:04X?}");
    notes.note(format!("SYNC stopped with 1006h = 1 ms: EMCY {silent:04X?}"));
    rig.finish();
}

// --- 2g heartbeat loss ----------------------------------------------------------------------

fn heartbeat_loss(notes: &mut Notes) {
    const MASTER_ID: u16 = 1;
    for option in 0..=3i16 {
        let mut rig = Rig::standard();
        rig.write(0x1016, 1, &((u32::from(MASTER_ID) << 16) | 250).to_le_bytes());
        rig.write(0x6007, 0, &option.to_le_bytes());
        rig.send(0x700 + MASTER_ID, &[0x05]);
        rig.turning(20_000);
        for _ in 0..5 {
            rig.send(0x700 + MASTER_ID, &[0x05]);
            rig.advance(100);
        }
        rig.send(0x700 + MASTER_ID, &[0x05]);
        let last = rig.now();
        rig.emcy_codes();
        rig.node().record = true;
        // The master is gone.
        rig.advance(800);
        let received = rig.master.bus_mut().drain_received();
        let emcy_at = received
            .iter()
            .find(|r| r.frame.standard_id() == Some(EMCY) && r.frame.data()[..2] == [0x30, 0x81])
            .map(|r| r.time);
        let Some(emcy_at) = emcy_at else { panic!("6007h = {option}: no EMCY 8130h") };
        let delay = emcy_at - last;
        assert!(delay >= Duration::from_millis(250) && delay <= Duration::from_millis(252), "{delay:?}");
        let records = std::mem::take(&mut rig.node().records);
        let after: Vec<_> = records.iter().filter(|r| r.at > emcy_at).collect();
        let state = rig.node().drive.state();
        let velocity = rig.node().motor.sample().velocity;
        match option {
            0 => assert!(matches!(state, State::OperationEnabled { .. }) && velocity > 15_000),
            1 => assert!(state == State::Fault && velocity.abs() < 50, "{state:?} {velocity}"),
            2 => {
                assert!(after.iter().skip(1).all(|r| !r.demand.drive_enabled), "energy off at once");
                assert_eq!(state, State::SwitchOnDisabled);
            }
            _ => {
                assert!(velocity.abs() < 50, "{velocity}");
                // The quick-stop ramp: velocity demands fall every tick until 0.
                let falling = after.windows(2).all(|w| match (w[0].demand.setpoint, w[1].demand.setpoint) {
                    (Setpoint::Velocity(a), Setpoint::Velocity(b)) => b.abs() <= a.abs(),
                    _ => true,
                });
                assert!(falling, "quick-stop ramp");
            }
        }
        let stop_ms = after.iter().position(|r| r.sample.velocity.abs() < 50).map(|i| i as u64);
        rig.finish();
        notes.note(format!(
            "6007h = {option}: EMCY 8130h {} ms after the last heartbeat, {state:?}, velocity {velocity}, \
             at rest after {}",
            delay.as_micros() / 1000,
            stop_ms.map_or("never (keeps turning)".to_string(), |ms| format!("{ms} ms"))
        ));
    }
}

// --- 2h master gone mid-SDO ------------------------------------------------------------------

fn master_disappears_mid_sdo(notes: &mut Notes) {
    let sdo_rx = 0x600 + u16::from(NODE);
    let sdo_tx = 0x580 + u16::from(NODE);
    let [tl, th] = TEXT.to_le_bytes();
    let cases: [(&str, Vec<[u8; 8]>); 4] = [
        (
            "segmented download after 1 of 3 segments",
            vec![[0x21, tl, th, 0, 20, 0, 0, 0], [0x00, b'x', b'x', b'x', b'x', b'x', b'x', b'x']],
        ),
        ("segmented upload after the initiate", vec![[0x40, tl, th, 0, 0, 0, 0, 0]]),
        (
            "block download after 1 segment",
            vec![[0xC6, tl, th, 0, 30, 0, 0, 0], [0x01, b'y', b'y', b'y', b'y', b'y', b'y', b'y']],
        ),
        (
            "block upload waiting for the acknowledgement",
            vec![[0xA4, tl, th, 0, 4, 0, 0, 0], [0xA3, 0, 0, 0, 0, 0, 0, 0]],
        ),
    ];
    for (name, frames) in cases {
        let mut rig = Rig::standard();
        let before = rig.read(TEXT, 0);
        for data in &frames {
            rig.send(sdo_rx, data);
            rig.advance(1);
        }
        rig.master.bus_mut().drain_received();
        let gone = rig.now();
        rig.advance(1100);
        let aborts: Vec<_> = rig
            .master
            .bus_mut()
            .drain_received()
            .into_iter()
            .filter(|r| r.frame.standard_id() == Some(sdo_tx))
            .collect();
        assert_eq!(aborts.len(), 1, "{name}: {aborts:?}");
        let abort = aborts[0].frame.data().to_vec();
        assert_eq!(abort, [0x80, tl, th, 0, 0x00, 0x00, 0x04, 0x05], "{name}");
        let after = aborts[0].time - gone;
        assert!(
            after >= Duration::from_millis(999) && after <= Duration::from_millis(1001),
            "{name}: {after:?}"
        );
        assert_eq!(rig.read(TEXT, 0), before, "{name}: the old value is kept");
        rig.write(LIMITED, 0, &[12]);
        rig.finish();
        notes.note(format!(
            "{name}: abort 05040000h {} ms after the last frame; server free",
            after.as_micros() / 1000
        ));
    }
}

// --- Regression: RPDO value rules -----------------------------------------------------------

fn rpdo_value_rules(notes: &mut Notes) {
    // RPDO2 (CiA 402 default): 6040h + 6060h.
    let mut rig = Rig::new(|mut c| {
        c.device.drive_modes = 0b101; // pp and pv only
        c
    });
    rig.nmt(NmtCommand::Start);
    let rpdo2 = 0x300 + u16::from(NODE);
    let cases: [(&str, [u8; 3], bool); 5] = [
        ("mode 3 (pv, supported)", [0x06, 0x00, 3], true),
        ("mode 8 (csp, not in 6502h)", [0x0F, 0x00, 8], false),
        ("mode 5 (reserved)", [0x0F, 0x00, 5], false),
        ("mode -119 (manufacturer, unsupported)", [0x0F, 0x00, 0x89], false),
        ("mode 1 (pp, supported)", [0x07, 0x00, 1], true),
    ];
    let mut outcomes = Vec::new();
    for (name, data, applied) in cases {
        let before = (
            rig.node().drive.od().get::<u16>(0x6040, 0).unwrap(),
            rig.node().drive.od().get::<i8>(0x6060, 0).unwrap(),
        );
        rig.send(rpdo2, &data);
        rig.advance(2);
        let after = (
            rig.node().drive.od().get::<u16>(0x6040, 0).unwrap(),
            rig.node().drive.od().get::<i8>(0x6060, 0).unwrap(),
        );
        let expected = if applied { (u16::from_le_bytes([data[0], data[1]]), data[2] as i8) } else { before };
        assert_eq!(after, expected, "{name}");
        outcomes
            .push(format!("{name}: {}", if applied { "applied" } else { "refused, 6040h untouched too" }));
        rig.node().check_dictionary();
    }
    // The same through SDO, for comparison: refused with 06090030h.
    assert_eq!(
        rig.master.sdo_download(NODE, 0x6060, 0, &[8]),
        Err(SdoError::Abort(canopen_drive::AbortCode::InvalidValue))
    );
    rig.finish();
    notes.note(outcomes.join("; "));
}
