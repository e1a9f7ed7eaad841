//! The drives this program can be (`--profile`): the generic canopen-drive node, and three
//! real drives rebuilt from their manuals on the unchanged core — a configuration of the core
//! plus the behaviour of the drive's manufacturer objects on the simulated axis.
//!
//! | profile | manual | module |
//! |---|---|---|
//! | `generic` | — (the library's defaults) | [`generic`] |
//! | `trinamic-pd57` | PD57/60-1378 CANopen firmware manual (stepper module) | [`trinamic`] |
//! | `harmonic-drive` | Harmonic Drive LLC CANopen firmware manual (servo actuators) | [`harmonic`] |
//! | `chieftek` | Chieftek DS402 manual (servo drive, profile objects only) | [`chieftek`] |
//!
//! A profile is data ([`BoardProfile`]): the core's `Config` of the drive (identity,
//! manufacturer and PDO tables, the drive-profile configuration with modes, option codes,
//! homing methods and the documented deviations, the drive's own defaults and descriptions of
//! standard objects, the meaning of 1029h), the simulated axis, and a [`Firmware`] that gives
//! manufacturer objects their meaning (live values, switch configuration, store commands).
//! Nothing in the core knows which drive it is.

pub mod chieftek;
pub mod generic;
pub mod harmonic;
pub mod trinamic;

use std::path::Path;

use canopen_drive::cia402::fsa::State;
use canopen_drive::hal::Sample;
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::{
    Access, DataType, DefaultOverride, DefaultValue, Dictionary, EntryOverride, Object, Var,
};
use canopen_drive::Config;
use canopen_drive_sim::motor::MotorParams;

use crate::board_objects::{BoardHooks, ValueRule};

/// Bytes of the dictionary's value store (the largest profile needs about 4 KiB).
pub const OD_BYTES: usize = 8192;

/// The dictionary of this board's drive.
pub type BoardDictionary = Dictionary<OD_BYTES>;

/// The profiles, by their `--profile` names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProfileName {
    /// The library's defaults (the program before profiles existed).
    Generic,
    /// A Chieftek servo drive.
    Chieftek,
    /// A Trinamic PD57/60-1378 stepper module.
    TrinamicPd57,
    /// A Harmonic Drive integrated servo actuator.
    HarmonicDrive,
}

impl ProfileName {
    /// Every profile.
    pub const ALL: [ProfileName; 4] =
        [ProfileName::Generic, ProfileName::Chieftek, ProfileName::TrinamicPd57, ProfileName::HarmonicDrive];

    /// The `--profile` name.
    pub const fn name(self) -> &'static str {
        match self {
            ProfileName::Generic => "generic",
            ProfileName::Chieftek => "chieftek",
            ProfileName::TrinamicPd57 => "trinamic-pd57",
            ProfileName::HarmonicDrive => "harmonic-drive",
        }
    }

    /// The profile called `name`.
    pub fn parse(name: &str) -> Option<Self> {
        ProfileName::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// A value the firmware puts into the dictionary (a live value of a read-only object, the
/// answer to a command): the numeric value of a fixed-size entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Update {
    /// Index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// The value, truncated to the entry's size.
    pub value: u64,
}

/// What the firmware may know about the program around it.
#[derive(Clone, Copy, Debug)]
pub struct Environment<'a> {
    /// The file of the LSS configuration (node-ID, bit timing), when the program keeps
    /// parameters (`--storage`).
    pub lss_file: Option<&'a Path>,
    /// The bit rate the program was configured with, kbit/s (what a CAN controller would run).
    pub bit_rate_kbit: u16,
}

/// The behaviour of a drive's manufacturer objects: the part of a vendor firmware the
/// simulated axis can reproduce. Every method has a default that does nothing.
pub trait Firmware: Send {
    /// At start-up, after stored parameters were loaded.
    fn start(&mut self, od: &BoardDictionary, env: &Environment<'_>, updates: &mut Vec<Update>) {
        let _ = (od, env, updates);
    }

