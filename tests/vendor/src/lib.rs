//! What a vendor writes around `canopen-drive`, using only its public API and docs: a
//! hand-written object joined with objects generated from the vendor's EDS, object hooks, and
//! the drive type of its board (parameter storage, 8 + 8 PDOs).
#![no_std]

use canopen_drive::comm::pdo;
use canopen_drive::drive::STANDARD_OD_BYTES;
use canopen_drive::od::{self, layout, AbortCode, Access, DataType, DefaultValue, Object, ObjectHooks, Var};
use canopen_drive::storage::Persistence;
use canopen_drive::{Config, PdoDrive};

include!(concat!(env!("OUT_DIR"), "/generated.rs"));

/// The hand-written object: pole pairs (even only, the hook says).
pub static HAND: [Object; 1] = layout([Object::var(
    0x2000,
    "Pole pairs",
    Var::new("Pole pairs", DataType::Unsigned8)
        .access(Access::ReadWrite)
        .default(DefaultValue::Unsigned(4))
        .limits_unsigned(1, 32),
)]);

/// Both, in one table.
pub static VENDOR: [Object; 4] = match od::join(&[&HAND, &GENERATED]) {
    Ok(table) => table,
    Err(_) => panic!("the vendor tables do not join"),
};
const _: () = assert!(od::check_manufacturer_table(&VENDOR).is_ok());

/// 8 RPDOs and 8 TPDOs.
pub static PDOS: [Object; 32] = layout(pdo::objects::<32>(8));

/// The value store: the standard objects with 8 + 8 PDOs instead of 4 + 4, and the vendor's.
pub const OD_BYTES: usize =
    STANDARD_OD_BYTES - od::storage_bytes(&[&pdo::DEFAULT_OBJECTS]) + od::storage_bytes(&[&PDOS, &VENDOR]);

/// The board's drive.
pub type BoardDrive<S> = PdoDrive<8, 8, S, Hooks, OD_BYTES>;

/// The configuration of node `node_id`.
pub const fn config(node_id: u8) -> Config {
    Config { manufacturer_objects: &VENDOR, pdo_objects: &PDOS, ..Config::new(node_id) }
}

/// The firmware's hooks.
#[derive(Default)]
pub struct Hooks {
    /// Pole-pair writes taken.
    pub pole_pair_writes: u32,
}

impl ObjectHooks for Hooks {
    fn validate(&mut self, index: u16, _sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, data) {
            (0x2000, [pairs]) if pairs % 2 == 1 => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn written(&mut self, index: u16, _sub: u8, _data: &[u8]) {
        if index == 0x2000 {
            self.pole_pair_writes += 1;
        }
    }
}

/// Builds the board's drive over `storage`.
pub fn build<S: Persistence>(node_id: u8, storage: S) -> Result<BoardDrive<S>, canopen_drive::ConfigError> {
    BoardDrive::build(config(node_id), Hooks::default(), storage)
}
