//! The bootloader node of the footprint (`canopen_drive::bootloader::Bootloader`) over a
//! stand-in program area: a flash of 256 KiB (4 KiB sectors, 8-byte units) that reads erased
//! and takes every write, so that the image holds the node's code, not a flash driver's.

use canopen_drive::bootloader::Bootloader;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::{ConfigError, DeviceInfo};
use canopen_drive::storage::{NonVolatile, NvError};
use canopen_drive::{CanFrame, Instant};

/// The bootloader node of the image.
pub type BootNode = Bootloader<Area>;

/// Where the payload lies in the area.
const PAYLOAD_AT: u32 = 512;

/// The program area stand-in.
pub struct Area;

impl NonVolatile for Area {
    fn capacity(&self) -> usize {
        256 * 1024
    }
    fn erase_size(&self) -> usize {
        4096
    }
    fn write_size(&self) -> usize {
        8
    }
    fn read(&mut self, _offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        buf.fill(0xFF);
        Ok(())
    }
    fn write(&mut self, _offset: u32, _data: &[u8]) -> Result<(), NvError> {
        Ok(())
    }
    fn erase(&mut self, _from: u32, _to: u32) -> Result<(), NvError> {
        Ok(())
    }
}

/// Builds the node in `slot` (a static) at the harness's node-ID, with the identity of a
/// servo drive (the application's 1000h and 1018h).
pub fn node(slot: &'static mut Option<BootNode>) -> Result<&'static mut BootNode, ConfigError> {
    let device = DeviceInfo { software_version: "bootloader", ..DeviceInfo::servo_drive() };
    let node = Bootloader::new(device, crate::NODE_ID, Area, PAYLOAD_AT)?;
    Ok(slot.insert(node))
}

impl crate::Node for BootNode {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        Bootloader::on_frame(self, frame, now);
    }
    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let next = Bootloader::poll(self, now);
        // A board starts the program here; the footprint's node stays.
        let _ = self.take_request();
        next
    }
    fn pop_tx(&mut self) -> Option<CanFrame> {
        Bootloader::pop_tx(self)
    }
    /// A bootloader runs no control loop.
    fn tick(&mut self, _now: Instant, _sample: &Sample) -> Demand {
        Demand::OFF
    }
}
