//! [`Drive`]: the object dictionary and every service composed behind the two entry points.
//!
//! ## Who owns an object
//!
//! The drive is a composer: it routes frames by identifier (a receive filter turns other nodes'
//! traffic away in O(1)), runs the timers and calls the tick. The rules and reactions of the
//! objects live with the services that implement them, registered by index in one place
//! ([`Owner`]): SYNC checks and reacts to 1005h/1006h/1019h
//! (`comm::sync`), the EMCY producer to 1014h/1015h and the error history to 1003h
//! (`comm::emcy`), the heartbeat and guarding objects and 1029h (`comm::error_control`), the
//! PDO records (`comm::pdo`), 1010h/1011h (`storage`), and the profile area with the cascade's
//! record (`cia402`: [`Rule`]). The registration follows the
//! index, not the table that describes it: a firmware's own PDO records keep the PDO rules. A
//! firmware's object that a service of the crate should rule carries the service in
//! [`Object::owner`](crate::od::Object::owner); its own objects it checks with
//! [`ObjectHooks`].
//!
//! A new abort condition of a communication object is one change in its service's
//! `check_write`; an RPDO entry's rule is decided once, when its mapping is validated, so
//! process data pays only for the values that have a rule.
//!
//! ## Choosing the drive type
//!
//! [`Drive`] has six generic parameters, all with defaults; the aliases name the usual shapes,
//! and [`Drive::build`] (or [`Drive::build_in`]) constructs any of them:
//!
//! | shape | type |
//! |---|---|
//! | one axis, 4 + 4 PDOs, no parameter storage | [`Drive`] (`Drive<MyHooks>` with hooks) |
//! | the same with 1010h/1011h storage `S` | [`StoredDrive<S, H, OD_BYTES>`](StoredDrive) |
//! | `RPDOS` + `TPDOS` PDOs (e.g. 8 + 8), storage optional | [`PdoDrive<RPDOS, TPDOS, S, H, OD_BYTES>`](PdoDrive) |
//! | several CiA 402 axes on one node | [`MultiAxisDrive<AXES, RPDOS, TPDOS, S, H, OD_BYTES>`](MultiAxisDrive) |
//!
//! `OD_BYTES` is best sized to the tables at compile time:
//! `STANDARD_OD_BYTES + od::storage_bytes(&[&VENDOR])` for one axis and 4 + 4 PDOs
//! ([`STANDARD_OD_BYTES`], [`od::storage_bytes`](crate::od::storage_bytes)); with other PDO
//! counts or axes, `od::storage_bytes` of every table the drive links (the communication
//! objects, the PDO table, the profile per axis). A store that is too small is refused by the
//! constructor with the size it needs ([`ConfigError::StorageTooSmall`]).
//!
//! ## Concurrency
//!
//! `Drive` is a plain value with `&mut self` entry points. Firmware that calls `tick` from a
//! high-priority interrupt and `on_frame`/`poll` from a lower one shares it behind a lock.
//! On an MCU the drive is built in place in a `static` ([`Drive::build_in`], e.g. into a
//! `static_cell::StaticCell`), because a drive built by value and moved costs several copies of
//! itself on the stack; what the lock holds is then the `&'static mut Drive` that `build_in`
//! returns:
//!
//! ```ignore
//! static DRIVE_CELL: StaticCell<FirmwareDrive> = StaticCell::new();
//! static DRIVE: Mutex<RefCell<Option<&'static mut FirmwareDrive>>> = Mutex::new(RefCell::new(None));
//! // main, once: build in place, then hand the reference to the lock.
//! let drive = FirmwareDrive::build_in(DRIVE_CELL.uninit(), config, hooks, storage)?;
//! critical_section::with(|cs| DRIVE.borrow_ref_mut(cs).replace(drive));
//! // tick interrupt and communication context alike:
//! critical_section::with(|cs| DRIVE.borrow_ref_mut(cs).as_mut().map(|d| d.tick(now, &sample)));
//! ```
//!
//! (`critical_section::Mutex`; `examples/firmware` is a whole `no_std` firmware built this
//! way.) With embassy, `canopen-drive-embassy`'s `SharedDrive` holds the same reference, and
//! its priority-ceiling lock leaves the interrupts above the tick (a current loop) unmasked.
//! Every entry point does bounded work, so the time the tick can be held off is bounded by the
//! longest single call (one frame, or one poll of at most [`TX_QUEUE`] frames).

use core::fmt;
use core::mem::MaybeUninit;

use heapless::Deque;

use crate::cia402::cyclic::CycleStart;
use crate::cia402::fsa::State;
use crate::cia402::objects::STANDARD_MODES;
use crate::cia402::objects::{Axis, Rule, PROFILE_AREA};
use crate::cia402::profile::Profile;
use crate::cia402::registry::IMPLEMENTED_MODES;
use crate::cia402::ProfileConfig;
use crate::comm::emcy::{self, code, EmcyProducer, EmcySettings, ErrorRegister};
use crate::comm::error_control::{
    check_consumer_write, guarding_configured, life_time_ms, ConsumerEvent, ErrorBehaviour, GuardingEvent,
    HeartbeatConsumer, NodeGuarding,
};
use crate::comm::heartbeat::{HeartbeatProducer, PeriodSlot};
use crate::comm::indicators::NodeStatus;
use crate::comm::lss::{LssHooks, LssSlave, LssState, StoreError, DEFAULT_BIT_RATES};
use crate::comm::nmt::{transition, NmtAction, Services};
use crate::comm::pdo::{self, FrameSink, PdoEvent, PdoRecord, PdoSet, RpdoFrame, ValueRules};
use crate::comm::program::{self, ProgramRequest, RunningProgram, PROGRAM_DATA};
use crate::comm::sdo_server::{self, upload_in_two_steps, ObjectAccess, SdoServer};
use crate::comm::sync::{self, Sync, SyncConfig, SyncPoll, SyncReception, SyncSlots};
use crate::frame::CanFrame;
use crate::hal::{Demand, Sample};
use crate::od::eds::{self, Capabilities, EdsInfo};
use crate::od::standard::{self, HEARTBEAT_CONSUMERS};
use crate::od::xdd;
use crate::od::{
    le_u32, AbortCode, ConfigError, DefaultOverride, DeviceInfo, Dictionary, Entry, EntryOverride,
    FirstLevel, Object, ObjectHooks, Owner,
};
use crate::storage::{Group, Persistence, SAVE_SIGNATURE};
use crate::time::{earliest, Duration, Instant};
use crate::wire::lss::{
    BitRate, BitTiming, LssAddress, LSS_REQUEST_COB_ID, LSS_RESPONSE_COB_ID, NODE_ID_UNCONFIGURED,
};
use crate::wire::nmt::{NmtState, NodeControl};
use crate::wire::sdo::Mux;
use crate::wire::{ERROR_CONTROL_BASE, NMT_COB_ID, SDO_RX_BASE, SDO_TX_BASE};

/// Heartbeats of nodes 1..=127.
const ERROR_CONTROL_FIRST: u16 = ERROR_CONTROL_BASE + 1;
const ERROR_CONTROL_LAST: u16 = ERROR_CONTROL_BASE + 127;

/// PDO events one frame or tick may report (two length errors and the reactions to up to two
/// RPDOs' worth of values).
const PDO_EVENTS: usize = 18;
/// Frames the drive can hold for transmission until [`Drive::pop_tx`] drains them.
pub const TX_QUEUE: usize = 16;
/// Bytes the SDO server can stage for one download.
pub const SDO_BUFFER: usize = 256;
/// Default size of the dictionary's value store in bytes: room for the standard objects
/// ([`STANDARD_OD_BYTES`]) and some 2 KiB of the firmware's own.
pub const DEFAULT_OD_BYTES: usize = 3072;
/// The value store the standard tables take in this build (communication objects, the default
/// 4 + 4 PDO records, the CiA 402 objects of the modes built): the dictionary size of a drive
/// without manufacturer objects. A firmware with its own tables adds theirs
/// ([`od::storage_bytes`](crate::od::storage_bytes)).
pub const STANDARD_OD_BYTES: usize = crate::od::storage_bytes(&[
    &standard::COMMUNICATION,
    &pdo::DEFAULT_OBJECTS,
    &crate::cia402::registry::PROFILE,
]);

/// The value store one more axis takes (its profile objects, [`Dictionary::attach_copies`]): a
/// node of `n` axes sizes its dictionary `STANDARD_OD_BYTES + (n − 1) × AXIS_OD_BYTES` (plus its
/// own objects, and the larger PDO tables of 4 + 4 PDOs per axis).
pub const AXIS_OD_BYTES: usize = crate::od::storage_bytes(&[&crate::cia402::registry::AXIS_PROFILE]);

pub use crate::comm::ConnectionEvent;

/// State of the CAN controller, as the board reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CanState {
    /// Error active: everything normal (also: recovered).
    ErrorActive,
    /// Error active, but a receive or transmit error counter reached the warning limit (96):
    /// no EMCY; the ERR indicator's single flash while it lasts (CiA 303-3).
    WarningLimit,
    /// Error passive (EMCY 0x8120 while it lasts; the ERR indicator's single flash too).
    ErrorPassive,
    /// Bus-off: the node cannot send (EMCY 0x8140 after recovery, 1029h reaction).
    BusOff,
    /// Frames were lost in the controller (EMCY 0x8110).
    Overrun,
}

/// A bit-rate change the LSS master asked for (activate bit timing): the board switches its
/// CAN controller after `switch_delay_ms`, stays silent for another `switch_delay_ms`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BitRateChange {
    /// The new bit timing (table 0: the CiA 305 standard rates).
    pub bit_timing: BitTiming,
    /// The switch delay in ms.
    pub switch_delay_ms: u16,
}

