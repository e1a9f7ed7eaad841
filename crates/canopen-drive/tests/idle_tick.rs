//! An idle drive's tick does only what changed inputs require (the tick checks the sample and
//! the dictionary's revision, and repeats its last demand while both stand), and yet every
//! input reaches the outputs at the same tick as ever: a value written between two ticks by
//! SDO or by the firmware, a new sample, and the TPDOs' change detection and event timers.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use canopen_drive::hal::{DigitalInputs, HardwareFaults};
use canopen_drive::{CanFrame, Config, Instant};
use common::{Node, NODE};
use embedded_can::Frame as _;

/// Statusword state bits (CiA 402 Table 30): mask 006Fh.
const READY_TO_SWITCH_ON: u16 = 0x21;
const SWITCHED_ON: u16 = 0x23;
const OPERATION_ENABLED: u16 = 0x27;
const SWITCH_ON_DISABLED: u16 = 0x40;

const TPDO1: u16 = 0x180 + NODE as u16;
const EMCY: u16 = 0x80 + NODE as u16;

fn idle(node: &mut Node, ticks: usize) {
    for _ in 0..ticks {
        node.tick();
    }
}

fn start_node(node: &mut Node) {
    node.send(&CanFrame::new_standard(0x000, &[0x01, NODE]).unwrap());
}

#[test]
fn commands_written_between_idle_ticks_act_at_the_next_tick() {
    let mut node = Node::new(Config::new(NODE));
    idle(&mut node, 20);
    assert_eq!(node.statusword() & 0x6F, SWITCH_ON_DISABLED);
    for (command, state) in [(0x06, READY_TO_SWITCH_ON), (0x07, SWITCHED_ON), (0x0F, OPERATION_ENABLED)] {
        idle(&mut node, 5);
        node.write(0x6040, 0, command, 2).unwrap();
        let demand = node.tick();
        assert_eq!(node.statusword() & 0x6F, state, "one tick after controlword {command:#06x}");
        assert_eq!(demand.high_voltage, state != READY_TO_SWITCH_ON, "after {command:#06x}");
        assert_eq!(demand.drive_enabled, state == OPERATION_ENABLED, "after {command:#06x}");
    }
    // And back: disable voltage from Operation enabled (an idle drive again from there).
    node.write(0x6040, 0, 0x00, 2).unwrap();
    let demand = node.tick();
    assert_eq!(node.statusword() & 0x6F, SWITCH_ON_DISABLED);
    assert!(!demand.drive_enabled && !demand.high_voltage);
}

#[test]
fn a_controlword_from_an_rpdo_between_idle_ticks_acts_at_the_next_tick() {
    let mut node = Node::new(Config::new(NODE));
    start_node(&mut node);
    idle(&mut node, 20);
    node.take_frames();
    // RPDO1 (controlword, asynchronous): a plain copy into the dictionary, no SDO rule.
    node.send(&CanFrame::new_standard(0x200 + u16::from(NODE), &[0x06, 0x00]).unwrap());
    node.tick();
    assert_eq!(node.statusword() & 0x6F, READY_TO_SWITCH_ON);
    let tpdo1: Vec<_> = node.take_frames().into_iter().filter(|f| f.standard_id() == Some(TPDO1)).collect();
    assert_eq!(tpdo1.len(), 1);
    assert_eq!(tpdo1[0].data(), [0x21, 0x02]);
}

#[test]
fn the_sample_of_an_idle_tick_is_read_at_that_tick() {
    let mut node = Node::new(Config::new(NODE));
    idle(&mut node, 20);
    node.sample.position = 1234;
    node.sample.velocity = -56;
    node.tick();
    assert_eq!(node.read(0x6064, 0), Ok(1234));
    assert_eq!(node.read(0x6063, 0), Ok(1234));
    assert_eq!(node.read(0x606C, 0), Ok((-56i32) as u32));
    idle(&mut node, 5);
    node.sample.inputs = DigitalInputs::POSITIVE_LIMIT;
    node.tick();
    assert_eq!(node.read(0x60FD, 0).map(|v| v & 0x0F), Ok(0x02));
    idle(&mut node, 5);
    node.sample.faults = HardwareFaults::OVER_CURRENT;
    node.take_frames();
    node.tick();
    node.poll();
    // Fault reaction active (xxxx xxxx x0xx 1111) at the tick that sampled the fault.
    assert_eq!(node.statusword() & 0x4F, 0x0F);
    let emcy: Vec<_> = node.take_frames().into_iter().filter(|f| f.standard_id() == Some(EMCY)).collect();
    assert_eq!(emcy.len(), 1);
    assert_eq!(emcy[0].data()[..2], [0x10, 0x23]);
}

#[test]
fn a_device_side_write_between_idle_ticks_acts_at_the_next_tick() {
    let mut node = Node::new(Config::new(NODE));
    idle(&mut node, 20);
    node.drive.od_mut().set::<i8>(0x6060, 0, 3).unwrap();
    node.tick();
    assert_eq!(node.read(0x6061, 0), Ok(3));
    idle(&mut node, 5);
    node.drive.od_mut().set::<u16>(0x6040, 0, 0x06).unwrap();
    node.tick();
    assert_eq!(node.statusword() & 0x6F, READY_TO_SWITCH_ON);
}

#[test]
fn tpdos_of_an_idle_drive_keep_their_change_detection_and_event_timer() {
    let mut node = Node::new(Config::new(NODE));
    // TPDO1 (statusword, event-driven): an event timer of 10 ms.
    node.write(0x1800, 5, 10, 2).unwrap();
    start_node(&mut node);
    let tpdo1 = |frames: Vec<CanFrame>| -> Vec<Vec<u8>> {
        frames.into_iter().filter(|f| f.standard_id() == Some(TPDO1)).map(|f| f.data().to_vec()).collect()
    };
    // Sent once on entering Operational (at the next tick), then every 10 ms: the drive is only
    // ticked here (never polled), as before this tick learnt to idle.
    let mut sent = Vec::new();
    for _ in 0..45 {
        node.tick();
        for data in tpdo1(node.take_frames()) {
            sent.push((node.now, data));
        }
    }
    let times: Vec<u64> = sent.iter().map(|(t, _)| t.as_micros() / 1000).collect();
    assert_eq!(times, [1, 11, 21, 31, 41]);
    assert!(sent.iter().all(|(_, data)| data[..] == [0x40, 0x02]), "{sent:02X?}");
    // A change of the statusword goes out at the tick that made it.
    node.write(0x6040, 0, 0x06, 2).unwrap();
    node.tick();
    assert_eq!(tpdo1(node.take_frames()), [vec![0x21, 0x02]]);
    assert_eq!(node.now, Instant::from_millis(46));
}
