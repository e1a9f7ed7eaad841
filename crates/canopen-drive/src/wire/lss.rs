//! LSS frames: Layer Setting Services (CiA 305).
//!
//! ```text
//! master → slave  COB-ID 0x7E5, DLC 8: [cs, 7 bytes per service, unused bytes 0]
//! slave → master  COB-ID 0x7E4, DLC 8: [cs, 7 bytes per service, unused bytes 0]
//!
//! cs    request                               bytes 1..7                     slave answers
//! 0x04  switch state global                   [mode: 0 waiting, 1 config]    –
//! 0x40  switch state selective vendor-ID      [u32 LE]                       –
//! 0x41   … product code                       [u32 LE]                       –
//! 0x42   … revision number                    [u32 LE]                       –
//! 0x43   … serial number                      [u32 LE]                       0x44 if all 4 matched
//! 0x11  configure node-ID                     [node-ID]                      0x11 [error, specific]
//! 0x13  configure bit timing                  [table selector, table index]  0x13 [error, specific]
//! 0x15  activate bit timing                   [switch delay ms: u16 LE]      –
//! 0x17  store configuration                   –                              0x17 [error, specific]
//! 0x46  identify remote slave vendor-ID       [u32 LE]                       –
//! 0x47   … product code                       [u32 LE]                       –
//! 0x48   … revision number low bound          [u32 LE]                       –
//! 0x49   … revision number high bound         [u32 LE]                       –
//! 0x4A   … serial number low bound            [u32 LE]                       –
//! 0x4B   … serial number high bound           [u32 LE]                       0x4F if in range
//! 0x4C  identify non-configured remote slave  –                              0x50 if non-configured
//! 0x51  fastscan                              [IDNumber: u32 LE, BitChecked, LSSSub, LSSNext]
//!                                                                            0x4F on match
//! 0x5A..0x5D inquire vendor/product/revision/serial   –                     same cs [u32 LE]
//! 0x5E  inquire node-ID                       –                              0x5E [active node-ID]
//! ```
//!
//! Every LSS frame carries exactly eight data bytes (CiA 305); frames of any other length
//! are refused with [`ParseError::Length`], as CANopenNode does. A command specifier that is no
//! master request parses as [`Request::Unknown`]; a known request whose parameter lies outside
//! its range (a switch mode other than 0/1, a BitChecked other than 0..=31 or 0x80, an LSSSub or
//! LSSNext above 3) is refused with [`ParseError::InvalidParameter`] and ignored by the slave.
//!
//! The codec is stateless; the slave state machine is [`crate::comm::lss`].

/// COB-ID of LSS requests, master → slave (CiA 305).
pub const LSS_REQUEST_COB_ID: u16 = 0x7E5;
/// COB-ID of LSS responses, slave → master (CiA 305).
pub const LSS_RESPONSE_COB_ID: u16 = 0x7E4;
/// Node-ID value of a non-configured LSS slave (CiA 305).
pub const NODE_ID_UNCONFIGURED: u8 = 0xFF;
/// BitChecked value of a fastscan reset request (CiA 305).
pub const FASTSCAN_RESET: u8 = 0x80;

/// An LSS command specifier, byte 0 of every LSS frame (CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum CommandSpecifier {
    /// 0x04: switch state global (to waiting or to configuration).
    SwitchStateGlobal = 0x04,
    /// 0x11: configure node-ID (request and response).
    ConfigureNodeId = 0x11,
    /// 0x13: configure bit timing parameters (request and response).
    ConfigureBitTiming = 0x13,
    /// 0x15: activate bit timing parameters.
    ActivateBitTiming = 0x15,
    /// 0x17: store configuration (request and response).
    StoreConfiguration = 0x17,
    /// 0x40: switch state selective, vendor-ID.
    SwitchStateSelectiveVendorId = 0x40,
    /// 0x41: switch state selective, product code.
    SwitchStateSelectiveProductCode = 0x41,
    /// 0x42: switch state selective, revision number.
    SwitchStateSelectiveRevisionNumber = 0x42,
    /// 0x43: switch state selective, serial number.
    SwitchStateSelectiveSerialNumber = 0x43,
    /// 0x44: switch state selective response (slave → master).
    SwitchStateSelectiveResponse = 0x44,
    /// 0x46: identify remote slave, vendor-ID.
    IdentifyRemoteSlaveVendorId = 0x46,
    /// 0x47: identify remote slave, product code.
    IdentifyRemoteSlaveProductCode = 0x47,
    /// 0x48: identify remote slave, revision number low bound.
    IdentifyRemoteSlaveRevisionLow = 0x48,
    /// 0x49: identify remote slave, revision number high bound.
    IdentifyRemoteSlaveRevisionHigh = 0x49,
    /// 0x4A: identify remote slave, serial number low bound.
    IdentifyRemoteSlaveSerialLow = 0x4A,
    /// 0x4B: identify remote slave, serial number high bound.
    IdentifyRemoteSlaveSerialHigh = 0x4B,
    /// 0x4C: identify non-configured remote slave.
    IdentifyNonConfiguredRemoteSlave = 0x4C,
    /// 0x4F: identify slave (response to identify remote slave and to fastscan).
    IdentifySlave = 0x4F,
    /// 0x50: identify non-configured slave (response).
    IdentifyNonConfiguredSlave = 0x50,
    /// 0x51: LSS fastscan.
    Fastscan = 0x51,
    /// 0x5A: inquire identity vendor-ID (request and response).
    InquireVendorId = 0x5A,
    /// 0x5B: inquire identity product code (request and response).
    InquireProductCode = 0x5B,
    /// 0x5C: inquire identity revision number (request and response).
    InquireRevisionNumber = 0x5C,
    /// 0x5D: inquire identity serial number (request and response).
    InquireSerialNumber = 0x5D,
    /// 0x5E: inquire node-ID (request and response).
    InquireNodeId = 0x5E,
}

