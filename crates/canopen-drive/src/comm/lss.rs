//! LSS slave (CiA 305, digest §12): the node-ID and the bit rate set over the bus.
//!
//! Requests arrive on COB-ID 0x7E5, answers leave on 0x7E4, always eight bytes; the frame
//! layouts are in [`crate::wire::lss`]. The LSS state is independent of the NMT state: the drive
//! hands every 0x7E5 frame to [`LssSlave::on_request`] in every NMT state, also while its
//! node-ID is 0xFF ("non-configured": CAN + LSS only, no boot-up, digest §18 item 21).
//!
//! ```text
//!                power-on
//!                   │
//!                   ▼
//!   ┌────────────────────────────────────────────┐  0x04 [00]        ┌───────────────┐
//!   │ Waiting                                    │◀──────────────────│ Configuration │
//!   │   selection: Idle → VendorIdMatched        │                   │               │
//!   │              → ProductCodeMatched          │  0x04 [01]        │  0x11 0x13    │
//!   │              → RevisionNumberMatched       │──────────────────▶│  0x15 0x17    │
//!   │   fastscan:  LSSPos (vendor..serial)       │  0x43 matched     │  0x5A..0x5E   │
//!   │                                            │  → 0x44           │               │
//!   │                                            │──────────────────▶│               │
//!   │                                            │  0x51 serial, bit │               │
//!   │                                            │  0, LSSNext 0     │               │
//!   │                                            │  → 0x4F           │               │
//!   │                                            │──────────────────▶│               │
//!   └────────────────────────────────────────────┘                   └───────────────┘
//!   in both states: identify remote slave 0x46..0x4B → 0x4F, identify non-configured 0x4C → 0x50
//! ```
//!
//! ## Node-ID: pending and active
//!
//! Configure node-ID (0x11) sets the *pending* node-ID; the stack runs on the *active* one.
//! The drive calls [`LssSlave::activate_pending`] at every NMT reset communication. When a
//! non-configured slave (active 0xFF) holding a valid pending node-ID is switched back to
//! waiting, [`LssHooks::continue_start_up`] tells the drive to continue its NMT start-up
//! (reset communication → `activate_pending` → boot-up); a configured slave keeps its node-ID
//! until the next reset communication (digest §12.2).
//!
//! ## Decisions where the digest leaves room
//!
//! - *Frames*: a frame that is not eight bytes long or carries an out-of-range parameter is
//!   not answered ([`crate::wire::lss::ParseError`]).
//! - *Sequences*: switch state selective must arrive in the order vendor → product → revision
//!   → serial, identify remote slave in the order 0x46 → 0x4B. Any other frame on 0x7E5,
//!   including an unknown or malformed one, ends the sequence in progress; a vendor-ID frame
//!   always starts a new one. A mismatching field ends it too, so the slave stays silent.
//! - *Non-configured* means active **and** pending node-ID are 0xFF (identify non-configured,
//!   digest §12.2). Only such a slave, and only in waiting, takes part in fastscan (digest
//!   §18 item 22): once a fastscan-found slave has been given a node-ID it no longer answers,
//!   even before its next reset communication.
//! - *Fastscan* follows digest §12.4 exactly. A probe matches when LSSSub is the slave's
//!   position LSSPos and bits 31..BitChecked agree; the slave answers 0x4F and moves to
//!   LSSNext. It enters configuration only on a match with BitChecked 0, LSSSub 3 (serial)
//!   and LSSNext 0, never at the end of an earlier field (CANopenNode's "LSSNext < LSSSub" test
//!   does, see CANopenNode PR #647). BitChecked 0x80 resets LSSPos to the vendor-ID and is
//!   answered. Entering waiting resets LSSPos as well.
//! - *Identify remote slave* is answered in both LSS states (lely; digest marks it "verify");
//!   vendor-ID and product code must be equal, revision and serial number within the
//!   inclusive bounds. Identify non-configured is answered in both states.
//! - *Bit timing*: table selector 0 with the table of digest §12.3 is the standard. Whether an
//!   entry is supported is up to [`LssHooks::bit_timing_supported`]; the default accepts the
//!   eight fixed rates of table 0 and refuses index 5 (100 kbit/s: reserved in CiA 305 v3,
//!   optional per digest §12.3), index 9 (automatic detection needs hardware support),
//!   reserved indices and every other table. Refused → error 1, the pending bit timing stays.
//! - *Activate bit timing* is obeyed in configuration only and only once a bit timing has
//!   been configured (before that the pending bit timing is the active one, nothing to
//!   switch). The hook gets the bit timing and the switch delay; the board waits the delay,
//!   switches, and stays silent for another delay (digest §12.3).
//! - *Store configuration* hands the pending node-ID and the configured bit timing (if any)
//!   to [`LssHooks::store_configuration`]; its [`StoreError`] becomes the response's error
//!   code. The default hook answers "not supported".
//! - *Inquire node-ID* reports the active node-ID (0xFF when none), not the pending one.
//! - `activate_pending` does not change the LSS state: LSS is independent of NMT.
//!
//! ## Example
//!
//! ```
//! use canopen_drive::comm::lss::{LssAddress, LssSlave, LssState, NODE_ID_UNCONFIGURED};
//! use canopen_drive::wire::lss::{ConfigureNodeIdStatus, LssField, Request, Response, SwitchMode};
//!
//! let identity =
//!     LssAddress { vendor_id: 0x1234, product_code: 0x0402, revision_number: 1, serial_number: 42 };
//! let mut slave = LssSlave::new(identity, NODE_ID_UNCONFIGURED);
//! let mut hooks = ();
//!
//! // Switch state selective: the fourth frame is answered with 0x44.
//! for field in LssField::ALL {
//!     let frame = Request::SwitchStateSelective { field, value: identity.field(field) }.emit();
//!     let answer = slave.on_request(&frame, &mut hooks);
//!     assert_eq!(answer.is_some(), field == LssField::SerialNumber);
//! }
//! assert_eq!(slave.state(), LssState::Configuration);
//!
//! let answer = slave.on_request(&Request::ConfigureNodeId(5).emit(), &mut hooks).unwrap();
//! assert_eq!(
//!     Response::parse(&answer),
//!     Ok(Response::ConfigureNodeId { status: ConfigureNodeIdStatus::Success, specific: 0 })
//! );
//! assert_eq!((slave.pending_node_id(), slave.active_node_id()), (5, NODE_ID_UNCONFIGURED));
//!
//! slave.on_request(&Request::SwitchStateGlobal(SwitchMode::Waiting).emit(), &mut hooks);
//! slave.activate_pending(); // done by the drive at NMT reset communication
//! assert_eq!(slave.active_node_id(), 5);
//! ```