    /// The inputs as the drive sees them (e.g. a limit-switch configuration): adjusts the
    /// motor's sample before the tick.
    fn inputs(&mut self, od: &BoardDictionary, sample: &mut Sample) {
        let _ = (od, sample);
    }

    /// A master wrote `value` to a manufacturer object or a profile object (2000h–9FFFh),
    /// after the dictionary stored it.
    fn written(
        &mut self,
        index: u16,
        sub: u8,
        value: u64,
        od: &BoardDictionary,
        env: &Environment<'_>,
        updates: &mut Vec<Update>,
    ) {
        let _ = (index, sub, value, od, env, updates);
    }

    /// A store on command (1010h sub `sub`) succeeded: data of the firmware's own that belongs
    /// to the group may be kept too.
    fn stored(&mut self, sub: u8, od: &BoardDictionary, env: &Environment<'_>) {
        let _ = (sub, od, env);
    }

    /// After an NMT reset node: the application restarted with its stored parameters (or its
    /// defaults), as at power-on but without [`Firmware::start`]'s knowledge of the program.
    fn reset(&mut self, od: &BoardDictionary, env: &Environment<'_>, updates: &mut Vec<Update>) {
        let _ = (od, env, updates);
    }

    /// After each tick: the live values of the manufacturer objects.
    fn after_tick(&mut self, od: &BoardDictionary, sample: &Sample, state: State, updates: &mut Vec<Update>) {
        let _ = (od, sample, state, updates);
    }

    /// What the firmware does to the drive itself, taken after `written` and `after_tick`.
    fn take_actions(&mut self) -> Vec<Action> {
        Vec::new()
    }
}

/// A firmware's action on the drive (besides values it writes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// 6064h reads this value at the present position ([`canopen_drive::Drive::preset_position`]).
    PresetPosition(i32),
    /// Store these parameters (index, sub-index), keeping the rest of the stored set
    /// ([`canopen_drive::Drive::store_entries`]).
    StoreEntries(&'static [(u16, u8)]),
    /// The node-ID the drive takes at its next reset ([`canopen_drive::Drive::configure_node_id`]).
    ConfigureNodeId(u8),
    /// PDO mappings may change while the PDO is valid, or not
    /// ([`canopen_drive::Drive::set_remap_while_valid`]).
    RemapWhileValid(bool),
}

/// The manufacturer-specific bytes of the communication EMCYs in the EMCY tables of the Trinamic
/// and Harmonic Drive manuals (the same firmware family: byte 2 is FFh), plus one code of the
/// drive's own.
pub(crate) const fn communication_emcy_bytes(own: (u16, [u8; 5])) -> [(u16, [u8; 5]); 9] {
    const FF: [u8; 5] = [0, 255, 0, 0, 0];
    [
        own,
        (0x6320, FF),
        (0x8100, FF),
        (0x8110, [1, 255, 0, 0, 0]),
        (0x8120, FF),
        (0x8130, FF),
        (0x8140, FF),
        (0x8210, FF),
        (0x8220, FF),
    ]
}

/// The bit rate (kbit/s) a vendor object stored for the next start, from the LSS file of
/// `--storage`; `None` without one.
pub(crate) fn stored_bit_rate(env: &Environment<'_>) -> Option<u16> {
    env.lss_file.and_then(crate::lss_store::load_bit_rate)
}

/// A drive without manufacturer behaviour.
#[derive(Debug, Default)]
pub struct NoFirmware;

impl Firmware for NoFirmware {}

/// The node-ID in a profile's configuration template: [`BoardProfile::config`] replaces it with
/// the one the program runs at.
pub const TEMPLATE_NODE_ID: u8 = 1;

