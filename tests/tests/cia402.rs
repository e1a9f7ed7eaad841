//! The CiA 402 drive profile on the virtual bus with the simulated motor. Tests are named after
//! the items of `docs/testing.md` they check (a_01 = section A, item 1); the
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
fn a_02_a_03_a_04_a_05_a_09_enable_sequence_and_power() {
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
fn a_06_a_07_a_08_commands_without_effect_in_switch_on_disabled() {
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
fn b_16_b_19_b_20_shutdown_and_disable_voltage_leave_at_once() {
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
fn c_28_c_29_c_31_quick_stop_option_6_stays_and_may_return() {
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
fn d_36_d_41_d_42_d_43_d_44_d_46_faults_and_fault_reset() {
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
fn g_58_g_63_option_code_defaults_and_reserved_values() {
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
fn h_66_h_68_h_69_h_70_h_71_modes_of_operation() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x6060, 0, [0; 4])), req(0x4F, 0x6060, 0, [0; 4]));
    // Every mode of the standard: pp, vl, pv, tq, hm, ip, csp, csv, cst.
    assert_eq!(bench.sdo1(&req(0x40, 0x6502, 0, [0; 4])), req(0x43, 0x6502, 0, [0xEF, 0x03, 0, 0]));
    // h_68 reserved values (h_69, a mode missing from 6502h, in modes_not_listed_are_refused).
    for mode in [5u8, 11, 0x80] {
        assert_eq!(bench.sdo1(&req(0x2F, 0x6060, 0, [mode, 0, 0, 0])), abort(0x6060, 0, 0x0609_0030));
    }
    assert_eq!(bench.sdo1(&req(0x2F, 0x6061, 0, [3, 0, 0, 0])), abort(0x6061, 0, 0x0601_0002));
    write(&mut bench, 0x6060, &[4]);
    bench.advance(Duration::from_millis(2));
    assert_eq!(bench.sdo1(&req(0x40, 0x6061, 0, [0; 4])), req(0x4F, 0x6061, 0, [4, 0, 0, 0]));
}

#[test]
fn h_69_modes_missing_from_6502_are_refused() {
    let mut bench = Bench::with_config(|mut config| {
        config.device.drive_modes = 0x0005; // pp and pv only
        config
    });
    for mode in [2u8, 4, 6, 7, 8, 9, 10] {
        assert_eq!(
            bench.sdo1(&req(0x2F, 0x6060, 0, [mode, 0, 0, 0])),
            abort(0x6060, 0, 0x0609_0030),
            "{mode}"
        );
    }
    write(&mut bench, 0x6060, &[3]);
    bench.advance(Duration::from_millis(2));
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0), Ok(3));
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
fn o_157_o_158_halt_in_profile_velocity() {
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
fn s_179_s_180_s_181_s_182_s_183_object_attributes() {
    let mut bench = Bench::new();
    for index in [0x6041u16, 0x6502, 0x6061, 0x6064] {
        assert_eq!(bench.sdo1(&req(0x23, index, 0, [0; 4])), abort(index, 0, 0x0601_0002), "{index:04X}");
    }
    // s_180: the mandatory objects of the built modes (pp, pv, tq; digest §20.1) exist.
    for index in [
        0x1000u16, 0x1001, 0x1018, 0x6040, 0x6041, 0x6502, 0x6060, 0x6061, 0x607A, 0x6064, 0x6081, 0x6083,
        0x606C, 0x60FF, 0x6071, 0x6087,
    ] {
        assert_ne!(bench.sdo1(&req(0x40, index, 0, [0; 4]))[0], 0x80, "{index:04X}");
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

/// The velocity demand 606Bh.
fn velocity_demand(bench: &mut Bench) -> i32 {
    bench.drive().od().get::<i32>(0x606B, 0).unwrap()
}

/// pv enabled and running at 1000 increments/s.
fn moving_pv(bench: &mut Bench) {
    enable_pv(bench);
    write(bench, 0x60FF, &1000i32.to_le_bytes());
    bench.advance(Duration::from_millis(200));
    assert_eq!(velocity_demand(bench), 1000);
}

#[test]
fn a_10_no_dc_link_voltage_clears_bit_4_only() {
    let mut bench = Bench::new();
    node(&mut bench).motor.set_dc_link_millivolts(0);
    bench.advance(Duration::from_millis(2));
    assert!(is(&mut bench, SOD));
    assert_eq!(statusword(&mut bench) & 0x0010, 0);
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
    cw(&mut bench, 0x0007, 2);
    assert!(is(&mut bench, SO), "the state code does not depend on bit 4");
    assert_eq!(statusword(&mut bench) & 0x0010, 0, "no DC link: voltage not enabled");
}

#[test]
fn a_11_a_12_a_13_repeated_commands_change_nothing() {
    let mut bench = Bench::new();
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
    assert_eq!(node(&mut bench).demand, canopen_drive::hal::Demand::OFF, "a_11: no power switched");
    cw(&mut bench, 0x0007, 2);
    let switched_on = node(&mut bench).demand;
    cw(&mut bench, 0x0007, 2);
    assert!(is(&mut bench, SO));
    assert_eq!(node(&mut bench).demand, switched_on, "a_12");
    cw(&mut bench, 0x000F, 2);
    let enabled = node(&mut bench).demand;
    for _ in 0..100 {
        cw(&mut bench, 0x000F, 1);
        assert_eq!(node(&mut bench).demand.drive_enabled, enabled.drive_enabled);
        assert_eq!(node(&mut bench).demand.high_voltage, enabled.high_voltage);
    }
    assert!(is(&mut bench, OE), "a_13");
}

#[test]
fn b_17_shutdown_option_1_ramps_before_ready_to_switch_on() {
    let mut bench = Bench::new();
    write(&mut bench, 0x605B, &1i16.to_le_bytes());
    write(&mut bench, 0x6084, &10_000u32.to_le_bytes());
    moving_pv(&mut bench);
    cw(&mut bench, 0x0006, 1);
    assert!(is(&mut bench, OE), "slowing down");
    assert!(node(&mut bench).demand.drive_enabled);
    bench.advance(Duration::from_millis(120));
    assert!(is(&mut bench, RTSO));
    assert!(!node(&mut bench).demand.high_voltage);
}

#[test]
fn b_18_b_21_b_22_transitions_6_7_10() {
    let mut bench = Bench::new();
    cw(&mut bench, 0x0006, 1);
    cw(&mut bench, 0x0007, 1);
    assert!(node(&mut bench).demand.high_voltage);
    cw(&mut bench, 0x0006, 1);
    assert!(is(&mut bench, RTSO), "b_18: transition 6");
    assert!(!node(&mut bench).demand.high_voltage, "high-level power off");
    for command in [0x0000u16, 0x0002] {
        cw(&mut bench, 0x0006, 1);
        cw(&mut bench, command, 1);
        assert!(is(&mut bench, SOD), "b_21: transition 7 by {command:#06x}");
    }
    for command in [0x0000u16, 0x0003] {
        cw(&mut bench, 0x0006, 1);
        cw(&mut bench, 0x0007, 1);
        cw(&mut bench, command, 1);
        assert!(is(&mut bench, SOD), "b_22: transition 10 by {command:#06x}");
    }
}

#[test]
fn c_26_quick_stop_option_1_uses_the_slow_down_ramp() {
    let mut bench = Bench::new();
    write(&mut bench, 0x605A, &1i16.to_le_bytes());
    write(&mut bench, 0x6084, &5000u32.to_le_bytes());
    write(&mut bench, 0x6085, &100_000u32.to_le_bytes());
    moving_pv(&mut bench);
    cw(&mut bench, 0x000B, 1);
    let first = velocity_demand(&mut bench);
    bench.advance(Duration::from_millis(100));
    let second = velocity_demand(&mut bench);
    assert!((495..=505).contains(&(first - second)), "6084h slope: {first} → {second}");
    assert!(is(&mut bench, QSA));
    bench.advance(Duration::from_millis(150));
    assert!(is(&mut bench, SOD));
}

#[test]
fn c_27_quick_stop_option_0_coasts() {
    let mut bench = Bench::new();
    write(&mut bench, 0x605A, &0i16.to_le_bytes());
    moving_pv(&mut bench);
    cw(&mut bench, 0x000B, 1);
    assert!(!node(&mut bench).demand.drive_enabled, "drive function off at once");
    assert!(is(&mut bench, SOD));
}

#[test]
fn c_30_transition_16_can_be_configured_off() {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.transition_16 = false;
        config
    });
    write(&mut bench, 0x605A, &6i16.to_le_bytes());
    enable_pv(&mut bench);
    cw(&mut bench, 0x000B, 5);
    cw(&mut bench, 0x000F, 5);
    assert!(is(&mut bench, QSA));
}

#[test]
fn c_32_c_33_quick_stop_completes_and_bit_5_returns() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6085, &5000u32.to_le_bytes());
    moving_pv(&mut bench);
    assert_eq!(statusword(&mut bench) & 0x0020, 0x0020, "bit 5 = 1 in OE");
    cw(&mut bench, 0x000B, 50);
    assert_eq!(statusword(&mut bench) & 0x0020, 0);
    cw(&mut bench, 0x000F, 50);
    assert!(is(&mut bench, QSA), "c_32: no return while decelerating (605Ah = 2)");
    assert_eq!(statusword(&mut bench) & 0x0020, 0, "c_33: bit 5 stays 0");
    bench.advance(Duration::from_millis(200));
    assert!(is(&mut bench, SOD));
    cw(&mut bench, 0x0006, 2);
    assert_eq!(statusword(&mut bench) & 0x0020, 0x0020, "bit 5 = 1 in RTSO");
}

