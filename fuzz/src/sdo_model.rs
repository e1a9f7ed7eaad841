//! A model dictionary for fuzzing the SDO server alone: a handful of entries of every shape the
//! server treats differently, and a record of how the server used them.
//!
//! | index | value | access |
//! |---|---|---|
//! | 1000h | 4 bytes | read only |
//! | 2000h | 4 bytes | read/write |
//! | 2001h | up to 300 bytes (more than the server's 256-byte buffer) | read/write |
//! | 2002h | 1000 bytes | read only |
//! | 2003h | 2 bytes | write only |
//! | 2004h | up to 16 bytes, empty at first | read/write |
//! | 2005h | 1 byte, at most 100 | read/write |
//!
//! The model refuses what a dictionary refuses (existence, access, size, limit) and notes what
//! the server must never do: read from beyond a value's end, write more than its buffer, write
//! twice for one request.

use canopen_drive::comm::sdo_server::ObjectAccess;
use canopen_drive::wire::sdo::Mux;
use canopen_drive::AbortCode;

/// The server's download buffer in the fuzz target.
pub const BUFFER: usize = 256;

/// Multiplexers of the model's entries (plus one that does not exist), for structured requests.
pub const MUXES: [(u16, u8); 8] =
    [(0x1000, 0), (0x2000, 0), (0x2001, 0), (0x2002, 0), (0x2003, 0), (0x2004, 0), (0x2005, 0), (0x3000, 0)];

struct Slot {
    index: u16,
    value: Vec<u8>,
    /// `Some(n)`: fixed size; `None`: variable up to `capacity`.
    fixed: Option<usize>,
    capacity: usize,
    readable: bool,
    writable: bool,
    max: Option<u8>,
}

/// The model dictionary (see the [module docs](self)).
pub struct Model {
    slots: Vec<Slot>,
    /// Values written, in order.
    pub writes: Vec<(Mux, Vec<u8>)>,
    /// What the server did that it must not do.
    pub violations: Vec<String>,
}

impl Default for Model {
    fn default() -> Self {
        Model::new()
    }
}

impl Model {
    /// The model with its initial values.
    pub fn new() -> Self {
        let slot = |index, value: Vec<u8>, fixed, capacity, readable, writable, max| Slot {
            index,
            value,
            fixed,
            capacity,
            readable,
            writable,
            max,
        };
        let table: Vec<u8> = (0..1000u32).map(|i| (i * 7 + 3) as u8).collect();
        Model {
            slots: vec![
                slot(0x1000, vec![0x92, 0x01, 0x02, 0x00], Some(4), 4, true, false, None),
                slot(0x2000, vec![1, 2, 3, 4], Some(4), 4, true, true, None),
                slot(0x2001, b"segmented value".to_vec(), None, 300, true, true, None),
                slot(0x2002, table, None, 1000, true, false, None),
                slot(0x2003, vec![0, 0], Some(2), 2, false, true, None),
                slot(0x2004, Vec::new(), None, 16, true, true, None),
                slot(0x2005, vec![50], Some(1), 1, true, true, Some(100)),
            ],
            writes: Vec::new(),
            violations: Vec::new(),
        }
    }

    fn slot(&self, mux: Mux) -> Result<&Slot, AbortCode> {
        let slot = self.slots.iter().find(|s| s.index == mux.index).ok_or(AbortCode::ObjectDoesNotExist)?;
        if mux.sub != 0 {
            return Err(AbortCode::SubIndexDoesNotExist);
        }
        Ok(slot)
    }
}

impl ObjectAccess for Model {
    fn upload_len(&mut self, mux: Mux) -> Result<usize, AbortCode> {
        let slot = self.slot(mux)?;
        if !slot.readable {
            return Err(AbortCode::ReadOfWriteOnly);
        }
        Ok(slot.value.len())
    }

    fn read(&mut self, mux: Mux, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let slot = self.slot(mux)?;
        if !slot.readable {
            self.violations.push(format!("read of write-only {:04X}", mux.index));
            return Err(AbortCode::ReadOfWriteOnly);
        }
        let Some(rest) = slot.value.get(offset..) else {
            let len = slot.value.len();
            self.violations.push(format!("read of {:04X} at {offset}, beyond its {len} bytes", mux.index));
            return Ok(0);
        };
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }

    fn download_check(&mut self, mux: Mux, size: Option<usize>) -> Result<Option<usize>, AbortCode> {
        let slot = self.slot(mux)?;
        if !slot.writable {
            return Err(AbortCode::WriteOfReadOnly);
        }
        match (slot.fixed, size) {
            (Some(n), Some(s)) if s > n => Err(AbortCode::LengthTooHigh),
            (Some(n), Some(s)) if s < n => Err(AbortCode::LengthTooLow),
            (None, Some(s)) if s > slot.capacity => Err(AbortCode::LengthTooHigh),
            _ => Ok(slot.fixed),
        }
    }

    fn write(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        if data.len() > BUFFER {
            self.violations.push(format!("write of {} bytes through a {BUFFER}-byte buffer", data.len()));
        }
        let slot = self.slot(mux)?;
        if !slot.writable {
            self.violations.push(format!("write to read-only {:04X} reached the dictionary", mux.index));
            return Err(AbortCode::WriteOfReadOnly);
        }
        match slot.fixed {
            Some(n) if data.len() > n => return Err(AbortCode::LengthTooHigh),
            Some(n) if data.len() < n => return Err(AbortCode::LengthTooLow),
            None if data.len() > slot.capacity => return Err(AbortCode::LengthTooHigh),
            _ => {}
        }
        if slot.max.is_some_and(|max| data.first().is_some_and(|v| *v > max)) {
            return Err(AbortCode::ValueTooHigh);
        }
        let index = mux.index;
        if let Some(slot) = self.slots.iter_mut().find(|s| s.index == index) {
            slot.value = data.to_vec();
        }
        self.writes.push((mux, data.to_vec()));
        Ok(())
    }
}