/// Start-up configuration of a drive.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Node-ID, 1..=127, or 0xFF: not configured (the node only runs LSS until a master gives
    /// it a node-ID).
    pub node_id: u8,
    /// Identity and names (1000h, 1008h–100Ah, 1018h, the EDS of 1021h).
    pub device: DeviceInfo,
    /// Time without a frame after which an SDO transfer is aborted (0x0504_0000).
    pub sdo_timeout: Duration,
    /// Whether the SDO server offers block transfers (default true; CiA 301 makes them
    /// optional, and a drive documented without them answers their initiation with abort
    /// 0x0504_0001).
    pub sdo_block_transfer: bool,
    /// The firmware's own objects (2000h–5FFFh), laid out with [`crate::od::layout`]; a
    /// hand-written table and one generated from an EDS are joined into this one table with
    /// [`crate::od::join`]. The constructors refuse an object outside 2000h–5FFFh and every
    /// other fault [`crate::od::check_manufacturer_table`] finds (which a firmware can also run
    /// when the table is compiled).
    pub manufacturer_objects: &'static [Object],
    /// What an RPDO longer than its mapping does (default: applied, EMCY 0x8220).
    pub long_rpdo: pdo::LongRpdo,
    /// The unit of the TPDO inhibit times (sub 3 of 1800h…): [`pdo::INHIBIT_UNIT`] (100 µs, CiA
    /// 301) by default; a drive documented with another unit (e.g. 1 ms) sets it here.
    pub tpdo_inhibit_unit: Duration,
    /// The parameter groups of 1010h/1011h the drive stores and restores (default all four).
    /// The others read 0 ("cannot store") and refuse the signature with 0x0800_0020.
    pub store_groups: &'static [Group],
    /// The board can make an LSS "store configuration" persistent (see
    /// [`Drive::take_lss_store`]); otherwise the request is answered "not supported".
    pub lss_store: bool,
    /// The bit rates of the standard table (CiA 305 table 0) the board's CAN controller runs
    /// at (default 125, 250, 500 and 1000 kbit/s, [`DEFAULT_BIT_RATES`]): the LSS slave accepts
    /// these in "configure bit timing" (and refuses the others with error 1, "bit rate not
    /// supported"), and the EDS and XDD list them (`BaudRate_n`). A board whose CAN clock does
    /// not divide into a rate leaves it out.
    pub bit_rates: &'static [BitRate],
    /// The PDO records (1400h–1BFFh): [`pdo::DEFAULT_OBJECTS`] for 4 + 4, or a table made by
    /// [`pdo::objects`] matching the drive's PDO capacity.
    pub pdo_objects: &'static [Object],
    /// The drive profile: tick rate, supported option codes, set-point buffer, … (the modes are
    /// [`DeviceInfo::drive_modes`]).
    pub profile: ProfileConfig,
    /// The firmware's own power-on values of entries of the crate's tables (default: none, the
    /// CiA defaults). They are the values after power-on and restore defaults, and the EDS's.
    pub default_overrides: &'static [DefaultOverride],
    /// The firmware's own descriptions of entries of the crate's tables: another data type of
    /// the same size, access, PDO mappability, limits or default where the drive's
    /// documentation departs from CiA 301/402 (default: none, the standard descriptions). An
    /// override that changes an entry's size is refused ([`ConfigError::EntrySize`]).
    pub entry_overrides: &'static [EntryOverride],
    /// Objects of the device-profile area beyond the crate's (indices above those of
    /// [`crate::cia402::registry::PROFILE`], ascending, laid out with [`crate::od::layout`]),
    /// e.g. objects of a later edition of CiA 402 (default: none). A second axis is not
    /// described here: it is an axis of a [`MultiAxisDrive`].
    pub extra_profile_objects: &'static [Object],
    /// What each value of 1029h sub 1 means (default [`ErrorBehaviour::CIA_301`]: 0
    /// Pre-operational, 1 no change, 2 Stopped); other values below 80h are refused.
    pub error_behaviour_values: &'static [(u8, ErrorBehaviour)],
    /// Standard objects of the crate's tables this drive does not have (default none): the
    /// bus gets 0x0602_0000 for them, PDOs cannot map them and the EDS leaves them out; the
    /// behaviour they carry keeps their defaults ([`crate::od::Dictionary::set_absent`]).
    pub absent_objects: &'static [u16],
    /// The manufacturer-specific field (bytes 3–7) of the EMCYs of these error codes, as the
    /// drive's documentation gives them (default none: the crate's, zero but for the
    /// node-ID of a heartbeat timeout, the PDO number of an RPDO timeout and the limit of a
    /// travel-limit EMCY). The codes are the reported ones
    /// ([`crate::cia402::ProfileConfig::error_codes`]).
    pub emcy_additional_bytes: &'static [(u16, [u8; 5])],
    /// The program download objects of the running application (CiA 302-3: 1F50h, 1F51h,
    /// 1F56h, 1F57h, [`crate::comm::program`]), for a drive whose board has a bootloader that
    /// takes a new program (default false: no such objects). 1F51h reads 1 (started); stop and
    /// reset are requests for the board ([`Drive::take_program_request`]); clear and a download
    /// are refused (0800 0022h), as they are the bootloader's.
    pub program_download: bool,
}

impl Config {
    /// A CiA 402 servo drive at `node_id` with the standard defaults.
    pub const fn new(node_id: u8) -> Self {
        Config {
            node_id,
            device: DeviceInfo::servo_drive(),
            sdo_timeout: Duration::from_millis(1000),
            sdo_block_transfer: true,
            manufacturer_objects: &[],
            lss_store: false,
            bit_rates: &DEFAULT_BIT_RATES,
            long_rpdo: pdo::LongRpdo::ApplyAndReport,
            tpdo_inhibit_unit: pdo::INHIBIT_UNIT,
            store_groups: &Group::ALL,
            pdo_objects: &pdo::DEFAULT_OBJECTS,
            profile: ProfileConfig::new(),
            default_overrides: &[],
            entry_overrides: &[],
            extra_profile_objects: &[],
            error_behaviour_values: &ErrorBehaviour::CIA_301,
            absent_objects: &[],
            emcy_additional_bytes: &[],
            program_download: false,
        }
    }
}

/// The communication entries read on every frame or poll, resolved once by their services (a
/// look-up each would cost more than the rest of a frame's handling).
struct CommSlots {
    sync: SyncSlots,
    heartbeat: PeriodSlot,
}

impl CommSlots {
    /// Slots that look their entries up (before the dictionary has its tables).
    const LOOKUP: CommSlots = CommSlots { sync: SyncSlots::LOOKUP, heartbeat: PeriodSlot::LOOKUP };

    fn resolve<const B: usize>(od: &Dictionary<B>) -> Self {
        CommSlots { sync: SyncSlots::resolve(od), heartbeat: PeriodSlot::resolve(od) }
    }
}

/// A drive of one axis and 4 + 4 PDOs whose parameters (1010h/1011h) are kept in `S` (e.g. a
/// [`Storage`](crate::storage::Storage) over the board's flash): the type
/// [`Drive::with_storage`] returns, with any value store size.
pub type StoredDrive<S, H = (), const OD_BYTES: usize = DEFAULT_OD_BYTES> = Drive<H, OD_BYTES, 4, 4, S>;

/// A drive of one axis with `RPDOS` + `TPDOS` PDOs ([`Config::pdo_objects`] a table of
/// [`pdo::objects`] with as many), parameter storage `S` (none by default).
pub type PdoDrive<
    const RPDOS: usize,
    const TPDOS: usize,
    S = (),
    H = (),
    const OD_BYTES: usize = DEFAULT_OD_BYTES,
> = Drive<H, OD_BYTES, RPDOS, TPDOS, S>;

/// A node of `AXES` CiA 402 axes (2–8; axis n's objects at 6000h + n × 800h) with `RPDOS` +
/// `TPDOS` PDOs, ticked by [`Drive::tick_axes`].
pub type MultiAxisDrive<
    const AXES: usize,
    const RPDOS: usize,
    const TPDOS: usize,
    S = (),
    H = (),
    const OD_BYTES: usize = DEFAULT_OD_BYTES,
> = Drive<H, OD_BYTES, RPDOS, TPDOS, S, AXES>;

/// A CANopen CiA 402 drive: dictionary, NMT slave, SDO server, PDOs, SYNC, EMCY, error control.
///
/// `H` are the firmware's object hooks; `OD_BYTES` the size of the value store; `RPDOS` and
/// `TPDOS` the PDO capacity (the PDO table in [`Config::pdo_objects`] must match it); `S` the
/// parameter storage; `AXES` the CiA 402 logical devices of the node (1–8, see
/// [`Drive::tick_axes`]).
pub struct Drive<
    H: ObjectHooks = (),
    const OD_BYTES: usize = DEFAULT_OD_BYTES,
    const RPDOS: usize = 4,
    const TPDOS: usize = 4,
    S: Persistence = (),
    const AXES: usize = 1,
> {
    od: Dictionary<OD_BYTES>,
    /// The communication entries every frame or poll reads, resolved once.
    slots: CommSlots,
    /// The identifiers this node receives.
    receive: ReceiveFilter,
    /// [`Drive::sync_config`] as last read ([`Drive::refresh`]).
    sync_settings: (SyncConfig, u16),
    /// 1014h/1015h as last read ([`Drive::refresh`]).
    emcy_settings: EmcySettings,
    /// The dictionary may have changed behind the drive's back ([`Drive::od_mut`]): refresh
    /// before the next frame or poll.
    stale: bool,
    sdo: SdoServer<SDO_BUFFER>,
    nmt: NmtState,
    heartbeat: HeartbeatProducer,
    emcy: EmcyProducer,
    heartbeat_consumer: HeartbeatConsumer<{ HEARTBEAT_CONSUMERS as usize }>,
    guarding: NodeGuarding,
    bus_off: bool,
    /// [`CanState::WarningLimit`] or [`CanState::ErrorPassive`] reported last.
    warning_limit: bool,
    connection_event: Option<ConnectionEvent>,
    sync: Sync,
    /// What the tick learns about the SYNC cycle (cyclic modes).
    cycle: CycleFlags,
    pdos: PdoSet<RPDOS, TPDOS>,
    lss: LssSlave,
    lss_requests: LssRequests,
    /// The drive profile of each axis: axis n runs the objects at 6000h + n × 800h.
    axes: [Profile; AXES],
    /// The meaning of 1029h's values ([`Config::error_behaviour_values`]).
    error_behaviour: &'static [(u8, ErrorBehaviour)],
    /// [`Config::store_groups`].
    store_groups: &'static [Group],
    /// [`Config::emcy_additional_bytes`].
    emcy_bytes: &'static [(u16, [u8; 5])],
    /// PDO mappings may be changed while the PDO is valid ([`Drive::set_remap_while_valid`]).
    remap_while_valid: bool,
    tx: TxQueue,
    /// Program download (CiA 302-3), the application's side ([`Config::program_download`]).
    program: RunningProgram,
    hooks: H,
    storage: S,
}

/// Whether the drive stores and restores `group` on command (1010h/1011h): it has storage, and
/// the group is one of [`Config::store_groups`]. The command objects read it, the EDS states it.
fn stores(storage: &impl Persistence, groups: &[Group], group: Group) -> bool {
    storage.available() && groups.contains(&group)
}

/// The service that owns `object`: the one that declares its index (the CiA 301 communication
/// objects, the PDO records, the profile area and the cascade's record), else the object's own
/// tag ([`Object::owner`]: a firmware's object a service of the crate rules). Each service checks
/// and reacts to its own objects; this is where they are registered.
fn owner<const AXES: usize>(index: u16, object: &Object, axes: &[Profile; AXES]) -> Owner {
    use crate::comm::error_control::{
        guarding_owns, CONSUMER_OBJECT, ERROR_BEHAVIOUR_OBJECT, PRODUCER_OBJECT,
    };
    if profile_axis::<AXES>(index).is_some()
        || axes.first().is_some_and(|p| p.config().cascade == Some(index))
    {
        return Owner::Profile;
    }
    match index {
        _ if sync::owns(index) => Owner::Sync,
        _ if emcy::owns(index) => Owner::Emcy,
        emcy::HISTORY => Owner::ErrorHistory,
        ERROR_BEHAVIOUR_OBJECT => Owner::ErrorBehaviour,
        CONSUMER_OBJECT => Owner::HeartbeatConsumer,
        PRODUCER_OBJECT => Owner::HeartbeatProducer,
        _ if guarding_owns(index) => Owner::Guarding,
        _ if crate::storage::owns(index) => Owner::Storage,
        _ if program::owns(index) => Owner::Program,
        _ if PdoRecord::of(index).is_some() => Owner::Pdo,
        _ => object.owner,
    }
}

/// A filter of received identifiers by their low seven bits (the node-ID part of the
/// pre-defined connection set): a frame whose bit is clear is for no service of this node, and is
/// turned away in O(1). One that passes is routed by the services' own identifiers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct ReceiveFilter([u32; 4]);

impl ReceiveFilter {
    /// An unconfigured node: LSS only.
    const LSS_ONLY: ReceiveFilter = {
        let mut filter = ReceiveFilter([0; 4]);
        filter.add(LSS_REQUEST_COB_ID);
        filter
    };

    // The word index is below 4.
    #[allow(clippy::indexing_slicing)]
    const fn add(&mut self, id: u16) {
        self.0[((id >> 5) & 3) as usize] |= 1 << (id & 31);
    }

    #[inline(always)]
    fn passes(&self, id: u16) -> bool {
        self.0.get(usize::from((id >> 5) & 3)).is_some_and(|word| word & (1 << (id & 31)) != 0)
    }
}

/// The axis whose object `index` is (axis n: 6000h + n × 800h …); the first axis for an
/// object outside the profile areas (the cascade's record, which every axis shares).
#[inline(always)]
fn axis_number<const AXES: usize>(index: u16) -> usize {
    if AXES == 1 {
        return 0;
    }
    profile_axis::<AXES>(index).unwrap_or(0)
}