/// Everything that makes this program one drive or another.
#[derive(Clone, Copy)]
pub struct BoardProfile {
    /// Which profile.
    pub name: ProfileName,
    /// The core's configuration of this drive (identity, tables, overrides, departures from
    /// CiA 301/402; what a profile leaves out is `Config::new`'s); its node-ID is replaced by
    /// the one the program runs at ([`BoardProfile::config`]).
    pub config: Config,
    /// The facts of the EDS's `[FileInfo]` (`[DeviceInfo]` comes from the drive).
    pub eds: EdsInfo,
    /// Index of the first simulation object ([`crate::board_objects`]).
    pub simulation: u16,
    /// Value rules of the manufacturer objects (signatures, value lists).
    pub rules: &'static [ValueRule],
    /// The simulated axis.
    pub axis: MotorParams,
    /// The firmware behaviour.
    pub firmware: fn() -> Box<dyn Firmware>,
    /// The axes of the node (`--axes`, [`crate::axes`]): 1 but for the generic drive.
    pub axes: u8,
}

impl BoardProfile {
    /// The profile `name`.
    pub fn of(name: ProfileName) -> Self {
        match name {
            ProfileName::Generic => generic::profile(),
            ProfileName::Chieftek => chieftek::profile(),
            ProfileName::TrinamicPd57 => trinamic::profile(),
            ProfileName::HarmonicDrive => harmonic::profile(),
        }
    }

    /// The core's configuration of this drive at `node_id`.
    pub fn config(&self, node_id: u8) -> Config {
        Config { node_id, ..self.config }
    }

    /// The object hooks of this drive; `storage`: parameters are kept.
    pub fn hooks(&self, storage: bool) -> BoardHooks {
        BoardHooks::new(self.simulation, self.rules, storage).with_axes(self.axes)
    }

    /// This drive as a node of `axes` axes ([`crate::axes`]): 4 + 4 PDOs and the simulation
    /// objects per axis.
    pub fn with_axes(self, axes: u8) -> BoardProfile {
        if axes <= 1 {
            // One axis: the profile's own tables.
            return self;
        }
        let mut profile = self;
        profile.axes = axes;
        profile.config.pdo_objects = crate::axes::pdo_objects(axes);
        profile.config.manufacturer_objects =
            crate::axes::manufacturer_objects(self.config.manufacturer_objects, self.simulation, axes);
        profile
    }
}

// --- Building blocks of the tables -------------------------------------------------------

/// A read-write entry of `data_type`.
pub(crate) const fn rw(name: &'static str, data_type: DataType) -> Var {
    Var::new(name, data_type).access(Access::ReadWrite)
}

/// A read-only entry of `data_type` (the device may change it).
pub(crate) const fn ro(name: &'static str, data_type: DataType) -> Var {
    Var::new(name, data_type).access(Access::ReadOnly)
}

/// A VAR object named like its entry.
pub(crate) const fn var(index: u16, var: Var) -> Object {
    Object::var(index, var.name(), var)
}

/// An unsigned default.
pub(crate) const fn u(value: u64) -> DefaultValue {
    DefaultValue::Unsigned(value)
}

/// A signed default.
pub(crate) const fn s(value: i64) -> DefaultValue {
    DefaultValue::Signed(value)
}

/// Sub-index 0 of a RECORD or ARRAY: the highest sub-index, read-only.
pub(crate) const fn highest(name: &'static str, n: u64) -> (u8, Var) {
    (0, Var::new(name, DataType::Unsigned8).access(Access::Const).default(DefaultValue::Unsigned(n)))
}

/// An override of a standard entry's default.
pub(crate) const fn default_of(index: u16, sub: u8, value: DefaultValue) -> DefaultOverride {
    DefaultOverride { index, sub, value }
}

/// The core's description of a CiA 402 entry, to be changed into the drive's own.
pub(crate) const fn profile_entry(index: u16, sub: u8) -> EntryOverride {
    EntryOverride::of(&canopen_drive::cia402::registry::PROFILE, index, sub)
}

