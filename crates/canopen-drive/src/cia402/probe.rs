//! Touch probe (60B8h–60BDh; CiA 402-2 §11.5.5–§11.5.11): the drive latches the actual position when a probe
//! input or the encoder index pulse changes, and reports it with a status word.
//!
//! ```text
//! 60B8h touch probe function (rw)          60B9h touch probe status (ro)
//!  bit  probe 1 | bit  probe 2              bit  probe 1 | bit  probe 2
//!   0   enable  |  8   enable                0   enabled |  8   enabled
//!   1   1 = continuous, 0 = first event      1   60BAh valid (positive edge stored)
//!   2   source: 1 = index pulse, 0 = input   2   60BBh valid (negative edge stored)
//!   3   reserved (refused) | 11              9   60BCh valid | 10   60BDh valid
//!   4   sample positive edge | 12            others 0
//!   5   sample negative edge | 13
//!   6,7 | 14,15 user-defined (accepted, no function here)
//!
//! 60BAh probe 1 positive edge   60BBh probe 1 negative edge
//! 60BCh probe 2 positive edge   60BDh probe 2 negative edge
//! ```
//!
//! [`TouchProbe::tick`] runs once per control tick with the 60B8h value, the digital inputs of
//! the sample, the actual position in increments and what the board knows about the instant of
//! the edge ([`Capture`]). It returns [`ProbeOutputs`]: 60B9h and the four latched positions in
//! increments (the caller converts them to user units, polarity included, CiA 402-2 §9.2.5) and which
//! of them changed. The work per tick is constant. Choices where the standard leaves room:
//!
//! - **Edges** are found by comparing the input level of this tick with that of the previous
//!   tick, which is tracked whether a probe is enabled or not. An input already active at the
//!   tick before the one that enables the probe is therefore not an edge; an input that rises
//!   between that tick and the enabling tick is (the order of the write and the edge inside one
//!   tick period cannot be known, so the edge is given the benefit). On the very first tick
//!   there is no previous level and no input edge is seen. A pulse shorter than a tick period
//!   that starts and ends between two samples is not seen.
//! - **Index pulse** (source bit 2/10 = 1): [`DigitalInputs::INDEX`] reports a pulse seen since
//!   the previous sample. It is an event, not a level, so it counts as a **positive edge only**:
//!   with the index as source, negative-edge sampling never latches and 60BBh/60BDh stay
//!   invalid. An index pulse flagged in the enabling tick counts, like an input edge.
//! - **First event** (bit 1/9 = 0): the first edge of each enabled kind latches its position
//!   and sets its status bit; later edges of that kind are ignored until the probe is re-armed.
//! - **Re-arm** (the reading this crate takes of CiA 402-2 §11.5.5): an edge kind is re-armed when the master switches
//!   the probe on (bit 0/8 0→1) or that edge's sampling bit on (bit 4/5, 12/13 0→1). Re-arming
//!   clears the status bit; the old position stays readable until a new edge replaces it.
//!   Switching an edge's sampling bit off keeps its status bit and value; so does changing
//!   bit 1/9 or the source, which do not re-arm.
//! - **Continuous** (bit 1/9 = 1): every edge of an enabled kind latches anew; the status bit
//!   stays 1 and [`ProbeOutputs::changed`] tells the caller a new value arrived.
//! - **Switched off** (bit 0/8 = 0): status bits 1, 2 (9, 10) are 0 and are cleared in the tick
//!   that sees the probe off; the latched positions keep their last values.
//! - **Edge position**: the actual position of the tick, unless the board captured better
//!   ([`EdgeCapture`]): a position latched by hardware at the edge, or the time from the edge to
//!   the sample, from which the position is interpolated back with the actual velocity.
//! - **Reserved bits** 3 and 11 are refused by [`check_write`]; the user-defined bits 6, 7, 14,
//!   15 are accepted and have no function. [`TouchProbe::tick`] ignores all of them.
//! - **Edge counters** (60D5h–60D8h: probe 1 positive, probe 1 negative, probe 2 positive,
//!   probe 2 negative; UNSIGNED16, ro): each counts the positions its edge kind latched. They
//!   restart at 0 when the probe is switched on (bit 0/8 0→1). In continuous mode they count on,
//!   wrapping from FFFFh to 0; in first-event mode re-arming an edge kind also restarts its
//!   counter, so it reads 0 until the edge is stored and 1 after. While the probe is off they keep
//!   their last values.

use super::objects::Rule;
use super::objects::{actual, parameter};
use crate::hal::DigitalInputs;
use crate::od::{AbortCode, DataType, DefaultValue, Object};
use bitflags::bitflags;

