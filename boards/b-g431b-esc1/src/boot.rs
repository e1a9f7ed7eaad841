//! Program download on this board (CiA 302-3): the program area the bootloader
//! (`src/bin/bootloader.rs`) fills and the application (built with the feature
//! `application-image`) runs from, the hand-over word between the two, the check of an
//! image's vector table, the jump into it, and the reset back into the bootloader.
//!
//! | what | STM32G431CB (128 KiB) | STM32G474CE (512 KiB, dual-bank mode) |
//! |---|---|---|
//! | bootloader | 0x0800_0000, 40 KiB | 0x0800_0000, 40 KiB |
//! | program area: the image header's page | 0x0800_A000 | 0x0800_A000 |
//! | program area: the payload (the application's vector table, code, data) | 0x0800_A800, 80 KiB | 0x0800_A800, 460 KiB |
//! | LSS configuration page | 0x0801_E800 | 0x0807_D800 |
//! | parameters | 0x0801_F000, 2 pages | 0x0807_E000, 4 pages |
//! | hand-over word | 0x2000_0000 (SRAM1) | 0x2000_0000 (SRAM1) |
//!
//! (`layout` holds the numbers; build.rs writes the linker's map from them.) The program area
//! is a [`NorFlashArea`] over embassy-stm32's blocking flash driver: 2 KiB pages, 8-byte
//! writes into erased flash. The core's program download erases it one page per `poll`,
//! with 1F57h bit 0 (busy) set meanwhile.
//!
//! The hand-over word: the application writes [`STAY_IN_BOOTLOADER`] there before it resets
//! for a stop (1F51h:1 = 0), and 0 for a reset (2). The bootloader reads and clears it first
//! thing: "stay" keeps it running even with a valid program in the area; anything else lets
//! it check the image and jump to a valid program before it initialises anything. It
//! relies on SRAM1 keeping its content through a system reset, which nobody has checked on
//! the board yet; if it did not, a stop would end with the application starting again
//! (never in a loop: only "stay" is read from the word).
//!
//! Both directions go through a reset, so each image starts with every peripheral in its
//! reset state: the bootloader jumps to the program only from its own first instructions
//! ([`start_image`]), and a start from the running bootloader (1F51h:1 = 1) is a reset that
//! ends in that jump.

use canopen_drive::comm::program::{ImageHeader, HEADER_LEN};
use canopen_drive::storage::{NonVolatile, NorFlashArea, NvError};
use embassy_stm32::flash::{Blocking, Flash, MAX_ERASE_SIZE, WRITE_SIZE};

use crate::layout::{self, THIS_PART};

/// The program area: the internal flash's pages after the bootloader.
pub type ProgramArea = NorFlashArea<Flash<'static, Blocking>>;

/// Offset of the program area in flash (the image header's page).
pub const PROGRAM_AREA: u32 = THIS_PART.program_area();
/// Bytes of the program area.
pub const PROGRAM_AREA_LEN: u32 = THIS_PART.program_area_len();
/// Where the payload (the application's vector table) lies in the area.
pub const PAYLOAD_OFFSET: u32 = layout::PAYLOAD_OFFSET;
/// The hand-over word: the first word of SRAM1, outside either image's RAM region.
pub const HANDOFF: u32 = layout::RAM_BASE;
/// The hand-over word's value that keeps the bootloader running ("STAY").
pub const STAY_IN_BOOTLOADER: u32 = 0x5941_5453;

// The driver's units are the layout's.
const _: () = assert!(layout::PAGE as usize == MAX_ERASE_SIZE && layout::WRITE_UNIT as usize == WRITE_SIZE);
// The payload: past the header, in whole write units, and 2 KiB-aligned, which serves any
// ARMv7-M vector table (at most 16 + 496 words) as VTOR requires.
const _: () = assert!(PAYLOAD_OFFSET as usize >= HEADER_LEN && PAYLOAD_OFFSET.is_multiple_of(2048));
const _: () = assert!(PROGRAM_AREA.is_multiple_of(2048) && PROGRAM_AREA_LEN.is_multiple_of(layout::PAGE));
// The area stays clear of the LSS page and the parameters.
const _: () = assert!(PROGRAM_AREA + PROGRAM_AREA_LEN <= crate::lss::PAGE_START);

