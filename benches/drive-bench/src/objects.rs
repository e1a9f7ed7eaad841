//! The manufacturer objects of the measured drives.
//!
//! - [`BENCH_OBJECTS`]: what the scenarios map and write besides the crate's own objects: eight
//!   PDO-mappable bytes, a string for block transfers, and the cascade controller's parameters.
//! - [`FILLER_SMALL`], [`FILLER_MEDIUM`], [`FILLER_LARGE`]: plain manufacturer parameters that
//!   grow the dictionary to about 160, 400 and 2000 objects for the look-up measurements. They sit
//!   at every other index from 2000h on, so the odd indices between them are misses inside the
//!   table's range.

use canopen_drive::cia402::registry::PROFILE;
use canopen_drive::comm::pdo::DEFAULT_OBJECTS;
use canopen_drive::control;
use canopen_drive::od::standard::COMMUNICATION;
use canopen_drive::od::{layout, Access, DataType, DefaultValue, Object, PdoMapping, Var};

/// Eight bytes mappable into RPDOs and TPDOs (sub 1–8).
pub const PDO_BYTES: u16 = 0x2100;
/// A writable VISIBLE_STRING of [`TEXT_CAPACITY`] bytes (block download target).
pub const TEXT: u16 = 0x2101;
/// Capacity of [`TEXT`].
pub const TEXT_CAPACITY: u16 = 64;
/// The cascade controller's parameter RECORD ([`control::object`]).
pub const CASCADE: u16 = 0x2400;

/// The objects every scenario drive has.
pub static BENCH_OBJECTS: [Object; 3] = layout([
    Object::array(
        PDO_BYTES,
        "Process bytes",
        8,
        &Var::new("Process byte", DataType::Unsigned8).access(Access::ReadWrite).pdo(PdoMapping::Both),
    ),
    Object::var(
        TEXT,
        "Text",
        Var::new("Text", DataType::VisibleString)
            .access(Access::ReadWrite)
            .capacity(TEXT_CAPACITY)
            .default(DefaultValue::Text("")),
    ),
    control::object(CASCADE),
]);

/// Objects of the crate's own tables (communication, PDOs, drive profile).
pub const CRATE_OBJECTS: usize = COMMUNICATION.len() + DEFAULT_OBJECTS.len() + PROFILE.len();

/// First index of the filler tables.
pub const FILLER_BASE: u16 = 0x2000;

/// Filler objects of the small dictionary (the default drive plus a few parameters).
pub const SMALL: usize = 16;
/// Filler objects that make the medium dictionary 400 objects.
pub const MEDIUM: usize = 400 - CRATE_OBJECTS;
/// Filler objects that make the large dictionary 2000 objects.
pub const LARGE: usize = 2000 - CRATE_OBJECTS;

/// `N` UNSIGNED8 parameters at 2000h, 2002h, 2004h, …
// The loop index is bounded by `N`; `get_mut` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
const fn filler<const N: usize>() -> [Object; N] {
    let var = Var::new("Parameter", DataType::Unsigned8).access(Access::ReadWrite);
    let mut out = [Object::var(FILLER_BASE, "Parameter", var); N];
    let mut i = 0;
    while i < N {
        out[i] = Object::var(FILLER_BASE + 2 * i as u16, "Parameter", var);
        i += 1;
    }
    out
}

/// See the module documentation.
pub static FILLER_SMALL: [Object; SMALL] = layout(filler());
/// See the module documentation.
pub static FILLER_MEDIUM: [Object; MEDIUM] = layout(filler());
/// See the module documentation.
pub static FILLER_LARGE: [Object; LARGE] = layout(filler());
