//! The board's power stage and feedback: what is initialised here is real (clocks, the
//! three-phase complementary PWM on TIM1 with dead time, ADC1 for the DC-link voltage, TIM4 as
//! quadrature encoder interface on the J8 hall/encoder connector); what turns a demand into
//! phase currents is the board's to complete and marked `BOARD STUB`.
//!
//! Pins from ST's UM2516 (B-G431B-ESC1 user manual): check them against your board revision.
//!
//! | function | pins |
//! |---|---|
//! | TIM1 CH1/CH1N, CH2/CH2N, CH3/CH3N (L6387 gate drivers) | PA8/PC13, PA9/PA12, PA10/PB15 |
//! | DC-link voltage divider (ADC1_IN1) | PA0 |
//! | encoder A/B (TIM4 CH1/CH2), H1/H2 of the hall connector | PB6/PB7 |

use canopen_drive::hal::{Demand, Sample, Setpoint};
use embassy_stm32::adc::{Adc, AdcConfig, SampleTime};
use embassy_stm32::gpio::OutputType;
use embassy_stm32::peripherals::{ADC1, PA0, PA10, PA12, PA8, PA9, PB15, PB6, PB7, PC13, TIM1, TIM4};
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::complementary_pwm::{ComplementaryPwm, ComplementaryPwmPin};
use embassy_stm32::timer::low_level::CountingMode;
use embassy_stm32::timer::qei::Qei;
use embassy_stm32::timer::simple_pwm::PwmPin;
use embassy_stm32::timer::{Ch1, Ch2, Channel};
use embassy_stm32::Peri;

/// PWM frequency of the inverter.
pub const PWM_HZ: u32 = 20_000;
/// DC link: volts per ADC count × 1000 (the board's 10.4 kΩ / 169 kΩ divider on 3.3 V, 12 bit:
/// BOARD STUB — calibrate).
const DC_LINK_MILLIVOLTS_PER_COUNT: u32 = 14;

/// System clock 170 MHz from HSI16 through the PLL, FDCAN and ADC on their own kernel clocks.
pub fn clocks() -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.pll = Some(Pll {
        source: PllSource::HSI,
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL85,
        divp: None,
        divq: Some(PllQDiv::DIV4),
        divr: Some(PllRDiv::DIV2),
    });
    config.rcc.sys = Sysclk::PLL1_R;
    config.rcc.boost = true;
    config.rcc.mux.fdcansel = mux::Fdcansel::PLL1_Q;
    config.rcc.mux.adc12sel = mux::Adcsel::SYS;
    config
}

/// The peripherals the power stage and the feedback take.
pub struct Pins {
    /// Advanced timer of the inverter.
    pub tim1: Peri<'static, TIM1>,
    /// Phase U high side.
    pub ch1: Peri<'static, PA8>,
    /// Phase U low side.
    pub ch1n: Peri<'static, PC13>,
    /// Phase V high side.
    pub ch2: Peri<'static, PA9>,
    /// Phase V low side.
    pub ch2n: Peri<'static, PA12>,
    /// Phase W high side.
    pub ch3: Peri<'static, PA10>,
    /// Phase W low side.
    pub ch3n: Peri<'static, PB15>,
    /// The ADC of the DC-link measurement.
    pub adc1: Peri<'static, ADC1>,
    /// DC-link divider.
    pub vbus: Peri<'static, PA0>,
    /// Encoder timer.
    pub tim4: Peri<'static, TIM4>,
    /// Encoder A.
    pub encoder_a: Peri<'static, PB6>,
    /// Encoder B.
    pub encoder_b: Peri<'static, PB7>,
}

