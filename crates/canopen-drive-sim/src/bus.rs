//! A virtual CAN bus with a virtual clock: whole nodes exchanging frames, deterministically,
//! without threads or wall-clock time.
//!
//! ## Model
//!
//! - The bus holds [`Node`]s (any type: a [`canopen_drive::Drive`], a fake written in a test)
//!   and one external port, the *master port* ([`Port::Master`]), through which a test or the
//!   scripted [`Master`](crate::Master) sends ([`VirtualBus::send`]) and receives
//!   ([`VirtualBus::received`]).
//! - A frame put on the bus reaches every node except its sender, and the master port unless
//!   the master sent it. Each frame gets a sequence number; frames due at the same instant are
//!   delivered in the order they were sent, one at a time, and each delivery is followed by the
//!   receivers' reactions, so cause always precedes effect.
//! - Time moves only in [`run_until`](VirtualBus::run_until) / [`advance`](VirtualBus::advance).
//!   The bus steps the clock to every instant at which something is due (a node deadline from
//!   [`Node::poll`], or a frame in flight because of [`set_latency`](VirtualBus::set_latency)
//!   or a delaying [fault rule](crate::fault)), and at each instant works until nothing is left
//!   to do: it polls the nodes that are due or received a frame, drains their transmit queues,
//!   and delivers the frames that are due. Nodes are always visited in the order they were
//!   added.
//! - Every frame is recorded in the [trace].
//!
//! ## Guards
//!
//! A node that keeps producing frames, or keeps asking to be polled again at the same instant,
//! would make a simulation loop forever. [`Limits`] bounds the work per instant and the
//! instants per call; exceeding either returns a [`BusError`] instead of hanging the test.

use std::any::Any;
use std::collections::VecDeque;
use std::fmt;
use std::marker::PhantomData;

use canopen_drive::od::ObjectHooks;
use canopen_drive::storage::Persistence;
use canopen_drive::{CanFrame, Drive, Duration, Instant};

use crate::fault::{FaultAction, FaultRule};
use crate::trace::{self, Fate, TraceRecord};

/// A participant of the virtual bus, driven the way a board drives a [`Drive`]: frames in,
/// deadlines out, frames drained.
pub trait Node {
    /// Handles one frame received at `now`.
    fn on_frame(&mut self, frame: &CanFrame, now: Instant);
    /// Does the work due at `now`; returns when to be polled next (`None`: only after a frame).
    fn poll(&mut self, now: Instant) -> Option<Instant>;
    /// The next frame to transmit.
    fn pop_tx(&mut self) -> Option<CanFrame>;
    /// The name shown in traces when the node is added with [`VirtualBus::add_node`].
    fn name(&self) -> String {
        "node".to_string()
    }
}

/// A drive on the bus; its name is `node<id>`.
impl<H: ObjectHooks, const B: usize, const R: usize, const T: usize, S: Persistence, const AXES: usize> Node
    for Drive<H, B, R, T, S, AXES>
{
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        Drive::on_frame(self, frame, now);
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        Drive::poll(self, now)
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        Drive::pop_tx(self)
    }

    fn name(&self) -> String {
        format!("node{}", self.node_id())
    }
}

/// A bootloader on the bus ([`canopen_drive::bootloader`]); its name is `boot<id>`.
impl<F: canopen_drive::storage::NonVolatile, const BUF: usize> Node
    for canopen_drive::bootloader::Bootloader<F, BUF>
{
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        canopen_drive::bootloader::Bootloader::on_frame(self, frame, now);
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        canopen_drive::bootloader::Bootloader::poll(self, now)
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        canopen_drive::bootloader::Bootloader::pop_tx(self)
    }

    fn name(&self) -> String {
        format!("boot{}", self.od().node_id())
    }
}

