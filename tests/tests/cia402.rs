//! The CiA 402 drive profile on the virtual bus with the simulated motor. Tests are named after
//! the items of `shared/spec/cia402-testable.md` they check (a_01 = section A, item 1); the
//! statusword is compared through the masks of digest §3.5.

mod common;

use common::profile::*;
use common::*;

use canopen_drive::cia402::fsa::State;
use canopen_drive::comm::NmtState;
use canopen_drive::hal::{HardwareFaults, Setpoint};
use canopen_drive::Duration;

#[test]
fn a_01_reaches_switch_on_disabled_by_itself() {
    let mut bench = Bench::new();
    bench.advance(Duration::from_millis(2));
    assert!(is(&mut bench, SOD));
    assert_eq!(statusword(&mut bench) & 0x0200, 0x0200, "remote");
}

#[test]
fn a_02_to_a_05_enable_sequence_and_power() {
    let mut bench = Bench::new();
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
    assert!(!node(&mut bench).demand.high_voltage);
    cw(&mut bench, 0x0007, 2);
    assert!(is(&mut bench, SO));
    assert!(node(&mut bench).demand.high_voltage, "transition 3 switches high-level power on");
    assert_eq!(statusword(&mut bench) & 0x0010, 0x0010, "a_09: voltage enabled");
    assert!(!node(&mut bench).demand.drive_enabled);
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE));
    assert!(node(&mut bench).demand.drive_enabled, "transition 4 enables the drive function");
    // a_05: from Ready to switch on, 0x000F goes to Operation enabled at once.
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE));
}

#[test]
fn a_06_to_a_08_commands_without_effect_in_switch_on_disabled() {
    let mut bench = Bench::new();
    for value in [0x0007, 0x000F, 0x0002, 0x0000] {
        cw(&mut bench, value, 2);
        assert!(is(&mut bench, SOD), "{value:#06x}");
    }
}

#[test]
fn b_14_b_15_disable_operation_with_and_without_ramp() {
    let mut bench = Bench::new();
    // 605Ch = 1 (default): while moving, Operation enabled is reported until the ramp is done.
    enable_pv(&mut bench);
    write(&mut bench, 0x6084, &20_000u32.to_le_bytes());
    write(&mut bench, 0x60FF, &2000i32.to_le_bytes());
    bench.advance(Duration::from_millis(500));
    cw(&mut bench, 0x0007, 1);
    assert!(is(&mut bench, OE), "ramping down");
    bench.advance(Duration::from_millis(200));
    assert!(is(&mut bench, SO));
    assert!(!node(&mut bench).demand.drive_enabled);
    // 605Ch = 0: at once.
    write(&mut bench, 0x605C, &0i16.to_le_bytes());
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE));
    cw(&mut bench, 0x0007, 1);
    assert!(is(&mut bench, SO));
}

#[test]
fn b_16_b_19_shutdown_and_disable_voltage_leave_at_once() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    bench.advance(Duration::from_millis(200));
    cw(&mut bench, 0x0006, 1);
    assert!(is(&mut bench, RTSO), "605Bh = 0: no ramp");
    assert!(!node(&mut bench).demand.drive_enabled);
    assert!(!node(&mut bench).demand.high_voltage);
    cw(&mut bench, 0x000F, 2);
    cw(&mut bench, 0x0000, 1);
    assert!(is(&mut bench, SOD), "transition 9");
    cw(&mut bench, 0x0006, 1);
    cw(&mut bench, 0x000F, 1);
    cw(&mut bench, 0x000D, 1);
    assert!(is(&mut bench, SOD), "b_20: bit 1 = 0 is disable voltage");
}

