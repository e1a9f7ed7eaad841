//! The firmware's manufacturer objects: test controls and measurements a remote test reads
//! over SDO.
//!
//! | index | name | type | meaning |
//! |---|---|---|---|
//! | 2F00h | Test exit | UNSIGNED32 rw | writing `n` ends the firmware: QEMU exits with status `n` (after the SDO response) |
//! | 2F01h | Tick count | UNSIGNED32 ro | control ticks since the last reset of 2F02h |
//! | 2F02h | Tick lateness max | UNSIGNED32 rw | longest time (ns) from a tick's timer expiry to the start of its handler, for ticks that fell due while the core was running; writing 0 restarts this and 2F01h, 2F03h, 2F06h–2F0Bh |
//! | 2F03h | Tick lateness mean | UNSIGNED32 ro | mean of the same (ns) |
//! | 2F04h | Stack used | UNSIGNED32 ro | deepest stack use since reset (bytes), from the painted stack |
//! | 2F05h | Simulated load torque | INTEGER16 rw | external load on the simulated shaft (‰ of rated torque) |
//! | 2F06h | Longest lock | UNSIGNED32 ro | longest hold (ns) of the drive's lock outside the tick since the last reset of 2F02h: the most the tick can have been held off by the drive's communication side |
//! | 2F07h | Longest tick | UNSIGNED32 ro | longest `Drive::tick` call (ns) since the last reset of 2F02h |
//! | 2F08h | Longest masked | UNSIGNED32 ro | longest time (ns) every interrupt was masked (a critical section, in any context) since the last reset of 2F02h: the most the current loop can have been held off |
//! | 2F09h | Current loop runs | UNSIGNED32 ro | runs of the 20 kHz current-loop interrupt since the last reset of 2F02h |
//! | 2F0Ah | Current loop gap max | UNSIGNED32 ro | longest time (ns) between two runs of the current loop |
//! | 2F0Bh | Current loop lateness max | UNSIGNED32 ro | latest start (ns) of a current-loop run after its timer expired |
//! | 2F10h | Test pattern | DOMAIN ro | 16 KiB computed on the fly (byte `i` = [`pattern_byte`]`(i)`): long SDO uploads |
//! | 2F11h | Test buffer | DOMAIN rw | up to 200 bytes kept in the dictionary: downloads read back |
//!
//! The measurements live in statics that the tick handler and the hooks share through atomics
//! (plain loads and stores: also on thumbv6m).

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use canopen_drive::od::{layout, AbortCode, Access, DataType, Object, ObjectHooks, Var};
use canopen_drive_embassy::TickMonitor;

/// 2F00h.
pub const TEST_EXIT: u16 = 0x2F00;
/// 2F01h.
pub const TICK_COUNT: u16 = 0x2F01;
/// 2F02h.
pub const TICK_LATENESS_MAX: u16 = 0x2F02;
/// 2F03h.
pub const TICK_LATENESS_MEAN: u16 = 0x2F03;
/// 2F04h.
pub const STACK_USED: u16 = 0x2F04;
/// 2F05h.
pub const SIMULATED_LOAD: u16 = 0x2F05;
/// 2F06h.
pub const LONGEST_LOCK: u16 = 0x2F06;
/// 2F07h.
pub const LONGEST_TICK: u16 = 0x2F07;
/// 2F08h.
pub const LONGEST_MASKED: u16 = 0x2F08;
/// 2F09h.
pub const CURRENT_LOOP_RUNS: u16 = 0x2F09;
/// 2F0Ah.
pub const CURRENT_LOOP_GAP_MAX: u16 = 0x2F0A;
/// 2F0Bh.
pub const CURRENT_LOOP_LATENESS_MAX: u16 = 0x2F0B;
/// 2F10h.
pub const TEST_PATTERN: u16 = 0x2F10;
/// 2F11h.
pub const TEST_BUFFER: u16 = 0x2F11;
/// Length of 2F10h.
pub const TEST_PATTERN_LEN: usize = 16 * 1024;