/// A node as the bus stores it: a [`Node`] that can be looked at under its own type again.
trait AnyNode: Node {
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Node + Any> AnyNode for T {
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// Names a node on one [`VirtualBus`] (the order in which it was added).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeHandle(usize);

impl NodeHandle {
    /// The handle of the `index`-th node added to a bus (0-based).
    pub const fn from_index(index: usize) -> Self {
        NodeHandle(index)
    }

    /// The position of the node on its bus.
    pub const fn index(self) -> usize {
        self.0
    }
}

/// A node of type `T` on one [`VirtualBus`], from [`VirtualBus::add_drive`]: the bus gives
/// it back as a `T` ([`VirtualBus::drive`], [`VirtualBus::drive_mut`]) without the test naming
/// the type again (where a wrong type given to [`VirtualBus::node_mut`] would find nothing).
pub struct Handle<T> {
    handle: NodeHandle,
    node: PhantomData<fn() -> T>,
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Handle<T> {}

impl<T> fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Handle({})", self.handle.0)
    }
}

impl<T> Handle<T> {
    /// The untyped handle (for [`Port::Node`], fault rules and traces).
    pub const fn untyped(self) -> NodeHandle {
        self.handle
    }
}

/// Where a frame enters the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Port {
    /// The external port of the test or the scripted master.
    Master,
    /// A node.
    Node(NodeHandle),
}

/// Why the bus stopped a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusError {
    /// The work at one instant did not come to an end within [`Limits::steps_per_instant`]
    /// steps: a node keeps transmitting, or keeps asking to be polled again at `at`.
    NoProgress {
        /// The instant that did not settle.
        at: Instant,
    },
    /// One call visited more than [`Limits::instants_per_run`] instants (deadlines that
    /// advance by tiny steps, or a run far too long).
    TooManyInstants {
        /// Where the clock stopped.
        at: Instant,
    },
}

impl fmt::Display for BusError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BusError::NoProgress { at } => {
                write!(f, "the bus did not settle at {} us (a node keeps working)", at.as_micros())
            }
            BusError::TooManyInstants { at } => {
                write!(f, "too many deadlines in one run (stopped at {} us)", at.as_micros())
            }
        }
    }
}

impl std::error::Error for BusError {}

/// Bounds on the work of one call, so that a misbehaving node fails a test instead of hanging
/// it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Polls, drained frames and deliveries at one instant.
    pub steps_per_instant: usize,
    /// Instants one [`VirtualBus::run_until`] may step through.
    pub instants_per_run: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { steps_per_instant: 100_000, instants_per_run: 10_000_000 }
    }
}

/// A frame that reached the master port.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Received {
    /// When it arrived.
    pub time: Instant,
    /// Who sent it.
    pub from: Port,
    /// The frame.
    pub frame: CanFrame,
}

struct Slot {
    name: String,
    node: Box<dyn AnyNode>,
    deadline: Option<Instant>,
    /// Must be polled at the current instant (added, or received a frame).
    dirty: bool,
}

/// A frame on its way to the receivers.
#[derive(Clone, Copy, Debug)]
struct InFlight {
    at: Instant,
    seq: u64,
    from: Port,
    frame: CanFrame,
    fate: Fate,
}

/// The virtual CAN bus (see the [module docs](self)).
pub struct VirtualBus {
    now: Instant,
    nodes: Vec<Slot>,
    in_flight: Vec<InFlight>,
    next_seq: u64,
    received: Vec<Received>,
    trace: VecDeque<TraceRecord>,
    trace_limit: Option<usize>,
    faults: Vec<FaultRule>,
    latency: Duration,
    interface: String,
    limits: Limits,
}

impl Default for VirtualBus {
    fn default() -> Self {
        VirtualBus::new()
    }
}

impl fmt::Debug for VirtualBus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("VirtualBus")
            .field("now", &self.now)
            .field("nodes", &self.nodes.iter().map(|s| s.name.as_str()).collect::<Vec<_>>())
            .field("in_flight", &self.in_flight.len())
            .field("received", &self.received.len())
            .field("trace", &self.trace.len())
            .field("faults", &self.faults)
            .finish()
    }
}

impl VirtualBus {
    /// An empty bus at time zero, without latency, named `vcan0` in traces.
    pub fn new() -> Self {
        VirtualBus {
            now: Instant::ZERO,
            nodes: Vec::new(),
            in_flight: Vec::new(),
            next_seq: 0,
            received: Vec::new(),
            trace: VecDeque::new(),
            trace_limit: None,
            faults: Vec::new(),
            latency: Duration::ZERO,
            interface: "vcan0".to_string(),
            limits: Limits::default(),
        }
    }

    /// Adds a node under its own [`Node::name`]. It is polled for the first time at the next
    /// instant the bus works (a [`Drive`] sends its boot-up frame then).
    pub fn add_node(&mut self, node: impl Node + 'static) -> NodeHandle {
        let name = node.name();
        self.add_named_node(name, node)
    }

