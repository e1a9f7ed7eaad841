//! LSS slave (CiA 305): the node-ID and the bit rate set over the bus.
//!
//! Requests arrive on COB-ID 0x7E5, answers leave on 0x7E4, always eight bytes; the frame
//! layouts are in [`crate::wire::lss`]. The LSS state is independent of the NMT state: the drive
//! hands every 0x7E5 frame to [`LssSlave::on_request`] in every NMT state, also while its
//! node-ID is 0xFF ("non-configured": CAN + LSS only, no boot-up; CiA 305).
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
//! until the next reset communication (CiA 305).
//!
//! ## Decisions where CiA 305 leaves room
//!
//! - *Frames*: a frame that is not eight bytes long or carries an out-of-range parameter is
//!   not answered ([`crate::wire::lss::ParseError`]).
//! - *Sequences*: switch state selective must arrive in the order vendor → product → revision
//!   → serial, identify remote slave in the order 0x46 → 0x4B. Any other frame on 0x7E5,
//!   including an unknown or malformed one, ends the sequence in progress; a vendor-ID frame
//!   always starts a new one. A mismatching field ends it too, so the slave stays silent.
//! - *Non-configured* means active **and** pending node-ID are 0xFF (identify non-configured,
//!   CiA 305). Only such a slave, and only in waiting, takes part in fastscan: once a fastscan-found slave has been given a node-ID it no longer answers,
//!   even before its next reset communication.
//! - *Fastscan* follows CiA 305 exactly. A probe matches when LSSSub is the slave's
//!   position LSSPos and bits 31..BitChecked agree; the slave answers 0x4F and moves to
//!   LSSNext. It enters configuration only on a match with BitChecked 0, LSSSub 3 (serial)
//!   and LSSNext 0, never at the end of an earlier field (CANopenNode's "LSSNext < LSSSub" test
//!   does, see CANopenNode PR #647). BitChecked 0x80 resets LSSPos to the vendor-ID and is
//!   answered. Entering waiting resets LSSPos as well.
//! - *Identify remote slave* is answered in both LSS states (as lely does; CiA 305 is not explicit);
//!   vendor-ID and product code must be equal, revision and serial number within the
//!   inclusive bounds. Identify non-configured is answered in both states.
//! - *Bit timing*: table selector 0 with the table of CiA 305 is the standard. Whether an
//!   entry is supported is up to [`LssHooks::bit_timing_supported`]; the default accepts the
//!   eight fixed rates of table 0 and refuses index 5 (100 kbit/s: reserved in CiA 305 v3,
//!   optional per CiA 305), index 9 (automatic detection needs hardware support),
//!   reserved indices and every other table (a [`Drive`](crate::Drive) accepts the rates of
//!   [`Config::bit_rates`](crate::Config::bit_rates), which its EDS lists). Refused → error 1,
//!   the pending bit timing stays.
//! - *Activate bit timing* is obeyed in configuration only and only once a bit timing has
//!   been configured (before that the pending bit timing is the active one, nothing to
//!   switch). The hook gets the bit timing and the switch delay; the board waits the delay,
//!   switches, and stays silent for another delay (CiA 305).
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

use crate::wire::lss::{
    BitChecked, ConfigureBitTimingStatus, ConfigureNodeIdStatus, Fastscan, Request, Response,
    StoreConfigurationStatus, SwitchMode,
};
pub use crate::wire::lss::{BitRate, BitTiming, LssAddress, LssField, NODE_ID_UNCONFIGURED};

/// True for the node-IDs a configured node may have, 1..=127.
pub const fn is_valid_node_id(node_id: u8) -> bool {
    matches!(node_id, 1..=127)
}

/// The bit rates a drive runs at unless its configuration says otherwise
/// ([`Config::bit_rates`](crate::Config::bit_rates)): 125, 250, 500 and 1000 kbit/s.
pub const DEFAULT_BIT_RATES: [BitRate; 4] =
    [BitRate::Kbit1000, BitRate::Kbit500, BitRate::Kbit250, BitRate::Kbit125];

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

