//! The one logging shim of the crate.
//!
//! Every log call of the core goes through these macros. What they become is chosen by cargo
//! feature, never by the call site:
//!
//! - `defmt`: a `defmt` call (the arguments are deferred-formatted on the host; every type
//!   logged implements `defmt::Format`);
//! - `log`: a call of the `log` facade, for host builds (simulators, tests, Linux programs);
//!   every type logged implements `Debug`;
//! - neither: nothing at all. The macro expands to an empty block, so the arguments are not
//!   even evaluated and a build without either feature carries no trace of logging (the
//!   footprint budgets check this).
//!
//! Both features may be on together (each gets every call). Format strings use only `{}` and
//! `{:?}` (both `core::fmt` and defmt accept them, and defmt treats them alike); values are
//! passed by value or reference, never computed for the log alone, so that the call sites read
//! the same in every build.
#![allow(unused_macros)]

macro_rules! trace {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::trace!($($arg)*);
        #[cfg(feature = "log")]
        log::trace!(target: "canopen_drive", $($arg)*);
    }};
}

macro_rules! debug {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::debug!($($arg)*);
        #[cfg(feature = "log")]
        log::debug!(target: "canopen_drive", $($arg)*);
    }};
}

macro_rules! info {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::info!($($arg)*);
        #[cfg(feature = "log")]
        log::info!(target: "canopen_drive", $($arg)*);
    }};
}

macro_rules! warning {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::warn!($($arg)*);
        #[cfg(feature = "log")]
        log::warn!(target: "canopen_drive", $($arg)*);
    }};
}

macro_rules! error {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::error!($($arg)*);
        #[cfg(feature = "log")]
        log::error!(target: "canopen_drive", $($arg)*);
    }};
}

#[allow(unused_imports)]
pub(crate) use {debug, error, info, trace, warning};

/// `defmt::Format` of the bitflags types: their name and raw bits (bitflags' own types cannot
/// derive it; the host's `Debug` names the flags).
#[cfg(feature = "defmt")]
mod bitflags_format {
    use crate::cia402::probe::Changed;
    use crate::comm::emcy::ErrorRegister;
    use crate::hal::{DigitalInputs, HardwareFaults};

    impl defmt::Format for DigitalInputs {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "DigitalInputs({=u32:#x})", self.bits());
        }
    }

    impl defmt::Format for HardwareFaults {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "HardwareFaults({=u32:#x})", self.bits());
        }
    }

    impl defmt::Format for ErrorRegister {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "ErrorRegister({=u8:#x})", self.bits());
        }
    }

    impl defmt::Format for crate::CanFrame {
        fn format(&self, f: defmt::Formatter<'_>) {
            use embedded_can::Frame;
            match self.id() {
                embedded_can::Id::Standard(id) => defmt::write!(f, "{=u16:03X}#", id.as_raw()),
                embedded_can::Id::Extended(id) => defmt::write!(f, "{=u32:08X}#", id.as_raw()),
            }
            if self.is_remote_frame() {
                defmt::write!(f, "R{=usize}", self.dlc());
            } else {
                for byte in self.data() {
                    defmt::write!(f, "{=u8:02X}", *byte);
                }
            }
        }
    }

    impl defmt::Format for Changed {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "Changed({=u8:#x})", self.bits());
        }
    }
}