impl CommandSpecifier {
    /// Every command specifier of the table, in ascending order.
    pub const ALL: [CommandSpecifier; 25] = [
        CommandSpecifier::SwitchStateGlobal,
        CommandSpecifier::ConfigureNodeId,
        CommandSpecifier::ConfigureBitTiming,
        CommandSpecifier::ActivateBitTiming,
        CommandSpecifier::StoreConfiguration,
        CommandSpecifier::SwitchStateSelectiveVendorId,
        CommandSpecifier::SwitchStateSelectiveProductCode,
        CommandSpecifier::SwitchStateSelectiveRevisionNumber,
        CommandSpecifier::SwitchStateSelectiveSerialNumber,
        CommandSpecifier::SwitchStateSelectiveResponse,
        CommandSpecifier::IdentifyRemoteSlaveVendorId,
        CommandSpecifier::IdentifyRemoteSlaveProductCode,
        CommandSpecifier::IdentifyRemoteSlaveRevisionLow,
        CommandSpecifier::IdentifyRemoteSlaveRevisionHigh,
        CommandSpecifier::IdentifyRemoteSlaveSerialLow,
        CommandSpecifier::IdentifyRemoteSlaveSerialHigh,
        CommandSpecifier::IdentifyNonConfiguredRemoteSlave,
        CommandSpecifier::IdentifySlave,
        CommandSpecifier::IdentifyNonConfiguredSlave,
        CommandSpecifier::Fastscan,
        CommandSpecifier::InquireVendorId,
        CommandSpecifier::InquireProductCode,
        CommandSpecifier::InquireRevisionNumber,
        CommandSpecifier::InquireSerialNumber,
        CommandSpecifier::InquireNodeId,
    ];

    /// The command specifier byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The command specifier for a byte; `None` for a value the table does not define.
    pub const fn from_code(raw: u8) -> Option<Self> {
        use CommandSpecifier::*;
        Some(match raw {
            0x04 => SwitchStateGlobal,
            0x11 => ConfigureNodeId,
            0x13 => ConfigureBitTiming,
            0x15 => ActivateBitTiming,
            0x17 => StoreConfiguration,
            0x40 => SwitchStateSelectiveVendorId,
            0x41 => SwitchStateSelectiveProductCode,
            0x42 => SwitchStateSelectiveRevisionNumber,
            0x43 => SwitchStateSelectiveSerialNumber,
            0x44 => SwitchStateSelectiveResponse,
            0x46 => IdentifyRemoteSlaveVendorId,
            0x47 => IdentifyRemoteSlaveProductCode,
            0x48 => IdentifyRemoteSlaveRevisionLow,
            0x49 => IdentifyRemoteSlaveRevisionHigh,
            0x4A => IdentifyRemoteSlaveSerialLow,
            0x4B => IdentifyRemoteSlaveSerialHigh,
            0x4C => IdentifyNonConfiguredRemoteSlave,
            0x4F => IdentifySlave,
            0x50 => IdentifyNonConfiguredSlave,
            0x51 => Fastscan,
            0x5A => InquireVendorId,
            0x5B => InquireProductCode,
            0x5C => InquireRevisionNumber,
            0x5D => InquireSerialNumber,
            0x5E => InquireNodeId,
            _ => return None,
        })
    }

    /// The switch-state-selective command for one field of the LSS address (0x40..=0x43).
    pub const fn switch_state_selective(field: LssField) -> Self {
        match field {
            LssField::VendorId => CommandSpecifier::SwitchStateSelectiveVendorId,
            LssField::ProductCode => CommandSpecifier::SwitchStateSelectiveProductCode,
            LssField::RevisionNumber => CommandSpecifier::SwitchStateSelectiveRevisionNumber,
            LssField::SerialNumber => CommandSpecifier::SwitchStateSelectiveSerialNumber,
        }
    }

    /// The inquire-identity command for one field of the LSS address (0x5A..=0x5D).
    pub const fn inquire_identity(field: LssField) -> Self {
        match field {
            LssField::VendorId => CommandSpecifier::InquireVendorId,
            LssField::ProductCode => CommandSpecifier::InquireProductCode,
            LssField::RevisionNumber => CommandSpecifier::InquireRevisionNumber,
            LssField::SerialNumber => CommandSpecifier::InquireSerialNumber,
        }
    }
}

/// One 32-bit field of the 128-bit LSS address, numbered as fastscan's LSSSub/LSSNext
/// (CiA 305). The address is object 1018h sub 1..4.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum LssField {
    /// 0: vendor-ID (1018h sub 1).
    VendorId = 0,
    /// 1: product code (1018h sub 2).
    ProductCode = 1,
    /// 2: revision number (1018h sub 3).
    RevisionNumber = 2,
    /// 3: serial number (1018h sub 4).
    SerialNumber = 3,
}

impl LssField {
    /// The four fields in address order.
    pub const ALL: [LssField; 4] =
        [LssField::VendorId, LssField::ProductCode, LssField::RevisionNumber, LssField::SerialNumber];

    /// The LSSSub / LSSNext value.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The field for an LSSSub / LSSNext value; `None` above 3.
    pub const fn from_code(raw: u8) -> Option<Self> {
        match raw {
            0 => Some(LssField::VendorId),
            1 => Some(LssField::ProductCode),
            2 => Some(LssField::RevisionNumber),
            3 => Some(LssField::SerialNumber),
            _ => None,
        }
    }
}

/// The 128-bit LSS address of a device: its identity object 1018h (CiA 305).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LssAddress {
    /// Vendor-ID (1018h sub 1).
    pub vendor_id: u32,
    /// Product code (1018h sub 2).
    pub product_code: u32,
    /// Revision number (1018h sub 3).
    pub revision_number: u32,
    /// Serial number (1018h sub 4).
    pub serial_number: u32,
}

impl LssAddress {
    /// One field of the address.
    pub const fn field(&self, field: LssField) -> u32 {
        match field {
            LssField::VendorId => self.vendor_id,
            LssField::ProductCode => self.product_code,
            LssField::RevisionNumber => self.revision_number,
            LssField::SerialNumber => self.serial_number,
        }
    }

    /// Sets one field of the address (a master assembling a fastscan result).
    pub fn set_field(&mut self, field: LssField, value: u32) {
        match field {
            LssField::VendorId => self.vendor_id = value,
            LssField::ProductCode => self.product_code = value,
            LssField::RevisionNumber => self.revision_number = value,
            LssField::SerialNumber => self.serial_number = value,
        }
    }
}

