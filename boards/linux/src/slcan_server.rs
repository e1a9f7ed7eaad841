//! SLCAN over TCP: every connected client is one endpoint of the [`Bus`].
//!
//! A client talks to the server as to a Lawicel USB-CAN adapter (see [`canopen_drive_slcan`]);
//! python-can does so with `can.Bus(interface="slcan", channel="socket://HOST:PORT")`. Several clients may
//! be connected at once and share the one bus: a frame a client sends reaches the drive and every
//! other client; a frame the drive sends reaches all clients.
//!
//! ## One thread for all clients
//!
//! One thread serves the listening socket and every client with non-blocking sockets (`mio`):
//! it reads what a client sends (at most [`READ_BUDGET`] bytes per client per turn, so a client
//! sending as fast as TCP allows cannot starve the others), answers each line, puts frames on
//! the bus, and writes each client's queue of lines out as its socket takes them. Neither the
//! drive loop nor another client ever waits on a client's socket: the queue of a client that
//! stops reading holds its newest [`CLIENT_QUEUE`] lines and loses the oldest; a client that
//! disconnects or sends garbage (answered with BEL) affects no one else. What a client sends
//! faster than the bus carries waits in its own queue on the bus ([`crate::bus`]).
//!
//! ## Limits
//!
//! - At most [`Limits::max_clients`] clients (`--max-clients`, default 32): one more is sent a
//!   line saying so and disconnected.
//! - TCP keepalive on every connection ([`KEEPALIVE_IDLE`], then [`KEEPALIVE_PROBES`] probes
//!   [`KEEPALIVE_INTERVAL`] apart) and a user timeout for unacknowledged data
//!   ([`USER_TIMEOUT`]): a peer that vanished without closing (power loss, cable pulled) is
//!   noticed and disconnected.
//! - `--idle-timeout SECONDS` disconnects a client that has sent nothing for that long (off by
//!   default: a listening-only client is a normal CANopen participant).
//! - Out of file descriptors, a waiting connection is taken with a spare descriptor kept for
//!   this, told so and closed, and the condition is logged once per [`LOG_INTERVAL`].
//!
//! Open state: frames are forwarded to a client whether or not it has sent `O` yet, and a
//! client's frames are accepted before `O` too. `O`, `L`, `C` and `Sn` are acknowledged and
//! otherwise ignored: the bus is virtual, it has no bit rate and is always on. python-can
//! ignores input that arrives before its open sequence is through, so tracking the state would
//! add code and no behaviour a client can rely on.
//!
//! Sockets use `TCP_NODELAY`: an SDO round trip is two small writes, and Nagle's algorithm
//! would hold each back for tens of milliseconds.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, ErrorKind, Read, Write};
use std::net::{Shutdown, SocketAddr, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread;
use std::time::{Duration, Instant};

use canopen_drive::CanFrame;
use canopen_drive_slcan::{Command, LineDecoder, BEL};
use mio::net::{TcpListener, TcpStream};
use mio::{Events, Interest, Poll, Token, Waker};
use socket2::{SockRef, TcpKeepalive};

use crate::bus::{Bus, Delivery, EndpointId};

/// Lines queued for one client before its oldest are dropped.
pub const CLIENT_QUEUE: usize = 4096;
/// Bytes joined into one socket write at most.
const WRITE_BATCH: usize = 16 * 1024;
/// Bytes read from one client before the others get their turn.
pub const READ_BUDGET: usize = 16 * 1024;
/// Idle time of a connection before the first keepalive probe.
pub const KEEPALIVE_IDLE: Duration = Duration::from_secs(10);
/// Time between keepalive probes.
pub const KEEPALIVE_INTERVAL: Duration = Duration::from_secs(5);
/// Unanswered keepalive probes before the connection is dropped.
pub const KEEPALIVE_PROBES: u32 = 3;
/// Time sent data may stay unacknowledged before the connection is dropped.
pub const USER_TIMEOUT: Duration = Duration::from_secs(30);
/// A condition that repeats (refused clients, no file descriptors) is logged once per this.
pub const LOG_INTERVAL: Duration = Duration::from_secs(10);
/// Retry of `accept` after a failure other than a missing descriptor.
const ACCEPT_RETRY: Duration = Duration::from_millis(100);

const LISTENER: Token = Token(0);
const WAKER: Token = Token(1);
/// Tokens of clients start here.
const FIRST_CLIENT: usize = 2;

/// The server's limits (`--max-clients`, `--idle-timeout`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Clients served at once.
    pub max_clients: usize,
    /// A client that sends nothing for this long is disconnected.
    pub idle_timeout: Option<Duration>,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { max_clients: 32, idle_timeout: None }
    }
}

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
            Outgoing::Frame(frame) => out.extend_from_slice(canopen_drive_slcan::encode(frame).as_bytes()),
            Outgoing::Reply(bytes) => out.extend_from_slice(bytes),
        }
    }
}

