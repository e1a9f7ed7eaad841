//! The full drive with two axes (issue 23): `Drive<…, AXES = 2>` with every CiA 402 mode, 4 + 4
//! PDOs per axis, the dictionary store sized to its tables (the second axis's profile objects
//! are the first axis's description attached once more), no manufacturer objects, no
//! parameter storage. The scripted master drives the first axis; both axes tick every
//! millisecond with the same sample.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use canopen_drive::cia402::registry::AXIS_PROFILE;
use canopen_drive::comm::pdo;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::{layout, standard, storage_bytes, Object};
use canopen_drive::{CanFrame, Config, Drive, Instant};
use canopen_drive_footprint::{run, target, Node, NODE_ID};

/// 8 RPDOs and 8 TPDOs: PDOs 1–4 the first axis's, 5–8 the second's.
static PDOS: [Object; 32] = layout(pdo::objects::<32>(8));

/// The store the node's tables take.
const BYTES: usize = storage_bytes(&[&standard::COMMUNICATION, &PDOS, &AXIS_PROFILE, &AXIS_PROFILE]);

type TwoAxes = Drive<(), BYTES, 8, 8, (), 2>;

/// The two-axis drive as the harness's node: one sample for both axes, the first axis's demand.
struct Node2(&'static mut TwoAxes);

impl Node for Node2 {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.0.on_frame(frame, now);
    }
    fn poll(&mut self, now: Instant) -> Option<Instant> {
        self.0.poll(now)
    }
    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.0.pop_tx()
    }
    fn tick(&mut self, now: Instant, sample: &Sample) -> Demand {
        let [first, _] = self.0.tick_axes(now, &[*sample; 2]);
        first
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    static mut NODE: MaybeUninit<TwoAxes> = MaybeUninit::uninit();
    let config = Config { pdo_objects: &PDOS, ..Config::new(NODE_ID) };
    let Ok(node) = Drive::build_in(NODE, config, (), ()) else { semihosting::process::exit(102) };
    let init = target::used_since_reset();
    let depth = run(&mut Node2(node), &mut target::probe);
    target::report_and_exit(init, depth)
}