#[test]
fn c_34_c_35_shutdown_in_quick_stop_and_after_it() {
    let mut bench = Bench::new();
    write(&mut bench, 0x605A, &6i16.to_le_bytes());
    enable_pv(&mut bench);
    cw(&mut bench, 0x000B, 5);
    cw(&mut bench, 0x0006, 5);
    assert!(is(&mut bench, QSA), "c_34: Shutdown ignored");
    // c_35 with 605Ah = 2: the automatic transition, then the quick-stop command held.
    cw(&mut bench, 0x0000, 2);
    write(&mut bench, 0x605A, &2i16.to_le_bytes());
    enable_pv(&mut bench);
    cw(&mut bench, 0x0002, 20);
    assert!(is(&mut bench, SOD));
    cw(&mut bench, 0x0002, 20);
    assert!(is(&mut bench, SOD));
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
}

#[test]
fn d_37_fault_reaction_0_coasts() {
    let mut bench = Bench::new();
    write(&mut bench, 0x605E, &0i16.to_le_bytes());
    moving_pv(&mut bench);
    node(&mut bench).motor.inject_fault(HardwareFaults::OVER_TEMPERATURE);
    bench.advance(Duration::from_millis(1));
    assert!(!node(&mut bench).demand.drive_enabled, "torque off in the detecting tick");
    assert!(is(&mut bench, FAULT));
}