/// The lines waiting for one client, filled by the bus (the drive loop's thread) and by the
/// server thread, emptied by the server thread.
struct Outbox {
    lines: Mutex<VecDeque<Outgoing>>,
    /// The client is gone: the bus detaches it.
    closed: AtomicBool,
    waker: Arc<Waker>,
}

impl Outbox {
    fn lines(&self) -> MutexGuard<'_, VecDeque<Outgoing>> {
        self.lines.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Queues a line, dropping the oldest if the queue is full; wakes the server thread when
    /// the queue was empty (it has nothing to write for this client until then).
    fn push(&self, line: Outgoing) -> Delivery {
        if self.closed.load(Ordering::Relaxed) {
            return Delivery::Gone;
        }
        let mut lines = self.lines();
        let full = lines.len() >= CLIENT_QUEUE;
        if full {
            lines.pop_front();
        }
        lines.push_back(line);
        let was_empty = lines.len() == 1;
        drop(lines);
        if was_empty {
            // A failed wake leaves the line for the next turn of the server thread.
            let _ = self.waker.wake();
        }
        if full {
            Delivery::Dropped
        } else {
            Delivery::Queued
        }
    }
}

/// A listening SLCAN server.
#[derive(Debug)]
pub struct SlcanServer {
    local_addr: SocketAddr,
}

impl SlcanServer {
    /// Binds `addr` and serves clients on `bus` from a background thread.
    pub fn start(addr: impl ToSocketAddrs, bus: Bus, limits: Limits) -> io::Result<SlcanServer> {
        let std_listener = std::net::TcpListener::bind(addr)?;
        std_listener.set_nonblocking(true)?;
        let local_addr = std_listener.local_addr()?;
        let mut listener = TcpListener::from_std(std_listener);
        let poll = Poll::new()?;
        poll.registry().register(&mut listener, LISTENER, Interest::READABLE)?;
        let waker = Arc::new(Waker::new(poll.registry(), WAKER)?);
        let server = Server {
            poll,
            listener,
            waker,
            bus,
            limits,
            clients: Vec::new(),
            spare: File::open("/dev/null").ok(),
            accept_retry: None,
            refused: Reported::default(),
            no_descriptors: Reported::default(),
        };
        thread::Builder::new().name("slcan".into()).spawn(move || server.run())?;
        Ok(SlcanServer { local_addr })
    }

    /// The address the server listens on (with the port chosen when 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }
}

/// A condition logged at most once per [`LOG_INTERVAL`], with the count since.
#[derive(Default)]
struct Reported {
    logged: Option<Instant>,
    count: u64,
}

impl Reported {
    /// Counts one occurrence; the count to log, when it is time to.
    fn occur(&mut self, now: Instant) -> Option<u64> {
        self.count += 1;
        if self.logged.is_some_and(|t| now.duration_since(t) < LOG_INTERVAL) {
            return None;
        }
        self.logged = Some(now);
        Some(std::mem::take(&mut self.count))
    }
}

struct Client {
    stream: TcpStream,
    peer: String,
    id: EndpointId,
    decoder: LineDecoder<CanFrame>,
    outbox: Arc<Outbox>,
    /// Encoded bytes the socket has not taken yet.
    pending: Vec<u8>,
    last_heard: Instant,
    /// The read budget ran out with data left: read again without waiting for the socket.
    unread: bool,
}

struct Server {
    poll: Poll,
    listener: TcpListener,
    waker: Arc<Waker>,
    bus: Bus,
    limits: Limits,
    /// Indexed by token − [`FIRST_CLIENT`].
    clients: Vec<Option<Client>>,
    /// A descriptor given up to take (and refuse) a connection when there is none left.
    spare: Option<File>,
    accept_retry: Option<Instant>,
    refused: Reported,
    no_descriptors: Reported,
}

/// Why a client's connection ends.
enum End {
    Closed,
    Failed(io::Error),
    Idle(Duration),
}

