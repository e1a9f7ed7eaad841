//! SDO server conformance on the virtual bus: every transfer type in both directions and every
//! abort code, asserted as the exact frames the drive sends (CiA 301 §7.2.4, digest §5).

mod common;

use common::*;
use embedded_can::Frame;

use canopen_drive::Duration;

const TIMEOUT: u32 = 0x0504_0000;
const TOGGLE: u32 = 0x0503_0000;
const COMMAND: u32 = 0x0504_0001;
const BLOCK_SIZE: u32 = 0x0504_0002;
const SEQUENCE: u32 = 0x0504_0003;
const CRC: u32 = 0x0504_0004;
const OUT_OF_MEMORY: u32 = 0x0504_0005;
const READ_WRITE_ONLY: u32 = 0x0601_0001;
const WRITE_READ_ONLY: u32 = 0x0601_0002;
const NO_OBJECT: u32 = 0x0602_0000;
const TOO_LONG: u32 = 0x0607_0012;
const TOO_SHORT: u32 = 0x0607_0013;
const NO_SUB: u32 = 0x0609_0011;
const TOO_HIGH: u32 = 0x0609_0031;
const TOO_LOW: u32 = 0x0609_0032;
const GENERAL: u32 = 0x0800_0000;
const DEVICE_STATE: u32 = 0x0800_0022;

/// Segmented download of `data` (size indicated), asserting every response.
fn segmented_download(bench: &mut Bench, index: u16, sub: u8, data: &[u8]) {
    let size = (data.len() as u32).to_le_bytes();
    assert_eq!(bench.sdo1(&req(0x21, index, sub, size)), req(0x60, index, sub, [0; 4]));
    let chunks: Vec<&[u8]> = if data.is_empty() { vec![&[]] } else { data.chunks(7).collect() };
    for (i, chunk) in chunks.iter().enumerate() {
        let toggle = (i % 2) as u8;
        let last = i + 1 == chunks.len();
        let mut f = [0u8; 8];
        f[0] = (toggle << 4) | (((7 - chunk.len()) as u8) << 1) | u8::from(last);
        f[1..1 + chunk.len()].copy_from_slice(chunk);
        assert_eq!(bench.sdo1(&f), [0x20 | (toggle << 4), 0, 0, 0, 0, 0, 0, 0]);
    }
}

/// Segmented upload, asserting the initiate response and every segment's header.
fn segmented_upload(bench: &mut Bench, index: u16, sub: u8) -> Vec<u8> {
    let response = bench.sdo1(&req(0x40, index, sub, [0; 4]));
    assert_eq!(response[..4], req(0x41, index, sub, [0; 4])[..4], "size indicated");
    let size = u32::from_le_bytes(response[4..8].try_into().unwrap()) as usize;
    let mut out = Vec::new();
    let mut toggle = 0u8;
    loop {
        let seg = bench.sdo1(&[0x60 | (toggle << 4), 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(seg[0] >> 5, 0, "upload segment response");
        assert_eq!((seg[0] >> 4) & 1, toggle, "toggle echoed");
        let n = 7 - ((seg[0] >> 1) & 7) as usize;
        out.extend_from_slice(&seg[1..1 + n]);
        if seg[0] & 1 == 1 {
            break;
        }
        toggle ^= 1;
    }
    assert_eq!(out.len(), size);
    out
}

#[test]
fn expedited_upload_of_device_type() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x1000, 0, [0; 4])), [0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]);
    // Identity: four UNSIGNED32 of the default device info (all zero).
    for sub in 1..=4 {
        assert_eq!(bench.sdo1(&req(0x40, 0x1018, sub, [0; 4])), req(0x43, 0x1018, sub, [0; 4]));
    }
    assert_eq!(bench.sdo1(&req(0x40, 0x1018, 0, [0; 4])), req(0x4F, 0x1018, 0, [4, 0, 0, 0]));
    // SDO server COB-IDs follow the node-ID.
    assert_eq!(bench.sdo1(&req(0x40, 0x1200, 1, [0; 4])), req(0x43, 0x1200, 1, [0x05, 0x06, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1200, 2, [0; 4])), req(0x43, 0x1200, 2, [0x85, 0x05, 0, 0]));
}

