//! The robustness report: every scenario runs (a failing one does not stop the others), its
//! outcome and notes are printed (`--nocapture`), and once the three sections (fault injection,
//! soak, hostile configuration) have run in one test process, the report is written to
//! `target/generated-docs/robustness.md` (`$GENERATED_DOCS`), of which `docs/robustness.md` is
//! the committed copy (`scripts/test.sh` fails when they differ; `--bless` updates the copy).
//! The file holds only results on the virtual clock, so it changes only when a result changes.

use std::fmt::Write as _;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Mutex;

/// The sections of the report, in their order in the file.
pub const SECTIONS: [&str; 3] = [
    "2. Fault injection on the virtual bus",
    "3. Simulated-time soak and time wraps",
    "4. Hostile configuration",
];

/// Hours of drive time the soak simulates: `SOAK_HOURS` (may be fractional), by default 0.25
/// (15 min: a quick run in a debug build that still crosses a u32 µs wrap). The report file is
/// written only by a run of at least [`FULL_SOAK_HOURS`].
pub fn soak_hours() -> f64 {
    std::env::var("SOAK_HOURS").ok().and_then(|h| h.parse().ok()).unwrap_or(0.25)
}

/// The soak length of the published report (issue 9: at least 24 h).
pub const FULL_SOAK_HOURS: f64 = 24.0;

/// Notes a scenario makes about what it saw (numbers, counts).
#[derive(Default)]
pub struct Notes(Vec<String>);

impl Notes {
    pub fn note(&mut self, line: impl Into<String>) {
        self.0.push(line.into());
    }
}

/// One scenario: a name, what it shows, and its body (asserting).
pub struct Scenario {
    pub name: &'static str,
    pub checks: &'static str,
    pub run: fn(&mut Notes),
}

struct Outcome {
    name: &'static str,
    checks: &'static str,
    passed: Result<(), String>,
    notes: Vec<String>,
}

static DONE: Mutex<Vec<(usize, Vec<Outcome>)>> = Mutex::new(Vec::new());

/// Runs the scenarios of section `section` (an index into [`SECTIONS`]), prints their outcomes,
/// records them for the report file, and panics if one failed.
pub fn run_section(section: usize, scenarios: &[Scenario]) {
    let title = SECTIONS.get(section).copied().unwrap_or("?");
    let mut outcomes = Vec::new();
    for scenario in scenarios {
        let mut notes = Notes::default();
        let started = std::time::Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| (scenario.run)(&mut notes)));
        let passed = result.map_err(|panic| {
            panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panicked".to_string())
        });
        let verdict = if passed.is_ok() { "PASS" } else { "FAIL" };
        println!("[{title}] {verdict} {} ({:.1?} wall)", scenario.name, started.elapsed());
        for line in &notes.0 {
            println!("    {line}");
        }
        if let Err(why) = &passed {
            println!("    failure: {why}");
        }
        outcomes.push(Outcome { name: scenario.name, checks: scenario.checks, passed, notes: notes.0 });
    }
    let failed: Vec<&str> = outcomes.iter().filter(|o| o.passed.is_err()).map(|o| o.name).collect();
    let complete = {
        let mut done = DONE.lock().unwrap_or_else(|e| e.into_inner());
        done.retain(|(s, _)| *s != section);
        done.push((section, outcomes));
        if done.len() == SECTIONS.len() {
            done.sort_by_key(|(s, _)| *s);
            Some(render(&done))
        } else {
            None
        }
    };
    if soak_hours() < FULL_SOAK_HOURS {
        if complete.is_some() {
            println!(
                "report not written: a {} h soak (SOAK_HOURS=24 writes target/generated-docs/robustness.md)",
                soak_hours()
            );
        }
    } else if let Some(text) = complete {
        // Into target/ (or $GENERATED_DOCS): a test run modifies no tracked file. scripts/test.sh
        // compares it with the committed docs/robustness.md (`--bless` copies it there).
        let docs = std::env::var_os("GENERATED_DOCS").map(std::path::PathBuf::from).unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("target").join("generated-docs")
        });
        let path = docs.join("robustness.md");
        match std::fs::create_dir_all(&docs).and_then(|()| std::fs::write(&path, text)) {
            Ok(()) => println!("report written to {}", path.display()),
            Err(e) => println!("report not written ({e})"),
        }
    }
    assert!(failed.is_empty(), "failed scenarios: {failed:?}");
}

