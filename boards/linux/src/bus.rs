//! The host-side CAN bus: one broadcast medium joining the drive and any number of endpoints
//! (SLCAN clients, a SocketCAN interface).
//!
//! Like a real CAN bus, every frame reaches every participant except its sender: a frame from
//! an endpoint goes to the drive and to every other endpoint; a frame from the drive goes to
//! every endpoint. Endpoints receive frames through a non-blocking [`Sink`], so a slow or stuck
//! endpoint can never hold up the drive or the others: when its queue is full the frame is
//! dropped for that endpoint alone (as a CAN controller drops frames on receive overrun).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use canopen_drive::CanFrame;

/// Identifies an endpoint attached to the bus.
pub type EndpointId = u64;

/// What became of a frame handed to an endpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delivery {
    /// Queued for the endpoint.
    Queued,
    /// The endpoint's queue is full; the frame is lost for this endpoint.
    Dropped,
    /// The endpoint is gone; the bus detaches it.
    Gone,
}

/// How the bus hands a frame to an endpoint. Must not block.
pub type Sink = Box<dyn Fn(&CanFrame) -> Delivery + Send>;

struct Endpoint {
    id: EndpointId,
    name: String,
    sink: Sink,
    dropped: u64,
}

struct Shared {
    endpoints: Mutex<Vec<Endpoint>>,
    next_id: AtomicU64,
    to_drive: Sender<CanFrame>,
}

/// A handle on the bus; clones share it.
#[derive(Clone)]
pub struct Bus {
    shared: Arc<Shared>,
}

impl Bus {
    /// A bus with no endpoints, and the receiver of the frames addressed to the drive.
    pub fn new() -> (Bus, Receiver<CanFrame>) {
        let (to_drive, frames) = mpsc::channel();
        let shared = Shared { endpoints: Mutex::new(Vec::new()), next_id: AtomicU64::new(1), to_drive };
        (Bus { shared: Arc::new(shared) }, frames)
    }

    fn endpoints(&self) -> MutexGuard<'_, Vec<Endpoint>> {
        // A thread that panicked while holding the lock left the list itself intact.
        self.shared.endpoints.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Attaches an endpoint; `name` is used in log lines.
    pub fn attach(&self, name: String, sink: Sink) -> EndpointId {
        let id = self.shared.next_id.fetch_add(1, Ordering::Relaxed);
        self.endpoints().push(Endpoint { id, name, sink, dropped: 0 });
        id
    }

    /// Detaches an endpoint (no-op if it is not attached).
    pub fn detach(&self, id: EndpointId) {
        self.endpoints().retain(|e| e.id != id);
    }

    /// Number of endpoints attached.
    pub fn endpoint_count(&self) -> usize {
        self.endpoints().len()
    }

    /// A frame an endpoint put on the bus: to the drive and every other endpoint.
    pub fn send_from_endpoint(&self, from: EndpointId, frame: &CanFrame) {
        // The receiver lives as long as the drive loop; after it has ended nobody listens.
        let _ = self.shared.to_drive.send(*frame);
        self.deliver(Some(from), frame);
    }

    /// A frame the drive put on the bus: to every endpoint.
    pub fn send_from_drive(&self, frame: &CanFrame) {
        self.deliver(None, frame);
    }

    fn deliver(&self, from: Option<EndpointId>, frame: &CanFrame) {
        let mut endpoints = self.endpoints();
        endpoints.retain_mut(|endpoint| {
            if Some(endpoint.id) == from {
                return true;
            }
            match (endpoint.sink)(frame) {
                Delivery::Queued => true,
                Delivery::Dropped => {
                    if endpoint.dropped == 0 {
                        log!("{} does not keep up; dropping frames for it", endpoint.name);
                    }
                    endpoint.dropped = endpoint.dropped.saturating_add(1);
                    true
                }
                Delivery::Gone => false,
            }
        });
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use std::sync::mpsc::{sync_channel, TrySendError};

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

    #[test]
    fn frames_reach_everyone_but_their_sender() {
        let (bus, drive) = Bus::new();
        let (sink_a, rx_a) = queue_sink(8);
        let (sink_b, rx_b) = queue_sink(8);
        let a = bus.attach("a".into(), sink_a);
        let _b = bus.attach("b".into(), sink_b);

        bus.send_from_endpoint(a, &frame(0x101));
        assert_eq!(drive.try_recv().unwrap(), frame(0x101));
        assert_eq!(rx_b.try_recv().unwrap(), frame(0x101));
        assert!(rx_a.try_recv().is_err());

        bus.send_from_drive(&frame(0x585));
        assert_eq!(rx_a.try_recv().unwrap(), frame(0x585));
        assert_eq!(rx_b.try_recv().unwrap(), frame(0x585));
        assert!(drive.try_recv().is_err());
    }

    #[test]
    fn gone_endpoints_are_detached_and_full_ones_only_lose_frames() {
        let (bus, _drive) = Bus::new();
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
        bus.detach(full);
        assert_eq!(bus.endpoint_count(), 0);
    }
}