#[test]
fn d_38_d_39_fault_reaction_ramps() {
    for (option, quick, slow, expected) in [(2i16, 5000u32, 100_000u32, 500), (1, 100_000, 5000, 500)] {
        let mut bench = Bench::new();
        write(&mut bench, 0x605E, &option.to_le_bytes());
        write(&mut bench, 0x6085, &quick.to_le_bytes());
        write(&mut bench, 0x6084, &slow.to_le_bytes());
        moving_pv(&mut bench);
        node(&mut bench).motor.inject_fault(HardwareFaults::OVER_TEMPERATURE);
        bench.advance(Duration::from_millis(1));
        let first = velocity_demand(&mut bench);
        bench.advance(Duration::from_millis(100));
        let second = velocity_demand(&mut bench);
        assert!(is(&mut bench, FRA), "fault only after standstill");
        assert!((expected - 5..=expected + 5).contains(&(first - second)), "{option}: {first} → {second}");
        bench.advance(Duration::from_millis(150));
        assert!(is(&mut bench, FAULT));
    }
}

#[test]
fn d_40_faults_in_the_disabled_states() {
    for commands in [&[][..], &[0x0006u16][..], &[0x0006, 0x0007][..]] {
        let mut bench = Bench::new();
        for &c in commands {
            cw(&mut bench, c, 2);
        }
        node(&mut bench).motor.inject_fault(HardwareFaults::UNDER_VOLTAGE);
        bench.advance(Duration::from_millis(2));
        assert!(is(&mut bench, FAULT), "after {commands:?}");
        assert_eq!(bench.drive().od().get::<u16>(0x603F, 0), Ok(0x3220));
    }
}

