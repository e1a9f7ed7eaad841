//! The two back-ends of the benchmark: one source, built for the host (run under callgrind) or
//! for thumbv7em-none-eabihf (run in QEMU). See the crate documentation of the library and
//! `scripts/bench.sh`.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(not(target_os = "none"))]
mod host {
    //! `drive-bench list`: one line per measurement, `name<TAB>label`.
    //!
    //! `drive-bench run <n> [name…]`: for each measurement (all, or the named ones, in table
    //! order) but the whole runs, prepares it, prints its name, then calls [`run_repetitions`]
    //! four times: base with `n` and `2n` repetitions, measured with `n` and `2n`. Under
    //! `valgrind --tool=callgrind --collect-atstart=no
    //! --toggle-collect=drive_bench::run_repetitions --dump-after=drive_bench::run_repetitions`
    //! every call leaves one dump with its instruction count, four per measurement in that order.
    //!
    //! `drive-bench runs`: the names of the whole runs ([`Prepared::Run`]), one a line.
    //!
    //! `drive-bench whole <name>`: runs that whole run once ([`run_whole`]) and prints the ticks
    //! it counted. Under callgrind with `--toggle-collect` and `--dump-after` of
    //! `drive_bench::calibrate` and `drive_bench::counted_tick`, the first dump is the markers'
    //! call, then one dump per tick.

    use std::io::Write as _;
    use std::process::ExitCode;

    use drive_bench::{
        dictionary_size, run_repetitions, run_whole, Measurement, Prepared, Scratch, MEASUREMENTS,
    };

    fn is_run(measurement: &Measurement) -> bool {
        matches!((measurement.prepare)(), Ok(Prepared::Run { .. }))
    }

    fn label(measurement: &Measurement) -> String {
        let prepared = (measurement.prepare)().ok();
        if let Some((objects, entries)) = prepared.as_ref().and_then(dictionary_size) {
            return format!("{} ({objects} objects, {entries} entries)", measurement.label);
        }
        match prepared.and_then(run_whole) {
            Some(Ok(ticks)) => format!("{} ({ticks} ticks)", measurement.label),
            _ => measurement.label.to_string(),
        }
    }

    fn whole(name: &str) -> Result<(), String> {
        let measurement = drive_bench::measurement(name).ok_or(format!("unknown measurement {name}"))?;
        let prepared = (measurement.prepare)().map_err(|e| format!("{name}: {e:?}"))?;
        match run_whole(prepared) {
            Some(Ok(ticks)) => {
                println!("{ticks}");
                Ok(())
            }
            Some(Err(e)) => Err(format!("{name}: {e:?}")),
            None => Err(format!("{name} is not a whole run")),
        }
    }

    fn run(n: u32, names: &[String]) -> Result<(), String> {
        for name in names {
            if drive_bench::measurement(name).is_none() {
                return Err(format!("unknown measurement {name}"));
            }
        }
        let mut scratch = Box::new(Scratch::new());
        let mut out = std::io::stdout().lock();
        for measurement in
            MEASUREMENTS.iter().filter(|m| names.is_empty() || names.iter().any(|n| n == m.name))
        {
            let prepared = (measurement.prepare)().map_err(|e| format!("{}: {e:?}", measurement.name))?;
            if matches!(prepared, Prepared::Run { .. }) {
                continue;
            }
            writeln!(out, "{}", measurement.name).map_err(|e| e.to_string())?;
            out.flush().map_err(|e| e.to_string())?;
            for (repetitions, measured) in [(n, false), (2 * n, false), (n, true), (2 * n, true)] {
                run_repetitions(&prepared, &mut scratch, repetitions, measured);
            }
        }
        Ok(())
    }

