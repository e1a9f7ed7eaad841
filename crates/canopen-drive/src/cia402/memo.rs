//! Results of configuration values kept between ticks.
//!
//! The modes convert their objects (through the factor group, into per-tick units) with 64-bit
//! divisions, library calls of about a hundred instructions each on a Cortex-M, while the
//! values change only when a master writes them. [`Memo`] keeps the last result with the values
//! it came from; [`Revised`] adds the dictionary's
//! [`configuration_revision`](crate::od::Dictionary::configuration_revision), so that while no
//! configuration was written (an RPDO with set-points alone does not count) the values are not
//! even read again.

/// The last result of a function, kept with its key: computed again only for another key.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Memo<K, V> {
    kept: Option<(K, V)>,
}

impl<K: Copy + PartialEq, V: Copy> Memo<K, V> {
    /// Nothing kept.
    pub(crate) const EMPTY: Self = Memo { kept: None };

    /// The value for `key`: the kept one, or `compute`'s, kept from now on.
    #[inline]
    pub(crate) fn get(&mut self, key: K, compute: impl FnOnce() -> V) -> V {
        match self.kept {
            Some((kept, value)) if kept == key => value,
            _ => {
                let value = compute();
                self.kept = Some((key, value));
                value
            }
        }
    }
}

/// A [`Memo`] whose key is read from the dictionary, with the revision it was read at.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Revised<K, V> {
    memo: Memo<K, V>,
    revision: u32,
}

impl<K: Copy + PartialEq, V: Copy> Revised<K, V> {
    /// Nothing kept.
    pub(crate) const EMPTY: Self = Revised { memo: Memo::EMPTY, revision: 0 };

    /// The kept value if the dictionary is still at `revision` since its key was read.
    #[inline]
    pub(crate) fn kept(&self, revision: u32) -> Option<V> {
        self.memo.kept.filter(|_| self.revision == revision).map(|(_, value)| value)
    }

    /// The value for `key`, read at `revision` ([`Memo::get`]).
    #[inline]
    pub(crate) fn get(&mut self, key: K, revision: u32, compute: impl FnOnce() -> V) -> V {
        self.revision = revision;
        self.memo.get(key, compute)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn computes_again_only_for_another_key_or_revision() {
        let mut calls = 0;
        let mut memo: Revised<u8, u16> = Revised::EMPTY;
        assert_eq!(memo.kept(0), None, "nothing kept at first");
        let mut get = |memo: &mut Revised<u8, u16>, key: u8, revision: u32| {
            memo.get(key, revision, || {
                calls += 1;
                u16::from(key) * 10
            })
        };
        assert_eq!(get(&mut memo, 1, 5), 10);
        assert_eq!(get(&mut memo, 1, 6), 10, "same key at a later revision: kept");
        assert_eq!(get(&mut memo, 2, 6), 20);
        assert_eq!(calls, 2);
        assert_eq!(memo.kept(6), Some(20));
        assert_eq!(memo.kept(7), None, "a write since: the key must be read again");
    }
}
