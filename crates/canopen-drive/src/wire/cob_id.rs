//! COB-ID entries (UNSIGNED32) of the communication objects (CiA 301 §7.5.2).
//!
//! ```text
//!  31      30        29      28 ........ 11  10 ........ 0
//! valid  gen/rtr   frame    (29-bit id)      11-bit CAN-ID
//! ```
//! Bit 31 is active-low "valid" for PDO, EMCY and SDO COB-IDs (0 = the object exists).

/// Bit 31: the object does not exist / is not valid (PDO, EMCY, SDO).
pub const INVALID: u32 = 1 << 31;
/// Bit 30: SYNC producer (1005h) / no RTR allowed (TPDO).
pub const BIT30: u32 = 1 << 30;
/// Bit 29: 29-bit identifier.
pub const EXTENDED: u32 = 1 << 29;

/// A COB-ID entry split into its fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CobId {
    /// Bit 31 clear.
    pub valid: bool,
    /// Bit 30.
    pub bit30: bool,
    /// The 11-bit CAN identifier.
    pub can_id: u16,
}

/// Why a COB-ID value is refused (all map to SDO abort 0x0609_0030).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CobIdError {
    /// Bit 29 set: this device only uses 11-bit identifiers.
    Extended,
    /// Bits 28..11 set without bit 29.
    ReservedBits,
    /// A CAN-ID reserved for other services (CiA 301 §7.3.5).
    Restricted,
}

impl CobId {
    /// Parses a raw entry of a device that speaks 11-bit identifiers only.
    pub fn parse(raw: u32) -> Result<Self, CobIdError> {
        if raw & EXTENDED != 0 {
            return Err(CobIdError::Extended);
        }
        if raw & 0x1FFF_F800 != 0 {
            return Err(CobIdError::ReservedBits);
        }
        Ok(CobId { valid: raw & INVALID == 0, bit30: raw & BIT30 != 0, can_id: (raw & 0x7FF) as u16 })
    }

    /// The raw entry.
    pub fn raw(self) -> u32 {
        u32::from(self.can_id) | if self.valid { 0 } else { INVALID } | if self.bit30 { BIT30 } else { 0 }
    }
}

/// CAN-IDs that must not be used for PDO, EMCY, SYNC, TIME or SDO (CiA 301 §7.3.5): NMT, the
/// node-ID ranges of the pre-defined SDO, error-control and LSS identifiers, and 0x101..=0x180.
pub fn is_restricted(can_id: u16) -> bool {
    matches!(can_id, 0x000..=0x07F | 0x101..=0x180 | 0x581..=0x5FF | 0x601..=0x67F | 0x6E0..=0x6FF | 0x701..=0x7FF)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_and_restrictions() {
        let c = CobId::parse(0x8000_0185).unwrap();
        assert!(!c.valid && !c.bit30);
        assert_eq!(c.can_id, 0x185);
        assert_eq!(c.raw(), 0x8000_0185);
        assert_eq!(CobId::parse(0x2000_0185), Err(CobIdError::Extended));
        assert_eq!(CobId::parse(0x0000_0985), Err(CobIdError::ReservedBits));
        for id in [0x000, 0x07F, 0x101, 0x180, 0x581, 0x5FF, 0x601, 0x67F, 0x6E0, 0x6FF, 0x701, 0x7E5] {
            assert!(is_restricted(id), "{id:#x}");
        }
        for id in [0x080, 0x085, 0x100, 0x181, 0x1FF, 0x580, 0x600, 0x680, 0x700] {
            assert!(!is_restricted(id), "{id:#x}");
        }
    }
}
