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