    pub fn main() -> ExitCode {
        let args: Vec<String> = std::env::args().skip(1).collect();
        let outcome = match args.first().map(String::as_str) {
            Some("list") => {
                for measurement in MEASUREMENTS {
                    println!("{}\t{}", measurement.name, label(measurement));
                }
                Ok(())
            }
            Some("run") => match args.get(1).and_then(|n| n.parse().ok()) {
                Some(n) => run(n, args.get(2..).unwrap_or(&[])),
                None => Err("run <repetitions> [name…]".to_string()),
            },
            Some("runs") => {
                for measurement in MEASUREMENTS.iter().filter(|m| is_run(m)) {
                    println!("{}", measurement.name);
                }
                Ok(())
            }
            Some("whole") => match args.get(1) {
                Some(name) => whole(name),
                None => Err("whole <name>".to_string()),
            },
            _ => Err("usage: drive-bench list | run <repetitions> [name…] | runs | whole <name>".to_string()),
        };
        match outcome {
            Ok(()) => ExitCode::SUCCESS,
            Err(message) => {
                eprintln!("drive-bench: {message}");
                ExitCode::FAILURE
            }
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() -> std::process::ExitCode {
    host::main()
}

#[cfg(target_os = "none")]
mod firmware {
    //! The semihosting command line is `drive-bench <name> <n> base|measured|whole`: prepare the
    //! measurement, call [`run_repetitions`] once, exit with status 0 (1 when the set-up failed,
    //! with the reason on the console). The QEMU plugin counts every instruction of the run
    //! (start-up, command line, set-up included); the script runs each mode with `n` and `2n`
    //! repetitions, so that all but `n` repetitions cancel out.
    //!
    //! `whole` (a whole run, `n` ignored): [`run_whole`] once, then `ticks=<counted ticks>` on the
    //! console; the plugin, given the markers' addresses, counts each tick on its own.

    use core::fmt::Write as _;
    use core::mem::MaybeUninit;

    use cortex_m as _; // the critical-section implementation
    use drive_bench::{run_repetitions, run_whole, Scratch};
    use semihosting::sys::arm_compat::{sys_get_cmdline_uninit, sys_writec};

    /// The semihosting console.
    struct Console;

    impl core::fmt::Write for Console {
        fn write_str(&mut self, text: &str) -> core::fmt::Result {
            text.bytes().for_each(sys_writec);
            Ok(())
        }
    }

    fn fail(args: core::fmt::Arguments<'_>) -> ! {
        let _ = Console.write_fmt(args);
        let _ = Console.write_str("\n");
        semihosting::process::exit(1)
    }

    #[cortex_m_rt::entry]
    fn main() -> ! {
        let mut buffer = [MaybeUninit::<u8>::uninit(); 160];
        let line = sys_get_cmdline_uninit(&mut buffer).ok().and_then(|b| core::str::from_utf8(b).ok());
        let mut words = line.unwrap_or("").split_ascii_whitespace().skip(1);
        let (Some(name), Some(n), Some(mode)) = (words.next(), words.next(), words.next()) else {
            fail(format_args!("usage: drive-bench <name> <repetitions> base|measured"))
        };
        let Some(measurement) = drive_bench::measurement(name) else {
            fail(format_args!("unknown measurement {name}"))
        };
        let Ok(n) = n.parse::<u32>() else { fail(format_args!("bad repetition count {n}")) };
        let measured = match mode {
            "base" => false,
            "measured" | "whole" => true,
            _ => fail(format_args!("mode must be base, measured or whole, not {mode}")),
        };
        let prepared = match (measurement.prepare)() {
            Ok(prepared) => prepared,
            Err(error) => fail(format_args!("{name}: {error:?}")),
        };
        if mode == "whole" {
            match run_whole(prepared) {
                Some(Ok(ticks)) => {
                    let _ = writeln!(Console, "ticks={ticks}");
                    semihosting::process::exit(0)
                }
                Some(Err(error)) => fail(format_args!("{name}: {error:?}")),
                None => fail(format_args!("{name} is not a whole run")),
            }
        }
        let mut scratch = Scratch::new();
        run_repetitions(&prepared, &mut scratch, n, measured);
        semihosting::process::exit(0)
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        semihosting::process::exit(101)
    }
}