fn render(sections: &[(usize, Vec<Outcome>)]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Robustness report\n\n\
         Written by the scenarios of `tests/tests/robustness/`:\n\n\
         ```sh\n\
         SOAK_HOURS=24 CARGO_PROFILE_DEV_OPT_LEVEL=2 cargo test -p canopen-drive-tests --test robustness -- --nocapture\n\
         ```\n\n\
         (optimised, with debug assertions and overflow checks on; a run with a shorter soak prints\n\
         the report without writing it). The run writes `target/generated-docs/robustness.md`;\n\
         this file is its committed copy, which `scripts/test.sh` checks (`--bless` updates it). Every number below is on the virtual clock of the\n\
         simulated bus, so the file is the same on every run until a result changes. The invariants\n\
         each step is checked against are in `crates/canopen-drive-sim/src/invariants.rs`; fuzzing\n\
         (item 1) is `scripts/fuzz.sh` with the targets in `fuzz/`.\n"
    );
    let _ = writeln!(out, "{FINDINGS}");
    let _ = writeln!(out, "{FUZZING}");
    for (section, outcomes) in sections {
        let title = SECTIONS.get(*section).copied().unwrap_or("?");
        let passed = outcomes.iter().filter(|o| o.passed.is_ok()).count();
        let _ = writeln!(out, "## {title}\n\n{passed} of {} scenarios pass.\n", outcomes.len());
        let _ = writeln!(out, "| scenario | checks | outcome |\n|---|---|---|");
        for o in outcomes {
            let verdict = match &o.passed {
                Ok(()) => "pass".to_string(),
                Err(why) => format!("**FAIL**: {}", why.replace('|', "\\|").replace('\n', " ")),
            };
            let _ = writeln!(out, "| {} | {} | {verdict} |", o.name, o.checks.replace('|', "\\|"));
        }
        let _ = writeln!(out);
        for o in outcomes.iter().filter(|o| !o.notes.is_empty()) {
            let _ = writeln!(out, "**{}**\n", o.name);
            for line in &o.notes {
                let _ = writeln!(out, "- {line}");
            }
            let _ = writeln!(out);
        }
    }
    out
}

/// Section 1, fuzzing: its throughput and campaigns are measured by hand, not by these
/// scenarios, and kept in a file of their own.
const FUZZING: &str = include_str!("fuzzing.md");

/// The bugs the fuzzers and these scenarios found, each with its regression test.
const FINDINGS: &str = "## Bugs found and fixed

| bug | found by | fix | regression test |
|---|---|---|---|
| An RPDO could store a value the SDO server refuses (an unsupported or reserved 6060h mode, a homing method the drive lacks, a reserved option code, …): RPDO values were checked against type and limits only (invariant 3). | fuzz target `drive_frames`, within seconds | `comm/pdo.rs`: `apply` takes the drive's value rules (`ValueRules`); `drive.rs` passes the SDO rules (`rpdo_rules` → `check_communication`), except the ip data record, whose overflow the buffer reports | `regression_rpdo_cannot_store_what_sdo_refuses`, scenario *RPDO value rules* |
| Profile torque: a max torque/current (6072h/6073h) lowered below the running torque was followed only at the torque slope (6087h), so the demand exceeded the limit for up to a second (invariant 2). | the seed corpus of the fuzzers (the invariant checker) | `cia402/profile.rs`: the ramped torque is clamped to the limit every tick (also while cst halts) | `regression_tq_lowered_torque_limit_holds_at_once` |
| csp/csv/cst: the torque offset 60B2h went to the power stage as feed-forward unclamped (up to ±32 767 ‰), and csp's velocity feed-forward (trajectory + 60B1h) beyond 607Fh/6080h (invariant 2). | the invariant checker's feed-forward rule | `cia402/profile.rs`: feed-forward clamped to the limits of the demand | `regression_cyclic_feed_forward_within_the_limits` |
| Cyclic modes: after a missed cycle the next missing SYNC was counted one tick late (every period + 1 ticks), so three lost SYNCs in a row counted as two (at 4 ticks per period) or one (at 1): the 6007h reaction came late or never. | scenario *SYNC loss in csp* | `cia402/cyclic.rs`: after a missed cycle the wait restarts at tolerance + 1 | unit test `consecutive_missing_syncs_are_counted_one_per_period`, scenario *SYNC loss in csp* |
";
