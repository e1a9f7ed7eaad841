//! A drive driven by hand for the tests of this crate: SDO requests answered at once, one
//! 1 ms tick at a time against a sample the test sets, and the other frames the drive sends
//! kept in order.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

use canopen_drive::hal::{Demand, Sample};
use canopen_drive::{CanFrame, Config, Drive, Instant};
use embedded_can::Frame as _;

pub const NODE: u8 = 5;
pub const SDO_RX: u16 = 0x600 + NODE as u16;
pub const SDO_TX: u16 = 0x580 + NODE as u16;

pub struct Node {
    pub drive: Drive,
    pub now: Instant,
    /// What the next tick samples (the motor at rest at 0, 48 V on the DC link, at first).
    pub sample: Sample,
    /// The frames the drive sent other than SDO answers, oldest first.
    pub frames: Vec<CanFrame>,
}

impl Node {
    /// A booted drive (boot-up sent and dropped), NMT Pre-operational, at time 0.
    pub fn new(config: Config) -> Self {
        let sample = Sample { dc_link_millivolts: 48_000, ..Sample::default() };
        let mut node = Node {
            drive: Drive::new(config).unwrap(),
            now: Instant::from_micros(0),
            sample,
            frames: Vec::new(),
        };
        node.drive.poll(node.now);
        while node.drive.pop_tx().is_some() {}
        node
    }

    /// A drive whose set-points written by SDO count as the cycle's new one (as by RPDO).
    pub fn with_sdo_set_points() -> Self {
        let mut config = Config::new(NODE);
        config.profile.cyclic.sdo_set_points = true;
        Node::new(config)
    }

    /// Sends `frame` to the drive now; the frames it sends are kept.
    pub fn send(&mut self, frame: &CanFrame) {
        self.drive.on_frame(frame, self.now);
        self.collect();
    }

    /// One SDO request; the server's answer (8 bytes).
    pub fn sdo(&mut self, request: [u8; 8]) -> [u8; 8] {
        let frame = CanFrame::new_standard(SDO_RX, &request).unwrap();
        self.send(&frame);
        let at = self.frames.iter().rposition(|f| f.standard_id() == Some(SDO_TX)).expect("an SDO answer");
        self.frames.remove(at).data().try_into().unwrap()
    }

    /// Expedited upload: the value, or the abort code.
    pub fn read(&mut self, index: u16, sub: u8) -> Result<u32, u32> {
        let [lo, hi] = index.to_le_bytes();
        let answer = self.sdo([0x40, lo, hi, sub, 0, 0, 0, 0]);
        let value = u32::from_le_bytes([answer[4], answer[5], answer[6], answer[7]]);
        match answer[0] {
            0x80 => Err(value),
            command if command & 0xE0 == 0x40 => Ok(value),
            other => panic!("unexpected SDO answer {other:#04x}"),
        }
    }

    /// Expedited download of `len` bytes: Ok, or the abort code.
    pub fn write(&mut self, index: u16, sub: u8, value: u32, len: usize) -> Result<(), u32> {
        let [lo, hi] = index.to_le_bytes();
        let command = 0x23 | (((4 - len) as u8) << 2);
        let v = value.to_le_bytes();
        let answer = self.sdo([command, lo, hi, sub, v[0], v[1], v[2], v[3]]);
        match answer[0] {
            0x60 => Ok(()),
            0x80 => Err(u32::from_le_bytes([answer[4], answer[5], answer[6], answer[7]])),
            other => panic!("unexpected SDO answer {other:#04x}"),
        }
    }

    /// One 1 ms tick with [`Self::sample`]; the frames it sends are kept.
    pub fn tick(&mut self) -> Demand {
        self.now = Instant::from_micros(self.now.as_micros() + 1000);
        let demand = self.drive.tick(self.now, &self.sample);
        self.collect();
        demand
    }

    /// The drive's timers and queued frames at [`Self::now`] (EMCYs go out here); the frames it
    /// sends are kept.
    pub fn poll(&mut self) {
        self.drive.poll(self.now);
        self.collect();
    }

    pub fn statusword(&mut self) -> u16 {
        self.read(0x6041, 0).unwrap() as u16
    }

    /// The frames sent since the last call.
    pub fn take_frames(&mut self) -> Vec<CanFrame> {
        core::mem::take(&mut self.frames)
    }

    fn collect(&mut self) {
        while let Some(frame) = self.drive.pop_tx() {
            self.frames.push(frame);
        }
    }
}
