//! Test harness: one drive (node 5, with the test objects) on the virtual bus, and a master
//! port that sends frames and sees everything the drive sends.
#![allow(dead_code)]

pub mod objects;
pub mod profile;

use canopen_drive::{CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::{bus::NodeHandle, DriveNode, VirtualBus};
use embedded_can::Frame;

pub use objects::*;

pub const NODE: u8 = 5;
pub const SDO_RX: u16 = 0x600 + NODE as u16;
pub const SDO_TX: u16 = 0x580 + NODE as u16;
pub const ERROR_CONTROL: u16 = 0x700 + NODE as u16;

pub type TestDrive = Drive<TestHooks>;

/// Node 5 with the test objects, ticked every millisecond against the simulated motor, on a
/// virtual bus whose master port is the test.
pub struct Bench {
    pub bus: VirtualBus,
    node: NodeHandle,
}

impl Bench {
    /// A booted drive; the boot-up frame has been consumed (and checked).
    pub fn new() -> Self {
        Bench::with_config(|config| config)
    }

    /// A booted drive whose configuration `adjust` changed.
    pub fn with_config(adjust: impl FnOnce(Config) -> Config) -> Self {
        Bench::with_config_and_tick(adjust, Duration::from_millis(1))
    }

    /// A booted drive whose configuration `adjust` changed, ticked every `tick` (the
    /// configuration's tick rate must agree).
    pub fn with_config_and_tick(adjust: impl FnOnce(Config) -> Config, tick: Duration) -> Self {
        let config = adjust(Config { manufacturer_objects: &TEST_OBJECTS, ..Config::new(NODE) });
        let drive = Drive::with_hooks(config, TestHooks::default()).unwrap();
        let mut bus = VirtualBus::new();
        let node = bus.add_node(DriveNode::new(drive, tick));
        let mut bench = Bench { bus, node };
        let boot = bench.advance(Duration::ZERO);
        assert_eq!(boot, vec![frame(ERROR_CONTROL, &[0x00])]);
        bench
    }

    /// The drive under test.
    pub fn drive(&mut self) -> &mut TestDrive {
        &mut self.bus.node_mut::<DriveNode<TestHooks>>(self.node).unwrap().drive
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.bus.now()
    }

    /// Sends `frame` from the master and returns what the bus carries in reply at this instant.
    pub fn send(&mut self, frame: CanFrame) -> Vec<CanFrame> {
        self.bus.send(frame);
        self.bus.settle().unwrap();
        self.bus.drain_received_frames()
    }

    /// Sends an SDO request and returns the data of the drive's SDO responses.
    pub fn sdo(&mut self, request: &[u8]) -> Vec<[u8; 8]> {
        let frames = self.send(frame(SDO_RX, request));
        sdo_data(&frames)
    }

    /// Sends an SDO request that must get exactly one response, and returns it.
    pub fn sdo1(&mut self, request: &[u8]) -> [u8; 8] {
        let responses = self.sdo(request);
        assert_eq!(responses.len(), 1, "request {request:02X?} got {responses:02X?}");
        responses[0]
    }

    /// Lets `span` of virtual time pass; returns the frames sent meanwhile.
    pub fn advance(&mut self, span: Duration) -> Vec<CanFrame> {
        self.bus.advance(span).unwrap();
        self.bus.settle().unwrap();
        self.bus.drain_received_frames()
    }

    /// Like [`advance`](Self::advance), with the time of each frame.
    pub fn advance_timed(&mut self, span: Duration) -> Vec<(Instant, CanFrame)> {
        self.bus.advance(span).unwrap();
        self.bus.settle().unwrap();
        self.bus.drain_received().into_iter().map(|r| (r.time, r.frame)).collect()
    }
}

/// With `CANOPEN_DRIVE_TRACE_DIR` set, every bench leaves the frames its master sent (with
/// their times) in `<dir>/<test name>-<n>.trace`: the seeds of the fuzz targets
/// (`fuzz/src/bin/seeds.rs`). One line per frame: `time_us id D<len>|R<len> hex`.
impl Drop for Bench {
    fn drop(&mut self) {
        let Some(dir) = std::env::var_os("CANOPEN_DRIVE_TRACE_DIR") else { return };
        let mut text = String::new();
        for record in self.bus.trace().iter().filter(|r| r.from == canopen_drive_sim::Port::Master) {
            let frame = &record.frame;
            let kind = if frame.is_remote_frame() { 'R' } else { 'D' };
            let hex: String = frame.data().iter().map(|b| format!("{b:02X}")).collect();
            let id = frame.standard_id().unwrap_or(0);
            text.push_str(&format!("{} {id:03X} {kind}{} {hex}\n", record.time.as_micros(), frame.dlc()));
        }
        let name = std::thread::current().name().unwrap_or("bench").replace("::", "-");
        static COUNT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let path = std::path::Path::new(&dir).join(format!("{name}-{}-{n}.trace", std::process::id()));
        // Best effort: a trace that cannot be written only means one seed less.
        let _ = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(path, text));
    }
}

pub fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new_standard(id, data).unwrap()
}

pub fn sdo_data(frames: &[CanFrame]) -> Vec<[u8; 8]> {
    frames
        .iter()
        .filter(|f| f.standard_id() == Some(SDO_TX))
        .map(|f| f.data().try_into().expect("SDO responses have DLC 8"))
        .collect()
}

/// The abort frame the drive must send.
pub fn abort(index: u16, sub: u8, code: u32) -> [u8; 8] {
    let [lo, hi] = index.to_le_bytes();
    let c = code.to_le_bytes();
    [0x80, lo, hi, sub, c[0], c[1], c[2], c[3]]
}

/// An SDO request/response header: command, index, sub, then four data bytes.
pub fn req(command: u8, index: u16, sub: u8, data: [u8; 4]) -> [u8; 8] {
    let [lo, hi] = index.to_le_bytes();
    [command, lo, hi, sub, data[0], data[1], data[2], data[3]]
}

/// CRC-16/XMODEM, computed independently of the crate's nibble-table version.
pub fn crc16(data: &[u8]) -> u16 {
    let mut crc = 0u16;
    for &b in data {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
        }
    }
    crc
}
