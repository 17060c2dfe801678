//! The canonical mesh's neighbourhoods that the walks (SPEC.md 7.2) step over.

use super::Faces;

/// The faces around each vertex, which the walks' predictions step over.
pub(super) struct Around<'a> {
    pub(super) f: Faces<'a>,
    vf_starts: Vec<u32>,
    vf: Vec<u32>,
    /// Per corner i of face g (at `starts[g] + i`): the first other face around the
    /// corner's vertex with the edge from it to the next corner, or `NONE`.
    across: Vec<u32>,
}

/// No face.
const NONE: u32 = u32::MAX;

impl<'a> Around<'a> {
    pub(super) fn new(f: Faces<'a>) -> Self {
        let mut count = vec![0u32; f.nv + 1];
        for &v in f.idx {
            count[v as usize + 1] += 1;
        }
        for i in 0..f.nv {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut vf = vec![0u32; f.idx.len()];
        for g in 0..f.count() {
            for &v in f.face(g) {
                vf[fill[v as usize] as usize] = g as u32;
                fill[v as usize] += 1;
            }
        }
        let mut around = Around {
            f,
            vf_starts: count,
            vf,
            across: Vec::new(),
        };
        let mut across = vec![NONE; f.idx.len()];
        for g in 0..f.count() {
            let face = f.face(g);
            let k = face.len();
            for i in 0..k {
                let (a, b) = (face[i], face[(i + 1) % k]);
                across[f.starts[g] as usize + i] = around.find_across(g, a, b).unwrap_or(NONE);
            }
        }
        around.across = across;
        around
    }

    pub(super) fn face(&self, g: usize) -> &'a [u32] {
        self.f.face(g)
    }

    pub(super) fn faces_of(&self, v: usize) -> &[u32] {
        &self.vf[self.vf_starts[v] as usize..self.vf_starts[v + 1] as usize]
    }

    /// The neighbours of b by its faces: (previous, next) corner around each face.
    pub(super) fn ring(&self, b: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.faces_of(b as usize).iter().filter_map(move |&g| {
            let face = self.face(g as usize);
            let k = face.len();
            let p = face.iter().position(|&c| c == b)?;
            Some((face[(p + k - 1) % k], face[(p + 1) % k]))
        })
    }

    /// Around vertex b, seen from its neighbour a (SPEC.md 7.2): straight on (the one
    /// neighbour besides a, left and right, if there is one only), left (the corner
    /// before b in a face where a follows b) and right (the corner after b in a face
    /// where a precedes b); all none if a is not b's neighbour.
    pub(super) fn sides(&self, b: u32, a: u32) -> [Option<u32>; 3] {
        let (mut x, mut y) = (None, None);
        for (prev, next) in self.ring(b) {
            if next == a && x.is_none() {
                x = Some(prev);
            }
            if prev == a && y.is_none() {
                y = Some(next);
            }
        }
        if x.is_none() && y.is_none() {
            return [None; 3];
        }
        let mut straight = None;
        let mut others = 0;
        for (prev, next) in self.ring(b) {
            for w in [next, prev] {
                if w != a && Some(w) != x && Some(w) != y && Some(w) != straight {
                    straight = Some(w);
                    others += 1;
                }
            }
        }
        [straight.filter(|_| others == 1), x, y]
    }

    /// The first three neighbours of a not `met`, turning from `start` to the left (the
    /// corner before a in a face where the last one follows a), then, past a border,
    /// from `start` to the right.
    pub(super) fn fan(&self, a: u32, start: u32, met: &[bool]) -> [Option<u32>; 3] {
        let mut out = [None; 3];
        let mut n = 0;
        let limit = self.faces_of(a as usize).len() + 1;
        for side in [1, 2] {
            let mut at = start;
            for _ in 0..limit {
                let Some(next) = self.sides(a, at)[side] else {
                    break;
                };
                if next == start {
                    break;
                }
                if !met[next as usize] && !out.contains(&Some(next)) && n < 3 {
                    out[n] = Some(next);
                    n += 1;
                }
                at = next;
            }
        }
        out
    }

    /// The first face around corner v of face g that shares no edge with g.
    pub(super) fn diagonal(&self, g: u32, v: u32) -> Option<u32> {
        self.faces_of(v as usize)
            .iter()
            .copied()
            .find(|&h| h != g && !self.faces_meet(g, h))
    }

    /// Whether vertices a and b share an edge.
    pub(super) fn vertices_meet(&self, a: u32, b: u32) -> bool {
        self.ring(a).any(|(p, n)| p == b || n == b)
    }

    /// Whether face h is across an edge of face g.
    pub(super) fn faces_meet(&self, g: u32, h: u32) -> bool {
        let (a, b) = (self.f.starts[g as usize], self.f.starts[g as usize + 1]);
        self.across[a as usize..b as usize].contains(&h)
    }

    /// The neighbour of v with the smallest number.
    pub(super) fn first_neighbour(&self, v: u32) -> Option<u32> {
        self.ring(v).flat_map(|(p, n)| [p, n]).min()
    }

    /// The first face other than g around a with the edge {a, b} (a search).
    fn find_across(&self, g: usize, a: u32, b: u32) -> Option<u32> {
        self.faces_of(a as usize).iter().copied().find(|&h| {
            let face = self.face(h as usize);
            let k = face.len();
            h as usize != g
                && (0..k).any(|i| {
                    let (p, q) = (face[i], face[(i + 1) % k]);
                    (p == a && q == b) || (p == b && q == a)
                })
        })
    }

    /// The face across the edge {a, b} of face g: the first other face around a with
    /// that edge.
    pub(super) fn across(&self, g: usize, a: u32, b: u32) -> Option<u32> {
        let face = self.face(g);
        let k = face.len();
        let p = face.iter().position(|&c| c == a)?;
        let i = if face[(p + 1) % k] == b {
            p
        } else if face[(p + k - 1) % k] == b {
            (p + k - 1) % k
        } else {
            return None;
        };
        Some(self.across[self.f.starts[g] as usize + i]).filter(|&h| h != NONE)
    }

    /// The faces across edges e + 2, e + 1, e + 3 and e of face g (its corners listed
    /// from its first input corner; degree k, mod k), where e is its edge shared with
    /// face h, or 0.
    pub(super) fn across_from(&self, g: u32, corners: &[u32], h: Option<u32>) -> [Option<u32>; 4] {
        let k = corners.len();
        let edge = |i: usize| self.across(g as usize, corners[i % k], corners[(i + 1) % k]);
        let e = h
            .and_then(|h| (0..k).find(|&i| edge(i) == Some(h)))
            .unwrap_or(0);
        [2, 1, 3, 0].map(|d| edge(e + d))
    }
}

