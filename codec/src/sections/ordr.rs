//! The ORDR section: the permutation from canonical vertex order back to the input's
//! (SPEC.md 7). Runs of consecutive indices cost a fraction of a bit each; the rest is
//! coded as a rank among the indices not yet used, close to log2(n!) bits in all.

use crate::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
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

/// Codes a permutation `order[new] = old` of `0..order.len()` (SPEC.md 7.1).
pub fn put_perm(e: &mut Encoder, order: &[u32]) {
    let n = order.len();
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
}

/// Decodes a permutation of `0..n` and checks it is one.
pub fn get_perm(d: &mut Decoder, n: usize) -> Result<Vec<u32>> {
    let mut run = [AdaptiveModel::new(2), AdaptiveModel::new(2)];
    let mut unused = Unused::new(n);
    let mut used = vec![false; n];
    let mut out = Vec::with_capacity(n);
    let mut prev: i64 = -1;
    let mut prev_hit = 0usize;
    for i in 0..n {
        let hit = d.symbol(&mut run[prev_hit])? == 1;
        let o = if hit {
            (prev + 1) as usize
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

/// The input's order: vertices, and (format 2) faces with their first corners.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct InputOrder {
    /// `vertices[c]` = input number of canonical vertex `c`.
    pub vertices: Vec<u32>,
    /// `faces[c]` = input position of canonical face `c`.
    pub faces: Vec<u32>,
    /// `rotations[c]`: input face `faces[c]` starts at corner `rotations[c]` of the
    /// canonical face (its corner order otherwise the same).
    pub rotations: Vec<u32>,
}

/// Codes the ORDR section of format 2 (SPEC.md 7).
pub fn encode(o: &InputOrder) -> Vec<u8> {
    let mut e = Encoder::new();
    put_perm(&mut e, &o.vertices);
    put_perm(&mut e, &o.faces);
    let mut m = IntModel::new();
    for &r in &o.rotations {
        e.int(&mut m, r as i64);
    }
    e.finish()
}

/// Decodes a format-2 ORDR section; `degrees[c]` is canonical face c's degree.
pub fn decode(payload: &[u8], nv: usize, degrees: &[u32]) -> Result<InputOrder> {
    let mut d = Decoder::new(payload, SECTION)?;
    let vertices = get_perm(&mut d, nv)?;
    let faces = get_perm(&mut d, degrees.len())?;
    let mut m = IntModel::new();
    let mut rotations = Vec::with_capacity(degrees.len());
    for &k in degrees {
        let r = d.int(&mut m)?;
        if r < 0 || r >= k as i64 {
            return Err(Error::corrupt(SECTION, "face rotation out of range"));
        }
        rotations.push(r as u32);
    }
    Ok(InputOrder {
        vertices,
        faces,
        rotations,
    })
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
            let o = InputOrder { vertices: p.clone(), faces: p.iter().rev().copied().collect(), rotations: p.iter().map(|&x| x % 4).collect() };
            let bytes = encode(&o);
            prop_assert_eq!(decode(&bytes, n, &vec![4; n]).unwrap(), o);
        }
    }

    #[test]
    fn identity_is_nearly_free() {
        let p: Vec<u32> = (0..100_000).collect();
        let o = InputOrder {
            vertices: p.clone(),
            faces: p,
            rotations: vec![0; 100_000],
        };
        assert!(encode(&o).len() < 160, "{}", encode(&o).len());
    }
}
