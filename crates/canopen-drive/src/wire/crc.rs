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
pub fn update(mut crc: u16, data: &[u8]) -> u16 {
    for &byte in data {
        for nibble in [byte >> 4, byte & 0x0F] {
            let index = usize::from(((crc >> 12) as u8) ^ nibble);
            crc = (crc << 4) ^ TABLE.get(index).copied().unwrap_or(0);
        }
    }
    crc
}

#[cfg(test)]
mod tests {
    #[test]
    fn check_value() {
        assert_eq!(super::update(0, b"123456789"), 0x31C3);
        assert_eq!(super::update(super::update(0, b"1234"), b"56789"), 0x31C3);
        assert_eq!(super::update(0, b""), 0);
    }
}
