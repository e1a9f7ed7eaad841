//! Command-line arguments, parsed by clap from the declaration of [`Options`]; the values are
//! checked by this module's own parsers, and clap's refusals become a [`CliError`] with the
//! wording the program has always used.

use std::error::Error as _;
use std::ffi::OsString;
use std::fmt;
use std::path::PathBuf;
use std::sync::OnceLock;

use clap::builder::{OsStringValueParser, TypedValueParser};
use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{ArgAction, CommandFactory, FromArgMatches, Parser};

use crate::profiles::ProfileName;
use crate::slcan_server::Limits;

/// The options, as `--help` lists them (clap renders it from the texts below, which keep their
/// line breaks).
#[derive(Debug, Parser)]
#[command(
    name = crate::NAME,
    about = "canopen-drive-linux: a CANopen CiA 301/402 drive node with a simulated motor",
    override_usage = "canopen-drive-linux [OPTIONS] (--slcan-listen HOST:PORT | --socketcan IFACE)...
       canopen-drive-linux [--profile NAME] [--node-id N] [--storage PATH]
                           (--write-eds PATH | --write-xdd PATH)...",
    after_help = "--slcan-listen and --socketcan may be combined; all of them form one bus.
The producer heartbeat (1017h) starts at 0 (off), as CiA 301 specifies: a master sets it.
Prints `ready` on stdout once it accepts connections and has sent its boot-up, then one line
`bit-rate <kbit/s> kbit/s (table T index I)` for each bit-rate change an LSS master activates;
SIGINT or SIGTERM end it (status 0).",
    disable_help_flag = true
)]
struct Options {
    /// The drive to be: generic (the default: the library's CiA
    /// 301/402 defaults), chieftek, trinamic-pd57, harmonic-drive
    /// (rebuilt from their manuals, on a simulated axis of their own)
    #[arg(long, value_name = "NAME", verbatim_doc_comment, allow_hyphen_values = true,
          value_parser = text("--profile", profile))]
    profile: Option<ProfileName>,

    /// Node-ID, 1..127, or 255: not configured, waiting for an LSS
    /// master (decimal or 0x hex; default 1). A node-ID stored by
    /// LSS (see --storage) takes precedence
    #[arg(long, value_name = "N", verbatim_doc_comment, allow_hyphen_values = true,
          value_parser = text("--node-id", node_id))]
    node_id: Option<u8>,

    /// Serve SLCAN (Lawicel ASCII) over TCP; every connected client
    /// is a node on one shared bus (python-can:
    /// interface="slcan", channel="socket://HOST:PORT")
    #[arg(long, value_name = "HOST:PORT", verbatim_doc_comment, allow_hyphen_values = true,
          value_parser = text("--slcan-listen", address))]
    slcan_listen: Option<String>,

    /// Join the SocketCAN interface IFACE (e.g. can0, vcan0)
    #[arg(long, value_name = "IFACE", allow_hyphen_values = true,
          value_parser = text("--socketcan", interface))]
    socketcan: Option<String>,

    /// File of the stored parameters (1010h "save" / 1011h "load"),
    /// created if missing (a 16 KiB two-bank journal); the LSS
    /// configuration (node-ID, bit timing) goes to PATH.lss. A
    /// damaged, wrong-size or foreign file is reported, the drive
    /// runs on its defaults (EMCY 6300h) and the file is left as it
    /// is until a master stores parameters. With --write-eds or
    /// --write-xdd: describe the drive that keeps parameters (PATH
    /// is not opened)
    #[arg(long, value_name = "PATH", verbatim_doc_comment, allow_hyphen_values = true)]
    storage: Option<PathBuf>,

    /// The node has a bootloader, its program area a file at PATH
    /// (512 KiB, created erased): a valid program there runs as the
    /// application, with program download (CiA 302-3: 1F50h, 1F51h,
    /// 1F56h, 1F57h); without one the bootloader waits for a master
    /// to download and start one. Stop (1F51h:1 = 0) resets into the
    /// bootloader. A program whose first line is `canopen-drive-linux
    /// build VERSION REVISION` (hex) runs as that build (100Ah,
    /// 1018h:3)
    #[arg(long, value_name = "PATH", verbatim_doc_comment, allow_hyphen_values = true)]
    program_area: Option<PathBuf>,

    /// SLCAN clients served at once (default 32); one more is sent
    /// a line saying so and disconnected
    #[arg(long, value_name = "N", verbatim_doc_comment, allow_hyphen_values = true,
          value_parser = text("--max-clients", |v| positive::<usize>(v, "--max-clients")))]
    max_clients: Option<usize>,

    /// Disconnect an SLCAN client that sends nothing for SECONDS
    /// (default: never; TCP keepalive notices vanished peers anyway)
    #[arg(long, value_name = "SECONDS", verbatim_doc_comment, allow_hyphen_values = true,
          value_parser = text("--idle-timeout", |v| positive::<u64>(v, "--idle-timeout")))]
    idle_timeout: Option<u64>,

    /// No log lines on stderr (errors that end the program still)
    #[arg(long)]
    quiet: bool,

    /// Also log on stderr the drive's NMT and CiA 402 state changes,
    /// its mode of operation, every EMCY and SDO abort on the bus;
    /// -vv: also every frame in both directions, NMT commands and
    /// the core's own log (state transitions, storage events)
    #[arg(short, long, action = ArgAction::Count, verbatim_doc_comment)]
    verbose: u8,

    /// Write every frame on the bus, both directions, to FILE in the
    /// log format of `candump -l` (replay: canplayer -I FILE)
    #[arg(long, value_name = "FILE", verbatim_doc_comment, allow_hyphen_values = true)]
    trace: Option<PathBuf>,

    /// CiA 402 axes of the node, 1..8 (default 1; generic profile
    /// only): axis n's objects at 6000h + n x 800h, PDOs 4n+1..4n+4,
    /// its simulated motor's objects at 2100h + n x 10h
    #[arg(long, value_name = "N", verbatim_doc_comment, allow_hyphen_values = true,
          value_parser = text("--axes", axes))]
    axes: Option<u8>,

    /// Write the profile's EDS (CiA 306) to PATH and exit
    #[arg(long, value_name = "PATH", allow_hyphen_values = true)]
    write_eds: Option<PathBuf>,

    /// Write the profile's XDD (CiA 311) to PATH and exit; may be
    /// given with --write-eds
    #[arg(long, value_name = "PATH", verbatim_doc_comment, allow_hyphen_values = true)]
    write_xdd: Option<PathBuf>,

    /// Print this help and exit
    #[arg(short, long, action = ArgAction::Help)]
    help: Option<bool>,
}

