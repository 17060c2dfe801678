//! Subdivision hierarchies: polygon topology, canonical Catmull-Clark refinement (what the
//! decoder rebuilds from the base mesh, SPEC.md 8) and recovery of a hierarchy from a
//! flat mesh in any vertex and face order (encoder only).

mod canonical;
pub mod cc;
pub mod gates;
pub mod polar;
pub(crate) mod rings;
pub mod sqrt2;

use crate::error::{Error, Result};

pub use canonical::{canonicalise, Canonical, Recovered};
pub(crate) use canonical::{
    base_numbering, check_matches, face_key, next_canonical_level, push_face_points, FaceIndex,
};

/// Which subdivision family the levels follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// No subdivision structure: a base mesh with zero levels.
    None,
    /// Catmull-Clark (1-to-4) refinement.
    Cc,
    /// sqrt(2) refinement.
    Sqrt2,
    /// Catmull-Clark with polar structures.
    Polar,
}

impl Family {
    /// The name `info` prints.
    pub fn name(self) -> &'static str {
        match self {
            Family::None => "none",
            Family::Cc => "cc",
            Family::Sqrt2 => "sqrt2",
            Family::Polar => "polar",
        }
    }

    /// The fine vertex count of one of its levels (coarse vertices first).
    pub(crate) fn fine_nv(self, level: &Level) -> usize {
        match self {
            Family::Sqrt2 => sqrt2::fine_nv(level),
            _ => level.fine_nv(),
        }
    }

    /// How many details one of its levels has: one per edge and face of a Catmull-Clark
    /// or polar level, one per face of a sqrt(2) step.
    pub(crate) fn details(self, level: &Level) -> usize {
        self.fine_nv(level) - level.nv
    }

    /// The fine face count of one of its levels (`pole`: the polar levels' poles).
    pub(crate) fn fine_faces(self, level: &Level, pole: &[bool]) -> usize {
        match self {
            Family::Sqrt2 => level.ne(),
            _ => level.fine_faces_with(pole),
        }
    }
}

/// "No such face / edge".
pub const NONE: u32 = u32::MAX;

/// A map from vertex pairs to numbers: open addressing with linear probing and a
/// multiplicative hash, several times faster than `HashMap` with SipHash for the edge
/// tables built at every level (its order never shows: only lookups are used).
#[derive(Debug, Clone)]
pub struct PairMap {
    keys: Vec<u64>,
    vals: Vec<u32>,
    len: usize,
}

const EMPTY_KEY: u64 = u64::MAX;

impl PairMap {
    /// A map sized for about `n` entries.
    pub fn with_capacity(n: usize) -> Self {
        let cap = (n.max(4) * 2).next_power_of_two();
        PairMap {
            keys: vec![EMPTY_KEY; cap],
            vals: vec![0; cap],
            len: 0,
        }
    }