/// The axis of this node whose profile area holds `index`, if any.
#[inline(always)]
fn profile_axis<const AXES: usize>(index: u16) -> Option<usize> {
    Axis::containing(index).map(|axis| usize::from(axis.number())).filter(|n| *n < AXES)
}

/// The profile of [`axis_number`]'s axis.
#[inline(always)]
fn axis_of<const AXES: usize>(axes: &[Profile; AXES], index: u16) -> Option<&Profile> {
    axes.get(axis_number::<AXES>(index))
}

/// The drive profile's value rules for process data ([`ValueRules`]): an RPDO entry's rule is
/// its axis's profile's [`Rule`] of the object, decided when the mapping is validated.
struct ProcessDataRules<'a, const AXES: usize>(&'a [Profile; AXES]);

impl<const B: usize, const AXES: usize> ValueRules<B> for ProcessDataRules<'_, AXES> {
    fn rule(&self, entry: &Entry) -> u8 {
        let index = entry.index();
        if owner(index, entry.object, self.0) != Owner::Profile {
            return 0;
        }
        match axis_of(self.0, index).and_then(|p| p.rule(index, entry.sub, true)) {
            Some(rule) if rule.reacts() => rule as u8 | <Self as ValueRules<B>>::REACTS,
            Some(rule) => rule as u8,
            None => 0,
        }
    }

    fn check(&self, od: &Dictionary<B>, rule: u8, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (Rule::from_raw(rule & !<Self as ValueRules<B>>::REACTS), axis_of(self.0, index)) {
            (Some(rule), Some(profile)) => profile.check(rule, od, index, sub, data),
            _ => Ok(()),
        }
    }

    fn is_process_data(&self, entry: &Entry) -> bool {
        let index = entry.index();
        owner(index, entry.object, self.0) == Owner::Profile
            && axis_of(self.0, index).is_some_and(|profile| profile.is_process_data(index))
    }
}

/// The SYNC cycle as the tick sees it.
#[derive(Clone, Copy, Debug, Default)]
struct CycleFlags {
    /// A SYNC arrived since the last tick; `fresh`: an RPDO came in the cycle before it.
    sync: Option<bool>,
    /// An RPDO arrived since the last SYNC.
    rpdo_since_sync: bool,
    /// The last tick.
    last_tick: Option<Instant>,
    /// Time from the last tick to the last SYNC.
    phase: Option<Duration>,
}

impl CycleFlags {
    /// The set-point that starts the tick's cycle ([`CycleStart::SetPoint`]: an RPDO since the
    /// last SYNC, taken by this tick; [`CycleStart::Sync`]: none, the SYNC starts it).
    fn take_set_point(&mut self, start: CycleStart) -> bool {
        match start {
            CycleStart::Sync => false,
            CycleStart::SetPoint => core::mem::take(&mut self.rpdo_since_sync),
        }
    }

    /// Whether the next tick would start a cycle on a set-point ([`Self::take_set_point`]
    /// without taking it).
    fn has_set_point(&self, start: CycleStart) -> bool {
        start == CycleStart::SetPoint && self.rpdo_since_sync
    }

    /// A SYNC arrived: the next tick sees it, fresh when an RPDO came in the cycle before it
    /// (taken with [`CycleStart::Sync`]; with [`CycleStart::SetPoint`] the set-point stays
    /// for the tick it starts).
    fn sync_received(&mut self, start: CycleStart) {
        let fresh = match start {
            CycleStart::Sync => core::mem::take(&mut self.rpdo_since_sync),
            CycleStart::SetPoint => self.rpdo_since_sync,
        };
        self.sync = Some(fresh);
    }
}

/// What LSS services asked of the drive during one frame.
#[derive(Clone, Copy, Debug)]
struct LssRequests {
    store_supported: bool,
    /// [`Config::bit_rates`].
    bit_rates: &'static [BitRate],
    start_up: bool,
    bit_rate: Option<BitRateChange>,
    store: Option<(u8, Option<BitTiming>)>,
}

impl LssRequests {
    fn new(config: &Config) -> Self {
        LssRequests {
            store_supported: config.lss_store,
            bit_rates: config.bit_rates,
            start_up: false,
            bit_rate: None,
            store: None,
        }
    }
}

impl LssHooks for LssRequests {
    fn bit_timing_supported(&self, bit_timing: BitTiming) -> bool {
        bit_timing.standard_rate().is_some_and(|rate| self.bit_rates.contains(&rate))
    }

    fn activate_bit_timing(&mut self, bit_timing: BitTiming, switch_delay_ms: u16) {
        self.bit_rate = Some(BitRateChange { bit_timing, switch_delay_ms });
    }

    fn store_configuration(&mut self, node_id: u8, bit_timing: Option<BitTiming>) -> Result<(), StoreError> {
        // Kept for the board (`take_lss_store`): the drive itself has no place for it.
        if !self.store_supported {
            return Err(StoreError::NotSupported);
        }
        self.store = Some((node_id, bit_timing));
        Ok(())
    }

    fn continue_start_up(&mut self, _node_id: u8) {
        self.start_up = true;
    }
}

/// The frames waiting for the CAN controller.
struct TxQueue {
    frames: Deque<CanFrame, TX_QUEUE>,
    dropped: u32,
}

impl TxQueue {
    #[inline]
    fn push(&mut self, frame: Option<CanFrame>) -> bool {
        let Some(frame) = frame else { return false };
        let sent = self.frames.push_back(frame).is_ok();
        if !sent {
            self.dropped = self.dropped.saturating_add(1);
        }
        sent
    }
}

impl FrameSink for TxQueue {
    fn send(&mut self, id: u16, data: &[u8]) -> bool {
        self.push(CanFrame::new_standard(id, data))
    }

    fn send_array(&mut self, id: u16, data: [u8; 8], len: usize) -> bool {
        self.push(CanFrame::from_padded(id, data, len))
    }
}

impl Drive {
    /// A drive without object hooks. It boots (sends its boot-up frame) at the first
    /// [`poll`](Drive::poll) or [`on_frame`](Drive::on_frame).
    pub fn new(config: Config) -> Result<Self, ConfigError> {
        Drive::with_hooks(config, ())
    }
}

impl<H: ObjectHooks> Drive<H> {
    /// A drive whose manufacturer objects are served through `hooks`, with the default value
    /// store of [`DEFAULT_OD_BYTES`].
    pub fn with_hooks(config: Config, hooks: H) -> Result<Self, ConfigError> {
        Drive::create(config, hooks)
    }
}

impl<H: ObjectHooks, S: Persistence> Drive<H, DEFAULT_OD_BYTES, 4, 4, S> {
    /// A drive whose parameters (1010h/1011h) are kept in `storage`, e.g. a
    /// [`Storage`](crate::storage::Storage) over the board's flash. The stored set is loaded
    /// here, as at every power-on.
    pub fn with_storage(config: Config, hooks: H, storage: S) -> Result<Self, ConfigError> {
        Drive::build(config, hooks, storage)
    }
}

impl<H: ObjectHooks, const OD_BYTES: usize, const RPDOS: usize, const TPDOS: usize>
    Drive<H, OD_BYTES, RPDOS, TPDOS>
{
    /// A drive with a value store of `OD_BYTES` bytes and `RPDOS` + `TPDOS` PDOs, without
    /// parameter storage: `Drive::<MyHooks, 8192, 8, 8>::create(config, hooks)` (with a matching
    /// [`Config::pdo_objects`] table).
    pub fn create(config: Config, hooks: H) -> Result<Self, ConfigError> {
        Drive::build(config, hooks, ())
    }
}

impl<H: ObjectHooks, const OD_BYTES: usize, const RPDOS: usize, const TPDOS: usize, S: Persistence>
    Drive<H, OD_BYTES, RPDOS, TPDOS, S>
{
    /// The control-loop tick: applies the RPDOs latched at the last SYNC, runs the drive profile
    /// (state machine, mode, stops, statusword, actual values) and stages event-driven TPDOs
    /// whose values changed. Returns what the power stage must do until the next tick. (A node
    /// of several axes ticks them together: [`Drive::tick_axes`].)
    #[inline]
    pub fn tick(&mut self, now: Instant, sample: &Sample) -> Demand {
        let [demand] = self.tick_axes(now, core::array::from_ref(sample));
        demand
    }
}