impl Server {
    fn run(mut self) {
        let mut events = Events::with_capacity(256);
        loop {
            let timeout = self.timeout(Instant::now());
            if let Err(e) = self.poll.poll(&mut events, timeout) {
                if e.kind() == ErrorKind::Interrupted {
                    continue;
                }
                log!("the SLCAN server stops: {e}");
                return;
            }
            for event in events.iter() {
                match event.token() {
                    LISTENER => self.accept(),
                    WAKER => {}
                    Token(n) => {
                        if let Some(Some(client)) = self.clients.get_mut(n - FIRST_CLIENT) {
                            client.unread |=
                                event.is_readable() || event.is_read_closed() || event.is_error();
                        }
                    }
                }
            }
            let now = Instant::now();
            if self.accept_retry.is_some_and(|t| now >= t) {
                self.accept_retry = None;
                self.accept();
            }
            self.serve_all(now);
        }
    }

    /// One turn of every client; closes those whose connection ended.
    fn serve_all(&mut self, now: Instant) {
        for slot in 0..self.clients.len() {
            let end = match self.clients.get_mut(slot) {
                Some(Some(client)) => serve(client, &self.bus, self.limits.idle_timeout, now),
                _ => None,
            };
            if let Some(end) = end {
                self.close(slot, &end);
            }
        }
    }

    /// How long to wait for events: not at all while a client has unread data, until the next
    /// accept retry or idle deadline otherwise.
    fn timeout(&self, now: Instant) -> Option<Duration> {
        let clients = self.clients.iter().flatten();
        if clients.clone().any(|c| c.unread) {
            return Some(Duration::ZERO);
        }
        let idle = self.limits.idle_timeout.and_then(|t| clients.map(|c| c.last_heard + t).min());
        [idle, self.accept_retry].into_iter().flatten().min().map(|at| at.saturating_duration_since(now))
    }

    /// Accepts every waiting connection.
    fn accept(&mut self) {
        loop {
            match self.listener.accept() {
                Ok((stream, peer)) => self.admit(stream, peer),
                Err(e) if e.kind() == ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) if matches!(e.raw_os_error(), Some(libc::EMFILE | libc::ENFILE)) => {
                    // Give up the spare descriptor to take the connection and refuse it (its
                    // descriptor is free again before the spare is taken back).
                    self.spare = None;
                    let refused = self.listener.accept();
                    if let Some(count) = self.no_descriptors.occur(Instant::now()) {
                        log!("out of file descriptors ({e}): refusing new clients ({count} since the last report)");
                    }
                    let taken = refused.is_ok();
                    if let Ok((stream, _)) = refused {
                        refuse(stream, "out of file descriptors");
                    }
                    self.spare = File::open("/dev/null").ok();
                    if !taken || self.spare.is_none() {
                        self.accept_retry = Some(Instant::now() + ACCEPT_RETRY);
                        return;
                    }
                }
                Err(e) => {
                    log!("accept failed: {e}");
                    self.accept_retry = Some(Instant::now() + ACCEPT_RETRY);
                    return;
                }
            }
        }
    }

    /// Serves a new connection, or refuses it beyond the limit.
    fn admit(&mut self, mut stream: TcpStream, peer: SocketAddr) {
        let mut served = self.clients.iter().flatten().count();
        if served >= self.limits.max_clients {
            // Clients that left and are not noticed yet do not count.
            for client in self.clients.iter_mut().flatten() {
                client.unread = true;
            }
            self.serve_all(Instant::now());
            served = self.clients.iter().flatten().count();
        }
        if served >= self.limits.max_clients {
            if let Some(count) = self.refused.occur(Instant::now()) {
                log!(
                    "{served} SLCAN clients connected, the limit (--max-clients): refusing {peer} \
                     ({count} refused since the last report)"
                );
            }
            let limit = self.limits.max_clients;
            refuse(stream, &format!("{limit} clients connected, the limit of this server (--max-clients)"));
            return;
        }
        let slot = self.clients.iter().position(Option::is_none).unwrap_or(self.clients.len());
        if let Err(e) = configure(&stream).and_then(|()| {
            self.poll.registry().register(
                &mut stream,
                Token(slot + FIRST_CLIENT),
                Interest::READABLE | Interest::WRITABLE,
            )
        }) {
            log!("cannot serve the SLCAN client {peer}: {e}");
            return;
        }
        let outbox = Arc::new(Outbox {
            lines: Mutex::new(VecDeque::new()),
            closed: AtomicBool::new(false),
            waker: Arc::clone(&self.waker),
        });
        let sink_outbox = Arc::clone(&outbox);
        let id = self.bus.attach(
            format!("SLCAN client {peer}"),
            Box::new(move |frame: &CanFrame| sink_outbox.push(Outgoing::Frame(*frame))),
        );
        let client = Client {
            stream,
            peer: peer.to_string(),
            id,
            decoder: LineDecoder::new(),
            outbox,
            pending: Vec::new(),
            last_heard: Instant::now(),
            unread: true,
        };
        if slot == self.clients.len() {
            self.clients.push(Some(client));
        } else if let Some(free) = self.clients.get_mut(slot) {
            *free = Some(client);
        }
        log!("SLCAN client {peer} connected ({} on the bus)", self.bus.endpoint_count());
    }

    fn close(&mut self, slot: usize, end: &End) {
        let Some(mut client) = self.clients.get_mut(slot).and_then(Option::take) else { return };
        client.outbox.closed.store(true, Ordering::Relaxed);
        let losses = self.bus.detach(client.id).unwrap_or_default();
        let _ = self.poll.registry().deregister(&mut client.stream);
        let _ = client.stream.shutdown(Shutdown::Both);
        let why = match end {
            End::Closed => String::new(),
            End::Failed(e) => format!(": {e}"),
            End::Idle(t) => format!(": nothing received for {} s (--idle-timeout)", t.as_secs()),
        };
        let lost = if losses.sent > 0 || losses.received > 0 {
            format!("; {} of its frames and {} frames for it dropped", losses.sent, losses.received)
        } else {
            String::new()
        };
        log!("SLCAN client {} left{why} ({} on the bus{lost})", client.peer, self.bus.endpoint_count());
        // Trim the table so that it does not keep the largest number of clients ever seen.
        while self.clients.last().is_some_and(Option::is_none) {
            self.clients.pop();
        }
        self.clients.shrink_to(self.clients.len().max(self.limits.max_clients.min(64)));
    }
}

