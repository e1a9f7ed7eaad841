//! Command-line arguments.

use std::ffi::OsString;
use std::fmt;
use std::path::PathBuf;

use crate::profiles::ProfileName;
use crate::slcan_server::Limits;

/// The text of `--help`.
pub const USAGE: &str = "\
canopen-drive-linux: a CANopen CiA 301/402 drive node with a simulated motor

USAGE:
    canopen-drive-linux [OPTIONS] (--slcan-listen HOST:PORT | --socketcan IFACE)...
    canopen-drive-linux [--profile NAME] [--node-id N] --write-eds PATH

OPTIONS:
    --profile NAME            The drive to be: generic (the default: the library's CiA
                              301/402 defaults), chieftek, trinamic-pd57, harmonic-drive
                              (rebuilt from their manuals, on a simulated axis of their own)
    --node-id N               Node-ID, 1..127, or 255: not configured, waiting for an LSS
                              master (decimal or 0x hex; default 1). A node-ID stored by
                              LSS (see --storage) takes precedence
    --slcan-listen HOST:PORT  Serve SLCAN (Lawicel ASCII) over TCP; every connected client
                              is a node on one shared bus (python-can:
                              interface=\"slcan\", channel=\"socket://HOST:PORT\")
    --socketcan IFACE         Join the SocketCAN interface IFACE (e.g. can0, vcan0)
    --storage PATH            File of the stored parameters (1010h \"save\" / 1011h \"load\"),
                              created if missing (a 16 KiB two-bank journal); the LSS
                              configuration (node-ID, bit timing) goes to PATH.lss. A
                              damaged, wrong-size or foreign file is reported, the drive
                              runs on its defaults (EMCY 6300h) and the file is left as it
                              is until a master stores parameters
    --max-clients N           SLCAN clients served at once (default 32); one more is sent
                              a line saying so and disconnected
    --idle-timeout SECONDS    Disconnect an SLCAN client that sends nothing for SECONDS
                              (default: never; TCP keepalive notices vanished peers anyway)
    --quiet                   No log lines on stderr (errors that end the program still)
    -v, --verbose             Also log on stderr the drive's NMT and CiA 402 state changes,
                              its mode of operation, every EMCY and SDO abort on the bus
    -vv                       ... and every frame in both directions, NMT commands and the
                              core's own log (state transitions, storage events)
    --trace FILE              Write every frame on the bus, both directions, to FILE in the
                              log format of `candump -l` (replay: canplayer -I FILE)
    --write-eds PATH          Write the profile's EDS to PATH and exit
    -h, --help                Print this help and exit

--slcan-listen and --socketcan may be combined; all of them form one bus.
The producer heartbeat (1017h) starts at 0 (off), as CiA 301 specifies: a master sets it.
Prints `ready` on stdout once it accepts connections, then one line
`bit-rate <kbit/s> kbit/s (table T index I)` for each bit-rate change an LSS master activates;
SIGINT or SIGTERM end it (status 0).
";

/// What the command line asks for.
#[derive(Debug, PartialEq, Eq)]
pub enum Action {
    /// Print [`USAGE`].
    Help,
    /// Write the EDS of a node with this ID to the path, then exit.
    WriteEds {
        /// The drive.
        profile: ProfileName,
        /// Node-ID.
        node_id: u8,
        /// Where to write.
        path: PathBuf,
    },
    /// Run the drive.
    Run(RunArgs),
}

/// Options of a running drive.
#[derive(Debug, PartialEq, Eq)]
pub struct RunArgs {
    /// The drive.
    pub profile: ProfileName,
    /// Node-ID, 1..=127.
    pub node_id: u8,
    /// `HOST:PORT` to serve SLCAN on.
    pub slcan_listen: Option<String>,
    /// SocketCAN interface name.
    pub socketcan: Option<String>,
    /// Parameter storage file.
    pub storage: Option<PathBuf>,
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
    /// Neither `--slcan-listen` nor `--socketcan` (nor `--write-eds`).
    NoBus,
    /// `--quiet` together with `-v`.
    QuietAndVerbose,
    /// `-v` given more than twice.
    TooVerbose,
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
        }
    }
}

impl std::error::Error for CliError {}