pub use crate::wire::lss::{BitRate, BitTiming, LssAddress, LssField, NODE_ID_UNCONFIGURED};
use crate::wire::lss::{
    BitChecked, ConfigureBitTimingStatus, ConfigureNodeIdStatus, Fastscan, Request, Response,
    StoreConfigurationStatus, SwitchMode,
};

/// True for the node-IDs a configured node may have, 1..=127.
pub const fn is_valid_node_id(node_id: u8) -> bool {
    matches!(node_id, 1..=127)
}

/// True for the eight fixed bit rates of the standard table (index 0..=4 and 6..=8): the
/// default of [`LssHooks::bit_timing_supported`].
pub const fn is_fixed_standard_rate(bit_timing: BitTiming) -> bool {
    use BitRate::*;
    match bit_timing.standard_rate() {
        Some(Kbit1000 | Kbit800 | Kbit500 | Kbit250 | Kbit125 | Kbit50 | Kbit20 | Kbit10) => true,
        Some(Kbit100 | Automatic) | None => false,
    }
}

/// Progress of switch state selective (cs 0x40..=0x43) in LSS waiting: the fields received in
/// order and equal to the slave's own so far.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Selection {
    /// No sequence in progress (or it broke off).
    Idle,
    /// 0x40 matched.
    VendorIdMatched,
    /// 0x40, 0x41 matched.
    ProductCodeMatched,
    /// 0x40, 0x41, 0x42 matched: a matching 0x43 selects the slave.
    RevisionNumberMatched,
}

