//! The import graph of the core points down the layers of the architecture
//! (`docs/architecture.md`, "Layers of the core", and the crate docs in `src/lib.rs`): a module
//! may name the modules of its own layer and the layers below, never one above. A path `crate::<module>` in code (not in comments or docs,
//! not in the unit-test modules at the bottom of a file) counts as an import; so do the items
//! re-exported at the crate root (`crate::Drive` is `drive`).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

use std::fs;
use std::path::{Path, PathBuf};

/// The layers, lowest first. `wide` (128-bit division), `fmt` (the logging shim) and `testing`
/// (helpers of the unit tests) are utilities below everything; `can_io` (the embedded-can helper) and `prelude` (re-exports) sit
/// on top of `drive`.
const LAYERS: &[&[&str]] = &[
    &["time", "frame", "wide", "fmt", "testing"],
    &["wire", "motion"],
    &["hal"],
    &["od"],
    &["storage", "control"],
    &["comm"],
    &["cia402"],
    &["drive", "bootloader"],
    &["can_io", "prelude", "lib"],
];

/// Items re-exported at the crate root, and the module they come from.
const ROOT_ITEMS: &[(&str, &str)] = &[
    ("Config", "drive"),
    ("Drive", "drive"),
    ("CanFrame", "frame"),
    ("AbortCode", "wire"),
    ("Duration", "time"),
    ("Instant", "time"),
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

fn source_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            source_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a file belongs to: the first component below `src/` (`od/persist.rs` is `od`).
fn module_of(src: &Path, file: &Path) -> String {
    let relative = file.strip_prefix(src).unwrap();
    let first = relative.components().next().unwrap().as_os_str().to_string_lossy().to_string();
    first.trim_end_matches(".rs").to_string()
}

/// The modules `line` names through `crate::`.
fn references(line: &str) -> Vec<String> {
    names_after(line, "crate::")
        .into_iter()
        .map(|ident| ROOT_ITEMS.iter().find(|(item, _)| *item == ident).map_or(ident, |(_, m)| m.to_string()))
        .collect()
}

/// The first identifier of every path in `line` that starts with `prefix` (each name of a
/// group: `prefix{a, b::c}` gives `a` and `b`).
fn names_after(line: &str, prefix: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find(prefix) {
        rest = &rest[at + prefix.len()..];
        let names: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            group[..end].split(',').map(str::trim).collect()
        } else {
            vec![rest]
        };
        for name in names {
            let ident: String = name.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if !ident.is_empty() {
                found.push(ident);
            }
        }
    }
    found
}

/// The lines of code of a source file before its unit tests (`#[cfg(test)]` closes the file),
/// comment lines left out: (line number from 1, the line without its indentation).
fn code_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .map(str::trim_start)
        .enumerate()
        .take_while(|(_, code)| !code.starts_with("#[cfg(test)]"))
        .filter(|(_, code)| !code.starts_with("//"))
        .map(|(n, code)| (n + 1, code))
}

#[test]
fn imports_point_down_the_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    source_files(&src, &mut files);
    let mut upward = Vec::new();
    let mut unknown = Vec::new();
    for file in &files {
        let name = file.file_name().unwrap().to_string_lossy();
        if name == "tests.rs" || name.ends_with("_tests.rs") {
            continue; // unit tests of the module, as the `mod tests` below
        }
        let module = module_of(&src, file);
        let Some(own) = layer_of(&module) else {
            unknown.push(format!("{}: module `{module}` is in no layer", file.display()));
            continue;
        };
        let text = fs::read_to_string(file).unwrap();
        for (n, code) in code_lines(&text) {
            for target in references(code) {
                match layer_of(&target) {
                    Some(layer) if layer > own => upward.push(format!(
                        "{}:{}: `{module}` (layer {own}) names `{target}` (layer {layer}): {}",
                        file.strip_prefix(&src).unwrap().display(),
                        n,
                        code
                    )),
                    Some(_) => {}
                    None => unknown.push(format!("{}:{n}: unknown module `{target}`", file.display())),
                }
            }
        }
    }
    assert!(unknown.is_empty(), "{}", unknown.join("\n"));
    assert!(upward.is_empty(), "imports that point up the layers:\n{}", upward.join("\n"));
}

#[test]
fn the_check_sees_an_upward_import() {
    // The parser the check relies on: direct paths, groups, root items.
    assert_eq!(references("use crate::cia402::hm::HomingConfig;"), ["cia402"]);
    assert_eq!(references("use crate::{Config, Drive, od};"), ["drive", "drive", "od"]);
    assert_eq!(references("let x = crate::comm::pdo::preset(1, 2);"), ["comm"]);
    assert!(layer_of("od").unwrap() < layer_of("cia402").unwrap());
}