/// The objects, for [`canopen_drive::Config::manufacturer_objects`].
pub static BOARD_OBJECTS: [Object; 14] = layout([
    Object::var(
        TEST_EXIT,
        "Test exit",
        Var::new("Test exit", DataType::Unsigned32).access(Access::ReadWrite),
    ),
    Object::var(TICK_COUNT, "Tick count", Var::new("Tick count", DataType::Unsigned32)),
    Object::var(
        TICK_LATENESS_MAX,
        "Tick lateness max",
        Var::new("Tick lateness max", DataType::Unsigned32).access(Access::ReadWrite).limits_unsigned(0, 0),
    ),
    Object::var(
        TICK_LATENESS_MEAN,
        "Tick lateness mean",
        Var::new("Tick lateness mean", DataType::Unsigned32),
    ),
    Object::var(STACK_USED, "Stack used", Var::new("Stack used", DataType::Unsigned32)),
    Object::var(
        SIMULATED_LOAD,
        "Simulated load torque",
        Var::new("Simulated load torque", DataType::Integer16)
            .access(Access::ReadWrite)
            .limits_signed(-3000, 3000),
    ),
    Object::var(LONGEST_LOCK, "Longest lock", Var::new("Longest lock", DataType::Unsigned32)),
    Object::var(LONGEST_TICK, "Longest tick", Var::new("Longest tick", DataType::Unsigned32)),
    Object::var(LONGEST_MASKED, "Longest masked", Var::new("Longest masked", DataType::Unsigned32)),
    Object::var(CURRENT_LOOP_RUNS, "Current loop runs", Var::new("Current loop runs", DataType::Unsigned32)),
    Object::var(
        CURRENT_LOOP_GAP_MAX,
        "Current loop gap max",
        Var::new("Current loop gap max", DataType::Unsigned32),
    ),
    Object::var(
        CURRENT_LOOP_LATENESS_MAX,
        "Current loop lateness max",
        Var::new("Current loop lateness max", DataType::Unsigned32),
    ),
    Object::var(TEST_PATTERN, "Test pattern", Var::new("Test pattern", DataType::Domain)),
    Object::var(
        TEST_BUFFER,
        "Test buffer",
        Var::new("Test buffer", DataType::Domain).access(Access::ReadWrite).capacity(200),
    ),
]);

/// Byte `i` of 2F10h.
pub fn pattern_byte(i: usize) -> u8 {
    (i.wrapping_mul(7) ^ (i >> 8)) as u8
}

/// Lateness of the control tick (ns), recorded by the tick handler.
pub static TICK_MONITOR: TickMonitor = TickMonitor::new();

/// An exit asked through 2F00h, and its code.
static EXIT_REQUESTED: AtomicBool = AtomicBool::new(false);
static EXIT_CODE: AtomicU32 = AtomicU32::new(0);
/// 2F05h, for the tick (the bits of an `i16`).
static LOAD: AtomicU32 = AtomicU32::new(0);

/// The exit code asked for through 2F00h, if any.
pub fn exit_requested() -> Option<i32> {
    EXIT_REQUESTED.load(Ordering::Acquire).then(|| EXIT_CODE.load(Ordering::Relaxed) as i32)
}

/// The load torque for the motor (2F05h).
pub fn load_torque() -> i16 {
    LOAD.load(Ordering::Relaxed) as u16 as i16
}

/// What the current loop (the board's most urgent interrupt) saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CurrentLoop {
    /// Runs of its handler.
    pub runs: u32,
    /// The longest time between two runs (ns): the period, give or take the jitter of its
    /// start, as long as it never missed one.
    pub longest_gap_ns: u32,
    /// The latest a run started after its timer expired (ns); a period or more would mean a
    /// run was lost.
    pub most_late_ns: u32,
}

/// What the board measures for the objects (the target side; tests use a stand-in).
pub trait Measurements {
    /// Deepest stack use since reset (bytes).
    fn stack_used(&self) -> u32;
    /// Longest hold of the drive's lock outside the tick (ns).
    fn longest_lock_ns(&self) -> u32;
    /// Longest `Drive::tick` call (ns).
    fn longest_tick_ns(&self) -> u32;
    /// Longest stretch with every interrupt masked (ns).
    fn longest_masked_ns(&self) -> u32;
    /// The current loop's statistics.
    fn current_loop(&self) -> CurrentLoop;
    /// Restarts the measurements: lock, tick, masked stretches, the current loop.
    fn reset_longest_section(&self);
}

/// The hooks of the board objects.
pub struct BoardHooks {
    /// The board's measurements.
    pub measurements: &'static (dyn Measurements + Sync),
}