impl<
        H: ObjectHooks,
        const OD_BYTES: usize,
        const RPDOS: usize,
        const TPDOS: usize,
        S: Persistence,
        const AXES: usize,
    > Drive<H, OD_BYTES, RPDOS, TPDOS, S, AXES>
{
    /// The general constructor: any value store size, PDO capacity, storage and number of axes
    /// (1–8; e.g. `Drive::<H, 6144, 8, 8, (), 2>::build(config, hooks, ())` for two axes with
    /// PDOs 1–4 for the first and 5–8 for the second, [`crate::od::standard::pdo_preset`]).
    pub fn build(config: Config, hooks: H, storage: S) -> Result<Self, ConfigError> {
        Self::check(&config)?;
        let mut drive = Self::unconfigured(&config, hooks, storage);
        drive.configure(&config)?;
        Ok(drive)
    }

    /// [`build`](Self::build), in place: the drive is built inside `slot` (a `static` on a
    /// board, e.g. `StaticCell::uninit()`) and never moved, so that building it takes about
    /// as much stack as one of its parts rather than several copies of the whole drive.
    /// On an error `slot` stays unusable (it may have been written).
    pub fn build_in(
        slot: &mut MaybeUninit<Self>,
        config: Config,
        hooks: H,
        storage: S,
    ) -> Result<&mut Self, ConfigError> {
        Self::check(&config)?;
        let drive = Self::unconfigured_in(slot, &config, hooks, storage);
        drive.configure(&config)?;
        Ok(drive)
    }

    /// The checks of the configuration that need no dictionary.
    fn check(config: &Config) -> Result<(), ConfigError> {
        if AXES == 0 || AXES > usize::from(Axis::MAX) {
            return Err(ConfigError::BadCopies { index: *PROFILE_AREA.start() });
        }
        if !(1..=127).contains(&config.node_id) && config.node_id != NODE_ID_UNCONFIGURED {
            return Err(ConfigError::InvalidNodeId);
        }
        let table = pdo::count(config.pdo_objects);
        if table != (RPDOS, TPDOS) {
            return Err(ConfigError::PdoCount { drive: (RPDOS, TPDOS), table });
        }
        // The firmware's tables (the crate's own are checked by its tests).
        crate::od::check_manufacturer_table(config.manufacturer_objects)?;
        crate::od::check_table(config.extra_profile_objects)?;
        crate::od::check_table(config.pdo_objects)?;
        let missing = config.device.drive_modes & STANDARD_MODES & !IMPLEMENTED_MODES;
        if missing != 0 {
            return Err(ConfigError::ModesNotBuilt { modes: missing });
        }
        Ok(())
    }

    /// The drive with an empty dictionary: every part at its power-on state, the store zeroed.
    #[inline(always)]
    fn unconfigured(config: &Config, hooks: H, storage: S) -> Self {
        let sdo = SdoServer::new(config.sdo_timeout);
        Drive {
            slots: CommSlots::LOOKUP,
            receive: ReceiveFilter::LSS_ONLY,
            sync_settings: (SyncConfig { producer: false, period_us: 0, overflow: 0 }, 0x80),
            stale: true,
            emcy_settings: EmcySettings { can_id: None, inhibit_100us: 0 },
            od: Dictionary::empty(config.device, config.node_id),
            sdo: if config.sdo_block_transfer { sdo } else { sdo.without_block_transfer() },
            nmt: NmtState::Initialising,
            heartbeat: HeartbeatProducer::default(),
            emcy: EmcyProducer::new(),
            heartbeat_consumer: HeartbeatConsumer::default(),
            guarding: NodeGuarding::default(),
            bus_off: false,
            warning_limit: false,
            connection_event: None,
            sync: Sync::default(),
            cycle: CycleFlags::default(),
            pdos: PdoSet::default(),
            lss: LssSlave::new(
                LssAddress {
                    vendor_id: config.device.vendor_id,
                    product_code: config.device.product_code,
                    revision_number: config.device.revision_number,
                    serial_number: config.device.serial_number,
                },
                config.node_id,
            ),
            lss_requests: LssRequests::new(config),
            axes: core::array::from_fn(|n| {
                Profile::for_axis(config.profile, Axis::new(n as u8).unwrap_or(Axis::FIRST))
            }),
            error_behaviour: config.error_behaviour_values,
            store_groups: config.store_groups,
            emcy_bytes: config.emcy_additional_bytes,
            remap_while_valid: false,
            tx: TxQueue { frames: Deque::new(), dropped: 0 },
            program: RunningProgram::new(0),
            hooks,
            storage,
        }
    }

    /// [`unconfigured`](Self::unconfigured) written into `slot`: about one drive's worth of
    /// stack (inlined into its caller, the drive would be assembled twice).
    #[inline(never)]
    fn unconfigured_in<'a>(
        slot: &'a mut MaybeUninit<Self>,
        config: &Config,
        hooks: H,
        storage: S,
    ) -> &'a mut Self {
        slot.write(Self::unconfigured(config, hooks, storage))
    }

    /// Gives the dictionary its tables and the firmware's overrides, then the power-on values.
    fn configure(&mut self, config: &Config) -> Result<(), ConfigError> {
        // One description of an axis's objects, attached once per axis (a single-axis drive's
        // has no 67FFh and links only `PROFILE`).
        use crate::cia402::registry::{AXIS_PROFILE, AXIS_PROFILE_FIRST_LEVEL, PROFILE, PROFILE_FIRST_LEVEL};
        let (profile, profile_level): (&'static [Object], &'static FirstLevel) = if AXES > 1 {
            (&AXIS_PROFILE, &AXIS_PROFILE_FIRST_LEVEL)
        } else {
            (&PROFILE, &PROFILE_FIRST_LEVEL)
        };
        let tables: [&'static [Object]; 6] = [
            &standard::COMMUNICATION,
            config.pdo_objects,
            if config.program_download { &program::OBJECTS } else { &[] },
            config.manufacturer_objects,
            profile,
            config.extra_profile_objects,
        ];
        let axes = AXES as u8;
        // The drive profile's table, where nearly every request goes, comes with its first level
        // of look-up (the others' would cost flash for a few steps of search).
        let first_levels = [None, None, None, None, Some(profile_level)];
        self.od.attach_indexed(&tables, &first_levels, &[1, 1, 1, 1, axes, axes])?;
        self.od.set_homing_methods(config.profile.homing.method_list());
        self.od.set_entry_overrides(config.entry_overrides)?;
        self.od.set_default_overrides(config.default_overrides)?;
        self.od.set_absent(config.absent_objects);
        for profile in &mut self.axes {
            profile.configure(&self.od);
        }
        self.slots = CommSlots::resolve(&self.od);
        self.pdos.long_rpdo = config.long_rpdo;
        self.pdos.inhibit_unit = config.tpdo_inhibit_unit;
        // Power-on values: the stored set where there is one (digest §3.3).
        self.load_stored(Group::All);
        self.heartbeat_consumer.configure_all(&self.od);
        self.configure_pdos();
        self.refresh();
        Ok(())
    }

    /// The node-ID.
    pub fn node_id(&self) -> u8 {
        self.od.node_id()
    }

    /// The NMT state.
    pub fn nmt_state(&self) -> NmtState {
        self.nmt
    }

    /// The node's state as the CiA 303-3 indicators show it: a board samples
    /// [`NodeStatus::leds`] with the drive's clock and drives its RUN (green) and ERR (red)
    /// LEDs. What only the board knows (an invalid configuration, a program download) it sets
    /// in the returned value first.
    pub fn node_status(&self) -> NodeStatus {
        NodeStatus {
            lss_configuration: matches!(self.lss.state(), LssState::Configuration),
            node_id_unconfigured: !self.is_configured(),
            warning_limit: self.warning_limit,
            error_control_event: self.heartbeat_consumer.any_timed_out() || self.guarding.failed(),
            sync_lost: self.sync.is_lost(),
            rpdo_timeout: self.emcy.is_active(code::RPDO_TIMEOUT),
            bus_off: self.bus_off,
            ..NodeStatus::new(self.nmt)
        }
    }

    /// The program's identification 1F56h:1 reads ([`Config::program_download`]): the CRC-32
    /// of the running image, which the board reads from the header its bootloader left
    /// ([`program::read_header`]).
    pub fn set_program_identification(&mut self, identification: u32) {
        self.program = RunningProgram::new(identification);
    }

    /// What a write to 1F51h:1 asks the board to do ([`Config::program_download`]): stop
    /// (reset into the bootloader) or reset the program. Given once every frame before it has
    /// been taken from [`pop_tx`](Self::pop_tx), so that the answer is on its way first; the
    /// board then waits for its CAN controller to have sent it.
    pub fn take_program_request(&mut self) -> Option<ProgramRequest> {
        if !self.tx.frames.is_empty() {
            return None;
        }
        self.program.take_request()
    }

    /// True while a program request waits to be taken ([`take_program_request`](Self::take_program_request)):
    /// a board whose loop sleeps until the next deadline comes back for it once the transmit
    /// queue is empty.
    pub fn has_program_request(&self) -> bool {
        self.program.has_request()
    }

    /// The object dictionary (device-side access).
    pub fn od(&self) -> &Dictionary<OD_BYTES> {
        &self.od
    }

    /// The object dictionary, mutable (device-side access: no SDO access rules).
    pub fn od_mut(&mut self) -> &mut Dictionary<OD_BYTES> {
        for profile in &mut self.axes {
            profile.invalidate();
        }
        self.stale = true;
        // Whatever the firmware writes, also through slots, is a change for the next tick.
        self.od.touch();
        &mut self.od
    }

    /// The firmware's hooks.
    pub fn hooks_mut(&mut self) -> &mut H {
        &mut self.hooks
    }

    /// Presets the position actual value: from the next tick on 6064h reads `position` (user
    /// units) where the shaft is now — a device-side "teach" or "set position" function; the
    /// homing coordinates move with it, a profile position move in progress stops there.
    pub fn preset_position(&mut self, position: i32) {
        self.preset_axis_position(0, position);
    }

    /// [`Self::preset_position`] of axis `axis` (nothing for an axis the node does not have).
    pub fn preset_axis_position(&mut self, axis: usize, position: i32) {
        if let Some(profile) = self.axes.get_mut(axis) {
            profile.preset_position(&self.od, position);
        }
    }

    /// Stores `group` as a "save" written to 1010h would (for a device-side store, e.g. after
    /// an automatic calibration): 0x0800_0020 without storage or for a group the drive does not
    /// store ([`Config::store_groups`]).
    pub fn store_parameters(&mut self, group: Group) -> Result<(), AbortCode> {
        if !stores(&self.storage, self.store_groups, group) {
            return Err(AbortCode::CannotStore);
        }
        self.storage.store(&self.od, group)?;
        self.hooks.stored(group as u8);
        self.clear_error(code::DATA_SET);
        Ok(())
    }

    /// Stores the current values of single parameters (index, sub-index) and keeps the rest of
    /// the stored set as it is: the firmware's own saving of a few values, e.g. the results of
    /// a homing run, without storing what the master changed but did not store. Refused without
    /// storage; a failed store answers as 1010h would. Entries that are not parameters are left
    /// out.
    pub fn store_entries(&mut self, entries: &[(u16, u8)]) -> Result<(), AbortCode> {
        if !self.storage.available() {
            return Err(AbortCode::CannotStore);
        }
        self.storage.store_entries(&self.od, entries)?;
        self.clear_error(code::DATA_SET);
        Ok(())
    }

    /// The parameter storage.
    pub fn storage_mut(&mut self) -> &mut S {
        &mut self.storage
    }

    /// Applies the stored values of `group`; a corrupt or foreign image is never loaded and is
    /// reported with EMCY 0x6300 (data set), active until the next successful store.
    fn load_stored(&mut self, group: Group) {
        if !self.apply_stored(group) {
            self.raise_data_set_error(group);
        }
    }

    /// Applies the stored values of `group`; false when the image is unreadable, corrupt or
    /// foreign (nothing of it is loaded: the defaults stay).
    fn apply_stored(&mut self, group: Group) -> bool {
        let intact = matches!(self.storage.load(&mut self.od, group), Ok(report) if !report.image.is_lost());
        for profile in &mut self.axes {
            profile.parameters_loaded(&self.od);
        }
        intact
    }

    fn raise_data_set_error(&mut self, group: Group) {
        self.raise_error(code::DATA_SET, ErrorRegister::empty(), [group as u8, 0, 0, 0, 0]);
    }

    /// Frames dropped because the transmit queue was full (the board did not drain it).
    pub fn tx_dropped(&self) -> u32 {
        self.tx.dropped
    }

    /// Writes the EDS of this drive's dictionary. `[DeviceInfo]` states what the drive does: its
    /// PDOs and mapping granularity, [`Config::bit_rates`], its LSS slave; 1010h/1011h the
    /// groups it stores (none without storage).
    pub fn write_eds(&self, info: &EdsInfo, w: &mut impl fmt::Write) -> fmt::Result {
        eds::write(&self.od, info, &self.capabilities(), w)
    }

    /// Writes the XDD (CiA 311) of this drive's dictionary: what [`Drive::write_eds`] writes, as
    /// XML (`info`'s file name with `.xdd` for `.eds`).
    pub fn write_xdd(&self, info: &EdsInfo, w: &mut impl fmt::Write) -> fmt::Result {
        xdd::write(&self.od, info, &self.capabilities(), w)
    }

    /// What the descriptions state of the drive around its dictionary.
    fn capabilities(&self) -> Capabilities {
        let store_commands = Group::ALL
            .iter()
            .filter(|group| stores(&self.storage, self.store_groups, **group))
            .fold(0, |bits, group| bits | 1 << group.sub());
        Capabilities { bit_rates: self.lss_requests.bit_rates, lss: true, store_commands }
    }

    /// Handles one received frame. Bounded work: at most one SDO step and a transmit queue's
    /// worth of block-upload segments.
    #[inline]
    pub fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        if self.stale {
            self.refresh();
        }
        if self.nmt == NmtState::Initialising {
            self.boot_if_pending(now);
        }
        let Some(id) = frame.standard_id() else {
            return;
        };
        if !self.receive.passes(id) {
            // Not an identifier this node receives (another node's traffic): nothing to do.
            return;
        }
        self.dispatch(id, frame, now);
    }

    /// A frame whose identifier passed the receive filter, routed to its service.
    #[inline(never)]
    fn dispatch(&mut self, id: u16, frame: &CanFrame, now: Instant) {
        if id == LSS_REQUEST_COB_ID && !embedded_can::Frame::is_remote_frame(frame) {
            self.lss_request(embedded_can::Frame::data(frame), now);
            return;
        }
        if !self.is_configured() {
            // Without a node-ID the node runs LSS only.
            return;
        }
        let node_id = self.node_id();
        if embedded_can::Frame::is_remote_frame(frame) {
            if id == ERROR_CONTROL_BASE + u16::from(node_id) {
                self.guarding_request(now);
            } else if self.nmt.serves_pdo() {
                self.pdos.on_remote(id, now, &self.od, &mut self.tx);
            }
            return;
        }
        let data = embedded_can::Frame::data(frame);
        // One dictionary look-up for the SYNC identifier; the rest only for a SYNC.
        let sync_id = self.sync_config().1;
        // SDO first: its identifier is restricted, no PDO or SYNC can use it.
        if id == SDO_RX_BASE + u16::from(node_id) {
            if self.nmt.serves_sdo() {
                self.sdo_request(data, now);
            }
        } else if id == sync_id && self.nmt.serves_emcy() {
            self.sync_received(data, now, self.sync_config().0);
        } else if let (ERROR_CONTROL_FIRST..=ERROR_CONTROL_LAST, Some(&state)) = (id, data.first()) {
            // Restricted identifiers (as NMT's): no RPDO uses them.
            if self.nmt.serves_sdo() {
                let event = self.heartbeat_consumer.on_heartbeat((id - ERROR_CONTROL_BASE) as u8, state, now);
                self.consumer_event(event, now);
            }
        } else if id == NMT_COB_ID {
            if let Some(control) = NodeControl::parse(data).filter(|c| c.addresses(node_id)) {
                self.nmt_command(transition(self.nmt, control.command), now);
            }
        } else if self.nmt.serves_pdo() {
            self.rpdo_received(id, data, now);
        }
    }

    /// A request to this node's SDO server. (Out of line: the process data, which take the same
    /// dispatch, then do not pay for its registers and stack.)
    #[inline(never)]
    fn sdo_request(&mut self, data: &[u8], now: Instant) {
        let node_id = self.node_id();
        // Between transfers, an upload of a plain value of 1..=4 bytes (nearly every upload)
        // is answered from its entry, without the access context the other requests need; the
        // server stays idle.
        if self.sdo.is_idle() && self.sdo_plain_upload(data) {
            return;
        }
        let mut access = Access::new(
            &mut self.od,
            &mut self.hooks,
            &mut self.storage,
            self.nmt,
            &self.axes,
            &mut self.program,
        );
        access.error_behaviour = self.error_behaviour;
        access.store_groups = self.store_groups;
        access.remap_while_valid = self.remap_while_valid;
        let response = self.sdo.on_request(data, now, &mut access);
        let written = access.written;
        let stored = access.stored;
        if let Some(response) = response {
            let _ = self.tx.send_array(SDO_TX_BASE + u16::from(node_id), response, 8);
        }
        if let Some((owner, mux, rule)) = written {
            self.after_write(owner, mux, rule, now);
        }
        if stored {
            self.clear_error(code::DATA_SET);
        }
        self.drain_sdo(now);
    }

    /// An expedited upload of a plain value of 1..=4 bytes ([`plain_value`]): answered, and
    /// `true`; `false` for any other request (the server's to answer).
    fn sdo_plain_upload(&mut self, data: &[u8]) -> bool {
        let Some(mux) = sdo_server::upload_request(data) else {
            return false;
        };
        let mut value = [0u8; 4];
        let Some(n) = plain_value(&self.od, &mut self.hooks, &self.axes, mux, &mut value) else {
            return false;
        };
        let id = SDO_TX_BASE + u16::from(self.node_id());
        let _ = self.tx.send_array(id, sdo_server::upload_response(mux, value, n), 8);
        true
    }

    /// Runs the timers and background work due at `now`; returns when to call again
    /// (`None`: only when a frame arrives).
    pub fn poll(&mut self, now: Instant) -> Option<Instant> {
        if self.stale {
            self.refresh();
        }
        self.boot_if_pending(now);
        let (sync, sync_id) = self.sync_config();
        let mut sync_deadline = None;
        if self.nmt.serves_emcy() {
            match self.sync.poll(now, sync) {
                SyncPoll::Idle => {}
                SyncPoll::Produce(event) => {
                    let counter = event.counter.map(|c| [c]);
                    self.tx.send(sync_id, counter.as_ref().map_or(&[], |c| c.as_slice()));
                    if self.nmt.serves_pdo() {
                        self.pdos.on_sync(event.counter, now, &self.od, &mut self.tx);
                    }
                }
                SyncPoll::Lost => self.raise_error(code::COMMUNICATION, ErrorRegister::COMMUNICATION, [0; 5]),
            }
            sync_deadline = self.sync.deadline(sync);
        }
        let mut pdo_deadline = None;
        if self.nmt.serves_pdo() {
            let mut events = heapless::Vec::<PdoEvent, 8>::new();
            self.pdos.poll(now, &self.od, &mut self.tx, &mut |e| {
                let _ = events.push(e);
            });
            for event in events {
                self.pdo_event(event, now);
            }
            pdo_deadline = self.pdos.deadline();
        }
        if self.heartbeat.due(now, self.heartbeat_period()) {
            self.send_error_control(self.nmt.heartbeat_byte());
        }
        if self.nmt.serves_sdo() {
            let event = self.heartbeat_consumer.poll(now);
            self.consumer_event(event, now);
        }
        if self.guarding.poll(now) == Some(GuardingEvent::LifeGuardingFailed) {
            self.communication_error(
                code::LIFE_GUARD_OR_HEARTBEAT,
                [0; 5],
                ConnectionEvent::LifeGuardingLost,
                now,
            );
        }
        self.drain_sdo(now);
        let emcy = self.send_emcy(now);
        let supervision = if self.nmt.serves_sdo() { self.heartbeat_consumer.deadline() } else { None };
        [
            self.heartbeat.deadline(),
            self.sdo.deadline(),
            emcy,
            supervision,
            self.guarding.deadline(),
            sync_deadline,
            pdo_deadline,
        ]
        .into_iter()
        .fold(None, earliest)
    }

    /// Reports a change of the CAN controller's state (from the board's error interrupt).
    pub fn on_can_state(&mut self, state: CanState, now: Instant) {
        match state {
            CanState::BusOff => {
                self.bus_off = true;
                self.communication_reaction(ConnectionEvent::BusOff, now);
            }
            CanState::ErrorActive => {
                self.warning_limit = false;
                self.clear_error(code::CAN_ERROR_PASSIVE);
                if core::mem::take(&mut self.bus_off) {
                    // Reported once the node can speak again (digest §15).
                    self.raise_error(code::RECOVERED_FROM_BUS_OFF, ErrorRegister::COMMUNICATION, [0; 5]);
                    self.clear_error(code::RECOVERED_FROM_BUS_OFF);
                }
            }
            CanState::WarningLimit => {
                self.warning_limit = true;
                // Back from error passive, or on the way there.
                self.clear_error(code::CAN_ERROR_PASSIVE);
            }
            CanState::ErrorPassive => {
                self.warning_limit = true;
                self.raise_error(code::CAN_ERROR_PASSIVE, ErrorRegister::COMMUNICATION, [0; 5]);
            }
            CanState::Overrun => {
                self.raise_error(code::CAN_OVERRUN, ErrorRegister::COMMUNICATION, [0; 5]);
                self.clear_error(code::CAN_OVERRUN);
            }
        }
    }

    /// The node-ID the drive takes at its next NMT reset (node or communication), as one an LSS
    /// master configured: for a firmware whose own objects configure the node-ID. Refuses
    /// anything but 1..=127 with [`ConfigError::InvalidNodeId`].
    pub fn configure_node_id(&mut self, node_id: u8) -> Result<(), ConfigError> {
        if self.lss.set_pending_node_id(node_id) {
            Ok(())
        } else {
            Err(ConfigError::InvalidNodeId)
        }
    }

    /// Lets a master change PDO mappings while the PDO is valid (no need to invalidate it
    /// first: a vendor's "manufacturer-specific mode", e.g. Trinamic's 2701h), or restores the
    /// CiA 301 rule (the default: 0x0601_0000 while valid). The new mapping takes effect when
    /// its sub-index 0 is written.
    pub fn set_remap_while_valid(&mut self, on: bool) {
        self.remap_while_valid = on;
    }

    /// The last event that broke the connection to the master, taken (for the 6007h reaction).
    pub fn take_connection_event(&mut self) -> Option<ConnectionEvent> {
        self.connection_event.take()
    }

    fn guarding_request(&mut self, now: Instant) {
        // Node guarding is answered only while the heartbeat producer is off (digest §4.3).
        if self.heartbeat_period() != 0 || self.nmt == NmtState::Initialising {
            return;
        }
        let life_time = life_time_ms(&self.od);
        let (byte, event) = self.guarding.on_request(self.nmt, life_time, now);
        self.send_error_control(byte);
        if event == Some(GuardingEvent::Resumed) {
            self.communication_recovered();
        }
    }

    fn consumer_event(&mut self, event: Option<ConsumerEvent>, now: Instant) {
        match event {
            None => {}
            Some(ConsumerEvent::Timeout { node_id } | ConsumerEvent::RemoteReset { node_id }) => {
                self.communication_error(
                    code::LIFE_GUARD_OR_HEARTBEAT,
                    [node_id, 0, 0, 0, 0],
                    ConnectionEvent::HeartbeatLost,
                    now,
                );
            }
            Some(ConsumerEvent::Recovered { .. }) => self.communication_recovered(),
        }
    }

    /// A communication error: its EMCY, the 1029h reaction and the connection event.
    fn communication_error(&mut self, code: u16, info: [u8; 5], event: ConnectionEvent, now: Instant) {
        self.raise_error(code, ErrorRegister::COMMUNICATION, info);
        // The error happened in the present NMT state: its EMCY goes out before a 1029h
        // reaction into Stopped silences the node.
        self.send_emcy(now);
        self.communication_reaction(event, now);
    }

    fn communication_reaction(&mut self, event: ConnectionEvent, now: Instant) {
        self.connection_lost(event);
        self.error_class_reaction(1, now);
    }

    /// The NMT state 1029h sub `class` selects for an error of that class (sub 1 communication,
    /// sub 2 the drive's Fault); nothing when the sub-index is not shown.
    fn error_class_reaction(&mut self, class: u8, now: Instant) {
        if let Some(state) = ErrorBehaviour::of_class(&self.od, self.error_behaviour, class)
            .and_then(|b| b.next_state(self.nmt))
        {
            self.nmt_command(NmtAction::Enter(state), now);
        }
    }

    /// Clears 0x8130 once no heartbeat entry is timed out and life guarding is fine.
    fn communication_recovered(&mut self) {
        if !self.heartbeat_consumer.any_timed_out() && !self.guarding.failed() {
            self.clear_error(code::LIFE_GUARD_OR_HEARTBEAT);
        }
    }

    /// Raises an error: sends its EMCY (in Pre-operational and Operational; queued in Stopped),
    /// records it in 1003h and sets its bits in 1001h. An error that is already active is not
    /// reported again. `info` is the manufacturer-specific field of the EMCY frame. A code in
    /// [`crate::cia402::ProfileConfig::error_codes`] is reported as the drive's own code.
    pub fn raise_error(&mut self, code: u16, register: ErrorRegister, info: [u8; 5]) {
        self.raise_axis_error(0, code, register, info);
    }

    /// [`Self::raise_error`] for axis `axis` of a multi-axis node: active until cleared for
    /// that axis ([`Self::clear_axis_error`]), whatever the other axes raise or clear.
    pub fn raise_axis_error(&mut self, axis: u8, code: u16, register: ErrorRegister, info: [u8; 5]) {
        let (code, info) = self.reported_error(code, info);
        if self.emcy.raise_of(axis, code, register, info).is_some() {
            crate::fmt::info!("EMCY: error {:x} raised", code);
            emcy::record_history(&mut self.od, code, info);
            self.sync_error_register();
        }
    }

    /// [`Self::raise_axis_error`], and when the error is active already its EMCY once more
    /// (recorded in 1003h as well): the condition was met again while the error lasts.
    fn raise_axis_error_again(&mut self, axis: u8, code: u16, register: ErrorRegister, info: [u8; 5]) {
        let (code, info) = self.reported_error(code, info);
        self.emcy.raise_again_of(axis, code, register, info);
        crate::fmt::info!("EMCY: error {:x} reported", code);
        emcy::record_history(&mut self.od, code, info);
        self.sync_error_register();
    }

    /// The code and additional bytes an error is reported with ([`Self::reported_code`],
    /// [`Config::emcy_additional_bytes`]).
    fn reported_error(&self, code: u16, info: [u8; 5]) -> (u16, [u8; 5]) {
        let code = self.reported_code(code);
        (code, self.emcy_bytes.iter().find(|(c, _)| *c == code).map_or(info, |(_, bytes)| *bytes))
    }

    /// Clears an active error: sends the "error reset" EMCY (code 0000h) and updates 1001h.
    pub fn clear_error(&mut self, code: u16) {
        self.clear_axis_error(0, code);
    }

    /// [`Self::clear_error`] for axis `axis` of a multi-axis node.
    pub fn clear_axis_error(&mut self, axis: u8, code: u16) {
        if self.emcy.active().is_empty() {
            // Nothing to clear (the common case: every SYNC and RPDO clears its errors).
            return;
        }
        let code = self.reported_code(code);
        if self.emcy.clear_of(axis, code) {
            crate::fmt::info!("EMCY: error {:x} cleared", code);
            self.sync_error_register();
        }
    }

    /// The code an error is reported with ([`crate::cia402::ProfileConfig::error_codes`]).
    fn reported_code(&self, code: u16) -> u16 {
        self.axes.first().map_or(code, |p| p.config().reported_code(code))
    }

    /// The error register 1001h.
    pub fn error_register(&self) -> ErrorRegister {
        self.emcy.register()
    }

    fn sync_error_register(&mut self) {
        emcy::show_register(&mut self.od, self.emcy.register());
    }

    /// Sends the EMCY frames due; returns when the next one may go.
    fn send_emcy(&mut self, now: Instant) -> Option<Instant> {
        let Some(can_id) = self.emcy_settings.can_id else {
            self.emcy.discard_pending();
            return None;
        };
        if !self.nmt.serves_emcy() {
            // Stopped: kept until the node may speak again.
            return None;
        }
        let inhibit = self.emcy_settings.inhibit_100us;
        while !self.tx.frames.is_full() {
            match self.emcy.pop_due(now, inhibit) {
                Some(data) => self.send(can_id, &data),
                None => break,
            }
        }
        self.emcy.deadline()
    }

    /// The next frame to transmit.
    pub fn pop_tx(&mut self) -> Option<CanFrame> {
        self.tx.frames.pop_front()
    }

    /// The next frame to transmit, left in the queue (for drivers that may refuse it).
    pub fn peek_tx(&self) -> Option<&CanFrame> {
        self.tx.frames.front()
    }

    /// The control-loop tick of a node of `AXES` axes ([`Drive::tick`] of a single-axis drive):
    /// applies the RPDOs latched at the last SYNC once, runs each axis's drive profile with its
    /// own sample (state machine, mode, stops, statusword, actual values), and stages the
    /// event-driven TPDOs whose values changed. Returns what each power stage must do until
    /// the next tick. Every axis runs from the same SYNC and the same RPDOs; an axis's fault is
    /// its own (its EMCY, 603Fh and 605Eh reaction) and leaves the others running unless 1029h
    /// sub 2 makes it a change of the node's NMT state.
    ///
    /// One call for all axes, not one per axis: the communication side of a tick (the RPDOs
    /// latched at SYNC, the SYNC itself, the TPDOs' change detection) belongs to the node, and
    /// with per-axis calls one of them would have to consume the SYNC for the others, and a TPDO
    /// mapping two axes would be sampled between their ticks. A board with one PWM timer per
    /// axis samples them all at its control interrupt and applies the demands it gets back.
    pub fn tick_axes(&mut self, now: Instant, samples: &[Sample; AXES]) -> [Demand; AXES] {
        if self.quiet_tick(now, samples) {
            return core::array::from_fn(|axis| {
                self.axes.get(axis).map_or(Demand::OFF, Profile::quiet_demand)
            });
        }
        let demands = self.full_tick(now, samples);
        // The share of a plan in progress for the next tick, once this one's work is done (out
        // of the tick's frames: the deepest stack is one or the other, not both).
        for profile in &mut self.axes {
            profile.plan_ahead();
        }
        demands
    }

    /// [`Self::tick_axes`] with every input looked at.
    #[inline(never)]
    fn full_tick(&mut self, now: Instant, samples: &[Sample; AXES]) -> [Demand; AXES] {
        if self.nmt.serves_pdo() {
            let mut events = heapless::Vec::<PdoEvent, PDO_EVENTS>::new();
            let rules = ProcessDataRules(&self.axes);
            self.pdos.apply_ready(&mut self.od, &mut self.hooks, &rules, &mut |e| {
                let _ = events.push(e);
            });
            for event in &events {
                self.pdo_event(*event, now);
            }
        }
        let sync = self.cycle.sync.take();
        let set_point = self.cycle.take_set_point(self.cycle_start());
        self.cycle.last_tick = Some(now);
        let cycle = crate::cia402::profile::SyncInput {
            sync: sync.is_some(),
            fresh: sync.unwrap_or(false),
            set_point,
        };
        let demands = core::array::from_fn(|axis| match samples.get(axis) {
            Some(sample) => self.tick_axis(axis, now, sample, cycle),
            None => Demand::OFF,
        });
        if self.nmt.serves_pdo() {
            self.pdos.detect_changes(now, &self.od, &mut self.tx);
        }
        demands
    }

    /// One axis's part of [`Self::full_tick`]: its profile's tick and the errors it reports.
    #[inline(always)]
    fn tick_axis(
        &mut self,
        axis: usize,
        now: Instant,
        sample: &Sample,
        cycle: crate::cia402::profile::SyncInput,
    ) -> Demand {
        let Some(profile) = self.axes.get_mut(axis) else { return Demand::OFF };
        let faulted = |state| matches!(state, State::FaultReactionActive | State::Fault);
        let was_faulted = faulted(profile.state());
        let (demand, report) = profile.tick(now, sample, &mut self.od, cycle);
        let entered_fault = !was_faulted && faulted(profile.state());
        if entered_fault {
            // CiA 402-2 §7.2: entering Fault is a device-internal error for 1029h.
            self.error_class_reaction(2, now);
        }
        // A multi-axis node's profile errors carry their axis in EMCY byte 7.
        let axis = axis as u8;
        let info = |limit: u8| [limit, 0, 0, 0, if AXES > 1 { axis } else { 0 }];
        if let Some((code, register)) = report.raise {
            self.raise_axis_error(axis, code, register, info(0));
        }
        if let Some(code) = report.clear {
            self.clear_axis_error(axis, code);
        }
        if let Some((code, limit)) = report.travel_limit {
            self.clear_axis_error(axis, code);
            if let Some(limit) = limit {
                self.raise_axis_error(axis, code, ErrorRegister::MANUFACTURER, info(limit as u8));
            }
        }
        if let Some((code, switch)) = report.limit_switch_touched {
            // The travel-limit error is active (the switch is): its EMCY once more.
            self.raise_axis_error_again(axis, code, ErrorRegister::MANUFACTURER, info(switch as u8));
        }
        for notice in report.notices {
            match notice {
                Some((code, true)) => {
                    self.raise_axis_error(axis, code, ErrorRegister::DEVICE_PROFILE, info(0))
                }
                Some((code, false)) => self.clear_axis_error(axis, code),
                None => {}
            }
        }
        demand
    }

    /// What starts a cycle of the cyclic modes (the profile configuration every axis shares).
    #[inline]
    fn cycle_start(&self) -> CycleStart {
        self.axes.first().map_or(CycleStart::Sync, |p| p.config().cyclic.cycle_start)
    }

    /// The tick of a node whose axes are idle with the inputs of the last tick
    /// ([`Profile::quiet_tick`](crate::cia402::profile::Profile::quiet_tick)): no RPDO to
    /// apply, no SYNC or set-point since, the same samples, the dictionary unchanged. Only the
    /// TPDOs' timers are looked at; false when a full tick is needed.
    fn quiet_tick(&mut self, now: Instant, samples: &[Sample; AXES]) -> bool {
        let serves_pdo = self.nmt.serves_pdo();
        let set_point = self.cycle.has_set_point(self.cycle_start());
        let revision = self.od.revision();
        if (serves_pdo && self.pdos.has_ready())
            || self.cycle.sync.is_some()
            || set_point
            || !self.axes.iter().zip(samples).all(|(profile, sample)| profile.is_quiet(sample, revision))
        {
            return false;
        }
        for profile in &mut self.axes {
            profile.pass_quietly(now);
        }
        self.cycle.last_tick = Some(now);
        if serves_pdo {
            // The dictionary is as the last full tick's change detection left it.
            self.pdos.send_due(now, &self.od, &mut self.tx);
        }
        true
    }

    /// Time from the last tick to the last SYNC: a board that steers its PWM timer onto SYNC
    /// keeps it constant. Also in [`crate::cia402::cyclic::CyclicConfig::sync_phase_object`].
    pub fn sync_phase(&self) -> Option<Duration> {
        self.cycle.phase
    }

    /// The CiA 402 state of the (first) axis.
    pub fn state(&self) -> crate::cia402::fsa::State {
        self.axis_state(0)
    }

    /// The CiA 402 state of axis `axis` (Not ready to switch on for an axis the node does not
    /// have).
    pub fn axis_state(&self, axis: usize) -> crate::cia402::fsa::State {
        self.axes.get(axis).map_or(State::NotReadyToSwitchOn, Profile::state)
    }

    /// The drive profile of axis `axis`.
    pub fn axis(&self, axis: usize) -> Option<&Profile> {
        self.axes.get(axis)
    }

    /// Records an event that broke the connection and lets the profile react (6007h).
    fn connection_lost(&mut self, event: ConnectionEvent) {
        self.connection_event = Some(event);
        for profile in &mut self.axes {
            profile.connection_lost(event, &self.od);
        }
    }

    /// SYNC configuration (1005h/1006h/1019h) and the SYNC CAN-ID, as last read
    /// ([`Self::refresh`]).
    fn sync_config(&self) -> (SyncConfig, u16) {
        self.sync_settings
    }

    /// Reads again what the drive keeps resolved from communication objects (the SYNC
    /// configuration, the identifiers it receives): after a write to them, a reset of
    /// communication, or device-side access ([`Self::od_mut`]).
    fn refresh(&mut self) {
        self.sync_settings = (self.slots.sync.config(&self.od), self.slots.sync.can_id(&self.od));
        self.emcy_settings = EmcySettings::read(&self.od);
        self.update_receive_filter();
        self.stale = false;
    }

    fn sync_received(&mut self, data: &[u8], now: Instant, config: SyncConfig) {
        match self.sync.on_frame(data, now, config) {
            SyncReception::WrongLength => {
                self.raise_error(code::SYNC_LENGTH, ErrorRegister::COMMUNICATION, [0; 5]);
            }
            SyncReception::Sync(event) => {
                self.clear_error(code::SYNC_LENGTH);
                let start = self.cycle_start();
                self.cycle.sync_received(start);
                if let Some(tick) = self.cycle.last_tick {
                    let phase = now - tick;
                    self.cycle.phase = Some(phase);
                    let phase_object = self.axes.first().and_then(|p| p.config().cyclic.sync_phase_object);
                    if let Some(index) = phase_object {
                        let micros = u32::try_from(phase.as_micros()).unwrap_or(u32::MAX);
                        let _ = self.od.set::<u32>(index, 0, micros);
                    }
                }
                if self.sync.take_recovered() {
                    self.clear_error(code::COMMUNICATION);
                }
                if self.nmt.serves_pdo() {
                    self.pdos.on_sync(event.counter, now, &self.od, &mut self.tx);
                }
            }
        }
    }

    /// Offers a frame to the RPDOs; true when one of them took it.
    fn rpdo_received(&mut self, id: u16, data: &[u8], now: Instant) -> bool {
        // Synchronous RPDOs arriving after the synchronous window are discarded (digest §7).
        let window = u64::from(self.slots.sync.window_us(&self.od));
        let late = window != 0 && self.sync.last().is_some_and(|at| now - at > Duration::from_micros(window));
        let mut events = heapless::Vec::<PdoEvent, PDO_EVENTS>::new();
        let rules = ProcessDataRules(&self.axes);
        let frame = RpdoFrame { can_id: id, data, now, late };
        let taken = self.pdos.on_frame(frame, &mut self.od, &mut self.hooks, &rules, &mut |e| {
            let _ = events.push(e);
        });
        for event in &events {
            self.pdo_event(*event, now);
        }
        self.cycle.rpdo_since_sync |= taken;
        taken
    }

    fn pdo_event(&mut self, event: PdoEvent, now: Instant) {
        match event {
            PdoEvent::Raise(code) => self.raise_error(code, ErrorRegister::COMMUNICATION, [0; 5]),
            PdoEvent::Clear(code) => self.clear_error(code),
            PdoEvent::RpdoTimeout(number) => {
                let [lo, hi] = number.to_le_bytes();
                // No 1029h-driven connection event: the RPDO timeout is a process-data error.
                self.raise_error(code::RPDO_TIMEOUT, ErrorRegister::COMMUNICATION, [lo, hi, 0, 0, 0]);
                self.error_class_reaction(1, now);
            }
            PdoEvent::Written { index, sub, rule } => {
                let reacts = <ProcessDataRules<AXES> as ValueRules<OD_BYTES>>::REACTS;
                let profile = self.axes.get_mut(axis_number::<AXES>(index));
                if let (Some(rule), Some(profile)) = (Rule::from_raw(rule & !reacts), profile) {
                    profile.written(&mut self.od, rule, index, sub);
                }
            }
        }
    }

    /// The identifiers this node receives, again: after a change of the node-ID, of 1005h, of a
    /// PDO's COB-ID or of the heartbeat consumer.
    fn update_receive_filter(&mut self) {
        let mut filter = ReceiveFilter::default();
        filter.add(LSS_REQUEST_COB_ID);
        if self.is_configured() {
            let node_id = u16::from(self.node_id());
            for id in [NMT_COB_ID, SDO_RX_BASE + node_id, ERROR_CONTROL_BASE + node_id] {
                filter.add(id);
            }
            filter.add(self.slots.sync.can_id(&self.od));
            for node in self.heartbeat_consumer.nodes() {
                filter.add(ERROR_CONTROL_BASE + u16::from(node));
            }
            for id in self.pdos.received_ids() {
                filter.add(id);
            }
        }
        self.receive = filter;
    }

    fn configure_pdos(&mut self) {
        if let Some(PdoEvent::Raise(code)) = self.pdos.configure_all(&self.od, &ProcessDataRules(&self.axes))
        {
            self.raise_error(code, ErrorRegister::COMMUNICATION, [0; 5]);
        }
        self.update_receive_filter();
    }

    /// True when the node has a node-ID (not waiting for LSS).
    pub fn is_configured(&self) -> bool {
        (1..=127).contains(&self.node_id())
    }

    /// The LSS slave (state, pending node-ID, pending bit timing).
    pub fn lss(&self) -> &LssSlave {
        &self.lss
    }

    /// A bit-rate change the LSS master activated, taken.
    pub fn take_bit_rate_change(&mut self) -> Option<BitRateChange> {
        self.lss_requests.bit_rate.take()
    }

    /// An LSS "store configuration" to make persistent (node-ID, bit timing), taken. The board
    /// stores it and loads it as [`Config::node_id`] at the next start.
    pub fn take_lss_store(&mut self) -> Option<(u8, Option<BitTiming>)> {
        self.lss_requests.store.take()
    }

    fn lss_request(&mut self, data: &[u8], now: Instant) {
        if let Some(response) = self.lss.on_request(data, &mut self.lss_requests) {
            self.send(LSS_RESPONSE_COB_ID, &response);
        }
        if core::mem::take(&mut self.lss_requests.start_up) {
            // A node that got its node-ID continues its start-up: reset communication.
            self.reset_communication(now);
        }
    }

    fn heartbeat_period(&self) -> u16 {
        self.slots.heartbeat.period_ms(&self.od)
    }

    fn boot_if_pending(&mut self, now: Instant) {
        if self.nmt != NmtState::Initialising || !self.is_configured() {
            return;
        }
        // Initialisation ends with the boot-up frame; the first heartbeat follows one period
        // later (digest §3.5).
        self.send_error_control(NmtState::Initialising.heartbeat_byte());
        crate::fmt::info!("NMT: boot-up of node {}, Pre-operational", self.node_id());
        self.nmt = NmtState::PreOperational;
        let period = self.heartbeat_period();
        self.heartbeat.restart(now + Duration::from_millis(u64::from(period)), period);
    }

    fn nmt_command(&mut self, action: NmtAction, now: Instant) {
        match action {
            NmtAction::None => {}
            NmtAction::Enter(state) => {
                if state != self.nmt {
                    crate::fmt::info!("NMT: {:?} -> {:?}", self.nmt, state);
                    if state == NmtState::Stopped {
                        self.connection_lost(ConnectionEvent::NmtStopped);
                    }
                    if self.nmt == NmtState::Stopped {
                        // The SYNC counter restarts at 1 when the node leaves Stopped.
                        self.sync.restart(now, self.sync_config().0);
                    }
                    if state == NmtState::Operational {
                        self.pdos.start(now);
                    }
                    self.nmt = state;
                    if !state.serves_sdo() {
                        self.sdo.reset();
                    }
                    self.heartbeat.restart(now, self.heartbeat_period());
                }
            }
            NmtAction::ResetApplication => {
                crate::fmt::info!("NMT: reset application");
                // The application restarts as at power-on: its fault and every active error
                // are forgotten (a condition still present is raised again when detected).
                self.emcy.reset();
                // A node-ID configured since (LSS, [`Self::configure_node_id`]) is the one the
                // application's `$NODEID` defaults restart with.
                let node_id = self.lss.activate_pending();
                self.od.set_node_id(node_id);
                self.od.reset(standard::APPLICATION_AREA);
                let manufacturer = self.apply_stored(Group::Manufacturer);
                let application = self.apply_stored(Group::Application);
                self.reset_communication(now);
                // A damaged image is such a condition: raised once communication is reset, so
                // that 1003h records it and its EMCY is sent (not discarded with the queue).
                if !(manufacturer && application) {
                    self.raise_data_set_error(if manufacturer {
                        Group::Application
                    } else {
                        Group::Manufacturer
                    });
                }
                for profile in &mut self.axes {
                    profile.reset();
                }
                self.connection_event = Some(ConnectionEvent::ResetApplication);
            }
            NmtAction::ResetCommunication => {
                crate::fmt::info!("NMT: reset communication");
                self.reset_communication(now);
                self.connection_lost(ConnectionEvent::ResetCommunication);
            }
        }
    }

    fn reset_communication(&mut self, now: Instant) {
        // A node-ID configured by LSS becomes active here (digest §3.3).
        let node_id = self.lss.activate_pending();
        self.od.set_node_id(node_id);
        self.od.reset(standard::COMMUNICATION_AREA);
        // Active errors are conditions of the device and stay; the history and queue go.
        self.emcy.discard_pending();
        self.load_stored(Group::Communication);
        self.refresh();
        self.sync_error_register();
        self.heartbeat_consumer = HeartbeatConsumer::default();
        self.heartbeat_consumer.configure_all(&self.od);
        self.guarding.reset();
        self.sync.restart(now, self.sync_config().0);
        self.configure_pdos();
        self.sdo.reset();
        self.heartbeat.stop();
        self.nmt = NmtState::Initialising;
        self.boot_if_pending(now);
    }

    /// The reaction of `owner` to a value the bus wrote to `mux` by SDO (`rule`: the profile's rule
    /// of the entry, found when the write was checked).
    fn after_write(&mut self, owner: Owner, mux: Mux, rule: Option<Rule>, now: Instant) {
        // Every axis derives its parameters again (the cascade's record is every axis's).
        let mut set_point = false;
        for profile in &mut self.axes {
            set_point |= profile.sdo_written(mux.index);
        }
        if set_point {
            // A set-point by SDO counts for the cyclic stream as an RPDO would.
            self.cycle.rpdo_since_sync = true;
        }
        match owner {
            Owner::Profile => {
                let profile = self.axes.get_mut(axis_number::<AXES>(mux.index));
                if let (Some(rule), Some(profile)) = (rule, profile) {
                    profile.written(&mut self.od, rule, mux.index, mux.sub);
                }
            }
            Owner::HeartbeatProducer => {
                self.heartbeat.restart(now, self.heartbeat_period());
                if self.heartbeat_period() != 0 {
                    self.guarding.stop();
                }
            }
            Owner::HeartbeatConsumer => {
                let raw = self.od.get::<u32>(mux.index, mux.sub).unwrap_or(0);
                self.heartbeat_consumer.configure(mux.sub, raw);
                self.communication_recovered();
                self.update_receive_filter();
            }
            Owner::Sync => {
                self.refresh();
                self.sync.restart(now, self.sync_config().0);
            }
            Owner::Pdo => {
                if let Some(record) = PdoRecord::of(mux.index) {
                    let rules = ProcessDataRules(&self.axes);
                    if let Some(PdoEvent::Raise(code)) = self.pdos.configure(&self.od, record, &rules) {
                        self.raise_error(code, ErrorRegister::COMMUNICATION, [0; 5]);
                    }
                    if self.nmt == NmtState::Operational {
                        self.pdos.start(now);
                    }
                    self.update_receive_filter();
                }
            }
            Owner::Guarding => {
                if !guarding_configured(&self.od) {
                    self.guarding.stop();
                }
            }
            Owner::Emcy => self.refresh(),
            Owner::Dictionary
            | Owner::ErrorHistory
            | Owner::ErrorBehaviour
            | Owner::Storage
            | Owner::Program => {}
        }
    }

    #[inline]
    fn drain_sdo(&mut self, now: Instant) {
        // Idle (nearly always after a request): nothing to send, no call.
        if self.sdo.deadline().is_none() {
            return;
        }
        self.drain_sdo_due(now);
    }

    fn drain_sdo_due(&mut self, now: Instant) {
        let node_id = self.node_id();
        // The server sends on its own only what is due (block-upload segments, a timeout).
        while self.sdo.deadline().is_some_and(|due| now >= due) && !self.tx.frames.is_full() {
            let mut access = Access::new(
                &mut self.od,
                &mut self.hooks,
                &mut self.storage,
                self.nmt,
                &self.axes,
                &mut self.program,
            );
            access.error_behaviour = self.error_behaviour;
            access.store_groups = self.store_groups;
            access.remap_while_valid = self.remap_while_valid;
            match self.sdo.poll(now, &mut access) {
                Some(frame) => {
                    let _ = self.tx.send_array(SDO_TX_BASE + u16::from(node_id), frame, 8);
                }
                None => break,
            }
        }
    }

    fn send_error_control(&mut self, byte: u8) {
        self.send(ERROR_CONTROL_BASE + u16::from(self.node_id()), &[byte]);
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        self.tx.send(id, data);
    }
}

