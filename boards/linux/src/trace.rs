//! `--trace FILE`: every frame on the bus, in both directions, in the log format of
//! `candump -l` (can-utils), so that `canplayer -I FILE` replays it:
//!
//! ```text
//! (1732637612.000123) can0 705#00
//! (1732637612.104711) can0 605#4000100000000000
//! (1732637612.104935) can0 585#4300100092010200
//! ```
//!
//! One line per frame: the wall-clock time in seconds and microseconds, the interface name
//! ([`INTERFACE`]: the program's bus is one CAN bus), the frame in candump's `ID#DATA`
//! notation (3 hex digits for an 11-bit identifier, 8 for a 29-bit one, `R` and the length for
//! a remote frame). Frames into the drive and out of it are in the order the drive loop saw
//! them; the format has no direction field, as a `candump` of a real bus has none.
//!
//! The file is written by a thread of its own behind a bounded queue, so a slow disk never
//! delays the drive loop; when the queue is full a frame is dropped and counted, and the next
//! line written is a comment (`# N frames not traced`; canplayer ignores lines that do not start
//! with `(`). The file is flushed whenever the queue runs empty and when the program ends.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{SystemTime, UNIX_EPOCH};

use canopen_drive::CanFrame;

use crate::monitor::candump_text;

/// The interface name in the trace. `canplayer vcan0=can0 -I FILE` replays it on `vcan0`.
pub const INTERFACE: &str = "can0";

/// Frames waiting for the writer thread before further frames are dropped.
const QUEUE: usize = 65_536;

/// A running trace; dropping it writes what is queued and closes the file.
pub struct Trace {
    queue: Option<SyncSender<(SystemTime, CanFrame)>>,
    dropped: Arc<AtomicU64>,
    writer: Option<JoinHandle<()>>,
}

impl Trace {
    /// Creates (or truncates) `path` and starts the writer thread.
    pub fn create(path: &Path) -> std::io::Result<Trace> {
        let file = BufWriter::new(File::create(path)?);
        let (queue, frames) = mpsc::sync_channel(QUEUE);
        let dropped = Arc::new(AtomicU64::new(0));
        let counter = Arc::clone(&dropped);
        let writer =
            thread::Builder::new().name("trace".into()).spawn(move || write_loop(file, &frames, &counter))?;
        Ok(Trace { queue: Some(queue), dropped, writer: Some(writer) })
    }

    /// Records a frame seen now. Never blocks.
    pub fn record(&self, frame: &CanFrame) {
        let Some(queue) = &self.queue else { return };
        match queue.try_send((SystemTime::now(), *frame)) {
            Ok(()) => {}
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

impl Drop for Trace {
    fn drop(&mut self) {
        // Closing the queue ends the writer once it has written everything queued.
        self.queue.take();
        if let Some(writer) = self.writer.take() {
            let _ = writer.join();
        }
    }
}

/// One line of the trace.
pub fn line(at: SystemTime, frame: &CanFrame) -> String {
    let since = at.duration_since(UNIX_EPOCH).unwrap_or_default();
    format!("({}.{:06}) {INTERFACE} {}\n", since.as_secs(), since.subsec_micros(), candump_text(frame))
}

fn write_loop(mut file: BufWriter<File>, frames: &Receiver<(SystemTime, CanFrame)>, dropped: &AtomicU64) {
    let mut reported = 0;
    let mut failed = false;
    loop {
        // Flush when nothing waits, then wait for the next frame.
        let next = match frames.try_recv() {
            Ok(item) => Some(item),
            Err(mpsc::TryRecvError::Empty) => {
                failed |= file.flush().is_err();
                frames.recv().ok()
            }
            Err(mpsc::TryRecvError::Disconnected) => None,
        };
        let Some((at, frame)) = next else { break };
        let lost = dropped.load(Ordering::Relaxed);
        if lost != reported {
            failed |= writeln!(file, "# {} frames not traced", lost - reported).is_err();
            reported = lost;
        }
        failed |= file.write_all(line(at, &frame).as_bytes()).is_err();
    }
    let lost = dropped.load(Ordering::Relaxed);
    if lost != reported {
        failed |= writeln!(file, "# {} frames not traced", lost - reported).is_err();
    }
    failed |= file.flush().is_err();
    if failed {
        log!("the trace file could not be written completely");
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn lines_are_candump_log_lines() {
        let at = UNIX_EPOCH + Duration::from_micros(1_732_637_612_000_123);
        let frame = CanFrame::new_standard(0x605, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(line(at, &frame), "(1732637612.000123) can0 605#4000100000000000\n");
    }

    #[test]
    fn every_recorded_frame_is_in_the_file_in_order() {
        let path = std::env::temp_dir().join(format!("canopen-drive-trace-{}.log", std::process::id()));
        let frames: Vec<CanFrame> = (0..1000u16)
            .map(|i| CanFrame::new_standard(0x180 + (i % 4), &i.to_le_bytes()).unwrap())
            .collect();
        {
            let trace = Trace::create(&path).unwrap();
            for frame in &frames {
                trace.record(frame);
            }
        }
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let written: Vec<&str> = text.lines().map(|l| l.split(' ').nth(2).unwrap()).collect();
        let expected: Vec<String> = frames.iter().map(candump_text).collect();
        assert_eq!(written, expected);
        assert!(text.lines().all(|l| l.starts_with('(') && l.contains(") can0 ")));
    }
}
