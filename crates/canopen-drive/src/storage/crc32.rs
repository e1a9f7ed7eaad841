//! CRC-32 of the storage images: the ISO-HDLC / Ethernet / zlib CRC (reflected polynomial
//! 0xEDB8_8320, initial value and final XOR 0xFFFF_FFFF). Check value of "123456789":
//! 0xCBF4_3926.

const POLYNOMIAL: u32 = 0xEDB8_8320;

/// Nibble table: 16 entries keep flash use small on the MCU.
// Indices are bounded by the loop; `get_mut` is not usable in a const initialiser.
#[allow(clippy::indexing_slicing)]
const TABLE: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut n = 0;
    while n < 16 {
        let mut crc = n as u32;
        let mut bit = 0;
        while bit < 4 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ POLYNOMIAL } else { crc >> 1 };
            bit += 1;
        }
        table[n] = crc;
        n += 1;
    }
    table
};

/// A CRC-32 computed over data that arrives in pieces.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Crc32(u32);

impl Crc32 {
    /// Nothing seen yet.
    pub(crate) const fn new() -> Self {
        Crc32(0xFFFF_FFFF)
    }

    /// Continues over `data`.
    pub(crate) fn update(&mut self, data: &[u8]) {
        let mut crc = self.0;
        for &byte in data {
            crc ^= u32::from(byte);
            for _ in 0..2 {
                crc = (crc >> 4) ^ TABLE.get((crc & 0x0F) as usize).copied().unwrap_or(0);
            }
        }
        self.0 = crc;
    }

    /// The CRC of everything seen.
    pub(crate) const fn value(&self) -> u32 {
        !self.0
    }
}

/// The CRC-32 of `data`.
pub(crate) fn crc32(data: &[u8]) -> u32 {
    let mut crc = Crc32::new();
    crc.update(data);
    crc.value()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        let mut crc = Crc32::new();
        crc.update(b"1234");
        crc.update(b"56789");
        assert_eq!(crc.value(), 0xCBF4_3926);
    }
}