/// What a switch-state-selective frame leads to.
enum SelectionStep {
    /// The sequence continues (or restarts, or broke off: `Idle`).
    Progress(Selection),
    /// All four fields matched: enter configuration and answer 0x44.
    Selected,
}

impl Selection {
    /// The step after a frame carrying `field`; `matched` tells whether its value is the
    /// slave's own.
    fn after(self, field: LssField, matched: bool) -> SelectionStep {
        use LssField::*;
        use Selection::*;
        use SelectionStep::{Progress, Selected};
        if !matched {
            return Progress(Idle);
        }
        match (self, field) {
            // A vendor-ID frame always starts a new sequence.
            (Idle | VendorIdMatched | ProductCodeMatched | RevisionNumberMatched, VendorId) => {
                Progress(VendorIdMatched)
            }
            (VendorIdMatched, ProductCode) => Progress(ProductCodeMatched),
            (ProductCodeMatched, RevisionNumber) => Progress(RevisionNumberMatched),
            (RevisionNumberMatched, SerialNumber) => Selected,
            // Out of order.
            (Idle | ProductCodeMatched | RevisionNumberMatched, ProductCode)
            | (Idle | VendorIdMatched | RevisionNumberMatched, RevisionNumber)
            | (Idle | VendorIdMatched | ProductCodeMatched, SerialNumber) => Progress(Idle),
        }
    }
}

/// The LSS state of the slave (digest §12.1), with the progress of the waiting-state services.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LssState {
    /// LSS waiting: the state after power-on.
    Waiting {
        /// Progress of switch state selective.
        selection: Selection,
        /// Fastscan position LSSPos: the field the next fastscan probe must address.
        fastscan: LssField,
    },
    /// LSS configuration: node-ID, bit timing, store and inquire services are served.
    Configuration,
}

impl LssState {
    /// Waiting with nothing in progress: at power-on and whenever waiting is entered.
    pub const WAITING: LssState = LssState::Waiting { selection: Selection::Idle, fastscan: LssField::VendorId };
}

/// Progress of identify remote slave (cs 0x46..=0x4B), served in both LSS states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Identification {
    /// No sequence in progress (or it broke off).
    Idle,
    /// 0x46 equal to the vendor-ID.
    VendorIdMatched,
    /// 0x47 equal to the product code.
    ProductCodeMatched,
    /// 0x48 received: the revision low bound, waiting for the high bound.
    RevisionLow(u32),
    /// 0x49 received and the revision number within the bounds.
    RevisionInRange,
    /// 0x4A received: the serial low bound, waiting for the high bound.
    SerialLow(u32),
}

/// Why store configuration failed; maps 1:1 to the error code of the 0x17 response.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// Error code 1: storing is not supported.
    NotSupported,
    /// Error code 2: storage media access error.
    StorageMediaAccess,
    /// Error code 0xFF with this manufacturer-specific error in byte 2.
    ManufacturerSpecific(u8),
}

impl StoreError {
    /// The error code of the response.
    pub const fn status(self) -> StoreConfigurationStatus {
        match self {
            StoreError::NotSupported => StoreConfigurationStatus::NotSupported,
            StoreError::StorageMediaAccess => StoreConfigurationStatus::StorageMediaAccess,
            StoreError::ManufacturerSpecific(_) => StoreConfigurationStatus::ManufacturerSpecific,
        }
    }

    /// The specific error byte of the response (0 unless manufacturer-specific).
    pub const fn specific(self) -> u8 {
        match self {
            StoreError::NotSupported | StoreError::StorageMediaAccess => 0,
            StoreError::ManufacturerSpecific(specific) => specific,
        }
    }
}

/// What the LSS slave needs from the device. Every method has a default, so `()` serves a
/// device that supports the eight fixed standard bit rates and cannot store.
pub trait LssHooks {
    /// Whether the device can run at `bit_timing` (configure bit timing, cs 0x13). The default
    /// accepts the fixed rates of table 0 ([`is_fixed_standard_rate`]).
    fn bit_timing_supported(&self, bit_timing: BitTiming) -> bool {
        is_fixed_standard_rate(bit_timing)
    }