#[test]
fn c_24_c_25_quick_stop_ramps_with_6085_then_switch_on_disabled() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    write(&mut bench, 0x6085, &10_000u32.to_le_bytes());
    write(&mut bench, 0x6083, &100_000u32.to_le_bytes());
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    bench.advance(Duration::from_millis(100));
    assert_eq!(bench.drive().od().get::<i32>(0x606B, 0), Ok(1000));
    cw(&mut bench, 0x000B, 1);
    assert!(is(&mut bench, QSA));
    assert_eq!(statusword(&mut bench) & 0x0020, 0, "bit 5 = 0 while quick stopping");
    // 10 000 inc/s²: the velocity demand falls by 500 inc/s in 50 ms.
    let first = bench.drive().od().get::<i32>(0x606B, 0).unwrap();
    bench.advance(Duration::from_millis(50));
    let second = bench.drive().od().get::<i32>(0x606B, 0).unwrap();
    assert!((495..=505).contains(&(first - second)), "{first} → {second}");
    bench.advance(Duration::from_millis(120));
    assert!(is(&mut bench, SOD));
}

#[test]
fn c_28_c_31_quick_stop_option_6_stays_and_may_return() {
    let mut bench = Bench::new();
    write(&mut bench, 0x605A, &6i16.to_le_bytes());
    enable_pv(&mut bench);
    cw(&mut bench, 0x000B, 5);
    assert!(is(&mut bench, QSA));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400, "target reached at rest");
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE), "transition 16");
    cw(&mut bench, 0x000B, 5);
    cw(&mut bench, 0x0000, 1);
    assert!(is(&mut bench, SOD), "c_31: transition 12");
}

#[test]
fn d_36_to_d_42_faults_and_fault_reset() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    bench.advance(Duration::from_millis(100));
    node(&mut bench).motor.inject_fault(HardwareFaults::OVER_CURRENT);
    let frames = bench.advance(Duration::from_millis(1));
    assert!(is(&mut bench, FRA), "d_36: fault reaction while stopping");
    // d_46: EMCY 2310h with current and device-profile bits, 603Fh holds it.
    let emcy = frames.iter().find(|f| f.standard_id() == Some(0x85)).expect("EMCY");
    assert_eq!(embedded_can::Frame::data(emcy)[..3], [0x10, 0x23, 0x23]);
    assert_eq!(bench.drive().od().get::<u16>(0x603F, 0), Ok(0x2310));
    bench.advance(Duration::from_millis(200));
    assert!(is(&mut bench, FAULT));
    assert!(!node(&mut bench).demand.drive_enabled);
    // d_41: cause present → no reset.
    cw(&mut bench, 0x0000, 1);
    cw(&mut bench, 0x0080, 2);
    assert!(is(&mut bench, FAULT));
    // d_43: holding bit 7 while the cause clears does not reset.
    node(&mut bench).motor.clear_faults();
    bench.advance(Duration::from_millis(2));
    assert!(is(&mut bench, FAULT));
    // d_42: a new edge resets.
    cw(&mut bench, 0x0000, 1);
    cw(&mut bench, 0x0080, 2);
    assert!(is(&mut bench, SOD));
    // d_44: with bit 7 still set other commands are not decoded.
    cw(&mut bench, 0x0086, 2);
    assert!(is(&mut bench, SOD));
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
}

#[test]
fn g_58_option_code_defaults_and_g_63_reserved_values() {
    let mut bench = Bench::new();
    for (index, default) in
        [(0x6007u16, 1i16), (0x605A, 2), (0x605B, 0), (0x605C, 1), (0x605D, 1), (0x605E, 2)]
    {
        let r = bench.sdo1(&req(0x40, index, 0, [0; 4]));
        assert_eq!(r[..6], req(0x4B, index, 0, [default as u8, 0, 0, 0])[..6], "{index:04X}");
    }
    for (index, value) in
        [(0x605Du16, 0i16), (0x605A, 9), (0x605B, 2), (0x605E, 5), (0x6007, 4), (0x6007, -1)]
    {
        let [a, b] = value.to_le_bytes();
        assert_eq!(
            bench.sdo1(&req(0x2B, index, 0, [a, b, 0, 0])),
            abort(index, 0, 0x0609_0030),
            "{index:04X}"
        );
    }
    assert_eq!(bench.drive().od().get::<i16>(0x605A, 0), Ok(2), "old value kept");
}

