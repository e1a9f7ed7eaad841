//! The host-side CAN bus: one broadcast medium joining the drive and any number of endpoints
//! (SLCAN clients, a SocketCAN interface).
//!
//! Like a real CAN bus, every frame reaches every participant except its sender: a frame from
//! an endpoint goes to the drive and to every other endpoint; a frame from the drive goes to
//! every endpoint.
//!
//! ## Bounded and fair under overload
//!
//! A frame an endpoint sends waits in that endpoint's own queue ([`INBOX`] frames) until the
//! drive loop, the bus's only arbiter, takes it ([`Bus::receive`]): the loop takes the
//! endpoints' frames in turn, one each, and an endpoint puts at most [`RATE`] frames a second on
//! the bus (in bursts of up to [`BURST`]), more than a 1 Mbit/s CAN bus carries (about 9 000).
//! Frames an endpoint sends faster than that wait in its queue; when the queue is full, its
//! **oldest** frame is dropped for the newest, and counted. So a client flooding the bus
//! loses its own frames, and neither grows the program's memory nor delays the frames of the
//! others (or the drive loop, which never waits for an endpoint).
//!
//! Endpoints receive frames through a non-blocking [`Sink`], so a slow or stuck endpoint can
//! never hold up the drive or the others: a sink whose queue is full drops frames for that
//! endpoint alone (as a CAN controller drops frames on receive overrun).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use canopen_drive::CanFrame;

/// Identifies an endpoint attached to the bus.
pub type EndpointId = u64;

/// Frames an endpoint may have waiting for the bus; beyond, its oldest are dropped.
pub const INBOX: usize = 1024;
/// Frames per second an endpoint may put on the bus.
pub const RATE: u32 = 10_000;
/// Frames an endpoint may put on the bus at once, above [`RATE`].
pub const BURST: u32 = 1000;

/// What became of a frame handed to an endpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delivery {
    /// Queued for the endpoint.
    Queued,
    /// Queued, but the endpoint's queue was full: a frame (the oldest, or this one) is lost
    /// for this endpoint.
    Dropped,
    /// The endpoint is gone; the bus detaches it.
    Gone,
}

/// How the bus hands a frame to an endpoint. Must not block.
pub type Sink = Box<dyn Fn(&CanFrame) -> Delivery + Send>;

/// Frames lost for and by one endpoint (see [`Bus::detach`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Losses {
    /// Frames the endpoint sent that were dropped (its queue was full).
    pub sent: u64,
    /// Frames for the endpoint that its sink dropped.
    pub received: u64,
}

struct Endpoint {
    id: EndpointId,
    name: String,
    sink: Sink,
    inbox: VecDeque<CanFrame>,
    /// Frames it may put on the bus now (refilled at [`RATE`] up to [`BURST`]).
    budget: f64,
    refilled: Instant,
    losses: Losses,
}

impl Endpoint {
    /// Refills the budget for the time since the last refill.
    fn refill(&mut self, now: Instant) {
        let elapsed = now.saturating_duration_since(self.refilled).as_secs_f64();
        self.budget = (self.budget + elapsed * f64::from(RATE)).min(f64::from(BURST));
        self.refilled = now;
    }

    /// When its next waiting frame may go (now if it may).
    fn ready_at(&self) -> Option<Instant> {
        if self.inbox.is_empty() {
            return None;
        }
        let missing = (1.0 - self.budget).max(0.0);
        Some(self.refilled + Duration::from_secs_f64(missing / f64::from(RATE)))
    }
}

#[derive(Default)]
struct State {
    endpoints: Vec<Endpoint>,
    /// The endpoint whose frame goes next if it has one (round robin).
    turn: usize,
}

struct Shared {
    state: Mutex<State>,
    /// Signalled when a frame waits.
    arrived: Condvar,
    next_id: AtomicU64,
}

/// A handle on the bus; clones share it.
#[derive(Clone)]
pub struct Bus {
    shared: Arc<Shared>,
}

impl Default for Bus {
    fn default() -> Self {
        Bus::new()
    }
}

impl Bus {
    /// A bus with no endpoints.
    pub fn new() -> Bus {
        let shared = Shared {
            state: Mutex::new(State::default()),
            arrived: Condvar::new(),
            next_id: AtomicU64::new(1),
        };
        Bus { shared: Arc::new(shared) }
    }