#[test]
fn expedited_download_with_and_without_size() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x2B, 0x1017, 0, [0xE8, 0x03, 0, 0])), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1017, 0, [0; 4])), req(0x4B, 0x1017, 0, [0xE8, 0x03, 0, 0]));
    // e = 1, s = 0: the entry's size (1 byte) counts, the rest of the frame is ignored.
    assert_eq!(bench.sdo1(&req(0x22, LIMITED, 0, [12, 0xFF, 0xFF, 0xFF])), req(0x60, LIMITED, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, LIMITED, 0, [0; 4])), req(0x4F, LIMITED, 0, [12, 0, 0, 0]));
    // A request shorter than 8 bytes is served when the needed bytes are there.
    assert_eq!(bench.sdo1(&[0x2B, 0x17, 0x10, 0x00, 0x64, 0x00]), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(bench.drive().od().get::<u16>(0x1017, 0), Ok(100));
    // Signed record entry.
    assert_eq!(bench.sdo1(&req(0x23, RECORD, 1, (-42i32).to_le_bytes())), req(0x60, RECORD, 1, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, RECORD, 1, [0; 4])), req(0x43, RECORD, 1, (-42i32).to_le_bytes()));
    assert_eq!(bench.drive().hooks_mut().written.last(), Some(&(RECORD, 1, (-42i32).to_le_bytes().to_vec())));
}

/// A frame shorter than eight bytes (digest §18 item 16): an expedited download is taken when
/// the bytes its size indicates are there, refused with "length too low" when they are not
/// (the value keeps its old content); an upload request needs only its multiplexer.
#[test]
fn short_expedited_frames() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&[0x2B, 0x17, 0x10, 0, 0xE8, 0x03]), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(bench.sdo1(&[0x40, 0x17, 0x10, 0]), req(0x4B, 0x1017, 0, [0xE8, 0x03, 0, 0]));
    // 1006h is UNSIGNED32: four bytes indicated, two in the frame.
    assert_eq!(bench.sdo1(&[0x23, 0x06, 0x10, 0, 0xD0, 0x07]), abort(0x1006, 0, TOO_SHORT));
    assert_eq!(bench.sdo1(&[0x40, 0x06, 0x10, 0]), req(0x43, 0x1006, 0, [0; 4]));
    // The size indicated is checked against the entry first: four bytes for 1017h are too many.
    assert_eq!(bench.sdo1(&[0x23, 0x17, 0x10, 0, 0xD0, 0x07]), abort(0x1017, 0, TOO_LONG));
}

/// In a block download every frame but an abort is a sub-block segment: bytes that would be
/// an expedited download between transfers write nothing (found by the `sdo_server` fuzz
/// target against the expedited fast path of issue 17).
#[test]
fn a_segment_that_reads_like_a_download_writes_nothing() {
    let mut bench = Bench::new();
    let before = bench.drive().od().get::<u16>(0x1017, 0).unwrap();
    assert_eq!(bench.sdo1(&req(0xC2, TEXT, 0, [10, 0, 0, 0]))[0], 0xA4);
    bench.sdo(&req(0x2B, 0x1017, 0, [0xE8, 0x03, 0, 0]));
    assert_eq!(bench.drive().od().get::<u16>(0x1017, 0), Ok(before));
    bench.sdo(&abort(TEXT, 0, GENERAL));
    let read = bench.sdo1(&req(0x40, 0x1017, 0, [0; 4]));
    assert_eq!(u16::from_le_bytes([read[4], read[5]]), before, "{read:02X?}");
}

#[test]
fn segmented_upload_of_strings() {
    let mut bench = Bench::new();
    // 1008h: the device name, 13 bytes: 41 + size, then two segments.
    assert_eq!(bench.sdo1(&req(0x40, 0x1008, 0, [0; 4])), req(0x41, 0x1008, 0, [13, 0, 0, 0]));
    assert_eq!(bench.sdo1(&[0x60, 0, 0, 0, 0, 0, 0, 0]), [0x00, b'c', b'a', b'n', b'o', b'p', b'e', b'n']);
    assert_eq!(
        bench.sdo1(&[0x70, 0, 0, 0, 0, 0, 0, 0]),
        [0x10 | (1 << 1) | 1, b'-', b'd', b'r', b'i', b'v', b'e', 0]
    );
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), DEFAULT_TEXT.as_bytes());
}