/// The core's description of a communication entry (1000h–1FFFh), to be changed into the
/// drive's own.
pub(crate) const fn communication_entry(index: u16, sub: u8) -> EntryOverride {
    EntryOverride::of(&canopen_drive::od::standard::COMMUNICATION, index, sub)
}

/// The value of a fixed-size entry as a number (0 when it cannot be read).
pub(crate) fn value_of(od: &BoardDictionary, index: u16, sub: u8) -> u64 {
    let Ok(entry) = od.entry(index, sub) else { return 0 };
    let mut raw = [0u8; 8];
    let n = od.read(&entry, 0, &mut raw);
    raw.iter().take(n).rev().fold(0u64, |acc, b| (acc << 8) | u64::from(*b))
}

/// CiA 305 bit-timing table 0 index of a bit rate in kbit/s.
pub(crate) fn bit_timing_index(kbit: u64) -> Option<u8> {
    [1000, 800, 500, 250, 125, 100, 50, 20, 10]
        .iter()
        .position(|&r| r == kbit)
        .and_then(|i| u8::try_from(i).ok())
}

/// The bit rate in kbit/s of a CiA 305 table 0 index.
pub(crate) fn bit_rate_of(index: u8) -> Option<u16> {
    [1000, 800, 500, 250, 125, 100, 50, 20, 10].get(usize::from(index)).copied()
}

// --- PDO records of the vendor drives: 4 + 4 PDOs, at most three mapping entries ---------------

/// An RPDO communication record (subs 0–2): COB-ID `cob_id` + node-ID, transmission type.
pub(crate) const fn rpdo_communication(cob_id: u32, transmission: u64) -> [(u8, Var); 3] {
    [
        highest("Largest sub-index supported", 2),
        (1, rw("COB-ID used by PDO", DataType::Unsigned32).default(DefaultValue::NodeIdPlus(cob_id))),
        (2, rw("Transmission type", DataType::Unsigned8).default(DefaultValue::Unsigned(transmission))),
    ]
}

/// A TPDO communication record (subs 0–5): COB-ID `cob_id` + node-ID, transmission type.
pub(crate) const fn tpdo_communication(cob_id: u32, transmission: u64) -> [(u8, Var); 6] {
    [
        highest("Largest sub-index supported", 5),
        (1, rw("COB-ID", DataType::Unsigned32).default(DefaultValue::NodeIdPlus(cob_id))),
        (2, rw("Transmission type", DataType::Unsigned8).default(DefaultValue::Unsigned(transmission))),
        (3, rw("Inhibit time", DataType::Unsigned16)),
        (4, ro("Compatibility entry", DataType::Unsigned8)),
        (5, rw("Event timer", DataType::Unsigned16)),
    ]
}

/// A mapping record of at most three entries, `first` and `second` (0: none) by default.
pub(crate) const fn pdo_mapping(first: u32, second: u32) -> [(u8, Var); 4] {
    let count = if second != 0 { 2 } else { 1 };
    [
        (
            0,
            rw("Number of mapped application objects in PDO", DataType::Unsigned8)
                .limits_unsigned(0, 3)
                .default(DefaultValue::Unsigned(count)),
        ),
        (1, rw("Mapping entry 1", DataType::Unsigned32).default(DefaultValue::Unsigned(first as u64))),
        (2, rw("Mapping entry 2", DataType::Unsigned32).default(DefaultValue::Unsigned(second as u64))),
        (3, rw("Mapping entry 3", DataType::Unsigned32)),
    ]
}