    fn state(&self) -> MutexGuard<'_, State> {
        // A thread that panicked while holding the lock left the list itself intact.
        self.shared.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Attaches an endpoint; `name` is used in log lines.
    pub fn attach(&self, name: String, sink: Sink) -> EndpointId {
        let id = self.shared.next_id.fetch_add(1, Ordering::Relaxed);
        let endpoint = Endpoint {
            id,
            name,
            sink,
            inbox: VecDeque::new(),
            budget: f64::from(BURST),
            refilled: Instant::now(),
            losses: Losses::default(),
        };
        self.state().endpoints.push(endpoint);
        id
    }

    /// Detaches an endpoint (its waiting frames are dropped); returns what it lost, `None` if
    /// it was not attached.
    pub fn detach(&self, id: EndpointId) -> Option<Losses> {
        let mut state = self.state();
        let position = state.endpoints.iter().position(|e| e.id == id)?;
        Some(state.endpoints.remove(position).losses)
    }

    /// Number of endpoints attached.
    pub fn endpoint_count(&self) -> usize {
        self.state().endpoints.len()
    }

    /// A frame an endpoint puts on the bus: queued until the drive loop takes it (its oldest
    /// waiting frame is dropped if its queue is full). Never blocks beyond the bus's lock.
    pub fn send_from_endpoint(&self, from: EndpointId, frame: &CanFrame) {
        let mut state = self.state();
        let Some(endpoint) = state.endpoints.iter_mut().find(|e| e.id == from) else { return };
        if endpoint.inbox.len() >= INBOX {
            endpoint.inbox.pop_front();
            if endpoint.losses.sent == 0 {
                log!("{} sends faster than the bus carries; dropping its oldest frames", endpoint.name);
            }
            endpoint.losses.sent = endpoint.losses.sent.saturating_add(1);
        }
        endpoint.inbox.push_back(*frame);
        drop(state);
        self.shared.arrived.notify_one();
    }

    /// The next frame for the drive, waiting up to `timeout` for one: the endpoints' frames in
    /// turn, each within its rate. The frame is also delivered to every other endpoint.
    pub fn receive(&self, timeout: Duration) -> Option<CanFrame> {
        let deadline = Instant::now() + timeout;
        let mut state = self.state();
        loop {
            let now = Instant::now();
            if let Some((from, frame)) = take_next(&mut state, now) {
                deliver(&mut state, Some(from), &frame);
                return Some(frame);
            }
            // Nothing may go now: wait for a frame, the next budget, or the deadline.
            let wake = state.endpoints.iter().filter_map(Endpoint::ready_at).fold(deadline, Instant::min);
            if now >= deadline {
                return None;
            }
            let wait = wake.saturating_duration_since(now).max(Duration::from_micros(50));
            state = self.shared.arrived.wait_timeout(state, wait).unwrap_or_else(PoisonError::into_inner).0;
        }
    }

    /// A frame the drive put on the bus: to every endpoint.
    pub fn send_from_drive(&self, frame: &CanFrame) {
        deliver(&mut self.state(), None, frame);
    }
}

/// The next endpoint in turn with a frame it may send, and the frame.
fn take_next(state: &mut State, now: Instant) -> Option<(EndpointId, CanFrame)> {
    let count = state.endpoints.len();
    for step in 0..count {
        let index = (state.turn + step) % count;
        let Some(endpoint) = state.endpoints.get_mut(index) else { continue };
        if endpoint.inbox.is_empty() {
            continue;
        }
        endpoint.refill(now);
        if endpoint.budget < 1.0 {
            continue;
        }
        let Some(frame) = endpoint.inbox.pop_front() else { continue };
        endpoint.budget -= 1.0;
        state.turn = index + 1;
        return Some((endpoint.id, frame));
    }
    None
}