#[test]
fn segmented_download_with_and_without_size() {
    let mut bench = Bench::new();
    let text = b"hello, segmented world";
    segmented_download(&mut bench, TEXT, 0, text);
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), text);

    // Size not indicated (0x20): the length is what arrives.
    assert_eq!(bench.sdo1(&req(0x20, TEXT, 0, [0; 4])), req(0x60, TEXT, 0, [0; 4]));
    assert_eq!(bench.sdo1(&[0x00, b'a', b'b', b'c', b'd', b'e', b'f', b'g']), [0x20, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(bench.sdo1(&[0x10 | (5 << 1) | 1, b'h', b'i', 0, 0, 0, 0, 0]), [0x30, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), b"abcdefghi");
}

#[test]
fn empty_values_travel_segmented() {
    let mut bench = Bench::new();
    segmented_download(&mut bench, TEXT, 0, b"");
    // Upload of an empty value: size 0, then one segment with c = 1 and n = 7.
    assert_eq!(bench.sdo1(&req(0x40, TEXT, 0, [0; 4])), req(0x41, TEXT, 0, [0; 4]));
    assert_eq!(bench.sdo1(&[0x60, 0, 0, 0, 0, 0, 0, 0]), [0x0F, 0, 0, 0, 0, 0, 0, 0]);
}

/// Sends a block-download sub-block; returns the drive's responses.
fn sub_block(bench: &mut Bench, segments: &[(u8, bool, &[u8])]) -> Vec<[u8; 8]> {
    let mut out = Vec::new();
    for (seq, last, data) in segments {
        let mut f = [0u8; 8];
        f[0] = seq | if *last { 0x80 } else { 0 };
        f[1..1 + data.len()].copy_from_slice(data);
        out.extend(bench.sdo(&f));
    }
    out
}

#[test]
fn block_download_with_crc() {
    let mut bench = Bench::new();
    let data: Vec<u8> = (0..100u8).map(|i| b'a' + i % 26).collect();
    let init = bench.sdo1(&req(0xC6, TEXT, 0, (data.len() as u32).to_le_bytes()));
    assert_eq!(init[..4], [0xA4, 0x00, 0x20, 0x00], "CRC supported");
    let block_size = init[4];
    assert!((1..=127).contains(&block_size));
    assert!(block_size >= 15, "100 bytes fit one sub-block");
    let chunks: Vec<&[u8]> = data.chunks(7).collect();
    let segments: Vec<(u8, bool, &[u8])> =
        chunks.iter().enumerate().map(|(i, c)| ((i + 1) as u8, i + 1 == chunks.len(), *c)).collect();
    let acks = sub_block(&mut bench, &segments);
    assert_eq!(acks.len(), 1);
    assert_eq!(acks[0][..2], [0xA2, 15]);
    // 100 = 14 * 7 + 2: five bytes of the last segment unused.
    let [c0, c1] = crc16(&data).to_le_bytes();
    assert_eq!(bench.sdo1(&[0xC1 | (5 << 2), c0, c1, 0, 0, 0, 0, 0]), [0xA1, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), data);
}

#[test]
fn block_download_filling_the_buffer_and_a_repeated_last_segment() {
    let mut bench = Bench::new();
    // 256 bytes (the SDO buffer) into the 1000-byte octet string: 37 segments, the last one
    // carrying 4 bytes of data and 3 of padding beyond the buffer.
    let data: Vec<u8> = (0..=255u8).collect();
    let init = bench.sdo1(&req(0xC6, BIG, 0, [0, 1, 0, 0]));
    let block_size = init[4] as usize;
    let chunks: Vec<&[u8]> = data.chunks(7).collect();
    let mut acks = Vec::new();
    for (i, chunk) in chunks.iter().enumerate() {
        let seq = (i % block_size + 1) as u8;
        acks.extend(sub_block(&mut bench, &[(seq, i + 1 == chunks.len(), chunk)]));
    }
    assert_eq!(acks.last().unwrap()[..2], [0xA2, (chunks.len() - block_size) as u8]);
    // The client did not see the ack and repeats the last segment: ignored.
    let last = chunks.len() - block_size;
    assert!(sub_block(&mut bench, &[(last as u8, true, chunks[chunks.len() - 1])]).is_empty());
    let [c0, c1] = crc16(&data).to_le_bytes();
    assert_eq!(bench.sdo1(&[0xC1 | (3 << 2), c0, c1, 0, 0, 0, 0, 0]), [0xA1, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(segmented_upload(&mut bench, BIG, 0), data);
}

#[test]
fn block_download_repeats_after_a_lost_segment() {
    let mut bench = Bench::new();
    let data: Vec<u8> = (0..40u8).collect();
    let init = bench.sdo1(&req(0xC2, TEXT, 0, (data.len() as u32).to_le_bytes()));
    assert_eq!(init[0], 0xA4);
    let c: Vec<&[u8]> = data.chunks(7).collect(); // 6 segments
                                                  // Segment 3 is lost: 4, 5 and the last (6) arrive out of sequence and are ignored.
    let acks = sub_block(
        &mut bench,
        &[(1, false, c[0]), (2, false, c[1]), (4, false, c[3]), (5, false, c[4]), (6, true, c[5])],
    );
    assert_eq!(acks.len(), 1);
    assert_eq!(acks[0][..2], [0xA2, 2], "acknowledges the last segment received in order");
    // The client repeats from segment 3, numbered from 1 in a new sub-block.
    let acks =
        sub_block(&mut bench, &[(1, false, c[2]), (2, false, c[3]), (3, false, c[4]), (4, true, c[5])]);
    assert_eq!(acks[0][..2], [0xA2, 4]);
    // No CRC (client did not ask): 40 = 5 * 7 + 5, two bytes unused.
    assert_eq!(bench.sdo1(&[0xC1 | (2 << 2), 0, 0, 0, 0, 0, 0, 0]), [0xA1, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), data);
}

/// A lost segment with the CRC on: the repeated segments count once in the CRC (the server
/// folds each segment into it when the next arrives in order), and a CRC one bit off is
/// refused.
#[test]
fn block_download_with_crc_repeats_after_a_lost_segment() {
    for wrong in [false, true] {
        let mut bench = Bench::new();
        let data: Vec<u8> = (0..40u8).map(|i| i.wrapping_mul(37)).collect();
        let init = bench.sdo1(&req(0xC6, TEXT, 0, (data.len() as u32).to_le_bytes()));
        assert_eq!(init[0], 0xA4);
        let c: Vec<&[u8]> = data.chunks(7).collect(); // 6 segments
        let acks =
            sub_block(&mut bench, &[(1, false, c[0]), (2, false, c[1]), (4, false, c[3]), (6, true, c[5])]);
        assert_eq!(acks[0][..2], [0xA2, 2]);
        let acks =
            sub_block(&mut bench, &[(1, false, c[2]), (2, false, c[3]), (3, false, c[4]), (4, true, c[5])]);
        assert_eq!(acks[0][..2], [0xA2, 4]);
        let crc = crc16(&data) ^ u16::from(wrong);
        let [c0, c1] = crc.to_le_bytes();
        let end = bench.sdo1(&[0xC1 | (2 << 2), c0, c1, 0, 0, 0, 0, 0]);
        if wrong {
            assert_eq!(end, abort(TEXT, 0, CRC));
        } else {
            assert_eq!(end, [0xA1, 0, 0, 0, 0, 0, 0, 0]);
            assert_eq!(segmented_upload(&mut bench, TEXT, 0), data);
        }
    }
}

/// Runs a whole block upload of `index` with the given client block size; returns the data.
fn block_upload(bench: &mut Bench, index: u16, block_size: u8) -> Vec<u8> {
    let init = bench.sdo1(&req(0xA4, index, 0, [block_size, 0, 0, 0]));
    assert_eq!(init[..4], req(0xC6, index, 0, [0; 4])[..4], "size indicated, CRC supported");
    let size = u32::from_le_bytes(init[4..8].try_into().unwrap()) as usize;
    let mut data = Vec::new();
    let mut responses = bench.sdo(&[0xA3, 0, 0, 0, 0, 0, 0, 0]);
    loop {
        // Segments of one sub-block: numbered 1.., the transfer's last one flagged.
        let expected = ((size - data.len()).div_ceil(7)).clamp(1, block_size as usize);
        assert_eq!(responses.len(), expected, "one sub-block of segments");
        let mut last = false;
        for (i, seg) in responses.iter().enumerate() {
            assert_eq!(seg[0] & 0x7F, (i + 1) as u8);
            last = seg[0] & 0x80 != 0;
            data.extend_from_slice(&seg[1..]);
        }
        let ack = [0xA2, expected as u8, block_size, 0, 0, 0, 0, 0];
        responses = bench.sdo(&ack);
        if last {
            break;
        }
    }
    assert_eq!(responses.len(), 1);
    let end = responses[0];
    assert_eq!(end[0] & 0xE3, 0xC1);
    let unused = ((end[0] >> 2) & 7) as usize;
    data.truncate(data.len() - unused);
    assert_eq!(data.len(), size);
    assert_eq!(u16::from_le_bytes([end[1], end[2]]), crc16(&data));
    // The client's end confirmation gets no answer.
    assert!(bench.sdo(&[0xA1, 0, 0, 0, 0, 0, 0, 0]).is_empty());
    data
}

#[test]
fn block_upload_across_sub_blocks() {
    let mut bench = Bench::new();
    // 1000 bytes = 143 segments: a full sub-block of 127, then 16.
    assert_eq!(block_upload(&mut bench, TABLE, 127), TABLE_BYTES);
    assert_eq!(block_upload(&mut bench, TABLE, 10), TABLE_BYTES);
    assert_eq!(block_upload(&mut bench, 0x1008, 127), b"canopen-drive");
}

#[test]
fn block_upload_repeats_unacknowledged_segments() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0xA4, TABLE, 0, [5, 0, 0, 0]));
    let first = bench.sdo(&[0xA3, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(first.len(), 5);
    // Client got only 3 in order: the server resends from byte 21 as segments 1..5.
    let again = bench.sdo(&[0xA2, 3, 5, 0, 0, 0, 0, 0]);
    assert_eq!(again.len(), 5);
    assert_eq!(again[0][0], 1);
    assert_eq!(again[0][1..], TABLE_BYTES[21..28]);
    // An acknowledgement beyond what was sent is a sequence error.
    assert_eq!(bench.sdo1(&[0xA2, 6, 5, 0, 0, 0, 0, 0]), abort(TABLE, 0, SEQUENCE));
}

#[test]
fn block_upload_switches_protocol_below_threshold() {
    let mut bench = Bench::new();
    // pst = 4 and the value has 2 bytes: a normal expedited answer.
    assert_eq!(bench.sdo1(&req(0xA4, 0x1017, 0, [127, 4, 0, 0])), req(0x4B, 0x1017, 0, [0; 4]));
    // pst = 100 and 13 bytes: a segmented upload.
    assert_eq!(bench.sdo1(&req(0xA4, 0x1008, 0, [127, 100, 0, 0])), req(0x41, 0x1008, 0, [13, 0, 0, 0]));
}

#[test]
fn aborts_on_the_initiate_checks() {
    let mut bench = Bench::new();
    let cases: [([u8; 8], [u8; 8]); 14] = [
        // Unknown command specifier (ccs 7).
        (req(0xE0, 0x1000, 0, [0; 4]), abort(0x1000, 0, COMMAND)),
        // Object and sub-index that do not exist, for uploads and downloads.
        (req(0x40, 0x3000, 0, [0; 4]), abort(0x3000, 0, NO_OBJECT)),
        (req(0x2F, 0x3000, 0, [1, 0, 0, 0]), abort(0x3000, 0, NO_OBJECT)),
        (req(0x40, 0x1017, 1, [0; 4]), abort(0x1017, 1, NO_SUB)),
        (req(0x40, 0x1018, 5, [0; 4]), abort(0x1018, 5, NO_SUB)),
        // Access.
        (req(0x40, WRITE_ONLY, 0, [0; 4]), abort(WRITE_ONLY, 0, READ_WRITE_ONLY)),
        (req(0x23, 0x1000, 0, [0; 4]), abort(0x1000, 0, WRITE_READ_ONLY)),
        (req(0x21, 0x1008, 0, [3, 0, 0, 0]), abort(0x1008, 0, WRITE_READ_ONLY)),
        // Length of a fixed-size value.
        (req(0x23, 0x1017, 0, [1, 0, 0, 0]), abort(0x1017, 0, TOO_LONG)),
        (req(0x2F, 0x1017, 0, [1, 0, 0, 0]), abort(0x1017, 0, TOO_SHORT)),
        // Length of a string beyond its storage, and beyond the SDO buffer.
        (req(0x21, TEXT, 0, [201, 0, 0, 0]), abort(TEXT, 0, TOO_LONG)),
        (req(0x21, BIG, 0, [0x2C, 0x01, 0, 0]), abort(BIG, 0, OUT_OF_MEMORY)),
        // Block upload with a block size outside 1..=127.
        (req(0xA0, TABLE, 0, [0, 0, 0, 0]), abort(TABLE, 0, BLOCK_SIZE)),
        (req(0xA0, TABLE, 0, [128, 0, 0, 0]), abort(TABLE, 0, BLOCK_SIZE)),
    ];
    for (request, expected) in cases {
        assert_eq!(bench.sdo1(&request), expected, "request {request:02X?}");
    }
}

#[test]
fn aborts_on_values() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x2F, LIMITED, 0, [21, 0, 0, 0])), abort(LIMITED, 0, TOO_HIGH));
    assert_eq!(bench.sdo1(&req(0x2F, LIMITED, 0, [9, 0, 0, 0])), abort(LIMITED, 0, TOO_LOW));
    assert_eq!(bench.sdo1(&req(0x23, RECORD, 1, 101i32.to_le_bytes())), abort(RECORD, 1, TOO_HIGH));
    assert_eq!(bench.sdo1(&req(0x23, RECORD, 1, (-101i32).to_le_bytes())), abort(RECORD, 1, TOO_LOW));
    assert_eq!(bench.sdo1(&req(0x23, REFUSED, 0, [1, 2, 3, 4])), abort(REFUSED, 0, GENERAL));
    // A refused write leaves the old value.
    assert_eq!(bench.sdo1(&req(0x40, LIMITED, 0, [0; 4])), req(0x4F, LIMITED, 0, [15, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, RECORD, 1, [0; 4])), req(0x43, RECORD, 1, (-5i32).to_le_bytes()));
    // An entry writable only outside Operational.
    assert_eq!(bench.sdo1(&req(0x2B, RECORD, 2, [7, 0, 0, 0])), req(0x60, RECORD, 2, [0; 4]));
    bench.send(frame(0x000, &[0x01, NODE]));
    assert_eq!(bench.sdo1(&req(0x2B, RECORD, 2, [8, 0, 0, 0])), abort(RECORD, 2, DEVICE_STATE));
    assert_eq!(bench.drive().od().get::<u16>(RECORD, 2), Ok(7));
}