    #[inline]
    fn slot(&self, key: u64) -> usize {
        let mask = self.keys.len() - 1;
        // Fibonacci hashing: the top bits of the product, after folding the high half
        // (the first vertex) into the low one so that both halves reach every bit.
        let bits = self.keys.len().trailing_zeros();
        let h = (key ^ (key >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let mut i = (h >> (64 - bits)) as usize;
        while self.keys[i] != EMPTY_KEY && self.keys[i] != key {
            i = (i + 1) & mask;
        }
        i
    }

    /// The value for `(a, b)`, if any.
    #[inline]
    pub fn get(&self, a: u32, b: u32) -> Option<u32> {
        let key = (a as u64) << 32 | b as u64;
        let i = self.slot(key);
        (self.keys[i] == key).then(|| self.vals[i])
    }

    /// The value for `(a, b)`, inserting `make()` first if there is none; and whether it
    /// was inserted.
    #[inline]
    pub fn get_or_insert(&mut self, a: u32, b: u32, make: impl FnOnce() -> u32) -> (u32, bool) {
        if 2 * (self.len + 1) > self.keys.len() {
            self.grow();
        }
        let key = (a as u64) << 32 | b as u64;
        let i = self.slot(key);
        if self.keys[i] == key {
            return (self.vals[i], false);
        }
        let v = make();
        self.keys[i] = key;
        self.vals[i] = v;
        self.len += 1;
        (v, true)
    }

    /// Sets the value for `(a, b)`.
    pub fn insert(&mut self, a: u32, b: u32, v: u32) {
        if 2 * (self.len + 1) > self.keys.len() {
            self.grow();
        }
        let key = (a as u64) << 32 | b as u64;
        let i = self.slot(key);
        if self.keys[i] != key {
            self.len += 1;
        }
        self.keys[i] = key;
        self.vals[i] = v;
    }

    /// Number of entries.
    #[cfg(feature = "internals")]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the map is empty.
    #[cfg(feature = "internals")]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The values, in no particular order.
    pub fn values(&self) -> impl Iterator<Item = u32> + '_ {
        self.keys
            .iter()
            .zip(&self.vals)
            .filter(|(k, _)| **k != EMPTY_KEY)
            .map(|(_, v)| *v)
    }

    fn grow(&mut self) {
        let old_keys = std::mem::take(&mut self.keys);
        let old_vals = std::mem::take(&mut self.vals);
        self.keys = vec![EMPTY_KEY; old_keys.len() * 2];
        self.vals = vec![0; old_keys.len() * 2];
        for (k, v) in old_keys.into_iter().zip(old_vals) {
            if k != EMPTY_KEY {
                let i = self.slot(k);
                self.keys[i] = k;
                self.vals[i] = v;
            }
        }
    }
}

/// Whether `mask[i]` is set; indices past the end of `mask` are not (an empty mask marks
/// nothing: the pole flags of a level without poles, the values no disc owns).
#[inline]
pub(crate) fn flag(mask: &[bool], i: usize) -> bool {
    mask.get(i).copied().unwrap_or(false)
}

/// Polygon topology: `nv` vertices and faces as index lists (CSR).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Topo {
    /// Number of vertices (some may be used by no face).
    pub nv: usize,
    /// `idx[starts[f]..starts[f + 1]]` are face `f`'s corners.
    pub starts: Vec<u32>,
    /// All corners.
    pub idx: Vec<u32>,
}

impl Topo {
    /// Topology with `nv` vertices and the given faces.
    pub fn new(nv: usize) -> Self {
        Topo {
            nv,
            starts: vec![0],
            idx: Vec::new(),
        }
    }

    /// Number of faces.
    pub fn nf(&self) -> usize {
        self.starts.len() - 1
    }

    /// Face `f`'s corners.
    #[inline]
    pub fn face(&self, f: usize) -> &[u32] {
        &self.idx[self.starts[f] as usize..self.starts[f + 1] as usize]
    }

    /// Appends a face.
    pub fn push(&mut self, corners: &[u32]) {
        self.idx.extend_from_slice(corners);
        self.starts.push(self.idx.len() as u32);
    }

    /// Whether every face is a quad.
    pub fn all_quads(&self) -> bool {
        self.starts.windows(2).all(|w| w[1] - w[0] == 4)
    }
}

/// One Catmull-Clark refinement of a coarse topology, with the adjacency the lifting
/// steps need (SPEC.md 8.1). Fine vertex numbering: coarse vertices `0..nv`, then one
/// edge point per coarse edge (`nv + e`), then one face point per face (`nv + ne + f`).
#[derive(Debug, Clone)]
pub struct Level {
    /// Coarse vertices.
    pub nv: usize,
    /// Coarse edges: their end points, in order of first appearance walking the faces.
    pub edges: Vec<[u32; 2]>,
    /// The (one or two) faces beside each edge; `NONE` for the missing one on a boundary.
    pub edge_faces: Vec<[u32; 2]>,
    /// Coarse faces.
    pub coarse: Topo,
    /// `face_edges[coarse.starts[f] + i]` is the edge from corner i to corner i + 1.
    pub face_edges: Vec<u32>,
    /// The per-vertex lists, made at their first use (a decoder's level that reads
    /// none never makes them); empty once freed.
    lists: std::sync::OnceLock<VertexLists>,
    /// The vertices' rings, where they came with the level (a decoder's sqrt(2) level,
    /// derived from its coarser level's: see [`rings::Rings::of_level`]).
    rings: Option<rings::Rings>,
}

/// A level's per-vertex lists (CSR).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct VertexLists {
    /// Per coarse vertex: its edges, in edge order.
    vert_edges: Vec<u32>,
    /// Per coarse vertex: the faces it is a corner of, once per corner, in face order.
    vert_faces: Vec<u32>,
    /// Starts of the vertex lists (`nv + 1` entries) in `vert_edges`.
    ve_starts: Vec<u32>,
    /// Starts of the vertex lists in `vert_faces`.
    vf_starts: Vec<u32>,
}

