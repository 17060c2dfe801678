//! Every vertex's ring of neighbours in rotation order (SPEC.md 8.4), which the sqrt(2)
//! predictions walk.

use std::borrow::Cow;

use crate::topology::{Level, NONE};

/// The neighbours of every vertex, in the rotation order of SPEC.md 8.4 (from a corner's
/// next corner through the face to its previous corner), with for every face corner
/// its place in its vertex's ring. A vertex whose fan is open (a boundary) or not one
/// disc gets an empty ring.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rings {
    /// Per vertex, the start of its ring in `ring` (`nv + 1` entries).
    pub starts: Vec<u32>,
    /// All rings.
    pub ring: Vec<u32>,
    /// Per face corner (as numbered in the topology's `idx`), its place in its vertex's ring.
    pub pos: Vec<u32>,
}

impl Rings {
    /// Builds the rings of `t` (for the solver; the codec uses [`Rings::of_level`]).
    #[cfg(any(test, feature = "reference"))]
    pub fn new(t: &crate::topology::Topo) -> Rings {
        match crate::topology::Level::new(t) {
            Ok(level) => Rings::from_level(&level),
            Err(_) => Rings {
                starts: vec![0; t.nv + 1],
                ring: Vec::new(),
                pos: vec![u32::MAX; t.idx.len()],
            },
        }
    }

