//! LSS (CiA 305, digest §12) on the virtual bus: unconfigured nodes, node-ID assignment by
//! identity, bit timing, store configuration, and fastscan finding several nodes that differ
//! only in their serial numbers.

use canopen_drive::comm::NmtState;
use canopen_drive::drive::BitRateChange;
use canopen_drive::od::DeviceInfo;
use canopen_drive::wire::lss::{BitRate, BitTiming};
use canopen_drive::{CanFrame, Config, Drive, Duration};
use canopen_drive_sim::bus::NodeHandle;
use canopen_drive_sim::{DriveNode, VirtualBus};
use embedded_can::Frame;

const REQUEST: u16 = 0x7E5;
const RESPONSE: u16 = 0x7E4;
const VENDOR: u32 = 0x0000_0ABC;
const PRODUCT: u32 = 0x0004_0002;
const REVISION: u32 = 0x0001_0003;

fn device(serial: u32) -> DeviceInfo {
    DeviceInfo {
        vendor_id: VENDOR,
        product_code: PRODUCT,
        revision_number: REVISION,
        serial_number: serial,
        ..DeviceInfo::servo_drive()
    }
}

fn add(bus: &mut VirtualBus, node_id: u8, serial: u32, lss_store: bool) -> NodeHandle {
    let config = Config { device: device(serial), lss_store, ..Config::new(node_id) };
    bus.add_node(DriveNode::new(Drive::new(config).unwrap(), Duration::from_millis(1)))
}

fn drive(bus: &mut VirtualBus, node: NodeHandle) -> &mut Drive {
    &mut bus.node_mut::<DriveNode>(node).unwrap().drive
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new_standard(id, data).unwrap()
}

/// Sends an LSS request; returns the LSS responses and every other frame.
fn lss(bus: &mut VirtualBus, request: [u8; 8]) -> (Vec<[u8; 8]>, Vec<CanFrame>) {
    bus.send(frame(REQUEST, &request));
    bus.advance(Duration::from_millis(1)).unwrap();
    let frames = bus.drain_received_frames();
    let responses = frames
        .iter()
        .filter(|f| f.standard_id() == Some(RESPONSE))
        .map(|f| f.data().try_into().unwrap())
        .collect();
    let others = frames.into_iter().filter(|f| f.standard_id() != Some(RESPONSE)).collect();
    (responses, others)
}

fn cmd(cs: u8, bytes: &[u8]) -> [u8; 8] {
    let mut f = [0u8; 8];
    f[0] = cs;
    f[1..1 + bytes.len()].copy_from_slice(bytes);
    f
}

fn selective(bus: &mut VirtualBus, serial: u32) -> Vec<[u8; 8]> {
    let mut responses = Vec::new();
    for (cs, value) in [(0x40, VENDOR), (0x41, PRODUCT), (0x42, REVISION), (0x43, serial)] {
        responses.extend(lss(bus, cmd(cs, &value.to_le_bytes())).0);
    }
    responses
}

#[test]
fn an_unconfigured_node_runs_only_lss_until_it_gets_a_node_id() {
    let mut bus = VirtualBus::new();
    let node = add(&mut bus, 0xFF, 1234, false);
    bus.advance(Duration::from_millis(100)).unwrap();
    assert!(bus.drain_received_frames().is_empty(), "no boot-up without a node-ID");
    // NMT and SDO to any node are not served.
    bus.send(frame(0x000, &[0x01, 0x00]));
    bus.send(frame(0x67F, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]));
    bus.advance(Duration::from_millis(10)).unwrap();
    assert!(bus.drain_received_frames().is_empty());
    assert_eq!(drive(&mut bus, node).nmt_state(), NmtState::Initialising);

    // Identify non-configured remote slave (0x4C) is answered with 0x50.
    assert_eq!(lss(&mut bus, cmd(0x4C, &[])).0, vec![cmd(0x50, &[])]);
    // Configuration by identity, node-ID 7.
    assert_eq!(selective(&mut bus, 1234), vec![cmd(0x44, &[])]);
    assert_eq!(lss(&mut bus, cmd(0x11, &[7])).0, vec![cmd(0x11, &[0])]);
    assert_eq!(lss(&mut bus, cmd(0x11, &[128])).0, vec![cmd(0x11, &[1])], "out of range");
    assert_eq!(lss(&mut bus, cmd(0x5E, &[])).0, vec![cmd(0x5E, &[0xFF])], "active node-ID unchanged");
    // Back to waiting: the node continues its start-up with node-ID 7.
    let (responses, others) = lss(&mut bus, cmd(0x04, &[0]));
    assert!(responses.is_empty());
    assert_eq!(others, vec![frame(0x707, &[0x00])]);
    bus.send(frame(0x607, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]));
    bus.advance(Duration::from_millis(1)).unwrap();
    let answer = bus.drain_received_frames();
    assert_eq!(answer, vec![frame(0x587, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])]);
    assert_eq!(lss(&mut bus, cmd(0x4C, &[])).0, Vec::<[u8; 8]>::new(), "configured now");
}

