//! Program download on this board (CiA 302-3): the memory layout the bootloader
//! (`src/bin/bootloader.rs`) and the application (`qemu-mps2` built with the feature
//! `application-image`) agree on, the program area as a [`NonVolatile`] area, the hand-over
//! word, and the jump from one image to the other.
//!
//! QEMU's mps2 "flash" (ZBT SSRAM1 at 0x0000_0000, 4 MiB) is RAM: the program area is a
//! region of it that the bootloader erases (fills with 0xFF) and programs like NOR flash.
//!
//! | what | address | size | linked by |
//! |---|---|---|---|
//! | bootloader | 0x0000_0000 | below 64 KiB (a link-time check) | `memory/standalone.x` + `memory/bootloader.x` |
//! | program area: image header ("CDPI", 16 bytes) | [`PROGRAM_AREA`] = 0x0001_0000 | [`PROGRAM_AREA_LEN`] = 1 MiB, [`SECTOR`] 4 KiB sectors, [`WRITE_UNIT`] 8-byte writes | — |
//! | application: vector table, code, data | [`PROGRAM_AREA`] + [`PAYLOAD_OFFSET`] = 0x0001_0400 | up to 1 MiB − 1 KiB | `memory/application.x` |
//! | RAM of either image | 0x2000_0000 | 64 KiB | both |
//! | hand-over word | [`HANDOFF`] = 0x2001_0000 | 4 bytes, initialised by neither | — |
//!
//! The numbers here and in the linker scripts are the same by hand (the scripts say so).
//!
//! The hand-over word: the application writes [`STAY_IN_BOOTLOADER`] there before it jumps
//! to the bootloader for a stop (1F51h:1 = 0); the bootloader then stays even though the area
//! holds a valid program, and clears the word when it starts the program. A cold start of
//! QEMU finds 0 there.
//!
//! The jump ([`start_image`]) stands in for a reset: QEMU's own reset (SYSRESETREQ) would
//! reload the images given on its command line and undo a download.

use canopen_drive::storage::{NonVolatile, NvError};

/// Where the bootloader's vector table is.
pub const BOOTLOADER: u32 = 0x0000_0000;
/// Start of the program area (the image header).
pub const PROGRAM_AREA: u32 = 0x0001_0000;
/// Bytes of the program area.
pub const PROGRAM_AREA_LEN: u32 = 1024 * 1024;
/// Where the payload (the application's vector table) lies in the area: a multiple of the
/// write unit past the header, aligned for VTOR (a table of 16 + 32 vectors needs 256 bytes;
/// 1 KiB serves any Cortex-M's).
pub const PAYLOAD_OFFSET: u32 = 0x400;
/// Erase sector of the program area.
pub const SECTOR: usize = 4096;
/// Write unit of the program area.
pub const WRITE_UNIT: usize = 8;
/// The hand-over word, right above the 64 KiB of RAM both images use.
pub const HANDOFF: usize = 0x2001_0000;
/// The hand-over word's value that keeps the bootloader running ("STAY").
pub const STAY_IN_BOOTLOADER: u32 = 0x5941_5453;

/// The RAM an image's initial stack pointer must lie in (SSRAM2/3).
const RAM: core::ops::RangeInclusive<u32> = 0x2000_0000..=0x2040_0000;

const _: () = assert!(PAYLOAD_OFFSET as usize >= canopen_drive::comm::program::HEADER_LEN);
const _: () =
    assert!((PAYLOAD_OFFSET as usize).is_multiple_of(WRITE_UNIT) && PAYLOAD_OFFSET.is_multiple_of(256));
const _: () =
    assert!((PROGRAM_AREA_LEN as usize).is_multiple_of(SECTOR) && SECTOR.is_multiple_of(WRITE_UNIT));

/// A region of memory used as NOR flash: erase fills whole sectors with 0xFF, a write programs
/// whole units and, like flash, only clears bits (the new byte is the old one AND the data).
#[derive(Debug)]
pub struct MemoryArea {
    start: usize,
    len: usize,
}

impl MemoryArea {
    /// The `len` bytes from address `start` on.
    ///
    /// # Safety
    ///
    /// The range is memory this image may read and write, and nothing else in it (its own
    /// code, data or stack, another `MemoryArea`) uses it while the area lives.
    pub const unsafe fn new(start: usize, len: usize) -> Self {
        MemoryArea { start, len }
    }

    /// The address of `offset..offset + n` after a bounds check.
    fn at(&self, offset: u32, n: usize) -> Result<*mut u8, NvError> {
        let end = (offset as usize).checked_add(n).ok_or(NvError::OutOfBounds)?;
        if end > self.len {
            return Err(NvError::OutOfBounds);
        }
        Ok((self.start + offset as usize) as *mut u8)
    }
}

