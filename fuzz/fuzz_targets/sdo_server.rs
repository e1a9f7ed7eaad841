//! (b) The SDO server alone, against a model dictionary (`canopen_drive_fuzz::sdo_model`), with
//! arbitrary client frames (structured: a client command specifier and a known multiplexer; or
//! raw, of any length) and arbitrary time steps.
//!
//! Ops (tag byte % 4): 0 structured request (command index, mux index, 4 bytes), 1 raw request
//! (length byte, bytes), 2 time passes (u16 ms) then poll, 3 poll now.
//!
//! Invariants after every step:
//! - a request gets at most one response (by type), and `poll` sends only block-upload
//!   segments (at most one sub-block of at most 127 segments between two client frames) or one
//!   timeout abort, and the timeout abort only once the deadline has passed;
//! - a value reaches the dictionary only together with a success response, never with an
//!   abort, and at most once per request;
//! - the server never reads beyond a value, never writes more than its buffer;
//! - after an abort (sent or received) and after a timeout, the server is idle; a server has a
//!   deadline exactly while a transfer is in progress.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| canopen_drive_fuzz::targets::sdo_server(data));