/// The command clap parses with, built once: its arguments' names live as long as the program.
fn command() -> &'static clap::Command {
    static COMMAND: OnceLock<clap::Command> = OnceLock::new();
    COMMAND.get_or_init(Options::command)
}

/// The text of `--help`.
pub fn help() -> String {
    command().clone().render_help().to_string()
}

/// What the command line asks for.
#[derive(Debug, PartialEq, Eq)]
pub enum Action {
    /// Print [`help`].
    Help,
    /// Write the device descriptions of a node with this ID, then exit.
    Describe {
        /// The drive.
        profile: ProfileName,
        /// Node-ID.
        node_id: u8,
        /// The drive keeps parameters (`--storage`).
        storage: bool,
        /// Where to write the EDS.
        eds: Option<PathBuf>,
        /// Where to write the XDD.
        xdd: Option<PathBuf>,
        /// Axes of the node.
        axes: u8,
    },
    /// Run the drive.
    Run(RunArgs),
}

/// Options of a running drive.
#[derive(Debug, PartialEq, Eq)]
pub struct RunArgs {
    /// The drive.
    pub profile: ProfileName,
    /// Axes of the node (`--axes`).
    pub axes: u8,
    /// Node-ID, 1..=127.
    pub node_id: u8,
    /// `HOST:PORT` to serve SLCAN on.
    pub slcan_listen: Option<String>,
    /// SocketCAN interface name.
    pub socketcan: Option<String>,
    /// Parameter storage file.
    pub storage: Option<PathBuf>,
    /// `--program-area PATH`: the node has a bootloader.
    pub program_area: Option<PathBuf>,
    /// Limits of the SLCAN server.
    pub limits: Limits,
    /// No log lines.
    pub quiet: bool,
    /// `-v` (1) or `-vv` (2): state changes, EMCYs, SDO aborts (and frames).
    pub verbose: u8,
    /// `--trace FILE`: the candump log of the bus.
    pub trace: Option<PathBuf>,
}