/// The target state of switch state global (byte 1 of cs 0x04, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum SwitchMode {
    /// 0: switch to LSS waiting.
    Waiting = 0,
    /// 1: switch to LSS configuration.
    Configuration = 1,
}

impl SwitchMode {
    /// The mode byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The mode for a byte; `None` for the reserved values 2..=255.
    pub const fn from_code(raw: u8) -> Option<Self> {
        match raw {
            0 => Some(SwitchMode::Waiting),
            1 => Some(SwitchMode::Configuration),
            _ => None,
        }
    }
}

/// An entry of the standard bit timing table, table selector 0 (CiA 305); the
/// discriminant is the table index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum BitRate {
    /// Index 0: 1000 kbit/s.
    Kbit1000 = 0,
    /// Index 1: 800 kbit/s.
    Kbit800 = 1,
    /// Index 2: 500 kbit/s.
    Kbit500 = 2,
    /// Index 3: 250 kbit/s.
    Kbit250 = 3,
    /// Index 4: 125 kbit/s.
    Kbit125 = 4,
    /// Index 5: 100 kbit/s. Reserved in CiA 305 v3 (CANopenNode), 100 kbit/s in older tables
    /// (python-canopen, emtas); treated as optional (CiA 305).
    Kbit100 = 5,
    /// Index 6: 50 kbit/s.
    Kbit50 = 6,
    /// Index 7: 20 kbit/s.
    Kbit20 = 7,
    /// Index 8: 10 kbit/s.
    Kbit10 = 8,
    /// Index 9: automatic bit rate detection.
    Automatic = 9,
}

impl BitRate {
    /// Every entry of the standard table, in index order.
    pub const ALL: [BitRate; 10] = [
        BitRate::Kbit1000,
        BitRate::Kbit800,
        BitRate::Kbit500,
        BitRate::Kbit250,
        BitRate::Kbit125,
        BitRate::Kbit100,
        BitRate::Kbit50,
        BitRate::Kbit20,
        BitRate::Kbit10,
        BitRate::Automatic,
    ];

    /// The table index.
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// The entry for a table index; `None` for the reserved indices 10..=255.
    pub const fn from_index(index: u8) -> Option<Self> {
        use BitRate::*;
        Some(match index {
            0 => Kbit1000,
            1 => Kbit800,
            2 => Kbit500,
            3 => Kbit250,
            4 => Kbit125,
            5 => Kbit100,
            6 => Kbit50,
            7 => Kbit20,
            8 => Kbit10,
            9 => Automatic,
            _ => return None,
        })
    }

    /// The bit rate in kbit/s; `None` for automatic detection.
    pub const fn kbit_per_s(self) -> Option<u16> {
        use BitRate::*;
        match self {
            Kbit1000 => Some(1000),
            Kbit800 => Some(800),
            Kbit500 => Some(500),
            Kbit250 => Some(250),
            Kbit125 => Some(125),
            Kbit100 => Some(100),
            Kbit50 => Some(50),
            Kbit20 => Some(20),
            Kbit10 => Some(10),
            Automatic => None,
        }
    }
}

/// The parameters of configure bit timing (bytes 1 and 2 of cs 0x13, CiA 305): a table
/// and an index into it, as received. Table 0 is the standard table ([`BitRate`]); 0x80..=0xFE
/// select manufacturer tables, the other selectors are reserved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BitTiming {
    /// Table selector.
    pub table_selector: u8,
    /// Index into the table.
    pub table_index: u8,
}

impl BitTiming {
    /// Table selector of the standard table.
    pub const STANDARD_TABLE: u8 = 0;

    /// An entry of the standard table.
    pub const fn standard(rate: BitRate) -> Self {
        BitTiming { table_selector: Self::STANDARD_TABLE, table_index: rate.index() }
    }

    /// The standard-table entry this selects; `None` for another table or a reserved index.
    pub const fn standard_rate(self) -> Option<BitRate> {
        if self.table_selector == Self::STANDARD_TABLE {
            BitRate::from_index(self.table_index)
        } else {
            None
        }
    }
}

/// BitChecked of a fastscan request (byte 5 of cs 0x51, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BitChecked {
    /// 0x80: reset the fastscan position of every non-configured slave; all of them answer.
    Reset,
    /// 0..=31: compare bits 31..=n of the addressed field. Values above 31 never parse.
    Bit(u8),
}

impl BitChecked {
    /// The BitChecked byte.
    pub const fn code(self) -> u8 {
        match self {
            BitChecked::Reset => FASTSCAN_RESET,
            BitChecked::Bit(bit) => bit,
        }
    }

    /// The BitChecked for a byte; `None` for 32..=0x7F and 0x81..=0xFF.
    pub const fn from_code(raw: u8) -> Option<Self> {
        match raw {
            FASTSCAN_RESET => Some(BitChecked::Reset),
            0..=31 => Some(BitChecked::Bit(raw)),
            _ => None,
        }
    }
}

/// The parameters of a fastscan request (cs 0x51, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Fastscan {
    /// IDNumber: the master's current guess of the field `sub`.
    pub id_number: u32,
    /// BitChecked: the lowest bit compared, or a reset.
    pub bit_checked: BitChecked,
    /// LSSSub: the field compared.
    pub sub: LssField,
    /// LSSNext: the field a matching slave compares next.
    pub next: LssField,
}