#[test]
fn aborts_during_segmented_transfers() {
    let mut bench = Bench::new();
    // Toggle error on the first download segment (must be t = 0).
    bench.sdo1(&req(0x21, TEXT, 0, [3, 0, 0, 0]));
    assert_eq!(bench.sdo1(&[0x10 | (4 << 1) | 1, 1, 2, 3, 0, 0, 0, 0]), abort(TEXT, 0, TOGGLE));
    // Toggle error on an upload segment.
    bench.sdo1(&req(0x40, TEXT, 0, [0; 4]));
    assert_eq!(bench.sdo1(&[0x70, 0, 0, 0, 0, 0, 0, 0]), abort(TEXT, 0, TOGGLE));
    // Fewer bytes than indicated.
    bench.sdo1(&req(0x21, TEXT, 0, [10, 0, 0, 0]));
    assert_eq!(bench.sdo1(&[(4 << 1) | 1, 1, 2, 3, 0, 0, 0, 0]), abort(TEXT, 0, TOO_SHORT));
    // More bytes than indicated.
    bench.sdo1(&req(0x21, TEXT, 0, [3, 0, 0, 0]));
    assert_eq!(bench.sdo1(&[0x00, 1, 2, 3, 4, 5, 6, 7]), abort(TEXT, 0, TOO_LONG));
    // A new initiate in the middle of a transfer.
    bench.sdo1(&req(0x21, TEXT, 0, [10, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1000, 0, [0; 4])), abort(TEXT, 0, COMMAND));
    // A segment without a transfer.
    assert_eq!(bench.sdo1(&[0x60, 0, 0, 0, 0, 0, 0, 0]), abort(0, 0, COMMAND));
    // Nothing was written by any of these.
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), DEFAULT_TEXT.as_bytes());
}