/// A refused command line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CliError {
    /// An option this program does not have.
    UnknownOption(String),
    /// A positional argument (this program takes none).
    UnexpectedArgument(String),
    /// An option given without its value.
    MissingValue(&'static str),
    /// An option given twice.
    Repeated(&'static str),
    /// A value that is not valid UTF-8 where text is needed.
    NotUnicode(&'static str),
    /// A node-ID that is not a number in 1..=127.
    InvalidNodeId(String),
    /// A profile this program does not have.
    UnknownProfile(String),
    /// A listen address that is not `HOST:PORT`.
    InvalidAddress(String),
    /// An empty interface name.
    InvalidInterface,
    /// A count or a time that is not a positive whole number.
    InvalidNumber(&'static str, String),
    /// Neither `--slcan-listen` nor `--socketcan` (nor `--write-eds`, `--write-xdd`).
    NoBus,
    /// `--quiet` together with `-v`.
    QuietAndVerbose,
    /// `-v` given more than twice.
    TooVerbose,
    /// `--axes` outside 1..=8.
    InvalidAxes(String),
    /// `--axes` above 1 with a vendor profile.
    AxesOfProfile(ProfileName),
    /// Any other refusal of the parser (e.g. a value given to `--quiet`), in its words.
    Refused(String),
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::UnknownOption(o) => write!(f, "unknown option '{o}'"),
            CliError::UnexpectedArgument(a) => write!(f, "unexpected argument '{a}'"),
            CliError::MissingValue(o) => write!(f, "option '{o}' needs a value"),
            CliError::Repeated(o) => write!(f, "option '{o}' given more than once"),
            CliError::NotUnicode(o) => write!(f, "the value of '{o}' is not valid UTF-8"),
            CliError::InvalidNodeId(v) => {
                write!(f, "invalid node-ID '{v}': expected a number from 1 to 127, or 255")
            }
            CliError::UnknownProfile(v) => {
                let names: Vec<&str> = ProfileName::ALL.iter().map(|p| p.name()).collect();
                write!(f, "unknown profile '{v}': expected one of {}", names.join(", "))
            }
            CliError::InvalidAddress(v) => {
                write!(f, "invalid address '{v}': expected HOST:PORT, e.g. 127.0.0.1:5000")
            }
            CliError::InvalidInterface => f.write_str("the interface name of '--socketcan' is empty"),
            CliError::InvalidNumber(o, v) => {
                write!(f, "invalid value '{v}' of '{o}': expected a whole number from 1")
            }
            CliError::NoBus => {
                f.write_str("nothing to connect to: give --slcan-listen HOST:PORT and/or --socketcan IFACE")
            }
            CliError::QuietAndVerbose => f.write_str("--quiet and -v/--verbose exclude each other"),
            CliError::TooVerbose => f.write_str("-v goes up to -vv"),
            CliError::InvalidAxes(v) => write!(
                f,
                "invalid value '{v}' of '--axes': expected a number from 1 to {}",
                crate::axes::MAX_AXES
            ),
            CliError::AxesOfProfile(p) => {
                write!(f, "profile {} is a single-axis drive: --axes needs the generic profile", p.name())
            }
            CliError::Refused(message) => f.write_str(message),
        }
    }
}

impl std::error::Error for CliError {}

/// Parses the arguments (without the program name).
pub fn parse(args: impl IntoIterator<Item = OsString>) -> Result<Action, CliError> {
    let program = std::iter::once(OsString::from(crate::NAME));
    let matches = match command().clone().try_get_matches_from(program.chain(args)) {
        Ok(matches) => matches,
        Err(e) if e.kind() == ErrorKind::DisplayHelp => return Ok(Action::Help),
        Err(e) => return Err(refusal(&e)),
    };
    let options = Options::from_arg_matches(&matches).map_err(|e| refusal(&e))?;
    if options.verbose > 2 {
        return Err(CliError::TooVerbose);
    }
    let node_id = options.node_id.unwrap_or(1);
    let profile = options.profile.unwrap_or(ProfileName::Generic);
    let axes = options.axes.unwrap_or(1);
    if axes > 1 && profile != ProfileName::Generic {
        return Err(CliError::AxesOfProfile(profile));
    }
    if options.write_eds.is_some() || options.write_xdd.is_some() {
        let (eds, xdd, storage) = (options.write_eds, options.write_xdd, options.storage.is_some());
        return Ok(Action::Describe { profile, node_id, storage, eds, xdd, axes });
    }
    if options.slcan_listen.is_none() && options.socketcan.is_none() {
        return Err(CliError::NoBus);
    }
    if options.quiet && options.verbose > 0 {
        return Err(CliError::QuietAndVerbose);
    }
    let defaults = Limits::default();
    let limits = Limits {
        max_clients: options.max_clients.unwrap_or(defaults.max_clients),
        idle_timeout: options.idle_timeout.map(std::time::Duration::from_secs).or(defaults.idle_timeout),
    };
    Ok(Action::Run(RunArgs {
        profile,
        axes,
        node_id,
        slcan_listen: options.slcan_listen,
        socketcan: options.socketcan,
        storage: options.storage,
        program_area: options.program_area,
        limits,
        quiet: options.quiet,
        verbose: options.verbose,
        trace: options.trace,
    }))
}

/// A refusal of clap as the program words it: a value parser's own [`CliError`], or the
/// option or argument clap names.
fn refusal(error: &clap::Error) -> CliError {
    if let Some(own) = error.source().and_then(|source| source.downcast_ref::<CliError>()) {
        return own.clone();
    }
    let named = match error.get(ContextKind::InvalidArg) {
        Some(ContextValue::String(text)) => text.clone(),
        _ => String::new(),
    };
    // clap names an option with its value, e.g. "--trace <FILE>".
    let option = named.split_whitespace().next().and_then(long_name);
    match (error.kind(), option) {
        (ErrorKind::UnknownArgument, _) if named.starts_with('-') => {
            CliError::UnknownOption(named.split('=').next().unwrap_or_default().to_string())
        }
        (ErrorKind::UnknownArgument, _) => CliError::UnexpectedArgument(named),
        (ErrorKind::InvalidValue, Some(option)) => CliError::MissingValue(option),
        (ErrorKind::ArgumentConflict, Some(option)) => CliError::Repeated(option),
        _ => {
            let text = error.to_string();
            let first = text.lines().next().unwrap_or_default();
            CliError::Refused(first.trim_start_matches("error: ").to_string())
        }
    }
}

/// `--name` as the command declares it, kept as long as the program runs (for [`CliError`]).
fn long_name(typed: &str) -> Option<&'static str> {
    static NAMES: OnceLock<Vec<String>> = OnceLock::new();
    let names = NAMES.get_or_init(|| {
        command().get_arguments().filter_map(|arg| arg.get_long()).map(|long| format!("--{long}")).collect()
    });
    names.iter().find(|name| *name == typed).map(String::as_str)
}