    /// The rings of a level's coarse mesh: those that came with it, else made from its
    /// edge-face adjacency ([`Rings::from_level`]).
    pub fn of_level(level: &Level) -> Cow<'_, Rings> {
        match &level.rings {
            Some(r) => Cow::Borrowed(r),
            None => Cow::Owned(Rings::from_level(level)),
        }
    }

    /// Builds the rings of a level's coarse mesh from its edge-face adjacency.
    pub fn from_level(level: &Level) -> Rings {
        let t = &level.coarse;
        let nc = t.idx.len();
        // link[c]: the corner of the same vertex in the face across the corner's
        // incoming edge (previous corner -> this one); NONE on a boundary.
        let mut link = vec![NONE; nc];
        let mut next_vertex = vec![NONE; nc];
        let mut first = vec![NONE; t.nv];
        let mut count = vec![0u32; t.nv];
        for f in 0..t.nf() {
            let s = t.starts[f] as usize;
            let face = t.face(f);
            let fe = level.f_edges(f);
            let k = face.len();
            for i in 0..k {
                let v = face[i];
                let c = s + i;
                // (Neighbouring corners without a division per corner.)
                let (next, prev) = (
                    if i + 1 == k { 0 } else { i + 1 },
                    if i == 0 { k - 1 } else { i - 1 },
                );
                next_vertex[c] = face[next];
                if first[v as usize] == NONE {
                    first[v as usize] = c as u32;
                }
                count[v as usize] += 1;
                let [g0, g1] = level.edge_faces[fe[prev] as usize];
                let g = if g0 as usize == f { g1 } else { g0 };
                if g == NONE {
                    continue;
                }
                let gs = t.starts[g as usize] as usize;
                if let Some(j) = t.face(g as usize).iter().position(|&w| w == v) {
                    link[c] = (gs + j) as u32;
                }
            }
        }
        let mut starts = Vec::with_capacity(t.nv + 1);
        let mut ring = Vec::with_capacity(nc);
        let mut pos = vec![u32::MAX; nc];
        starts.push(0u32);
        for v in 0..t.nv {
            let base = ring.len();
            let c0 = first[v];
            if c0 != NONE {
                let mut c = c0 as usize;
                let mut ok = false;
                for k in 0..count[v] {
                    pos[c] = k;
                    ring.push(next_vertex[c]);
                    match link[c] {
                        n if n == c0 => {
                            ok = k + 1 == count[v];
                            break;
                        }
                        NONE => break,
                        n => c = n as usize,
                    }
                }
                if !ok {
                    ring.truncate(base);
                }
            }
            starts.push(ring.len() as u32);
        }
        Rings { starts, ring, pos }
    }

    /// The rings of the fine mesh of a sqrt(2) step on `level` (SPEC.md 8.4: per coarse
    /// edge q = (a, b) with faces (f1, f2), in edge order, the quad (a, F2, b, F1)),
    /// derived from `rings`, the level's own, without a search: equal to
    /// [`Rings::from_level`] of the fine level. The coarse faces must have distinct
    /// corners (the caller, [`crate::topology::sqrt2::next_level`], derives only where
    /// its fine edges found them so). `None` (make them from the fine level) unless
    /// every coarse face has at most 64 corners, every edge's first face walks it from
    /// its first end and its second face back (a closed, consistently oriented mesh),
    /// and every vertex's ring is a disc.
    ///
    /// In the fine mesh an old vertex v's quads are those of its coarse edges, and a
    /// face point's those of its face's edges. Around v, the coarse ring walks faces
    /// f_0, f_1, ..., each the face across the edge that enters v in the one before;
    /// the fine walk goes through the quads of the edges that leave v in f_0, f_1, ...,
    /// and the quad of the edge leaving v in f_t lists F_(t-1), the point of the face
    /// before. Around a face point, the quad of the face's edge i (corner i to i + 1)
    /// lists corner i, and the walk goes to edge i + 1. Each walk starts, as
    /// [`Rings::from_level`]'s, at the vertex's first fine corner: the quad of its
    /// lowest edge.
    pub fn sqrt2_next(level: &Level, rings: &Rings) -> Option<Rings> {
        let t = &level.coarse;
        let (nv, nf, nc) = (level.nv, t.nf(), t.idx.len());
        if rings.starts.len() != nv + 1
            || rings.ring.len() != nc
            || rings.starts.windows(2).any(|w| w[0] == w[1])
        {
            return None;
        }
        let mut starts = Vec::with_capacity(nv + nf + 1);
        starts.extend_from_slice(&rings.starts);
        let mut ring = vec![0u32; 2 * nc];
        let mut pos = vec![u32::MAX; 4 * level.ne()];
        let (vertex_ring, point_ring) = ring.split_at_mut(nc);
        // Per coarse ring slot (vertex v's t-th): the face of its corner, and the edge
        // that leaves v in that face, twice its number plus 1 where v is its first end
        // (where the face is the edge's first).
        let mut face_at = vec![0u32; nc];
        let mut out_at = vec![0u32; nc];
        for f in 0..nf {
            let (s, e) = (t.starts[f] as usize, t.starts[f + 1] as usize);
            let (face, fe, cpos) = (&t.idx[s..e], &level.face_edges[s..e], &rings.pos[s..e]);
            let k = face.len();
            if k > 64 {
                return None;
            }
            // The corners whose edge has this face first, and the corner of the lowest edge.
            let (mut firsts, mut i0) = (0u64, 0);
            for (i, ((&v, &q), &p)) in face.iter().zip(fe).zip(cpos).enumerate() {
                let next = if i + 1 == k { face[0] } else { face[i + 1] };
                let first = level.edge_faces[q as usize][0] == f as u32;
                let ends = if first { [v, next] } else { [next, v] };
                debug_assert!(!face[i + 1..].contains(&v), "face {f}: corners not distinct");
                if level.edges[q as usize] != ends {
                    return None;
                }
                let slot = rings.starts[v as usize] as usize + p as usize;
                face_at[slot] = f as u32;
                out_at[slot] = 2 * q + first as u32;
                firsts |= (first as u64) << i;
                if q < fe[i0] {
                    i0 = i;
                }
            }
            // The face point's ring from the lowest edge's corner, and its corner's place
            // in quad q: 4 q + 3 where the face is q's first, else 4 q + 1.
            let base = starts[nv + f] as usize - nc;
            for (i, (&v, &q)) in face.iter().zip(fe).enumerate() {
                let j = if i >= i0 { i - i0 } else { i + k - i0 };
                point_ring[base + j] = v;
                pos[4 * q as usize + if firsts >> i & 1 == 1 { 3 } else { 1 }] = j as u32;
            }
            starts.push(starts[nv + f] + k as u32);
        }
        for v in 0..nv {
            let (lo, hi) = (rings.starts[v] as usize, rings.starts[v + 1] as usize);
            let (outs, faces) = (&out_at[lo..hi], &face_at[lo..hi]);
            let n = outs.len();
            let t0 = (0..n).min_by_key(|&t| outs[t]).unwrap_or(0);
            for (j, r) in vertex_ring[lo..hi].iter_mut().enumerate() {
                let t = if t0 + j < n { t0 + j } else { t0 + j - n };
                let before = if t == 0 { n - 1 } else { t - 1 };
                *r = nv as u32 + faces[before];
                // Old vertex v's corner in quad q: 4 q where v is q's first end, else 4 q + 2.
                let o = outs[t];
                pos[4 * (o >> 1) as usize + if o & 1 == 1 { 0 } else { 2 }] = j as u32;
            }
        }
        Some(Rings { starts, ring, pos })
    }

    /// Vertex `v`'s ring (empty when open or not a disc).
    pub fn of(&self, v: usize) -> &[u32] {
        &self.ring[self.starts[v] as usize..self.starts[v + 1] as usize]
    }
}

