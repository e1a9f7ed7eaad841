//! `canopen-drive-linux`: the canopen-drive CiA 301/402 drive as a Linux process, with a
//! simulated motor, on a bus made of SLCAN-over-TCP clients and/or a SocketCAN interface.
//!
//! ```text
//! python-canopen ─┐                      ┌─ SLCAN client ─┐
//!  (SLCAN client) ├─ TCP ─ slcan_server ─┤                ├─ bus ─ node (Drive + SimMotor)
//!  other clients ─┘                      └─ SocketCAN ────┘
//! ```
//!
//! Modules: [`cli`] (arguments), [`slcan`] (the Lawicel ASCII codec), [`bus`] (the broadcast
//! medium), [`slcan_server`] and [`socketcan_port`] (endpoints), [`node`] (the drive's
//! configuration, EDS and real-time loop), [`profiles`] (the drives it can be: `--profile`).
//!
//! `--storage PATH` keeps the stored parameters (1010h/1011h) in PATH, a file that behaves
//! as NOR flash under the core's two-bank journal, and the LSS configuration in `PATH.lss`.

/// The one place the program reports to its operator: a line on stderr, prefixed with the
/// program's name. (stdout carries only the `ready` line, which tests and scripts wait for.)
macro_rules! log {
    ($($arg:tt)*) => {
        eprintln!("canopen-drive-linux: {}", format_args!($($arg)*))
    };
}

mod board_objects;
mod bus;
mod cli;
mod lss_store;
mod node;
mod profiles;
mod slcan;
mod slcan_server;
mod socketcan_port;

use std::io::Write;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use std::path::Path;

use canopen_drive::storage::{device_signature, Persistence, Storage};
use canopen_drive_sim::flash::FileFlash;
use signal_hook::consts::{SIGINT, SIGTERM};

use crate::bus::Bus;
use crate::cli::{Action, RunArgs};
use crate::profiles::{BoardProfile, ProfileName};
use crate::slcan_server::SlcanServer;

const NAME: &str = "canopen-drive-linux";

fn main() -> ExitCode {
    let action = match cli::parse(std::env::args_os().skip(1)) {
        Ok(action) => action,
        Err(e) => {
            eprintln!("{NAME}: error: {e}\nTry '{NAME} --help'.");
            return ExitCode::from(2);
        }
    };
    let result = match action {
        Action::Help => {
            print!("{}", cli::USAGE);
            Ok(())
        }
        Action::WriteEds { profile, node_id, path } => write_eds(profile, node_id, &path),
        Action::Run(args) => run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("{NAME}: error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn write_eds(profile: ProfileName, node_id: u8, path: &std::path::Path) -> Result<(), String> {
    let (_, eds) = node::config_with_eds(&BoardProfile::of(profile), node_id)?;
    std::fs::write(path, eds).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn run(args: &RunArgs) -> Result<(), String> {
    let profile = BoardProfile::of(args.profile);
    let lss_file = args.storage.as_deref().map(lss_store::path_for);
    let mut node_id = args.node_id;
    if let Some(stored) = lss_file.as_deref().and_then(lss_store::load) {
        log!(
            "node-ID {stored} from the LSS configuration in {}",
            lss_file.as_deref().unwrap_or(Path::new("")).display()
        );
        node_id = stored;
    }
    // SLCAN over TCP has no bit rate: the one stored by LSS (or a drive's own store command)
    // is what a CAN controller would run at; 1000 kbit/s otherwise.
    let bit_rate_kbit = lss_file.as_deref().and_then(lss_store::load_bit_rate).unwrap_or(1000);
    let board = node::Board { profile: &profile, lss_file: lss_file.as_deref(), bit_rate_kbit };
    let (mut config, _) = node::config_with_eds(&profile, node_id)?;
    config.lss_store = args.storage.is_some();
    let hooks = profile.hooks(args.storage.is_some());
    match &args.storage {
        Some(path) => {
            let flash =
                FileFlash::open_default(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
            let signature = device_signature(&config.device, node::STORAGE_LAYOUT);
            let storage =
                Storage::new(flash, signature).map_err(|e| format!("storage {}: {e:?}", path.display()))?;
            let drive = node::BoardDrive::build(config, hooks, storage)
                .map_err(|e| format!("invalid drive configuration: {e:?}"))?;
            serve(args, node_id, drive, &board)
        }
        None => {
            let drive = node::BoardDrive::<()>::create(config, hooks)
                .map_err(|e| format!("invalid drive configuration: {e:?}"))?;
            serve(args, node_id, drive, &board)
        }
    }
}

fn serve<S: Persistence>(
    args: &RunArgs,
    node_id: u8,
    drive: node::BoardDrive<S>,
    board: &node::Board<'_>,
) -> Result<(), String> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .map_err(|e| format!("cannot install the handler of signal {signal}: {e}"))?;
    }

    let (bus, frames) = Bus::new();
    if let Some(addr) = &args.slcan_listen {
        let server = SlcanServer::start(addr.as_str(), bus.clone())
            .map_err(|e| format!("cannot listen on {addr}: {e}"))?;
        log!("node {node_id} serving SLCAN on {}", server.local_addr());
    }
    if let Some(iface) = &args.socketcan {
        socketcan_port::attach(iface, &bus)
            .map_err(|e| format!("cannot open SocketCAN interface '{iface}': {e}"))?;
        log!("node {node_id} on SocketCAN {iface}");
    }

    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "ready")
        .and_then(|()| stdout.flush())
        .map_err(|e| format!("cannot write to stdout: {e}"))?;
    drop(stdout);

    log!("profile {}", board.profile.name.name());
    node::run(drive, board, &bus, &frames, &stop);
    Ok(())
}