/// The LSS state of the slave (CiA 305), with the progress of the waiting-state services.
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
    pub const WAITING: LssState =
        LssState::Waiting { selection: Selection::Idle, fastscan: LssField::VendorId };
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
#[non_exhaustive]
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

    /// Sets the pending node-ID from the device side (a vendor object that configures the
    /// node-ID, say), as configure node-ID would: active after the next
    /// [`Self::activate_pending`]. Refuses (false) anything but 1..=127.
    pub fn set_pending_node_id(&mut self, node_id: u8) -> bool {
        if !(1..=127).contains(&node_id) {
            return false;
        }
        self.pending_node_id = node_id;
        true
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
            Request::IdentifyRemoteVendorId(value) => {
                (if value == id.vendor_id { VendorIdMatched } else { Idle }, None)
            }
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
    fn in_waiting(
        &self,
        selection: Selection,
        fastscan: LssField,
        request: Request,
    ) -> (LssState, Option<Response>) {
        // Whatever is not the next selective frame ends the selective sequence.
        let stay = LssState::Waiting { selection: Selection::Idle, fastscan };
        match request {
            Request::SwitchStateGlobal(SwitchMode::Waiting) => (LssState::WAITING, None),
            Request::SwitchStateGlobal(SwitchMode::Configuration) => (LssState::Configuration, None),
            Request::SwitchStateSelective { field, value } => {
                match selection.after(field, value == self.identity.field(field)) {
                    SelectionStep::Progress(selection) => (LssState::Waiting { selection, fastscan }, None),
                    SelectionStep::Selected => {
                        (LssState::Configuration, Some(Response::SwitchStateSelective))
                    }
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
    /// (CiA 305).
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
                let complete =
                    bit == 0 && scan.sub == LssField::SerialNumber && scan.next == LssField::VendorId;
                match (matched, complete) {
                    (false, _) => {
                        (LssState::Waiting { selection: Selection::Idle, fastscan: position }, None)
                    }
                    (true, false) => {
                        (LssState::Waiting { selection: Selection::Idle, fastscan: scan.next }, answer)
                    }
                    (true, true) => (LssState::Configuration, answer),
                }
            }
        }
    }

    /// The transition from LSS configuration.
    fn in_configuration(
        &mut self,
        request: Request,
        hooks: &mut impl LssHooks,
    ) -> (LssState, Option<Response>) {
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

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec::Vec;

    use super::*;
    use crate::wire::lss::{LSS_REQUEST_COB_ID, LSS_RESPONSE_COB_ID};

    const IDENTITY: LssAddress = LssAddress {
        vendor_id: 0x0000_0A5C,
        product_code: 0x0402_0001,
        revision_number: 0x0002_0003,
        serial_number: 0x1234_5678,
    };

    /// Hooks that record what the slave asked for.
    #[derive(Debug, Default)]
    struct Recorder {
        supports_100k: bool,
        store_result: Option<Result<(), StoreError>>,
        stored: Vec<(u8, Option<BitTiming>)>,
        activated: Vec<(BitTiming, u16)>,
        start_ups: Vec<u8>,
    }

    impl LssHooks for Recorder {
        fn bit_timing_supported(&self, bit_timing: BitTiming) -> bool {
            is_fixed_standard_rate(bit_timing)
                || (self.supports_100k && bit_timing == BitTiming::standard(BitRate::Kbit100))
        }
        fn activate_bit_timing(&mut self, bit_timing: BitTiming, switch_delay_ms: u16) {
            self.activated.push((bit_timing, switch_delay_ms));
        }
        fn store_configuration(
            &mut self,
            node_id: u8,
            bit_timing: Option<BitTiming>,
        ) -> Result<(), StoreError> {
            self.stored.push((node_id, bit_timing));
            self.store_result.unwrap_or(Err(StoreError::NotSupported))
        }
        fn continue_start_up(&mut self, node_id: u8) {
            self.start_ups.push(node_id);
        }
    }

    /// Sends a request as frame bytes and parses the answer.
    fn send(slave: &mut LssSlave, hooks: &mut impl LssHooks, request: Request) -> Option<Response> {
        slave.on_request(&request.emit(), hooks).map(|bytes| Response::parse(&bytes).unwrap())
    }

    fn configuration(slave: &mut LssSlave, hooks: &mut impl LssHooks) {
        assert_eq!(send(slave, hooks, Request::SwitchStateGlobal(SwitchMode::Configuration)), None);
        assert_eq!(slave.state(), LssState::Configuration);
    }

    fn selective(field: LssField, value: u32) -> Request {
        Request::SwitchStateSelective { field, value }
    }

    fn selective_sequence(address: LssAddress) -> [Request; 4] {
        LssField::ALL.map(|field| selective(field, address.field(field)))
    }

    fn node_id_status(status: ConfigureNodeIdStatus) -> Option<Response> {
        Some(Response::ConfigureNodeId { status, specific: 0 })
    }

    #[test]
    fn cob_ids() {
        assert_eq!(LSS_REQUEST_COB_ID, 0x7E5);
        assert_eq!(LSS_RESPONSE_COB_ID, 0x7E4);
    }

    #[test]
    fn construction() {
        let slave = LssSlave::new(IDENTITY, 5);
        assert_eq!(slave.state(), LssState::WAITING);
        assert_eq!((slave.pending_node_id(), slave.active_node_id()), (5, 5));
        assert_eq!(slave.identity(), IDENTITY);
        assert_eq!(slave.pending_bit_timing(), None);
        assert!(!slave.is_non_configured());
        assert!(LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED).is_non_configured());
        // Out-of-range node-IDs are taken as non-configured.
        for node_id in [0, 128, 0xFE] {
            let slave = LssSlave::new(IDENTITY, node_id);
            assert_eq!((slave.pending_node_id(), slave.active_node_id()), (0xFF, 0xFF));
        }
    }

    #[test]
    fn switch_state_global_both_ways_without_answer() {
        let mut slave = LssSlave::new(IDENTITY, 5);
        let hooks = &mut Recorder::default();
        configuration(&mut slave, hooks);
        // Again: stays.
        configuration(&mut slave, hooks);
        assert_eq!(send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting)), None);
        assert_eq!(slave.state(), LssState::WAITING);
        // A configured slave does not restart its start-up.
        assert!(hooks.start_ups.is_empty());
        // A reserved mode is no request.
        assert_eq!(slave.on_request(&[0x04, 0x02, 0, 0, 0, 0, 0, 0], hooks), None);
        assert_eq!(slave.state(), LssState::WAITING);
    }

    #[test]
    fn switch_state_selective_matching() {
        let mut slave = LssSlave::new(IDENTITY, 5);
        let hooks = &mut ();
        let [vendor, product, revision, serial] = selective_sequence(IDENTITY);
        assert_eq!(send(&mut slave, hooks, vendor), None);
        assert_eq!(
            slave.state(),
            LssState::Waiting { selection: Selection::VendorIdMatched, fastscan: LssField::VendorId }
        );
        assert_eq!(send(&mut slave, hooks, product), None);
        assert_eq!(send(&mut slave, hooks, revision), None);
        assert_eq!(
            slave.state(),
            LssState::Waiting { selection: Selection::RevisionNumberMatched, fastscan: LssField::VendorId }
        );
        assert_eq!(slave.on_request(&serial.emit(), hooks), Some([0x44, 0, 0, 0, 0, 0, 0, 0]));
        assert_eq!(slave.state(), LssState::Configuration);
        // Selective frames are not served in configuration: no second answer.
        for request in selective_sequence(IDENTITY) {
            assert_eq!(send(&mut slave, hooks, request), None);
        }
        assert_eq!(slave.state(), LssState::Configuration);
    }

    #[test]
    fn switch_state_selective_wrong_identity() {
        let hooks = &mut ();
        for field in LssField::ALL {
            let mut other = IDENTITY;
            other.set_field(field, IDENTITY.field(field) ^ 0x0000_0100);
            let mut slave = LssSlave::new(IDENTITY, 5);
            for request in selective_sequence(other) {
                assert_eq!(send(&mut slave, hooks, request), None, "{field:?}");
            }
            assert!(matches!(slave.state(), LssState::Waiting { .. }));
        }
    }

    #[test]
    fn switch_state_selective_interleaved_or_out_of_order() {
        let hooks = &mut ();
        let [vendor, product, revision, serial] = selective_sequence(IDENTITY);
        let interruptions = [
            Request::InquireNodeId,
            Request::Unknown(0x33),
            Request::IdentifyNonConfiguredRemoteSlave,
            Request::Fastscan(Fastscan {
                id_number: 0,
                bit_checked: BitChecked::Bit(31),
                sub: LssField::VendorId,
                next: LssField::VendorId,
            }),
            Request::SwitchStateGlobal(SwitchMode::Waiting),
            selective(LssField::ProductCode, IDENTITY.product_code),
        ];
        for interruption in interruptions {
            let mut slave = LssSlave::new(IDENTITY, 5);
            for request in [vendor, product, interruption, revision, serial] {
                assert_eq!(send(&mut slave, hooks, request), None, "{interruption:?}");
            }
            assert!(matches!(slave.state(), LssState::Waiting { .. }));
        }
        // A malformed frame (7 bytes) breaks off too.
        let mut slave = LssSlave::new(IDENTITY, 5);
        send(&mut slave, hooks, vendor);
        send(&mut slave, hooks, product);
        assert_eq!(slave.on_request(&[0x42, 0, 0, 0, 0, 0, 0], hooks), None);
        assert_eq!(send(&mut slave, hooks, revision), None);
        assert_eq!(send(&mut slave, hooks, serial), None);
        // Out of order: product first, serial before revision.
        let mut slave = LssSlave::new(IDENTITY, 5);
        for request in [product, vendor, revision, serial] {
            assert_eq!(send(&mut slave, hooks, request), None);
        }
        for request in [vendor, product, serial, revision] {
            assert_eq!(send(&mut slave, hooks, request), None);
        }
        // A vendor-ID frame restarts the sequence; the complete sequence then selects.
        for request in [vendor, product, vendor, product, revision] {
            assert_eq!(send(&mut slave, hooks, request), None);
        }
        assert_eq!(send(&mut slave, hooks, serial), Some(Response::SwitchStateSelective));
    }

    #[test]
    fn switch_state_selective_picks_one_of_several() {
        let hooks = &mut ();
        let mut other = IDENTITY;
        other.serial_number += 1;
        let mut slaves = [LssSlave::new(IDENTITY, 5), LssSlave::new(other, 6)];
        let mut answers = Vec::new();
        for request in selective_sequence(other) {
            for slave in slaves.iter_mut() {
                answers.extend(send(slave, hooks, request));
            }
        }
        assert_eq!(answers, [Response::SwitchStateSelective]);
        assert!(matches!(slaves[0].state(), LssState::Waiting { .. }));
        assert_eq!(slaves[1].state(), LssState::Configuration);
    }

    #[test]
    fn configure_node_id() {
        let mut slave = LssSlave::new(IDENTITY, 5);
        let hooks = &mut Recorder::default();
        // Not served while waiting.
        assert_eq!(send(&mut slave, hooks, Request::ConfigureNodeId(9)), None);
        assert_eq!(slave.pending_node_id(), 5);
        configuration(&mut slave, hooks);
        assert_eq!(
            slave.on_request(&Request::ConfigureNodeId(9).emit(), hooks),
            Some([0x11, 0, 0, 0, 0, 0, 0, 0])
        );
        assert_eq!((slave.pending_node_id(), slave.active_node_id()), (9, 5));
        // 0 and 128.. are out of range; the pending node-ID stays.
        for bad in [0u8, 128, 200, 0xFE] {
            assert_eq!(
                send(&mut slave, hooks, Request::ConfigureNodeId(bad)),
                node_id_status(ConfigureNodeIdStatus::NodeIdOutOfRange)
            );
            assert_eq!(slave.pending_node_id(), 9);
        }
        assert_eq!(
            slave.on_request(&Request::ConfigureNodeId(128).emit(), hooks),
            Some([0x11, 1, 0, 0, 0, 0, 0, 0])
        );
        for good in [1u8, 127] {
            assert_eq!(
                send(&mut slave, hooks, Request::ConfigureNodeId(good)),
                node_id_status(ConfigureNodeIdStatus::Success)
            );
            assert_eq!(slave.pending_node_id(), good);
        }
        // 0xFF: the node will be non-configured after the next reset communication.
        assert_eq!(
            send(&mut slave, hooks, Request::ConfigureNodeId(0xFF)),
            node_id_status(ConfigureNodeIdStatus::Success)
        );
        assert_eq!((slave.pending_node_id(), slave.active_node_id()), (0xFF, 5));
        assert!(!slave.is_non_configured());
        // A configured slave keeps its node-ID when switched to waiting.
        send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting));
        assert!(hooks.start_ups.is_empty());
        assert_eq!(slave.active_node_id(), 5);
        assert_eq!(slave.activate_pending(), 0xFF);
        assert!(slave.is_non_configured());
        assert_eq!(slave.state(), LssState::WAITING);
    }

    #[test]
    fn non_configured_slave_continues_start_up_when_back_to_waiting() {
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        let hooks = &mut Recorder::default();
        configuration(&mut slave, hooks);
        // Without a node-ID, back to waiting changes nothing.
        send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting));
        assert!(hooks.start_ups.is_empty());
        configuration(&mut slave, hooks);
        send(&mut slave, hooks, Request::ConfigureNodeId(0x22));
        assert_eq!(slave.active_node_id(), 0xFF);
        send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting));
        assert_eq!(hooks.start_ups, [0x22]);
        // The drive's reset communication.
        assert_eq!(slave.activate_pending(), 0x22);
        assert_eq!(slave.active_node_id(), 0x22);
        // Waiting again while already waiting: no second start-up.
        send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting));
        assert_eq!(hooks.start_ups, [0x22]);
    }

    #[test]
    fn inquire_services() {
        let mut slave = LssSlave::new(IDENTITY, 0x21);
        let hooks = &mut ();
        // Not served while waiting.
        assert_eq!(send(&mut slave, hooks, Request::InquireNodeId), None);
        for field in LssField::ALL {
            assert_eq!(send(&mut slave, hooks, Request::InquireIdentity(field)), None);
        }
        configuration(&mut slave, hooks);
        for field in LssField::ALL {
            assert_eq!(
                send(&mut slave, hooks, Request::InquireIdentity(field)),
                Some(Response::InquireIdentity { field, value: IDENTITY.field(field) })
            );
        }
        assert_eq!(
            slave.on_request(&Request::InquireIdentity(LssField::SerialNumber).emit(), hooks),
            Some([0x5D, 0x78, 0x56, 0x34, 0x12, 0, 0, 0])
        );
        assert_eq!(
            slave.on_request(&Request::InquireNodeId.emit(), hooks),
            Some([0x5E, 0x21, 0, 0, 0, 0, 0, 0])
        );
        // Inquire node-ID reports the active node-ID, not the pending one.
        send(&mut slave, hooks, Request::ConfigureNodeId(0x30));
        assert_eq!(send(&mut slave, hooks, Request::InquireNodeId), Some(Response::InquireNodeId(0x21)));
        let mut unconfigured = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        configuration(&mut unconfigured, hooks);
        assert_eq!(
            send(&mut unconfigured, hooks, Request::InquireNodeId),
            Some(Response::InquireNodeId(0xFF))
        );
    }

    fn identify(
        slave: &mut LssSlave,
        vendor: u32,
        product: u32,
        revision: (u32, u32),
        serial: (u32, u32),
    ) -> Vec<Response> {
        let hooks = &mut ();
        [
            Request::IdentifyRemoteVendorId(vendor),
            Request::IdentifyRemoteProductCode(product),
            Request::IdentifyRemoteRevisionLow(revision.0),
            Request::IdentifyRemoteRevisionHigh(revision.1),
            Request::IdentifyRemoteSerialLow(serial.0),
            Request::IdentifyRemoteSerialHigh(serial.1),
        ]
        .into_iter()
        .filter_map(|request| send(slave, hooks, request))
        .collect()
    }

    #[test]
    fn identify_remote_slave_in_ranges() {
        let (v, p, r, s) =
            (IDENTITY.vendor_id, IDENTITY.product_code, IDENTITY.revision_number, IDENTITY.serial_number);
        let mut slave = LssSlave::new(IDENTITY, 5);
        // Only the last frame is answered; bounds are inclusive.
        assert_eq!(identify(&mut slave, v, p, (0, u32::MAX), (0, u32::MAX)), [Response::IdentifySlave]);
        assert_eq!(identify(&mut slave, v, p, (r, r), (s, s)), [Response::IdentifySlave]);
        assert_eq!(identify(&mut slave, v, p, (r - 1, r + 1), (s - 10, s + 10)), [Response::IdentifySlave]);
        // The LSS state does not change, and configuration serves it too.
        assert_eq!(slave.state(), LssState::WAITING);
        configuration(&mut slave, &mut ());
        assert_eq!(identify(&mut slave, v, p, (r, r), (s, s)), [Response::IdentifySlave]);
        assert_eq!(slave.state(), LssState::Configuration);
        assert_eq!(
            slave.on_request(&Request::IdentifyRemoteSerialHigh(s).emit(), &mut ()),
            None,
            "the last frame alone identifies nothing"
        );
    }

    #[test]
    fn identify_remote_slave_out_of_ranges() {
        let (v, p, r, s) =
            (IDENTITY.vendor_id, IDENTITY.product_code, IDENTITY.revision_number, IDENTITY.serial_number);
        let mut slave = LssSlave::new(IDENTITY, 5);
        let none: [Response; 0] = [];
        assert_eq!(identify(&mut slave, v + 1, p, (0, u32::MAX), (0, u32::MAX)), none);
        assert_eq!(identify(&mut slave, v, p + 1, (0, u32::MAX), (0, u32::MAX)), none);
        assert_eq!(identify(&mut slave, v, p, (r + 1, u32::MAX), (0, u32::MAX)), none);
        assert_eq!(identify(&mut slave, v, p, (0, r - 1), (0, u32::MAX)), none);
        assert_eq!(identify(&mut slave, v, p, (0, u32::MAX), (s + 1, u32::MAX)), none);
        assert_eq!(identify(&mut slave, v, p, (0, u32::MAX), (0, s - 1)), none);
        // Low above high matches nothing.
        assert_eq!(identify(&mut slave, v, p, (r + 1, r - 1), (0, u32::MAX)), none);
        // An interleaved frame breaks the sequence off.
        let hooks = &mut ();
        for request in [
            Request::IdentifyRemoteVendorId(v),
            Request::IdentifyRemoteProductCode(p),
            Request::IdentifyRemoteRevisionLow(0),
            Request::InquireNodeId,
            Request::IdentifyRemoteRevisionHigh(u32::MAX),
            Request::IdentifyRemoteSerialLow(0),
            Request::IdentifyRemoteSerialHigh(u32::MAX),
        ] {
            assert_eq!(send(&mut slave, hooks, request), None);
        }
        // Still works afterwards.
        assert_eq!(identify(&mut slave, v, p, (r, r), (s, s)), [Response::IdentifySlave]);
    }

    #[test]
    fn identify_non_configured_remote_slave() {
        let hooks = &mut ();
        let request = Request::IdentifyNonConfiguredRemoteSlave;
        let mut unconfigured = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        assert_eq!(unconfigured.on_request(&request.emit(), hooks), Some([0x50, 0, 0, 0, 0, 0, 0, 0]));
        let mut configured = LssSlave::new(IDENTITY, 5);
        assert_eq!(send(&mut configured, hooks, request), None);
        // Served in configuration as well.
        configuration(&mut unconfigured, hooks);
        assert_eq!(send(&mut unconfigured, hooks, request), Some(Response::IdentifyNonConfiguredSlave));
        // Once a node-ID is pending, the slave no longer counts as non-configured.
        send(&mut unconfigured, hooks, Request::ConfigureNodeId(3));
        assert_eq!(send(&mut unconfigured, hooks, request), None);
        // A configured node given 0xFF becomes non-configured only after activation.
        configuration(&mut configured, hooks);
        send(&mut configured, hooks, Request::ConfigureNodeId(0xFF));
        assert_eq!(send(&mut configured, hooks, request), None);
        configured.activate_pending();
        assert_eq!(send(&mut configured, hooks, request), Some(Response::IdentifyNonConfiguredSlave));
    }

    #[test]
    fn bit_timing_configuration() {
        let mut slave = LssSlave::new(IDENTITY, 5);
        let hooks = &mut Recorder::default();
        let request = |timing| Request::ConfigureBitTiming(timing);
        let ok =
            Some(Response::ConfigureBitTiming { status: ConfigureBitTimingStatus::Success, specific: 0 });
        let unsupported = Some(Response::ConfigureBitTiming {
            status: ConfigureBitTimingStatus::BitRateNotSupported,
            specific: 0,
        });
        // Not served while waiting.
        assert_eq!(send(&mut slave, hooks, request(BitTiming::standard(BitRate::Kbit250))), None);
        configuration(&mut slave, hooks);
        for rate in BitRate::ALL {
            let expected = match rate {
                BitRate::Kbit100 | BitRate::Automatic => unsupported,
                _ => ok,
            };
            assert_eq!(send(&mut slave, hooks, request(BitTiming::standard(rate))), expected, "{rate:?}");
        }
        // The last supported one is pending; refused ones do not replace it.
        assert_eq!(slave.pending_bit_timing(), Some(BitTiming::standard(BitRate::Kbit10)));
        for timing in [
            BitTiming { table_selector: 0, table_index: 10 },
            BitTiming { table_selector: 0, table_index: 0xFF },
            BitTiming { table_selector: 1, table_index: 0 },
            BitTiming { table_selector: 0x80, table_index: 0 },
        ] {
            assert_eq!(send(&mut slave, hooks, request(timing)), unsupported);
        }
        assert_eq!(
            slave.on_request(&request(BitTiming::standard(BitRate::Kbit100)).emit(), hooks),
            Some([0x13, 1, 0, 0, 0, 0, 0, 0])
        );
        assert_eq!(slave.pending_bit_timing(), Some(BitTiming::standard(BitRate::Kbit10)));
        // A board with 100 kbit/s hardware support opts in.
        hooks.supports_100k = true;
        assert_eq!(
            slave.on_request(&request(BitTiming::standard(BitRate::Kbit100)).emit(), hooks),
            Some([0x13, 0, 0, 0, 0, 0, 0, 0])
        );
        assert_eq!(slave.pending_bit_timing(), Some(BitTiming::standard(BitRate::Kbit100)));
        // Default hooks behave the same for the fixed rates.
        assert_eq!(send(&mut slave, &mut (), request(BitTiming::standard(BitRate::Kbit100))), unsupported);
        assert_eq!(send(&mut slave, &mut (), request(BitTiming::standard(BitRate::Kbit500))), ok);
    }

    #[test]
    fn activate_bit_timing_calls_the_hook_with_the_delay() {
        let mut slave = LssSlave::new(IDENTITY, 5);
        let hooks = &mut Recorder::default();
        let activate = Request::ActivateBitTiming { switch_delay_ms: 250 };
        configuration(&mut slave, hooks);
        // Nothing configured yet: nothing to switch to.
        assert_eq!(send(&mut slave, hooks, activate), None);
        assert!(hooks.activated.is_empty());
        send(&mut slave, hooks, Request::ConfigureBitTiming(BitTiming::standard(BitRate::Kbit125)));
        // No answer: the bus is about to change.
        assert_eq!(slave.on_request(&[0x15, 0xFA, 0x00, 0, 0, 0, 0, 0], hooks), None);
        assert_eq!(hooks.activated, [(BitTiming::standard(BitRate::Kbit125), 250)]);
        assert_eq!(slave.state(), LssState::Configuration);
        // Not served while waiting.
        send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting));
        assert_eq!(send(&mut slave, hooks, Request::ActivateBitTiming { switch_delay_ms: 7 }), None);
        assert_eq!(hooks.activated.len(), 1);
    }

    #[test]
    fn store_configuration_through_the_hooks() {
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        let store = Request::StoreConfiguration;
        let status = |status, specific| Some(Response::StoreConfiguration { status, specific });
        // Not served while waiting.
        let hooks = &mut Recorder::default();
        assert_eq!(send(&mut slave, hooks, store), None);
        assert!(hooks.stored.is_empty());
        configuration(&mut slave, hooks);
        // Default hooks: not supported.
        assert_eq!(slave.on_request(&store.emit(), &mut ()), Some([0x17, 1, 0, 0, 0, 0, 0, 0]));
        send(&mut slave, hooks, Request::ConfigureNodeId(0x12));
        assert_eq!(send(&mut slave, hooks, store), status(StoreConfigurationStatus::NotSupported, 0));
        hooks.store_result = Some(Ok(()));
        assert_eq!(send(&mut slave, hooks, store), status(StoreConfigurationStatus::Success, 0));
        send(&mut slave, hooks, Request::ConfigureBitTiming(BitTiming::standard(BitRate::Kbit500)));
        assert_eq!(slave.on_request(&store.emit(), hooks), Some([0x17, 0, 0, 0, 0, 0, 0, 0]));
        hooks.store_result = Some(Err(StoreError::StorageMediaAccess));
        assert_eq!(slave.on_request(&store.emit(), hooks), Some([0x17, 2, 0, 0, 0, 0, 0, 0]));
        hooks.store_result = Some(Err(StoreError::ManufacturerSpecific(0x5A)));
        assert_eq!(slave.on_request(&store.emit(), hooks), Some([0x17, 0xFF, 0x5A, 0, 0, 0, 0, 0]));
        let bit_timing = Some(BitTiming::standard(BitRate::Kbit500));
        assert_eq!(
            hooks.stored,
            [(0x12, None), (0x12, None), (0x12, bit_timing), (0x12, bit_timing), (0x12, bit_timing)]
        );
        // Storing activates nothing.
        assert_eq!(slave.active_node_id(), 0xFF);
    }

    fn probe(id_number: u32, bit: u8, sub: LssField, next: LssField) -> Request {
        Request::Fastscan(Fastscan { id_number, bit_checked: BitChecked::Bit(bit), sub, next })
    }

    const FASTSCAN_RESET_REQUEST: Request = Request::Fastscan(Fastscan {
        id_number: 0,
        bit_checked: BitChecked::Reset,
        sub: LssField::VendorId,
        next: LssField::VendorId,
    });

    #[test]
    fn fastscan_only_for_non_configured_slaves_in_waiting() {
        let hooks = &mut ();
        let mut configured = LssSlave::new(IDENTITY, 5);
        assert_eq!(send(&mut configured, hooks, FASTSCAN_RESET_REQUEST), None);
        assert_eq!(
            send(
                &mut configured,
                hooks,
                probe(IDENTITY.vendor_id, 0, LssField::VendorId, LssField::ProductCode)
            ),
            None
        );
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        assert_eq!(
            slave.on_request(&FASTSCAN_RESET_REQUEST.emit(), hooks),
            Some([0x4F, 0, 0, 0, 0, 0, 0, 0])
        );
        configuration(&mut slave, hooks);
        assert_eq!(send(&mut slave, hooks, FASTSCAN_RESET_REQUEST), None);
        // Invalid BitChecked: no request.
        send(&mut slave, hooks, Request::SwitchStateGlobal(SwitchMode::Waiting));
        assert_eq!(slave.on_request(&[0x51, 0, 0, 0, 0, 32, 0, 0], hooks), None);
    }

    #[test]
    fn fastscan_compares_bits_down_to_bit_checked_at_the_position() {
        let hooks = &mut ();
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        let vendor = IDENTITY.vendor_id; // 0x0000_0A5C
        assert_eq!(send(&mut slave, hooks, FASTSCAN_RESET_REQUEST), Some(Response::IdentifySlave));
        // Bits 31..12 of 0x0A5C are 0: a guess of 0 matches down to bit 12, not bit 11.
        assert_eq!(
            send(&mut slave, hooks, probe(0, 12, LssField::VendorId, LssField::VendorId)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(send(&mut slave, hooks, probe(0, 11, LssField::VendorId, LssField::VendorId)), None);
        assert_eq!(
            send(&mut slave, hooks, probe(0x800, 11, LssField::VendorId, LssField::VendorId)),
            Some(Response::IdentifySlave)
        );
        // Bits below BitChecked are don't-care.
        assert_eq!(
            send(&mut slave, hooks, probe(vendor ^ 0x7, 3, LssField::VendorId, LssField::VendorId)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(
            send(&mut slave, hooks, probe(vendor ^ 0x8, 3, LssField::VendorId, LssField::VendorId)),
            None
        );
        // A probe of another field than the position is not answered.
        assert_eq!(
            send(
                &mut slave,
                hooks,
                probe(IDENTITY.product_code, 0, LssField::ProductCode, LssField::RevisionNumber)
            ),
            None
        );
        assert_eq!(
            slave.state(),
            LssState::Waiting { selection: Selection::Idle, fastscan: LssField::VendorId }
        );
        // Confirmation moves the position to LSSNext.
        assert_eq!(
            send(&mut slave, hooks, probe(vendor, 0, LssField::VendorId, LssField::ProductCode)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(
            slave.state(),
            LssState::Waiting { selection: Selection::Idle, fastscan: LssField::ProductCode }
        );
        // Vendor probes are now ignored until a reset.
        assert_eq!(
            send(&mut slave, hooks, probe(vendor, 0, LssField::VendorId, LssField::ProductCode)),
            None
        );
        assert_eq!(send(&mut slave, hooks, FASTSCAN_RESET_REQUEST), Some(Response::IdentifySlave));
        assert_eq!(slave.state(), LssState::WAITING);
    }

    #[test]
    fn fastscan_enters_configuration_only_after_the_serial_field() {
        let hooks = &mut ();
        let (v, p, r, s) =
            (IDENTITY.vendor_id, IDENTITY.product_code, IDENTITY.revision_number, IDENTITY.serial_number);
        use LssField::*;
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        send(&mut slave, hooks, FASTSCAN_RESET_REQUEST);
        assert_eq!(
            send(&mut slave, hooks, probe(v, 0, VendorId, ProductCode)),
            Some(Response::IdentifySlave)
        );
        // A smaller LSSNext at the end of an earlier field is no complete match (CANopenNode
        // PR #647): the slave goes back to the vendor position and stays waiting.
        assert_eq!(
            send(&mut slave, hooks, probe(p, 0, ProductCode, VendorId)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(slave.state(), LssState::WAITING);
        // The serial field confirmed with LSSNext other than 0 is no complete match either.
        for next in [ProductCode, RevisionNumber, SerialNumber] {
            let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
            for request in [
                FASTSCAN_RESET_REQUEST,
                probe(v, 0, VendorId, ProductCode),
                probe(p, 0, ProductCode, RevisionNumber),
                probe(r, 0, RevisionNumber, SerialNumber),
                probe(s, 0, SerialNumber, next),
            ] {
                assert_eq!(send(&mut slave, hooks, request), Some(Response::IdentifySlave));
            }
            assert_eq!(slave.state(), LssState::Waiting { selection: Selection::Idle, fastscan: next });
        }
        // Serial matched only down to bit 1: not complete.
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        for request in [
            FASTSCAN_RESET_REQUEST,
            probe(v, 0, VendorId, ProductCode),
            probe(p, 0, ProductCode, RevisionNumber),
            probe(r, 0, RevisionNumber, SerialNumber),
            probe(s, 1, SerialNumber, VendorId),
        ] {
            assert_eq!(send(&mut slave, hooks, request), Some(Response::IdentifySlave));
        }
        assert!(matches!(slave.state(), LssState::Waiting { .. }));
        // The complete match.
        let mut slave = LssSlave::new(IDENTITY, NODE_ID_UNCONFIGURED);
        for request in [
            FASTSCAN_RESET_REQUEST,
            probe(v, 0, VendorId, ProductCode),
            probe(p, 0, ProductCode, RevisionNumber),
            probe(r, 0, RevisionNumber, SerialNumber),
        ] {
            send(&mut slave, hooks, request);
        }
        assert_eq!(
            slave.on_request(&probe(s, 0, SerialNumber, VendorId).emit(), hooks),
            Some([0x4F, 0, 0, 0, 0, 0, 0, 0])
        );
        assert_eq!(slave.state(), LssState::Configuration);
    }

    /// Every slave on one CAN bus, with its own hooks.
    struct Bus {
        slaves: Vec<(LssSlave, Recorder)>,
        frames: usize,
    }

    impl Bus {
        /// The master sends a request; every slave receives it; the answers are collected.
        fn send(&mut self, request: Request) -> Vec<Response> {
            self.frames += 1;
            let frame = request.emit();
            self.slaves
                .iter_mut()
                .filter_map(|(slave, hooks)| slave.on_request(&frame, hooks))
                .map(|bytes| Response::parse(&bytes).unwrap())
                .collect()
        }

        /// Identical answers collide into one frame on a real bus: "anyone answered?".
        fn answered(&mut self, request: Request) -> bool {
            let answers = self.send(request);
            assert!(answers.iter().all(|answer| *answer == Response::IdentifySlave));
            !answers.is_empty()
        }

        fn in_configuration(&self) -> usize {
            self.slaves.iter().filter(|(slave, _)| slave.state() == LssState::Configuration).count()
        }
    }

    /// The master side of fastscan as python-canopen runs it (CiA 305): a reset, then per
    /// field 32 probes from bit 31 down to bit 0 with the bit under test guessed 0, then a
    /// confirmation with the whole value and LSSNext = the next field (0 after the serial).
    fn master_fastscan(bus: &mut Bus) -> Option<LssAddress> {
        if !bus.answered(FASTSCAN_RESET_REQUEST) {
            return None;
        }
        let mut address = LssAddress::default();
        let mut next = LssField::VendorId;
        for (i, sub) in LssField::ALL.into_iter().enumerate() {
            let mut value = 0u32;
            for bit in (0..32u8).rev() {
                if !bus.answered(probe(value, bit, sub, next)) {
                    value |= 1 << bit;
                }
            }
            next = LssField::ALL[(i + 1) % 4];
            assert!(bus.answered(probe(value, 0, sub, next)), "confirmation of {sub:?}");
            address.set_field(sub, value);
        }
        Some(address)
    }

    #[test]
    fn fastscan_finds_every_non_configured_slave_on_a_shared_bus() {
        let identity = |serial_number| LssAddress { serial_number, ..IDENTITY };
        // Serial numbers sharing long prefixes, and one with a different product code.
        let unconfigured = [
            identity(0x1234_5679),
            identity(0x0000_0001),
            identity(0x1234_5678),
            LssAddress { product_code: 0x0402_0000, serial_number: 0xFFFF_FFFF, ..IDENTITY },
        ];
        let mut bus = Bus {
            slaves: unconfigured
                .iter()
                .map(|address| (LssSlave::new(*address, NODE_ID_UNCONFIGURED), Recorder::default()))
                .collect(),
            frames: 0,
        };
        // A configured slave with the smallest address never takes part.
        bus.slaves.push((LssSlave::new(identity(0), 0x7F), Recorder::default()));
        assert_eq!(bus.send(Request::IdentifyNonConfiguredRemoteSlave).len(), 4);

        let mut found = Vec::new();
        let mut node_id = 0x10;
        while let Some(address) = master_fastscan(&mut bus) {
            assert!(found.len() < unconfigured.len(), "found more slaves than there are");
            // Exactly the slave with that address is in configuration.
            assert_eq!(bus.in_configuration(), 1);
            assert_eq!(
                bus.send(Request::InquireIdentity(LssField::SerialNumber)),
                [Response::InquireIdentity { field: LssField::SerialNumber, value: address.serial_number }]
            );
            assert_eq!(
                bus.send(Request::ConfigureNodeId(node_id)),
                [Response::ConfigureNodeId { status: ConfigureNodeIdStatus::Success, specific: 0 }]
            );
            assert_eq!(bus.send(Request::SwitchStateGlobal(SwitchMode::Waiting)), []);
            assert_eq!(bus.in_configuration(), 0);
            found.push((address, node_id));
            node_id += 1;
            // The configured one stops answering at once (its node-ID is pending).
            assert_eq!(
                bus.send(Request::IdentifyNonConfiguredRemoteSlave).len(),
                unconfigured.len() - found.len()
            );
        }

        // Smallest 128-bit address first.
        let mut expected = unconfigured;
        expected.sort_by_key(|a| (a.vendor_id, a.product_code, a.revision_number, a.serial_number));
        let found_addresses: Vec<LssAddress> = found.iter().map(|(address, _)| *address).collect();
        assert_eq!(found_addresses, expected);
        // Each slave got its node-ID and asked the drive to continue its start-up.
        for (address, node_id) in &found {
            let (slave, hooks) =
                bus.slaves.iter_mut().find(|(slave, _)| slave.identity() == *address).unwrap();
            assert_eq!(slave.pending_node_id(), *node_id);
            assert_eq!(slave.active_node_id(), NODE_ID_UNCONFIGURED);
            assert_eq!(hooks.start_ups, [*node_id]);
            slave.activate_pending();
            assert_eq!(slave.active_node_id(), *node_id);
        }
        let configured = &bus.slaves[4];
        assert_eq!((configured.0.active_node_id(), configured.1.start_ups.len()), (0x7F, 0));
        // 1 reset + 4 × 33 probes per slave, plus the final unanswered reset.
        assert!(bus.frames > 4 * 133);
        assert!(!bus.answered(FASTSCAN_RESET_REQUEST));
    }
}