/// A value parser of one option: the value as UTF-8 text (refused as [`CliError::NotUnicode`]
/// otherwise), then `parse`.
fn text<T: Clone + Send + Sync + 'static>(
    option: &'static str,
    parse: impl Fn(&str) -> Result<T, CliError> + Clone + Send + Sync + 'static,
) -> impl TypedValueParser<Value = T> {
    OsStringValueParser::new()
        .try_map(move |value| parse(&value.into_string().map_err(|_| CliError::NotUnicode(option))?))
}

fn profile(text: &str) -> Result<ProfileName, CliError> {
    ProfileName::parse(text).ok_or_else(|| CliError::UnknownProfile(text.to_string()))
}

fn axes(text: &str) -> Result<u8, CliError> {
    match text.parse::<u8>() {
        Ok(n) if (1..=crate::axes::MAX_AXES).contains(&n) => Ok(n),
        _ => Err(CliError::InvalidAxes(text.to_string())),
    }
}

fn interface(text: &str) -> Result<String, CliError> {
    if text.is_empty() {
        return Err(CliError::InvalidInterface);
    }
    Ok(text.to_string())
}

/// A whole number from 1 (a count or seconds).
fn positive<T: std::str::FromStr + Default + PartialOrd>(
    text: &str,
    option: &'static str,
) -> Result<T, CliError> {
    match text.parse::<T>() {
        Ok(n) if n > T::default() => Ok(n),
        _ => Err(CliError::InvalidNumber(option, text.to_string())),
    }
}