/// A request of the LSS master (COB-ID 0x7E5), as parsed from the frame (CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Request {
    /// 0x04: switch state global.
    SwitchStateGlobal(SwitchMode),
    /// 0x40..=0x43: switch state selective, one field of the LSS address.
    SwitchStateSelective {
        /// The field this frame carries (0x40 + field).
        field: LssField,
        /// Its value.
        value: u32,
    },
    /// 0x11: configure node-ID (1..=127, or 0xFF = non-configured; other values are answered
    /// with an error, so they parse).
    ConfigureNodeId(u8),
    /// 0x13: configure bit timing.
    ConfigureBitTiming(BitTiming),
    /// 0x15: activate bit timing.
    ActivateBitTiming {
        /// Switch delay in ms: silence before and after the switch.
        switch_delay_ms: u16,
    },
    /// 0x17: store configuration.
    StoreConfiguration,
    /// 0x46: identify remote slave, vendor-ID (exact).
    IdentifyRemoteVendorId(u32),
    /// 0x47: identify remote slave, product code (exact).
    IdentifyRemoteProductCode(u32),
    /// 0x48: identify remote slave, revision number low bound (inclusive).
    IdentifyRemoteRevisionLow(u32),
    /// 0x49: identify remote slave, revision number high bound (inclusive).
    IdentifyRemoteRevisionHigh(u32),
    /// 0x4A: identify remote slave, serial number low bound (inclusive).
    IdentifyRemoteSerialLow(u32),
    /// 0x4B: identify remote slave, serial number high bound (inclusive); the last frame.
    IdentifyRemoteSerialHigh(u32),
    /// 0x4C: identify non-configured remote slave.
    IdentifyNonConfiguredRemoteSlave,
    /// 0x51: fastscan.
    Fastscan(Fastscan),
    /// 0x5A..=0x5D: inquire one field of the LSS address.
    InquireIdentity(LssField),
    /// 0x5E: inquire node-ID.
    InquireNodeId,
    /// A command specifier that is no master request (reserved, or a response code).
    Unknown(u8),
}

/// Why a frame is not a valid LSS frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ParseError {
    /// The frame does not carry exactly eight data bytes (CiA 305).
    Length,
    /// A known command with a parameter outside its range.
    InvalidParameter(CommandSpecifier),
    /// The command specifier (carried here) is no slave response.
    NotAResponse(u8),
}

/// The eight bytes of a frame, or [`ParseError::Length`].
fn eight_bytes(data: &[u8]) -> Result<[u8; 8], ParseError> {
    <[u8; 8]>::try_from(data).map_err(|_| ParseError::Length)
}

/// A frame `[cs, value LE, 0, 0, 0]`.
const fn with_u32(cs: CommandSpecifier, value: u32) -> [u8; 8] {
    let [a, b, c, d] = value.to_le_bytes();
    [cs.code(), a, b, c, d, 0, 0, 0]
}

/// A frame `[cs, b1, b2, 0, 0, 0, 0, 0]`.
const fn with_bytes(cs: CommandSpecifier, b1: u8, b2: u8) -> [u8; 8] {
    [cs.code(), b1, b2, 0, 0, 0, 0, 0]
}

impl Request {
    /// Parses the data of a frame received on COB-ID 0x7E5.
    pub fn parse(data: &[u8]) -> Result<Self, ParseError> {
        use CommandSpecifier as Cs;
        let [raw_cs, b1, b2, b3, b4, b5, b6, b7] = eight_bytes(data)?;
        let value = u32::from_le_bytes([b1, b2, b3, b4]);
        let Some(cs) = CommandSpecifier::from_code(raw_cs) else {
            return Ok(Request::Unknown(raw_cs));
        };
        let invalid = ParseError::InvalidParameter(cs);
        Ok(match cs {
            Cs::SwitchStateGlobal => Request::SwitchStateGlobal(SwitchMode::from_code(b1).ok_or(invalid)?),
            Cs::SwitchStateSelectiveVendorId => {
                Request::SwitchStateSelective { field: LssField::VendorId, value }
            }
            Cs::SwitchStateSelectiveProductCode => {
                Request::SwitchStateSelective { field: LssField::ProductCode, value }
            }
            Cs::SwitchStateSelectiveRevisionNumber => {
                Request::SwitchStateSelective { field: LssField::RevisionNumber, value }
            }
            Cs::SwitchStateSelectiveSerialNumber => {
                Request::SwitchStateSelective { field: LssField::SerialNumber, value }
            }
            Cs::ConfigureNodeId => Request::ConfigureNodeId(b1),
            Cs::ConfigureBitTiming => {
                Request::ConfigureBitTiming(BitTiming { table_selector: b1, table_index: b2 })
            }
            Cs::ActivateBitTiming => {
                Request::ActivateBitTiming { switch_delay_ms: u16::from_le_bytes([b1, b2]) }
            }
            Cs::StoreConfiguration => Request::StoreConfiguration,
            Cs::IdentifyRemoteSlaveVendorId => Request::IdentifyRemoteVendorId(value),
            Cs::IdentifyRemoteSlaveProductCode => Request::IdentifyRemoteProductCode(value),
            Cs::IdentifyRemoteSlaveRevisionLow => Request::IdentifyRemoteRevisionLow(value),
            Cs::IdentifyRemoteSlaveRevisionHigh => Request::IdentifyRemoteRevisionHigh(value),
            Cs::IdentifyRemoteSlaveSerialLow => Request::IdentifyRemoteSerialLow(value),
            Cs::IdentifyRemoteSlaveSerialHigh => Request::IdentifyRemoteSerialHigh(value),
            Cs::IdentifyNonConfiguredRemoteSlave => Request::IdentifyNonConfiguredRemoteSlave,
            Cs::Fastscan => Request::Fastscan(Fastscan {
                id_number: value,
                bit_checked: BitChecked::from_code(b5).ok_or(invalid)?,
                sub: LssField::from_code(b6).ok_or(invalid)?,
                next: LssField::from_code(b7).ok_or(invalid)?,
            }),
            Cs::InquireVendorId => Request::InquireIdentity(LssField::VendorId),
            Cs::InquireProductCode => Request::InquireIdentity(LssField::ProductCode),
            Cs::InquireRevisionNumber => Request::InquireIdentity(LssField::RevisionNumber),
            Cs::InquireSerialNumber => Request::InquireIdentity(LssField::SerialNumber),
            Cs::InquireNodeId => Request::InquireNodeId,
            // Slave → master command specifiers are no requests.
            Cs::SwitchStateSelectiveResponse | Cs::IdentifySlave | Cs::IdentifyNonConfiguredSlave => {
                Request::Unknown(raw_cs)
            }
        })
    }