#[test]
fn d_45_commands_in_fault_and_fault_reaction_are_ignored() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6085, &2000u32.to_le_bytes());
    moving_pv(&mut bench);
    node(&mut bench).motor.inject_fault(HardwareFaults::OVER_TEMPERATURE);
    bench.advance(Duration::from_millis(1));
    node(&mut bench).motor.clear_faults();
    for command in [0x000F, 0x0000, 0x0080, 0x0006] {
        cw(&mut bench, command, 1);
        assert!(is(&mut bench, FRA), "{command:#06x} in FRA");
    }
    bench.advance(Duration::from_millis(600));
    assert!(is(&mut bench, FAULT));
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, FAULT));
}

#[test]
fn d_46_fault_history_and_device_profile_bit() {
    let mut bench = Bench::new();
    moving_pv(&mut bench);
    node(&mut bench).motor.inject_fault(HardwareFaults::OVER_VOLTAGE);
    let frames = bench.advance(Duration::from_millis(1));
    let emcy = frames.iter().find(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).expect("EMCY");
    assert_eq!(embedded_can::Frame::data(emcy)[..2], [0x10, 0x32]);
    assert_eq!(bench.drive().od().get::<u16>(0x603F, 0), Ok(0x3210));
    let history = bench.sdo1(&req(0x40, 0x1003, 1, [0; 4]));
    assert_eq!(u16::from_le_bytes([history[4], history[5]]), 0x3210);
    let register = bench.sdo1(&req(0x40, 0x1001, 0, [0; 4]))[4];
    assert_eq!(register & 0x20, 0x20, "device profile specific");
}

#[test]
fn d_47_warning_sets_bit_7_only() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    node(&mut bench).motor.set_warnings(HardwareFaults::OVER_TEMPERATURE);
    bench.advance(Duration::from_millis(2));
    assert_eq!(statusword(&mut bench) & 0x0080, 0x0080);
    assert!(is(&mut bench, OE));
    node(&mut bench).motor.set_warnings(HardwareFaults::empty());
    bench.advance(Duration::from_millis(2));
    assert_eq!(statusword(&mut bench) & 0x0080, 0);
}

#[test]
fn e_50_e_51_manufacturer_and_reserved_bits_are_ignored() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6060, &[3]);
    cw(&mut bench, 0xF806, 2);
    assert!(is(&mut bench, RTSO));
    cw(&mut bench, 0xF80F, 2);
    assert!(is(&mut bench, OE), "e_50: 0xF80F is Enable operation");
    cw(&mut bench, 0x040F, 2);
    assert!(is(&mut bench, OE), "e_51: bit 10 has no effect");
    cw(&mut bench, 0x0407, 2);
    assert!(is(&mut bench, SO));
}