impl PartialEq for Level {
    /// The same topology and the same per-vertex lists (made for the comparison).
    fn eq(&self, o: &Level) -> bool {
        self.nv == o.nv
            && self.edges == o.edges
            && self.edge_faces == o.edge_faces
            && self.coarse == o.coarse
            && self.face_edges == o.face_edges
            && self.lists() == o.lists()
    }
}

impl Eq for Level {}

impl Level {
    /// Number of coarse edges.
    pub fn ne(&self) -> usize {
        self.edges.len()
    }

    /// Number of coarse faces.
    pub fn nf(&self) -> usize {
        self.coarse.nf()
    }

    /// Number of fine vertices.
    pub fn fine_nv(&self) -> usize {
        self.nv + self.ne() + self.nf()
    }

    /// Edge `e` has a face on one side only.
    #[inline]
    pub fn is_boundary(&self, e: usize) -> bool {
        self.edge_faces[e][1] == NONE
    }

    /// Coarse vertex `v`'s boundary edges: their count and the first two (which coarse
    /// vertices lie on a boundary curve, and where it goes; SPEC.md 9.2).
    pub fn boundary_edges(&self, v: usize) -> (usize, [u32; 2]) {
        let mut n = 0;
        let mut be = [0u32; 2];
        for &e in self.v_edges(v) {
            if self.is_boundary(e as usize) {
                if n < 2 {
                    be[n] = e;
                }
                n += 1;
            }
        }
        (n, be)
    }

    /// The end of edge `e` that is not coarse vertex `v`.
    #[inline]
    pub fn other_end(&self, e: u32, v: usize) -> u32 {
        let [a, b] = self.edges[e as usize];
        if a as usize == v {
            b
        } else {
            a
        }
    }

    /// The per-vertex lists, made now if not yet.
    #[inline(always)]
    fn lists(&self) -> &VertexLists {
        match self.lists.get() {
            Some(l) => l,
            None => self.make_lists(),
        }
    }

    /// [`Level::lists`]'s making, once per level (out of its callers' loops).
    #[cold]
    #[inline(never)]
    fn make_lists(&self) -> &VertexLists {
        self.lists.get_or_init(|| {
            let (ve_starts, vert_edges) = csr(
                self.nv,
                self.edges
                    .iter()
                    .enumerate()
                    .flat_map(|(e, &[a, b])| [(a, e as u32), (b, e as u32)]),
            );
            let (vf_starts, vert_faces) = vertex_faces(&self.coarse);
            VertexLists {
                vert_edges,
                vert_faces,
                ve_starts,
                vf_starts,
            }
        })
    }