/// 60B8h touch probe function (UNSIGNED16, rw).
pub const TOUCH_PROBE_FUNCTION: u16 = 0x60B8;
/// 60B9h touch probe status (UNSIGNED16, ro).
pub const TOUCH_PROBE_STATUS: u16 = 0x60B9;
/// 60BAh touch probe 1 positive edge (INTEGER32, ro, user position units).
pub const TOUCH_PROBE_1_POSITIVE_EDGE: u16 = 0x60BA;
/// 60BBh touch probe 1 negative edge (INTEGER32, ro, user position units).
pub const TOUCH_PROBE_1_NEGATIVE_EDGE: u16 = 0x60BB;
/// 60BCh touch probe 2 positive edge (INTEGER32, ro, user position units).
pub const TOUCH_PROBE_2_POSITIVE_EDGE: u16 = 0x60BC;
/// 60BDh touch probe 2 negative edge (INTEGER32, ro, user position units).
pub const TOUCH_PROBE_2_NEGATIVE_EDGE: u16 = 0x60BD;
/// 60D5h touch probe 1 positive edge counter (UNSIGNED16, ro).
pub const TOUCH_PROBE_1_POSITIVE_EDGE_COUNTER: u16 = 0x60D5;
/// 60D6h touch probe 1 negative edge counter (UNSIGNED16, ro).
pub const TOUCH_PROBE_1_NEGATIVE_EDGE_COUNTER: u16 = 0x60D6;
/// 60D7h touch probe 2 positive edge counter (UNSIGNED16, ro).
pub const TOUCH_PROBE_2_POSITIVE_EDGE_COUNTER: u16 = 0x60D7;
/// 60D8h touch probe 2 negative edge counter (UNSIGNED16, ro).
pub const TOUCH_PROBE_2_NEGATIVE_EDGE_COUNTER: u16 = 0x60D8;

/// 60B8h bits 3 and 11: reserved, must be 0.
pub const RESERVED_FUNCTION_BITS: u16 = 0x0808;

/// Bits of one probe's byte of 60B8h (probe 1: low byte, probe 2: high byte).
const ENABLE: u8 = 1 << 0;
const CONTINUOUS: u8 = 1 << 1;
const INDEX_SOURCE: u8 = 1 << 2;
const POSITIVE_EDGE: u8 = 1 << 4;
const NEGATIVE_EDGE: u8 = 1 << 5;

/// Bits of one probe's byte of 60B9h.
const STATUS_ENABLED: u8 = 1 << 0;
const STATUS_POSITIVE_STORED: u8 = 1 << 1;
const STATUS_NEGATIVE_STORED: u8 = 1 << 2;

/// Value rule of 60B8h: the reserved bits 3 and 11 must be 0 ([`AbortCode::InvalidValue`]).
pub fn check_write(value: u16) -> Result<(), AbortCode> {
    if value & RESERVED_FUNCTION_BITS != 0 {
        Err(AbortCode::InvalidValue)
    } else {
        Ok(())
    }
}

pub use crate::hal::{Capture, EdgeCapture};

bitflags! {
    /// Which outputs of [`TouchProbe::tick`] changed in this tick.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct Changed: u8 {
        /// 60B9h differs from the previous tick.
        const STATUS = 1 << 0;
        /// 60BAh latched a new position (possibly equal to the old one).
        const PROBE_1_POSITIVE = 1 << 1;
        /// 60BBh latched a new position.
        const PROBE_1_NEGATIVE = 1 << 2;
        /// 60BCh latched a new position.
        const PROBE_2_POSITIVE = 1 << 3;
        /// 60BDh latched a new position.
        const PROBE_2_NEGATIVE = 1 << 4;
        /// An edge counter (60D5h–60D8h) differs from the previous tick.
        const COUNTERS = 1 << 5;
    }
}

/// The touch probe objects after a tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProbeOutputs {
    /// 60B9h touch probe status.
    pub status: u16,
    /// Positive-edge positions in increments: `[60BAh, 60BCh]` (probe 1, probe 2).
    pub positive: [i32; 2],
    /// Negative-edge positions in increments: `[60BBh, 60BDh]` (probe 1, probe 2).
    pub negative: [i32; 2],
    /// Positive-edge counters: `[60D5h, 60D7h]` (probe 1, probe 2).
    pub positive_count: [u16; 2],
    /// Negative-edge counters: `[60D6h, 60D8h]` (probe 1, probe 2).
    pub negative_count: [u16; 2],
    /// What changed in this tick (empty from [`TouchProbe::outputs`]).
    pub changed: Changed,
}

/// The edges one probe's trigger source showed in this tick, and where they happened.
#[derive(Clone, Copy, Debug)]
struct Edges {
    rising: bool,
    falling: bool,
    position: i32,
}

/// What one probe latched in a tick.
#[derive(Clone, Copy, Debug, Default)]
struct Latched {
    positive: bool,
    negative: bool,
}