#[test]
fn a_configured_node_takes_a_new_node_id_at_reset_communication() {
    let mut bus = VirtualBus::new();
    let node = add(&mut bus, 5, 42, false);
    bus.advance(Duration::ZERO).unwrap();
    bus.drain_received_frames();
    assert_eq!(selective(&mut bus, 41), Vec::<[u8; 8]>::new(), "wrong serial");
    assert_eq!(selective(&mut bus, 42), vec![cmd(0x44, &[])]);
    for (cs, value) in [(0x5A, VENDOR), (0x5B, PRODUCT), (0x5C, REVISION), (0x5D, 42)] {
        assert_eq!(lss(&mut bus, cmd(cs, &[])).0, vec![cmd(cs, &value.to_le_bytes())]);
    }
    assert_eq!(lss(&mut bus, cmd(0x11, &[9])).0, vec![cmd(0x11, &[0])]);
    lss(&mut bus, cmd(0x04, &[0]));
    assert_eq!(drive(&mut bus, node).node_id(), 5, "pending until reset communication");
    bus.send(frame(0x000, &[0x82, 5]));
    bus.advance(Duration::ZERO).unwrap();
    assert_eq!(bus.drain_received_frames(), vec![frame(0x709, &[0x00])]);
    assert_eq!(drive(&mut bus, node).node_id(), 9);
    assert_eq!(drive(&mut bus, node).od().get::<u32>(0x1200, 1), Ok(0x609), "$NODEID objects follow");
}

#[test]
fn bit_timing_and_store_configuration() {
    let mut bus = VirtualBus::new();
    let without_store = add(&mut bus, 5, 1, false);
    let with_store = add(&mut bus, 6, 2, true);
    bus.advance(Duration::ZERO).unwrap();
    bus.drain_received_frames();
    // Both nodes in configuration: each answers.
    assert_eq!(lss(&mut bus, cmd(0x04, &[1])).0, Vec::<[u8; 8]>::new());
    assert_eq!(lss(&mut bus, cmd(0x13, &[0, 2])).0, vec![cmd(0x13, &[0]); 2], "500 kbit/s");
    assert_eq!(lss(&mut bus, cmd(0x13, &[0, 9])).0, vec![cmd(0x13, &[1]); 2], "automatic: not supported");
    let mut stores = lss(&mut bus, cmd(0x17, &[])).0;
    stores.sort();
    assert_eq!(stores, vec![cmd(0x17, &[0]), cmd(0x17, &[1])]);
    assert_eq!(
        drive(&mut bus, with_store).take_lss_store(),
        Some((6, Some(BitTiming { table_selector: 0, table_index: 2 })))
    );
    assert_eq!(drive(&mut bus, without_store).take_lss_store(), None);
    // Activate bit timing: no answer, the board is told.
    assert!(lss(&mut bus, cmd(0x15, &100u16.to_le_bytes())).0.is_empty());
    let change =
        BitRateChange { bit_timing: BitTiming { table_selector: 0, table_index: 2 }, switch_delay_ms: 100 };
    assert_eq!(drive(&mut bus, with_store).take_bit_rate_change(), Some(change));
}

#[test]
fn configure_bit_timing_accepts_only_the_rates_the_board_can_run() {
    let mut bus = VirtualBus::new();
    // A board whose CAN clock divides into 500 and 250 kbit/s only.
    let config =
        Config { device: device(3), bit_rates: &[BitRate::Kbit500, BitRate::Kbit250], ..Config::new(5) };
    let node = bus.add_node(DriveNode::new(Drive::new(config).unwrap(), Duration::from_millis(1)));
    bus.advance(Duration::ZERO).unwrap();
    bus.drain_received_frames();
    lss(&mut bus, cmd(0x04, &[1]));
    assert_eq!(lss(&mut bus, cmd(0x13, &[0, 3])).0, vec![cmd(0x13, &[0])], "250 kbit/s");
    assert_eq!(lss(&mut bus, cmd(0x13, &[0, 1])).0, vec![cmd(0x13, &[1])], "800 kbit/s: not supported");
    assert_eq!(lss(&mut bus, cmd(0x13, &[0, 0])).0, vec![cmd(0x13, &[1])], "1000 kbit/s: not supported");
    assert_eq!(lss(&mut bus, cmd(0x13, &[1, 3])).0, vec![cmd(0x13, &[1])], "another table");
    // The refusals left the accepted rate pending: activation switches to 250 kbit/s.
    lss(&mut bus, cmd(0x15, &50u16.to_le_bytes()));
    let change = drive(&mut bus, node).take_bit_rate_change().map(|c| c.bit_timing.standard_rate());
    assert_eq!(change, Some(Some(BitRate::Kbit250)));
}