    /// Activate bit timing (cs 0x15): wait `switch_delay_ms`, switch the CAN controller to
    /// `bit_timing`, wait `switch_delay_ms` again, transmitting nothing meanwhile. The default
    /// does nothing.
    fn activate_bit_timing(&mut self, bit_timing: BitTiming, switch_delay_ms: u16) {
        let _ = (bit_timing, switch_delay_ms);
    }

    /// Store configuration (cs 0x17): make the pending node-ID and the configured bit timing
    /// (`None`: not configured since start-up, keep the stored one) persistent. The default
    /// answers "not supported".
    fn store_configuration(&mut self, node_id: u8, bit_timing: Option<BitTiming>) -> Result<(), StoreError> {
        let _ = (node_id, bit_timing);
        Err(StoreError::NotSupported)
    }

    /// A non-configured slave that got the valid pending `node_id` was switched back to
    /// waiting: continue the NMT start-up (reset communication, which calls
    /// [`LssSlave::activate_pending`], then boot-up). The default does nothing.
    fn continue_start_up(&mut self, node_id: u8) {
        let _ = node_id;
    }
}

/// A device with the default behaviour of every hook.
impl LssHooks for () {}

/// The LSS slave of one device.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LssSlave {
    identity: LssAddress,
    state: LssState,
    identification: Identification,
    pending_node_id: u8,
    active_node_id: u8,
    pending_bit_timing: Option<BitTiming>,
}

impl LssSlave {
    /// A slave in LSS waiting with the device's `identity` (1018h) and its node-ID at
    /// start-up, pending and active: 1..=127, or 0xFF when non-configured. Any other value is
    /// taken as 0xFF.
    pub const fn new(identity: LssAddress, node_id: u8) -> Self {
        let node_id = if is_valid_node_id(node_id) { node_id } else { NODE_ID_UNCONFIGURED };
        LssSlave {
            identity,
            state: LssState::WAITING,
            identification: Identification::Idle,
            pending_node_id: node_id,
            active_node_id: node_id,
            pending_bit_timing: None,
        }
    }

    /// Handles the data of a frame received on COB-ID 0x7E5; returns the eight bytes to send
    /// on 0x7E4, if the slave answers.
    pub fn on_request(&mut self, data: &[u8], hooks: &mut impl LssHooks) -> Option<[u8; 8]> {
        match Request::parse(data) {
            Ok(request) => self.handle(request, hooks).map(|response| response.emit()),
            Err(_) => {
                self.break_off_sequences();
                None
            }
        }
    }

    /// Handles a parsed request; returns the response, if the slave answers.
    pub fn handle(&mut self, request: Request, hooks: &mut impl LssHooks) -> Option<Response> {
        let identified = self.identify(request);
        let (state, response) = match self.state {
            LssState::Waiting { selection, fastscan } => self.in_waiting(selection, fastscan, request),
            LssState::Configuration => self.in_configuration(request, hooks),
        };
        self.state = state;
        // At most one of the two answers: identification requests change no LSS state.
        identified.or(response)
    }

    /// The LSS state.
    pub const fn state(&self) -> LssState {
        self.state
    }

    /// The LSS address (1018h) given at construction.
    pub const fn identity(&self) -> LssAddress {
        self.identity
    }

    /// The node-ID set by configure node-ID, active after the next [`Self::activate_pending`].
    pub const fn pending_node_id(&self) -> u8 {
        self.pending_node_id
    }

    /// The node-ID the stack runs on (0xFF when non-configured).
    pub const fn active_node_id(&self) -> u8 {
        self.active_node_id
    }

    /// The bit timing set by the last successful configure bit timing, if any.
    pub const fn pending_bit_timing(&self) -> Option<BitTiming> {
        self.pending_bit_timing
    }

    /// True when active and pending node-ID are both 0xFF: the slave answers identify
    /// non-configured and takes part in fastscan.
    pub const fn is_non_configured(&self) -> bool {
        self.active_node_id == NODE_ID_UNCONFIGURED && self.pending_node_id == NODE_ID_UNCONFIGURED
    }

    /// Makes the pending node-ID the active one; the drive calls it at NMT reset
    /// communication. Returns the active node-ID.
    pub fn activate_pending(&mut self) -> u8 {
        self.active_node_id = self.pending_node_id;
        self.active_node_id
    }

