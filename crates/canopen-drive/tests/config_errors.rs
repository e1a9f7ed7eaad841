//! Every way a configuration or a table can be wrong, as a firmware meets it: the error
//! `Drive::new` (or the table checks) return, and the sentence it prints.
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

use canopen_drive::od::DeviceInfo;
use canopen_drive::od::{
    self, layout, Access, DataType, DefaultOverride, DefaultValue, Dictionary, EntryOverride, Object, Var,
};
use canopen_drive::{Config, ConfigError, Drive};

const NODE: u8 = 5;

/// The error of a drive of the default shape built with `manufacturer_objects`.
fn vendor(objects: &'static [Object]) -> ConfigError {
    Drive::new(Config { manufacturer_objects: objects, ..Config::new(NODE) }).err().unwrap()
}

const fn u8_var(name: &'static str) -> Var {
    Var::new(name, DataType::Unsigned8).access(Access::ReadWrite)
}

#[test]
fn a_node_id_outside_1_to_127() {
    let error = Drive::new(Config::new(0)).err().unwrap();
    assert_eq!(error, ConfigError::InvalidNodeId);
    assert_eq!(error.to_string(), "the node-ID is outside 1–127 (or FFh, unconfigured)");
    assert!(Drive::new(Config::new(128)).is_err());
}

#[test]
fn a_pdo_table_of_another_size_than_the_drive_type() {
    let error = Drive::<(), 4096, 8, 8>::create(Config::new(NODE), ()).err().unwrap();
    assert_eq!(error, ConfigError::PdoCount { drive: (8, 8), table: (4, 4) });
    assert_eq!(error.to_string(), "the PDO table describes 4 + 4 PDOs, the drive type holds 8 + 8");
}