    /// Adds a node shown as `name` in traces.
    pub fn add_named_node(&mut self, name: impl Into<String>, node: impl Node + 'static) -> NodeHandle {
        self.nodes.push(Slot { name: name.into(), node: Box::new(node), deadline: None, dirty: true });
        NodeHandle(self.nodes.len() - 1)
    }

    /// Adds a node (e.g. a [`DriveNode`](crate::DriveNode) around the firmware's own drive)
    /// under its own [`Node::name`], and returns a handle that knows its type.
    pub fn add_drive<T: Node + 'static>(&mut self, node: T) -> Handle<T> {
        Handle { handle: self.add_node(node), node: PhantomData }
    }

    /// The node behind a typed handle (`None` only for a handle of another bus).
    pub fn drive<T: Node + 'static>(&self, handle: Handle<T>) -> Option<&T> {
        self.node(handle.handle)
    }

    /// The node behind a typed handle, mutable (`None` only for a handle of another bus). The
    /// node is polled again at the next instant the bus works.
    pub fn drive_mut<T: Node + 'static>(&mut self, handle: Handle<T>) -> Option<&mut T> {
        self.node_mut(handle.handle)
    }

    /// The node behind `handle`, if it has type `T`.
    pub fn node<T: Node + 'static>(&self, handle: NodeHandle) -> Option<&T> {
        self.nodes.get(handle.0)?.node.as_any().downcast_ref()
    }

    /// The node behind `handle`, mutable, if it has type `T`. The node is polled again at the
    /// next instant the bus works, in case the change moved its deadline.
    pub fn node_mut<T: Node + 'static>(&mut self, handle: NodeHandle) -> Option<&mut T> {
        let slot = self.nodes.get_mut(handle.0)?;
        slot.dirty = true;
        slot.node.as_any_mut().downcast_mut()
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The name of a port in traces.
    pub fn port_name(&self, port: Port) -> &str {
        match port {
            Port::Master => "master",
            Port::Node(handle) => self.nodes.get(handle.0).map_or("?", |slot| slot.name.as_str()),
        }
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Time from transmission to reception of every frame (default zero: a reaction happens
    /// at the same instant as its cause).
    pub fn set_latency(&mut self, latency: Duration) {
        self.latency = latency;
    }

    /// The work bounds of one call.
    pub fn set_limits(&mut self, limits: Limits) {
        self.limits = limits;
    }

    /// The work bounds of one call.
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// The interface name in rendered traces (default `vcan0`).
    pub fn set_interface_name(&mut self, name: impl Into<String>) {
        self.interface = name.into();
    }

    /// Puts `frame` on the bus from the master port, at the current time. It is delivered when
    /// the bus next works ([`settle`](Self::settle), [`run_until`](Self::run_until)).
    pub fn send(&mut self, frame: CanFrame) {
        self.transmit(Port::Master, frame);
    }

    /// Adds a fault rule (tried after the rules added before it); returns its position for
    /// [`fault`](Self::fault).
    pub fn add_fault(&mut self, rule: FaultRule) -> usize {
        self.faults.push(rule);
        self.faults.len() - 1
    }

    /// The fault rule at `position`, to read its counters.
    pub fn fault(&self, position: usize) -> Option<&FaultRule> {
        self.faults.get(position)
    }

    /// Removes every fault rule.
    pub fn clear_faults(&mut self) {
        self.faults.clear();
    }

    /// Frames that reached the master port, oldest first.
    pub fn received(&self) -> &[Received] {
        &self.received
    }

    /// Takes every frame that reached the master port.
    pub fn drain_received(&mut self) -> Vec<Received> {
        std::mem::take(&mut self.received)
    }

    /// Takes every frame that reached the master port, without time and sender.
    pub fn drain_received_frames(&mut self) -> Vec<CanFrame> {
        self.drain_received().into_iter().map(|r| r.frame).collect()
    }

    /// Takes the oldest received frame for which `pred` is true, leaving the others.
    pub fn take_received(&mut self, mut pred: impl FnMut(&Received) -> bool) -> Option<Received> {
        let position = self.received.iter().position(&mut pred)?;
        Some(self.received.remove(position))
    }

    /// The trace: every frame the bus carried (the last [`set_trace_limit`](Self::set_trace_limit)
    /// ones), oldest first.
    pub fn trace(&self) -> Vec<TraceRecord> {
        self.trace.iter().cloned().collect()
    }

    /// The trace as candump-style text, one line per frame.
    pub fn render_trace(&self) -> String {
        trace::render(&self.trace, &self.interface)
    }

    /// Forgets the trace so far.
    pub fn clear_trace(&mut self) {
        self.trace.clear();
    }

    /// Keeps only the newest `limit` records (`None`: keep everything, the default).
    pub fn set_trace_limit(&mut self, limit: Option<usize>) {
        self.trace_limit = limit;
        self.trim_trace();
    }

    /// The next instant at which something is due: a node deadline or a frame in flight.
    pub fn next_event(&self) -> Option<Instant> {
        let deadlines =
            self.nodes.iter().filter_map(|slot| if slot.dirty { Some(self.now) } else { slot.deadline });
        let frames = self.in_flight.iter().map(|f| f.at);
        deadlines.chain(frames).min()
    }

    /// Does all the work due at the current instant, without moving the clock.
    pub fn settle(&mut self) -> Result<(), BusError> {
        let mut steps = 0usize;
        loop {
            let mut progressed = false;
            for index in 0..self.nodes.len() {
                steps = steps.saturating_add(self.service_node(index));
            }
            if let Some(frame) = self.take_due_frame() {
                self.deliver(frame);
                steps = steps.saturating_add(1);
                progressed = true;
            }
            let due =
                self.nodes.iter().any(|slot| slot.dirty || slot.deadline.is_some_and(|d| d <= self.now));
            if !progressed && !due {
                return Ok(());
            }
            if steps > self.limits.steps_per_instant {
                return Err(BusError::NoProgress { at: self.now });
            }
        }
    }

    /// Runs the bus up to and including `until`, stepping the clock through every deadline and
    /// frame in flight on the way; the clock ends at `until` (or stays if already later).
    pub fn run_until(&mut self, until: Instant) -> Result<(), BusError> {
        self.settle()?;
        let mut instants = 0usize;
        while let Some(next) = self.next_event().filter(|&t| t <= until) {
            instants = instants.saturating_add(1);
            if instants > self.limits.instants_per_run {
                return Err(BusError::TooManyInstants { at: self.now });
            }
            self.now = self.now.max(next);
            self.settle()?;
        }
        self.now = self.now.max(until);
        self.settle()
    }

    /// Runs the bus for `span` of virtual time.
    pub fn advance(&mut self, span: Duration) -> Result<(), BusError> {
        self.run_until(self.now + span)
    }

    /// Polls node `index` if it is due and drains its transmit queue; returns the steps done.
    fn service_node(&mut self, index: usize) -> usize {
        let now = self.now;
        let mut frames = Vec::new();
        let mut steps = 0;
        if let Some(slot) = self.nodes.get_mut(index) {
            if slot.dirty || slot.deadline.is_some_and(|d| d <= now) {
                slot.dirty = false;
                slot.deadline = slot.node.poll(now);
                steps += 1;
            }
            // Bounded by the node's transmit queue; the per-instant guard catches a node that
            // refills it forever.
            while let Some(frame) = slot.node.pop_tx() {
                frames.push(frame);
                if frames.len() > self.limits.steps_per_instant {
                    break;
                }
            }
        }
        steps += frames.len();
        for frame in frames {
            self.transmit(Port::Node(NodeHandle(index)), frame);
        }
        steps
    }

    /// Applies the fault rules to a frame sent now and schedules its delivery.
    fn transmit(&mut self, from: Port, frame: CanFrame) {
        let action = self.faults.iter_mut().find_map(|rule| rule.hits(&frame, from).then(|| rule.action()));
        let at = self.now + self.latency;
        match action {
            None => self.schedule(at, from, frame, Fate::Delivered),
            Some(FaultAction::Drop) => self.record(self.now, from, frame, Fate::Dropped),
            Some(FaultAction::Delay(by)) => self.schedule(at + by, from, frame, Fate::Delayed(by)),
            Some(FaultAction::Duplicate) => {
                self.schedule(at, from, frame, Fate::Delivered);
                self.schedule(at, from, frame, Fate::Duplicate);
            }
        }
    }

    fn schedule(&mut self, at: Instant, from: Port, frame: CanFrame, fate: Fate) {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1);
        self.in_flight.push(InFlight { at, seq, from, frame, fate });
    }

    /// Removes the earliest frame due now (ties in sending order).
    fn take_due_frame(&mut self) -> Option<InFlight> {
        let now = self.now;
        let position = self
            .in_flight
            .iter()
            .enumerate()
            .filter(|(_, f)| f.at <= now)
            .min_by_key(|(_, f)| (f.at, f.seq))
            .map(|(i, _)| i)?;
        Some(self.in_flight.remove(position))
    }

    fn deliver(&mut self, flight: InFlight) {
        let now = self.now;
        self.record(now, flight.from, flight.frame, flight.fate);
        for (index, slot) in self.nodes.iter_mut().enumerate() {
            if flight.from != Port::Node(NodeHandle(index)) {
                slot.node.on_frame(&flight.frame, now);
                slot.dirty = true;
            }
        }
        if flight.from != Port::Master {
            self.received.push(Received { time: now, from: flight.from, frame: flight.frame });
        }
    }

    fn record(&mut self, time: Instant, from: Port, frame: CanFrame, fate: Fate) {
        let sender = self.port_name(from).to_string();
        self.trace.push_back(TraceRecord { time, from, sender, frame, fate });
        self.trim_trace();
    }

    fn trim_trace(&mut self) {
        if let Some(limit) = self.trace_limit {
            while self.trace.len() > limit {
                self.trace.pop_front();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::Frame;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new_standard(id, data).unwrap()
    }

    /// Answers every frame on `listen` with `reply` after `delay`; sends `[n]` on `tick_id`
    /// every `period` if set.
    struct Echo {
        listen: u16,
        reply: u16,
        delay: Duration,
        period: Option<Duration>,
        next_tick: Instant,
        ticks: u8,
        pending: Vec<(Instant, CanFrame)>,
        tx: VecDeque<CanFrame>,
        seen: Vec<(Instant, CanFrame)>,
    }

    impl Echo {
        fn new(listen: u16, reply: u16) -> Self {
            Echo {
                listen,
                reply,
                delay: Duration::ZERO,
                period: None,
                next_tick: Instant::ZERO,
                ticks: 0,
                pending: Vec::new(),
                tx: VecDeque::new(),
                seen: Vec::new(),
            }
        }
    }

    impl Node for Echo {
        fn on_frame(&mut self, f: &CanFrame, now: Instant) {
            self.seen.push((now, *f));
            if f.standard_id() == Some(self.listen) {
                let reply = CanFrame::new_standard(self.reply, f.data()).unwrap();
                self.pending.push((now + self.delay, reply));
            }
        }
        fn poll(&mut self, now: Instant) -> Option<Instant> {
            let (due, later): (Vec<_>, Vec<_>) = self.pending.drain(..).partition(|(at, _)| *at <= now);
            self.pending = later;
            self.tx.extend(due.into_iter().map(|(_, f)| f));
            if let Some(period) = self.period {
                if now >= self.next_tick {
                    self.tx.push_back(frame(0x700, &[self.ticks]));
                    self.ticks = self.ticks.wrapping_add(1);
                    self.next_tick = now + period;
                }
            }
            let tick = self.period.map(|_| self.next_tick);
            self.pending.iter().map(|(at, _)| *at).chain(tick).min()
        }
        fn pop_tx(&mut self) -> Option<CanFrame> {
            self.tx.pop_front()
        }
        fn name(&self) -> String {
            format!("echo{:x}", self.listen)
        }
    }

    /// Asks to be polled again at the same instant forever.
    struct Busy;
    impl Node for Busy {
        fn on_frame(&mut self, _: &CanFrame, _: Instant) {}
        fn poll(&mut self, now: Instant) -> Option<Instant> {
            Some(now)
        }
        fn pop_tx(&mut self) -> Option<CanFrame> {
            None
        }
    }

    /// Transmits a frame every time it is asked.
    struct Chatter;
    impl Node for Chatter {
        fn on_frame(&mut self, _: &CanFrame, _: Instant) {}
        fn poll(&mut self, _: Instant) -> Option<Instant> {
            None
        }
        fn pop_tx(&mut self) -> Option<CanFrame> {
            CanFrame::new_standard(0x123, &[])
        }
    }

    #[test]
    fn frames_reach_every_other_node_and_the_master() {
        let mut bus = VirtualBus::new();
        let a = bus.add_node(Echo::new(0x100, 0x101));
        let b = bus.add_node(Echo::new(0x101, 0x102));
        bus.send(frame(0x100, &[7]));
        bus.settle().unwrap();
        // a answers the master on 0x101, b answers a on 0x102; nobody hears its own frame.
        let got: Vec<u16> = bus.received().iter().map(|r| r.frame.standard_id().unwrap()).collect();
        assert_eq!(got, [0x101, 0x102]);
        assert_eq!(bus.received()[0].from, Port::Node(a));
        let seen_a: Vec<u16> =
            bus.node::<Echo>(a).unwrap().seen.iter().map(|(_, f)| f.standard_id().unwrap()).collect();
        let seen_b: Vec<u16> =
            bus.node::<Echo>(b).unwrap().seen.iter().map(|(_, f)| f.standard_id().unwrap()).collect();
        assert_eq!(seen_a, [0x100, 0x102]);
        assert_eq!(seen_b, [0x100, 0x101]);
        assert_eq!(bus.now(), Instant::ZERO);
        let senders: Vec<String> = bus.trace().into_iter().map(|r| r.sender).collect();
        assert_eq!(senders, ["master", "echo100", "echo101"]);
    }

    #[test]
    fn clock_steps_through_every_deadline() {
        let mut bus = VirtualBus::new();
        let mut echo = Echo::new(0x100, 0x101);
        echo.delay = Duration::from_micros(2500);
        echo.period = Some(Duration::from_millis(10));
        bus.add_named_node("ticker", echo);
        bus.send(frame(0x100, &[1]));
        bus.run_until(Instant::from_millis(25)).unwrap();
        assert_eq!(bus.now(), Instant::from_millis(25));
        let got: Vec<(u64, u16)> = bus
            .drain_received()
            .iter()
            .map(|r| (r.time.as_micros(), r.frame.standard_id().unwrap()))
            .collect();
        assert_eq!(got, [(0, 0x700), (2500, 0x101), (10_000, 0x700), (20_000, 0x700)]);
        assert!(bus.received().is_empty());
        bus.advance(Duration::from_millis(5)).unwrap();
        assert_eq!(bus.drain_received_frames(), [frame(0x700, &[3])]);
        assert_eq!(bus.next_event(), Some(Instant::from_millis(40)));
    }

    #[test]
    fn latency_delays_every_frame() {
        let mut bus = VirtualBus::new();
        bus.add_node(Echo::new(0x100, 0x101));
        bus.set_latency(Duration::from_micros(200));
        bus.send(frame(0x100, &[]));
        bus.settle().unwrap();
        assert!(bus.received().is_empty());
        bus.advance(Duration::from_millis(1)).unwrap();
        let r = bus.take_received(|r| r.frame.standard_id() == Some(0x101)).unwrap();
        assert_eq!(r.time, Instant::from_micros(400));
        assert!(bus.take_received(|_| true).is_none());
    }

    #[test]
    fn trace_renders_like_candump() {
        let mut bus = VirtualBus::new();
        bus.add_named_node("echo", Echo::new(0x605, 0x585));
        bus.run_until(Instant::from_millis(1)).unwrap();
        bus.send(frame(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
        bus.send(CanFrame::new_remote_standard(0x705, 1).unwrap());
        bus.settle().unwrap();
        assert_eq!(
            bus.render_trace(),
            "(000.001000)  vcan0  605   [8]  40 00 10 00 00 00 00 00  ; master\n\
             (000.001000)  vcan0  705   [1]  R                        ; master\n\
             (000.001000)  vcan0  585   [8]  40 00 10 00 00 00 00 00  ; echo\n"
        );
        bus.set_trace_limit(Some(1));
        assert_eq!(bus.trace().len(), 1);
        assert_eq!(bus.trace()[0].frame.standard_id(), Some(0x585));
        bus.clear_trace();
        assert!(bus.trace().is_empty());
    }

    #[test]
    fn drop_rule_loses_the_frame_for_everyone() {
        let mut bus = VirtualBus::new();
        let echo = bus.add_node(Echo::new(0x100, 0x101));
        let rule = bus.add_fault(FaultRule::drop().with_id(0x100).times(1));
        bus.send(frame(0x100, &[1]));
        bus.send(frame(0x100, &[2]));
        bus.settle().unwrap();
        assert_eq!(bus.drain_received_frames(), [frame(0x101, &[2])]);
        assert_eq!(bus.node::<Echo>(echo).unwrap().seen.len(), 1);
        assert_eq!(bus.fault(rule).unwrap().applied(), 1);
        let fates: Vec<Fate> = bus.trace().iter().map(|r| r.fate).collect();
        assert_eq!(fates, [Fate::Dropped, Fate::Delivered, Fate::Delivered]);
        assert!(bus.render_trace().lines().next().unwrap().ends_with("; master (dropped)"));
    }

    #[test]
    fn delay_rule_lets_later_frames_overtake() {
        let mut bus = VirtualBus::new();
        bus.add_node(Echo::new(0x100, 0x101));
        bus.add_fault(
            FaultRule::delay(Duration::from_millis(3)).from_port(Port::Master).when(|f, _| f.data() == [1]),
        );
        bus.send(frame(0x100, &[1]));
        bus.send(frame(0x100, &[2]));
        bus.advance(Duration::from_millis(5)).unwrap();
        let got: Vec<(u64, Vec<u8>)> =
            bus.drain_received().iter().map(|r| (r.time.as_micros(), r.frame.data().to_vec())).collect();
        assert_eq!(got, [(0, vec![2]), (3000, vec![1])]);
        let delayed = bus.trace().into_iter().find(|r| r.fate != Fate::Delivered).unwrap();
        assert_eq!(
            (delayed.time, delayed.fate),
            (Instant::from_millis(3), Fate::Delayed(Duration::from_millis(3)))
        );
    }

    #[test]
    fn duplicate_rule_delivers_twice() {
        let mut bus = VirtualBus::new();
        let echo = bus.add_node(Echo::new(0x100, 0x101));
        bus.add_fault(FaultRule::duplicate().from_port(Port::Node(echo)));
        bus.send(frame(0x100, &[9]));
        bus.settle().unwrap();
        assert_eq!(bus.drain_received_frames(), [frame(0x101, &[9]), frame(0x101, &[9])]);
        let fates: Vec<Fate> = bus.trace().iter().map(|r| r.fate).collect();
        assert_eq!(fates, [Fate::Delivered, Fate::Delivered, Fate::Duplicate]);
    }

    #[test]
    fn rate_rule_is_deterministic_on_the_bus() {
        let run = || {
            let mut bus = VirtualBus::new();
            bus.add_node(Echo::new(0x100, 0x101));
            bus.add_fault(FaultRule::drop().from_port(Port::Master).rate(0.3, 2024));
            for n in 0..50u8 {
                bus.send(frame(0x100, &[n]));
            }
            bus.settle().unwrap();
            bus.drain_received_frames()
        };
        let first = run();
        assert_eq!(first, run());
        assert!((20..50).contains(&first.len()), "{}", first.len());
    }

    #[test]
    fn guards_stop_runaway_nodes() {
        let mut bus = VirtualBus::new();
        bus.add_node(Busy);
        assert_eq!(bus.settle(), Err(BusError::NoProgress { at: Instant::ZERO }));
        let mut bus = VirtualBus::new();
        bus.add_node(Chatter);
        bus.set_limits(Limits { steps_per_instant: 1000, ..Limits::default() });
        assert_eq!(bus.advance(Duration::from_millis(1)), Err(BusError::NoProgress { at: Instant::ZERO }));
        let mut bus = VirtualBus::new();
        let mut echo = Echo::new(0, 0);
        echo.period = Some(Duration::from_micros(1));
        bus.add_node(echo);
        bus.set_limits(Limits { instants_per_run: 100, ..Limits::default() });
        assert!(matches!(bus.advance(Duration::from_millis(1)), Err(BusError::TooManyInstants { .. })));
        assert!(BusError::NoProgress { at: Instant::ZERO }.to_string().contains("did not settle"));
    }

    #[test]
    fn nodes_are_reachable_under_their_type() {
        let mut bus = VirtualBus::new();
        let h = bus.add_node(Echo::new(1, 2));
        assert!(bus.node::<Busy>(h).is_none());
        assert!(bus.node::<Echo>(NodeHandle::from_index(5)).is_none());
        bus.node_mut::<Echo>(h).unwrap().listen = 3;
        assert_eq!(bus.node::<Echo>(h).unwrap().listen, 3);
        assert_eq!(bus.port_name(Port::Node(h)), "echo1");
        assert_eq!(bus.node_count(), 1);
        assert_eq!(h.index(), 0);
    }
}
