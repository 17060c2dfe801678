//! Coding one refinement level's details (SPEC.md 10): the edge points' details, then the
//! face points', each as x, y, z with integer models chosen by class, axis, the previous
//! axis's magnitude and the activity of the coarser neighbours.

use crate::coder::{class_of, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::hierarchy::Level;

/// Largest magnitude of a lifted value or detail (SPEC.md 9.3).
pub const MAX_LIFTED: i64 = (1 << 52) - 1;

/// Activity of a vertex with no detail (base vertices).
pub const UNKNOWN: u8 = 255;

const NBR_BINS: usize = 6;

fn nbr_bin(sum: u32, n: u32, unknown: bool) -> usize {
    if unknown || n == 0 {
        return 5;
    }
    match (sum + n / 2) / n {
        0 => 0,
        1..=2 => 1,
        3..=5 => 2,
        6..=9 => 3,
        _ => 4,
    }
}

fn prev_bin(c: usize) -> usize {
    match c {
        0..=2 => 0,
        3..=6 => 1,
        _ => 2,
    }
}

struct Models(Vec<IntModel>);

impl Models {
    fn new() -> Self {
        Models((0..2 * 3 * 3 * NBR_BINS).map(|_| IntModel::new()).collect())
    }

    fn get(&mut self, class: usize, axis: usize, prev: usize, nbr: usize) -> &mut IntModel {
        let p = if axis == 0 { 0 } else { prev_bin(prev) };
        &mut self.0[((class * 3 + axis) * 3 + p) * NBR_BINS + nbr]
    }
}

fn e_context(level: &Level, act: &[u8], e: usize) -> usize {
    let [a, b] = level.edges[e];
    let (x, y) = (act[a as usize], act[b as usize]);
    nbr_bin(x as u32 + y as u32, 2, x == UNKNOWN || y == UNKNOWN)
}

fn f_context(level: &Level, act: &[u8], f: usize) -> usize {
    let mut s = 0u32;
    let mut n = 0u32;
    for &e in level.f_edges(f) {
        s += act[level.nv + e as usize] as u32;
        n += 1;
    }
    nbr_bin(s, n, false)
}

fn activity(d: [i64; 3]) -> u8 {
    d.iter().map(|&v| class_of(v)).max().unwrap_or(0) as u8
}

/// Codes the details `x[nv..]` of one level. `act` holds the coarse vertices' activity
/// and is extended to the fine vertices.
pub fn encode(level: &Level, x: &[Vec<i64>; 3], act: &mut Vec<u8>) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut m = Models::new();
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    act.resize(nv + ne + nf, 0);
    for e in 0..ne {
        let nbr = e_context(level, act, e);
        let i = nv + e;
        let mut prev = 0;
        for k in 0..3 {
            enc.int(m.get(0, k, prev, nbr), x[k][i]);
            prev = class_of(x[k][i]);
        }
        act[i] = activity([x[0][i], x[1][i], x[2][i]]);
    }
    for f in 0..nf {
        let nbr = f_context(level, act, f);
        let i = nv + ne + f;
        let mut prev = 0;
        for k in 0..3 {
            enc.int(m.get(1, k, prev, nbr), x[k][i]);
            prev = class_of(x[k][i]);
        }
        act[i] = activity([x[0][i], x[1][i], x[2][i]]);
    }
    enc.finish()
}

/// Decodes what [`encode`] wrote into `x[nv..]`.
pub fn decode(
    payload: &[u8],
    level: &Level,
    x: &mut [Vec<i64>; 3],
    act: &mut Vec<u8>,
) -> Result<()> {
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    // Density bound (SPEC.md 2.6), checked before the level's arrays are sized.
    if (ne + nf) as u64 > 2048 * (payload.len() as u64 + 8) {
        return Err(Error::corrupt(
            "LEVL",
            format!("{} bytes cannot hold {} details", payload.len(), ne + nf),
        ));
    }
    let mut dec = Decoder::new(payload, "LEVL")?;
    let mut m = Models::new();
    act.resize(nv + ne + nf, 0);
    for xs in x.iter_mut() {
        xs.resize(nv + ne + nf, 0);
    }
    let mut read = |dec: &mut Decoder,
                    i: usize,
                    class: usize,
                    nbr: usize,
                    x: &mut [Vec<i64>; 3]|
     -> Result<u8> {
        let mut prev = 0;
        for k in 0..3 {
            let v = dec.int(m.get(class, k, prev, nbr))?;
            if v.abs() > MAX_LIFTED {
                return Err(Error::corrupt("LEVL", "detail out of range"));
            }
            x[k][i] = v;
            prev = class_of(v);
        }
        Ok(activity([x[0][i], x[1][i], x[2][i]]))
    };
    for e in 0..ne {
        let nbr = e_context(level, act, e);
        act[nv + e] = read(&mut dec, nv + e, 0, nbr, x)?;
    }
    for f in 0..nf {
        let nbr = f_context(level, act, f);
        act[nv + ne + f] = read(&mut dec, nv + ne + f, 1, nbr, x)?;
    }
    Ok(())
}