/// The value of 1..=4 bytes of `mux` when the bus may read it and the dictionary's store holds
/// it as it is: no command object of the store (1010h/1011h), no program download object, no
/// error history (whose sub-indices above the count are refused), no value of the firmware's
/// hooks. `None` for any other entry, and for one the bus may not read: the full access rules
/// ([`Access`]) answer those, with their abort codes.
#[inline]
fn plain_value<H: ObjectHooks, const B: usize, const AXES: usize>(
    od: &Dictionary<B>,
    hooks: &mut H,
    axes: &[Profile; AXES],
    mux: Mux,
    value: &mut [u8; 4],
) -> Option<usize> {
    let entry = od.bus_entry(mux.index, mux.sub).ok()?;
    sdo_server::check_upload(entry.var).ok()?;
    let owner = owner(entry.index(), entry.object, axes);
    if matches!(owner, Owner::Storage | Owner::Program | Owner::ErrorHistory)
        || hooks.read_len(mux.index, mux.sub).is_some()
    {
        return None;
    }
    od.read_small(&entry, value)
}

/// The profile's rule of a write from the bus to `mux`, an object of `owner` (`None` for an
/// object the profile does not own, or one without a rule).
#[inline]
fn profile_rule<const AXES: usize>(axes: &[Profile; AXES], owner: Owner, mux: Mux) -> Option<Rule> {
    match owner {
        Owner::Profile => axis_of(axes, mux.index).and_then(|p| p.rule(mux.index, mux.sub, false)),
        _ => None,
    }
}

