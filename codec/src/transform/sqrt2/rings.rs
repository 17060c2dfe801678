//! Every vertex's ring of neighbours in rotation order (SPEC.md 8.4), which the sqrt(2)
//! predictions walk.

use crate::topology::NONE;

/// The neighbours of every vertex, in the rotation order of SPEC.md 8.4 (from a corner's
/// next corner through the face to its previous corner), with for every face corner
/// its place in its vertex's ring. A vertex whose fan is open (a boundary) or not one
/// disc gets an empty ring.
pub struct Rings {
    /// Per vertex, the start of its ring in `ring` (`nv + 1` entries).
    pub starts: Vec<u32>,
    /// All rings.
    pub ring: Vec<u32>,
    /// Per face corner (as numbered in the topology's `idx`), its place in its vertex's ring.
    pub pos: Vec<u32>,
}

impl Rings {
    /// Builds the rings of `t` (for the solver; the codec uses [`Rings::from_level`]).
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

    /// Builds the rings of a level's coarse mesh from its edge-face adjacency.
    pub fn from_level(level: &crate::topology::Level) -> Rings {
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

    /// Vertex `v`'s ring (empty when open or not a disc).
    pub fn of(&self, v: usize) -> &[u32] {
        &self.ring[self.starts[v] as usize..self.starts[v + 1] as usize]
    }
}