/// The composer (`drive.rs`) routes frames, runs timers and calls the services: it holds no
/// object index (a literal from 1000h on, or an index constant of `od::standard` or of a
/// service) and so no rule of an object. Each service registers its own objects (`src/drive.rs`,
/// "Who owns an object").
#[test]
fn the_composer_holds_no_object_index() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join("drive.rs");
    let text = fs::read_to_string(&file).unwrap();
    let mut found = Vec::new();
    for (n, code) in code_lines(&text) {
        if let Some(hit) = object_index(code) {
            found.push(format!("drive.rs:{n}: {hit}: {code}"));
        }
    }
    assert!(found.is_empty(), "object indices in the composer:\n{}", found.join("\n"));
    // The check sees both forms.
    assert_eq!(object_index("match mux.index { 0x6060 => {} }"), Some("0x6060".to_string()));
    assert_eq!(
        object_index("let x = od.get::<u8>(PRE_DEFINED_ERROR_FIELD, 0);"),
        Some("PRE_DEFINED_ERROR_FIELD".to_string())
    );
    assert_eq!(object_index("let id = 0x80;"), None);
}

/// A hexadecimal literal of an object index (1000h and above), or an index constant of the
/// crate's tables, in a line of code.
fn object_index(code: &str) -> Option<String> {
    let code = code.split("//").next().unwrap_or("");
    for (at, _) in code.match_indices("0x") {
        let digits: String =
            code[at + 2..].chars().take_while(|c| c.is_ascii_hexdigit() || *c == '_').collect();
        let value = u32::from_str_radix(&digits.replace('_', ""), 16).unwrap_or(0);
        if value >= 0x1000 && digits.replace('_', "").len() == 4 {
            return Some(format!("0x{digits}"));
        }
    }
    const INDEX_CONSTANTS: &[&str] = &[
        "COB_ID_SYNC",
        "COB_ID_EMCY",
        "COMMUNICATION_CYCLE_PERIOD",
        "SYNCHRONOUS_COUNTER_OVERFLOW",
        "SYNCHRONOUS_WINDOW_LENGTH",
        "PRE_DEFINED_ERROR_FIELD",
        "ERROR_REGISTER",
        "ERROR_BEHAVIOUR",
        "GUARD_TIME",
        "LIFE_TIME_FACTOR",
        "INHIBIT_TIME_EMCY",
        "CONSUMER_HEARTBEAT_TIME",
        "PRODUCER_HEARTBEAT_TIME",
        "STORE_PARAMETERS",
        "RESTORE_DEFAULT_PARAMETERS",
        "IDENTITY",
        "MODES_OF_OPERATION",
        "SUPPORTED_DRIVE_MODES",
        "TARGET_POSITION",
        "TARGET_VELOCITY",
        "TARGET_TORQUE",
        "INTERPOLATION_DATA_RECORD",
    ];
    INDEX_CONSTANTS
        .iter()
        .find(|name| {
            code.match_indices(*name).any(|(at, _)| {
                let before = code[..at].chars().next_back();
                let after = code[at + name.len()..].chars().next();
                let word = |c: Option<char>| c.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_');
                !word(before) && !word(after)
            })
        })
        .map(|name| name.to_string())
}

/// The modules of `cia402/` a line of its code names: `super::<module>` and
/// `crate::cia402::<module>`, and the items `cia402/mod.rs` re-exports (`super::Axis` is
/// `objects`).
fn profile_references(line: &str, modules: &[String], reexports: &[(String, String)]) -> Vec<String> {
    ["super::", "crate::cia402::"]
        .iter()
        .flat_map(|prefix| names_after(line, prefix))
        .filter_map(|ident| {
            if modules.contains(&ident) {
                Some(ident)
            } else {
                reexports.iter().find(|(item, _)| *item == ident).map(|(_, module)| module.clone())
            }
        })
        .collect()
}

/// The source files of `cia402/` but its unit tests' own files, with their directory.
fn profile_files() -> (PathBuf, Vec<PathBuf>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join("cia402");
    let mut files = Vec::new();
    source_files(&dir, &mut files);
    files.retain(|file| {
        let name = file.file_name().unwrap().to_string_lossy();
        !(name == "tests.rs" || name.ends_with("_tests.rs"))
    });
    (dir, files)
}