/// Sets up the inverter (outputs off) and the feedback.
pub fn init(pins: Pins) -> (Feedback, Stage) {
    let mut pwm = ComplementaryPwm::new(
        pins.tim1,
        Some(PwmPin::new(pins.ch1, OutputType::PushPull)),
        Some(ComplementaryPwmPin::new(pins.ch1n, OutputType::PushPull)),
        Some(PwmPin::new(pins.ch2, OutputType::PushPull)),
        Some(ComplementaryPwmPin::new(pins.ch2n, OutputType::PushPull)),
        Some(PwmPin::new(pins.ch3, OutputType::PushPull)),
        Some(ComplementaryPwmPin::new(pins.ch3n, OutputType::PushPull)),
        None,
        None,
        Hertz(PWM_HZ),
        CountingMode::CenterAlignedBothInterrupts,
    );
    // About 500 ns at 170 MHz (BOARD STUB: take the gate driver's and MOSFETs' figures).
    pwm.set_dead_time(85);
    let mut stage = Stage { pwm, enabled: false };
    stage.outputs(false);

    let adc = Adc::new(pins.adc1, AdcConfig::default());
    let qei = Qei::new::<Ch1, Ch2>(pins.tim4, pins.encoder_a, pins.encoder_b, Default::default());
    let feedback = Feedback { adc, vbus: pins.vbus, qei, last_count: 0, position: 0, velocity: 0 };
    (feedback, stage)
}

/// The sensors: encoder position and velocity, DC-link voltage.
pub struct Feedback {
    adc: Adc<'static, ADC1>,
    vbus: Peri<'static, PA0>,
    qei: Qei<'static, TIM4>,
    last_count: u16,
    position: i32,
    velocity: i32,
}

impl Feedback {
    /// One sample, taken at the tick.
    pub fn sample(&mut self) -> Sample {
        let count = self.qei.count();
        let step = count.wrapping_sub(self.last_count) as i16;
        self.last_count = count;
        self.position = self.position.wrapping_add(i32::from(step));
        // Increments per tick × tick rate (1 kHz).
        self.velocity = i32::from(step).saturating_mul(1000);
        let vbus = u32::from(self.adc.blocking_read(&mut self.vbus, SampleTime::CYCLES24_5));
        Sample {
            position: self.position,
            velocity: self.velocity,
            // BOARD STUB: phase currents from the three op-amps (OPAMP1-3 into ADC1/ADC2),
            // transformed to torque; hardware faults from the L6387 / comparator inputs;
            // the hall sensors for commutation.
            torque: 0,
            dc_link_millivolts: vbus.saturating_mul(DC_LINK_MILLIVOLTS_PER_COUNT),
            ..Sample::default()
        }
    }
}

/// The inverter.
pub struct Stage {
    pwm: ComplementaryPwm<'static, TIM1>,
    enabled: bool,
}

impl Stage {
    fn outputs(&mut self, on: bool) {
        for channel in [Channel::Ch1, Channel::Ch2, Channel::Ch3] {
            if on {
                self.pwm.enable(channel);
            } else {
                self.pwm.disable(channel);
            }
        }
        self.enabled = on;
    }

    /// Applies the demand of one tick. Energy only while the drive profile says so
    /// (`drive_enabled`: the power stage is energised only when the drive says so): otherwise all six switches are off, unless a
    /// dynamic brake is asked for (`dynamic_brake`): then the three low-side switches are on
    /// (duty 0 of the complementary outputs), shorting the windings, and no energy flows in.
    pub fn apply(&mut self, demand: &Demand) {
        if !demand.drive_enabled {
            if demand.dynamic_brake {
                if !self.enabled {
                    self.outputs(true);
                }
                for channel in [Channel::Ch1, Channel::Ch2, Channel::Ch3] {
                    self.pwm.set_duty(channel, 0);
                }
            } else if self.enabled {
                self.outputs(false);
            }
            return;
        }
        if !self.enabled {
            self.outputs(true);
        }
        // BOARD STUB: the field-oriented current loop goes here (or in the ADC end-of-
        // conversion interrupt at PWM rate): turn the set-point into phase duties from the
        // rotor angle. Until then the stage holds 50 % on every phase (no net voltage).
        let half = self.pwm.get_max_duty() / 2;
        let _setpoint: Setpoint = demand.setpoint;
        for channel in [Channel::Ch1, Channel::Ch2, Channel::Ch3] {
            self.pwm.set_duty(channel, half);
        }
    }
}
