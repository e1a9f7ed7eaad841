//! Programs showing how firmware links canopen-drive; run them with
//! `cargo run -p canopen-drive-examples --example <name>`.