/// The CiA 402 pre-defined mapping of PDOs 1–4 in three-entry mapping records (RPDOs:
/// controlword, then mode / pp target / pv target; TPDOs: statusword, then the displays).
pub(crate) static CIA402_RPDO_MAPPING: [[(u8, Var); 4]; 4] = [
    pdo_mapping(0x6040_0010, 0),
    pdo_mapping(0x6040_0010, 0x6060_0008),
    pdo_mapping(0x6040_0010, 0x607A_0020),
    pdo_mapping(0x6040_0010, 0x60FF_0020),
];
/// See [`CIA402_RPDO_MAPPING`].
pub(crate) static CIA402_TPDO_MAPPING: [[(u8, Var); 4]; 4] = [
    pdo_mapping(0x6041_0010, 0),
    pdo_mapping(0x6041_0010, 0x6061_0008),
    pdo_mapping(0x6041_0010, 0x6064_0020),
    pdo_mapping(0x6041_0010, 0x606C_0020),
];

/// The PDO records 1400h–1403h, 1600h–1603h, 1800h–1803h and 1A00h–1A03h (lay them out with
/// [`canopen_drive::od::layout`]).
pub(crate) const fn pdo_records(
    rpdo_communication: &'static [[(u8, Var); 3]; 4],
    rpdo_mapping: &'static [[(u8, Var); 4]; 4],
    tpdo_communication: &'static [[(u8, Var); 6]; 4],
    tpdo_mapping: &'static [[(u8, Var); 4]; 4],
) -> [Object; 16] {
    let [rc0, rc1, rc2, rc3] = rpdo_communication;
    let [rm0, rm1, rm2, rm3] = rpdo_mapping;
    let [tc0, tc1, tc2, tc3] = tpdo_communication;
    let [tm0, tm1, tm2, tm3] = tpdo_mapping;
    [
        Object::record(0x1400, "RPDO communication parameter", rc0).numbered(1),
        Object::record(0x1401, "RPDO communication parameter", rc1).numbered(2),
        Object::record(0x1402, "RPDO communication parameter", rc2).numbered(3),
        Object::record(0x1403, "RPDO communication parameter", rc3).numbered(4),
        Object::record(0x1600, "RPDO mapping parameter", rm0).numbered(1),
        Object::record(0x1601, "RPDO mapping parameter", rm1).numbered(2),
        Object::record(0x1602, "RPDO mapping parameter", rm2).numbered(3),
        Object::record(0x1603, "RPDO mapping parameter", rm3).numbered(4),
        Object::record(0x1800, "TPDO communication parameter", tc0).numbered(1),
        Object::record(0x1801, "TPDO communication parameter", tc1).numbered(2),
        Object::record(0x1802, "TPDO communication parameter", tc2).numbered(3),
        Object::record(0x1803, "TPDO communication parameter", tc3).numbered(4),
        Object::record(0x1A00, "TPDO mapping parameter", tm0).numbered(1),
        Object::record(0x1A01, "TPDO mapping parameter", tm1).numbered(2),
        Object::record(0x1A02, "TPDO mapping parameter", tm2).numbered(3),
        Object::record(0x1A03, "TPDO mapping parameter", tm3).numbered(4),
    ]
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use canopen_drive::Drive;

    #[test]
    fn names_round_trip_and_every_profile_builds_a_drive() {
        for name in ProfileName::ALL {
            assert_eq!(ProfileName::parse(name.name()), Some(name));
            let profile = BoardProfile::of(name);
            assert_eq!(profile.name, name);
            let drive = Drive::<BoardHooks, OD_BYTES, 4, 4>::create(profile.config(5), profile.hooks(false));
            let drive = drive.unwrap_or_else(|e| panic!("{}: {e:?}", name.name()));
            assert!(drive.od().used_bytes() <= OD_BYTES);
        }
        assert_eq!(ProfileName::parse("other"), None);
    }

    #[test]
    fn bit_rates_of_cia_305_table_0() {
        assert_eq!(bit_timing_index(1000), Some(0));
        assert_eq!(bit_timing_index(125), Some(4));
        assert_eq!(bit_timing_index(20), Some(7));
        assert_eq!(bit_timing_index(42), None);
        assert_eq!(bit_rate_of(2), Some(500));
        assert_eq!(bit_rate_of(9), None);
    }
}