    /// A frame that is no request at all ends both sequences.
    fn break_off_sequences(&mut self) {
        self.identification = Identification::Idle;
        self.state = match self.state {
            LssState::Waiting { fastscan, .. } => LssState::Waiting { selection: Selection::Idle, fastscan },
            LssState::Configuration => LssState::Configuration,
        };
    }

    /// Identify remote slave and identify non-configured remote slave, in both states.
    fn identify(&mut self, request: Request) -> Option<Response> {
        use Identification::*;
        let id = self.identity;
        let progress = self.identification;
        let (next, response) = match request {
            Request::IdentifyRemoteVendorId(value) => (if value == id.vendor_id { VendorIdMatched } else { Idle }, None),
            Request::IdentifyRemoteProductCode(value) => {
                let matched = progress == VendorIdMatched && value == id.product_code;
                (if matched { ProductCodeMatched } else { Idle }, None)
            }
            Request::IdentifyRemoteRevisionLow(low) => {
                (if progress == ProductCodeMatched { RevisionLow(low) } else { Idle }, None)
            }
            Request::IdentifyRemoteRevisionHigh(high) => {
                let revision = id.revision_number;
                let in_range = matches!(progress, RevisionLow(low) if low <= revision && revision <= high);
                (if in_range { RevisionInRange } else { Idle }, None)
            }
            Request::IdentifyRemoteSerialLow(low) => {
                (if progress == RevisionInRange { SerialLow(low) } else { Idle }, None)
            }
            Request::IdentifyRemoteSerialHigh(high) => {
                let serial = id.serial_number;
                let in_range = matches!(progress, SerialLow(low) if low <= serial && serial <= high);
                (Idle, in_range.then_some(Response::IdentifySlave))
            }
            Request::IdentifyNonConfiguredRemoteSlave => {
                (Idle, self.is_non_configured().then_some(Response::IdentifyNonConfiguredSlave))
            }
            Request::SwitchStateGlobal(_)
            | Request::SwitchStateSelective { .. }
            | Request::ConfigureNodeId(_)
            | Request::ConfigureBitTiming(_)
            | Request::ActivateBitTiming { .. }
            | Request::StoreConfiguration
            | Request::Fastscan(_)
            | Request::InquireIdentity(_)
            | Request::InquireNodeId
            | Request::Unknown(_) => (Idle, None),
        };
        self.identification = next;
        response
    }

    /// The transition from LSS waiting.
    fn in_waiting(&self, selection: Selection, fastscan: LssField, request: Request) -> (LssState, Option<Response>) {
        // Whatever is not the next selective frame ends the selective sequence.
        let stay = LssState::Waiting { selection: Selection::Idle, fastscan };
        match request {
            Request::SwitchStateGlobal(SwitchMode::Waiting) => (LssState::WAITING, None),
            Request::SwitchStateGlobal(SwitchMode::Configuration) => (LssState::Configuration, None),
            Request::SwitchStateSelective { field, value } => {
                match selection.after(field, value == self.identity.field(field)) {
                    SelectionStep::Progress(selection) => (LssState::Waiting { selection, fastscan }, None),
                    SelectionStep::Selected => (LssState::Configuration, Some(Response::SwitchStateSelective)),
                }
            }
            Request::Fastscan(scan) if self.is_non_configured() => self.fastscan(fastscan, scan),
            Request::Fastscan(_) => (stay, None),
            // Served in both states by `identify`.
            Request::IdentifyRemoteVendorId(_)
            | Request::IdentifyRemoteProductCode(_)
            | Request::IdentifyRemoteRevisionLow(_)
            | Request::IdentifyRemoteRevisionHigh(_)
            | Request::IdentifyRemoteSerialLow(_)
            | Request::IdentifyRemoteSerialHigh(_)
            | Request::IdentifyNonConfiguredRemoteSlave => (stay, None),
            // Configuration-state services, and unknown ones: ignored while waiting.
            Request::ConfigureNodeId(_)
            | Request::ConfigureBitTiming(_)
            | Request::ActivateBitTiming { .. }
            | Request::StoreConfiguration
            | Request::InquireIdentity(_)
            | Request::InquireNodeId
            | Request::Unknown(_) => (stay, None),
        }
    }

