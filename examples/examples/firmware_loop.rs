//! How vendor firmware links the library: manufacturer objects with hooks, a CAN driver that
//! implements `embedded_can::nb::Can`, and the two rates (communication and control tick).
//!
//! The "driver" here is a loopback queue standing in for a bxCAN/FDCAN peripheral, and the
//! "master" is two hand-written frames, so the program runs on any host.

use std::collections::VecDeque;

use canopen_drive::can_io;
use canopen_drive::hal::Sample;
use canopen_drive::od::{layout, AbortCode, Access, DataType, DefaultValue, Object, ObjectHooks, Var};
use canopen_drive::{CanFrame, Config, Drive, Instant};
use embedded_can::Frame;

/// The firmware's own objects: one parameter with limits, one value the firmware computes.
static VENDOR_OBJECTS: [Object; 2] = layout([
    Object::var(
        0x2000,
        "Current loop bandwidth",
        Var::new("Current loop bandwidth", DataType::Unsigned16)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(1000))
            .limits_unsigned(100, 5000),
    ),
    Object::var(0x2001, "Board temperature", Var::new("Board temperature", DataType::Integer16)),
]);

/// Hooks: refuse odd bandwidths, and serve the temperature from a sensor reading.
struct Board {
    temperature_decidegrees: i16,
}

impl ObjectHooks for Board {
    fn validate(&mut self, index: u16, _sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, data) {
            (0x2000, [lo, _]) if lo % 2 == 1 => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn read_len(&mut self, index: u16, _sub: u8) -> Option<Result<usize, AbortCode>> {
        (index == 0x2001).then_some(Ok(2))
    }

    fn read(&mut self, _index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let bytes = self.temperature_decidegrees.to_le_bytes();
        let rest = bytes.get(offset..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        for (dst, src) in buf.iter_mut().zip(rest) {
            *dst = *src;
        }
        Ok(n)
    }
}

/// A stand-in CAN peripheral: frames "on the wire" in two queues.
#[derive(Default)]
struct LoopbackCan {
    rx: VecDeque<CanFrame>,
    tx: Vec<CanFrame>,
}

impl embedded_can::nb::Can for LoopbackCan {
    type Frame = CanFrame;
    type Error = embedded_can::ErrorKind;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        self.tx.push(*frame);
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let config = Config { manufacturer_objects: &VENDOR_OBJECTS, ..Config::new(3) };
    let board = Board { temperature_decidegrees: 412 };
    let mut drive = Drive::with_hooks(config, board).map_err(|e| format!("dictionary: {e:?}"))?;
    let mut can = LoopbackCan::default();

    // A master writes 2000h = 2000 (accepted), then 2001 (odd: refused), then reads 2001h.
    for request in [
        [0x2B, 0x00, 0x20, 0x00, 0xD0, 0x07, 0, 0],
        [0x2B, 0x00, 0x20, 0x00, 0xD1, 0x07, 0, 0],
        [0x40, 0x01, 0x20, 0x00, 0, 0, 0, 0],
    ] {
        can.rx.extend(CanFrame::new_standard(0x603, &request));
    }

    // The main loop: communication when frames arrive or the deadline comes, the control
    // tick at its own fixed rate (here 1 kHz, 10 ticks).
    for ms in 0..10u64 {
        let now = Instant::from_millis(ms);
        can_io::service(&mut can, &mut drive, now).map_err(|e| format!("CAN: {e:?}"))?;
        let _demand = drive.tick(now, &Sample::default());
    }

    for frame in &can.tx {
        println!("{:03X} {:02X?}", frame.standard_id().unwrap_or(0), frame.data());
    }
    assert_eq!(drive.od().get::<u16>(0x2000, 0), Ok(2000));
    Ok(())
}
