//! The ORDR section: the permutation from canonical vertex order back to the input's
//! (SPEC.md 7). Runs of consecutive indices cost a fraction of a bit each; the rest is
//! coded as a rank among the indices not yet used, close to log2(n!) bits in all.

use crate::coder::{AdaptiveModel, Decoder, Encoder};
use crate::error::{Error, Result};

const SECTION: &str = "ORDR";

/// Fenwick tree over `0..n` holding 1 for every index still unused.
struct Unused {
    tree: Vec<u32>,
}

impl Unused {
    fn new(n: usize) -> Self {
        let mut tree = vec![0u32; n + 1];
        for i in 1..=n {
            tree[i] += 1;
            let j = i + (i & i.wrapping_neg());
            if j <= n {
                tree[j] += tree[i];
            }
        }
        Unused { tree }
    }

    /// Unused indices below `i`.
    fn rank(&self, i: usize) -> u64 {
        let mut s = 0u64;
        let mut k = i;
        while k > 0 {
            s += self.tree[k] as u64;
            k &= k - 1;
        }
        s
    }

    /// The unused index with `r` unused indices below it.
    fn select(&self, r: u64) -> usize {
        let n = self.tree.len() - 1;
        let mut pos = 0usize;
        let mut rem = r;
        let mut step = if n == 0 {
            0
        } else {
            1usize << (usize::BITS - 1 - n.leading_zeros())
        };
        while step > 0 {
            let next = pos + step;
            if next <= n && (self.tree[next] as u64) <= rem {
                pos = next;
                rem -= self.tree[next] as u64;
            }
            step >>= 1;
        }
        pos
    }

    fn remove(&mut self, i: usize) {
        let mut k = i + 1;
        while k < self.tree.len() {
            self.tree[k] -= 1;
            k += k & k.wrapping_neg();
        }
    }
}

/// Codes `order[new] = old`, a permutation of `0..order.len()`.
pub fn encode(order: &[u32]) -> Vec<u8> {
    let n = order.len();
    let mut e = Encoder::new();
    let mut run = [AdaptiveModel::new(2), AdaptiveModel::new(2)];
    let mut unused = Unused::new(n);
    let mut prev: i64 = -1;
    let mut prev_hit = 0usize;
    for (i, &o) in order.iter().enumerate() {
        let hit = o as i64 == prev + 1;
        e.symbol(&mut run[prev_hit], hit as usize);
        if !hit {
            e.uniform(unused.rank(o as usize), (n - i) as u64);
        }
        unused.remove(o as usize);
        prev = o as i64;
        prev_hit = hit as usize;
    }
    e.finish()
}

/// Decodes a permutation of `0..n` and checks it is one.
pub fn decode(payload: &[u8], n: usize) -> Result<Vec<u32>> {
    let mut d = Decoder::new(payload, SECTION)?;
    let mut run = [AdaptiveModel::new(2), AdaptiveModel::new(2)];
    let mut unused = Unused::new(n);
    let mut used = vec![false; n];
    let mut out = Vec::with_capacity(n);
    let mut prev: i64 = -1;
    let mut prev_hit = 0usize;
    for i in 0..n {
        let hit = d.symbol(&mut run[prev_hit])? == 1;
        let o = if hit {
            let o = (prev + 1) as usize;
            if o >= n || used[o] {
                return Err(Error::corrupt(SECTION, "not a permutation"));
            }
            o
        } else {
            let r = d.uniform((n - i) as u64)?;
            unused.select(r)
        };
        if o >= n || used[o] {
            return Err(Error::corrupt(SECTION, "not a permutation"));
        }
        used[o] = true;
        unused.remove(o);
        out.push(o as u32);
        prev = o as i64;
        prev_hit = hit as usize;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn permutations_round_trip(n in 0usize..400, seed in proptest::num::u64::ANY, runs in proptest::bool::ANY) {
            let mut p: Vec<u32> = (0..n as u32).collect();
            let mut s = seed | 1;
            let swaps = if runs { n / 20 } else { n };
            for _ in 0..swaps {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                let a = (s % n.max(1) as u64) as usize;
                let b = ((s >> 20) % n.max(1) as u64) as usize;
                if n > 0 { p.swap(a, b); }
            }
            let bytes = encode(&p);
            prop_assert_eq!(decode(&bytes, n).unwrap(), p);
        }
    }

    #[test]
    fn identity_is_nearly_free() {
        let p: Vec<u32> = (0..100_000).collect();
        assert!(encode(&p).len() < 64);
    }
}
