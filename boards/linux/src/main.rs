//! `canopen-drive-linux`: the canopen-drive CiA 301/402 drive as a Linux process, with a
//! simulated motor, on a bus made of SLCAN-over-TCP clients and/or a SocketCAN interface.
//!
//! ```text
//! python-canopen ─┐                      ┌─ SLCAN client ─┐
//!  (SLCAN client) ├─ TCP ─ slcan_server ─┤                ├─ bus ─ node (Drive + SimMotor)
//!  other clients ─┘                      └─ SocketCAN ────┘
//! ```
//!
//! Modules: [`cli`] (arguments), [`bus`] (the broadcast medium), [`slcan_server`] (with the
//! SLCAN codec of `canopen-drive-slcan`) and [`socketcan_port`] (endpoints), [`node`] (the
//! drive's configuration, EDS and real-time loop), [`profiles`] (the drives it can be:
//! `--profile`).
//!
//! `--storage PATH` keeps the stored parameters (1010h/1011h) in PATH, a file that behaves
//! as NOR flash under the core's two-bank journal, and the LSS configuration in `PATH.lss`.
//! `--program-area PATH` makes the node a device with a bootloader ([`program_area`]).

/// The one place the program reports to its operator: a line on stderr, prefixed with the
/// program's name, written by [`output`] (never blocking, never failing; dropped with
/// `--quiet`). stdout carries the `ready` line, which tests and scripts wait for, and the
/// bit-rate changes.
macro_rules! log {
    ($($arg:tt)*) => {
        $crate::output::log(format_args!($($arg)*))
    };
}

mod axes;
mod board_objects;
mod bus;
mod cli;
mod lss_store;
mod monitor;
mod node;
mod output;
mod profiles;
mod program_area;
mod slcan_server;
mod socketcan_port;
mod trace;

use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use std::path::Path;

use canopen_drive::comm::program::ProgramRequest;
use canopen_drive::od::DeviceInfo;
use canopen_drive::storage::{device_signature, ImageState, Persistence, Storage};
use canopen_drive::Config;
use canopen_drive_sim::flash::FileFlash;
use signal_hook::consts::{SIGINT, SIGTERM};

use crate::board_objects::BoardHooks;
use crate::bus::Bus;
use crate::cli::{Action, RunArgs};
use crate::profiles::{BoardProfile, ProfileName};
use crate::slcan_server::SlcanServer;

const NAME: &str = "canopen-drive-linux";

/// How long the program waits at exit for its last output to be written.
const OUTPUT_FLUSH: Duration = Duration::from_secs(1);

fn main() -> ExitCode {
    let action = cli::parse(std::env::args_os().skip(1));
    output::init(matches!(&action, Ok(Action::Run(RunArgs { quiet: true, .. }))));
    let status = match action {
        Err(e) => {
            output::error(format_args!("{e}\nTry '{NAME} --help'."));
            ExitCode::from(2)
        }
        Ok(action) => {
            let result = match action {
                Action::Help => {
                    output::text(&cli::help());
                    Ok(())
                }
                Action::Describe { profile, node_id, storage, eds, xdd, axes } => {
                    describe(profile, axes, node_id, storage, eds.as_deref(), xdd.as_deref())
                }
                Action::Run(args) => run(&args),
            };
            match result {
                Ok(()) => ExitCode::SUCCESS,
                Err(message) => {
                    output::error(format_args!("{message}"));
                    ExitCode::FAILURE
                }
            }
        }
    };
    output::flush(OUTPUT_FLUSH);
    status
}

