//! The first level of a look-up: a table's objects grouped by their index, computed at compile
//! time, so that finding an object of the table is one load of its group's bounds and a short
//! scan instead of a binary search over the table's descriptions.
//!
//! The index relative to the table's first one, shifted right by the table's `shift`, names a
//! group of `1 << shift` consecutive indices; [`FirstLevel::group`] gives the positions of the
//! group's objects in the table. `shift` is the smallest that makes the table's range fit
//! [`GROUPS`] groups: a table spanning fewer than 256 indices has a group per index (a direct
//! map), the drive profile (6000h–67FFh) groups of 8. A table of more than 255 objects has no
//! first level (its positions do not fit a byte): the dictionary binary-searches it.

use super::entry::Object;

/// Groups of one first level.
const GROUPS: usize = 256;

/// The first level of one table ([`first_level`]), with the table.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FirstLevel {
    /// The table.
    objects: &'static [Object],
    /// The table's first index.
    first: u16,
    /// Indices per group: `1 << shift`; [`NONE`] when the table has no first level.
    shift: u8,
    /// `starts[g]`: the position of the table's first object at or above group `g`'s first
    /// index; `starts[GROUPS]` the table's length.
    starts: [u8; GROUPS + 1],
}

/// [`FirstLevel::shift`] of a table without a first level.
const NONE: u8 = u8::MAX;

impl FirstLevel {
    /// The table the first level groups.
    #[inline]
    pub(crate) fn objects(&self) -> &'static [Object] {
        self.objects
    }

    /// The positions in its table of the objects of the group that would hold `key` (an index
    /// of the table's first copy), or `None` when no object of the table can have it.
    #[inline]
    pub(crate) fn group(&self, key: u16) -> Option<core::ops::Range<usize>> {
        let group = usize::from(key.checked_sub(self.first)? >> self.shift);
        let start = usize::from(*self.starts.get(group)?);
        let end = usize::from(*self.starts.get(group + 1)?);
        Some(start..end)
    }

    /// Whether the table has a first level.
    pub(crate) fn is_some(&self) -> bool {
        self.shift != NONE
    }
}

/// The first level of `objects` (a table ascending by index), at compile time; a table of more
/// than 255 objects gets none ([`FirstLevel::is_some`] false).
// Evaluated at compile time (the crate's tables): a `while` over the lengths (a const fn has no
// iterators), every index bounded by them.
#[allow(clippy::indexing_slicing)]
pub(crate) const fn first_level(objects: &'static [Object]) -> FirstLevel {
    let mut level = FirstLevel { objects, first: 0, shift: NONE, starts: [0; GROUPS + 1] };
    let len = objects.len();
    if len == 0 || len > u8::MAX as usize {
        return level;
    }
    let first = objects[0].index;
    let range = (objects[len - 1].index.wrapping_sub(first)) as usize;
    let mut shift = 0;
    while range >> shift >= GROUPS {
        shift += 1;
    }
    let mut group = 0;
    let mut position = 0;
    while group <= GROUPS {
        while position < len && ((objects[position].index.wrapping_sub(first) as usize) >> shift) < group {
            position += 1;
        }
        level.starts[group] = position as u8;
        group += 1;
    }
    level.first = first;
    level.shift = shift as u8;
    level
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{DataType, Var};

    const fn object(index: u16) -> Object {
        Object::var(index, "x", Var::new("x", DataType::Unsigned8))
    }

    #[test]
    fn a_group_holds_exactly_the_objects_of_its_indices() {
        static NARROW: [Object; 4] = [object(0x1000), object(0x1001), object(0x1005), object(0x10FF)];
        let level = first_level(&NARROW);
        assert!(level.is_some());
        assert_eq!(level.group(0x1000), Some(0..1));
        assert_eq!(level.group(0x1005), Some(2..3));
        assert_eq!(level.group(0x1004), Some(2..2));
        assert_eq!(level.group(0x10FF), Some(3..4));
        assert_eq!(level.group(0x0FFF), None);
        assert_eq!(level.group(0x1100), None);

        // 6007h–67FFh: groups of 8 indices from the first (6007h–600Eh, …, 603Fh–6046h, …).
        static WIDE: [Object; 5] =
            [object(0x6007), object(0x6040), object(0x6041), object(0x6048), object(0x67FF)];
        let level = first_level(&WIDE);
        assert_eq!(level.group(0x6041), Some(1..3));
        assert_eq!(level.group(0x6046), Some(1..3));
        assert_eq!(level.group(0x6047), Some(3..4));
        assert_eq!(level.group(0x6048), Some(3..4));
        assert_eq!(level.group(0x67FF), Some(4..5));
        assert_eq!(level.group(0x6807), None);
    }

    #[test]
    fn a_table_of_more_than_255_objects_has_none() {
        static MANY: [Object; 256] = {
            let mut many = [object(0); 256];
            let mut i = 0;
            while i < 256 {
                many[i].index = 0x2000 + i as u16;
                i += 1;
            }
            many
        };
        assert!(!first_level(&MANY).is_some());
        assert!(!first_level(&[]).is_some());
    }
}