/// The state of one probe.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Probe {
    /// Status bit 1 (9): a positive-edge position is stored (and, in first-event mode, the
    /// positive edge is spent until re-armed).
    positive_stored: bool,
    /// Status bit 2 (10), likewise for the negative edge.
    negative_stored: bool,
    positive: i32,
    negative: i32,
    /// Edge counters (60D5h/60D6h, 60D7h/60D8h).
    positive_count: u16,
    negative_count: u16,
}

impl Probe {
    /// One tick of one probe: `function` and `previous` are its byte of 60B8h in this tick and
    /// the previous one.
    fn step(&mut self, function: u8, previous: u8, edges: Edges) -> Latched {
        if function & ENABLE == 0 {
            self.positive_stored = false;
            self.negative_stored = false;
            return Latched::default();
        }
        let was_on = |bit: u8| previous & ENABLE != 0 && previous & bit != 0;
        let sampling_positive = function & POSITIVE_EDGE != 0;
        let sampling_negative = function & NEGATIVE_EDGE != 0;
        let continuous = function & CONTINUOUS != 0;
        if previous & ENABLE == 0 {
            self.positive_count = 0;
            self.negative_count = 0;
        }
        if sampling_positive && !was_on(POSITIVE_EDGE) {
            self.positive_stored = false;
            if !continuous {
                self.positive_count = 0;
            }
        }
        if sampling_negative && !was_on(NEGATIVE_EDGE) {
            self.negative_stored = false;
            if !continuous {
                self.negative_count = 0;
            }
        }
        let latched = Latched {
            positive: sampling_positive && edges.rising && (continuous || !self.positive_stored),
            negative: sampling_negative && edges.falling && (continuous || !self.negative_stored),
        };
        if latched.positive {
            self.positive = edges.position;
            self.positive_stored = true;
            self.positive_count = self.positive_count.wrapping_add(1);
        }
        if latched.negative {
            self.negative = edges.position;
            self.negative_stored = true;
            self.negative_count = self.negative_count.wrapping_add(1);
        }
        latched
    }

    /// This probe's byte of 60B9h for its byte of 60B8h.
    fn status(&self, function: u8) -> u8 {
        if function & ENABLE == 0 {
            return 0;
        }
        let mut status = STATUS_ENABLED;
        if self.positive_stored {
            status |= STATUS_POSITIVE_STORED;
        }
        if self.negative_stored {
            status |= STATUS_NEGATIVE_STORED;
        }
        status
    }
}

/// The two touch probes of an axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TouchProbe {
    one: Probe,
    two: Probe,
    /// 60B8h of the previous tick (reserved bits masked off).
    function: u16,
    /// Inputs of the previous tick; `None` before the first tick.
    inputs: Option<DigitalInputs>,
    /// 60B9h of the previous tick.
    status: u16,
}

impl TouchProbe {
    /// Both probes off, nothing latched, all positions 0.
    pub const fn new() -> Self {
        TouchProbe { one: PROBE_OFF, two: PROBE_OFF, function: 0, inputs: None, status: 0 }
    }

    /// The tick of an axis whose probes were off in the last tick and are off in this one
    /// (`function`, 60B8h) with 60B9h at 0: the inputs are remembered for the edges of a later
    /// enable, and nothing else changes. True if so; otherwise nothing was done, and
    /// [`Self::tick`] is due. (The drive's tick then skips the probe's outputs: the cost of an
    /// unused touch probe is this test.)
    #[inline]
    pub fn rest(&mut self, function: u16, inputs: DigitalInputs) -> bool {
        let both = u16::from_le_bytes([ENABLE, ENABLE]);
        let resting = (function | self.function) & both == 0 && self.status == 0;
        if resting {
            self.function = function & !RESERVED_FUNCTION_BITS;
            self.inputs = Some(inputs);
        }
        resting
    }

