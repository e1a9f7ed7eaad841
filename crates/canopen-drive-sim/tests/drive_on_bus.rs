//! A real `canopen_drive::Drive` (node 5) on the virtual bus, driven by the scripted master.
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use canopen_drive::od::{layout, Access, DataType, Object, Var};
use canopen_drive::wire::nmt::{NmtCommand, NmtState};
use canopen_drive::{AbortCode, CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::{Fate, FaultRule, Master, NodeHandle, Port, SdoError, VirtualBus};
use embedded_can::Frame;

/// A writable DOMAIN large enough for segmented and block downloads.
static BLOB: [Object; 1] = layout([Object::var(
    0x2000,
    "Blob",
    Var::new("Blob", DataType::Domain).access(Access::ReadWrite).capacity(300),
)]);

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new_standard(id, data).unwrap()
}

fn master_with(config: Config) -> (Master, NodeHandle) {
    let mut bus = VirtualBus::new();
    let node = bus.add_node(Drive::new(config).unwrap());
    let mut master = Master::new(bus);
    // Boot-up at 0, first request at 1 ms.
    master.advance(Duration::from_millis(1)).unwrap();
    (master, node)
}

fn master() -> (Master, NodeHandle) {
    master_with(Config::new(5))
}

fn master_with_blob() -> (Master, NodeHandle) {
    master_with(Config { manufacturer_objects: &BLOB, ..Config::new(5) })
}

fn drive(master: &Master, node: NodeHandle) -> &Drive {
    master.bus().node::<Drive>(node).unwrap()
}

fn pattern(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i * 7 + 3) as u8).collect()
}

#[test]
fn boot_up_frame_is_seen() {
    let (mut master, node) = master();
    let received = master.bus_mut().drain_received();
    assert_eq!(received.len(), 1);
    assert_eq!(received[0].frame, frame(0x705, &[0x00]));
    assert_eq!((received[0].time, received[0].from), (Instant::ZERO, Port::Node(node)));
    assert_eq!(drive(&master, node).nmt_state(), NmtState::PreOperational);
    assert_eq!(
        master.bus().render_trace(),
        "(000.000000)  vcan0  705   [1]  00                       ; node5\n"
    );
}

#[test]
fn expedited_upload_of_the_device_type() {
    let (mut master, _) = master();
    let answer = master.sdo_request(5, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap();
    assert_eq!(answer, [frame(0x585, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])]);
    assert_eq!(master.sdo_upload(5, 0x1000, 0).unwrap(), [0x92, 0x01, 0x02, 0x00]);
    let trace = master.bus().render_trace();
    assert!(
        trace.ends_with(
            "(000.002000)  vcan0  605   [8]  40 00 10 00 00 00 00 00  ; master\n\
             (000.002000)  vcan0  585   [8]  43 00 10 00 92 01 02 00  ; node5\n"
        ),
        "{trace}"
    );
}

#[test]
fn segmented_upload_of_the_device_name() {
    let (mut master, _) = master();
    assert_eq!(master.sdo_upload_segmented(5, 0x1008, 0).unwrap(), b"canopen-drive");
    assert_eq!(master.sdo_upload(5, 0x1008, 0).unwrap(), b"canopen-drive");
    let node_frames: Vec<Vec<u8>> = master
        .bus()
        .trace()
        .iter()
        .filter(|r| r.frame.standard_id() == Some(0x585))
        .map(|r| r.frame.data().to_vec())
        .take(3)
        .collect();
    assert_eq!(node_frames[0], [0x41, 0x08, 0x10, 0x00, 13, 0, 0, 0]);
    assert_eq!(node_frames[1], *b"\x00canopen");
    // Six bytes, n = 1, c = 1, toggle 1.
    assert_eq!(node_frames[2], *b"\x13-drive\0");
}