/// Hands `frame` to every endpoint but its sender; detaches those that are gone.
fn deliver(state: &mut State, from: Option<EndpointId>, frame: &CanFrame) {
    state.endpoints.retain_mut(|endpoint| {
        if Some(endpoint.id) == from {
            return true;
        }
        match (endpoint.sink)(frame) {
            Delivery::Queued => true,
            Delivery::Dropped => {
                if endpoint.losses.received == 0 {
                    log!("{} does not keep up; dropping frames for it", endpoint.name);
                }
                endpoint.losses.received = endpoint.losses.received.saturating_add(1);
                true
            }
            Delivery::Gone => false,
        }
    });
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use std::sync::mpsc::{sync_channel, Receiver, TrySendError};

    fn queue_sink(capacity: usize) -> (Sink, Receiver<CanFrame>) {
        let (tx, rx) = sync_channel(capacity);
        let sink: Sink = Box::new(move |frame: &CanFrame| match tx.try_send(*frame) {
            Ok(()) => Delivery::Queued,
            Err(TrySendError::Full(_)) => Delivery::Dropped,
            Err(TrySendError::Disconnected(_)) => Delivery::Gone,
        });
        (sink, rx)
    }

    fn frame(id: u16) -> CanFrame {
        CanFrame::new_standard(id, &[id as u8]).unwrap()
    }

    const NOW: Duration = Duration::ZERO;

    #[test]
    fn frames_reach_everyone_but_their_sender() {
        let bus = Bus::new();
        let (sink_a, rx_a) = queue_sink(8);
        let (sink_b, rx_b) = queue_sink(8);
        let a = bus.attach("a".into(), sink_a);
        let _b = bus.attach("b".into(), sink_b);

        bus.send_from_endpoint(a, &frame(0x101));
        assert_eq!(bus.receive(NOW).unwrap(), frame(0x101));
        assert_eq!(rx_b.try_recv().unwrap(), frame(0x101));
        assert!(rx_a.try_recv().is_err());

        bus.send_from_drive(&frame(0x585));
        assert_eq!(rx_a.try_recv().unwrap(), frame(0x585));
        assert_eq!(rx_b.try_recv().unwrap(), frame(0x585));
        assert!(bus.receive(NOW).is_none());
    }

    #[test]
    fn gone_endpoints_are_detached_and_full_ones_only_lose_frames() {
        let bus = Bus::new();
        let (sink_full, rx_full) = queue_sink(1);
        let (sink_gone, rx_gone) = queue_sink(1);
        let full = bus.attach("full".into(), sink_full);
        bus.attach("gone".into(), sink_gone);
        drop(rx_gone);
        bus.send_from_drive(&frame(1));
        bus.send_from_drive(&frame(2));
        assert_eq!(bus.endpoint_count(), 1);
        assert_eq!(rx_full.try_recv().unwrap(), frame(1));
        assert!(rx_full.try_recv().is_err());
        bus.send_from_drive(&frame(3));
        assert_eq!(rx_full.try_recv().unwrap(), frame(3));
        assert_eq!(bus.detach(full), Some(Losses { sent: 0, received: 1 }));
        assert_eq!(bus.endpoint_count(), 0);
    }

    #[test]
    fn a_flooding_endpoint_loses_its_oldest_frames_and_the_others_keep_their_turn() {
        let bus = Bus::new();
        let (sink_a, _rx_a) = queue_sink(1);
        let (sink_b, _rx_b) = queue_sink(1);
        let a = bus.attach("a".into(), sink_a);
        let b = bus.attach("b".into(), sink_b);
        let extra = 10;
        for i in 0..(INBOX + extra) {
            bus.send_from_endpoint(a, &frame((i % 0x700) as u16));
        }
        bus.send_from_endpoint(b, &frame(0x605));
        // a's oldest frames are gone; b's frame goes within two turns.
        assert_eq!(bus.receive(NOW).unwrap(), frame(extra as u16));
        assert_eq!(bus.receive(NOW).unwrap(), frame(0x605));
        // a is held to its burst, then to its rate (what the rate refills while this loop runs
        // on a loaded machine is allowed for).
        let started = Instant::now();
        let mut taken = 2;
        while bus.receive(NOW).is_some() {
            taken += 1;
        }
        let refilled = (started.elapsed().as_secs_f64() * f64::from(RATE)).ceil() as usize;
        assert!(taken <= BURST as usize + 2 + 5 + refilled, "{taken} frames at once ({refilled} refilled)");
        assert_eq!(bus.detach(a), Some(Losses { sent: extra as u64, received: 0 }));
    }
}
