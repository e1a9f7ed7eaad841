//! CiA 402 drive profile (CiA 402-2).
//!
//! So far this holds the process-data objects that the CiA 402 default PDO mapping refers to;
//! the state machine and the operation modes build on them.

pub mod fsa;
pub mod objects;