    /// One control tick: `function` is 60B8h, `inputs` the digital inputs of the sample
    /// ([`DigitalInputs::TOUCH_PROBE_1`], [`DigitalInputs::TOUCH_PROBE_2`],
    /// [`DigitalInputs::INDEX`] are read), `position` the actual position in increments and
    /// `capture` what the board captured at the edges. Returns 60B9h and the latched positions.
    pub fn tick(
        &mut self,
        function: u16,
        inputs: DigitalInputs,
        position: i32,
        capture: &Capture,
    ) -> ProbeOutputs {
        if self.rest(function, inputs) {
            // Both probes off in this tick and the last: nothing to latch, 60B9h stays 0.
            return self.outputs();
        }
        let function = function & !RESERVED_FUNCTION_BITS;
        let counts_before = self.counts();
        let previous = self.inputs.unwrap_or(inputs);
        let index = inputs.contains(DigitalInputs::INDEX);
        let edges = |input: DigitalInputs, input_capture: EdgeCapture, source_is_index: bool| {
            if source_is_index {
                Edges {
                    rising: index,
                    falling: false,
                    position: capture.position_at(capture.index, position),
                }
            } else {
                let now = inputs.contains(input);
                let before = previous.contains(input);
                Edges {
                    rising: now && !before,
                    falling: !now && before,
                    position: capture.position_at(input_capture, position),
                }
            }
        };
        let [low, high] = function.to_le_bytes();
        let [previous_low, previous_high] = self.function.to_le_bytes();
        let one = self.one.step(
            low,
            previous_low,
            edges(DigitalInputs::TOUCH_PROBE_1, capture.probe_1, low & INDEX_SOURCE != 0),
        );
        let two = self.two.step(
            high,
            previous_high,
            edges(DigitalInputs::TOUCH_PROBE_2, capture.probe_2, high & INDEX_SOURCE != 0),
        );
        self.function = function;
        self.inputs = Some(inputs);

        let mut changed = Changed::empty();
        changed.set(Changed::PROBE_1_POSITIVE, one.positive);
        changed.set(Changed::PROBE_1_NEGATIVE, one.negative);
        changed.set(Changed::PROBE_2_POSITIVE, two.positive);
        changed.set(Changed::PROBE_2_NEGATIVE, two.negative);
        let status = self.status_word();
        changed.set(Changed::STATUS, status != self.status);
        changed.set(Changed::COUNTERS, self.counts() != counts_before);
        self.status = status;
        ProbeOutputs { changed, ..self.outputs() }
    }

    /// 60B9h and the latched positions as of the last tick, with nothing marked changed.
    pub fn outputs(&self) -> ProbeOutputs {
        ProbeOutputs {
            status: self.status,
            positive: [self.one.positive, self.two.positive],
            negative: [self.one.negative, self.two.negative],
            positive_count: [self.one.positive_count, self.two.positive_count],
            negative_count: [self.one.negative_count, self.two.negative_count],
            changed: Changed::empty(),
        }
    }

    /// The four edge counters: 60D5h, 60D6h, 60D7h, 60D8h.
    pub fn counts(&self) -> [u16; 4] {
        [self.one.positive_count, self.one.negative_count, self.two.positive_count, self.two.negative_count]
    }

    /// 60B9h as of the last tick.
    pub fn status(&self) -> u16 {
        self.status
    }

    fn status_word(&self) -> u16 {
        let [low, high] = self.function.to_le_bytes();
        u16::from_le_bytes([self.one.status(low), self.two.status(high)])
    }
}

const PROBE_OFF: Probe = Probe {
    positive_stored: false,
    negative_stored: false,
    positive: 0,
    negative: 0,
    positive_count: 0,
    negative_count: 0,
};

// `defmt::Format` of the bitflags type: its raw bits.
#[cfg(feature = "defmt")]
impl defmt::Format for Changed {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "Changed({=u8:#x})", self.bits());
    }
}

/// The touch probe's objects (60B8h–60BDh, 60D5h–60D8h), in [`super::registry::PROFILE`] when
/// the build has the touch probe.
pub(crate) const OBJECTS: [Object; 10] = [
    parameter(TOUCH_PROBE_FUNCTION, "Touch probe function", DataType::Unsigned16, DefaultValue::Zero),
    actual(TOUCH_PROBE_STATUS, "Touch probe status", DataType::Unsigned16),
    actual(TOUCH_PROBE_1_POSITIVE_EDGE, "Touch probe 1 positive edge", DataType::Integer32),
    actual(TOUCH_PROBE_1_NEGATIVE_EDGE, "Touch probe 1 negative edge", DataType::Integer32),
    actual(TOUCH_PROBE_2_POSITIVE_EDGE, "Touch probe 2 positive edge", DataType::Integer32),
    actual(TOUCH_PROBE_2_NEGATIVE_EDGE, "Touch probe 2 negative edge", DataType::Integer32),
    actual(TOUCH_PROBE_1_POSITIVE_EDGE_COUNTER, "Touch probe 1 positive edge counter", DataType::Unsigned16),
    actual(TOUCH_PROBE_1_NEGATIVE_EDGE_COUNTER, "Touch probe 1 negative edge counter", DataType::Unsigned16),
    actual(TOUCH_PROBE_2_POSITIVE_EDGE_COUNTER, "Touch probe 2 positive edge counter", DataType::Unsigned16),
    actual(TOUCH_PROBE_2_NEGATIVE_EDGE_COUNTER, "Touch probe 2 negative edge counter", DataType::Unsigned16),
];