/// Parses the arguments (without the program name).
pub fn parse(args: impl IntoIterator<Item = OsString>) -> Result<Action, CliError> {
    let mut profile: Option<ProfileName> = None;
    let mut node_id: Option<u8> = None;
    let mut slcan_listen: Option<String> = None;
    let mut socketcan: Option<String> = None;
    let mut storage: Option<PathBuf> = None;
    let mut write_eds: Option<PathBuf> = None;
    let mut max_clients: Option<usize> = None;
    let mut idle_timeout: Option<u64> = None;
    let mut quiet = false;
    let mut verbose: u8 = 0;
    let mut trace: Option<PathBuf> = None;

    let mut args = args.into_iter();
    while let Some(arg) = args.next() {
        let Some(text) = arg.to_str() else {
            return Err(CliError::UnexpectedArgument(arg.to_string_lossy().into_owned()));
        };
        // `--name=value` and `--name value` are both accepted.
        let (name, inline) = match text.split_once('=') {
            Some((name, value)) if name.starts_with("--") => (name.to_string(), Some(OsString::from(value))),
            _ => (text.to_string(), None),
        };
        let mut value = |option: &'static str| {
            inline.clone().or_else(|| args.next()).ok_or(CliError::MissingValue(option))
        };
        match name.as_str() {
            "-h" | "--help" => return Ok(Action::Help),
            "--node-id" => {
                let v = utf8(value("--node-id")?, "--node-id")?;
                set_once(&mut node_id, parse_node_id(&v)?, "--node-id")?;
            }
            "--profile" => {
                let v = utf8(value("--profile")?, "--profile")?;
                let name = ProfileName::parse(&v).ok_or(CliError::UnknownProfile(v))?;
                set_once(&mut profile, name, "--profile")?;
            }
            "--slcan-listen" => {
                let v = utf8(value("--slcan-listen")?, "--slcan-listen")?;
                check_address(&v)?;
                set_once(&mut slcan_listen, v, "--slcan-listen")?;
            }
            "--socketcan" => {
                let v = utf8(value("--socketcan")?, "--socketcan")?;
                if v.is_empty() {
                    return Err(CliError::InvalidInterface);
                }
                set_once(&mut socketcan, v, "--socketcan")?;
            }
            "--storage" => set_once(&mut storage, PathBuf::from(value("--storage")?), "--storage")?,
            "--max-clients" => {
                let v = utf8(value("--max-clients")?, "--max-clients")?;
                set_once(&mut max_clients, positive(&v, "--max-clients")?, "--max-clients")?;
            }
            "--idle-timeout" => {
                let v = utf8(value("--idle-timeout")?, "--idle-timeout")?;
                set_once(&mut idle_timeout, positive(&v, "--idle-timeout")?, "--idle-timeout")?;
            }
            "--quiet" if inline.is_none() => {
                if quiet {
                    return Err(CliError::Repeated("--quiet"));
                }
                quiet = true;
            }
            "-v" | "--verbose" | "-vv" if inline.is_none() => {
                verbose = verbose.saturating_add(if name == "-vv" { 2 } else { 1 });
                if verbose > 2 {
                    return Err(CliError::TooVerbose);
                }
            }
            "--trace" => set_once(&mut trace, PathBuf::from(value("--trace")?), "--trace")?,
            "--write-eds" => set_once(&mut write_eds, PathBuf::from(value("--write-eds")?), "--write-eds")?,
            other if other.starts_with('-') => return Err(CliError::UnknownOption(other.to_string())),
            other => return Err(CliError::UnexpectedArgument(other.to_string())),
        }
    }

    let node_id = node_id.unwrap_or(1);
    let profile = profile.unwrap_or(ProfileName::Generic);
    if let Some(path) = write_eds {
        return Ok(Action::WriteEds { profile, node_id, path });
    }
    if slcan_listen.is_none() && socketcan.is_none() {
        return Err(CliError::NoBus);
    }
    if quiet && verbose > 0 {
        return Err(CliError::QuietAndVerbose);
    }
    let defaults = Limits::default();
    let limits = Limits {
        max_clients: max_clients.unwrap_or(defaults.max_clients),
        idle_timeout: idle_timeout.map(std::time::Duration::from_secs).or(defaults.idle_timeout),
    };
    Ok(Action::Run(RunArgs {
        profile,
        node_id,
        slcan_listen,
        socketcan,
        storage,
        limits,
        quiet,
        verbose,
        trace,
    }))
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

fn utf8(value: OsString, option: &'static str) -> Result<String, CliError> {
    value.into_string().map_err(|_| CliError::NotUnicode(option))
}

fn set_once<T>(slot: &mut Option<T>, value: T, option: &'static str) -> Result<(), CliError> {
    if slot.is_some() {
        return Err(CliError::Repeated(option));
    }
    *slot = Some(value);
    Ok(())
}

fn parse_node_id(text: &str) -> Result<u8, CliError> {
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
fn check_address(text: &str) -> Result<(), CliError> {
    match text.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => Ok(()),
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
                node_id: 1,
                slcan_listen: Some("127.0.0.1:5000".into()),
                socketcan: None,
                storage: None,
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
                node_id: 127,
                slcan_listen: Some("localhost:0".into()),
                socketcan: Some("can0".into()),
                storage: Some("/tmp/p.bin".into()),
                limits: Limits { max_clients: 4, idle_timeout: Some(std::time::Duration::from_secs(30)) },
                quiet: true,
                verbose: 0,
                trace: Some("bus.log".into()),
            }))
        );
        assert_eq!(
            parse_str(&["--write-eds", "out.eds", "--node-id=5"]),
            Ok(Action::WriteEds { profile: ProfileName::Generic, node_id: 5, path: "out.eds".into() })
        );
        assert_eq!(
            parse_str(&["--write-eds", "t.eds", "--profile", "trinamic-pd57"]),
            Ok(Action::WriteEds { profile: ProfileName::TrinamicPd57, node_id: 1, path: "t.eds".into() })
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
}