/// A mode is one file: the modules of `cia402/` import one another without a cycle. The leaf
/// (`objects`: indices, `Rule`, constructors) imports none of them; the registry above the
/// modes (`registry`) and the run-time of an axis (`profile`) import the modes, never the other
/// way round.
#[test]
fn the_profile_modules_import_no_cycle() {
    let (dir, files) = profile_files();
    let module = |file: &Path| module_of(&dir, file);
    let modules: Vec<String> = files.iter().map(|f| module(f)).filter(|m| m != "mod").collect();
    // What mod.rs re-exports: `pub use <module>::{A, B};` or `pub use <module>::A;`.
    let parent = fs::read_to_string(dir.join("mod.rs")).unwrap();
    let mut reexports = Vec::new();
    for statement in parent.split(';') {
        let Some(path) = statement.trim().strip_prefix("pub use ") else { continue };
        let Some((from, items)) = path.split_once("::") else { continue };
        let items = items.trim_start_matches('{').trim_end_matches('}');
        for item in items.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            reexports.push((item.to_string(), from.trim().to_string()));
        }
    }
    let mut edges: Vec<(String, String, String)> = Vec::new();
    for file in &files {
        let from = module(file);
        let name = file.file_name().unwrap().to_string_lossy();
        if from == "mod" {
            continue;
        }
        let text = fs::read_to_string(file).unwrap();
        for (n, code) in code_lines(&text) {
            let code = code.split("//").next().unwrap_or("");
            for to in profile_references(code, &modules, &reexports) {
                if to != from && !edges.iter().any(|(a, b, _)| *a == from && *b == to) {
                    edges.push((from.clone(), to, format!("{name}:{n}")));
                }
            }
        }
    }
    // Depth-first search for a cycle; report the first one with where each import is.
    fn visit(
        node: &str,
        edges: &[(String, String, String)],
        path: &mut Vec<(String, String)>,
        done: &mut Vec<String>,
    ) -> Option<Vec<(String, String)>> {
        if let Some(at) = path.iter().position(|(m, _)| m == node) {
            return Some(path[at..].to_vec());
        }
        if done.iter().any(|d| d == node) {
            return None;
        }
        for (from, to, at) in edges.iter().filter(|(from, _, _)| from == node) {
            path.push((from.clone(), format!("{at} names `{to}`")));
            if let Some(cycle) = visit(to, edges, path, done) {
                return Some(cycle);
            }
            path.pop();
        }
        done.push(node.to_string());
        None
    }
    let mut done = Vec::new();
    for start in &modules {
        let mut path = Vec::new();
        if let Some(cycle) = visit(start, &edges, &mut path, &mut done) {
            let shown: Vec<String> = cycle.iter().map(|(m, how)| format!("{m} ({how})")).collect();
            panic!("an import cycle in cia402/: {}", shown.join(" -> "));
        }
    }
    // The leaf names no other module of the profile.
    let leaf: Vec<_> = edges.iter().filter(|(from, _, _)| from == "objects").collect();
    assert!(leaf.is_empty(), "objects.rs imports {leaf:?}");
    // The parser sees the forms the modules use.
    let modules = ["objects".to_string(), "hm".to_string()];
    let reexports = [("Axis".to_string(), "objects".to_string())];
    assert_eq!(profile_references("use super::objects::Rule;", &modules, &reexports), ["objects"]);
    assert_eq!(profile_references("use super::{hm, Axis};", &modules, &reexports), ["hm", "objects"]);
    assert_eq!(profile_references("x(crate::cia402::hm::rule(i))", &modules, &reexports), ["hm"]);
}

/// The functions of `text` before its unit tests: (name, first line, lines), a function running
/// from its `fn` line to the closing brace at the same indentation.
fn function_lengths(text: &str) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let end = lines.iter().position(|l| l.trim_start().starts_with("#[cfg(test)]")).unwrap_or(lines.len());
    let mut found = Vec::new();
    for (at, line) in lines[..end].iter().enumerate() {
        let code = line.trim_start();
        let indent = &line[..line.len() - code.len()];
        let signature = ["pub(crate) ", "pub(super) ", "pub ", ""]
            .iter()
            .find_map(|vis| code.strip_prefix(vis))
            .map(|rest| rest.strip_prefix("const ").unwrap_or(rest));
        let Some(name) = signature.and_then(|rest| rest.strip_prefix("fn ")) else { continue };
        let name: String = name.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let close = format!("{indent}}}");
        if let Some(last) = lines[at..end].iter().position(|l| *l == close) {
            found.push((name, at + 1, last + 1));
        }
    }
    found
}

/// A function of the profile reads in one screen: none in `cia402/` longer than 120 lines, and
/// the tick (`Profile::tick`, its phases in functions of their own) under 80.
#[test]
fn the_profile_functions_are_short() {
    let (_, files) = profile_files();
    let mut long = Vec::new();
    let mut tick = None;
    for file in &files {
        let name = file.file_name().unwrap().to_string_lossy().to_string();
        for (function, line, lines) in function_lengths(&fs::read_to_string(file).unwrap()) {
            if lines > 120 {
                long.push(format!("{name}:{line}: `{function}` has {lines} lines"));
            }
            if name == "profile.rs" && function == "tick" {
                tick = Some(lines);
            }
        }
    }
    assert!(long.is_empty(), "functions over 120 lines in cia402/:\n{}", long.join("\n"));
    let tick = tick.expect("Profile::tick in cia402/profile.rs");
    assert!(tick < 80, "Profile::tick has {tick} lines");
    // The parser measures from the signature to the brace that closes it.
    let text = "impl A {\n    pub fn f(&self) {\n        if x {\n        }\n    }\n    const fn g() {}\n}\n";
    assert_eq!(function_lengths(text), [("f".to_string(), 2, 4)]);
}