/// The profile's check of a value from the bus for its object `mux` with `rule` (none: no
/// check beyond type, access and limits).
#[inline]
fn profile_check<const B: usize, const AXES: usize>(
    axes: &[Profile; AXES],
    od: &Dictionary<B>,
    rule: Option<Rule>,
    mux: Mux,
    data: &[u8],
) -> Result<(), AbortCode> {
    match (rule, axis_of(axes, mux.index)) {
        (Some(rule), Some(profile)) => profile.check(rule, od, mux.index, mux.sub, data),
        _ => Ok(()),
    }
}

/// A value from the bus that passed every rule of the drive: to the firmware's check, then
/// into the store, and the firmware told.
#[inline]
fn store_checked<H: ObjectHooks, const B: usize>(
    od: &mut Dictionary<B>,
    hooks: &mut H,
    entry: &Entry,
    data: &[u8],
) -> Result<(), AbortCode> {
    let (index, sub) = (entry.index(), entry.sub);
    hooks.validate(index, sub, data)?;
    od.commit(entry, data);
    hooks.written(index, sub, data);
    Ok(())
}

/// Whether the drive function is off where a write to `index` (an object of `owner`) takes
/// effect: in the axis of a profile object, in every axis for another object.
fn switched_off<const AXES: usize>(axes: &[Profile; AXES], owner: Owner, index: u16) -> bool {
    let off = |p: &Profile| matches!(p.state(), State::SwitchOnDisabled | State::NotReadyToSwitchOn);
    match owner {
        Owner::Profile => axis_of(axes, index).is_none_or(off),
        _ => axes.iter().all(off),
    }
}