/// Writes the EDS and/or the XDD of the drive `profile` of `axes` axes at `node_id`, with
/// parameter storage or without.
fn describe(
    profile: ProfileName,
    axes: u8,
    node_id: u8,
    storage: bool,
    eds: Option<&Path>,
    xdd: Option<&Path>,
) -> Result<(), String> {
    let profile = BoardProfile::of(profile).with_axes(axes);
    let write = |path: &Path, text: String| {
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    if let Some(path) = eds {
        write(path, node::eds(&profile, node_id, storage)?)?;
    }
    if let Some(path) = xdd {
        write(path, node::xdd(&profile, node_id, storage)?)?;
    }
    Ok(())
}

fn run(args: &RunArgs) -> Result<(), String> {
    let mut profile = BoardProfile::of(args.profile).with_axes(args.axes);
    profile.config.program_download = args.program_area.is_some();
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
    let trace = match &args.trace {
        Some(path) => Some(
            trace::Trace::create(path)
                .map_err(|e| format!("cannot write the trace {}: {e}", path.display()))?,
        ),
        None => None,
    };
    if args.verbose > 0 {
        CoreLog::install(args.verbose);
    }
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .map_err(|e| format!("cannot install the handler of signal {signal}: {e}"))?;
    }
    let bus = open_bus(args, node_id)?;
    match profile.axes {
        1 => log!("profile {}", profile.name.name()),
        axes => log!("profile {}, {axes} axes", profile.name.name()),
    }
    // `ready` follows the first boot-up frame, so what a master sees does not depend on how
    // soon it connects. Whoever started the program may stop reading it after this line (see
    // `output`).
    let ready = std::cell::Cell::new(true);
    let started = || {
        if ready.replace(false) {
            output::line(format_args!("ready"));
        }
    };
    let Some(path) = &args.program_area else {
        let board = node::Board {
            profile: &profile,
            lss_file: lss_file.as_deref(),
            bit_rate_kbit,
            verbose: args.verbose,
            trace: trace.as_ref(),
        };
        start_drive(args, node_id, &board, None, &bus, &stop, started)?;
        return Ok(());
    };
    // A device with a bootloader: what runs after each stop or start is decided as at power-on.
    let mut area = program_area::open(path)?;
    let mut stay_in_bootloader = false;
    loop {
        let program = if stay_in_bootloader {
            None
        } else {
            let (checked, program) = program_area::check_program(area);
            area = checked;
            program
        };
        match program {
            Some((header, payload)) => {
                let mut build = profile;
                build.config.device = program_area::build_identity(profile.config.device, &payload);
                let board = node::Board {
                    profile: &build,
                    lss_file: lss_file.as_deref(),
                    bit_rate_kbit,
                    verbose: args.verbose,
                    trace: trace.as_ref(),
                };
                log!("application {} (1F56h {:08X}h)", build.config.device.software_version, header.crc);
                match start_drive(args, node_id, &board, Some(header.crc), &bus, &stop, started)? {
                    Some(ProgramRequest::Stop) => stay_in_bootloader = true,
                    Some(ProgramRequest::Reset | ProgramRequest::Start) => {}
                    None => return Ok(()),
                }
            }
            None => {
                let device = DeviceInfo { software_version: "bootloader", ..profile.config.device };
                let board = node::Board {
                    profile: &profile,
                    lss_file: None,
                    bit_rate_kbit,
                    verbose: args.verbose,
                    trace: trace.as_ref(),
                };
                log!("bootloader");
                let observer = node::observer(&board);
                match program_area::run_bootloader(area, device, node_id, &bus, &stop, &observer, started)? {
                    Some(returned) => {
                        area = returned;
                        stay_in_bootloader = false;
                    }
                    None => return Ok(()),
                }
            }
        }
    }
}

/// The bus of the node: the SLCAN server and/or the SocketCAN interface of the arguments.
fn open_bus(args: &RunArgs, node_id: u8) -> Result<Bus, String> {
    let bus = Bus::new();
    if let Some(addr) = &args.slcan_listen {
        let server = SlcanServer::start(addr.as_str(), bus.clone(), args.limits)
            .map_err(|e| format!("cannot listen on {addr}: {e}"))?;
        log!("node {node_id} serving SLCAN on {}", server.local_addr());
    }
    if let Some(iface) = &args.socketcan {
        socketcan_port::attach(iface, &bus)
            .map_err(|e| format!("cannot open SocketCAN interface '{iface}': {e}"))?;
        log!("node {node_id} on SocketCAN {iface}");
    }
    Ok(bus)
}

/// Builds the drive of `board` and runs it on `bus` until `stop` is set or a master stops or
/// resets its program (returned); `identification`: the program's CRC-32 (1F56h:1) when the
/// node has a bootloader.
fn start_drive(
    args: &RunArgs,
    node_id: u8,
    board: &node::Board<'_>,
    identification: Option<u32>,
    bus: &Bus,
    stop: &AtomicBool,
    started: impl FnOnce(),
) -> Result<Option<ProgramRequest>, String> {
    let (mut config, _) = node::config_with_eds(board.profile, node_id, args.storage.is_some())?;
    config.lss_store = args.storage.is_some();
    let hooks = board.profile.hooks(args.storage.is_some());
    let run = Run { args, board, identification, bus, stop };
    axes::with_axes!(board.profile.axes, start(&run, config, hooks, started))
}

