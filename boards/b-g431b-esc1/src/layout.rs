// The memory layout of the board's two parts, in one place: the firmware uses it as the
// module `layout` (src/lib.rs), and build.rs includes this file (`include!`) to write the
// linker's memory map from the same numbers. (No inner doc comment: `include!` would refuse
// it.)

/// Where the internal flash starts (the bootloader's vector table, and the reset vector's
/// table at power-on).
pub const FLASH_BASE: u32 = 0x0800_0000;
/// Where the RAM starts: SRAM1, followed by SRAM2 and the CCM SRAM on both parts.
pub const RAM_BASE: u32 = 0x2000_0000;
/// A flash page, the erase unit: 2 KiB on the STM32G431CB and on the STM32G474CE in its
/// dual-bank mode.
pub const PAGE: u32 = 2048;
/// The flash write unit: a double word, programmed only into erased flash.
pub const WRITE_UNIT: u32 = 8;
/// Bytes at the start of RAM that neither image links anything into: the hand-over word
/// (src/boot.rs) and padding that keeps the RAM region 16-byte aligned.
pub const HANDOFF_LEN: u32 = 16;
/// Flash from [`FLASH_BASE`] on that the bootloader may take (build.rs checks that its link
/// ends below).
pub const BOOTLOADER_LEN: u32 = 40 * 1024;
/// Where the program's payload (its vector table) lies in the program area: one page after
/// the area's start, the image header's page.
pub const PAYLOAD_OFFSET: u32 = PAGE;

/// One part's flash and RAM, and where each thing lives in them (offsets from
/// [`FLASH_BASE`]):
///
/// ```text
/// 0                           bootloader (BOOTLOADER_LEN)
/// BOOTLOADER_LEN              program area: the image header's page, then the payload
/// lss_page()                  LSS configuration (one page, src/lss.rs)
/// parameters_start()          stored parameters (src/storage.rs), to the end of flash
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Bytes of flash.
    pub flash: u32,
    /// Bytes of RAM.
    pub ram: u32,
    /// Bytes of the parameter area at the end of flash: two pages (one per journal bank) on
    /// the STM32G431CB, four on the STM32G474CE.
    pub parameters: u32,
}

impl Layout {
    /// The STM32G431CB (128 KiB flash, 32 KiB RAM; `g474` false) or the STM32G474CE
    /// (512 KiB, 128 KiB; `g474` true).
    pub const fn of(g474: bool) -> Layout {
        if g474 {
            Layout { flash: 512 * 1024, ram: 128 * 1024, parameters: 4 * PAGE }
        } else {
            Layout { flash: 128 * 1024, ram: 32 * 1024, parameters: 2 * PAGE }
        }
    }

    /// Offset of the parameter area.
    pub const fn parameters_start(&self) -> u32 {
        self.flash - self.parameters
    }

    /// Offset of the LSS configuration page, right below the parameters.
    pub const fn lss_page(&self) -> u32 {
        self.parameters_start() - PAGE
    }

    /// Flash a standalone firmware may link into: everything below the LSS page.
    pub const fn code_len(&self) -> u32 {
        self.lss_page()
    }

    /// Offset of the program area, right after the bootloader.
    pub const fn program_area(&self) -> u32 {
        BOOTLOADER_LEN
    }

    /// Bytes of the program area: up to the LSS page.
    pub const fn program_area_len(&self) -> u32 {
        self.lss_page() - BOOTLOADER_LEN
    }

    /// Flash the application behind the bootloader may link into: the program area after the
    /// header's page.
    pub const fn application_len(&self) -> u32 {
        self.program_area_len() - PAYLOAD_OFFSET
    }
}
