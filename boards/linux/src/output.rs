//! Everything the program writes to stdout and stderr, through one writer thread.
//!
//! Whoever started the program may stop reading its output at any time: close the pipes
//! (`EPIPE`), or keep them open and never read (a full pipe blocks every write). Neither may
//! stop the drive, so no other thread writes to stdout or stderr:
//!
//! - [`log`] and [`line`] hand their text to the writer thread through a bounded queue and
//!   return at once; when the queue is full (the writer is blocked on a pipe nobody reads), the
//!   line is dropped and counted, and the next line written says how many were lost;
//! - the writer ignores write errors: a closed pipe loses the text, nothing else;
//! - `--quiet` drops the log lines (stderr) but not warnings, what stdout carries or the final
//!   error.
//!
//! Before the process exits, [`flush`] waits (a bounded time) for the queue to be written.

use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::thread;
use std::time::Duration;

/// Lines waiting for the writer before further lines are dropped.
const QUEUE: usize = 1024;

/// One piece of output.
enum Output {
    /// A line for stdout.
    Stdout(String),
    /// A line for stderr.
    Stderr(String),
    /// Answer when everything before has been written.
    Flush(SyncSender<()>),
}

struct Writer {
    queue: SyncSender<Output>,
}

static WRITER: OnceLock<Writer> = OnceLock::new();
static QUIET: AtomicBool = AtomicBool::new(false);
static DROPPED: AtomicU64 = AtomicU64::new(0);
/// Serialises the fallback of writing directly (before the writer runs).
static DIRECT: Mutex<()> = Mutex::new(());

/// Starts the writer thread; `quiet` drops the log lines. Output before this call is written
/// directly (ignoring errors).
pub fn init(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
    WRITER.get_or_init(|| {
        let (queue, lines) = mpsc::sync_channel(QUEUE);
        let spawned = thread::Builder::new().name("output".into()).spawn(move || write_loop(&lines));
        if spawned.is_err() {
            // Without the thread the queue fills and lines are dropped: nothing blocks.
            DROPPED.fetch_add(1, Ordering::Relaxed);
        }
        Writer { queue }
    });
}

/// A log line on stderr, prefixed with the program's name (dropped with `--quiet`).
pub fn log(args: std::fmt::Arguments<'_>) {
    if !QUIET.load(Ordering::Relaxed) {
        send(Output::Stderr(format!("{}: {args}\n", crate::NAME)));
    }
}

/// An error on stderr, prefixed with the program's name (also with `--quiet`).
pub fn error(args: std::fmt::Arguments<'_>) {
    send(Output::Stderr(format!("{}: error: {args}\n", crate::NAME)));
}

/// A warning on stderr, prefixed with the program's name (also with `--quiet`): a condition
/// the operator must know of that does not stop the program.
pub fn warning(args: std::fmt::Arguments<'_>) {
    send(Output::Stderr(format!("{}: warning: {args}\n", crate::NAME)));
}

/// A line on stdout (`ready`, bit-rate changes).
pub fn line(args: std::fmt::Arguments<'_>) {
    send(Output::Stdout(format!("{args}\n")));
}

/// Text on stdout as it is (`--help`).
pub fn text(text: &str) {
    send(Output::Stdout(text.to_string()));
}

/// Waits up to `timeout` until everything queued so far has been written (or failed to).
pub fn flush(timeout: Duration) {
    let Some(writer) = WRITER.get() else { return };
    let (done, written) = mpsc::sync_channel(1);
    if send_within(&writer.queue, Output::Flush(done), timeout) {
        let _ = written.recv_timeout(timeout);
    }
}

fn send(output: Output) {
    match WRITER.get() {
        Some(writer) => match writer.queue.try_send(output) {
            Ok(()) => {}
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                DROPPED.fetch_add(1, Ordering::Relaxed);
            }
        },
        None => {
            let _guard = DIRECT.lock().unwrap_or_else(PoisonError::into_inner);
            write_out(output);
        }
    }
}

fn write_loop(lines: &Receiver<Output>) {
    while let Ok(output) = lines.recv() {
        let dropped = DROPPED.swap(0, Ordering::Relaxed);
        if dropped > 0 {
            write_out(Output::Stderr(format!("{}: {dropped} output lines dropped\n", crate::NAME)));
        }
        write_out(output);
    }
}

/// Writes and flushes; errors (a closed pipe) lose the text and nothing else.
fn write_out(output: Output) {
    match output {
        Output::Stdout(text) => {
            let mut out = std::io::stdout().lock();
            let _ = out.write_all(text.as_bytes()).and_then(|()| out.flush());
        }
        Output::Stderr(text) => {
            let _ = std::io::stderr().lock().write_all(text.as_bytes());
        }
        Output::Flush(done) => {
            let _ = done.try_send(());
        }
    }
}

/// Queues `value`, waiting up to `timeout` while the queue is full (std's `SyncSender` has no
/// send with a deadline). Returns whether it was queued.
fn send_within<T>(queue: &SyncSender<T>, mut value: T, timeout: Duration) -> bool {
    let deadline = std::time::Instant::now() + timeout;
    loop {
        match queue.try_send(value) {
            Ok(()) => return true,
            Err(TrySendError::Disconnected(_)) => return false,
            Err(TrySendError::Full(back)) if std::time::Instant::now() < deadline => {
                value = back;
                thread::sleep(Duration::from_millis(5));
            }
            Err(TrySendError::Full(_)) => return false,
        }
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn output_never_blocks_and_flush_returns() {
        init(false);
        for i in 0..(QUEUE * 3) {
            log(format_args!("line {i}"));
        }
        flush(Duration::from_secs(5));
    }
}