#[test]
fn e_52_fault_reset_is_one_attempt_per_edge() {
    let mut bench = Bench::new();
    node(&mut bench).motor.inject_fault(HardwareFaults::ENCODER);
    bench.advance(Duration::from_millis(2));
    assert!(is(&mut bench, FAULT));
    cw(&mut bench, 0x0080, 1);
    node(&mut bench).motor.clear_faults();
    // Ten more frames with bit 7 set: no further reset attempt.
    for _ in 0..10 {
        cw(&mut bench, 0x0080, 1);
    }
    assert!(is(&mut bench, FAULT));
    cw(&mut bench, 0x0000, 1);
    cw(&mut bench, 0x0080, 1);
    assert!(is(&mut bench, SOD));
}

#[test]
fn f_53_local_control_clears_remote_and_ignores_the_controlword() {
    let mut bench = Bench::new();
    node(&mut bench).motor.set_local_control(true);
    bench.advance(Duration::from_millis(2));
    assert_eq!(statusword(&mut bench) & 0x0200, 0, "bit 9 = 0");
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, SOD), "no transition");
    node(&mut bench).motor.set_position(1234);
    bench.advance(Duration::from_millis(2));
    assert_eq!(read_i32(&mut bench, 0x6064), 1234, "actual values go on");
    node(&mut bench).motor.set_local_control(false);
    cw(&mut bench, 0x0000, 1);
    cw(&mut bench, 0x0006, 2);
    assert!(is(&mut bench, RTSO));
    assert_eq!(statusword(&mut bench) & 0x0200, 0x0200);
}

#[test]
fn f_54_h_67_bit_10_after_a_mode_change() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6060, &[3]);
    bench.advance(Duration::from_millis(1));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400, "bit 10 in the tick after the change");
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0), Ok(3));
    // h_67: in Operation enabled while moving, 6061h keeps the old mode until it has stopped.
    enable_pv(&mut bench);
    write(&mut bench, 0x60FF, &2000i32.to_le_bytes());
    bench.advance(Duration::from_millis(300));
    write(&mut bench, 0x6060, &[4]);
    bench.advance(Duration::from_millis(5));
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0), Ok(3), "still stopping in pv");
    assert!(velocity_demand(&mut bench) < 2000);
    bench.advance(Duration::from_millis(500));
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0), Ok(4));
    assert!(is(&mut bench, OE));
}

#[test]
fn f_55_same_target_velocity_keeps_bit_10() {
    let mut bench = Bench::new();
    enable_pv(&mut bench);
    write(&mut bench, 0x60FF, &500i32.to_le_bytes());
    bench.advance(Duration::from_millis(300));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400);
    write(&mut bench, 0x60FF, &500i32.to_le_bytes());
    bench.advance(Duration::from_millis(1));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400, "same value: bit 10 stays");
    write(&mut bench, 0x60FF, &900i32.to_le_bytes());
    bench.advance(Duration::from_millis(1));
    assert_eq!(statusword(&mut bench) & 0x0400, 0, "a new value clears it");
}

#[test]
fn f_56_unimplemented_mode_bits_read_0() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6060, &[4]);
    cw(&mut bench, 0x0006, 1);
    cw(&mut bench, 0x000F, 2);
    write(&mut bench, 0x6071, &100i16.to_le_bytes());
    for _ in 0..50 {
        bench.advance(Duration::from_millis(3));
        assert_eq!(statusword(&mut bench) & 0x3800, 0, "tq: bits 11, 12, 13 not used");
    }
}