impl NonVolatile for MemoryArea {
    fn capacity(&self) -> usize {
        self.len
    }

    fn erase_size(&self) -> usize {
        SECTOR
    }

    fn write_size(&self) -> usize {
        WRITE_UNIT
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        let from = self.at(offset, buf.len())?;
        // SAFETY: the range lies inside the area (checked), which `new`'s caller gave to it.
        unsafe { core::ptr::copy_nonoverlapping(from, buf.as_mut_ptr(), buf.len()) };
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        if !(offset as usize).is_multiple_of(WRITE_UNIT) || !data.len().is_multiple_of(WRITE_UNIT) {
            return Err(NvError::NotAligned);
        }
        let to = self.at(offset, data.len())?;
        for (i, &byte) in data.iter().enumerate() {
            // SAFETY: as in `read`; volatile, so that each byte is programmed as flash would.
            unsafe {
                let cell = to.add(i);
                cell.write_volatile(cell.read_volatile() & byte);
            }
        }
        Ok(())
    }

    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        if !(from as usize).is_multiple_of(SECTOR) || !(to as usize).is_multiple_of(SECTOR) || to < from {
            return Err(NvError::NotAligned);
        }
        let start = self.at(from, (to - from) as usize)?;
        // SAFETY: as in `read`.
        unsafe { core::ptr::write_bytes(start, 0xFF, (to - from) as usize) };
        Ok(())
    }
}

/// The vector table of the program whose payload (`len` bytes) starts at `payload_offset` in
/// `area`, which the core sees at `area_address`, if it looks like one: an initial stack
/// pointer in RAM and a Thumb reset vector inside the payload. A payload whose CRC is right
/// but that is no program for this board is not started.
pub fn vector_table(
    area: &mut impl NonVolatile,
    area_address: u32,
    payload_offset: u32,
    len: u32,
) -> Option<u32> {
    let mut words = [0u8; 8];
    area.read(payload_offset, &mut words).ok()?;
    let [s0, s1, s2, s3, r0, r1, r2, r3] = words;
    let stack = u32::from_le_bytes([s0, s1, s2, s3]);
    let reset = u32::from_le_bytes([r0, r1, r2, r3]);
    let table = area_address.checked_add(payload_offset)?;
    let code = table..table.checked_add(len)?;
    (RAM.contains(&stack) && reset & 1 == 1 && code.contains(&(reset & !1))).then_some(table)
}

/// The program area of this board.
#[cfg(target_os = "none")]
pub fn program_area() -> MemoryArea {
    // SAFETY: 0x0001_0000..0x0011_0000 is SSRAM1, which neither image links anything into
    // (memory/bootloader.x and memory/application.x keep them out); each image makes one area.
    unsafe { MemoryArea::new(PROGRAM_AREA as usize, PROGRAM_AREA_LEN as usize) }
}

/// True when the image that jumped to the bootloader asked it to stay ([`STAY_IN_BOOTLOADER`]).
#[cfg(target_os = "none")]
pub fn stay_requested() -> bool {
    // SAFETY: the hand-over word is RAM outside either image's sections.
    unsafe { (HANDOFF as *const u32).read_volatile() == STAY_IN_BOOTLOADER }
}

/// Sets (`true`) or clears the hand-over word.
#[cfg(target_os = "none")]
pub fn set_stay(stay: bool) {
    let value = if stay { STAY_IN_BOOTLOADER } else { 0 };
    // SAFETY: as in `stay_requested`.
    unsafe { (HANDOFF as *mut u32).write_volatile(value) };
}

