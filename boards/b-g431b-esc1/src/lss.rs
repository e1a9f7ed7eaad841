//! The LSS configuration an LSS master stored ("store configuration", CiA 305 cs 0x17): the
//! node-ID and the bit timing the firmware starts with. It has a flash page of its own, the
//! one below the parameter area (build.rs keeps both from the linker): the parameter
//! journal and its 1010h/1011h commands do not touch it.
//!
//! The page is a log of 8-byte records, one flash write unit each, written in order from the
//! start; the last valid record before the first blank one is the configuration. A store
//! that changes nothing writes nothing; a store into a full page (after 256 of them) erases
//! the page and writes its record first.
//!
//! ```text
//! offset  size  field
//!      0     1  0x4C ('L'): a record of this layout
//!      1     1  node-ID: 1..=127, or 0xFF (start unconfigured, waiting for an LSS master)
//!      2     1  1: a bit timing follows; 0: none stored
//!      3     1  bit timing: table selector (0: the CiA 305 standard table)
//!      4     1  bit timing: table index
//!      5     1  0xFF
//!      6     2  CRC-16 of bytes 0..6 (CiA 301's SDO block CRC), little-endian
//! ```
//!
//! Power loss: a store cut while its record is programmed leaves a record that fails its
//! check, and the one before it stays the configuration; a store cut while it erases a full
//! page loses the configuration (the firmware then starts with its built-in node-ID and bit
//! rate).

use canopen_drive::wire::crc;
use canopen_drive::wire::lss::{BitTiming, NODE_ID_UNCONFIGURED};
use embassy_stm32::flash::{Blocking, Error, Flash, MAX_ERASE_SIZE, WRITE_SIZE};

use crate::layout::{self, THIS_PART};

/// The page: one erase unit (2 KiB on both parts).
const PAGE_LEN: u32 = layout::PAGE;
/// Where it starts (offset from the start of flash): right below the parameters.
pub const PAGE_START: u32 = THIS_PART.lss_page();
/// A record: one flash write unit.
const RECORD_LEN: usize = 8;
const SLOTS: u32 = PAGE_LEN / RECORD_LEN as u32;
const MAGIC: u8 = 0x4C;

const _: () = assert!(PAGE_LEN as usize == MAX_ERASE_SIZE && RECORD_LEN == WRITE_SIZE);

/// What an LSS master stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct LssConfig {
    /// 1..=127, or 0xFF: unconfigured.
    pub node_id: u8,
    /// The bit timing to start with; `None`: the firmware's default.
    pub bit_timing: Option<BitTiming>,
}

impl LssConfig {
    fn encode(&self) -> [u8; RECORD_LEN] {
        let (flag, selector, index) = match self.bit_timing {
            Some(t) => (1, t.table_selector, t.table_index),
            None => (0, 0, 0),
        };
        let head = [MAGIC, self.node_id, flag, selector, index, 0xFF];
        let [lo, hi] = crc::update(0, &head).to_le_bytes();
        [MAGIC, self.node_id, flag, selector, index, 0xFF, lo, hi]
    }

    fn decode(record: &[u8; RECORD_LEN]) -> Option<Self> {
        let [magic, node_id, flag, selector, index, reserved, lo, hi] = *record;
        let head = [magic, node_id, flag, selector, index, reserved];
        let valid_node_id = (1..=127).contains(&node_id) || node_id == NODE_ID_UNCONFIGURED;
        if magic != MAGIC || !valid_node_id || crc::update(0, &head) != u16::from_le_bytes([lo, hi]) {
            return None;
        }
        let bit_timing = match flag {
            0 => None,
            1 => Some(BitTiming { table_selector: selector, table_index: index }),
            _ => return None,
        };
        Some(LssConfig { node_id, bit_timing })
    }
}

/// The stored configuration and the first blank slot (`None`: the page is full).
fn scan(flash: &mut Flash<'_, Blocking>) -> Result<(Option<LssConfig>, Option<u32>), Error> {
    let mut newest = None;
    for slot in 0..SLOTS {
        let mut record = [0u8; RECORD_LEN];
        flash.blocking_read(PAGE_START + slot * RECORD_LEN as u32, &mut record)?;
        if record == [0xFF; RECORD_LEN] {
            return Ok((newest, Some(slot)));
        }
        if let Some(config) = LssConfig::decode(&record) {
            newest = Some(config);
        }
    }
    Ok((newest, None))
}

/// The configuration stored last, if any.
pub fn load(flash: &mut Flash<'_, Blocking>) -> Option<LssConfig> {
    scan(flash).ok().and_then(|(newest, _)| newest)
}

/// Stores `config` for the next start; returns once it is written and read back.
pub fn store(flash: &mut Flash<'_, Blocking>, config: &LssConfig) -> Result<(), Error> {
    let (newest, blank) = scan(flash)?;
    if newest.as_ref() == Some(config) {
        return Ok(());
    }
    let slot = match blank {
        Some(slot) => slot,
        None => {
            flash.blocking_erase(PAGE_START, PAGE_START + PAGE_LEN)?;
            0
        }
    };
    let at = PAGE_START + slot * RECORD_LEN as u32;
    let record = config.encode();
    flash.blocking_write(at, &record)?;
    let mut back = [0u8; RECORD_LEN];
    flash.blocking_read(at, &mut back)?;
    if back == record {
        Ok(())
    } else {
        Err(Error::Prog)
    }
}