    /// The eight data bytes of the request (what a master sends on 0x7E5).
    pub const fn emit(&self) -> [u8; 8] {
        use CommandSpecifier as Cs;
        match *self {
            Request::SwitchStateGlobal(mode) => with_bytes(Cs::SwitchStateGlobal, mode.code(), 0),
            Request::SwitchStateSelective { field, value } => {
                with_u32(Cs::switch_state_selective(field), value)
            }
            Request::ConfigureNodeId(node_id) => with_bytes(Cs::ConfigureNodeId, node_id, 0),
            Request::ConfigureBitTiming(timing) => {
                with_bytes(Cs::ConfigureBitTiming, timing.table_selector, timing.table_index)
            }
            Request::ActivateBitTiming { switch_delay_ms } => {
                let [lo, hi] = switch_delay_ms.to_le_bytes();
                with_bytes(Cs::ActivateBitTiming, lo, hi)
            }
            Request::StoreConfiguration => with_bytes(Cs::StoreConfiguration, 0, 0),
            Request::IdentifyRemoteVendorId(value) => with_u32(Cs::IdentifyRemoteSlaveVendorId, value),
            Request::IdentifyRemoteProductCode(value) => with_u32(Cs::IdentifyRemoteSlaveProductCode, value),
            Request::IdentifyRemoteRevisionLow(value) => with_u32(Cs::IdentifyRemoteSlaveRevisionLow, value),
            Request::IdentifyRemoteRevisionHigh(value) => {
                with_u32(Cs::IdentifyRemoteSlaveRevisionHigh, value)
            }
            Request::IdentifyRemoteSerialLow(value) => with_u32(Cs::IdentifyRemoteSlaveSerialLow, value),
            Request::IdentifyRemoteSerialHigh(value) => with_u32(Cs::IdentifyRemoteSlaveSerialHigh, value),
            Request::IdentifyNonConfiguredRemoteSlave => {
                with_bytes(Cs::IdentifyNonConfiguredRemoteSlave, 0, 0)
            }
            Request::Fastscan(Fastscan { id_number, bit_checked, sub, next }) => {
                let [a, b, c, d] = id_number.to_le_bytes();
                [Cs::Fastscan.code(), a, b, c, d, bit_checked.code(), sub.code(), next.code()]
            }
            Request::InquireIdentity(field) => with_bytes(Cs::inquire_identity(field), 0, 0),
            Request::InquireNodeId => with_bytes(Cs::InquireNodeId, 0, 0),
            Request::Unknown(cs) => [cs, 0, 0, 0, 0, 0, 0, 0],
        }
    }
}

/// Error code of the configure node-ID response (byte 1 of cs 0x11, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ConfigureNodeIdStatus {
    /// 0: protocol successfully completed.
    Success = 0,
    /// 1: node-ID out of range (not 1..=127 and not 0xFF).
    NodeIdOutOfRange = 1,
    /// 0xFF: manufacturer-specific error, detailed in byte 2.
    ManufacturerSpecific = 0xFF,
}

impl ConfigureNodeIdStatus {
    /// The error code byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The status for an error code byte; `None` for reserved codes.
    pub const fn from_code(raw: u8) -> Option<Self> {
        match raw {
            0 => Some(ConfigureNodeIdStatus::Success),
            1 => Some(ConfigureNodeIdStatus::NodeIdOutOfRange),
            0xFF => Some(ConfigureNodeIdStatus::ManufacturerSpecific),
            _ => None,
        }
    }
}

/// Error code of the configure bit timing response (byte 1 of cs 0x13, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ConfigureBitTimingStatus {
    /// 0: protocol successfully completed.
    Success = 0,
    /// 1: bit rate not supported.
    BitRateNotSupported = 1,
    /// 0xFF: manufacturer-specific error, detailed in byte 2.
    ManufacturerSpecific = 0xFF,
}

impl ConfigureBitTimingStatus {
    /// The error code byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The status for an error code byte; `None` for reserved codes.
    pub const fn from_code(raw: u8) -> Option<Self> {
        match raw {
            0 => Some(ConfigureBitTimingStatus::Success),
            1 => Some(ConfigureBitTimingStatus::BitRateNotSupported),
            0xFF => Some(ConfigureBitTimingStatus::ManufacturerSpecific),
            _ => None,
        }
    }
}

/// Error code of the store configuration response (byte 1 of cs 0x17, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum StoreConfigurationStatus {
    /// 0: protocol successfully completed.
    Success = 0,
    /// 1: store configuration not supported.
    NotSupported = 1,
    /// 2: storage media access error.
    StorageMediaAccess = 2,
    /// 0xFF: manufacturer-specific error, detailed in byte 2.
    ManufacturerSpecific = 0xFF,
}

impl StoreConfigurationStatus {
    /// The error code byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The status for an error code byte; `None` for reserved codes.
    pub const fn from_code(raw: u8) -> Option<Self> {
        match raw {
            0 => Some(StoreConfigurationStatus::Success),
            1 => Some(StoreConfigurationStatus::NotSupported),
            2 => Some(StoreConfigurationStatus::StorageMediaAccess),
            0xFF => Some(StoreConfigurationStatus::ManufacturerSpecific),
            _ => None,
        }
    }
}

/// A response of an LSS slave (COB-ID 0x7E4, CiA 305).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Response {
    /// 0x44: the slave matched switch state selective and is now in configuration.
    SwitchStateSelective,
    /// 0x11: result of configure node-ID.
    ConfigureNodeId {
        /// Error code (byte 1).
        status: ConfigureNodeIdStatus,
        /// Manufacturer-specific error (byte 2), 0 unless `status` is manufacturer-specific.
        specific: u8,
    },
    /// 0x13: result of configure bit timing.
    ConfigureBitTiming {
        /// Error code (byte 1).
        status: ConfigureBitTimingStatus,
        /// Manufacturer-specific error (byte 2), 0 unless `status` is manufacturer-specific.
        specific: u8,
    },
    /// 0x17: result of store configuration.
    StoreConfiguration {
        /// Error code (byte 1).
        status: StoreConfigurationStatus,
        /// Manufacturer-specific error (byte 2), 0 unless `status` is manufacturer-specific.
        specific: u8,
    },
    /// 0x4F: identify slave (answer to identify remote slave and to fastscan).
    IdentifySlave,
    /// 0x50: identify non-configured slave.
    IdentifyNonConfiguredSlave,
    /// 0x5A..=0x5D: one field of the slave's LSS address.
    InquireIdentity {
        /// The field inquired.
        field: LssField,
        /// Its value.
        value: u32,
    },
    /// 0x5E: the slave's active node-ID (0xFF when non-configured).
    InquireNodeId(u8),
}

