//! The ORDR section: the permutations from canonical vertex and face order back to the
//! input's, and the faces' first corners (SPEC.md 7). Two methods, the smaller kept:
//! three lists, where runs of consecutive indices cost a fraction of a bit each and the
//! rest is coded as a rank among the indices not yet used (close to log2(n!) bits for a
//! random order); or walks over the faces and then the vertices in the input's order,
//! each next one coded as which of a few predicted neighbours it is (straight on, turning,
//! the next row, the next vertex of the faces' corners), so that the orders exporters
//! write (rows, grids, first use) cost little; or, on a Catmull-Clark hierarchy's finest
//! level, as blocks of its base elements, each in the order of the last block of its
//! shape turned (Blender's subdivision order), the vertices also by first use in those
//! faces (Blender's PLY cut at UV seams), or as the order a Catmull-Clark or sqrt(2)
//! refinement produces level by level from its base's order (a tool that writes each
//! level's old vertices, edge points and face points as blocks).


mod around;
mod elements;
mod levels;
mod walks;
#[cfg(test)]
mod tests;

use crate::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use elements::{decode_elements, decode_first_use, encode_by_elements};
use levels::{decode_levels, encode_levels};
pub use elements::Hierarchy;
use walks::{decode_walks, encode_walks};

const SECTION: &str = "ORDR";

/// Fenwick tree over `0..n` holding 1 for every index still unused.
pub(super) struct Unused {
    tree: Vec<u32>,
}

