//! # The dictionary from the integrator's EDS
//!
//! A firmware whose manufacturer objects are already described in an EDS (from CANopenEditor or
//! a previous product) does not transcribe them: its `build.rs` hands the file to
//! [canopen-drive-build](https://docs.rs/canopen-drive-build), which writes the Rust table into
//! `OUT_DIR`, and the firmware includes it. This crate is that firmware's part, for the
//! manufacturer objects of `canopen-drive-linux`'s generic drive (`generic-drive.eds`):
//!
//! | index | name | type | access |
//! |---|---|---|---|
//! | 2000h | Motor pole pairs | UNSIGNED8, 1–32, default 4 | rw |
//! | 2001h | Motor data (RECORD): rated current, peak current (mA), winding resistance (Ω) | UNSIGNED32, UNSIGNED32, REAL32 | rw |
//! | 2002h | Temperature sensor offsets (ARRAY of 2), −100…100, default −5 | INTEGER16 | rw |
//! | 2003h | Axis label, default "axis 1" | VISIBLE_STRING (32 bytes) | rw |
//! | 2004h | Firmware build | UNSIGNED32 | const |
//! | 2005h | Torque offset, −1000…1000 | INTEGER16 | rww (RPDO) |
//! | 2006h | Drive temperature | INTEGER16 | ro (TPDO) |
//! | 2100h–2102h | the program's simulation objects (faults, inputs, load) | | rw |
//!
//! `build.rs` is the whole integration:
//!
//! ```text
//! canopen_drive_build::Table::new("MANUFACTURER_OBJECTS")
//!     .build("generic-drive.eds", out_dir.join("manufacturer_objects.rs"))
//! ```
//!
//! and the table goes where a hand-written one would:
//! `Config { manufacturer_objects: &MANUFACTURER_OBJECTS, .. }`. The crate is `no_std` and
//! builds for every target of the core (CI builds it for thumbv7em); the Linux program links it
//! as its generic drive's manufacturer objects, and its python-canopen test reads and writes
//! them over SDO and compares the drive's EDS with this file.
#![no_std]

include!(concat!(env!("OUT_DIR"), "/manufacturer_objects.rs"));

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]
mod tests {
    extern crate std;
    use std::string::String;
    use std::vec::Vec;

    use canopen_drive::od::{eds, DeviceInfo, Dictionary};

    use super::MANUFACTURER_OBJECTS;

    fn dictionary() -> Dictionary<1024> {
        Dictionary::new(&[&MANUFACTURER_OBJECTS], DeviceInfo::servo_drive(), 5).unwrap()
    }

    /// The table in a dictionary: the objects of the EDS hold its defaults.
    #[test]
    fn the_generated_objects_hold_their_defaults() {
        let od = dictionary();
        let read = |index, sub| -> Vec<u8> {
            let entry = od.entry(index, sub).unwrap();
            let mut value = [0u8; 32];
            let n = od.read(&entry, 0, &mut value);
            value[..n].to_vec()
        };
        assert_eq!(read(0x2000, 0), [4]);
        assert_eq!(read(0x2001, 0), [3]);
        assert_eq!(read(0x2001, 1), 2000u32.to_le_bytes());
        assert_eq!(read(0x2001, 3), 0.35f32.to_le_bytes());
        assert_eq!(read(0x2002, 0), [2]);
        assert_eq!(read(0x2002, 2), (-5i16).to_le_bytes());
        assert_eq!(read(0x2003, 0), b"axis 1");
        assert_eq!(read(0x2004, 0), 0x2026_1126u32.to_le_bytes());
        assert_eq!(read(0x2102, 0), [0, 0]);
        assert!(od.entry(0x2007, 0).is_err());
    }

    /// EDS → table → EDS → table: the EDS the core writes from the generated table generates
    /// the same table again, so no object, name, type, access, mapping, default or limit was
    /// lost or changed on the way (the numbers may be spelled differently: 4 and 0x4).
    #[test]
    fn the_eds_written_from_the_table_gives_the_same_table() {
        let source =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/generic-drive.eds")).unwrap();
        let mut written = String::new();
        eds::write(&dictionary(), &eds::EdsInfo::default(), &eds::Capabilities::PLAIN, &mut written).unwrap();
        let table = |eds: &str| canopen_drive_build::generate(eds, "T", 0x2000..=0x5FFF).unwrap();
        assert_eq!(table(&written), table(&source));
        assert!(table(&source).contains("; 10] ="), "all ten objects: {}", table(&source));
    }
}