#[test]
fn g_59_heartbeat_loss_in_operation_enabled_faults_the_axis() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0x23, 0x1016, 1, [100, 0, 3, 0]));
    bench.send(frame(0x000, &[0x01, NODE]));
    enable_pv(&mut bench);
    bench.send(frame(0x703, &[0x05]));
    bench.advance(Duration::from_millis(150));
    assert!(is(&mut bench, FAULT));
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
}

#[test]
fn g_60_g_61_abort_connection_as_disable_voltage_or_quick_stop() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6007, &2i16.to_le_bytes());
    enable_pv(&mut bench);
    bench.send(frame(0x000, &[0x02, NODE]));
    bench.advance(Duration::from_millis(2));
    bench.send(frame(0x000, &[0x80, NODE]));
    assert!(is(&mut bench, SOD), "6007h = 2: disable voltage");
    write(&mut bench, 0x6007, &3i16.to_le_bytes());
    enable_pv(&mut bench);
    bench.send(frame(0x000, &[0x02, NODE]));
    bench.advance(Duration::from_millis(1));
    assert_eq!(bench.drive().state(), State::QuickStopActive, "6007h = 3: quick stop");
}

#[test]
fn h_66_to_h_71_modes_of_operation() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x6060, 0, [0; 4])), req(0x4F, 0x6060, 0, [0; 4]));
    // pp + pv + tq.
    assert_eq!(bench.sdo1(&req(0x40, 0x6502, 0, [0; 4])), req(0x43, 0x6502, 0, [0x0D, 0, 0, 0]));
    // h_68 reserved, h_69 not in 6502h (homing, vl).
    for mode in [5u8, 11, 0x80, 6, 2] {
        assert_eq!(bench.sdo1(&req(0x2F, 0x6060, 0, [mode, 0, 0, 0])), abort(0x6060, 0, 0x0609_0030));
    }
    assert_eq!(bench.sdo1(&req(0x2F, 0x6061, 0, [3, 0, 0, 0])), abort(0x6061, 0, 0x0601_0002));
    write(&mut bench, 0x6060, &[4]);
    bench.advance(Duration::from_millis(2));
    assert_eq!(bench.sdo1(&req(0x40, 0x6061, 0, [0; 4])), req(0x4F, 0x6061, 0, [4, 0, 0, 0]));
}

#[test]
fn o_154_o_156_profile_velocity_ramps_and_reaches_the_target() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    write(&mut bench, 0x6083, &10_000u32.to_le_bytes());
    write(&mut bench, 0x6084, &20_000u32.to_le_bytes());
    write(&mut bench, 0x606D, &100u16.to_le_bytes());
    write(&mut bench, 0x606E, &10u16.to_le_bytes());
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    let demand = bench.drive().od().get::<i32>(0x606B, 0).unwrap();
    assert!((480..=520).contains(&demand), "6083h slope: {demand}");
    assert_eq!(statusword(&mut bench) & 0x0400, 0, "not reached yet");
    bench.advance(Duration::from_millis(500));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Velocity(1000));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400, "within 606Dh for 606Eh");
    // A lower target decelerates with 6084h.
    write(&mut bench, 0x60FF, &0i32.to_le_bytes());
    bench.advance(Duration::from_millis(25));
    let demand = bench.drive().od().get::<i32>(0x606B, 0).unwrap();
    assert!((480..=520).contains(&demand), "6084h slope: {demand}");
}

#[test]
fn o_157_halt_in_profile_velocity() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    bench.advance(Duration::from_millis(300));
    cw(&mut bench, 0x010F, 1);
    assert_eq!(statusword(&mut bench) & 0x0400, 0, "decelerating");
    bench.advance(Duration::from_millis(300));
    assert!(is(&mut bench, OE));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400, "at rest under halt");
    assert_eq!(bench.drive().od().get::<i32>(0x606B, 0), Ok(0));
    cw(&mut bench, 0x000F, 300);
    assert_eq!(bench.drive().od().get::<i32>(0x606B, 0), Ok(1000), "o_158: back to 60FFh");
}

