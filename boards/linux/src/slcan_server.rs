//! SLCAN over TCP: every connected client is one endpoint of the [`Bus`].
//!
//! A client talks to the server as to a Lawicel USB-CAN adapter (see [`crate::slcan`]); python-can
//! does so with `can.Bus(interface="slcan", channel="socket://HOST:PORT")`. Several clients may
//! be connected at once and share the one bus: a frame a client sends reaches the drive and every
//! other client; a frame the drive sends reaches all clients.
//!
//! Threads: one accepting connections, and per client a reader (parses lines, answers, puts
//! frames on the bus) and a writer (drains the client's queue onto the socket, joining queued
//! lines into one write). Neither the drive loop nor another client ever waits on a client's
//! socket: a client that stops reading loses frames once its queue of [`CLIENT_QUEUE`] lines is
//! full; a client that disconnects or sends garbage (answered with BEL) affects no one else.
//!
//! Open state: frames are forwarded to a client whether or not it has sent `O` yet, and a
//! client's frames are accepted before `O` too. `O`, `L`, `C` and `Sn` are acknowledged and
//! otherwise ignored: the bus is virtual, it has no bit rate and is always on. python-can
//! ignores input that arrives before its open sequence is through, so tracking the state would
//! add code and no behaviour a client can rely on.
//!
//! Sockets use `TCP_NODELAY`: an SDO round trip is two small writes, and Nagle's algorithm
//! would hold each back for tens of milliseconds.