impl Response {
    /// Parses the data of a frame received on COB-ID 0x7E4 (master side and tests).
    pub fn parse(data: &[u8]) -> Result<Self, ParseError> {
        use CommandSpecifier as Cs;
        let [raw_cs, b1, b2, b3, b4, _, _, _] = eight_bytes(data)?;
        let value = u32::from_le_bytes([b1, b2, b3, b4]);
        let not_a_response = ParseError::NotAResponse(raw_cs);
        let cs = CommandSpecifier::from_code(raw_cs).ok_or(not_a_response)?;
        let invalid = ParseError::InvalidParameter(cs);
        Ok(match cs {
            Cs::SwitchStateSelectiveResponse => Response::SwitchStateSelective,
            Cs::ConfigureNodeId => Response::ConfigureNodeId {
                status: ConfigureNodeIdStatus::from_code(b1).ok_or(invalid)?,
                specific: b2,
            },
            Cs::ConfigureBitTiming => Response::ConfigureBitTiming {
                status: ConfigureBitTimingStatus::from_code(b1).ok_or(invalid)?,
                specific: b2,
            },
            Cs::StoreConfiguration => Response::StoreConfiguration {
                status: StoreConfigurationStatus::from_code(b1).ok_or(invalid)?,
                specific: b2,
            },
            Cs::IdentifySlave => Response::IdentifySlave,
            Cs::IdentifyNonConfiguredSlave => Response::IdentifyNonConfiguredSlave,
            Cs::InquireVendorId => Response::InquireIdentity { field: LssField::VendorId, value },
            Cs::InquireProductCode => Response::InquireIdentity { field: LssField::ProductCode, value },
            Cs::InquireRevisionNumber => Response::InquireIdentity { field: LssField::RevisionNumber, value },
            Cs::InquireSerialNumber => Response::InquireIdentity { field: LssField::SerialNumber, value },
            Cs::InquireNodeId => Response::InquireNodeId(b1),
            // Master → slave only.
            Cs::SwitchStateGlobal
            | Cs::ActivateBitTiming
            | Cs::SwitchStateSelectiveVendorId
            | Cs::SwitchStateSelectiveProductCode
            | Cs::SwitchStateSelectiveRevisionNumber
            | Cs::SwitchStateSelectiveSerialNumber
            | Cs::IdentifyRemoteSlaveVendorId
            | Cs::IdentifyRemoteSlaveProductCode
            | Cs::IdentifyRemoteSlaveRevisionLow
            | Cs::IdentifyRemoteSlaveRevisionHigh
            | Cs::IdentifyRemoteSlaveSerialLow
            | Cs::IdentifyRemoteSlaveSerialHigh
            | Cs::IdentifyNonConfiguredRemoteSlave
            | Cs::Fastscan => return Err(not_a_response),
        })
    }