#[test]
fn p_161_p_163_profile_torque_slope_and_limit() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6060, &[4]);
    write(&mut bench, 0x6087, &1000u32.to_le_bytes());
    write(&mut bench, 0x6072, &400u16.to_le_bytes());
    cw(&mut bench, 0x0006, 1);
    cw(&mut bench, 0x000F, 1);
    write(&mut bench, 0x6071, &500i16.to_le_bytes());
    bench.advance(Duration::from_millis(200));
    let torque = bench.drive().od().get::<i16>(0x6074, 0).unwrap();
    assert!((190..=210).contains(&torque), "1000 ‰/s: {torque}");
    bench.advance(Duration::from_millis(600));
    assert_eq!(bench.drive().od().get::<i16>(0x6074, 0), Ok(400), "limited by 6072h");
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(400));
}

#[test]
fn s_179_to_s_183_object_attributes() {
    let mut bench = Bench::new();
    for index in [0x6041u16, 0x6502, 0x6061, 0x6064] {
        assert_eq!(bench.sdo1(&req(0x23, index, 0, [0; 4])), abort(index, 0, 0x0601_0002), "{index:04X}");
    }
    for index in [0x6045u16, 0x6050, 0x6089] {
        assert_eq!(bench.sdo1(&req(0x40, index, 0, [0; 4])), abort(index, 0, 0x0602_0000), "{index:04X}");
    }
    assert_eq!(bench.sdo1(&req(0x40, 0x6060, 0, [0; 4]))[0], 0x4F, "1 byte");
    assert_eq!(bench.sdo1(&req(0x40, 0x6040, 0, [0; 4]))[0], 0x4B, "2 bytes");
    assert_eq!(bench.sdo1(&req(0x40, 0x607A, 0, [0; 4]))[0], 0x43, "4 bytes");
    assert_eq!(bench.sdo1(&req(0x23, 0x6040, 0, [0; 4])), abort(0x6040, 0, 0x0607_0012));
    assert_eq!(bench.sdo1(&req(0x40, 0x60FE, 0, [0; 4])), req(0x4F, 0x60FE, 0, [2, 0, 0, 0]));
    for sub in 1..=2 {
        assert_eq!(bench.sdo1(&req(0x40, 0x60FE, sub, [0; 4])), req(0x43, 0x60FE, sub, [0; 4]));
    }
    for index in [0x6403u16, 0x6404, 0x6405, 0x6503, 0x6505] {
        assert_eq!(bench.sdo1(&req(0x40, index, 0, [0; 4])), req(0x41, index, 0, [0; 4]), "empty string");
        assert_eq!(bench.sdo1(&[0x60, 0, 0, 0, 0, 0, 0, 0]), [0x0F, 0, 0, 0, 0, 0, 0, 0]);
    }
    assert_eq!(bench.sdo1(&req(0x40, 0x6407, 0, [0; 4])), req(0x43, 0x6407, 0, [0; 4]));
}

#[test]
fn t_185_t_186_digital_inputs_and_brake_output() {
    use canopen_drive::hal::DigitalInputs;
    let mut bench = Bench::new();
    for (input, bit) in [
        (DigitalInputs::NEGATIVE_LIMIT, 0),
        (DigitalInputs::POSITIVE_LIMIT, 1),
        (DigitalInputs::HOME, 2),
        (DigitalInputs::INTERLOCK, 3),
    ] {
        node(&mut bench).motor.set_input(input, true);
        bench.advance(Duration::from_millis(2));
        assert_eq!(bench.drive().od().get::<u32>(0x60FD, 0), Ok(1 << bit));
        node(&mut bench).motor.set_input(input, false);
    }
    enable_pv(&mut bench);
    assert!(node(&mut bench).demand.brake_released);
    // Brake bit set, but masked off: no effect.
    bench.sdo1(&req(0x23, 0x60FE, 1, [1, 0, 0, 0]));
    bench.advance(Duration::from_millis(2));
    assert!(node(&mut bench).demand.brake_released);
    bench.sdo1(&req(0x23, 0x60FE, 2, [1, 0, 0, 0]));
    bench.advance(Duration::from_millis(2));
    assert!(!node(&mut bench).demand.brake_released, "brake engaged by the master");
}
