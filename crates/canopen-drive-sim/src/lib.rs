//! Simulation support (filled in below).
