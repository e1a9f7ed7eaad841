//! The harness alone: start-up, the scripted master, the stack probe, no node. Its size is
//! what the other images carry besides the library.
#![no_std]
#![no_main]

use canopen_drive::hal::{Demand, Sample};
use canopen_drive::{CanFrame, Instant};
use canopen_drive_footprint::{run, sink, target, Node};

/// Answers nothing, but looks at every frame (so the harness's delivery stays in the image).
struct Nothing(u32);

impl Node for Nothing {
    fn on_frame(&mut self, frame: &CanFrame, _now: Instant) {
        self.0 = self.0.wrapping_add(u32::from(frame.standard_id().unwrap_or(0)));
    }
    fn poll(&mut self, _now: Instant) -> Option<Instant> {
        None
    }
    fn pop_tx(&mut self) -> Option<CanFrame> {
        None
    }
    fn tick(&mut self, _now: Instant, _sample: &Sample) -> Demand {
        Demand::OFF
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut node = Nothing(0);
    let init = target::used_since_reset();
    let depth = run(&mut node, &mut target::probe);
    sink(node.0);
    target::report_and_exit(init, depth)
}