    /// The eight data bytes of the response (what the slave sends on 0x7E4).
    pub const fn emit(&self) -> [u8; 8] {
        use CommandSpecifier as Cs;
        match *self {
            Response::SwitchStateSelective => with_bytes(Cs::SwitchStateSelectiveResponse, 0, 0),
            Response::ConfigureNodeId { status, specific } => {
                with_bytes(Cs::ConfigureNodeId, status.code(), specific)
            }
            Response::ConfigureBitTiming { status, specific } => {
                with_bytes(Cs::ConfigureBitTiming, status.code(), specific)
            }
            Response::StoreConfiguration { status, specific } => {
                with_bytes(Cs::StoreConfiguration, status.code(), specific)
            }
            Response::IdentifySlave => with_bytes(Cs::IdentifySlave, 0, 0),
            Response::IdentifyNonConfiguredSlave => with_bytes(Cs::IdentifyNonConfiguredSlave, 0, 0),
            Response::InquireIdentity { field, value } => with_u32(Cs::inquire_identity(field), value),
            Response::InquireNodeId(node_id) => with_bytes(Cs::InquireNodeId, node_id, 0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const VALUE: u32 = 0x1234_5678;

    fn all_requests() -> impl Iterator<Item = Request> {
        let fixed = [
            Request::SwitchStateGlobal(SwitchMode::Waiting),
            Request::SwitchStateGlobal(SwitchMode::Configuration),
            Request::ConfigureNodeId(0),
            Request::ConfigureNodeId(5),
            Request::ConfigureNodeId(128),
            Request::ConfigureNodeId(0xFF),
            Request::ConfigureBitTiming(BitTiming::standard(BitRate::Kbit250)),
            Request::ConfigureBitTiming(BitTiming { table_selector: 0x80, table_index: 7 }),
            Request::ActivateBitTiming { switch_delay_ms: 0x1234 },
            Request::StoreConfiguration,
            Request::IdentifyRemoteVendorId(VALUE),
            Request::IdentifyRemoteProductCode(VALUE),
            Request::IdentifyRemoteRevisionLow(VALUE),
            Request::IdentifyRemoteRevisionHigh(VALUE),
            Request::IdentifyRemoteSerialLow(VALUE),
            Request::IdentifyRemoteSerialHigh(VALUE),
            Request::IdentifyNonConfiguredRemoteSlave,
            Request::InquireNodeId,
            Request::Unknown(0x00),
            Request::Unknown(0x12),
            Request::Unknown(0xFF),
        ];
        let per_field = LssField::ALL.into_iter().flat_map(|field| {
            [Request::SwitchStateSelective { field, value: VALUE }, Request::InquireIdentity(field)]
        });
        let fastscans = LssField::ALL.into_iter().flat_map(|sub| {
            [BitChecked::Reset, BitChecked::Bit(0), BitChecked::Bit(17), BitChecked::Bit(31)]
                .into_iter()
                .flat_map(move |bit_checked| {
                    LssField::ALL.into_iter().map(move |next| {
                        Request::Fastscan(Fastscan { id_number: VALUE, bit_checked, sub, next })
                    })
                })
        });
        fixed.into_iter().chain(per_field).chain(fastscans)
    }

    fn all_responses() -> impl Iterator<Item = Response> {
        let fixed = [
            Response::SwitchStateSelective,
            Response::ConfigureNodeId { status: ConfigureNodeIdStatus::Success, specific: 0 },
            Response::ConfigureNodeId { status: ConfigureNodeIdStatus::NodeIdOutOfRange, specific: 0 },
            Response::ConfigureNodeId { status: ConfigureNodeIdStatus::ManufacturerSpecific, specific: 9 },
            Response::ConfigureBitTiming { status: ConfigureBitTimingStatus::Success, specific: 0 },
            Response::ConfigureBitTiming {
                status: ConfigureBitTimingStatus::BitRateNotSupported,
                specific: 0,
            },
            Response::ConfigureBitTiming {
                status: ConfigureBitTimingStatus::ManufacturerSpecific,
                specific: 3,
            },
            Response::StoreConfiguration { status: StoreConfigurationStatus::Success, specific: 0 },
            Response::StoreConfiguration { status: StoreConfigurationStatus::NotSupported, specific: 0 },
            Response::StoreConfiguration {
                status: StoreConfigurationStatus::StorageMediaAccess,
                specific: 0,
            },
            Response::StoreConfiguration {
                status: StoreConfigurationStatus::ManufacturerSpecific,
                specific: 0x42,
            },
            Response::IdentifySlave,
            Response::IdentifyNonConfiguredSlave,
            Response::InquireNodeId(5),
            Response::InquireNodeId(NODE_ID_UNCONFIGURED),
        ];
        let inquire =
            LssField::ALL.into_iter().map(|field| Response::InquireIdentity { field, value: VALUE });
        fixed.into_iter().chain(inquire)
    }

    #[test]
    fn command_specifiers_round_trip() {
        for raw in 0..=255u8 {
            if let Some(cs) = CommandSpecifier::from_code(raw) {
                assert_eq!(cs.code(), raw);
            }
        }
        for cs in CommandSpecifier::ALL {
            assert_eq!(CommandSpecifier::from_code(cs.code()), Some(cs));
        }
        let defined = (0..=255u8).filter(|raw| CommandSpecifier::from_code(*raw).is_some()).count();
        assert_eq!(defined, CommandSpecifier::ALL.len());
        assert_eq!(CommandSpecifier::Fastscan as u8, 0x51);
        assert_eq!(CommandSpecifier::InquireNodeId as u8, 0x5E);
    }

    #[test]
    fn small_code_enums_round_trip() {
        for raw in 0..=255u8 {
            if let Some(v) = LssField::from_code(raw) {
                assert_eq!(v.code(), raw);
            }
            if let Some(v) = SwitchMode::from_code(raw) {
                assert_eq!(v.code(), raw);
            }
            if let Some(v) = BitRate::from_index(raw) {
                assert_eq!(v.index(), raw);
            }
            if let Some(v) = BitChecked::from_code(raw) {
                assert_eq!(v.code(), raw);
            }
            if let Some(v) = ConfigureNodeIdStatus::from_code(raw) {
                assert_eq!(v.code(), raw);
            }
            if let Some(v) = ConfigureBitTimingStatus::from_code(raw) {
                assert_eq!(v.code(), raw);
            }
            if let Some(v) = StoreConfigurationStatus::from_code(raw) {
                assert_eq!(v.code(), raw);
            }
        }
        assert_eq!(LssField::from_code(4), None);
        assert_eq!(SwitchMode::from_code(2), None);
        assert_eq!(BitRate::from_index(10), None);
        assert_eq!(BitChecked::from_code(32), None);
        assert_eq!(BitChecked::from_code(0x81), None);
    }

    #[test]
    fn bit_timing_table() {
        let kbit: [Option<u16>; 10] = [
            Some(1000),
            Some(800),
            Some(500),
            Some(250),
            Some(125),
            Some(100),
            Some(50),
            Some(20),
            Some(10),
            None,
        ];
        for (index, rate) in BitRate::ALL.into_iter().enumerate() {
            assert_eq!(usize::from(rate.index()), index);
            assert_eq!(rate.kbit_per_s(), kbit[index]);
            assert_eq!(BitTiming::standard(rate).standard_rate(), Some(rate));
        }
        assert_eq!(BitTiming { table_selector: 0, table_index: 10 }.standard_rate(), None);
        assert_eq!(BitTiming { table_selector: 0x80, table_index: 0 }.standard_rate(), None);
    }

    #[test]
    fn every_request_round_trips() {
        let mut count = 0;
        for request in all_requests() {
            assert_eq!(Request::parse(&request.emit()), Ok(request), "{request:?}");
            count += 1;
        }
        assert!(count > 80);
    }

    #[test]
    fn every_response_round_trips() {
        for response in all_responses() {
            assert_eq!(Response::parse(&response.emit()), Ok(response), "{response:?}");
        }
    }

    #[test]
    fn request_bytes_on_the_wire() {
        assert_eq!(Request::SwitchStateGlobal(SwitchMode::Configuration).emit(), [0x04, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Request::SwitchStateSelective { field: LssField::RevisionNumber, value: 0x0403_0201 }.emit(),
            [0x42, 1, 2, 3, 4, 0, 0, 0]
        );
        assert_eq!(Request::ConfigureNodeId(0x22).emit(), [0x11, 0x22, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Request::ConfigureBitTiming(BitTiming::standard(BitRate::Kbit125)).emit(),
            [0x13, 0, 4, 0, 0, 0, 0, 0]
        );
        assert_eq!(
            Request::ActivateBitTiming { switch_delay_ms: 0x01F4 }.emit(),
            [0x15, 0xF4, 0x01, 0, 0, 0, 0, 0]
        );
        assert_eq!(Request::StoreConfiguration.emit(), [0x17, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Request::IdentifyRemoteSerialHigh(0xAABB_CCDD).emit(),
            [0x4B, 0xDD, 0xCC, 0xBB, 0xAA, 0, 0, 0]
        );
        assert_eq!(Request::IdentifyNonConfiguredRemoteSlave.emit(), [0x4C, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Request::Fastscan(Fastscan {
                id_number: 0x0000_0300,
                bit_checked: BitChecked::Bit(7),
                sub: LssField::ProductCode,
                next: LssField::RevisionNumber,
            })
            .emit(),
            [0x51, 0x00, 0x03, 0, 0, 7, 1, 2]
        );
        assert_eq!(
            Request::Fastscan(Fastscan {
                id_number: 0,
                bit_checked: BitChecked::Reset,
                sub: LssField::VendorId,
                next: LssField::VendorId,
            })
            .emit(),
            [0x51, 0, 0, 0, 0, 0x80, 0, 0]
        );
        assert_eq!(Request::InquireIdentity(LssField::SerialNumber).emit(), [0x5D, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(Request::InquireNodeId.emit(), [0x5E, 0, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn response_bytes_on_the_wire() {
        assert_eq!(Response::SwitchStateSelective.emit(), [0x44, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Response::ConfigureNodeId { status: ConfigureNodeIdStatus::NodeIdOutOfRange, specific: 0 }.emit(),
            [0x11, 1, 0, 0, 0, 0, 0, 0]
        );
        assert_eq!(
            Response::StoreConfiguration {
                status: StoreConfigurationStatus::StorageMediaAccess,
                specific: 0
            }
            .emit(),
            [0x17, 2, 0, 0, 0, 0, 0, 0]
        );
        assert_eq!(Response::IdentifySlave.emit(), [0x4F, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(Response::IdentifyNonConfiguredSlave.emit(), [0x50, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Response::InquireIdentity { field: LssField::VendorId, value: 0x0403_0201 }.emit(),
            [0x5A, 1, 2, 3, 4, 0, 0, 0]
        );
        assert_eq!(Response::InquireNodeId(0x7F).emit(), [0x5E, 0x7F, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn frames_must_carry_eight_bytes() {
        assert_eq!(Request::parse(&[]), Err(ParseError::Length));
        assert_eq!(Request::parse(&[0x04, 0x01]), Err(ParseError::Length));
        assert_eq!(Request::parse(&[0x5E, 0, 0, 0, 0, 0, 0]), Err(ParseError::Length));
        assert_eq!(Request::parse(&[0x5E, 0, 0, 0, 0, 0, 0, 0, 0]), Err(ParseError::Length));
        assert_eq!(Response::parse(&[0x4F]), Err(ParseError::Length));
    }

    #[test]
    fn out_of_range_parameters_are_refused() {
        let invalid = |cs| Some(ParseError::InvalidParameter(cs));
        assert_eq!(
            Request::parse(&[0x04, 2, 0, 0, 0, 0, 0, 0]).err(),
            invalid(CommandSpecifier::SwitchStateGlobal)
        );
        // BitChecked 32..0x7F and above 0x80, LSSSub / LSSNext above 3.
        for frame in [
            [0x51, 0, 0, 0, 0, 32, 0, 0],
            [0x51, 0, 0, 0, 0, 0x81, 0, 0],
            [0x51, 0, 0, 0, 0, 0, 4, 0],
            [0x51, 0, 0, 0, 0, 0, 0, 4],
            [0x51, 0, 0, 0, 0, 0x80, 0xFF, 0],
        ] {
            assert_eq!(Request::parse(&frame).err(), invalid(CommandSpecifier::Fastscan));
        }
        assert_eq!(
            Response::parse(&[0x11, 2, 0, 0, 0, 0, 0, 0]).err(),
            invalid(CommandSpecifier::ConfigureNodeId)
        );
        assert_eq!(
            Response::parse(&[0x13, 2, 0, 0, 0, 0, 0, 0]).err(),
            invalid(CommandSpecifier::ConfigureBitTiming)
        );
        assert_eq!(
            Response::parse(&[0x17, 3, 0, 0, 0, 0, 0, 0]).err(),
            invalid(CommandSpecifier::StoreConfiguration)
        );
    }

    #[test]
    fn unknown_and_misdirected_command_specifiers() {
        // Reserved command specifiers and slave → master ones are no requests.
        for cs in [0x00u8, 0x05, 0x12, 0x45, 0x4D, 0x52, 0x5F, 0xFF, 0x44, 0x4F, 0x50] {
            assert_eq!(Request::parse(&[cs, 1, 2, 3, 4, 5, 6, 7]), Ok(Request::Unknown(cs)));
        }
        // Master → slave command specifiers are no responses.
        for cs in [0x04u8, 0x15, 0x40, 0x43, 0x46, 0x4B, 0x4C, 0x51, 0x00, 0xFF] {
            assert_eq!(Response::parse(&[cs, 0, 0, 0, 0, 0, 0, 0]), Err(ParseError::NotAResponse(cs)));
        }
    }

    #[test]
    fn unused_bytes_are_ignored_on_parse() {
        // Senders must zero unused bytes; receivers do not insist.
        assert_eq!(Request::parse(&[0x17, 9, 9, 9, 9, 9, 9, 9]), Ok(Request::StoreConfiguration));
        assert_eq!(
            Request::parse(&[0x04, 0, 9, 9, 9, 9, 9, 9]),
            Ok(Request::SwitchStateGlobal(SwitchMode::Waiting))
        );
        assert_eq!(Response::parse(&[0x4F, 9, 9, 9, 9, 9, 9, 9]), Ok(Response::IdentifySlave));
    }

    #[test]
    fn address_fields() {
        let mut address = LssAddress::default();
        for (i, field) in LssField::ALL.into_iter().enumerate() {
            address.set_field(field, 10 + i as u32);
        }
        assert_eq!(
            address,
            LssAddress { vendor_id: 10, product_code: 11, revision_number: 12, serial_number: 13 }
        );
        for (i, field) in LssField::ALL.into_iter().enumerate() {
            assert_eq!(address.field(field), 10 + i as u32);
        }
    }
}
