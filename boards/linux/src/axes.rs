//! A node of several axes (`--axes N`): N CiA 402 logical devices on one node, each with a
//! simulated motor of its own.
//!
//! - Axis n runs the objects at 6000h + n × 800h (the library's multi-axis drive, `Drive<…,
//!   AXES>`); 1000h carries the multi-device marker and 67FFh + n × 800h each axis's type.
//! - The node has 4 + 4 PDOs per axis: PDOs 4n + 1 … 4n + 4 are axis n's, with CiA 402's
//!   pre-defined mapping shifted to the axis (identifiers of their own only for PDOs 1–4).
//! - The simulation objects of axis n lie 10h × n above the first axis's (generic drive: 2100h–
//!   2102h for axis 0, 2110h–2112h for axis 1, …; [`crate::board_objects`]).
//!
//! Only the generic drive has more than one axis: the vendor profiles rebuild single-axis
//! products from their manuals.

/// Calls `f::<PDOS, AXES>(args…)` for a node of `axes` axes (1–[`MAX_AXES`]): each count is
/// one monomorphic drive.
macro_rules! with_axes {
    ($axes:expr, $f:ident ( $($arg:expr),* $(,)? )) => {
        match $axes {
            2 => $f::<8, 2>($($arg),*),
            3 => $f::<12, 3>($($arg),*),
            4 => $f::<16, 4>($($arg),*),
            5 => $f::<20, 5>($($arg),*),
            6 => $f::<24, 6>($($arg),*),
            7 => $f::<28, 7>($($arg),*),
            8 => $f::<32, 8>($($arg),*),
            _ => $f::<4, 1>($($arg),*),
        }
    };
}
pub(crate) use with_axes;

use canopen_drive::comm::pdo;
use canopen_drive::od::{layout, Object};

/// The most axes this program runs: CiA 402's eight (each count is one more build of the
/// drive's communication side in this program).
pub const MAX_AXES: u8 = 8;

/// Distance between the simulation objects of two neighbouring axes.
pub const SIMULATION_STRIDE: u16 = 0x10;

static PDOS_2: [Object; 32] = layout(pdo::objects::<32>(8));
static PDOS_3: [Object; 48] = layout(pdo::objects::<48>(12));
static PDOS_4: [Object; 64] = layout(pdo::objects::<64>(16));
static PDOS_5: [Object; 80] = layout(pdo::objects::<80>(20));
static PDOS_6: [Object; 96] = layout(pdo::objects::<96>(24));
static PDOS_7: [Object; 112] = layout(pdo::objects::<112>(28));
static PDOS_8: [Object; 128] = layout(pdo::objects::<128>(32));

/// The PDO records of a node of `axes` axes (4 + 4 per axis).
pub fn pdo_objects(axes: u8) -> &'static [Object] {
    match axes {
        2 => &PDOS_2,
        3 => &PDOS_3,
        4 => &PDOS_4,
        5 => &PDOS_5,
        6 => &PDOS_6,
        7 => &PDOS_7,
        8 => &PDOS_8,
        _ => &pdo::DEFAULT_OBJECTS,
    }
}

/// The manufacturer objects of a node of `axes` axes: `first`'s (the first axis's, with its
/// simulation objects at `simulation`) and, for every further axis, copies of the simulation
/// objects [`SIMULATION_STRIDE`] apart, laid out again. The table lives as long as the program
/// (`Box::leak`: a drive's tables are `'static`).
pub fn manufacturer_objects(first: &'static [Object], simulation: u16, axes: u8) -> &'static [Object] {
    if axes <= 1 {
        return first;
    }
    let mut objects: Vec<Object> = first.to_vec();
    for axis in 1..u16::from(axes) {
        for k in 0..3 {
            if let Some(object) = first.iter().find(|o| o.index == simulation + k) {
                objects.push(object.at(simulation + k + SIMULATION_STRIDE * axis));
            }
        }
    }
    objects.sort_by_key(|o| o.index);
    let mut base = 0usize;
    for object in &mut objects {
        object.base = u16::try_from(base).unwrap_or(u16::MAX);
        base += object.storage_size();
    }
    Box::leak(objects.into_boxed_slice())
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use canopen_drive::od::ConfigError;
    use canopen_drive::Drive;

    use crate::board_objects::BoardHooks;
    use crate::profiles::{BoardProfile, ProfileName, OD_BYTES};

    fn used_bytes<const PDOS: usize, const AXES: usize>(
        profile: &BoardProfile,
    ) -> Result<usize, ConfigError> {
        let (config, hooks) = (profile.config(5), profile.hooks(false));
        let drive = Drive::<BoardHooks, OD_BYTES, PDOS, PDOS, (), AXES>::build(config, hooks, ())?;
        Ok(drive.od().used_bytes())
    }

    /// Every count of axes builds, and its dictionary fits the board's store.
    #[test]
    fn every_count_of_axes_builds() {
        let profile = BoardProfile::of(ProfileName::Generic);
        for axes in 1..=MAX_AXES {
            let profile = profile.with_axes(axes);
            let used = with_axes!(axes, used_bytes(&profile));
            assert!(used.unwrap() <= OD_BYTES, "{axes} axes");
        }
    }

    /// One axis is the profile as it is: a vendor profile keeps its own PDO and manufacturer
    /// tables.
    #[test]
    fn one_axis_keeps_the_profiles_tables() {
        for name in ProfileName::ALL {
            let profile = BoardProfile::of(name);
            let one = profile.with_axes(1);
            assert!(std::ptr::eq(one.config.pdo_objects, profile.config.pdo_objects), "{}", name.name());
            let same = std::ptr::eq(one.config.manufacturer_objects, profile.config.manufacturer_objects);
            assert!(same, "{}", name.name());
        }
    }

    #[test]
    fn each_axis_has_its_simulation_objects() {
        let profile = BoardProfile::of(ProfileName::Generic).with_axes(3);
        let table = profile.config.manufacturer_objects;
        for index in [0x2100, 0x2101, 0x2102, 0x2110, 0x2111, 0x2112, 0x2120, 0x2121, 0x2122] {
            assert!(table.iter().any(|o| o.index == index), "{index:04X}h");
        }
        assert!(!table.iter().any(|o| o.index == 0x2130));
        assert!(table.windows(2).all(|w| w[0].index < w[1].index));
        let faults = table.iter().find(|o| o.index == 0x2110).unwrap();
        assert_eq!(faults.name(), "Simulated hardware faults");
    }
}
