//! A SocketCAN interface as an endpoint of the [`Bus`].
//!
//! One thread reads frames from the socket onto the bus; one writes the bus's frames (queued,
//! so the drive loop never waits on the socket) to the socket. Error frames are not passed on.

use std::io;
use std::sync::mpsc::{self, TrySendError};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use canopen_drive::CanFrame;
use socketcan::{CanSocket, Socket};

use crate::bus::{Bus, Delivery, EndpointId};

/// Frames queued for the interface before frames are dropped.
const QUEUE: usize = 1024;

/// Attempts to write one frame while the interface's transmit queue is full.
const WRITE_ATTEMPTS: u32 = 100;

/// Opens `iface` and attaches it to `bus`.
pub fn attach(iface: &str, bus: &Bus) -> io::Result<()> {
    let socket = Arc::new(CanSocket::open(iface)?);
    let (tx, rx) = mpsc::sync_channel::<CanFrame>(QUEUE);
    let id = bus.attach(
        format!("SocketCAN {iface}"),
        Box::new(move |frame: &CanFrame| match tx.try_send(*frame) {
            Ok(()) => Delivery::Queued,
            Err(TrySendError::Full(_)) => Delivery::Dropped,
            Err(TrySendError::Disconnected(_)) => Delivery::Gone,
        }),
    );

    spawn_threads(iface, socket, rx, id, bus).inspect_err(|_| {
        bus.detach(id);
    })
}

fn spawn_threads(
    iface: &str,
    socket: Arc<CanSocket>,
    rx: mpsc::Receiver<CanFrame>,
    id: EndpointId,
    bus: &Bus,
) -> io::Result<()> {
    let write_socket = Arc::clone(&socket);
    let write_name = iface.to_string();
    thread::Builder::new().name(format!("socketcan-write {iface}")).spawn(move || {
        while let Ok(frame) = rx.recv() {
            let Some(frame) = frame.to_frame::<socketcan::CanFrame>() else {
                continue;
            };
            if let Err(e) = write_with_retries(&write_socket, &frame) {
                log!("writing to {write_name} failed: {e}");
                break;
            }
        }
    })?;

    let read_bus = bus.clone();
    let read_name = iface.to_string();
    thread::Builder::new().name(format!("socketcan-read {iface}")).spawn(move || {
        loop {
            match socket.read_frame() {
                Ok(socketcan::CanFrame::Error(_)) => {}
                Ok(frame) => read_bus.send_from_endpoint(id, &CanFrame::from_frame(&frame)),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    log!("reading from {read_name} failed: {e}");
                    break;
                }
            }
        }
        read_bus.detach(id);
    })?;
    Ok(())
}

/// Writes a frame; while the kernel's transmit queue is full (ENOBUFS: nobody acknowledges on
/// the bus), waits and retries for up to ~0.1 s, then drops the frame. Other errors end the port.
fn write_with_retries(socket: &CanSocket, frame: &socketcan::CanFrame) -> io::Result<()> {
    for _ in 0..WRITE_ATTEMPTS {
        match socket.write_frame(frame) {
            Ok(()) => return Ok(()),
            Err(e) if is_transient(&e) => thread::sleep(Duration::from_millis(1)),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

fn is_transient(e: &io::Error) -> bool {
    e.raw_os_error() == Some(libc::ENOBUFS)
        || matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted)
}