/// Socket options of a client connection: no Nagle, keepalive, user timeout.
fn configure(stream: &TcpStream) -> io::Result<()> {
    stream.set_nodelay(true)?;
    let socket = SockRef::from(stream);
    let keepalive = TcpKeepalive::new()
        .with_time(KEEPALIVE_IDLE)
        .with_interval(KEEPALIVE_INTERVAL)
        .with_retries(KEEPALIVE_PROBES);
    socket.set_tcp_keepalive(&keepalive)?;
    socket.set_tcp_user_timeout(Some(USER_TIMEOUT))
}

/// Tells a connection why it is not served and closes it.
fn refuse(mut stream: TcpStream, why: &str) {
    // BEL first: what an SLCAN client takes for an error; the text is for a human.
    let _ = stream.write_all(format!("\x07{}: refused: {why}\r\n", crate::NAME).as_bytes());
    let _ = stream.shutdown(Shutdown::Both);
}

/// One turn of a client: reads (up to the budget), writes what waits, checks the idle timeout.
fn serve(client: &mut Client, bus: &Bus, idle_timeout: Option<Duration>, now: Instant) -> Option<End> {
    if client.unread {
        if let Err(end) = read(client, bus, now) {
            return Some(end);
        }
    }
    if let Err(e) = write(client) {
        return Some(End::Failed(e));
    }
    match idle_timeout {
        Some(t) if now.saturating_duration_since(client.last_heard) >= t => Some(End::Idle(t)),
        _ => None,
    }
}

/// Reads up to [`READ_BUDGET`] bytes: answers each line, puts frames on the bus.
fn read(client: &mut Client, bus: &Bus, now: Instant) -> Result<(), End> {
    let mut chunk = [0u8; 4096];
    let mut total = 0;
    while total < READ_BUDGET {
        let n = match client.stream.read(&mut chunk) {
            Ok(0) => return Err(End::Closed),
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                client.unread = false;
                return Ok(());
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(End::Failed(e)),
        };
        total += n;
        client.last_heard = now;
        for &byte in chunk.get(..n).unwrap_or(&[]) {
            let Some(line) = client.decoder.push(byte) else { continue };
            let reply = match line {
                Ok(command) => command.reply(),
                Err(_) => &[BEL],
            };
            // The answer goes before any frame the line causes.
            client.outbox.push(Outgoing::Reply(reply));
            if let Ok(Command::Frame(frame)) = line {
                bus.send_from_endpoint(client.id, &frame);
            }
        }
    }
    client.unread = true;
    Ok(())
}

