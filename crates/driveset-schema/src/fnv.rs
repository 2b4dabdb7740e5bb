//! Owns a small FNV-1a hasher for the crate's hot lookup tables (code names,
//! set keys): keys are short, and a file is at most 4 MiB, so SipHash's
//! flooding resistance buys nothing here and costs time.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// FNV-1a, 64 bit.
#[derive(Default, Clone, Copy)]
pub(crate) struct Fnv(u64);

impl Hasher for Fnv {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        let mut h = if self.0 == 0 {
            0xcbf2_9ce4_8422_2325
        } else {
            self.0
        };
        for b in bytes {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        self.0 = h;
    }
}

/// A `HashMap` with [`Fnv`].
pub(crate) type FnvMap<K, V> = HashMap<K, V, BuildHasherDefault<Fnv>>;

/// FNV-1a of a string (as `Hash for str` feeds it: bytes then 0xff).
pub(crate) fn hash_str(s: &str) -> u64 {
    use std::hash::Hash;
    let mut h = Fnv::default();
    s.hash(&mut h);
    h.finish()
}
