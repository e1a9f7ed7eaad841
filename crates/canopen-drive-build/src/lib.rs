//! # canopen-drive-build
//!
//! The objects of an EDS (CiA 306) as the Rust table a [canopen-drive] firmware links: an
//! integrator who already describes the drive's manufacturer objects in an EDS (from
//! CANopenEditor or a previous product) generates the table at build time instead of
//! transcribing it.
//!
//! In the firmware's `build.rs` (with `canopen-drive-build` as a build dependency):
//!
//! ```no_run
//! // build.rs: fn main() { … }
//! let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").unwrap());
//! canopen_drive_build::Table::new("VENDOR_OBJECTS")
//!     .build("vendor.eds", out.join("vendor_objects.rs"))
//!     .unwrap_or_else(|e| panic!("{e}"));
//! ```
//!
//! and in the firmware:
//!
//! ```ignore
//! include!(concat!(env!("OUT_DIR"), "/vendor_objects.rs"));
//! let config = canopen_drive::Config { manufacturer_objects: &VENDOR_OBJECTS, ..Config::new(5) };
//! ```
//!
//! The generated file is one `pub static [Object; N]`, laid out with
//! `canopen_drive::od::layout`, written with the same `const` builders a hand-written table
//! uses, so it builds for any target the core builds for. The objects of the chosen index
//! range ([`Table::range`], 2000h–5FFFh by default) are taken; everything else in the file
//! (the communication and profile objects, which the core provides) is left out.
//!
//! ## What an entry becomes
//!
//! | EDS | table |
//! |---|---|
//! | `ParameterName` | the object's and the entry's name (kept with the core's `names` feature) |
//! | `ObjectType` 0x7 / 0x8 / 0x9 | `Object::var` / `Object::array_with_sub0` / `Object::record` |
//! | `DataType` 0x0001–0x001B | `DataType` |
//! | `AccessType` `ro`, `wo`, `rw`, `const` | `Access::ReadOnly`, `WriteOnly`, `ReadWrite`, `Const` |
//! | `AccessType` `rww` / `rwr` | `Access::ReadWrite`, with `PDOMapping=1` mappable into RPDOs / TPDOs only |
//! | `PDOMapping=1` | `PdoMapping::Both` for `rw`, `Tpdo` for `ro` and `const`, `Rpdo` for `wo` |
//! | `DefaultValue` | `DefaultValue::Unsigned`, `Signed`, `Real`, `Text`, `Bytes` (hex digits), `NodeIdPlus` (`$NODEID+n`) |
//! | `LowLimit`, `HighLimit` | `Var::limits` |
//!
//! The core's EDS writer (`canopen_drive::od::eds`) writes these back as the same objects, so
//! EDS → table → EDS keeps every object, name, type, access, mapping, default and limit.
//!
//! An EDS carries no storage size for strings and domains: a VISIBLE_STRING, OCTET_STRING,
//! UNICODE_STRING or DOMAIN entry gets [`Table::string_capacity`] bytes (at least its
//! default's). What the core cannot represent is refused with the object and the reason
//! ([`Error`]), never guessed: an ARRAY whose elements differ in anything but their names,
//! element names other than the core's `<name> <sub>`, `CompactSubObj`, DOMAIN objects
//! (`ObjectType` 0x2), a default or limit outside the entry's type, a default outside the
//! entry's limits and a low limit above the high one (the core refuses such a table when a
//! drive is built, `ConfigError::DefaultOutsideLimits` and `BadLimits`).
//!
//! [canopen-drive]: https://docs.rs/canopen-drive

mod eds;
mod generate;

use std::fmt;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

pub use generate::Table;

/// Why an EDS could not be read or turned into a table.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be read or the table not written.
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        error: std::io::Error,
    },
    /// A line is not INI (`[Section]`, `Key=Value`, `;comment`).
    Syntax {
        /// Line number, from 1.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An object or entry the core's tables cannot hold as described.
    Object {
        /// Index.
        index: u16,
        /// Sub-index, for an entry of an ARRAY or RECORD.
        sub: Option<u8>,
        /// What is wrong.
        message: String,
    },
}

impl Error {
    fn syntax(line: usize, message: impl Into<String>) -> Self {
        Error::Syntax { line, message: message.into() }
    }

    fn object(index: u16, sub: Option<u8>, message: impl Into<String>) -> Self {
        Error::Object { index, sub, message: message.into() }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, error } => write!(f, "{}: {error}", path.display()),
            Error::Syntax { line, message } => write!(f, "line {line}: {message}"),
            Error::Object { index, sub: None, message } => write!(f, "object {index:04X}h: {message}"),
            Error::Object { index, sub: Some(sub), message } => {
                write!(f, "object {index:04X}h sub {sub}: {message}")
            }
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { error, .. } => Some(error),
            _ => None,
        }
    }
}

/// The objects of `range` in the EDS text `eds` as Rust source (see [`Table::generate`]).
pub fn generate(eds: &str, name: &str, range: RangeInclusive<u16>) -> Result<String, Error> {
    Table::new(name).range(range).generate(eds)
}

fn read(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|error| Error::Io { path: path.to_path_buf(), error })
}
