//! Helpers of the crate's unit tests.

/// xorshift64*: a seeded generator for the tests' sweeps (each test module adds the draws it
/// needs in an `impl` of its own).
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}
