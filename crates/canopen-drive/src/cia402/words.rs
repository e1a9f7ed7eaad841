//! The controlword 6040h and the statusword 6041h as typed bit sets (CiA 402-2 §8.4.1,
//! §8.4.2). Bits 4–6, 9, 12 and 13 mean something different in each operation mode: they
//! have one generic name (`MODE_SPECIFIC_n`) and the names of their meanings in the modes.

use bitflags::bitflags;

bitflags! {
    /// Controlword 6040h. Unknown bits (10 reserved, 11–15 manufacturer-specific) are kept.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct Controlword: u16 {
        /// Bit 0.
        const SWITCH_ON = 1 << 0;
        /// Bit 1.
        const ENABLE_VOLTAGE = 1 << 1;
        /// Bit 2, active low: 0 commands Quick stop.
        const QUICK_STOP = 1 << 2;
        /// Bit 3.
        const ENABLE_OPERATION = 1 << 3;
        /// Bit 4, by mode: see the aliases below.
        const MODE_SPECIFIC_4 = 1 << 4;
        /// Bit 5, by mode.
        const MODE_SPECIFIC_5 = 1 << 5;
        /// Bit 6, by mode.
        const MODE_SPECIFIC_6 = 1 << 6;
        /// Bit 7: its 0→1 edge commands Fault reset.
        const FAULT_RESET = 1 << 7;
        /// Bit 8.
        const HALT = 1 << 8;
        /// Bit 9, by mode.
        const MODE_SPECIFIC_9 = 1 << 9;

        /// pp: bit 4, new set-point (its 0→1 edge).
        const NEW_SET_POINT = 1 << 4;
        /// pp: bit 5, change set immediately.
        const CHANGE_SET_IMMEDIATELY = 1 << 5;
        /// pp: bit 6, the target is relative.
        const RELATIVE = 1 << 6;
        /// pp: bit 9, change on set-point (blend into the next one).
        const CHANGE_ON_SET_POINT = 1 << 9;
        /// hm: bit 4, homing operation start.
        const HOMING_START = 1 << 4;
        /// ip: bit 4, enable interpolation.
        const ENABLE_IP = 1 << 4;
        /// vl: bit 4, ramp function generator enable.
        const RAMP_FUNCTION_GENERATOR_ENABLE = 1 << 4;
        /// vl: bit 5, ramp unlock (0: the ramp's output is frozen).
        const RAMP_UNLOCK = 1 << 5;
        /// vl: bit 6, ramp reference (0: the ramp's input is 0).
        const RAMP_REFERENCE = 1 << 6;
    }
}

bitflags! {
    /// Statusword 6041h.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct Statusword: u16 {
        /// Bit 0.
        const READY_TO_SWITCH_ON = 1 << 0;
        /// Bit 1.
        const SWITCHED_ON = 1 << 1;
        /// Bit 2.
        const OPERATION_ENABLED = 1 << 2;
        /// Bit 3.
        const FAULT = 1 << 3;
        /// Bit 4: high voltage applied.
        const VOLTAGE_ENABLED = 1 << 4;
        /// Bit 5, active low: 0 while a quick stop runs.
        const QUICK_STOP = 1 << 5;
        /// Bit 6.
        const SWITCH_ON_DISABLED = 1 << 6;
        /// Bit 7.
        const WARNING = 1 << 7;
        /// Bit 9: the controlword is processed.
        const REMOTE = 1 << 9;
        /// Bit 10, by mode: target reached (also set for one tick after a mode switch here).
        const TARGET_REACHED = 1 << 10;
        /// Bit 11.
        const INTERNAL_LIMIT_ACTIVE = 1 << 11;
        /// Bit 12, by mode: see the aliases below.
        const MODE_SPECIFIC_12 = 1 << 12;
        /// Bit 13, by mode.
        const MODE_SPECIFIC_13 = 1 << 13;
        /// Bit 14, manufacturer-specific.
        const MANUFACTURER_14 = 1 << 14;
        /// Bit 15, manufacturer-specific.
        const MANUFACTURER_15 = 1 << 15;

        /// pp and ip: bit 12, set-point acknowledge (pp) / interpolation active (ip).
        const SET_POINT_ACKNOWLEDGE = 1 << 12;
        /// pv: bit 12, speed (zero).
        const SPEED = 1 << 12;
        /// csp, csv, cst: bit 12, the target value is followed.
        const TARGET_FOLLOWED = 1 << 12;
        /// hm: bit 12, homing attained.
        const HOMING_ATTAINED = 1 << 12;
        /// hm: bit 13, homing error.
        const HOMING_ERROR = 1 << 13;
        /// pp, csp, ip: bit 13, following error.
        const FOLLOWING_ERROR = 1 << 13;
        /// pv: bit 13, max slippage.
        const MAX_SLIPPAGE = 1 << 13;
    }
}

impl Controlword {
    /// `raw` as it is, unknown bits included.
    #[inline]
    pub const fn from_raw(raw: u16) -> Self {
        Controlword::from_bits_retain(raw)
    }
}

impl Statusword {
    /// `raw` as it is, unknown bits included.
    #[inline]
    pub const fn from_raw(raw: u16) -> Self {
        Statusword::from_bits_retain(raw)
    }
}

// `defmt::Format`: the raw bits (a bitflags type cannot derive it).
#[cfg(feature = "defmt")]
impl defmt::Format for Controlword {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "Controlword({=u16:#06x})", self.bits());
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Statusword {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "Statusword({=u16:#06x})", self.bits());
    }
}