#[test]
fn heartbeat_time_is_written_and_read_back() {
    let (mut master, _) = master();
    master.sdo_download(5, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
    assert_eq!(master.sdo_upload(5, 0x1017, 0).unwrap(), [100, 0]);
    let written = master.bus().trace().iter().find(|r| r.from == Port::Master).unwrap().frame;
    assert_eq!(written.data(), [0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0]);
    // The drive now sends a heartbeat at once and every 100 ms.
    master.bus_mut().drain_received();
    let start = master.now();
    master.advance(Duration::from_millis(1000)).unwrap();
    let beats: Vec<_> = master.bus_mut().drain_received();
    assert_eq!(beats.len(), 10, "{beats:?}");
    assert!(beats.iter().all(|r| r.frame == frame(0x705, &[0x7F])));
    for pair in beats.windows(2) {
        assert_eq!(pair[1].time - pair[0].time, Duration::from_millis(100));
    }
    // The write at 1 ms sent one at once; the grid continues from there.
    assert_eq!(start, Instant::from_millis(3));
    assert_eq!(beats[0].time, Instant::from_millis(101));
}

#[test]
fn segmented_and_block_download_of_a_short_value() {
    let (mut master, _) = master();
    master.sdo_download_segmented(5, 0x1017, 0, &[0x34, 0x12]).unwrap();
    assert_eq!(master.sdo_upload(5, 0x1017, 0).unwrap(), [0x34, 0x12]);
    master.sdo_block_download(5, 0x1017, 0, &[0x78, 0x56]).unwrap();
    assert_eq!(master.sdo_upload(5, 0x1017, 0).unwrap(), [0x78, 0x56]);
    // A wrong length is refused at the initiate.
    assert_eq!(
        master.sdo_block_download(5, 0x1017, 0, &[1, 2, 3]),
        Err(SdoError::Abort(AbortCode::LengthTooHigh))
    );
}

#[test]
fn block_upload_of_the_identity_vendor_id() {
    let (mut master, _) = master();
    // pst = 0: the server answers with a block transfer of 4 bytes (one segment).
    assert_eq!(master.sdo_block_upload(5, 0x1018, 1, 127).unwrap(), [0, 0, 0, 0]);
    assert!(master.bus().trace().iter().any(|r| r.frame.data().first() == Some(&0xC6)));
    // pst = 4: the server may switch to an expedited upload; either way the value arrives.
    master.bus_mut().clear_trace();
    assert_eq!(master.sdo_block_upload_pst(5, 0x1018, 1, 127, 4).unwrap(), [0, 0, 0, 0]);
    let first_answer = master.bus().trace().into_iter().find(|r| r.from != Port::Master).unwrap();
    assert_eq!(first_answer.frame.data(), [0x43, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
}

#[test]
fn block_upload_of_the_device_name() {
    for block_size in [127, 2, 1] {
        let (mut master, _) = master();
        assert_eq!(
            master.sdo_block_upload(5, 0x1008, 0, block_size).unwrap(),
            b"canopen-drive",
            "{block_size}"
        );
        let end = master
            .bus()
            .trace()
            .into_iter()
            .find(|r| r.frame.data().first().is_some_and(|b| b & 0xE3 == 0xC1));
        // 13 bytes = 2 segments, one byte unused: C1 | 1 << 2.
        assert_eq!(end.unwrap().frame.data()[0], 0xC5);
    }
}

#[test]
fn block_upload_recovers_from_a_lost_segment() {
    let (mut master, node) = master();
    let rule = master.bus_mut().add_fault(
        FaultRule::drop().from_port(Port::Node(node)).when(|f, _| f.data().first() == Some(&0x01)).times(1),
    );
    assert_eq!(master.sdo_block_upload(5, 0x1008, 0, 127).unwrap(), b"canopen-drive");
    assert_eq!(master.bus().fault(rule).unwrap().applied(), 1);
    let trace = master.bus().trace();
    let dropped: Vec<_> = trace.iter().filter(|r| r.fate == Fate::Dropped).collect();
    assert_eq!(dropped.len(), 1);
    assert_eq!(dropped[0].frame.data(), *b"\x01canopen");
    // The client acknowledged nothing, the server repeated both segments.
    let acks: Vec<Vec<u8>> = trace
        .iter()
        .filter(|r| r.from == Port::Master && r.frame.data().first() == Some(&0xA2))
        .map(|r| r.frame.data()[..3].to_vec())
        .collect();
    assert_eq!(acks, [vec![0xA2, 0, 127], vec![0xA2, 2, 127]]);
    let segments = trace
        .iter()
        .filter(|r| {
            r.frame.standard_id() == Some(0x585) && r.frame.data()[0] & 0x7F <= 2 && r.frame.data()[0] != 0
        })
        .count();
    assert_eq!(segments, 4);
    let text = master.bus().render_trace();
    assert!(text.contains("585   [8]  01 63 61 6E 6F 70 65 6E  ; node5 (dropped)"), "{text}");
}

#[test]
fn large_value_in_every_transfer_mode() {
    let (mut master, _) = master_with_blob();
    let data = pattern(100);
    master.sdo_download(5, 0x2000, 0, &data).unwrap();
    assert_eq!(master.sdo_upload(5, 0x2000, 0).unwrap(), data);
    let data = pattern(200);
    master.sdo_block_download(5, 0x2000, 0, &data).unwrap();
    assert_eq!(master.sdo_upload_segmented(5, 0x2000, 0).unwrap(), data);
    for block_size in [127, 5, 1] {
        assert_eq!(master.sdo_block_upload(5, 0x2000, 0, block_size).unwrap(), data);
    }
    master.sdo_download(5, 0x2000, 0, &[]).unwrap();
    assert_eq!(master.sdo_upload(5, 0x2000, 0).unwrap(), []);
    assert_eq!(master.sdo_block_upload(5, 0x2000, 0, 127).unwrap(), []);
}

#[test]
fn block_download_recovers_from_a_lost_segment() {
    let (mut master, _) = master_with_blob();
    // Lose the third segment of the first sub-block once.
    let rule = master.bus_mut().add_fault(
        FaultRule::drop()
            .from_port(Port::Master)
            .with_id(0x605)
            .when(|f, _| f.data().first() == Some(&0x03))
            .times(1),
    );
    let data = pattern(150);
    master.sdo_block_download(5, 0x2000, 0, &data).unwrap();
    assert_eq!(master.bus().fault(rule).unwrap().applied(), 1);
    assert_eq!(master.sdo_upload(5, 0x2000, 0).unwrap(), data);
    let acks: Vec<u8> = master
        .bus()
        .trace()
        .iter()
        .filter(|r| r.frame.standard_id() == Some(0x585) && r.frame.data()[0] == 0xA2)
        .map(|r| r.frame.data()[1])
        .collect();
    // 150 bytes = 22 segments; the server acknowledges 2 of the first sub-block, then the rest.
    assert_eq!(acks, [2, 20]);
}

#[test]
fn block_upload_of_a_large_value_with_a_lost_segment_per_sub_block() {
    let (mut master, node) = master_with_blob();
    let data = pattern(210);
    master.sdo_block_download(5, 0x2000, 0, &data).unwrap();
    // Lose segment 3 of the first two sub-blocks.
    master.bus_mut().add_fault(
        FaultRule::drop().from_port(Port::Node(node)).when(|f, _| f.data().first() == Some(&0x03)).times(2),
    );
    assert_eq!(master.sdo_block_upload(5, 0x2000, 0, 10).unwrap(), data);
}

#[test]
fn refused_accesses_carry_the_precise_abort_code() {
    let (mut master, _) = master();
    assert_eq!(master.sdo_upload(5, 0x1234, 0), Err(SdoError::Abort(AbortCode::ObjectDoesNotExist)));
    assert_eq!(master.sdo_upload(5, 0x1018, 9), Err(SdoError::Abort(AbortCode::SubIndexDoesNotExist)));
    assert_eq!(master.sdo_download(5, 0x1000, 0, &[0; 4]), Err(SdoError::Abort(AbortCode::WriteOfReadOnly)));
    assert_eq!(
        master.sdo_block_upload(5, 0x1234, 0, 10),
        Err(SdoError::Abort(AbortCode::ObjectDoesNotExist))
    );
    assert_eq!(
        master.sdo_request(5, &[0x80, 0, 0, 0, 0, 0, 0, 0]).unwrap(),
        [],
        "an abort is never answered"
    );
}

#[test]
fn nmt_states_gate_the_sdo_server() {
    let (mut master, node) = master();
    master.set_timeout(Duration::from_millis(10));
    master.nmt(NmtCommand::Stop, 5).unwrap();
    assert_eq!(drive(&master, node).nmt_state(), NmtState::Stopped);
    assert_eq!(master.sdo_upload(5, 0x1000, 0), Err(SdoError::Timeout));
    master.nmt(NmtCommand::Start, 0).unwrap();
    assert_eq!(drive(&master, node).nmt_state(), NmtState::Operational);
    assert_eq!(master.sdo_upload(5, 0x1000, 0).unwrap(), [0x92, 0x01, 0x02, 0x00]);
    master.bus_mut().drain_received();
    master.nmt(NmtCommand::ResetCommunication, 5).unwrap();
    assert_eq!(master.bus_mut().drain_received_frames(), [frame(0x705, &[0x00])]);
    assert_eq!(drive(&master, node).nmt_state(), NmtState::PreOperational);
    // Another node's command is not for us.
    master.nmt(NmtCommand::Stop, 6).unwrap();
    assert_eq!(drive(&master, node).nmt_state(), NmtState::PreOperational);
}

#[test]
fn server_times_out_a_stalled_transfer() {
    let (mut master, _) = master();
    master.bus_mut().drain_received();
    let answer = master.sdo_request(5, &[0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]).unwrap();
    assert_eq!(answer, [frame(0x585, &[0x41, 0x08, 0x10, 0x00, 13, 0, 0, 0])]);
    let sent_at = Instant::from_millis(1);
    master.advance(Duration::from_millis(1500)).unwrap();
    let received = master.bus_mut().drain_received();
    assert_eq!(received.len(), 1);
    assert_eq!(received[0].frame, frame(0x585, &[0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]));
    assert_eq!(received[0].time, sent_at + Duration::from_millis(1000));
}

#[test]
fn a_duplicated_request_is_seen_by_the_server() {
    let (mut master, _) = master();
    // The first upload-segment request reaches the server twice: the copy has the wrong
    // toggle bit for the server's next segment.
    master.bus_mut().add_fault(
        FaultRule::duplicate().from_port(Port::Master).when(|f, _| f.data().first() == Some(&0x60)).times(1),
    );
    let error = master.sdo_upload(5, 0x1008, 0).unwrap_err();
    assert!(matches!(error, SdoError::Protocol { .. } | SdoError::Abort(_)), "{error:?}");
    let text = master.bus().render_trace();
    assert!(text.contains("(duplicate)"), "{text}");
}

/// A block download may fill the whole SDO buffer (256 bytes): the padding of the last segment
/// lies beyond the buffer and must not count (a regression test for a bug found here).
#[test]
fn block_download_of_a_value_filling_the_sdo_buffer() {
    for len in 253..=256 {
        let (mut master, _) = master_with_blob();
        let data = pattern(len);
        master.sdo_download_segmented(5, 0x2000, 0, &data).unwrap();
        assert_eq!(master.sdo_block_download(5, 0x2000, 0, &data), Ok(()), "{len} bytes");
        assert_eq!(master.sdo_upload(5, 0x2000, 0).unwrap(), data);
    }
}