#[test]
fn bit_timing_takes_the_rates_the_board_declares() {
    // The rates of `Config::bit_rates` and no other: the EDS lists the same.
    let mut bus = VirtualBus::new();
    let config =
        Config { device: device(1), bit_rates: &[BitRate::Kbit20, BitRate::Kbit800], ..Config::new(5) };
    let node = bus.add_node(DriveNode::new(Drive::new(config).unwrap(), Duration::from_millis(1)));
    bus.advance(Duration::ZERO).unwrap();
    bus.drain_received_frames();
    lss(&mut bus, cmd(0x04, &[1]));
    for (index, status) in [(7, 0), (1, 0), (2, 1), (0, 1), (5, 1), (9, 1)] {
        assert_eq!(lss(&mut bus, cmd(0x13, &[0, index])).0, vec![cmd(0x13, &[status])], "index {index}");
    }
    let mut eds = String::new();
    drive(&mut bus, node).write_eds(&Default::default(), &mut eds).unwrap();
    assert!(eds.contains("BaudRate_10=0\nBaudRate_20=1\nBaudRate_50=0\nBaudRate_125=0\n"), "{eds}");
    assert!(eds.contains("BaudRate_500=0\nBaudRate_800=1\nBaudRate_1000=0\n"), "{eds}");
    assert!(eds.contains("\nLSS_Supported=1\n"));
}

/// One fastscan run (digest §12.4) by a master: returns the identity found, if any.
fn fastscan(bus: &mut VirtualBus) -> Option<[u32; 4]> {
    let probe = |bus: &mut VirtualBus, id: u32, bit: u8, sub: u8, next: u8| -> bool {
        let mut f = cmd(0x51, &id.to_le_bytes());
        f[5] = bit;
        f[6] = sub;
        f[7] = next;
        !lss(bus, f).0.is_empty()
    };
    if !probe(bus, 0, 0x80, 0, 0) {
        return None;
    }
    let mut id = [0u32; 4];
    for sub in 0..4u8 {
        for bit in (0..32u8).rev() {
            // Does any node have 0 at this bit (higher bits as found)?
            if !probe(bus, id[sub as usize], bit, sub, sub) {
                id[sub as usize] |= 1 << bit;
            }
        }
        let next = (sub + 1) % 4;
        if !probe(bus, id[sub as usize], 0, sub, next) {
            return None;
        }
    }
    Some(id)
}

#[test]
fn fastscan_finds_each_unconfigured_node() {
    let mut bus = VirtualBus::new();
    let serials = [0x0000_1111, 0x0000_0222, 0x8000_0001];
    let nodes: Vec<NodeHandle> = serials.iter().map(|&s| add(&mut bus, 0xFF, s, false)).collect();
    let configured = add(&mut bus, 3, 0x0000_0001, false);
    bus.advance(Duration::ZERO).unwrap();
    bus.drain_received_frames();
    let mut found = Vec::new();
    for node_id in 20..23u8 {
        let id = fastscan(&mut bus).expect("a node answers");
        assert_eq!(id[..3], [VENDOR, PRODUCT, REVISION]);
        found.push(id[3]);
        // The node found is in configuration: give it a node-ID, back to waiting.
        assert_eq!(lss(&mut bus, cmd(0x11, &[node_id])).0, vec![cmd(0x11, &[0])]);
        let (_, boot) = lss(&mut bus, cmd(0x04, &[0]));
        assert_eq!(boot, vec![frame(0x700 + u16::from(node_id), &[0])]);
    }
    assert_eq!(fastscan(&mut bus), None, "every node configured");
    found.sort();
    let mut expected = serials.to_vec();
    expected.sort();
    assert_eq!(found, expected);
    let ids: Vec<u8> = nodes.iter().map(|&n| drive(&mut bus, n).node_id()).collect();
    assert!(ids.iter().all(|id| (20..23).contains(id)), "{ids:?}");
    assert_eq!(drive(&mut bus, configured).node_id(), 3);
}
