//! Manufacturer objects the integration tests use to reach every SDO path.

use canopen_drive::od::{
    layout, AbortCode, Access, DataType, DefaultValue, Object, ObjectHooks, PdoMapping, Var, WriteRule,
};

/// 2000h: a VISIBLE_STRING of up to 200 bytes.
pub const TEXT: u16 = 0x2000;
/// 2001h: UNSIGNED8 limited to 10..=20.
pub const LIMITED: u16 = 0x2001;
/// 2002h: write-only UNSIGNED32.
pub const WRITE_ONLY: u16 = 0x2002;
/// 2003h: OCTET_STRING of up to 1000 bytes (more than the SDO buffer).
pub const BIG: u16 = 0x2003;
/// 2004h: a record (sub 1 INTEGER32 -100..=100, sub 2 UNSIGNED16 not writable in Operational).
pub const RECORD: u16 = 0x2004;
/// 2005h: a read-only DOMAIN of 1000 bytes.
pub const TABLE: u16 = 0x2005;
/// 2006h: an UNSIGNED32 whose writes the firmware's hook refuses with "general error".
pub const REFUSED: u16 = 0x2006;
/// 2007h: a BOOLEAN mappable both ways (bit-level mapping).
pub const FLAG: u16 = 0x2007;
/// 2008h: an UNSIGNED8 mappable both ways, limited to 0..=100.
pub const PERCENT: u16 = 0x2008;

pub const DEFAULT_TEXT: &str = "canopen-drive test string";

pub static TABLE_BYTES: [u8; 1000] = {
    let mut t = [0u8; 1000];
    let mut i = 0;
    while i < 1000 {
        t[i] = (i * 7 + 3) as u8;
        i += 1;
    }
    t
};

const RECORD_SUBS: [(u8, Var); 3] = [
    (
        0,
        Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(2)),
    ),
    (
        1,
        Var::new("Offset", DataType::Integer32)
            .access(Access::ReadWrite)
            .default(DefaultValue::Signed(-5))
            .limits_signed(-100, 100),
    ),
    (2, Var::new("Mode", DataType::Unsigned16).access(Access::ReadWrite).rule(WriteRule::NotOperational)),
];

pub static TEST_OBJECTS: [Object; 9] = layout([
    Object::var(
        TEXT,
        "Text",
        Var::new("Text", DataType::VisibleString)
            .access(Access::ReadWrite)
            .capacity(200)
            .default(DefaultValue::Text(DEFAULT_TEXT)),
    ),
    Object::var(
        LIMITED,
        "Limited",
        Var::new("Limited", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(15))
            .limits_unsigned(10, 20),
    ),
    Object::var(
        WRITE_ONLY,
        "Write only",
        Var::new("Write only", DataType::Unsigned32).access(Access::WriteOnly),
    ),
    Object::var(BIG, "Big", Var::new("Big", DataType::OctetString).access(Access::ReadWrite).capacity(1000)),
    Object::record(RECORD, "Record", &RECORD_SUBS),
    Object::var(
        TABLE,
        "Table",
        Var::new("Table", DataType::Domain).access(Access::Const).default(DefaultValue::Bytes(&TABLE_BYTES)),
    ),
    Object::var(REFUSED, "Refused", Var::new("Refused", DataType::Unsigned32).access(Access::ReadWrite)),
    Object::var(
        FLAG,
        "Flag",
        Var::new("Flag", DataType::Boolean).access(Access::ReadWrite).pdo(PdoMapping::Both),
    ),
    Object::var(
        PERCENT,
        "Percent",
        Var::new("Percent", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .pdo(PdoMapping::Both)
            .limits_unsigned(0, 100),
    ),
]);

/// The firmware side of the test objects.
#[derive(Default)]
pub struct TestHooks {
    pub written: Vec<(u16, u8, Vec<u8>)>,
}

impl ObjectHooks for TestHooks {
    fn validate(&mut self, index: u16, _sub: u8, _data: &[u8]) -> Result<(), AbortCode> {
        if index == REFUSED {
            Err(AbortCode::General)
        } else {
            Ok(())
        }
    }

    fn written(&mut self, index: u16, sub: u8, data: &[u8]) {
        self.written.push((index, sub, data.to_vec()));
    }
}