/// The dictionary with the access rules of the bus (CiA 301 §7.2.4).
struct Access<'a, H, S, const B: usize, const AXES: usize> {
    od: &'a mut Dictionary<B>,
    hooks: &'a mut H,
    storage: &'a mut S,
    nmt: NmtState,
    axes: &'a [Profile; AXES],
    program: &'a mut RunningProgram,
    error_behaviour: &'static [(u8, ErrorBehaviour)],
    store_groups: &'static [Group],
    /// [`Drive::set_remap_while_valid`].
    remap_while_valid: bool,
    /// The owner and place of the value a download stored, with the profile's rule of it.
    written: Option<(Owner, Mux, Option<Rule>)>,
    /// A store on command succeeded.
    stored: bool,
}

impl<'a, H: ObjectHooks, S: Persistence, const B: usize, const AXES: usize> Access<'a, H, S, B, AXES> {
    fn new(
        od: &'a mut Dictionary<B>,
        hooks: &'a mut H,
        storage: &'a mut S,
        nmt: NmtState,
        axes: &'a [Profile; AXES],
        program: &'a mut RunningProgram,
    ) -> Self {
        Access {
            od,
            hooks,
            storage,
            nmt,
            axes,
            program,
            error_behaviour: &ErrorBehaviour::CIA_301,
            store_groups: &Group::ALL,
            remap_while_valid: false,
            written: None,
            stored: false,
        }
    }