impl Unused {
    pub(super) fn new(n: usize) -> Self {
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
    pub(super) fn rank(&self, i: usize) -> u64 {
        let mut s = 0u64;
        let mut k = i;
        while k > 0 {
            s += self.tree[k] as u64;
            k &= k - 1;
        }
        s
    }

    /// The unused index with `r` unused indices below it.
    pub(super) fn select(&self, r: u64) -> usize {
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

    pub(super) fn remove(&mut self, i: usize) {
        let mut k = i + 1;
        while k < self.tree.len() {
            self.tree[k] -= 1;
            k += k & k.wrapping_neg();
        }
    }
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

/// The canonical faces the order refers to: `idx[starts[f]..starts[f + 1]]` are
/// canonical face f's corners, over `nv` vertices.
#[derive(Debug, Clone, Copy)]
pub struct Faces<'a> {
    /// Vertices.
    pub nv: usize,
    /// Face starts (one more than faces).
    pub starts: &'a [u32],
    /// Corners.
    pub idx: &'a [u32],
    /// The Catmull-Clark hierarchy these faces are the finest level of, if they are
    /// (method 2).
    pub hierarchy: Option<Hierarchy<'a>>,
}

impl<'a> Faces<'a> {
    pub(super) fn count(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    pub(super) fn face(&self, g: usize) -> &'a [u32] {
        &self.idx[self.starts[g] as usize..self.starts[g + 1] as usize]
    }
}

/// Codes a permutation `order[new] = old` of `0..order.len()` (SPEC.md 7.1).
fn put_perm(e: &mut Encoder, order: &[u32]) {
    let n = order.len();
    let mut step = Steps::new();
    let mut unused = Unused::new(n);
    for (i, &o) in order.iter().enumerate() {
        let sym = step.symbol_of(o as i64);
        e.symbol(step.model(), sym);
        if sym == OTHER {
            e.uniform(unused.rank(o as usize), (n - i) as u64);
        }
        unused.remove(o as usize);
        step.take(o as i64, sym);
    }
}

/// Each value of a permutation (SPEC.md 7.1): the last one's next, the last one plus
/// the last step that was not 1 or the one before it (a row's end, a column's next, a
/// block's next: a grid's order, row by row in blocks), or another, by its rank among
/// those not yet taken.
const NEXT: usize = 0;
const STRIDE: usize = 1;
const STRIDE2: usize = 2;
pub(super) const OTHER: usize = 3;

/// What [`put_perm`] and [`get_perm`] keep: the last value, the last two different
/// steps other than 1, the run of the last symbol (how many times in a row it came)
/// and per symbol its last run's length, and per last symbol and whether its run is as
/// long as its last one a model of the next symbol.
pub(super) struct Steps {
    models: [AdaptiveModel; 8],
    prev_sym: usize,
    pub(super) last: i64,
    strides: [i64; 2],
    run: usize,
    last_run: [usize; 4],
}

impl Steps {
    pub(super) fn new() -> Self {
        Steps {
            models: std::array::from_fn(|_| AdaptiveModel::new(4)),
            prev_sym: NEXT,
            last: -1,
            strides: [1, 1],
            run: 0,
            last_run: [usize::MAX; 4],
        }
    }

    /// The model of the next symbol.
    pub(super) fn model(&mut self) -> &mut AdaptiveModel {
        &mut self.models[self.prev_sym * 2 + (self.run == self.last_run[self.prev_sym]) as usize]
    }

    /// The value symbol `sym` stands for, if any.
    pub(super) fn value(&self, sym: usize) -> Option<i64> {
        let [a, b] = self.strides;
        match sym {
            NEXT => Some(self.last + 1),
            STRIDE if a != 1 => Some(self.last + a),
            STRIDE2 if b != 1 && b != a => Some(self.last + b),
            _ => None,
        }
    }

    pub(super) fn symbol_of(&self, o: i64) -> usize {
        [NEXT, STRIDE, STRIDE2]
            .into_iter()
            .find(|&s| self.value(s) == Some(o))
            .unwrap_or(OTHER)
    }

    pub(super) fn take(&mut self, o: i64, sym: usize) {
        let d = o - self.last;
        if d != 1 && d != self.strides[0] {
            self.strides = [d, self.strides[0]];
        }
        if sym == self.prev_sym {
            self.run += 1;
        } else {
            self.last_run[self.prev_sym] = self.run;
            self.run = 1;
        }
        self.last = o;
        self.prev_sym = sym;
    }
}

/// Decodes a permutation of `0..n` and checks it is one.
fn get_perm(d: &mut Decoder, n: usize) -> Result<Vec<u32>> {
    let mut step = Steps::new();
    let mut unused = Unused::new(n);
    let mut used = vec![false; n];
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let sym = d.symbol(step.model())?;
        let o = match (sym, step.value(sym)) {
            (OTHER, _) => unused.select(d.uniform((n - i) as u64)?) as i64,
            (_, Some(o)) => o,
            _ => return Err(Error::corrupt(SECTION, "a step of a permutation not yet taken")),
        };
        if !(0..n as i64).contains(&o) || used[o as usize] {
            return Err(Error::corrupt(SECTION, "not a permutation"));
        }
        used[o as usize] = true;
        unused.remove(o as usize);
        out.push(o as u32);
        step.take(o, sym);
    }
    Ok(out)
}

/// Codes the order as three lists (SPEC.md 7.1, method 0).
fn encode_lists(o: &InputOrder) -> Vec<u8> {
    let mut e = Encoder::new();
    put_perm(&mut e, &o.vertices);
    put_perm(&mut e, &o.faces);
    let mut m = IntModel::new();
    for &r in &o.rotations {
        e.int(&mut m, r as i64);
    }
    e.finish()
}

/// Decodes method 0 (SPEC.md 7.1); `degrees[c]` is canonical face c's degree.
fn decode_lists(payload: &[u8], nv: usize, degrees: &[u32]) -> Result<InputOrder> {
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

/// Codes the ORDR section (SPEC.md 7) of the input order `o` of the canonical
/// `faces`: a method byte, then the order as three lists (method 0), as walks
/// (method 1) or, on the finest level of a Catmull-Clark hierarchy, by its base
/// elements (method 2), as face blocks with the vertices by first use (method 3) or
/// as the order its refinement produces (method 4), whichever is smallest.
pub fn encode(o: &InputOrder, faces: Faces<'_>) -> Vec<u8> {
    let lists = encode_lists(o);
    let walks = encode_walks(o, faces);
    let (mut method, mut body) = if walks.len() < lists.len() {
        (1, walks)
    } else {
        (0, lists)
    };
    let by_elements = faces.hierarchy.and_then(|h| encode_by_elements(o, faces, h));
    if let Some((m, b)) = by_elements.filter(|(_, b)| b.len() < body.len()) {
        (method, body) = (m, b);
    }
    let by_levels = faces.hierarchy.and_then(|h| encode_levels(o, faces, h));
    if let Some(b) = by_levels.filter(|b| b.len() < body.len()) {
        (method, body) = (4, b);
    }
    let mut out = Vec::with_capacity(body.len() + 1);
    out.push(method);
    out.extend_from_slice(&body);
    out
}

/// What `info` calls an ORDR payload's method (SPEC.md 7).
pub fn method_name(payload: &[u8]) -> &'static str {
    match payload.first() {
        Some(0) => "lists",
        Some(1) => "walks",
        Some(2) => "base elements",
        Some(3) => "face blocks and first use",
        Some(4) => "refinement levels",
        _ => "unknown method",
    }
}

/// Decodes an ORDR section for the canonical `faces`.
pub fn decode(payload: &[u8], faces: Faces<'_>) -> Result<InputOrder> {
    match payload.split_first() {
        Some((0, body)) => {
            let degrees: Vec<u32> = faces.starts.windows(2).map(|w| w[1] - w[0]).collect();
            decode_lists(body, faces.nv, &degrees)
        }
        Some((1, body)) => decode_walks(body, faces),
        Some((2, body)) => decode_elements(body, faces, faces.hierarchy),
        Some((3, body)) => decode_first_use(body, faces, faces.hierarchy),
        Some((4, body)) => decode_levels(body, faces, faces.hierarchy),
        Some((m, _)) => Err(Error::corrupt(SECTION, format!("unknown method {m}"))),
        None => Err(Error::corrupt(SECTION, "empty payload")),
    }
}