    /// Coarse vertex `v`'s edges, in edge order (none once
    /// [`Level::free_vertex_adjacency`] ran).
    #[inline]
    pub fn v_edges(&self, v: usize) -> &[u32] {
        let l = self.lists();
        match (l.ve_starts.get(v), l.ve_starts.get(v + 1)) {
            (Some(&a), Some(&b)) => &l.vert_edges[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Coarse vertex `v`'s faces, one entry per corner, in face order (none once
    /// [`Level::free_vertex_adjacency`] ran).
    #[inline]
    pub fn v_faces(&self, v: usize) -> &[u32] {
        let l = self.lists();
        match (l.vf_starts.get(v), l.vf_starts.get(v + 1)) {
            (Some(&a), Some(&b)) => &l.vert_faces[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Whether the per-vertex lists were freed ([`Level::free_vertex_adjacency`]):
    /// [`Level::v_edges`] and [`Level::v_faces`] are then empty.
    pub fn vertex_lists_freed(&self) -> bool {
        self.lists.get().is_some_and(|l| l.ve_starts.is_empty())
    }

    /// Frees the per-vertex lists (or never makes them), for a decoder step that never
    /// reads them (a sqrt2-lazy or ir2w level: its predictions, update, details and
    /// synthesis read faces and edges only), so the level's memory is smaller where the
    /// decoder's peaks.
    pub fn free_vertex_adjacency(&mut self) {
        self.lists = std::sync::OnceLock::from(VertexLists::default());
    }

    /// Face `f`'s edges, in corner order.
    #[inline]
    pub fn f_edges(&self, f: usize) -> &[u32] {
        &self.face_edges[self.coarse.starts[f] as usize..self.coarse.starts[f + 1] as usize]
    }

    /// Builds the refinement of `coarse`. Fails on topology that Catmull-Clark levels
    /// cannot refine: a face with a repeated corner or an edge with more than two faces.
    pub fn new(coarse: &Topo) -> Result<Level> {
        let nv = coarse.nv;
        let mut edge_id = PairMap::with_capacity(coarse.idx.len() / 2 + 4);
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(coarse.idx.len() / 2 + 4);
        let mut edge_faces: Vec<[u32; 2]> = Vec::with_capacity(coarse.idx.len() / 2 + 4);
        let mut face_edges = Vec::with_capacity(coarse.idx.len());
        for f in 0..coarse.nf() {
            let face = coarse.face(f);
            let k = face.len();
            for i in 0..k {
                let (a, b) = (face[i], face[(i + 1) % k]);
                if a == b || a as usize >= nv || b as usize >= nv {
                    return Err(Error::InvalidMesh(format!(
                        "face {} has a repeated or invalid corner; it cannot be refined",
                        f + 1
                    )));
                }
                let (id, _) = edge_id.get_or_insert(a.min(b), a.max(b), || {
                    edges.push([a, b]);
                    edge_faces.push([NONE, NONE]);
                    (edges.len() - 1) as u32
                });
                let ef = &mut edge_faces[id as usize];
                if ef[0] == NONE {
                    ef[0] = f as u32;
                } else if ef[1] == NONE {
                    ef[1] = f as u32;
                } else {
                    return Err(Error::InvalidMesh(format!(
                        "edge {}-{} has more than two faces; it cannot be refined",
                        a as u64 + 1,
                        b as u64 + 1
                    )));
                }
                face_edges.push(id);
            }
        }
        Ok(Level::from_edges(
            coarse.clone(),
            edges,
            edge_faces,
            face_edges,
            true,
        ))
    }

    /// The level of `coarse` whose edges, their faces and the faces' edges are already
    /// known (exactly as [`Level::new`] would find them); without the per-vertex lists
    /// unless `lists` (as after [`Level::free_vertex_adjacency`]).
    pub(crate) fn from_edges(
        coarse: Topo,
        edges: Vec<[u32; 2]>,
        edge_faces: Vec<[u32; 2]>,
        face_edges: Vec<u32>,
        lists: bool,
    ) -> Level {
        let mut level = Level {
            nv: coarse.nv,
            edges,
            edge_faces,
            coarse,
            face_edges,
            lists: std::sync::OnceLock::new(),
            rings: None,
        };
        if !lists {
            level.free_vertex_adjacency();
        }
        level
    }

    /// The fine topology (SPEC.md 8.1): per coarse face f, per corner i, the quad
    /// (corner i, edge point of edge i, face point, edge point of edge i - 1).
    pub fn fine(&self) -> Topo {
        self.fine_with(&[])
    }

    /// The fine topology of a polar level (SPEC.md 8.6): as [`Level::fine`], except that
    /// at each corner of a triangle that is a pole (`pole[v]`; vertices past the end of
    /// `pole` are not poles) the quad is split along (corner, face point) into two
    /// triangles.
    pub fn fine_with(&self, pole: &[bool]) -> Topo {
        let mut t = Topo::new(self.fine_nv());
        t.idx.reserve(self.coarse.idx.len() * 4);
        t.starts.reserve(self.coarse.idx.len());
        let e0 = self.nv as u32;
        let f0 = (self.nv + self.ne()) as u32;
        for f in 0..self.nf() {
            let face = self.coarse.face(f);
            let fe = self.f_edges(f);
            let k = face.len();
            let fp = f0 + f as u32;
            for i in 0..k {
                let (c, a, b) = (face[i], e0 + fe[i], e0 + fe[(i + k - 1) % k]);
                if k == 3 && flag(pole, c as usize) {
                    t.push(&[c, a, fp]);
                    t.push(&[c, fp, b]);
                } else {
                    t.push(&[c, a, fp, b]);
                }
            }
        }
        t
    }

    /// The level of [`Level::fine`]`()`, equal to `Level::new(&self.fine())` but derived
    /// from this level without looking edges up: a fine edge is half of a coarse edge
    /// (from one of its ends to its edge point) or a face's spoke (from an edge point to
    /// its face point), numbered as `Level::new` numbers them, by first appearance in
    /// the fine faces' corner order.
    pub fn next(&self) -> Level {
        self.next_mapped().0
    }

    /// [`Level::next`] and where its edges came from ([`NextMap`]).
    pub fn next_mapped(&self) -> (Level, NextMap) {
        let fine = self.fine();
        let (nv, ne) = (self.nv as u32, self.ne());
        let (e0, f0) = (nv, nv + ne as u32);
        // Per coarse edge, the fine edges of its halves at its first and second end.
        let mut half = vec![[NONE; 2]; ne];
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(2 * ne + self.coarse.idx.len());
        let mut edge_faces: Vec<[u32; 2]> = Vec::with_capacity(edges.capacity());
        let mut face_edges = Vec::with_capacity(fine.idx.len());
        let (mut q, mut spoke) = (0u32, Vec::new());
        let mut spokes = Vec::with_capacity(self.coarse.idx.len());
        // A fine edge `a -> b` seen in fine face q: its number (new if `*id` is NONE).
        let mut visit = |id: &mut u32, a: u32, b: u32, q: u32| {
            if *id == NONE {
                *id = edges.len() as u32;
                edges.push([a, b]);
                edge_faces.push([q, NONE]);
            } else {
                edge_faces[*id as usize][1] = q;
            }
            face_edges.push(*id);
        };
        for f in 0..self.nf() {
            let face = self.coarse.face(f);
            let fe = self.f_edges(f);
            let k = face.len();
            let fp = f0 + f as u32;
            // Spoke i: edge point of fe[i] to the face point (one buffer for all faces).
            spoke.clear();
            spoke.resize(k, NONE);
            for i in 0..k {
                let p = if i == 0 { k - 1 } else { i - 1 };
                let c = face[i];
                let (ei, ep) = (fe[i] as usize, fe[p] as usize);
                let (a, b) = (e0 + fe[i], e0 + fe[p]);
                // Quad (c, a, fp, b): half of fe[i] at c, spoke i, spoke p, half of
                // fe[p] at c.
                let end = |e: usize| (self.edges[e][0] != c) as usize;
                let (hi, hp) = (end(ei), end(ep));
                visit(&mut half[ei][hi], c, a, q);
                visit(&mut spoke[i], a, fp, q);
                visit(&mut spoke[p], fp, b, q);
                visit(&mut half[ep][hp], b, c, q);
                q += 1;
            }
            spokes.extend_from_slice(&spoke);
        }
        let level = Level::from_edges(fine, edges, edge_faces, face_edges, true);
        (level, NextMap { half, spokes })
    }

    /// The number of faces [`Level::fine_with`] makes.
    pub fn fine_faces_with(&self, pole: &[bool]) -> usize {
        let splits = (0..self.nf())
            .map(|f| self.coarse.face(f))
            .filter(|face| face.len() == 3)
            .flatten()
            .filter(|&&v| flag(pole, v as usize))
            .count();
        self.coarse.idx.len() + splits
    }
}

/// Where [`Level::next_mapped`]'s fine edges came from: per coarse edge, the fine edges
/// of its halves at its first and second end; per coarse face corner (numbered as in
/// the coarse `idx`), the fine edge from the edge point of the corner's edge (the edge
/// from that corner to the next) to the face point.
#[derive(Debug, Clone)]
pub struct NextMap {
    /// Per coarse edge, its halves' fine edges at its first and second end.
    pub half: Vec<[u32; 2]>,
    /// Per coarse face corner, the fine edge from its edge's edge point to the face
    /// point.
    pub spokes: Vec<u32>,
}

/// Per vertex of `topo`: the faces it is a corner of, once per corner, in face order
/// (CSR: the starts, `nv + 1` entries, and the lists).
pub(crate) fn vertex_faces(topo: &Topo) -> (Vec<u32>, Vec<u32>) {
    csr(
        topo.nv,
        (0..topo.nf()).flat_map(|f| topo.face(f).iter().map(move |&v| (v, f as u32))),
    )
}

/// Compressed lists: for each key in `0..n`, its values in insertion order.
#[inline(always)]
pub(crate) fn csr<T: Copy + Default>(
    n: usize,
    pairs: impl Iterator<Item = (u32, T)> + Clone,
) -> (Vec<u32>, Vec<T>) {
    let mut starts = vec![0u32; n + 1];
    for (k, _) in pairs.clone() {
        starts[k as usize + 1] += 1;
    }
    for i in 0..n {
        starts[i + 1] += starts[i];
    }
    let mut fill = starts.clone();
    let mut vals = vec![T::default(); starts[n] as usize];
    for (k, v) in pairs {
        vals[fill[k as usize] as usize] = v;
        fill[k as usize] += 1;
    }
    (starts, vals)
}

/// Test fixtures shared by the hierarchy and transform tests.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::Topo;

    /// A cube: eight corners of three edges, six quads.
    pub(crate) fn cube() -> Topo {
        let mut t = Topo::new(8);
        for f in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            t.push(&f);
        }
        t
    }

    /// Scrambles vertex numbers, face order and face starts.
    pub(crate) fn shuffle(t: &Topo, seed: u64) -> Topo {
        let mut s = seed | 1;
        let mut rnd = move |n: usize| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % n as u64) as usize
        };
        let mut perm: Vec<u32> = (0..t.nv as u32).collect();
        for i in (1..perm.len()).rev() {
            perm.swap(i, rnd(i + 1));
        }
        let mut faces: Vec<Vec<u32>> = (0..t.nf())
            .map(|f| {
                let face = t.face(f);
                let r = rnd(face.len());
                (0..face.len())
                    .map(|i| perm[face[(i + r) % face.len()] as usize])
                    .collect()
            })
            .collect();
        for i in (1..faces.len()).rev() {
            faces.swap(i, rnd(i + 1));
        }
        let mut out = Topo::new(t.nv);
        for f in &faces {
            out.push(f);
        }
        out
    }

    /// `n` pseudo-random values in `-2^(bits - 1)..2^(bits - 1)` (a fixed sequence per
    /// seed).
    pub(crate) fn pseudo(seed: u64, n: usize, bits: u32) -> Vec<i64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 20) % (1 << bits)) as i64 - (1 << (bits - 1))
            })
            .collect()
    }

    /// An (n - 1) x (n - 1) grid of quads over n^2 vertices, row-major.
    pub(crate) fn quad_grid(n: u32) -> Topo {
        let mut t = Topo::new((n * n) as usize);
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = y * n + x;
                t.push(&[i, i + 1, i + n + 1, i + n]);
            }
        }
        t
    }

    /// A closed pentagonal prism with one side split into two triangles: a pentagon,
    /// triangles and quads, vertices of valence 3, 4 and 5.
    pub(crate) fn prism_with_triangles() -> Topo {
        let mut t = Topo::new(10);
        t.push(&[4, 3, 2, 1, 0]);
        t.push(&[5, 6, 7, 8, 9]);
        t.push(&[0, 1, 6]);
        t.push(&[0, 6, 5]);
        for i in 1..5u32 {
            let j = (i + 1) % 5;
            t.push(&[i, j, j + 5, i + 5]);
        }
        t
    }
}