#[test]
fn aborts_during_block_transfers() {
    let mut bench = Bench::new();
    // Wrong CRC.
    bench.sdo1(&req(0xC6, TEXT, 0, [3, 0, 0, 0]));
    assert_eq!(sub_block(&mut bench, &[(1, true, b"abc")])[0][..2], [0xA2, 1]);
    assert_eq!(bench.sdo1(&[0xC1 | (4 << 2), 0x12, 0x34, 0, 0, 0, 0, 0]), abort(TEXT, 0, CRC));
    // Sequence number 0 in a sub-block.
    bench.sdo1(&req(0xC2, TEXT, 0, [3, 0, 0, 0]));
    assert_eq!(bench.sdo1(&[0x00, 1, 2, 3, 0, 0, 0, 0]), abort(TEXT, 0, SEQUENCE));
    // Size indicated at the end differs from the data.
    bench.sdo1(&req(0xC2, TEXT, 0, [10, 0, 0, 0]));
    sub_block(&mut bench, &[(1, true, b"abc")]);
    assert_eq!(bench.sdo1(&[0xC1 | (4 << 2), 0, 0, 0, 0, 0, 0, 0]), abort(TEXT, 0, TOO_SHORT));
    // Wrong block size in an upload acknowledgement.
    bench.sdo1(&req(0xA4, TABLE, 0, [5, 0, 0, 0]));
    assert_eq!(bench.sdo(&[0xA3, 0, 0, 0, 0, 0, 0, 0]).len(), 5);
    assert_eq!(bench.sdo1(&[0xA2, 5, 0, 0, 0, 0, 0, 0]), abort(TABLE, 0, BLOCK_SIZE));
    // Abort from the client ends a transfer silently.
    bench.sdo1(&req(0xC2, TEXT, 0, [3, 0, 0, 0]));
    assert!(bench.sdo(&abort(TEXT, 0, GENERAL)).is_empty());
    assert_eq!(bench.sdo1(&req(0x40, 0x1000, 0, [0; 4]))[0], 0x43, "server idle again");
    assert_eq!(segmented_upload(&mut bench, TEXT, 0), DEFAULT_TEXT.as_bytes());
}