/// The value rule of the touch probe's object `index` ([`super::registry::rule`]): 60B8h
/// ([`check_write`]).
pub(crate) fn rule(index: u16) -> Option<Rule> {
    (super::PROBE && index == TOUCH_PROBE_FUNCTION).then_some(Rule::TouchProbe)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TP1: DigitalInputs = DigitalInputs::TOUCH_PROBE_1;
    const TP2: DigitalInputs = DigitalInputs::TOUCH_PROBE_2;
    const INDEX: DigitalInputs = DigitalInputs::INDEX;
    const NONE: DigitalInputs = DigitalInputs::empty();

    /// Ticks with no capture hardware.
    fn tick(probe: &mut TouchProbe, function: u16, inputs: DigitalInputs, position: i32) -> ProbeOutputs {
        probe.tick(function, inputs, position, &Capture::NONE)
    }

    /// A probe that has seen one tick with `function` and no input active.
    fn armed(function: u16) -> TouchProbe {
        let mut probe = TouchProbe::new();
        tick(&mut probe, function, NONE, 0);
        probe
    }

    #[test]
    fn m_136_disabled_probe_reports_zero_whatever_the_inputs() {
        let mut probe = armed(0x0030);
        for (i, inputs) in [TP1, NONE, TP1 | INDEX, INDEX, NONE, TP1].into_iter().enumerate() {
            let out = tick(&mut probe, 0x0030, inputs, i as i32 * 100);
            assert_eq!(out.status & 0x0007, 0);
            assert_eq!(out.changed, Changed::empty());
        }
        // Likewise with the index as source.
        let mut probe = armed(0x0034);
        assert_eq!(tick(&mut probe, 0x0034, INDEX, 5).status, 0);
    }

    #[test]
    fn m_137_first_rising_edge_latches_position_and_status_0003() {
        let mut probe = armed(0x0011);
        assert_eq!(probe.status(), 0x0001);
        let out = tick(&mut probe, 0x0011, TP1, 1234);
        assert_eq!(out.positive[0], 1234);
        assert_eq!(out.status, 0x0003);
        assert_eq!(out.changed, Changed::STATUS | Changed::PROBE_1_POSITIVE | Changed::COUNTERS);
    }

    #[test]
    fn m_138_first_event_ignores_a_second_edge() {
        let mut probe = armed(0x0011);
        tick(&mut probe, 0x0011, TP1, 1234);
        tick(&mut probe, 0x0011, NONE, 1500);
        let out = tick(&mut probe, 0x0011, TP1, 2000);
        assert_eq!(out.positive[0], 1234);
        assert_eq!(out.status, 0x0003);
        assert_eq!(out.changed, Changed::empty());
    }

    #[test]
    fn m_139_continuous_updates_on_each_rising_edge() {
        let mut probe = armed(0x0013);
        for position in [100, 300, -700] {
            let out = tick(&mut probe, 0x0013, TP1, position);
            assert_eq!(out.positive[0], position);
            assert_eq!(out.status, 0x0003);
            assert!(out.changed.contains(Changed::PROBE_1_POSITIVE));
            // Holding and releasing the input latches nothing (no negative sampling).
            let out = tick(&mut probe, 0x0013, TP1, position + 1);
            assert_eq!(out.changed, Changed::empty());
            let out = tick(&mut probe, 0x0013, NONE, position + 2);
            assert_eq!(out.changed, Changed::empty());
            assert_eq!(out.positive[0], position);
        }
    }

    #[test]
    fn m_140_falling_edge_latches_negative_value() {
        let mut probe = armed(0x0021);
        // A rising edge is not sampled.
        let out = tick(&mut probe, 0x0021, TP1, 10);
        assert_eq!(out.status, 0x0001);
        let out = tick(&mut probe, 0x0021, NONE, 42);
        assert_eq!(out.negative[0], 42);
        assert_eq!(out.status, 0x0005);
        assert_eq!(out.changed, Changed::STATUS | Changed::PROBE_1_NEGATIVE | Changed::COUNTERS);
    }

    #[test]
    fn m_141_switching_off_clears_stored_bits_in_the_same_tick() {
        let mut probe = armed(0x0033);
        tick(&mut probe, 0x0033, TP1, 7);
        let out = tick(&mut probe, 0x0033, NONE, 9);
        assert_eq!(out.status, 0x0007);
        let out = tick(&mut probe, 0x0032, NONE, 9);
        assert_eq!(out.status, 0x0000);
        assert_eq!(out.changed, Changed::STATUS);
        // The positions stay readable.
        assert_eq!((out.positive[0], out.negative[0]), (7, 9));
    }

    #[test]
    fn m_142_probe_2_uses_the_high_byte_and_its_own_objects() {
        let mut probe = armed(0x3300);
        assert_eq!(probe.status(), 0x0100);
        // Probe 1's input does nothing for probe 2.
        let out = tick(&mut probe, 0x3300, TP1, 1);
        assert_eq!(out.status, 0x0100);
        let out = tick(&mut probe, 0x3300, TP2, 20);
        assert_eq!(
            (out.status, out.positive[1], out.changed),
            (0x0300, 20, Changed::STATUS | Changed::PROBE_2_POSITIVE | Changed::COUNTERS)
        );
        let out = tick(&mut probe, 0x3300, NONE, 30);
        assert_eq!(
            (out.status, out.negative[1], out.changed),
            (0x0700, 30, Changed::STATUS | Changed::PROBE_2_NEGATIVE | Changed::COUNTERS)
        );
        assert_eq!((out.positive[0], out.negative[0]), (0, 0));
        let out = tick(&mut probe, 0x3200, NONE, 30);
        assert_eq!(out.status, 0x0000);
    }

    #[test]
    fn m_143_index_source_triggers_on_the_index_pulse_not_the_input() {
        let mut probe = armed(0x0017);
        // The probe input toggles: ignored.
        assert_eq!(tick(&mut probe, 0x0017, TP1, 1).status, 0x0001);
        assert_eq!(tick(&mut probe, 0x0017, NONE, 2).status, 0x0001);
        let out = tick(&mut probe, 0x0017, INDEX, 4096);
        assert_eq!((out.status, out.positive[0]), (0x0003, 4096));
        // Continuous: every index pulse, even on consecutive ticks.
        let out = tick(&mut probe, 0x0017, INDEX, 8192);
        assert_eq!(out.positive[0], 8192);
        // Probe 2 with the index as source too.
        let mut probe = armed(0x1700);
        let out = tick(&mut probe, 0x1700, INDEX | TP2, 55);
        assert_eq!((out.status, out.positive[1]), (0x0300, 55));
    }

    #[test]
    fn index_pulse_is_not_a_negative_edge() {
        let mut probe = armed(0x0027);
        for inputs in [INDEX, NONE, INDEX, NONE] {
            assert_eq!(tick(&mut probe, 0x0027, inputs, 3).status, 0x0001);
        }
    }

    #[test]
    fn continuous_mode_latches_both_edges() {
        let mut probe = armed(0x0033);
        let levels = [(TP1, 10), (NONE, 20), (TP1, 30), (NONE, 40)];
        for (inputs, position) in levels {
            let out = tick(&mut probe, 0x0033, inputs, position);
            if inputs == TP1 {
                assert_eq!(out.positive[0], position);
                assert!(out.changed.contains(Changed::PROBE_1_POSITIVE));
            } else {
                assert_eq!(out.negative[0], position);
                assert!(out.changed.contains(Changed::PROBE_1_NEGATIVE));
            }
        }
        let out = probe.outputs();
        assert_eq!((out.status, out.positive[0], out.negative[0]), (0x0007, 30, 40));
    }

    #[test]
    fn first_event_latches_each_edge_kind_once() {
        let mut probe = armed(0x0031);
        tick(&mut probe, 0x0031, TP1, 10);
        tick(&mut probe, 0x0031, NONE, 20);
        tick(&mut probe, 0x0031, TP1, 30);
        let out = tick(&mut probe, 0x0031, NONE, 40);
        assert_eq!((out.status, out.positive[0], out.negative[0]), (0x0007, 10, 20));
    }

    #[test]
    fn rearm_by_switching_the_probe_off_and_on() {
        let mut probe = armed(0x0011);
        tick(&mut probe, 0x0011, TP1, 10);
        tick(&mut probe, 0x0011, NONE, 10);
        tick(&mut probe, 0x0010, NONE, 10);
        let out = tick(&mut probe, 0x0011, NONE, 10);
        assert_eq!((out.status, out.positive[0]), (0x0001, 10));
        let out = tick(&mut probe, 0x0011, TP1, 50);
        assert_eq!((out.status, out.positive[0]), (0x0003, 50));
    }

    #[test]
    fn rearm_by_switching_the_edge_sampling_on() {
        let mut probe = armed(0x0031);
        tick(&mut probe, 0x0031, TP1, 10);
        tick(&mut probe, 0x0031, NONE, 20);
        // Positive sampling off: its status bit and value stay.
        let out = tick(&mut probe, 0x0021, NONE, 20);
        assert_eq!((out.status, out.positive[0]), (0x0007, 10));
        // Back on: re-armed, the negative edge is untouched.
        let out = tick(&mut probe, 0x0031, NONE, 20);
        assert_eq!((out.status, out.positive[0], out.negative[0]), (0x0005, 10, 20));
        // (First event: re-arming restarts the positive-edge counter.)
        assert_eq!(out.changed, Changed::STATUS | Changed::COUNTERS);
        assert_eq!((out.positive_count[0], out.negative_count[0]), (0, 1));
        let out = tick(&mut probe, 0x0031, TP1, 60);
        assert_eq!((out.status, out.positive[0]), (0x0007, 60));
        // A further falling edge is still spent.
        let out = tick(&mut probe, 0x0031, NONE, 70);
        assert_eq!(out.negative[0], 20);
    }

    #[test]
    fn mode_and_source_changes_do_not_rearm() {
        let mut probe = armed(0x0011);
        tick(&mut probe, 0x0011, TP1, 10);
        tick(&mut probe, 0x0015, NONE, 10);
        let out = tick(&mut probe, 0x0011, TP1, 30);
        assert_eq!((out.status, out.positive[0]), (0x0003, 10));
    }

    #[test]
    fn input_active_before_enabling_is_not_an_edge() {
        let mut probe = TouchProbe::new();
        tick(&mut probe, 0x0000, TP1, 0);
        let out = tick(&mut probe, 0x0011, TP1, 5);
        assert_eq!(out.status, 0x0001);
        tick(&mut probe, 0x0011, NONE, 6);
        let out = tick(&mut probe, 0x0011, TP1, 7);
        assert_eq!((out.status, out.positive[0]), (0x0003, 7));
    }

    #[test]
    fn edge_in_the_enabling_tick_counts() {
        let mut probe = armed(0x0000);
        let out = tick(&mut probe, 0x0011, TP1, 8);
        assert_eq!((out.status, out.positive[0]), (0x0003, 8));
        let mut probe = armed(0x0000);
        let out = tick(&mut probe, 0x0015, INDEX, 9);
        assert_eq!((out.status, out.positive[0]), (0x0003, 9));
    }

    #[test]
    fn the_first_tick_sees_no_input_edge() {
        let mut probe = TouchProbe::new();
        let out = tick(&mut probe, 0x0011, TP1, 8);
        assert_eq!(out.status, 0x0001);
        assert_eq!(out.changed, Changed::STATUS);
    }

    #[test]
    fn edges_are_tracked_while_disabled() {
        let mut probe = armed(0x0000);
        tick(&mut probe, 0x0000, TP1, 0);
        // Falls while disabled, rises again with the enable.
        tick(&mut probe, 0x0000, NONE, 0);
        let out = tick(&mut probe, 0x0021, NONE, 0);
        assert_eq!(out.status, 0x0001);
    }

    #[test]
    fn edge_counters_count_latched_edges_and_restart_when_switched_on() {
        // Continuous, both edges of probe 1: each latched edge counts.
        let mut probe = armed(0x0033);
        for n in 1..=3u16 {
            let out = tick(&mut probe, 0x0033, TP1, 10);
            assert_eq!(out.positive_count[0], n);
            assert!(out.changed.contains(Changed::COUNTERS));
            let out = tick(&mut probe, 0x0033, NONE, 20);
            assert_eq!((out.positive_count[0], out.negative_count[0]), (n, n));
        }
        assert_eq!(probe.counts(), [3, 3, 0, 0]);
        // Switched off: the counters keep their values; switched on again: they restart.
        let out = tick(&mut probe, 0x0032, TP1, 30);
        assert_eq!((out.positive_count[0], out.changed.contains(Changed::COUNTERS)), (3, false));
        let out = tick(&mut probe, 0x0033, NONE, 40);
        assert_eq!((out.positive_count[0], out.negative_count[0]), (0, 1));
        // Wrapping: a counter at FFFFh goes on at 0.
        probe.one.positive_count = u16::MAX;
        let out = tick(&mut probe, 0x0033, TP1, 50);
        assert_eq!(out.positive_count[0], 0);
        // First event: 0 until the edge is stored, 1 after, 0 again when re-armed.
        let mut probe = armed(0x1100);
        let out = tick(&mut probe, 0x1100, TP2, 1);
        assert_eq!(out.positive_count[1], 1);
        tick(&mut probe, 0x1100, NONE, 2);
        let out = tick(&mut probe, 0x1100, TP2, 3);
        assert_eq!((out.positive_count[1], out.changed), (1, Changed::empty()));
        tick(&mut probe, 0x0100, NONE, 4);
        let out = tick(&mut probe, 0x1100, NONE, 5);
        assert_eq!((out.positive_count[1], out.changed), (0, Changed::STATUS | Changed::COUNTERS));
    }

    #[test]
    fn both_probes_at_once() {
        let mut probe = armed(0x2711);
        // TP1 rises; the index pulse comes, but probe 2 samples only negative edges.
        let out = tick(&mut probe, 0x2711, TP1 | INDEX, 100);
        assert_eq!(out.status, 0x0103);
        // Probe 2 samples positive edges too; TP1 falls, probe 1 does not sample it.
        let out = tick(&mut probe, 0x3711, INDEX, 200);
        assert_eq!((out.status, out.positive), (0x0303, [100, 200]));
        // Probe 2's input rises (index source: ignored); no index pulse.
        let out = tick(&mut probe, 0x3711, TP2, 300);
        assert_eq!((out.status, out.changed), (0x0303, Changed::empty()));
        // One tick, one edge on each probe.
        let mut probe = armed(0x3333);
        tick(&mut probe, 0x3333, TP2, 1);
        let out = tick(&mut probe, 0x3333, TP1, 2);
        assert_eq!(out.status, 0x0703);
        assert_eq!((out.positive, out.negative), ([2, 1], [0, 2]));
        assert_eq!(
            out.changed,
            Changed::STATUS | Changed::PROBE_1_POSITIVE | Changed::PROBE_2_NEGATIVE | Changed::COUNTERS
        );
    }

    #[test]
    fn hardware_latched_position_is_taken_as_is() {
        let mut probe = armed(0x1111);
        let capture = Capture {
            probe_1: EdgeCapture::Position(-77),
            probe_2: EdgeCapture::Position(66),
            ..Capture::NONE
        };
        let out = probe.tick(0x1111, TP1 | TP2, 1000, &capture);
        assert_eq!(out.positive, [-77, 66]);
    }

    #[test]
    fn capture_follows_the_trigger_signal_not_the_probe() {
        let mut probe = armed(0x0015);
        let capture =
            Capture { probe_1: EdgeCapture::Position(1), index: EdgeCapture::Position(2), ..Capture::NONE };
        let out = probe.tick(0x0015, TP1 | INDEX, 1000, &capture);
        assert_eq!(out.positive[0], 2);
    }

    #[test]
    fn capture_time_interpolates_back_with_the_velocity() {
        // 100 000 inc/s, edge 250 µs before the sample: 25 increments earlier.
        let mut probe = armed(0x0033);
        let capture =
            Capture { velocity: 100_000, probe_1: EdgeCapture::Before { micros: 250 }, ..Capture::NONE };
        let out = probe.tick(0x0033, TP1, 10_000, &capture);
        assert_eq!(out.positive[0], 9_975);
        // Moving backwards: the edge was at a larger position.
        let capture = Capture { velocity: -100_000, ..capture };
        let out = probe.tick(0x0033, NONE, 10_000, &capture);
        assert_eq!(out.negative[0], 10_025);
    }

    #[test]
    fn interpolation_rounds_half_away_from_zero() {
        let at = |velocity, micros| {
            Capture { velocity, ..Capture::NONE }.position_at(EdgeCapture::Before { micros }, 0)
        };
        assert_eq!(at(1_000, 500), -1); // 0.5 increments
        assert_eq!(at(1_000, 499), 0);
        assert_eq!(at(-1_000, 500), 1);
        assert_eq!(at(-1_000, 1_499), 1);
        assert_eq!(at(7, 0), 0);
    }

    #[test]
    fn interpolation_saturates_at_the_extremes() {
        let extreme = |velocity, position| {
            Capture { velocity, ..Capture::NONE }
                .position_at(EdgeCapture::Before { micros: u32::MAX }, position)
        };
        assert_eq!(extreme(i32::MAX, i32::MIN), i32::MIN);
        assert_eq!(extreme(i32::MIN, i32::MAX), i32::MAX);
        assert_eq!(extreme(i32::MIN, i32::MIN), i32::MAX);
        assert_eq!(extreme(i32::MAX, i32::MAX), i32::MIN);
    }

    #[test]
    fn capture_of_a_signal_without_an_edge_is_ignored() {
        let mut probe = armed(0x0011);
        let capture = Capture { probe_1: EdgeCapture::Position(5), ..Capture::NONE };
        let out = probe.tick(0x0011, NONE, 10, &capture);
        assert_eq!((out.status, out.positive[0]), (0x0001, 0));
    }

    #[test]
    fn sampling_bits_off_latch_nothing() {
        let mut probe = armed(0x0003);
        for inputs in [TP1, NONE, TP1 | INDEX, NONE] {
            let out = tick(&mut probe, 0x0003, inputs, 1);
            assert_eq!((out.status, out.changed), (0x0001, Changed::empty()));
        }
    }

    #[test]
    fn reserved_and_user_bits_do_not_change_the_function() {
        let mut probe = armed(0x0011 | RESERVED_FUNCTION_BITS | 0xC0C0);
        let out = tick(&mut probe, 0x0011 | RESERVED_FUNCTION_BITS | 0xC0C0, TP1, 3);
        assert_eq!((out.status, out.positive[0]), (0x0003, 3));
    }

    #[test]
    fn check_write_refuses_the_reserved_bits_only() {
        assert_eq!(check_write(0x0008), Err(AbortCode::InvalidValue));
        assert_eq!(check_write(0x0800), Err(AbortCode::InvalidValue));
        assert_eq!(check_write(0xFFFF), Err(AbortCode::InvalidValue));
        assert_eq!(check_write(0x0000), Ok(()));
        assert_eq!(check_write(0xF7F7), Ok(()));
        assert_eq!(check_write(0x3737), Ok(()));
    }

    #[test]
    fn outputs_before_any_tick_are_zero() {
        let probe = TouchProbe::new();
        assert_eq!(probe.outputs(), ProbeOutputs::default());
        assert_eq!(TouchProbe::default(), TouchProbe::new());
    }
}