    /// A write to the program download's objects (1F50h:1 data, 1F51h:1 a command): the
    /// service's, nothing in the dictionary.
    #[inline(never)]
    fn program_write(&mut self, entry: &Entry, data: &[u8]) -> Result<(), AbortCode> {
        if entry.index() == PROGRAM_DATA {
            return self.program.begin();
        }
        // 1F51h:1, UNSIGNED8 (the other entries are read only).
        match data {
            &[command] => self.program.command(command),
            [] => Err(AbortCode::LengthTooLow),
            _ => Err(AbortCode::LengthTooHigh),
        }
    }

    /// 1010h/1011h subs 1..=4: the read value says whether the command is supported (§11).
    fn command_capability(&self, entry: &Entry, owner: Owner) -> Option<u32> {
        let group = Group::from_sub(entry.sub).filter(|_| owner == Owner::Storage)?;
        Some(u32::from(stores(self.storage, self.store_groups, group)))
    }

    /// Sub 1 of the program download's objects: the value the service holds (1F51h one
    /// byte, 1F56h/1F57h four), as little-endian bytes and its length.
    fn program_value(&self, entry: &Entry, owner: Owner) -> Option<([u8; 4], usize)> {
        if owner != Owner::Program || entry.sub != 1 {
            return None;
        }
        let value = self.program.read(entry.index())?;
        Some((value.to_le_bytes(), program::value_len(entry.index())))
    }

    /// Store or restore on command: the signature, then the operation; nothing is written to
    /// the dictionary.
    fn storage_command(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        let group = Group::from_sub(mux.sub).ok_or(AbortCode::SubIndexDoesNotExist)?;
        let value = le_u32(data);
        let signature = crate::storage::signature(mux.index);
        if value != signature || !stores(self.storage, self.store_groups, group) {
            return Err(AbortCode::CannotStore);
        }
        if signature == SAVE_SIGNATURE {
            self.storage.store(self.od, group)?;
            self.stored = true;
            self.hooks.stored(mux.sub);
        } else {
            self.storage.restore_defaults(group)?;
        }
        Ok(())
    }

    /// `mux` as the bus sees it, with the owner of its object. (The expedited transfers, nearly
    /// all of them, resolve their entry once; a segmented one once per frame.)
    #[inline]
    fn entry(&self, mux: Mux) -> Result<(Entry, Owner), AbortCode> {
        let entry = self.od.bus_entry(mux.index, mux.sub)?;
        Ok((entry, owner(entry.index(), entry.object, self.axes)))
    }

    /// The rules of the object's owner beyond type, access and limits (each service checks its
    /// own objects; `rule`: the profile's rule of a profile entry).
    #[inline]
    fn check_owned(
        &self,
        entry: &Entry,
        owner: Owner,
        rule: Option<Rule>,
        data: &[u8],
    ) -> Result<(), AbortCode> {
        let (od, index, sub) = (&*self.od, entry.index(), entry.sub);
        match owner {
            Owner::Dictionary
            | Owner::HeartbeatProducer
            | Owner::Guarding
            | Owner::Storage
            | Owner::Program => Ok(()),
            Owner::Emcy => emcy::check_write(od, index, data),
            Owner::ErrorHistory => emcy::check_history_write(data),
            Owner::ErrorBehaviour => ErrorBehaviour::check_write(self.error_behaviour, data),
            Owner::Sync => sync::check_write(od, index, data),
            Owner::HeartbeatConsumer => check_consumer_write(od, sub, data),
            Owner::Pdo => pdo::check_write(od, index, sub, data, self.remap_while_valid),
            Owner::Profile => profile_check(self.axes, od, rule, Mux { index, sub }, data),
        }
    }

    #[inline]
    fn readable_entry(&mut self, mux: Mux) -> Result<(Entry, Owner), AbortCode> {
        let (entry, owner) = self.entry(mux)?;
        sdo_server::check_upload(entry.var)?;
        if owner == Owner::ErrorHistory {
            emcy::check_history_read(self.od, mux.index, mux.sub)?;
        }
        Ok((entry, owner))
    }

    #[inline]
    fn writable_entry(&mut self, mux: Mux) -> Result<(Entry, Owner), AbortCode> {
        let (entry, owner) = self.entry(mux)?;
        sdo_server::check_download(entry.var, self.nmt, || switched_off(self.axes, owner, mux.index))?;
        Ok((entry, owner))
    }
}

impl<H: ObjectHooks, S: Persistence, const B: usize, const AXES: usize> ObjectAccess
    for Access<'_, H, S, B, AXES>
{
    fn upload_len(&mut self, mux: Mux) -> Result<usize, AbortCode> {
        let (entry, owner) = self.readable_entry(mux)?;
        if self.command_capability(&entry, owner).is_some() {
            return Ok(4);
        }
        if let Some((_, len)) = self.program_value(&entry, owner) {
            return Ok(len);
        }
        match self.hooks.read_len(mux.index, mux.sub) {
            Some(result) => result,
            None => Ok(self.od.value_len(&entry)),
        }
    }

    fn read(&mut self, mux: Mux, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let (entry, owner) = self.entry(mux)?;
        if let Some(capability) = self.command_capability(&entry, owner) {
            let bytes = capability.to_le_bytes();
            let rest = bytes.get(offset..).unwrap_or(&[]);
            let n = rest.len().min(buf.len());
            if let (Some(d), Some(s)) = (buf.get_mut(..n), rest.get(..n)) {
                d.copy_from_slice(s);
            }
            return Ok(n);
        }
        if let Some((bytes, len)) = self.program_value(&entry, owner) {
            let value = bytes.get(offset..len).unwrap_or(&[]);
            let n = value.len().min(buf.len());
            if let (Some(d), Some(s)) = (buf.get_mut(..n), value.get(..n)) {
                d.copy_from_slice(s);
            }
            return Ok(n);
        }
        match self.hooks.read_len(mux.index, mux.sub) {
            Some(_) => self.hooks.read(mux.index, mux.sub, offset, buf),
            None => Ok(self.od.read(&entry, offset, buf)),
        }
    }

    fn upload_expedited(&mut self, mux: Mux, buf: &mut [u8; 4]) -> Result<Option<usize>, AbortCode> {
        // A plain value of the store: one look-up, no second pass through the hooks. (The
        // store's command objects and the program's answer with values of their own; a refusal
        // comes with its code from the two steps.)
        match plain_value(self.od, self.hooks, self.axes, mux, buf) {
            Some(n) => Ok(Some(n)),
            None => upload_in_two_steps(self, mux, buf),
        }
    }

    /// `write` refuses every size `download_check` refuses, with the same codes.
    fn download_expedited(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        self.write(mux, data)
    }

    fn download_check(&mut self, mux: Mux, size: Option<usize>) -> Result<Option<usize>, AbortCode> {
        let (entry, owner) = self.writable_entry(mux)?;
        let fixed = entry.var.data_type.fixed_size();
        match (fixed, size) {
            (Some(n), Some(s)) if s > n => Err(AbortCode::LengthTooHigh),
            (Some(n), Some(s)) if s < n => Err(AbortCode::LengthTooLow),
            // The program data has no size of its own: the service checks it.
            _ if owner == Owner::Program => Ok(fixed),
            (None, Some(s)) if s > usize::from(entry.var.capacity) => Err(AbortCode::LengthTooHigh),
            _ => Ok(fixed),
        }
    }

    // One copy, for the expedited and the other transfers.
    #[inline(never)]
    fn write(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        let (entry, owner) = self.writable_entry(mux)?;
        if owner == Owner::Program {
            return self.program_write(&entry, data);
        }
        self.od.check_write(&entry, data)?;
        if self.command_capability(&entry, owner).is_some() {
            return self.storage_command(mux, data);
        }
        let rule = profile_rule(self.axes, owner, mux);
        self.check_owned(&entry, owner, rule, data)?;
        store_checked(self.od, self.hooks, &entry, data)?;
        self.written = Some((owner, mux, rule));
        Ok(())
    }

    fn begin_stream(&mut self, mux: Mux, _size: Option<usize>) -> Result<bool, AbortCode> {
        if mux.index != PROGRAM_DATA {
            return Ok(false);
        }
        // The application refuses (0800 0022h): its program is the bootloader's to replace.
        self.program.begin().map(|()| true)
    }
}