/// What [`start`] runs the drive with.
struct Run<'a> {
    args: &'a RunArgs,
    board: &'a node::Board<'a>,
    identification: Option<u32>,
    bus: &'a Bus,
    stop: &'a AtomicBool,
}

/// Builds the drive of `AXES` axes with `PDOS` + `PDOS` PDOs (with the parameter storage of
/// `--storage`, or none) and serves it.
fn start<const PDOS: usize, const AXES: usize>(
    run: &Run<'_>,
    config: Config,
    hooks: BoardHooks,
    started: impl FnOnce(),
) -> Result<Option<ProgramRequest>, String> {
    match &run.args.storage {
        Some(path) => {
            let (flash, wrong_size) = FileFlash::open_default_tolerant(path)
                .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
            let signature = device_signature(&config.device, node::STORAGE_LAYOUT);
            let mut storage =
                Storage::new(flash, signature).map_err(|e| format!("storage {}: {e:?}", path.display()))?;
            report_damage(path, wrong_size, &mut storage);
            let drive = node::BoardDrive::<_, PDOS, AXES>::build(config, hooks, storage)
                .map_err(|e| format!("invalid drive configuration: {e:?}"))?;
            Ok(serve(run, drive, started))
        }
        None => {
            let drive = node::BoardDrive::<(), PDOS, AXES>::build(config, hooks, ())
                .map_err(|e| format!("invalid drive configuration: {e:?}"))?;
            Ok(serve(run, drive, started))
        }
    }
}

/// The core's own log (its `log` feature) on stderr: warnings and errors with `-v`, every record
/// with `-vv`.
struct CoreLog;

impl CoreLog {
    fn install(verbose: u8) {
        static LOGGER: CoreLog = CoreLog;
        if log::set_logger(&LOGGER).is_ok() {
            log::set_max_level(if verbose >= 2 { log::LevelFilter::Trace } else { log::LevelFilter::Warn });
        }
    }
}

impl log::Log for CoreLog {
    /// The core's records only (its macros log with target `canopen_drive`), not those of the
    /// libraries the program uses.
    fn enabled(&self, metadata: &log::Metadata<'_>) -> bool {
        metadata.target() == "canopen_drive"
    }

    fn log(&self, record: &log::Record<'_>) {
        if !self.enabled(record.metadata()) {
            return;
        }
        log!("core {}: {}", record.level().as_str().to_lowercase(), record.args());
    }

    fn flush(&self) {}
}

/// Says on stderr, before the drive starts, when the stored parameters cannot be used: a file
/// of the wrong size, damaged contents, an image of another drive. The rule is the same for
/// all: the drive runs on its defaults and reports the image lost (EMCY 6300h, 1001h, 1003h),
/// and the file is left as it is until a master stores parameters (1010h).
fn report_damage(path: &Path, wrong_size: Option<String>, storage: &mut Storage<FileFlash>) {
    let what = match (wrong_size, storage.status()) {
        (Some(why), _) => why,
        (None, Ok(ImageState::Corrupt)) => "the contents are damaged".to_string(),
        (None, Ok(ImageState::Foreign)) => {
            "it holds the parameters of another drive (identity 1018h or format)".to_string()
        }
        (None, Ok(ImageState::Found { .. } | ImageState::Empty)) => return,
        (None, Err(e)) => format!("it cannot be read ({e:?})"),
    };
    output::warning(format_args!(
        "stored parameters in {} not used: {what}; running on the defaults (EMCY 6300h); the file \
         is rewritten only when a master stores parameters (1010h)",
        path.display()
    ));
}

fn serve<S: Persistence, const PDOS: usize, const AXES: usize>(
    run: &Run<'_>,
    mut drive: node::BoardDrive<S, PDOS, AXES>,
    started: impl FnOnce(),
) -> Option<ProgramRequest> {
    if let Some(identification) = run.identification {
        drive.set_program_identification(identification);
    }
    node::run(drive, run.board, run.bus, run.stop, started)
}
