//! CRC-16 of SDO block transfers (CiA 301 §7.2.4.3.16): polynomial 0x1021,
//! initial value 0, no reflection, no final XOR ("CRC-16/XMODEM").

/// Nibble table: 16 entries keep flash use small on the MCU.
// Indices are bounded by the loop; `get_mut` is not usable in a const initialiser.
#[allow(clippy::indexing_slicing)]
const TABLE: [u16; 16] = {
    let mut table = [0u16; 16];
    let mut n = 0;
    while n < 16 {
        let mut crc = (n as u16) << 12;
        let mut bit = 0;
        while bit < 4 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
            bit += 1;
        }
        table[n] = crc;
        n += 1;
    }
    table
};

/// Continues a CRC over `data` (start with 0).
pub fn update(crc: u16, data: &[u8]) -> u16 {
    // In 32 bits (the CRC in the low half; a u16 is re-narrowed after every shift on a
    // Cortex-M), two nibble steps per byte written out.
    let crc = data.iter().fold(u32::from(crc), |crc, &byte| {
        let crc = step(crc, u32::from(byte >> 4));
        step(crc, u32::from(byte))
    });
    crc as u16
}

/// One nibble of the CRC: the low four bits of `nibble` against the CRC's top four.
#[inline(always)]
fn step(crc: u32, nibble: u32) -> u32 {
    // The index has four bits: the table look-up needs no bounds check.
    let index = ((crc >> 12) ^ nibble) & 0x0F;
    ((crc << 4) & 0xFFFF) ^ u32::from(TABLE.get(index as usize).copied().unwrap_or(0))
}

#[cfg(test)]
mod tests {
    #[test]
    fn check_value() {
        assert_eq!(super::update(0, b"123456789"), 0x31C3);
        assert_eq!(super::update(super::update(0, b"1234"), b"56789"), 0x31C3);
        assert_eq!(super::update(0, b""), 0);
        // Every byte value and starting CRC against the bitwise definition.
        for start in [0u16, 0x1D0F, 0xFFFF, 0x8000] {
            for byte in 0..=255u8 {
                let mut crc = start;
                for bit in (0..8).rev() {
                    let top = (crc >> 15) as u8 ^ (byte >> bit & 1);
                    crc = if top != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
                }
                assert_eq!(super::update(start, &[byte]), crc, "start {start:#x}, byte {byte:#x}");
            }
        }
    }
}