#[test]
fn f_57_unavailable_function_sends_an_emcy() {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.change_on_setpoint = false;
        config
    });
    write(&mut bench, 0x6060, &[1]);
    cw(&mut bench, 0x0006, 1);
    cw(&mut bench, 0x000F, 2);
    write(&mut bench, 0x6040, &0x020Fu16.to_le_bytes());
    let frames = bench.advance(Duration::from_millis(1));
    let emcy = frames.iter().find(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).expect("EMCY");
    assert_eq!(embedded_can::Frame::data(emcy)[..2], [0x20, 0x63]);
    assert!(is(&mut bench, OE), "no state change");
    write(&mut bench, 0x6040, &0x000Fu16.to_le_bytes());
    let frames = bench.advance(Duration::from_millis(1));
    let reset = frames.iter().find(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).expect("EMCY reset");
    assert_eq!(embedded_can::Frame::data(reset)[..2], [0, 0]);
}

#[test]
fn g_62_reset_communication_leaves_the_axis_alone_with_6007_0() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6007, &0i16.to_le_bytes());
    moving_pv(&mut bench);
    bench.send(frame(0x000, &[0x82, NODE]));
    bench.advance(Duration::from_millis(5));
    assert!(is(&mut bench, OE));
    assert_eq!(velocity_demand(&mut bench), 1000);
}

#[test]
fn g_64_g_65_halt_ramps_per_605d() {
    for (option, quick, slow) in [(2i16, 5000u32, 100_000u32), (1, 100_000, 5000)] {
        let mut bench = Bench::new();
        write(&mut bench, 0x605D, &option.to_le_bytes());
        write(&mut bench, 0x6085, &quick.to_le_bytes());
        write(&mut bench, 0x6084, &slow.to_le_bytes());
        moving_pv(&mut bench);
        cw(&mut bench, 0x010F, 1);
        let first = velocity_demand(&mut bench);
        bench.advance(Duration::from_millis(100));
        let second = velocity_demand(&mut bench);
        assert!((495..=505).contains(&(first - second)), "605Dh = {option}: {first} → {second}");
        assert!(is(&mut bench, OE), "g_65");
        bench.advance(Duration::from_millis(200));
        assert!(is(&mut bench, OE), "g_65 after the halt");
    }
}

#[test]
fn h_72_mode_change_leaves_pdo_mapping_alone() {
    let mut bench = Bench::new();
    let read_mapping = |bench: &mut Bench| -> Vec<[u8; 8]> {
        let mut all = Vec::new();
        for index in [0x1600u16, 0x1601, 0x1A00, 0x1A01] {
            for sub in 0..=2 {
                all.push(bench.sdo1(&req(0x40, index, sub, [0; 4])));
            }
        }
        all
    };
    let before = read_mapping(&mut bench);
    for mode in [1u8, 3, 4, 1] {
        write(&mut bench, 0x6060, &[mode]);
        bench.advance(Duration::from_millis(2));
    }
    assert_eq!(read_mapping(&mut bench), before);
}

#[test]
fn o_155_speed_bit_12_with_threshold_time() {
    let mut bench = Bench::new();
    write(&mut bench, 0x606F, &50u16.to_le_bytes());
    write(&mut bench, 0x6070, &20u16.to_le_bytes());
    enable_pv(&mut bench);
    assert_eq!(statusword(&mut bench) & 0x1000, 0x1000, "speed = 0 at standstill");
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    let mut above = None;
    for n in 0..200 {
        bench.advance(Duration::from_millis(1));
        let actual = bench.drive().od().get::<i32>(0x606C, 0).unwrap();
        let bit12 = statusword(&mut bench) & 0x1000 != 0;
        if above.is_none() && actual.abs() > 50 {
            above = Some(n);
        }
        match above {
            Some(first) if n - first > 20 => assert!(!bit12, "{} ms above", n - first),
            _ => assert!(bit12, "within 6070h: {n}"),
        }
    }
}