/// Hands the core to the image whose vector table is at `vector_table`, as a reset would:
/// interrupts masked, every interrupt source this board's images use stopped (TIMER0, the dual
/// timer, SysTick, UART0's interrupts) and every NVIC line disabled and unpended, VTOR set, the
/// main stack pointer from the table, CONTROL cleared (main stack, privileged, no FP context),
/// interrupts unmasked again, and a branch to the reset vector. UART0 keeps what it has
/// sent and received: the new image goes on reading the same link.
///
/// Call from thread mode, never inside the drive's lock (BASEPRI is 0 there, as at reset).
///
/// # Safety
///
/// `vector_table` is the vector table of an image linked to run from there.
#[cfg(target_os = "none")]
pub unsafe fn start_image(vector_table: u32) -> ! {
    use crate::mps2::{core_registers, dualtimer, systick, timer0, uart0};
    cortex_m::interrupt::disable();
    timer0::stop();
    dualtimer::stop();
    systick::stop();
    uart0::disable_interrupts();
    core_registers::disable_interrupt_lines();
    core_registers::set_vector_table(vector_table);
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    // SAFETY: the table's first two words are the image's initial stack pointer and reset
    // vector (the caller's promise).
    let (stack, reset) = unsafe {
        let table = vector_table as *const u32;
        (table.read_volatile(), table.add(1).read_volatile())
    };
    // SAFETY: nothing of this image runs after the branch, so its stack may be dropped; no
    // interrupt source is left enabled when interrupts are unmasked.
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

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use canopen_drive::comm::program::{read_header, ImageHeader, ProgramDownload, ProgramState, HEADER_LEN};
    use std::boxed::Box;
    use std::vec;

    /// An area over a buffer of the test (leaked: the area lives as long as the test).
    fn area(len: usize) -> MemoryArea {
        let buf: &'static mut [u8] = Box::leak(vec![0x5Au8; len].into_boxed_slice());
        // SAFETY: the buffer is the area's alone.
        unsafe { MemoryArea::new(buf.as_mut_ptr() as usize, len) }
    }

    #[test]
    fn erase_fills_sectors_and_writes_only_clear_bits_in_whole_units() {
        let mut a = area(2 * SECTOR);
        assert_eq!(a.erase(0, SECTOR as u32), Ok(()));
        let mut buf = [0u8; 16];
        a.read(SECTOR as u32 - 8, &mut buf).unwrap();
        assert_eq!(
            buf,
            [0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x5A, 0x5A, 0x5A, 0x5A, 0x5A, 0x5A, 0x5A, 0x5A]
        );
        assert_eq!(a.write(8, &[0x0F; 8]), Ok(()));
        assert_eq!(a.write(8, &[0xF1; 8]), Ok(()));
        a.read(8, &mut buf[..8]).unwrap();
        assert_eq!(buf[..8], [0x01; 8], "programming ANDs, as NOR flash");
        assert_eq!(a.write(4, &[0; 8]), Err(NvError::NotAligned));
        assert_eq!(a.write(8, &[0; 4]), Err(NvError::NotAligned));
        assert_eq!(a.erase(0, 100), Err(NvError::NotAligned));
        assert_eq!(a.write(2 * SECTOR as u32, &[0; 8]), Err(NvError::OutOfBounds));
        assert_eq!(a.read(2 * SECTOR as u32 - 4, &mut buf), Err(NvError::OutOfBounds));
        assert_eq!(a.erase(SECTOR as u32, 3 * SECTOR as u32), Err(NvError::OutOfBounds));
    }

    fn crc32(data: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in data {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }

    /// The core's bootloader service takes an image into the area; the application reads
    /// its identification back, and the vector table check finds the program.
    #[test]
    fn an_image_downloaded_into_the_area_is_verified_and_its_vector_table_found() {
        let len = 4 * SECTOR;
        let mut a = area(len);
        let table = PROGRAM_AREA + PAYLOAD_OFFSET;
        let mut payload = vec![0u8; 3000];
        payload[..4].copy_from_slice(&0x2001_0000u32.to_le_bytes());
        payload[4..8].copy_from_slice(&(table + 0x101).to_le_bytes());
        for (i, b) in payload.iter_mut().enumerate().skip(8) {
            *b = (i * 7) as u8;
        }
        let header = ImageHeader { len: payload.len() as u32, crc: crc32(&payload) };
        let mut image = header.encode().to_vec();
        image.extend_from_slice(&payload);

        let mut service = ProgramDownload::bootloader(&mut a, PAYLOAD_OFFSET);
        assert_eq!(service.state(), ProgramState::NoProgram);
        service.command(3).unwrap();
        while service.poll() {}
        service.begin(Some(image.len())).unwrap();
        for (i, piece) in image.chunks(889).enumerate() {
            let last = (i + 1) * 889 >= image.len();
            service.piece(i * 889, piece, last).unwrap();
        }
        while service.poll() {}
        assert_eq!(service.state(), ProgramState::Stopped);
        assert_eq!(service.identification(), header.crc);

        assert_eq!(read_header(&mut a), Ok(header));
        let mut raw = [0u8; HEADER_LEN];
        a.read(0, &mut raw).unwrap();
        assert_eq!(raw, header.encode());
        assert_eq!(vector_table(&mut a, PROGRAM_AREA, PAYLOAD_OFFSET, header.len), Some(table));
        // A reset vector outside the payload, or a stack outside RAM, is no program.
        assert_eq!(vector_table(&mut a, PROGRAM_AREA, PAYLOAD_OFFSET, 0x100), None);
        let mut b = area(len);
        b.erase(0, len as u32).unwrap();
        b.write(PAYLOAD_OFFSET, &[0, 0, 0, 0x10, 0x01, 0x01, 0x00, 0x00]).unwrap();
        assert_eq!(vector_table(&mut b, PROGRAM_AREA, PAYLOAD_OFFSET, 3000), None);
    }
}