#[test]
fn more_tables_than_a_dictionary_joins() {
    let tables: [&'static [Object]; 7] = [&[], &[], &[], &[], &[], &[], &[]];
    let error = Dictionary::<64>::new(&tables, DeviceInfo::servo_drive(), NODE).err().unwrap();
    assert_eq!(error, ConfigError::TooManyTables);
    assert_eq!(error.to_string(), "more than 6 tables");
}

#[test]
fn objects_out_of_order() {
    static UNSORTED: [Object; 2] =
        layout([Object::var(0x2001, "b", u8_var("b")), Object::var(0x2000, "a", u8_var("a"))]);
    let error = vendor(&UNSORTED);
    assert_eq!(error, ConfigError::NotSorted { index: 0x2000 });
    assert_eq!(error.to_string(), "object 2000h: indices not in ascending order");
}

#[test]
fn an_index_described_twice() {
    static TWICE: [Object; 2] =
        layout([Object::var(0x2000, "a", u8_var("a")), Object::var(0x2000, "b", u8_var("b"))]);
    let error = vendor(&TWICE);
    assert_eq!(error, ConfigError::DuplicateIndex { index: 0x2000 });
    assert_eq!(error.to_string(), "object 2000h: described twice");
}

#[test]
fn a_manufacturer_object_outside_2000h_to_5fffh() {
    static LOW: [Object; 1] = layout([Object::var(0x1234, "a", u8_var("a"))]);
    static HIGH: [Object; 2] =
        layout([Object::var(0x5FFF, "a", u8_var("a")), Object::var(0x6000, "b", u8_var("b"))]);
    let error = vendor(&LOW);
    assert_eq!(error, ConfigError::NotManufacturer { index: 0x1234 });
    assert_eq!(error.to_string(), "object 1234h: a manufacturer object outside 2000h–5FFFh");
    assert_eq!(vendor(&HIGH), ConfigError::NotManufacturer { index: 0x6000 });
}

#[test]
fn a_table_not_laid_out() {
    static RAW: [Object; 2] = [Object::var(0x2000, "a", u8_var("a")), Object::var(0x2001, "b", u8_var("b"))];
    let error = vendor(&RAW);
    assert_eq!(error, ConfigError::NotLaidOut { index: 0x2001 });
    assert_eq!(error.to_string(), "object 2001h: the table was not laid out (od::layout)");
}

#[test]
fn a_value_store_too_small_for_the_tables() {
    let error = Drive::<(), 64>::create(Config::new(NODE), ()).err().unwrap();
    let needed = canopen_drive::drive::STANDARD_OD_BYTES;
    assert_eq!(error, ConfigError::StorageTooSmall { needed });
    assert_eq!(error.to_string(), format!("the value store is too small: the tables need {needed} bytes"));
}

#[test]
fn a_string_of_more_than_64_kib() {
    static HUGE: [Object; 1] = layout([Object::var(
        0x2000,
        "Text",
        Var::new("Text", DataType::VisibleString).access(Access::ReadWrite).capacity(u16::MAX),
    )]);
    let error = vendor(&HUGE);
    assert_eq!(error, ConfigError::EntryTooLarge { index: 0x2000, sub: 0 });
    assert_eq!(error.to_string(), "object 2000h sub 0: more than 65 535 bytes of storage");
}

#[test]
fn record_sub_indices_out_of_order() {
    static SUBS: [(u8, Var); 3] = [
        (0, Var::new("Highest sub-index supported", DataType::Unsigned8).access(Access::Const)),
        (2, Var::new("b", DataType::Unsigned8)),
        (1, Var::new("a", DataType::Unsigned8)),
    ];
    static RECORD: [Object; 1] = layout([Object::record(0x2000, "Record", &SUBS)]);
    let error = vendor(&RECORD);
    assert_eq!(error, ConfigError::SubsNotSorted { index: 0x2000, sub: 1 });
    assert_eq!(error.to_string(), "object 2000h sub 1: sub-indices not in ascending order");
}

#[test]
fn a_default_the_type_cannot_hold() {
    static TOO_BIG: [Object; 1] =
        layout([Object::var(0x2000, "a", u8_var("a").default(DefaultValue::Unsigned(300)))]);
    static NEGATIVE: [Object; 1] =
        layout([Object::var(0x2000, "a", u8_var("a").default(DefaultValue::Signed(-1)))]);
    static TEXT: [Object; 1] =
        layout([Object::var(0x2000, "a", u8_var("a").default(DefaultValue::Text("4")))]);
    static LONG_TEXT: [Object; 1] = layout([Object::var(
        0x2000,
        "Label",
        Var::new("Label", DataType::VisibleString)
            .access(Access::ReadWrite)
            .capacity(4)
            .default(DefaultValue::Text("motor 1")),
    )]);
    for table in [&TOO_BIG, &NEGATIVE, &TEXT, &LONG_TEXT] {
        let error = vendor(table);
        assert_eq!(error, ConfigError::DefaultType { index: 0x2000, sub: 0 });
        assert_eq!(error.to_string(), "object 2000h sub 0: the default does not fit the data type");
    }
}

#[test]
fn a_default_outside_its_limits() {
    // The case of an EDS with DefaultValue=100 and HighLimit=64: the drive would serve 100 and
    // refuse a write of 100 with 0609 0031h.
    static ABOVE: [Object; 1] = layout([Object::var(
        0x2000,
        "Current limit",
        u8_var("Current limit").default(DefaultValue::Unsigned(100)).limits_unsigned(0, 64),
    )]);
    // The default zero lies below a low limit of 1.
    static BELOW: [Object; 1] = layout([Object::array(
        0x2001,
        "Gains",
        2,
        &Var::new("Gain", DataType::Integer16).access(Access::ReadWrite).limits_signed(1, 100),
    )]);
    let error = vendor(&ABOVE);
    assert_eq!(error, ConfigError::DefaultOutsideLimits { index: 0x2000, sub: 0 });
    assert_eq!(error.to_string(), "object 2000h sub 0: the default is outside the limits");
    assert_eq!(vendor(&BELOW), ConfigError::DefaultOutsideLimits { index: 0x2001, sub: 1 });
    // A firmware's override of a standard default is held to the entry's limits too
    // (6060h modes of operation: INTEGER8, −128 as UNSIGNED would not fit).
    static OVERRIDE: [DefaultOverride; 1] =
        [DefaultOverride { index: 0x6060, sub: 0, value: DefaultValue::Unsigned(200) }];
    let error = Drive::new(Config { default_overrides: &OVERRIDE, ..Config::new(NODE) }).err().unwrap();
    assert_eq!(error, ConfigError::DefaultType { index: 0x6060, sub: 0 });
}

#[test]
fn limits_of_another_kind_or_inverted() {
    static SIGNED_LIMITS: [Object; 1] = layout([Object::var(0x2000, "a", u8_var("a").limits_signed(-1, 10))]);
    static INVERTED: [Object; 1] = layout([Object::var(0x2000, "a", u8_var("a").limits_unsigned(10, 1))]);
    for table in [&SIGNED_LIMITS, &INVERTED] {
        let error = vendor(table);
        assert_eq!(error, ConfigError::BadLimits { index: 0x2000, sub: 0 });
        assert_eq!(
            error.to_string(),
            "object 2000h sub 0: limits not of the data type's kind, or low above high"
        );
    }
}

#[test]
fn an_override_of_an_entry_that_does_not_exist() {
    static MISSING: [DefaultOverride; 1] =
        [DefaultOverride { index: 0x6085, sub: 7, value: DefaultValue::Unsigned(1) }];
    let error = Drive::new(Config { default_overrides: &MISSING, ..Config::new(NODE) }).err().unwrap();
    assert_eq!(error, ConfigError::NoSuchEntry { index: 0x6085, sub: 7 });
    assert_eq!(error.to_string(), "object 6085h sub 7: overridden but not in the tables");
}

#[test]
fn modes_this_build_does_not_run() {
    // Built by `Drive::new` only when a mode's feature is off (tests/modes.rs); the text:
    let error = ConfigError::ModesNotBuilt { modes: 0x20 };
    assert_eq!(
        error.to_string(),
        "6502h lists modes this build does not run (bits 0x00000020): enable their features"
    );
}

#[test]
fn more_axes_than_cia_402_gives_a_node() {
    let error = Drive::<(), 65535, 4, 4, (), 9>::build(Config::new(NODE), (), ()).err().unwrap();
    assert_eq!(error, ConfigError::BadCopies { index: 0x6000 });
    assert_eq!(error.to_string(), "object 6000h: the table cannot be copied for that many axes");
}

#[test]
fn an_override_that_changes_the_size_of_its_entry() {
    static WIDER: [EntryOverride; 1] =
        [EntryOverride::of(&canopen_drive::cia402::registry::PROFILE, 0x6072, 0)
            .data_type(DataType::Integer32)];
    let error = Drive::new(Config { entry_overrides: &WIDER, ..Config::new(NODE) }).err().unwrap();
    assert_eq!(error, ConfigError::EntrySize { index: 0x6072, sub: 0 });
    assert_eq!(error.to_string(), "object 6072h sub 0: the override changes the entry's size or storage");
}

#[test]
fn joined_tables_of_another_length() {
    static ONE: [Object; 1] = layout([Object::var(0x2000, "a", u8_var("a"))]);
    let error = od::join::<2>(&[&ONE]).err().unwrap();
    assert_eq!(error, ConfigError::TableLength { declared: 2, objects: 1 });
    assert_eq!(error.to_string(), "the joined tables hold 1 objects, the table 2");
}

// ---- Joining a hand-written and a generated table -----------------------------------------

static HAND: [Object; 2] =
    layout([Object::var(0x2000, "Mode", u8_var("Mode")), Object::var(0x2100, "Fault", u8_var("Fault"))]);
static GENERATED: [Object; 2] = layout([
    Object::var(0x2001, "Gain", u8_var("Gain").default(DefaultValue::Unsigned(7))),
    Object::var(0x3000, "Offset", Var::new("Offset", DataType::Integer32).access(Access::ReadWrite)),
]);
static VENDOR: [Object; 4] = match od::join(&[&HAND, &GENERATED]) {
    Ok(table) => table,
    Err(_) => panic!("the vendor tables do not join"),
};
// Checked when compiled: the build fails on a wrong table.
const _: () = assert!(od::check_manufacturer_table(&VENDOR).is_ok());

#[test]
fn a_hand_written_and_a_generated_table_joined_serve_every_object() {
    assert_eq!(VENDOR.map(|o| o.index), [0x2000, 0x2001, 0x2100, 0x3000]);
    let mut drive = Drive::new(Config { manufacturer_objects: &VENDOR, ..Config::new(NODE) }).unwrap();
    assert_eq!(drive.od().get::<u8>(0x2001, 0), Ok(7));
    drive.od_mut().set::<i32>(0x3000, 0, -5).unwrap();
    assert_eq!(drive.od().get::<i32>(0x3000, 0), Ok(-5));
    assert_eq!(drive.od().get::<u8>(0x2001, 0), Ok(7), "each object has its own bytes");
}

#[test]
fn tables_that_share_an_index_do_not_join() {
    static CLASH: [Object; 1] = layout([Object::var(0x2100, "Other", u8_var("Other"))]);
    let error = od::join::<3>(&[&HAND, &CLASH]).err().unwrap();
    assert_eq!(error, ConfigError::DuplicateIndex { index: 0x2100 });
    static UNSORTED: [Object; 2] =
        layout([Object::var(0x2003, "b", u8_var("b")), Object::var(0x2002, "a", u8_var("a"))]);
    assert_eq!(od::join::<4>(&[&HAND, &UNSORTED]).err(), Some(ConfigError::NotSorted { index: 0x2002 }));
    // A joined table keeps the checks of its entries.
    static BAD_DEFAULT: [Object; 1] = layout([Object::var(
        0x2002,
        "a",
        u8_var("a").default(DefaultValue::Unsigned(9)).limits_unsigned(0, 8),
    )]);
    assert_eq!(
        od::join::<3>(&[&HAND, &BAD_DEFAULT]).err(),
        Some(ConfigError::DefaultOutsideLimits { index: 0x2002, sub: 0 })
    );
}

#[test]
fn the_checks_run_when_the_table_is_compiled() {
    static ABOVE: [Object; 1] = layout([Object::var(
        0x2000,
        "a",
        u8_var("a").default(DefaultValue::Unsigned(100)).limits_unsigned(0, 64),
    )]);
    const CHECKED: Result<(), ConfigError> = od::check_table(&ABOVE);
    assert_eq!(CHECKED, Err(ConfigError::DefaultOutsideLimits { index: 0x2000, sub: 0 }));
    assert!(od::check_table(&canopen_drive::cia402::registry::PROFILE).is_ok());
    assert!(od::check_table(&canopen_drive::od::standard::COMMUNICATION).is_ok());
}

#[test]
fn config_error_is_an_error() {
    fn takes(_: &dyn core::error::Error) {}
    takes(&ConfigError::InvalidNodeId);
}