#[test]
fn o_159_slippage_sets_bit_13() {
    let mut bench = Bench::new();
    write(&mut bench, 0x60F8, &100i32.to_le_bytes());
    enable_pv(&mut bench);
    write(&mut bench, 0x60FF, &500i32.to_le_bytes());
    bench.advance(Duration::from_millis(500));
    assert_eq!(statusword(&mut bench) & 0x2000, 0, "following the demand");
    // A load the motor cannot move: the actual velocity falls behind the demand.
    node(&mut bench).motor.set_load_torque(-5000.0);
    bench.advance(Duration::from_millis(100));
    assert_eq!(statusword(&mut bench) & 0x2000, 0x2000);
}

#[test]
fn o_160_p_164_s_184_defaults_and_sizes() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x606E, 0, [0; 4])), req(0x4B, 0x606E, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x606D, 0, [0; 4]))[0], 0x4B);
    assert_eq!(bench.sdo1(&req(0x40, 0x606F, 0, [0; 4]))[0], 0x4B);
    assert_eq!(bench.sdo1(&req(0x40, 0x6071, 0, [0; 4])), req(0x4B, 0x6071, 0, [0; 4]), "p_164");
    for (index, command) in [(0x607Cu16, 0x43), (0x60B0, 0x43), (0x60B1, 0x43), (0x60B2, 0x4B)] {
        assert_eq!(
            bench.sdo1(&req(0x40, index, 0, [0; 4])),
            req(command, index, 0, [0; 4]),
            "s_184 {index:04X}"
        );
    }
}

#[test]
fn p_162_halt_ramps_torque_to_zero_and_back() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6060, &[4]);
    write(&mut bench, 0x6087, &1000u32.to_le_bytes());
    cw(&mut bench, 0x0006, 1);
    cw(&mut bench, 0x000F, 1);
    write(&mut bench, 0x6071, &300i16.to_le_bytes());
    bench.advance(Duration::from_millis(400));
    assert_eq!(bench.drive().od().get::<i16>(0x6074, 0), Ok(300));
    cw(&mut bench, 0x010F, 100);
    let torque = bench.drive().od().get::<i16>(0x6074, 0).unwrap();
    assert!((195..=205).contains(&torque), "ramps down with 6087h: {torque}");
    bench.advance(Duration::from_millis(300));
    assert_eq!(bench.drive().od().get::<i16>(0x6074, 0), Ok(0));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400);
    cw(&mut bench, 0x000F, 400);
    assert_eq!(bench.drive().od().get::<i16>(0x6074, 0), Ok(300), "back to 6071h");
}

#[test]
fn brake_opens_before_motion_and_closes_before_the_drive_function_is_disabled() {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.brake_release_delay = Duration::from_millis(50);
        config.profile.brake_engage_delay = Duration::from_millis(30);
        config
    });
    write(&mut bench, 0x6060, &[3]);
    write(&mut bench, 0x60FF, &1000i32.to_le_bytes());
    write(&mut bench, 0x6083, &100_000u32.to_le_bytes());
    write(&mut bench, 0x6084, &100_000u32.to_le_bytes());
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x000F, 1);
    for _ in 0..48 {
        let demand = node(&mut bench).demand;
        assert!(demand.drive_enabled && demand.brake_released, "{demand:?}");
        assert!(matches!(demand.setpoint, Setpoint::Position(_)), "holding while the brake opens");
        assert_eq!(velocity_demand(&mut bench), 0);
        bench.advance(Duration::from_millis(1));
    }
    bench.advance(Duration::from_millis(60));
    assert_eq!(velocity_demand(&mut bench), 1000, "moves once the brake is open");
    // Disable operation (605Ch = 1): ramp (10 ms), then 30 ms with the brake closing.
    cw(&mut bench, 0x0007, 15);
    let demand = node(&mut bench).demand;
    assert!(demand.drive_enabled && !demand.brake_released, "holding while the brake closes");
    assert!(is(&mut bench, OE));
    bench.advance(Duration::from_millis(20));
    assert!(is(&mut bench, OE));
    bench.advance(Duration::from_millis(15));
    assert!(is(&mut bench, SO));
    assert!(!node(&mut bench).demand.drive_enabled);
}