impl BoardHooks {
    fn measured(&self, index: u16) -> Option<u32> {
        match index {
            TICK_COUNT => Some(TICK_MONITOR.ticks()),
            TICK_LATENESS_MAX => Some(TICK_MONITOR.max_lateness()),
            TICK_LATENESS_MEAN => Some(TICK_MONITOR.mean_lateness()),
            STACK_USED => Some(self.measurements.stack_used()),
            LONGEST_LOCK => Some(self.measurements.longest_lock_ns()),
            LONGEST_TICK => Some(self.measurements.longest_tick_ns()),
            LONGEST_MASKED => Some(self.measurements.longest_masked_ns()),
            CURRENT_LOOP_RUNS => Some(self.measurements.current_loop().runs),
            CURRENT_LOOP_GAP_MAX => Some(self.measurements.current_loop().longest_gap_ns),
            CURRENT_LOOP_LATENESS_MAX => Some(self.measurements.current_loop().most_late_ns),
            _ => None,
        }
    }
}

impl ObjectHooks for BoardHooks {
    fn read_len(&mut self, index: u16, _sub: u8) -> Option<Result<usize, AbortCode>> {
        match index {
            TEST_PATTERN => Some(Ok(TEST_PATTERN_LEN)),
            _ => self.measured(index).map(|_| Ok(4)),
        }
    }

    fn read(&mut self, index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        if index == TEST_PATTERN {
            let n = buf.len().min(TEST_PATTERN_LEN.saturating_sub(offset));
            for (i, b) in buf.iter_mut().take(n).enumerate() {
                *b = pattern_byte(offset + i);
            }
            return Ok(n);
        }
        let bytes = self.measured(index).unwrap_or(0).to_le_bytes();
        let rest = bytes.get(offset..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        for (d, s) in buf.iter_mut().zip(rest) {
            *d = *s;
        }
        Ok(n)
    }

    fn written(&mut self, index: u16, _sub: u8, data: &[u8]) {
        let raw = data.iter().rev().fold(0u32, |acc, b| (acc << 8) | u32::from(*b));
        match index {
            TEST_EXIT => {
                EXIT_CODE.store(raw, Ordering::Relaxed);
                EXIT_REQUESTED.store(true, Ordering::Release);
            }
            TICK_LATENESS_MAX => {
                TICK_MONITOR.reset();
                self.measurements.reset_longest_section();
            }
            SIMULATED_LOAD => LOAD.store(raw, Ordering::Relaxed),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use canopen_drive::{Config, Drive};

    struct Fixed;
    impl Measurements for Fixed {
        fn stack_used(&self) -> u32 {
            1234
        }
        fn longest_lock_ns(&self) -> u32 {
            5678
        }
        fn longest_tick_ns(&self) -> u32 {
            910
        }
        fn longest_masked_ns(&self) -> u32 {
            112
        }
        fn current_loop(&self) -> CurrentLoop {
            CurrentLoop { runs: 20, longest_gap_ns: 50_000, most_late_ns: 700 }
        }
        fn reset_longest_section(&self) {}
    }

    #[test]
    fn the_objects_fit_the_default_dictionary() {
        let config = Config { manufacturer_objects: &BOARD_OBJECTS, ..Config::new(5) };
        let drive = Drive::with_hooks(config, BoardHooks { measurements: &Fixed });
        assert!(drive.is_ok());
    }

    #[test]
    fn writes_reach_the_statics() {
        let mut hooks = BoardHooks { measurements: &Fixed };
        assert_eq!(exit_requested(), None);
        hooks.written(SIMULATED_LOAD, 0, &(-200i16).to_le_bytes());
        assert_eq!(load_torque(), -200);
        hooks.written(TEST_EXIT, 0, &7u32.to_le_bytes());
        assert_eq!(exit_requested(), Some(7));
        let mut buf = [0; 4];
        assert_eq!(hooks.read_len(STACK_USED, 0), Some(Ok(4)));
        assert_eq!(hooks.read(STACK_USED, 0, 0, &mut buf), Ok(4));
        assert_eq!(u32::from_le_bytes(buf), 1234);
        assert_eq!(hooks.read(CURRENT_LOOP_GAP_MAX, 0, 0, &mut buf), Ok(4));
        assert_eq!(u32::from_le_bytes(buf), 50_000);
        let mut chunk = [0; 7];
        assert_eq!(hooks.read(TEST_PATTERN, 0, TEST_PATTERN_LEN - 3, &mut chunk), Ok(3));
        assert_eq!(chunk[0], pattern_byte(TEST_PATTERN_LEN - 3));
    }
}