fn node_id(text: &str) -> Result<u8, CliError> {
    let number = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u8::from_str_radix(hex, 16),
        None => text.parse::<u8>(),
    };
    match number {
        Ok(id @ (1..=127 | 255)) => Ok(id),
        _ => Err(CliError::InvalidNodeId(text.to_string())),
    }
}

/// `HOST:PORT` with a non-empty host and a numeric port (`[::1]:5000` for IPv6). The host is
/// resolved when the server binds.
fn address(text: &str) -> Result<String, CliError> {
    match text.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => Ok(text.to_string()),
        _ => Err(CliError::InvalidAddress(text.to_string())),
    }
}
#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    fn parse_str(args: &[&str]) -> Result<Action, CliError> {
        parse(args.iter().map(OsString::from))
    }

    #[test]
    fn run_with_defaults() {
        assert_eq!(
            parse_str(&["--slcan-listen", "127.0.0.1:5000"]),
            Ok(Action::Run(RunArgs {
                profile: ProfileName::Generic,
                axes: 1,
                node_id: 1,
                slcan_listen: Some("127.0.0.1:5000".into()),
                socketcan: None,
                storage: None,
                program_area: None,
                limits: Limits::default(),
                quiet: false,
                verbose: 0,
                trace: None,
            }))
        );
    }

    #[test]
    fn all_options() {
        assert_eq!(
            parse_str(&[
                "--node-id",
                "0x7F",
                "--slcan-listen=localhost:0",
                "--socketcan",
                "can0",
                "--storage",
                "/tmp/p.bin",
                "--max-clients=4",
                "--idle-timeout",
                "30",
                "--quiet",
                "--trace",
                "bus.log",
            ]),
            Ok(Action::Run(RunArgs {
                profile: ProfileName::Generic,
                axes: 1,
                node_id: 127,
                slcan_listen: Some("localhost:0".into()),
                socketcan: Some("can0".into()),
                storage: Some("/tmp/p.bin".into()),
                program_area: None,
                limits: Limits { max_clients: 4, idle_timeout: Some(std::time::Duration::from_secs(30)) },
                quiet: true,
                verbose: 0,
                trace: Some("bus.log".into()),
            }))
        );
        let describe = |profile, node_id, storage, eds: Option<&str>, xdd: Option<&str>| {
            Ok(Action::Describe {
                profile,
                node_id,
                storage,
                eds: eds.map(Into::into),
                xdd: xdd.map(Into::into),
                axes: 1,
            })
        };
        assert_eq!(
            parse_str(&["--write-eds", "out.eds", "--node-id=5"]),
            describe(ProfileName::Generic, 5, false, Some("out.eds"), None)
        );
        assert_eq!(
            parse_str(&["--write-eds", "t.eds", "--profile", "trinamic-pd57"]),
            describe(ProfileName::TrinamicPd57, 1, false, Some("t.eds"), None)
        );
        assert_eq!(
            parse_str(&["--write-xdd", "t.xdd", "--storage", "p.bin", "--write-eds", "t.eds"]),
            describe(ProfileName::Generic, 1, true, Some("t.eds"), Some("t.xdd"))
        );
        for name in ProfileName::ALL {
            let Ok(Action::Run(args)) = parse_str(&["--profile", name.name(), "--socketcan", "can0"]) else {
                panic!("--profile {}", name.name());
            };
            assert_eq!(args.profile, name);
        }
        assert!(matches!(
            parse_str(&["--profile=harmonic-drive", "--socketcan", "can0"]),
            Ok(Action::Run(RunArgs { profile: ProfileName::HarmonicDrive, .. }))
        ));
        assert_eq!(parse_str(&["--slcan-listen", "x:1", "--help"]), Ok(Action::Help));
        assert_eq!(parse_str(&["-h"]), Ok(Action::Help));
        for (args, level) in [(&["-v"][..], 1), (&["-vv"], 2), (&["-v", "--verbose"], 2), (&[], 0)] {
            let mut all = vec!["--socketcan", "can0"];
            all.extend_from_slice(args);
            let Ok(Action::Run(run)) = parse_str(&all) else { panic!("{args:?}") };
            assert_eq!(run.verbose, level, "{args:?}");
        }
    }

    #[test]
    fn bad_arguments_are_refused() {
        let cases: [(&[&str], CliError); 25] = [
            (&["-v", "--quiet", "--socketcan", "c"], CliError::QuietAndVerbose),
            (&["-vv", "-v", "--socketcan", "c"], CliError::TooVerbose),
            (&["--trace"], CliError::MissingValue("--trace")),
            (&["--trace", "a", "--trace", "b"], CliError::Repeated("--trace")),
            (
                &["--max-clients", "0", "--socketcan", "c"],
                CliError::InvalidNumber("--max-clients", "0".into()),
            ),
            (
                &["--max-clients", "x", "--socketcan", "c"],
                CliError::InvalidNumber("--max-clients", "x".into()),
            ),
            (
                &["--idle-timeout", "-5", "--socketcan", "c"],
                CliError::InvalidNumber("--idle-timeout", "-5".into()),
            ),
            (&["--quiet", "--quiet"], CliError::Repeated("--quiet")),
            (&["--profile", "ds402", "--socketcan", "can0"], CliError::UnknownProfile("ds402".into())),
            (&["--profile"], CliError::MissingValue("--profile")),
            (&["--profile", "chieftek", "--profile", "chieftek"], CliError::Repeated("--profile")),
            (&[], CliError::NoBus),
            (&["--node-id", "5"], CliError::NoBus),
            (&["--node-id", "0", "--socketcan", "can0"], CliError::InvalidNodeId("0".into())),
            (&["--node-id", "128", "--socketcan", "can0"], CliError::InvalidNodeId("128".into())),
            (&["--node-id", "abc"], CliError::InvalidNodeId("abc".into())),
            (&["--node-id", "-1"], CliError::InvalidNodeId("-1".into())),
            (&["--node-id"], CliError::MissingValue("--node-id")),
            (&["--slcan-listen", "5000"], CliError::InvalidAddress("5000".into())),
            (&["--slcan-listen", ":5000"], CliError::InvalidAddress(":5000".into())),
            (&["--slcan-listen", "host:99999"], CliError::InvalidAddress("host:99999".into())),
            (&["--socketcan", ""], CliError::InvalidInterface),
            (&["--heartbeat", "100"], CliError::UnknownOption("--heartbeat".into())),
            (&["can0"], CliError::UnexpectedArgument("can0".into())),
            (&["--node-id", "1", "--node-id", "2"], CliError::Repeated("--node-id")),
        ];
        for (args, error) in cases {
            assert_eq!(parse_str(args), Err(error), "{args:?}");
        }
        assert!(CliError::NoBus.to_string().contains("--slcan-listen"));
        assert!(CliError::InvalidNodeId("0".into()).to_string().contains("1 to 127"));
        assert!(CliError::UnknownProfile("x".into()).to_string().contains("trinamic-pd57, harmonic-drive"));
    }

    #[test]
    fn axes() {
        let Ok(Action::Run(args)) = parse_str(&["--axes", "2", "--socketcan", "can0"]) else {
            panic!("--axes 2")
        };
        assert_eq!(args.axes, 2);
        let Ok(Action::Describe { axes, .. }) = parse_str(&["--axes=4", "--write-eds", "a.eds"]) else {
            panic!("--axes=4 --write-eds")
        };
        assert_eq!(axes, 4);
        for bad in ["0", "9", "two"] {
            assert_eq!(
                parse_str(&["--axes", bad, "--socketcan", "can0"]),
                Err(CliError::InvalidAxes(bad.into()))
            );
        }
        assert_eq!(
            parse_str(&["--axes", "2", "--profile", "chieftek", "--socketcan", "can0"]),
            Err(CliError::AxesOfProfile(ProfileName::Chieftek))
        );
        assert!(CliError::InvalidAxes("9".into()).to_string().contains("from 1 to 8"));
    }

    #[test]
    fn refusals_clap_words_and_values_that_are_not_text() {
        use std::os::unix::ffi::OsStringExt;
        let not_text = OsString::from_vec(vec![b'c', 0xFF]);
        assert_eq!(
            parse([OsString::from("--socketcan"), not_text]),
            Err(CliError::NotUnicode("--socketcan"))
        );
        let Err(CliError::Refused(message)) = parse_str(&["--quiet=yes"]) else { panic!("--quiet=yes") };
        assert!(message.contains("'yes'") && message.contains("--quiet"), "{message}");
        assert_eq!(parse_str(&["--bogus=1"]), Err(CliError::UnknownOption("--bogus".into())));
    }

    #[test]
    fn help_lists_every_option_its_default_and_the_notes() {
        let help = help();
        for text in [
            "canopen-drive-linux [OPTIONS] (--slcan-listen HOST:PORT | --socketcan IFACE)...",
            "canopen-drive-linux [--profile NAME] [--node-id N] [--storage PATH]\n",
            "(--write-eds PATH | --write-xdd PATH)...",
            "--profile <NAME>",
            "chieftek, trinamic-pd57, harmonic-drive",
            "--node-id <N>",
            "default 1",
            "--slcan-listen <HOST:PORT>",
            "channel=\"socket://HOST:PORT\"",
            "--socketcan <IFACE>",
            "--storage <PATH>",
            "PATH.lss",
            "--max-clients <N>",
            "default 32",
            "--idle-timeout <SECONDS>",
            "default: never",
            "--quiet",
            "-v, --verbose",
            "-vv: also every frame",
            "--trace <FILE>",
            "canplayer -I FILE",
            "--axes <N>",
            "PDOs 4n+1..4n+4",
            "--write-eds <PATH>",
            "--write-xdd <PATH>",
            "describe the drive that keeps parameters",
            "-h, --help",
            "all of them form one bus",
            "SIGINT or SIGTERM end it (status 0)",
        ] {
            assert!(help.contains(text), "{text:?} not in\n{help}");
        }
    }
}
