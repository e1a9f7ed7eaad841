//! SDO abort codes (CiA 301 §7.2.4.3.17).
//!
//! Every refusal in the object dictionary and the SDO server is one of these codes, so an
//! access path can hand its error straight to the bus.

/// The reason an SDO transfer or an object access was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum AbortCode {
    /// 0x0503_0000: toggle bit not alternated (§5.4).
    ToggleBitNotAlternated,
    /// 0x0504_0000: SDO protocol timed out (§5.10).
    Timeout,
    /// 0x0504_0001: client/server command specifier not valid or unknown.
    InvalidCommandSpecifier,
    /// 0x0504_0002: invalid block size (block mode only).
    InvalidBlockSize,
    /// 0x0504_0003: invalid sequence number (block mode only).
    InvalidSequenceNumber,
    /// 0x0504_0004: CRC error (block mode only).
    CrcError,
    /// 0x0504_0005: out of memory.
    OutOfMemory,
    /// 0x0601_0000: unsupported access to an object.
    UnsupportedAccess,
    /// 0x0601_0001: attempt to read a write-only object.
    ReadOfWriteOnly,
    /// 0x0601_0002: attempt to write a read-only object.
    WriteOfReadOnly,
    /// 0x0602_0000: object does not exist in the object dictionary.
    ObjectDoesNotExist,
    /// 0x0604_0041: object cannot be mapped to the PDO.
    ObjectNotMappable,
    /// 0x0604_0042: number and length of the mapped objects would exceed the PDO length.
    PdoLengthExceeded,
    /// 0x0604_0043: general parameter incompatibility.
    ParameterIncompatible,
    /// 0x0604_0047: general internal incompatibility in the device.
    InternalIncompatibility,
    /// 0x0606_0000: access failed due to a hardware error (e.g. non-volatile storage).
    HardwareError,
    /// 0x0607_0010: data type does not match, length of service parameter does not match.
    LengthMismatch,
    /// 0x0607_0012: length of service parameter too high.
    LengthTooHigh,
    /// 0x0607_0013: length of service parameter too low.
    LengthTooLow,
    /// 0x0609_0011: sub-index does not exist.
    SubIndexDoesNotExist,
    /// 0x0609_0030: invalid value for parameter (download only).
    InvalidValue,
    /// 0x0609_0031: value of parameter written too high (download only).
    ValueTooHigh,
    /// 0x0609_0032: value of parameter written too low (download only).
    ValueTooLow,
    /// 0x0609_0036: maximum value is less than minimum value.
    MaxLessThanMin,
    /// 0x060A_0023: resource not available: SDO connection.
    ResourceNotAvailable,
    /// 0x0800_0000: general error.
    General,
    /// 0x0800_0020: data cannot be transferred or stored to the application.
    CannotStore,
    /// 0x0800_0021: ... because of local control.
    CannotStoreLocalControl,
    /// 0x0800_0022: ... because of the present device state.
    CannotStoreDeviceState,
    /// 0x0800_0023: object dictionary dynamic generation failed or no dictionary present.
    NoObjectDictionary,
    /// 0x0800_0024: no data available.
    NoDataAvailable,
    /// Any other value received from a peer (reserved codes are never sent by this crate).
    Unknown(u32),
}

impl AbortCode {
    /// The 32-bit code carried in bytes 4..8 of an abort frame.
    pub const fn code(self) -> u32 {
        use AbortCode::*;
        match self {
            ToggleBitNotAlternated => 0x0503_0000,
            Timeout => 0x0504_0000,
            InvalidCommandSpecifier => 0x0504_0001,
            InvalidBlockSize => 0x0504_0002,
            InvalidSequenceNumber => 0x0504_0003,
            CrcError => 0x0504_0004,
            OutOfMemory => 0x0504_0005,
            UnsupportedAccess => 0x0601_0000,
            ReadOfWriteOnly => 0x0601_0001,
            WriteOfReadOnly => 0x0601_0002,
            ObjectDoesNotExist => 0x0602_0000,
            ObjectNotMappable => 0x0604_0041,
            PdoLengthExceeded => 0x0604_0042,
            ParameterIncompatible => 0x0604_0043,
            InternalIncompatibility => 0x0604_0047,
            HardwareError => 0x0606_0000,
            LengthMismatch => 0x0607_0010,
            LengthTooHigh => 0x0607_0012,
            LengthTooLow => 0x0607_0013,
            SubIndexDoesNotExist => 0x0609_0011,
            InvalidValue => 0x0609_0030,
            ValueTooHigh => 0x0609_0031,
            ValueTooLow => 0x0609_0032,
            MaxLessThanMin => 0x0609_0036,
            ResourceNotAvailable => 0x060A_0023,
            General => 0x0800_0000,
            CannotStore => 0x0800_0020,
            CannotStoreLocalControl => 0x0800_0021,
            CannotStoreDeviceState => 0x0800_0022,
            NoObjectDictionary => 0x0800_0023,
            NoDataAvailable => 0x0800_0024,
            Unknown(raw) => raw,
        }
    }

    /// The code for a raw value; reserved values become [`AbortCode::Unknown`].
    pub const fn from_code(raw: u32) -> Self {
        use AbortCode::*;
        match raw {
            0x0503_0000 => ToggleBitNotAlternated,
            0x0504_0000 => Timeout,
            0x0504_0001 => InvalidCommandSpecifier,
            0x0504_0002 => InvalidBlockSize,
            0x0504_0003 => InvalidSequenceNumber,
            0x0504_0004 => CrcError,
            0x0504_0005 => OutOfMemory,
            0x0601_0000 => UnsupportedAccess,
            0x0601_0001 => ReadOfWriteOnly,
            0x0601_0002 => WriteOfReadOnly,
            0x0602_0000 => ObjectDoesNotExist,
            0x0604_0041 => ObjectNotMappable,
            0x0604_0042 => PdoLengthExceeded,
            0x0604_0043 => ParameterIncompatible,
            0x0604_0047 => InternalIncompatibility,
            0x0606_0000 => HardwareError,
            0x0607_0010 => LengthMismatch,
            0x0607_0012 => LengthTooHigh,
            0x0607_0013 => LengthTooLow,
            0x0609_0011 => SubIndexDoesNotExist,
            0x0609_0030 => InvalidValue,
            0x0609_0031 => ValueTooHigh,
            0x0609_0032 => ValueTooLow,
            0x0609_0036 => MaxLessThanMin,
            0x060A_0023 => ResourceNotAvailable,
            0x0800_0000 => General,
            0x0800_0020 => CannotStore,
            0x0800_0021 => CannotStoreLocalControl,
            0x0800_0022 => CannotStoreDeviceState,
            0x0800_0023 => NoObjectDictionary,
            0x0800_0024 => NoDataAvailable,
            other => Unknown(other),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip() {
        for raw in [0x0503_0000, 0x0504_0005, 0x0602_0000, 0x0609_0011, 0x0800_0024, 0x1234_5678] {
            assert_eq!(AbortCode::from_code(raw).code(), raw);
        }
        assert_eq!(AbortCode::from_code(0x1234_5678), AbortCode::Unknown(0x1234_5678));
    }
}