#[cfg(test)]
mod next_tests {
    use super::fixtures::{self, prism_with_triangles, shuffle};
    use super::*;

    /// `Level::next` is `Level::new` of the fine faces, for closed and open meshes,
    /// mixed degrees, several components, scrambled numbering and inconsistent
    /// orientation, three levels deep.
    #[test]
    fn next_level_is_the_level_of_the_fine_faces() {
        let mut open = Topo::new(9);
        open.push(&[0, 1, 2]);
        open.push(&[0, 2, 3, 4]);
        open.push(&[0, 4, 5, 6, 1]);
        // A second component, its face against the others' orientation.
        open.push(&[7, 8, 6]);
        let grid = fixtures::quad_grid(4);
        let mut flipped = prism_with_triangles();
        let mut f0: Vec<u32> = flipped.face(0).to_vec();
        f0.reverse();
        let mut t = Topo::new(flipped.nv);
        t.push(&f0);
        for f in 1..flipped.nf() {
            t.push(flipped.face(f));
        }
        flipped = t;
        let prism = prism_with_triangles();
        for base in [
            shuffle(&prism, 3),
            prism,
            open.clone(),
            shuffle(&open, 5),
            grid.clone(),
            shuffle(&grid, 9),
            flipped,
        ] {
            let mut level = Level::new(&base).unwrap();
            for depth in 0..3 {
                let next = level.next();
                assert_eq!(next, Level::new(&level.fine()).unwrap(), "depth {depth}");
                level = next;
            }
        }
    }
}
