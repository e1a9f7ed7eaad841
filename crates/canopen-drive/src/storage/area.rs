//! The board's non-volatile area, seen as NOR flash.

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};

/// Why the non-volatile area refused or failed an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum NvError {
    /// The range lies (partly) outside the area.
    OutOfBounds,
    /// The offset or length is not a multiple of the write or erase size.
    NotAligned,
    /// The device failed (programming or erase error, power lost, I/O error...).
    Device,
}

/// A non-volatile area with NOR-flash semantics, at offsets `0..capacity()`.
///
/// - [`erase`](Self::erase) sets whole sectors of [`erase_size`](Self::erase_size) bytes to
///   0xFF;
/// - [`write`](Self::write) programs erased bytes, in units of
///   [`write_size`](Self::write_size) bytes at offsets that are multiples of it; programming
///   can only clear bits, so a unit is programmed once between two erases;
/// - [`read`](Self::read) reads any byte range.
///
/// The journal in [`Storage`](super::Storage) relies on nothing more: it programs every unit at
/// most once after erasing it, and never assumes an operation that failed left anything in a
/// known state.
pub trait NonVolatile {
    /// Bytes in the area.
    fn capacity(&self) -> usize;
    /// Bytes of one erase sector (at least 1).
    fn erase_size(&self) -> usize;
    /// Bytes of one program unit (at least 1).
    fn write_size(&self) -> usize;
    /// Reads `buf.len()` bytes from `offset` on.
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError>;
    /// Programs `data` at `offset`; both `offset` and `data.len()` are multiples of
    /// [`write_size`](Self::write_size).
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError>;
    /// Erases the sectors in `from..to` (both multiples of [`erase_size`](Self::erase_size)),
    /// lowest first.
    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError>;
}

impl<T: NonVolatile + ?Sized> NonVolatile for &mut T {
    fn capacity(&self) -> usize {
        (**self).capacity()
    }
    fn erase_size(&self) -> usize {
        (**self).erase_size()
    }
    fn write_size(&self) -> usize {
        (**self).write_size()
    }
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        (**self).read(offset, buf)
    }
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        (**self).write(offset, data)
    }
    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        (**self).erase(from, to)
    }
}

fn nor_error<E: NorFlashError>(error: E) -> NvError {
    match error.kind() {
        NorFlashErrorKind::NotAligned => NvError::NotAligned,
        NorFlashErrorKind::OutOfBounds => NvError::OutOfBounds,
        _ => NvError::Device,
    }
}

/// Largest read granularity [`NorFlashArea`] handles for reads at any offset.
pub const MAX_READ_SIZE: usize = 64;

/// A window of any [`embedded_storage`] NOR flash used as the [`NonVolatile`] area: the sectors
/// `start..start + len` of the flash (e.g. the last two sectors of an MCU's internal flash),
/// seen at offsets `0..len`.
///
/// Reads may start and end anywhere: when the flash reads in units (`READ_SIZE` > 1, up to
/// [`MAX_READ_SIZE`]) the ends go through a small buffer. Writes and erases keep the flash's
/// own granularity (`WRITE_SIZE`, `ERASE_SIZE`) and are refused with [`NvError::NotAligned`]
/// when they break it, since NOR flash cannot merge a partial unit.
#[derive(Debug)]
pub struct NorFlashArea<F> {
    flash: F,
    start: u32,
    len: u32,
}

impl<F: NorFlash> NorFlashArea<F> {
    /// The window `start..start + len` of `flash`. Both must be multiples of the erase size and
    /// the window must lie inside the flash.
    pub fn new(flash: F, start: u32, len: u32) -> Result<Self, NvError> {
        let erase = F::ERASE_SIZE;
        let end = start.checked_add(len).ok_or(NvError::OutOfBounds)?;
        if erase == 0 || F::WRITE_SIZE == 0 || F::READ_SIZE > MAX_READ_SIZE {
            return Err(NvError::NotAligned);
        }
        if !(start as usize).is_multiple_of(erase) || !(len as usize).is_multiple_of(erase) {
            return Err(NvError::NotAligned);
        }
        if end as usize > flash.capacity() {
            return Err(NvError::OutOfBounds);
        }
        Ok(NorFlashArea { flash, start, len })
    }

    /// The whole flash, rounded down to whole sectors.
    pub fn whole(flash: F) -> Result<Self, NvError> {
        let erase = F::ERASE_SIZE.max(1);
        let len = flash.capacity() / erase * erase;
        let len = u32::try_from(len).map_err(|_| NvError::OutOfBounds)?;
        Self::new(flash, 0, len)
    }

    /// The flash.
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// Gives the flash back.
    pub fn into_inner(self) -> F {
        self.flash
    }

    /// Flash address of area offset `offset` for `n` bytes, after a bounds check.
    fn address(&self, offset: u32, n: usize) -> Result<u32, NvError> {
        let n = u32::try_from(n).map_err(|_| NvError::OutOfBounds)?;
        let end = offset.checked_add(n).ok_or(NvError::OutOfBounds)?;
        if end > self.len {
            return Err(NvError::OutOfBounds);
        }
        Ok(self.start + offset)
    }
}

impl<F: NorFlash> NonVolatile for NorFlashArea<F> {
    fn capacity(&self) -> usize {
        self.len as usize
    }

    fn erase_size(&self) -> usize {
        F::ERASE_SIZE
    }