use std::io::{self, ErrorKind, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::thread;
use std::time::Duration;

use canopen_drive::CanFrame;

use crate::bus::{Bus, Delivery, EndpointId};
use crate::slcan::{self, Command, LineDecoder, BEL};

/// Lines queued for one client before frames for it are dropped.
pub const CLIENT_QUEUE: usize = 4096;
/// Bytes joined into one socket write at most.
const WRITE_BATCH: usize = 16 * 1024;

/// A line for a client.
#[derive(Clone, Copy, Debug)]
enum Outgoing {
    /// A frame from the bus.
    Frame(CanFrame),
    /// The answer to one of the client's own lines.
    Reply(&'static [u8]),
}

impl Outgoing {
    fn encode(&self, out: &mut Vec<u8>) {
        match self {
            Outgoing::Frame(frame) => slcan::encode_frame(frame, out),
            Outgoing::Reply(bytes) => out.extend_from_slice(bytes),
        }
    }
}

/// A listening SLCAN server.
#[derive(Debug)]
pub struct SlcanServer {
    local_addr: SocketAddr,
}

impl SlcanServer {
    /// Binds `addr` and accepts clients onto `bus` from a background thread.
    pub fn start(addr: impl ToSocketAddrs, bus: Bus) -> io::Result<SlcanServer> {
        let listener = TcpListener::bind(addr)?;
        let local_addr = listener.local_addr()?;
        thread::Builder::new().name("slcan-accept".into()).spawn(move || accept_loop(&listener, &bus))?;
        Ok(SlcanServer { local_addr })
    }

    /// The address the server listens on (with the port chosen when 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }
}

fn accept_loop(listener: &TcpListener, bus: &Bus) {
    for stream in listener.incoming() {
        match stream {
            Ok(stream) => {
                if let Err(e) = serve_client(stream, bus) {
                    log!("cannot serve an SLCAN client: {e}");
                }
            }
            Err(e) => {
                // E.g. out of file descriptors: wait instead of spinning.
                log!("accept failed: {e}");
                thread::sleep(Duration::from_millis(50));
            }
        }
    }
}

fn serve_client(stream: TcpStream, bus: &Bus) -> io::Result<()> {
    stream.set_nodelay(true)?;
    let peer = stream.peer_addr().map_or_else(|_| "?".to_string(), |a| a.to_string());
    let writer_stream = stream.try_clone()?;
    let (tx, rx) = mpsc::sync_channel::<Outgoing>(CLIENT_QUEUE);
    let sink_tx = tx.clone();
    let id = bus.attach(
        format!("SLCAN client {peer}"),
        Box::new(move |frame: &CanFrame| match sink_tx.try_send(Outgoing::Frame(*frame)) {
            Ok(()) => Delivery::Queued,
            Err(TrySendError::Full(_)) => Delivery::Dropped,
            Err(TrySendError::Disconnected(_)) => Delivery::Gone,
        }),
    );
    let spawned = thread::Builder::new()
        .name(format!("slcan-write {peer}"))
        .spawn(move || write_loop(writer_stream, &rx))
        .and_then(|_| {
            let reader_bus = bus.clone();
            let reader_peer = peer.clone();
            thread::Builder::new()
                .name(format!("slcan-read {peer}"))
                .spawn(move || read_loop(id, &reader_peer, stream, &tx, &reader_bus))
        });
    match spawned {
        Ok(_) => {
            log!("SLCAN client {peer} connected ({} on the bus)", bus.endpoint_count());
            Ok(())
        }
        Err(e) => {
            bus.detach(id);
            Err(e)
        }
    }
}

fn write_loop(mut stream: TcpStream, rx: &Receiver<Outgoing>) {
    let mut buf = Vec::with_capacity(WRITE_BATCH);
    while let Ok(first) = rx.recv() {
        buf.clear();
        first.encode(&mut buf);
        while buf.len() < WRITE_BATCH {
            match rx.try_recv() {
                Ok(next) => next.encode(&mut buf),
                Err(_) => break,
            }
        }
        if stream.write_all(&buf).is_err() {
            break;
        }
    }
    // Wake the reader if the write side failed first.
    let _ = stream.shutdown(Shutdown::Both);
}

fn read_loop(id: EndpointId, peer: &str, mut stream: TcpStream, tx: &SyncSender<Outgoing>, bus: &Bus) {
    let mut decoder = LineDecoder::new();
    let mut chunk = [0u8; 1024];
    'connection: loop {
        let n = match stream.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(_) => break,
        };
        for &byte in chunk.get(..n).unwrap_or(&[]) {
            let Some(line) = decoder.push(byte) else {
                continue;
            };
            let reply = match line {
                Ok(command) => command.reply(),
                Err(_) => &[BEL],
            };
            // The answer goes before any frame the line causes; a client that does not read
            // its answers only loses them.
            if let Err(TrySendError::Disconnected(_)) = tx.try_send(Outgoing::Reply(reply)) {
                break 'connection;
            }
            if let Ok(Command::Frame(frame)) = line {
                bus.send_from_endpoint(id, &frame);
            }
        }
    }
    bus.detach(id);
    let _ = stream.shutdown(Shutdown::Both);
    log!("SLCAN client {peer} left ({} on the bus)", bus.endpoint_count());
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use embedded_can::Frame;
    use std::io::{BufRead, BufReader};
    use std::time::Instant;

    const TIMEOUT: Duration = Duration::from_secs(5);

    struct Client {
        writer: TcpStream,
        reader: BufReader<TcpStream>,
    }

    impl Client {
        /// Connects and waits until the server serves the connection (its `V` is answered).
        fn connect(addr: SocketAddr) -> Client {
            let stream = TcpStream::connect(addr).unwrap();
            stream.set_read_timeout(Some(TIMEOUT)).unwrap();
            let mut client = Client { writer: stream.try_clone().unwrap(), reader: BufReader::new(stream) };
            client.send("V\r");
            assert_eq!(client.line(), "V1013\r");
            client
        }

        fn send(&mut self, text: &str) {
            self.writer.write_all(text.as_bytes()).unwrap();
        }

        /// The next `\r`-terminated line (BEL counts as a line of its own).
        fn line(&mut self) -> String {
            let mut out = Vec::new();
            loop {
                let buf = self.reader.fill_buf().unwrap();
                assert!(!buf.is_empty(), "connection closed");
                let byte = buf[0];
                self.reader.consume(1);
                out.push(byte);
                if byte == b'\r' || byte == BEL {
                    return String::from_utf8(out).unwrap();
                }
            }
        }
    }

    fn start() -> (SlcanServer, Bus, mpsc::Receiver<CanFrame>) {
        let (bus, drive) = Bus::new();
        let server = SlcanServer::start("127.0.0.1:0", bus.clone()).unwrap();
        (server, bus, drive)
    }

    fn wait_for_endpoints(bus: &Bus, n: usize) {
        let start = Instant::now();
        while bus.endpoint_count() != n {
            assert!(start.elapsed() < TIMEOUT, "{} endpoints, want {n}", bus.endpoint_count());
            thread::sleep(Duration::from_millis(2));
        }
    }

    #[test]
    fn two_clients_form_one_bus_with_the_drive() {
        let (server, bus, drive) = start();
        let mut a = Client::connect(server.local_addr());
        let mut b = Client::connect(server.local_addr());

        // python-can's open sequence.
        a.send("C\rS6\r\rO\r");
        for _ in 0..4 {
            assert_eq!(a.line(), "\r");
        }

        a.send("t60584000100000000000\r");
        assert_eq!(a.line(), "z\r");
        assert_eq!(b.line(), "t60584000100000000000\r");
        let frame = drive.recv_timeout(TIMEOUT).unwrap();
        assert_eq!(frame, CanFrame::new_standard(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap());

        b.send("T1234567821122\r");
        assert_eq!(b.line(), "Z\r");
        assert_eq!(a.line(), "T1234567821122\r");
        assert!(drive.recv_timeout(TIMEOUT).unwrap().is_extended());

        bus.send_from_drive(&CanFrame::new_standard(0x585, &[0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]).unwrap());
        assert_eq!(a.line(), "t58586017100000000000\r");
        assert_eq!(b.line(), "t58586017100000000000\r");
    }

    #[test]
    fn garbage_gets_bel_and_the_connection_goes_on() {
        let (server, _bus, drive) = start();
        let mut a = Client::connect(server.local_addr());
        a.send("hello\rt12\rt1232AABB\r");
        assert_eq!(a.line(), "\x07");
        assert_eq!(a.line(), "\x07");
        assert_eq!(a.line(), "z\r");
        assert_eq!(
            drive.recv_timeout(TIMEOUT).unwrap(),
            CanFrame::new_standard(0x123, &[0xAA, 0xBB]).unwrap()
        );
        let long = "x".repeat(10_000);
        a.send(&long);
        a.send("\rN\r");
        assert_eq!(a.line(), "\x07");
        assert_eq!(a.line(), "N0001\r");
    }

    #[test]
    fn a_client_that_leaves_does_not_disturb_the_others() {
        let (server, bus, drive) = start();
        let mut a = Client::connect(server.local_addr());
        let b = Client::connect(server.local_addr());
        wait_for_endpoints(&bus, 2);
        // b leaves in the middle of a line.
        let mut b_writer = b.writer;
        b_writer.write_all(b"t12").unwrap();
        b_writer.shutdown(Shutdown::Both).unwrap();
        drop(b.reader);
        drop(b_writer);
        wait_for_endpoints(&bus, 1);
        bus.send_from_drive(&CanFrame::new_standard(0x705, &[0x7F]).unwrap());
        assert_eq!(a.line(), "t70517F\r");
        a.send("t0000\r");
        assert_eq!(a.line(), "z\r");
        assert_eq!(drive.recv_timeout(TIMEOUT).unwrap(), CanFrame::new_standard(0, &[]).unwrap());
    }
}