    /// One fastscan frame for a non-configured slave in waiting at position `position`
    /// (digest §12.4).
    fn fastscan(&self, position: LssField, scan: Fastscan) -> (LssState, Option<Response>) {
        let answer = Some(Response::IdentifySlave);
        match scan.bit_checked {
            BitChecked::Reset => {
                (LssState::Waiting { selection: Selection::Idle, fastscan: LssField::VendorId }, answer)
            }
            BitChecked::Bit(bit) => {
                let mask = u32::MAX.checked_shl(u32::from(bit)).unwrap_or(0);
                let own = self.identity.field(scan.sub);
                let matched = scan.sub == position && (own ^ scan.id_number) & mask == 0;
                let complete = bit == 0 && scan.sub == LssField::SerialNumber && scan.next == LssField::VendorId;
                match (matched, complete) {
                    (false, _) => (LssState::Waiting { selection: Selection::Idle, fastscan: position }, None),
                    (true, false) => {
                        (LssState::Waiting { selection: Selection::Idle, fastscan: scan.next }, answer)
                    }
                    (true, true) => (LssState::Configuration, answer),
                }
            }
        }
    }

    /// The transition from LSS configuration.
    fn in_configuration(&mut self, request: Request, hooks: &mut impl LssHooks) -> (LssState, Option<Response>) {
        let stay = LssState::Configuration;
        match request {
            Request::SwitchStateGlobal(SwitchMode::Waiting) => {
                if self.active_node_id == NODE_ID_UNCONFIGURED && is_valid_node_id(self.pending_node_id) {
                    hooks.continue_start_up(self.pending_node_id);
                }
                (LssState::WAITING, None)
            }
            Request::SwitchStateGlobal(SwitchMode::Configuration) => (stay, None),
            Request::ConfigureNodeId(node_id) => {
                let status = if is_valid_node_id(node_id) || node_id == NODE_ID_UNCONFIGURED {
                    self.pending_node_id = node_id;
                    ConfigureNodeIdStatus::Success
                } else {
                    ConfigureNodeIdStatus::NodeIdOutOfRange
                };
                (stay, Some(Response::ConfigureNodeId { status, specific: 0 }))
            }
            Request::ConfigureBitTiming(bit_timing) => {
                let status = if hooks.bit_timing_supported(bit_timing) {
                    self.pending_bit_timing = Some(bit_timing);
                    ConfigureBitTimingStatus::Success
                } else {
                    ConfigureBitTimingStatus::BitRateNotSupported
                };
                (stay, Some(Response::ConfigureBitTiming { status, specific: 0 }))
            }
            Request::ActivateBitTiming { switch_delay_ms } => {
                if let Some(bit_timing) = self.pending_bit_timing {
                    hooks.activate_bit_timing(bit_timing, switch_delay_ms);
                }
                (stay, None)
            }
            Request::StoreConfiguration => {
                let (status, specific) =
                    match hooks.store_configuration(self.pending_node_id, self.pending_bit_timing) {
                        Ok(()) => (StoreConfigurationStatus::Success, 0),
                        Err(error) => (error.status(), error.specific()),
                    };
                (stay, Some(Response::StoreConfiguration { status, specific }))
            }
            Request::InquireIdentity(field) => {
                (stay, Some(Response::InquireIdentity { field, value: self.identity.field(field) }))
            }
            Request::InquireNodeId => (stay, Some(Response::InquireNodeId(self.active_node_id))),
            // Waiting-state services: ignored in configuration.
            Request::SwitchStateSelective { .. } | Request::Fastscan(_) => (stay, None),
            // Served in both states by `identify`.
            Request::IdentifyRemoteVendorId(_)
            | Request::IdentifyRemoteProductCode(_)
            | Request::IdentifyRemoteRevisionLow(_)
            | Request::IdentifyRemoteRevisionHigh(_)
            | Request::IdentifyRemoteSerialLow(_)
            | Request::IdentifyRemoteSerialHigh(_)
            | Request::IdentifyNonConfiguredRemoteSlave => (stay, None),
            Request::Unknown(_) => (stay, None),
        }
    }
}