#[test]
fn a_stalled_transfer_times_out() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0x21, TEXT, 0, [10, 0, 0, 0]));
    assert!(sdo_data(&bench.advance(Duration::from_millis(999))).is_empty());
    assert_eq!(sdo_data(&bench.advance(Duration::from_millis(2))), vec![abort(TEXT, 0, TIMEOUT)]);
    // The server is free again.
    assert_eq!(bench.sdo1(&req(0x40, 0x1000, 0, [0; 4]))[0], 0x43);
    // A block upload whose client stops acknowledging times out too.
    bench.sdo1(&req(0xA4, TABLE, 0, [5, 0, 0, 0]));
    bench.sdo(&[0xA3, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(sdo_data(&bench.advance(Duration::from_millis(1001))), vec![abort(TABLE, 0, TIMEOUT)]);
}

#[test]
fn responses_always_have_dlc_8_and_frames_for_others_are_ignored() {
    let mut bench = Bench::new();
    let frames = bench.send(frame(SDO_RX, &[0x40, 0x00, 0x10, 0x00]));
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].dlc(), 8);
    // Another node's SDO channel and unrelated identifiers get nothing.
    assert!(bench.send(frame(0x606, &req(0x40, 0x1000, 0, [0; 4]))).is_empty());
    assert!(bench.send(frame(0x585, &req(0x40, 0x1000, 0, [0; 4]))).is_empty());
    // A request too short to name an object is dropped.
    assert!(bench.send(frame(SDO_RX, &[0x40, 0x00])).is_empty());
}