/// The program area over the flash driver.
pub fn program_area(flash: Flash<'static, Blocking>) -> Result<ProgramArea, NvError> {
    NorFlashArea::new(flash, PROGRAM_AREA, PROGRAM_AREA_LEN)
}

/// The running program's identification for 1F56h:1: the CRC-32 in the header the bootloader
/// wrote before it (0 without one).
pub fn identification(flash: &mut Flash<'static, Blocking>) -> u32 {
    let mut raw = [0u8; HEADER_LEN];
    if flash.blocking_read(PROGRAM_AREA, &mut raw).is_err() {
        return 0;
    }
    ImageHeader::decode(&raw).map_or(0, |header| header.crc)
}

/// The vector table of the program whose payload (`len` bytes) starts at [`PAYLOAD_OFFSET`]
/// in `area`, if it looks like one of this board's: an initial stack pointer in RAM and a
/// Thumb reset vector inside the payload. A payload whose CRC is right but that is no
/// program for this place is not started.
pub fn vector_table(area: &mut impl NonVolatile, len: u32) -> Option<u32> {
    let mut words = [0u8; 8];
    area.read(PAYLOAD_OFFSET, &mut words).ok()?;
    let [s0, s1, s2, s3, r0, r1, r2, r3] = words;
    let stack = u32::from_le_bytes([s0, s1, s2, s3]);
    let reset = u32::from_le_bytes([r0, r1, r2, r3]);
    let table = layout::FLASH_BASE + PROGRAM_AREA + PAYLOAD_OFFSET;
    let code = table..table.checked_add(len)?;
    let ram = layout::RAM_BASE..=layout::RAM_BASE + THIS_PART.ram;
    (ram.contains(&stack) && reset & 1 == 1 && code.contains(&(reset & !1))).then_some(table)
}

/// True when the application asked the bootloader to stay ([`STAY_IN_BOOTLOADER`]); clears
/// the word, so that the next reset starts the program again.
pub fn take_stay() -> bool {
    let word = HANDOFF as *mut u32;
    // SAFETY: the hand-over word is RAM outside either image's sections (build.rs).
    unsafe {
        let stay = word.read_volatile() == STAY_IN_BOOTLOADER;
        word.write_volatile(0);
        stay
    }
}

/// Resets the MCU into the bootloader: with `stay`, it stays (a stop); without, it starts
/// the program in the area (a reset, or the start of a new one).
pub fn reset_into_bootloader(stay: bool) -> ! {
    let value = if stay { STAY_IN_BOOTLOADER } else { 0 };
    // SAFETY: as in `take_stay`.
    unsafe { (HANDOFF as *mut u32).write_volatile(value) };
    cortex_m::asm::dsb();
    cortex_m::peripheral::SCB::sys_reset()
}

/// Hands the core to the image whose vector table is at `vector_table`, as a reset would:
/// interrupts masked, VTOR set, the main stack pointer from the table, CONTROL cleared (main
/// stack, privileged, no floating-point context), interrupts unmasked, a branch to the reset
/// vector.
///
/// # Safety
///
/// `vector_table` is the vector table of an image linked to run from there, and the caller
/// has enabled no interrupt and started no peripheral: this is the bootloader's first work
/// after its reset.
pub unsafe fn start_image(vector_table: u32) -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: VTOR takes any 128-byte-aligned address of a table (checked by the caller's
    // layout); nothing else uses the SCB now.
    unsafe { (*cortex_m::peripheral::SCB::PTR).vtor.write(vector_table) };
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    // SAFETY: the table's first two words are the image's initial stack pointer and reset
    // vector (the caller's promise).
    let (stack, reset) = unsafe {
        let table = vector_table as *const u32;
        (table.read_volatile(), table.add(1).read_volatile())
    };
    // SAFETY: nothing of this image runs after the branch, so its stack may be dropped; no
    // interrupt source is enabled when interrupts are unmasked.
    unsafe {
        core::arch::asm!(
            "msr msp, {stack}",
            "msr control, {zero}",
            "isb",
            "cpsie i",
            "bx {reset}",
            stack = in(reg) stack,
            zero = in(reg) 0u32,
            reset = in(reg) reset | 1,
            options(noreturn, nostack),
        )
    }
}