/// Writes waiting lines until the socket takes no more.
fn write(client: &mut Client) -> io::Result<()> {
    loop {
        if client.pending.is_empty() {
            let mut lines = client.outbox.lines();
            while client.pending.len() < WRITE_BATCH {
                let Some(line) = lines.pop_front() else { break };
                line.encode(&mut client.pending);
            }
            drop(lines);
            if client.pending.is_empty() {
                // Give back the memory of a burst.
                client.pending.shrink_to(WRITE_BATCH);
                return Ok(());
            }
        }
        match client.stream.write(&client.pending) {
            Ok(0) => return Err(ErrorKind::WriteZero.into()),
            Ok(n) => {
                client.pending.drain(..n);
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(()),
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use embedded_can::Frame;
    use std::io::{BufRead, BufReader};
    use std::net::TcpStream;

    const TIMEOUT: Duration = Duration::from_secs(5);

    struct Client {
        writer: TcpStream,
        reader: BufReader<TcpStream>,
    }

    impl Client {
        /// Connects and waits until the server serves the connection (its `V` is answered).
        fn connect(addr: SocketAddr) -> Client {
            let mut client = Client::connect_raw(addr);
            client.send("V\r");
            assert_eq!(client.line(), "V1013\r");
            client
        }

        fn connect_raw(addr: SocketAddr) -> Client {
            let stream = TcpStream::connect(addr).unwrap();
            stream.set_read_timeout(Some(TIMEOUT)).unwrap();
            Client { writer: stream.try_clone().unwrap(), reader: BufReader::new(stream) }
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

    /// A server; frames for the drive are taken from the bus (`bus.receive`, as the drive loop
    /// does, which also hands them to the other clients).
    fn start() -> (SlcanServer, Bus) {
        start_with(Limits::default())
    }

    fn start_with(limits: Limits) -> (SlcanServer, Bus) {
        let bus = Bus::new();
        let server = SlcanServer::start("127.0.0.1:0", bus.clone(), limits).unwrap();
        (server, bus)
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
        let (server, bus) = start();
        let mut a = Client::connect(server.local_addr());
        let mut b = Client::connect(server.local_addr());

        // python-can's open sequence.
        a.send("C\rS6\r\rO\r");
        for _ in 0..4 {
            assert_eq!(a.line(), "\r");
        }

        a.send("t60584000100000000000\r");
        assert_eq!(a.line(), "z\r");
        let frame = bus.receive(TIMEOUT).unwrap();
        assert_eq!(b.line(), "t60584000100000000000\r");
        assert_eq!(frame, CanFrame::new_standard(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap());

        b.send("T1234567821122\r");
        assert_eq!(b.line(), "Z\r");
        let frame = bus.receive(TIMEOUT).unwrap();
        assert_eq!(a.line(), "T1234567821122\r");
        assert!(frame.is_extended());

        bus.send_from_drive(&CanFrame::new_standard(0x585, &[0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]).unwrap());
        assert_eq!(a.line(), "t58586017100000000000\r");
        assert_eq!(b.line(), "t58586017100000000000\r");
    }

    #[test]
    fn garbage_gets_bel_and_the_connection_goes_on() {
        let (server, bus) = start();
        let mut a = Client::connect(server.local_addr());
        a.send("hello\rt12\rt1232AABB\r");
        assert_eq!(a.line(), "\x07");
        assert_eq!(a.line(), "\x07");
        assert_eq!(a.line(), "z\r");
        assert_eq!(bus.receive(TIMEOUT).unwrap(), CanFrame::new_standard(0x123, &[0xAA, 0xBB]).unwrap());
        let long = "x".repeat(10_000);
        a.send(&long);
        a.send("\rN\r");
        assert_eq!(a.line(), "\x07");
        assert_eq!(a.line(), "N0001\r");
    }

    #[test]
    fn a_client_that_leaves_does_not_disturb_the_others() {
        let (server, bus) = start();
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
        assert_eq!(bus.receive(TIMEOUT).unwrap(), CanFrame::new_standard(0, &[]).unwrap());
    }

    #[test]
    fn clients_beyond_the_limit_are_told_and_disconnected() {
        let (server, bus) = start_with(Limits { max_clients: 2, idle_timeout: None });
        let _a = Client::connect(server.local_addr());
        let _b = Client::connect(server.local_addr());
        let mut c = Client::connect_raw(server.local_addr());
        let mut text = String::new();
        c.reader.read_to_string(&mut text).unwrap();
        assert!(text.starts_with("\x07canopen-drive-linux: refused: 2 clients connected"), "{text:?}");
        assert_eq!(bus.endpoint_count(), 2);
    }

    #[test]
    fn an_idle_client_is_disconnected() {
        let (server, bus) = start_with(Limits { max_clients: 2, idle_timeout: Some(Duration::from_secs(1)) });
        let mut a = Client::connect(server.local_addr());
        wait_for_endpoints(&bus, 1);
        let started = Instant::now();
        let mut rest = Vec::new();
        a.reader.read_to_end(&mut rest).unwrap();
        assert!(started.elapsed() >= Duration::from_millis(900), "{:?}", started.elapsed());
        wait_for_endpoints(&bus, 0);
    }
}
