//! The bank header: its byte layout (see the [module docs](super)) and its checks.

use super::crc32::crc32;

/// Bytes of the header; the payload starts at the next multiple of the write size.
pub(crate) const HEADER_LEN: usize = 32;
/// First four bytes of every header.
pub(crate) const MAGIC: [u8; 4] = *b"COPJ";
/// The format this code writes and reads: header layout, record layout, CRC.
pub(crate) const FORMAT_VERSION: u16 = 1;
/// Bytes the header CRC covers (everything before it).
const CHECKED_LEN: usize = 28;

/// A header with a valid magic and header CRC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Header {
    pub(crate) version: u16,
    pub(crate) signature: u32,
    pub(crate) sequence: u32,
    pub(crate) len: u32,
    pub(crate) crc: u32,
}

/// What the first [`HEADER_LEN`] bytes of a bank hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Decoded {
    /// All 0xFF: erased, never written since.
    Blank,
    /// Neither blank nor a header: a wrong magic or a wrong header CRC.
    Garbled,
    /// A complete header (its payload still to be checked).
    Header(Header),
}

impl Header {
    /// The header as stored.
    pub(crate) fn encode(&self) -> [u8; HEADER_LEN] {
        let mut raw = [0u8; HEADER_LEN];
        let fields: [(usize, &[u8]); 7] = [
            (0, &MAGIC),
            (4, &self.version.to_le_bytes()),
            (6, &[0, 0]),
            (8, &self.signature.to_le_bytes()),
            (12, &self.sequence.to_le_bytes()),
            (16, &self.len.to_le_bytes()),
            (20, &self.crc.to_le_bytes()),
        ];
        for (at, bytes) in fields {
            if let Some(dst) = raw.get_mut(at..at + bytes.len()) {
                dst.copy_from_slice(bytes);
            }
        }
        // Bytes 24..28 are reserved (0).
        let crc = crc32(raw.get(..CHECKED_LEN).unwrap_or(&[]));
        if let Some(dst) = raw.get_mut(CHECKED_LEN..) {
            dst.copy_from_slice(&crc.to_le_bytes());
        }
        raw
    }

    /// Reads the first bytes of a bank.
    pub(crate) fn decode(raw: &[u8; HEADER_LEN]) -> Decoded {
        if raw.iter().all(|b| *b == 0xFF) {
            return Decoded::Blank;
        }
        let u32_at = |at: usize| {
            let mut b = [0u8; 4];
            if let Some(src) = raw.get(at..at + 4) {
                b.copy_from_slice(src);
            }
            u32::from_le_bytes(b)
        };
        let checked = raw.get(..CHECKED_LEN).unwrap_or(&[]);
        if raw.get(..4) != Some(&MAGIC[..]) || crc32(checked) != u32_at(CHECKED_LEN) {
            return Decoded::Garbled;
        }
        Decoded::Header(Header {
            version: (u32_at(4) & 0xFFFF) as u16,
            signature: u32_at(8),
            sequence: u32_at(12),
            len: u32_at(16),
            crc: u32_at(20),
        })
    }
}

/// True when sequence number `a` was written after `b`: serial-number arithmetic (RFC 1982
/// style), so that the count may wrap from 0xFFFF_FFFF to 0.
pub(crate) fn is_newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: Header =
        Header { version: FORMAT_VERSION, signature: 0xCAFE_0042, sequence: 7, len: 100, crc: 0x1234_5678 };

    #[test]
    fn layout() {
        let raw = HEADER.encode();
        assert_eq!(&raw[..4], b"COPJ");
        assert_eq!(raw[4..8], [1, 0, 0, 0]);
        assert_eq!(raw[8..12], 0xCAFE_0042u32.to_le_bytes());
        assert_eq!(raw[12..16], 7u32.to_le_bytes());
        assert_eq!(raw[16..20], 100u32.to_le_bytes());
        assert_eq!(raw[20..24], 0x1234_5678u32.to_le_bytes());
        assert_eq!(raw[24..28], [0; 4]);
        assert_eq!(raw[28..32], crc32(&raw[..28]).to_le_bytes());
        assert_eq!(Header::decode(&raw), Decoded::Header(HEADER));
        assert_eq!(Header::decode(&[0xFF; HEADER_LEN]), Decoded::Blank);
        assert_eq!(Header::decode(&[0; HEADER_LEN]), Decoded::Garbled);
    }

    #[test]
    fn every_flipped_bit_is_caught() {
        let raw = HEADER.encode();
        for byte in 0..HEADER_LEN {
            for bit in 0..8 {
                let mut bad = raw;
                bad[byte] ^= 1 << bit;
                assert_eq!(Header::decode(&bad), Decoded::Garbled, "byte {byte} bit {bit}");
            }
        }
    }

    #[test]
    fn sequence_order_wraps() {
        assert!(is_newer(2, 1));
        assert!(!is_newer(1, 2));
        assert!(!is_newer(5, 5));
        assert!(is_newer(0, u32::MAX));
        assert!(is_newer(3, 0xFFFF_FFF0));
        assert!(!is_newer(u32::MAX, 0));
    }
}
