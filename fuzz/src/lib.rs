//! Shared harness of the canopen-drive fuzz targets.
//!
//! - [`ops`]: the input language: a fuzz input is a sequence of [`ops::Op`]s (a raw frame, a
//!   time step, an SDO write, an NMT command, a motor fault, …), decoded from bytes so that
//!   every byte string is a valid program, and encoded back by the seed generator.
//! - [`rig`]: a whole drive with its simulated motor, ticked at 1 kHz, fed the ops, with the
//!   DESIGN invariants checked after every step ([`canopen_drive_sim::invariants`]).
//! - [`sdo_model`]: a model dictionary for the SDO server fuzzed alone.
//! - [`targets`]: the bodies of the four fuzz targets, also run by the `replay` binary.
//!
//! A violated invariant is a `panic!` with the description, which libFuzzer reports as a crash.

pub mod ops;
pub mod rig;
pub mod sdo_model;
pub mod targets;

/// Reads fields from a fuzz input; an exhausted input reads as zeros.
#[derive(Clone, Debug)]
pub struct Reader<'a> {
    data: &'a [u8],
}

impl<'a> Reader<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Reader { data }
    }

    /// True when every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The next byte (0 when exhausted).
    pub fn u8(&mut self) -> u8 {
        match self.data.split_first() {
            Some((first, rest)) => {
                self.data = rest;
                *first
            }
            None => 0,
        }
    }

    /// The next two bytes, little-endian.
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    /// The next four bytes, little-endian.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    /// The next `n` bytes (zero-padded when exhausted).
    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.u8()).collect()
    }
}
