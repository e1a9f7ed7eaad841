//! Stored parameters (1010h/1011h) in the last two pages of the internal flash (2 × 2 KiB on
//! the STM32G431CB, 4 × 2 KiB on the STM32G474CE in dual-bank mode), through `embedded-storage`: the core's
//! power-loss-safe two-bank journal over a `NorFlashArea`. build.rs keeps them (and the LSS
//! configuration page below them, `lss.rs`) out of the linker's flash region (`layout`).

use canopen_drive::od::DeviceInfo;
use canopen_drive::storage::{device_signature, NorFlashArea, Storage};
use embassy_stm32::flash::{Blocking, Flash};

use crate::layout::THIS_PART;

/// Its size: two pages (one per journal bank) on the STM32G431CB, four on the STM32G474CE
/// (`layout::Layout::parameters`).
pub const AREA_LEN: u32 = THIS_PART.parameters;
/// Where the parameters live: the end of flash (offsets from the start of flash).
pub const AREA_START: u32 = THIS_PART.parameters_start();

/// The parameter storage of this board.
pub type ParameterStore = Storage<NorFlashArea<Flash<'static, Blocking>>>;

/// Opens the parameter area (reads nothing yet: the drive loads the stored set when it is
/// built). The drive owns the flash from then on; the LSS configuration page is written
/// through it (`Drive::storage_mut`).
pub fn open(flash: Flash<'static, Blocking>, device: &DeviceInfo, layout: u16) -> Option<ParameterStore> {
    let area = NorFlashArea::new(flash, AREA_START, AREA_LEN).ok()?;
    Storage::new(area, device_signature(device, layout)).ok()
}
