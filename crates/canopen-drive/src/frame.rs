//! The core's CAN frame, and conversion to and from any `embedded_can::Frame`.
//!
//! Classic CAN only: up to 8 data bytes, 11- or 29-bit identifiers, data or remote frames.
//! The core accepts frames of any driver through [`CanFrame::from_frame`] and hands its own
//! frames back through [`CanFrame::to_frame`], so a board never copies bytes by hand.

use embedded_can::{ExtendedId, Frame, Id, StandardId};

/// A classic CAN frame (data or remote), owned and `Copy`.
///
/// With the `defmt` feature it is logged as candump writes a frame: `605#4000100000000000`
/// (3 hex digits for an 11-bit identifier, 8 for a 29-bit one, `R` and the length for a
/// remote frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CanFrame {
    // Word-sized fields first: a frame is 16 bytes, aligned, and copied as four words (the
    // transmit queue moves every frame once).
    data: [u8; 8],
    /// The raw identifier; [`EXTENDED`] set for a 29-bit one.
    id: u32,
    remote: bool,
    dlc: u8,
}

/// Bit of [`CanFrame`]'s raw identifier that marks an extended (29-bit) identifier.
const EXTENDED: u32 = 1 << 31;

/// The raw form of `id` ([`EXTENDED`] set for a 29-bit identifier).
fn raw_id(id: Id) -> u32 {
    match id {
        Id::Standard(id) => u32::from(id.as_raw()),
        Id::Extended(id) => id.as_raw() | EXTENDED,
    }
}

impl CanFrame {
    /// A data frame with an 11-bit identifier; `None` if `id > 0x7FF` or `data` is longer than 8.
    pub fn new_standard(id: u16, data: &[u8]) -> Option<Self> {
        Self::new(Id::Standard(StandardId::new(id)?), data)
    }

    /// A data frame with an 11-bit identifier and the first `len` bytes of `data`, whose bytes
    /// beyond `len` are zero (a whole buffer: no copy of a variable length); `None` if
    /// `id > 0x7FF` or `len > 8`.
    pub(crate) fn from_padded(id: u16, data: [u8; 8], len: usize) -> Option<Self> {
        debug_assert!(data.get(len..).is_none_or(|rest| rest.iter().all(|b| *b == 0)));
        let id = u32::from(StandardId::new(id)?.as_raw());
        (len <= 8).then_some(CanFrame { id, remote: false, dlc: len as u8, data })
    }

    /// A remote frame with an 11-bit identifier and data length code `dlc` (0..=8).
    pub fn new_remote_standard(id: u16, dlc: u8) -> Option<Self> {
        Self::new_remote(Id::Standard(StandardId::new(id)?), usize::from(dlc))
    }

    /// The 11-bit identifier, or `None` for an extended frame.
    pub fn standard_id(&self) -> Option<u16> {
        (self.id & EXTENDED == 0).then_some(self.id as u16)
    }

    /// Copies any `embedded_can::Frame` (data beyond 8 bytes is cut, which classic CAN
    /// drivers never produce).
    pub fn from_frame<F: Frame>(frame: &F) -> Self {
        let mut data = [0u8; 8];
        let src = frame.data();
        let len = src.len().min(8);
        if let (Some(dst), Some(src)) = (data.get_mut(..len), src.get(..len)) {
            dst.copy_from_slice(src);
        }
        CanFrame {
            id: raw_id(frame.id()),
            remote: frame.is_remote_frame(),
            dlc: if frame.is_remote_frame() { frame.dlc().min(8) as u8 } else { len as u8 },
            data,
        }
    }

    /// Converts into the frame type of a driver.
    pub fn to_frame<F: Frame>(&self) -> Option<F> {
        if self.remote {
            F::new_remote(self.id(), usize::from(self.dlc))
        } else {
            F::new(self.id(), self.data())
        }
    }
}

impl Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        if data.len() > 8 {
            return None;
        }
        let mut buf = [0u8; 8];
        buf.get_mut(..data.len())?.copy_from_slice(data);
        Some(CanFrame { id: raw_id(id.into()), remote: false, dlc: data.len() as u8, data: buf })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        if dlc > 8 {
            return None;
        }
        Some(CanFrame { id: raw_id(id.into()), remote: true, dlc: dlc as u8, data: [0; 8] })
    }

    fn is_extended(&self) -> bool {
        self.id & EXTENDED != 0
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> Id {
        let raw = self.id & !EXTENDED;
        let id = if self.id & EXTENDED != 0 {
            ExtendedId::new(raw).map(Id::Extended)
        } else {
            StandardId::new(raw as u16).map(Id::Standard)
        };
        // Every raw identifier was made from a valid one.
        id.unwrap_or(Id::Standard(StandardId::ZERO))
    }

    fn dlc(&self) -> usize {
        usize::from(self.dlc)
    }

    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            self.data.get(..usize::from(self.dlc)).unwrap_or(&[])
        }
    }
}

/// Builds an extended-id data frame; `None` if `id` needs more than 29 bits.
pub fn extended(id: u32, data: &[u8]) -> Option<CanFrame> {
    CanFrame::new(Id::Extended(ExtendedId::new(id)?), data)
}

/// Logged as candump writes a frame (see [`CanFrame`]).
#[cfg(feature = "defmt")]
impl defmt::Format for CanFrame {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self.id() {
            Id::Standard(id) => defmt::write!(f, "{=u16:03X}#", id.as_raw()),
            Id::Extended(id) => defmt::write!(f, "{=u32:08X}#", id.as_raw()),
        }
        if self.is_remote_frame() {
            defmt::write!(f, "R{=usize}", self.dlc());
        } else {
            for byte in self.data() {
                defmt::write!(f, "{=u8:02X}", *byte);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_frame_round_trips_through_the_trait() {
        let f = CanFrame::new_standard(0x601, &[0x40, 0x00, 0x10, 0x00]).unwrap();
        assert_eq!(f.standard_id(), Some(0x601));
        assert_eq!(f.data(), &[0x40, 0x00, 0x10, 0x00]);
        let g: CanFrame = f.to_frame().unwrap();
        assert_eq!(CanFrame::from_frame(&g), f);
    }

    #[test]
    fn limits_are_refused() {
        assert!(CanFrame::new_standard(0x800, &[]).is_none());
        assert!(CanFrame::new_standard(0x100, &[0; 9]).is_none());
        assert!(CanFrame::new_remote_standard(0x701, 9).is_none());
        assert!(extended(1 << 29, &[]).is_none());
    }

    #[test]
    fn remote_frame_has_no_data_but_keeps_dlc() {
        let f = CanFrame::new_remote_standard(0x705, 1).unwrap();
        assert!(f.is_remote_frame());
        assert_eq!(f.dlc(), 1);
        assert!(f.data().is_empty());
        assert_eq!(f.standard_id(), Some(0x705));
    }
}
