//! The LSS configuration of this board ("store configuration", cs 0x17): a small text file
//! next to the parameter storage, `PATH.lss`, replaced atomically (write, sync, rename).
//!
//! ```text
//! node-id=7
//! bit-timing=0,2
//! ```

use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};

use canopen_drive::wire::lss::BitTiming;

/// `PATH.lss` for the storage file `PATH`.
pub fn path_for(storage: &Path) -> PathBuf {
    let mut name = OsString::from(storage.as_os_str());
    name.push(".lss");
    PathBuf::from(name)
}

/// The stored node-ID, if the file exists and holds a valid one (1..=127).
pub fn load(path: &Path) -> Option<u8> {
    let text = std::fs::read_to_string(path).ok()?;
    text.lines()
        .find_map(|line| line.strip_prefix("node-id="))
        .and_then(|v| v.trim().parse::<u8>().ok())
        .filter(|id| (1..=127).contains(id))
}

/// The stored bit rate in kbit/s (CiA 305 table 0), if the file holds one.
pub fn load_bit_rate(path: &Path) -> Option<u16> {
    let text = std::fs::read_to_string(path).ok()?;
    let timing = text.lines().find_map(|line| line.strip_prefix("bit-timing="))?;
    let (table, index) = timing.trim().split_once(',')?;
    if table.trim() != "0" {
        return None;
    }
    crate::profiles::bit_rate_of(index.trim().parse().ok()?)
}

/// Replaces the file with `node_id` and `bit_timing`.
pub fn save(path: &Path, node_id: u8, bit_timing: Option<BitTiming>) -> std::io::Result<()> {
    let mut text = format!("node-id={node_id}\n");
    if let Some(t) = bit_timing {
        text.push_str(&format!("bit-timing={},{}\n", t.table_selector, t.table_index));
    }
    let mut temporary = OsString::from(path.as_os_str());
    temporary.push(".new");
    let temporary = PathBuf::from(temporary);
    let mut file = std::fs::File::create(&temporary)?;
    file.write_all(text.as_bytes())?;
    file.sync_all()?;
    std::fs::rename(&temporary, path)
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_invalid_contents() {
        let dir = std::env::temp_dir().join(format!("lss-store-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = path_for(&dir.join("params.bin"));
        assert!(path.to_string_lossy().ends_with("params.bin.lss"));
        assert_eq!(load(&path), None);
        save(&path, 42, Some(BitTiming { table_selector: 0, table_index: 2 })).unwrap();
        assert_eq!(load(&path), Some(42));
        assert!(std::fs::read_to_string(&path).unwrap().contains("bit-timing=0,2"));
        assert_eq!(load_bit_rate(&path), Some(500));
        save(&path, 255, None).unwrap();
        assert_eq!(load(&path), None, "255 = not configured");
        assert_eq!(load_bit_rate(&path), None);
        std::fs::write(&path, "garbage").unwrap();
        assert_eq!(load(&path), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
