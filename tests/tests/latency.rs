//! Latency of the two entry points, call by call (issue 8 item 3): no virtual bus and no
//! clock in between, so "the same call" and "the next tick" are exact.
//!
//! - A SYNC queues the synchronous TPDOs in the `on_frame` call that handled it (before any
//!   tick or poll).
//! - A synchronous RPDO is applied by the first tick after the SYNC that follows it, never
//!   earlier and never later.
//! - A controlword command is reported in the statusword by the tick that processed it (one
//!   tick from "enable operation" to "Operation enabled").

use canopen_drive::hal::Sample;
use canopen_drive::{CanFrame, Config, Drive, Instant};
use embedded_can::Frame;

const NODE: u16 = 5;

struct Node {
    drive: Drive,
    now: Instant,
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new_standard(id, data).unwrap()
}

impl Node {
    /// Node 5, booted and started (NMT Operational), boot-up and start-up frames drained.
    fn operational() -> Self {
        let mut node =
            Node { drive: Drive::new(Config::new(NODE as u8)).unwrap(), now: Instant::from_millis(0) };
        node.drive.poll(node.now);
        node.drain();
        node.drive.on_frame(&frame(0x000, &[0x01, NODE as u8]), node.now);
        node.tick();
        node.drain();
        node
    }

    fn drain(&mut self) -> Vec<CanFrame> {
        std::iter::from_fn(|| self.drive.pop_tx()).collect()
    }

    fn tick(&mut self) {
        self.now = self.now + canopen_drive::Duration::from_micros(250);
        let sample = Sample { dc_link_millivolts: 48_000, ..Sample::default() };
        self.drive.tick(self.now, &sample);
    }

    /// An expedited SDO download, answered in the same call.
    fn write(&mut self, index: u16, sub: u8, value: &[u8]) {
        let command = 0x23 | ((4 - value.len() as u8) << 2);
        let mut data = [command, index as u8, (index >> 8) as u8, sub, 0, 0, 0, 0];
        data[4..4 + value.len()].copy_from_slice(value);
        self.drive.on_frame(&frame(0x600 + NODE, &data), self.now);
        let answer: Vec<_> =
            self.drain().into_iter().filter(|f| f.standard_id() == Some(0x580 + NODE)).collect();
        assert_eq!(answer.len(), 1, "one SDO answer, in the same call");
        assert_eq!(answer[0].data()[0], 0x60, "{index:04X}h sub {sub} written: {:02X?}", answer[0].data());
    }

    fn controlword(&mut self, value: u16) {
        self.write(0x6040, 0, &value.to_le_bytes());
    }

    fn od_u16(&self, index: u16) -> u16 {
        self.drive.od().get::<u16>(index, 0).unwrap()
    }

    fn statusword(&self) -> u16 {
        self.od_u16(0x6041) & 0x006F
    }
}

#[test]
fn sync_queues_the_synchronous_tpdos_in_the_call_that_handled_it() {
    let mut node = Node::operational();
    // TPDO1 (statusword, default mapping) synchronous, every SYNC.
    node.write(0x1800, 2, &[1]);
    node.tick();
    let before = node.drain();
    assert!(
        !before.iter().any(|f| f.standard_id() == Some(0x180 + NODE)),
        "no TPDO1 before the SYNC: {before:?}"
    );
    node.drive.on_frame(&frame(0x080, &[]), node.now);
    let sent = node.drain();
    let tpdo1: Vec<_> = sent.iter().filter(|f| f.standard_id() == Some(0x180 + NODE)).collect();
    assert_eq!(tpdo1.len(), 1, "TPDO1 queued by the SYNC's on_frame call: {sent:?}");
    assert_eq!(tpdo1[0].data()[..2], node.od_u16(0x6041).to_le_bytes());
}

#[test]
fn synchronous_rpdo_is_applied_by_the_first_tick_after_the_next_sync() {
    let mut node = Node::operational();
    // RPDO1 (controlword, default mapping) synchronous.
    node.write(0x1400, 2, &[1]);
    node.tick();
    assert_eq!(node.statusword(), 0x0040, "Switch on disabled");
    node.drive.on_frame(&frame(0x200 + NODE, &[0x06, 0x00]), node.now);
    for _ in 0..5 {
        node.tick();
        assert_eq!(node.od_u16(0x6040), 0, "not before the SYNC");
        assert_eq!(node.statusword(), 0x0040);
    }
    node.drive.on_frame(&frame(0x080, &[]), node.now);
    assert_eq!(node.od_u16(0x6040), 0, "applied by the tick, not by the SYNC frame");
    node.tick();
    assert_eq!(node.od_u16(0x6040), 0x0006, "applied by the first tick after the SYNC");
    assert_eq!(node.statusword(), 0x0021, "and acted on in that tick: Ready to switch on");
}

#[test]
fn enable_operation_is_reported_by_the_tick_that_processed_it() {
    let mut node = Node::operational();
    node.controlword(0x0006);
    node.tick();
    assert_eq!(node.statusword(), 0x0021, "Ready to switch on after one tick");
    node.controlword(0x0007);
    node.tick();
    assert_eq!(node.statusword(), 0x0023, "Switched on after one tick");
    node.controlword(0x000F);
    assert_eq!(node.statusword(), 0x0023, "nothing happens without a tick");
    node.tick();
    assert_eq!(node.statusword(), 0x0027, "Operation enabled after one tick");
}