    fn write_size(&self) -> usize {
        F::WRITE_SIZE
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        let address = self.address(offset, buf.len())?;
        let unit = F::READ_SIZE.max(1);
        if unit == 1 {
            return self.flash.read(address, buf).map_err(nor_error);
        }
        // `unit` divides the erase size and so the window's start: aligning the flash address
        // aligns the area offset too.
        let unit32 = u32::try_from(unit).map_err(|_| NvError::NotAligned)?;
        let mut at = address;
        let mut rest = buf;
        let mut bounce = [0u8; MAX_READ_SIZE];
        while !rest.is_empty() {
            let skip = (at % unit32) as usize;
            if skip == 0 && rest.len() >= unit {
                // Whole units straight into the caller's buffer.
                let whole = rest.len() / unit * unit;
                let (head, tail) = rest.split_at_mut(whole);
                self.flash.read(at, head).map_err(nor_error)?;
                at += u32::try_from(whole).map_err(|_| NvError::OutOfBounds)?;
                rest = tail;
            } else {
                let block = bounce.get_mut(..unit).ok_or(NvError::NotAligned)?;
                self.flash.read(at - skip as u32, block).map_err(nor_error)?;
                let n = (unit - skip).min(rest.len());
                let (head, tail) = rest.split_at_mut(n);
                head.copy_from_slice(block.get(skip..skip + n).ok_or(NvError::NotAligned)?);
                at += n as u32;
                rest = tail;
            }
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        let address = self.address(offset, data.len())?;
        let unit = F::WRITE_SIZE.max(1);
        if !(offset as usize).is_multiple_of(unit) || !data.len().is_multiple_of(unit) {
            return Err(NvError::NotAligned);
        }
        self.flash.write(address, data).map_err(nor_error)
    }

    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        if to < from {
            return Err(NvError::OutOfBounds);
        }
        let address = self.address(from, (to - from) as usize)?;
        let unit = F::ERASE_SIZE.max(1);
        if !(from as usize).is_multiple_of(unit) || !(to as usize).is_multiple_of(unit) {
            return Err(NvError::NotAligned);
        }
        self.flash.erase(address, address + (to - from)).map_err(nor_error)
    }
}

#[cfg(test)]
mod tests {
    use embedded_storage::nor_flash::{ErrorType, ReadNorFlash};

    use super::*;

    /// A NOR flash that reads in 4-byte units, programs 8-byte units, erases 64-byte sectors.
    struct Chip {
        bytes: [u8; 256],
    }

    impl ErrorType for Chip {
        type Error = NorFlashErrorKind;
    }

    impl ReadNorFlash for Chip {
        const READ_SIZE: usize = 4;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
            embedded_storage::nor_flash::check_read(self, offset, bytes.len())?;
            bytes.copy_from_slice(&self.bytes[offset as usize..offset as usize + bytes.len()]);
            Ok(())
        }
        fn capacity(&self) -> usize {
            self.bytes.len()
        }
    }

    impl NorFlash for Chip {
        const WRITE_SIZE: usize = 8;
        const ERASE_SIZE: usize = 64;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
            embedded_storage::nor_flash::check_erase(self, from, to)?;
            self.bytes[from as usize..to as usize].fill(0xFF);
            Ok(())
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
            embedded_storage::nor_flash::check_write(self, offset, bytes.len())?;
            for (d, s) in self.bytes[offset as usize..].iter_mut().zip(bytes) {
                *d &= *s;
            }
            Ok(())
        }
    }

    fn chip() -> Chip {
        let mut bytes = [0u8; 256];
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = i as u8;
        }
        Chip { bytes }
    }

    #[test]
    fn window_geometry_is_checked() {
        assert_eq!(NorFlashArea::new(chip(), 64, 128).unwrap().capacity(), 128);
        assert_eq!(NorFlashArea::new(chip(), 32, 128).err(), Some(NvError::NotAligned));
        assert_eq!(NorFlashArea::new(chip(), 64, 100).err(), Some(NvError::NotAligned));
        assert_eq!(NorFlashArea::new(chip(), 128, 192).err(), Some(NvError::OutOfBounds));
        assert_eq!(NorFlashArea::whole(chip()).unwrap().capacity(), 256);
    }

    #[test]
    fn reads_at_any_offset_through_read_units() {
        let mut area = NorFlashArea::new(chip(), 64, 128).unwrap();
        for start in 0..20u32 {
            for len in 0..20usize {
                let mut buf = [0u8; 20];
                area.read(start, &mut buf[..len]).unwrap();
                for (i, b) in buf[..len].iter().enumerate() {
                    assert_eq!(*b as usize, 64 + start as usize + i);
                }
            }
        }
        let mut buf = [0u8; 4];
        assert_eq!(area.read(126, &mut buf), Err(NvError::OutOfBounds));
    }

    #[test]
    fn writes_and_erases_keep_the_granularity() {
        let mut area = NorFlashArea::new(chip(), 64, 128).unwrap();
        assert_eq!(area.write(4, &[0; 8]), Err(NvError::NotAligned));
        assert_eq!(area.write(8, &[0; 4]), Err(NvError::NotAligned));
        assert_eq!(area.erase(0, 32), Err(NvError::NotAligned));
        assert_eq!(area.erase(64, 192), Err(NvError::OutOfBounds));
        area.erase(64, 128).unwrap();
        area.write(72, &[0x12; 8]).unwrap();
        let mut buf = [0u8; 10];
        area.read(70, &mut buf).unwrap();
        assert_eq!(buf, [0xFF, 0xFF, 0x12, 0x12, 0x12, 0x12, 0x12, 0x12, 0x12, 0x12]);
        let chip = area.into_inner();
        assert_eq!(chip.bytes[64 + 63], 64 + 63, "the first sector of the window is untouched");
        assert_eq!(chip.bytes[128], 0xFF);
    }
}
