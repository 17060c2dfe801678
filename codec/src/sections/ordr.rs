//! The ORDR section: the permutations from canonical vertex and face order back to the
//! input's, and the faces' first corners (SPEC.md 7). Two methods, the smaller kept:
//! three lists, where runs of consecutive indices cost a fraction of a bit each and the
//! rest is coded as a rank among the indices not yet used (close to log2(n!) bits for a
//! random order); or walks over the faces and then the vertices in the input's order,
//! each next one coded as which of a few predicted neighbours it is (straight on, turning,
//! the next row, the next vertex of the faces' corners), so that the orders exporters
//! write (rows, grids, Blender's subdivision order, first use) cost little.

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
}

impl<'a> Faces<'a> {
    fn count(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    fn face(&self, g: usize) -> &'a [u32] {
        &self.idx[self.starts[g] as usize..self.starts[g + 1] as usize]
    }
}

/// The faces around each vertex, which the walks' predictions step over.
struct Around<'a> {
    f: Faces<'a>,
    vf_starts: Vec<u32>,
    vf: Vec<u32>,
    /// Per corner i of face g (at `starts[g] + i`): the first other face around the
    /// corner's vertex with the edge from it to the next corner, or `NONE`.
    across: Vec<u32>,
}

/// No face.
const NONE: u32 = u32::MAX;

impl<'a> Around<'a> {
    fn new(f: Faces<'a>) -> Self {
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

    fn face(&self, g: usize) -> &'a [u32] {
        self.f.face(g)
    }

    fn faces_of(&self, v: usize) -> &[u32] {
        &self.vf[self.vf_starts[v] as usize..self.vf_starts[v + 1] as usize]
    }

    /// The neighbours of b by its faces: (previous, next) corner around each face.
    fn ring(&self, b: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.faces_of(b as usize).iter().filter_map(move |&g| {
            let face = self.face(g as usize);
            let k = face.len();
            let p = face.iter().position(|&c| c == b)?;
            Some((face[(p + k - 1) % k], face[(p + 1) % k]))
        })
    }

    /// Around vertex b, seen from its neighbour a (SPEC.md 7.1): straight on (the one
    /// neighbour besides a, left and right, if there is one only), left (the corner
    /// before b in a face where a follows b) and right (the corner after b in a face
    /// where a precedes b); all none if a is not b's neighbour.
    fn sides(&self, b: u32, a: u32) -> [Option<u32>; 3] {
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
    fn fan(&self, a: u32, start: u32, met: &[bool]) -> [Option<u32>; 3] {
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
    fn diagonal(&self, g: u32, v: u32) -> Option<u32> {
        self.faces_of(v as usize)
            .iter()
            .copied()
            .find(|&h| h != g && !self.faces_meet(g, h))
    }

    /// Whether vertices a and b share an edge.
    fn vertices_meet(&self, a: u32, b: u32) -> bool {
        self.ring(a).any(|(p, n)| p == b || n == b)
    }

    /// Whether face h is across an edge of face g.
    fn faces_meet(&self, g: u32, h: u32) -> bool {
        let (a, b) = (self.f.starts[g as usize], self.f.starts[g as usize + 1]);
        self.across[a as usize..b as usize].contains(&h)
    }

    /// The neighbour of v with the smallest number.
    fn first_neighbour(&self, v: u32) -> Option<u32> {
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
    fn across(&self, g: usize, a: u32, b: u32) -> Option<u32> {
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
    fn across_from(&self, g: u32, corners: &[u32], h: Option<u32>) -> [Option<u32>; 4] {
        let k = corners.len();
        let edge = |i: usize| self.across(g as usize, corners[i % k], corners[(i + 1) % k]);
        let e = h
            .and_then(|h| (0..k).find(|&i| edge(i) == Some(h)))
            .unwrap_or(0);
        [2, 1, 3, 0].map(|d| edge(e + d))
    }
}

/// Vertex walk slots (SPEC.md 7.1), the last one the escape.
const V_SLOTS: usize = 13;
/// Face walk slots (SPEC.md 7.2), the last one the escape.
const F_SLOTS: usize = 14;
/// First-corner slots (SPEC.md 7.2), the last one the escape.
const C_SLOTS: usize = 9;

/// A candidate: the item, and the item it steps from.
type Candidate = (Option<u32>, Option<u32>);

/// Whether two items are neighbours (vertices on an edge, faces across one).
type Adjacent<'a> = &'a dyn Fn(u32, u32) -> bool;

/// A walk over vertices or faces in the input's order (SPEC.md 7.1): the items met,
/// the previous item and the one it stepped from, the row start and the item after it,
/// the previous slot and a model per previous slot.
struct Walk {
    unused: Unused,
    met: Vec<bool>,
    taken: usize,
    prev: Option<u32>,
    from: Option<u32>,
    row: Option<u32>,
    row_next: Option<u32>,
    /// The row start before this row's.
    last_row: Option<u32>,
    slot: usize,
    models: Vec<AdaptiveModel>,
    /// The last item reached by the escape, and the model of the next one's distance.
    jumped: u32,
    jump: IntModel,
}

impl Walk {
    fn new(n: usize, slots: usize) -> Self {
        Walk {
            unused: Unused::new(n),
            met: vec![false; n],
            taken: 0,
            prev: None,
            from: None,
            row: None,
            row_next: None,
            last_row: None,
            slot: 0,
            models: (0..slots).map(|_| AdaptiveModel::new(slots)).collect(),
            jumped: 0,
            jump: IntModel::new(),
        }
    }

    /// The item after the previous one in canonical order (the first at the start).
    fn next_canonical(&self) -> Option<u32> {
        let n = self.met.len() as u32;
        self.prev
            .map_or(Some(0), |p| (p + 1 < n).then_some(p + 1))
            .filter(|_| n > 0)
    }

    /// Codes item x with the candidates `cands` (the escape after them).
    fn put(&mut self, e: &mut Encoder, cands: &[Candidate], x: u32, adjacent: Adjacent<'_>) {
        let escape = cands.len();
        // Of the slots that predict x, the one seen most often in this context (the
        // first on ties): the walk then keeps to one kind of step where several agree.
        let model = &self.models[self.slot];
        let slot = (0..escape)
            .filter(|&i| cands[i].0 == Some(x))
            .fold(None, |best: Option<usize>, i| match best {
                Some(b) if model.count_of(b) >= model.count_of(i) => Some(b),
                _ => Some(i),
            })
            .unwrap_or(escape);
        e.symbol(&mut self.models[self.slot], slot);
        if slot == escape {
            // The rank among the items not met, as a distance from the last escape's.
            let r = self.unused.rank(x as usize) as i64;
            let r0 = self.unused.rank(self.jumped as usize) as i64;
            e.int(&mut self.jump, r - r0);
            self.jumped = x;
        }
        let from = cands.get(slot).and_then(|&(_, f)| f);
        self.take(x, slot, from, adjacent);
    }

    /// Decodes an item, `candidate(slot)` giving a slot's candidate (only the decoded
    /// slot's is made); `escape` is the escape slot.
    fn get(
        &mut self,
        d: &mut Decoder,
        escape: usize,
        candidate: &dyn Fn(&Walk, usize) -> Candidate,
        adjacent: Adjacent<'_>,
    ) -> Result<u32> {
        let slot = d.symbol(&mut self.models[self.slot])?;
        let (x, from) = if slot == escape {
            let r0 = self.unused.rank(self.jumped as usize) as i64;
            let r = r0 + d.int(&mut self.jump)?;
            let left = (self.met.len() - self.taken) as i64;
            if !(0..left).contains(&r) {
                return Err(Error::corrupt(SECTION, "an escape past the items left"));
            }
            let x = self.unused.select(r as u64) as u32;
            self.jumped = x;
            (Some(x), None)
        } else {
            candidate(self, slot)
        };
        let x = x
            .filter(|&x| (x as usize) < self.met.len() && !self.met[x as usize])
            .ok_or_else(|| Error::corrupt(SECTION, "an item predicted twice or not at all"))?;
        self.take(x, slot, from, adjacent);
        Ok(x)
    }

    /// Takes item x, reached by `slot`: a step to a neighbour of the previous item
    /// keeps the row, any other item starts one. x steps from the item its slot steps
    /// from, else from the previous item if they are neighbours.
    fn take(&mut self, x: u32, slot: usize, from: Option<u32>, adjacent: Adjacent<'_>) {
        self.met[x as usize] = true;
        self.taken += 1;
        self.unused.remove(x as usize);
        let step = self.prev.is_some_and(|p| adjacent(p, x));
        if step {
            if self.row_next.is_none() {
                self.row_next = Some(x);
            }
        } else {
            self.last_row = self.row;
            self.row = Some(x);
            self.row_next = None;
        }
        self.from = from.or(self.prev.filter(|_| step));
        self.prev = Some(x);
        self.slot = slot;
    }
}


/// The vertex walk's slot groups (SPEC.md 7.1): the first slot of each, then the end.
const V_GROUPS: [usize; 7] = [0, 1, 4, 7, 8, 11, 12];
/// The face walk's slot groups (SPEC.md 7.2).
const F_GROUPS: [usize; 5] = [0, 1, 5, 9, 13];

/// The group of `slot` among `groups`' bounds.
fn group_of(groups: &[usize], slot: usize) -> usize {
    groups.iter().rposition(|&g| g <= slot).unwrap_or(0)
}

/// Every candidate of a walk whose group `k` gives `group(k)` (its slots in order).
fn all_candidates<const N: usize>(
    groups: &[usize],
    group: impl Fn(usize) -> [Candidate; 4],
) -> [Candidate; N] {
    let mut c = [(None, None); N];
    for k in 0..groups.len() - 1 {
        let g = group(k);
        for slot in groups[k]..groups[k + 1].min(N) {
            c[slot] = g[slot - groups[k]];
        }
    }
    c
}

/// The vertex walk's candidates of slot group k (SPEC.md 7.1).
fn vertex_group(
    w: &Walk,
    around: &Around<'_>,
    first_use: Option<u32>,
    k: usize,
) -> [Candidate; 4] {
    let mut c = [(None, None); 4];
    match k {
        // The canonical vertex after the previous one.
        0 => c[0].0 = w.next_canonical(),
        // Straight on, left and right of the previous vertex, seen from the vertex it
        // stepped from, else from its first neighbour; that first neighbour.
        1 | 3 => {
            if let Some(b) = w.prev {
                let first = around.first_neighbour(b);
                if k == 3 {
                    c[0] = (first.filter(|_| w.from.is_none()), Some(b));
                } else if let Some(a) = w.from.or(first) {
                    let [s, x, y] = around.sides(b, a);
                    c = [(s, Some(b)), (x, Some(b)), (y, Some(b)), (None, None)];
                }
            }
        }
        // Left, right and straight on of the row start, seen from the vertex after it;
        // the first three neighbours not met of the vertex behind the row start (where
        // the next run of edge points may start).
        2 | 4 => {
            if let (Some(r), Some(d)) = (w.row, w.row_next) {
                let [s, x, y] = around.sides(r, d);
                if k == 2 {
                    c = [(x, Some(r)), (y, Some(r)), (s, Some(r)), (None, None)];
                } else if let Some(a) = s {
                    for (j, v) in around.fan(a, r, &w.met).into_iter().enumerate() {
                        c[j] = (v, Some(a));
                    }
                }
            }
        }
        // The next vertex not met in the faces' corners, in the input's order.
        _ => c[0].0 = first_use,
    }
    c
}

/// The face walk's candidates of slot group k (SPEC.md 7.2); `corners(g)` lists face
/// g's corners from its first input corner.
fn face_group(
    w: &Walk,
    around: &Around<'_>,
    corners: &dyn Fn(u32) -> Vec<u32>,
    k: usize,
) -> [Candidate; 4] {
    let mut c = [(None, None); 4];
    match k {
        // The canonical face after the previous one.
        0 => c[0].0 = w.next_canonical(),
        // Across the previous face's edges e + 2, e + 1, e + 3, e (e: the edge shared
        // with the face it stepped from, else its first input edge).
        1 => {
            if let Some(p) = w.prev {
                c = around
                    .across_from(p, &corners(p), w.from)
                    .map(|g| (g, Some(p)));
            }
        }
        // Across the row start's edges e + 1, e + 3, e + 2, e (e: the edge shared with
        // the face after it).
        2 => {
            if let Some(r) = w.row {
                let [a2, a1, a3, a0] = around.across_from(r, &corners(r), w.row_next);
                c = [a1, a3, a2, a0].map(|g| (g, Some(r)));
            }
        }
        // The faces that meet the last row's start at its input corners 0-3 only.
        _ => {
            if let Some(r) = w.last_row {
                for (i, &v) in corners(r).iter().take(4).enumerate() {
                    c[i].0 = around.diagonal(r, v);
                }
            }
        }
    }
    c
}

/// Face corners listed from corner `first`.
fn rotated(face: &[u32], first: usize) -> Vec<u32> {
    let k = face.len();
    (0..k).map(|i| face[(first + i) % k]).collect()
}

/// The faces' walk, both ways: each face's first input corner (`firsts`, by canonical
/// face) and the models of the first corners.
struct FaceWalk<'a> {
    around: &'a Around<'a>,
    walk: Walk,
    firsts: Vec<usize>,
    corner_models: Vec<AdaptiveModel>,
    corner_slot: usize,
}

impl<'a> FaceWalk<'a> {
    fn new(around: &'a Around<'a>) -> Self {
        let nf = around.f.count();
        FaceWalk {
            around,
            walk: Walk::new(nf, F_SLOTS),
            firsts: vec![0; nf],
            corner_models: (0..C_SLOTS).map(|_| AdaptiveModel::new(C_SLOTS)).collect(),
            corner_slot: 0,
        }
    }

    fn corners(&self, g: u32) -> Vec<u32> {
        rotated(self.around.face(g as usize), self.firsts[g as usize])
    }

    /// The candidates for face g's first input corner (SPEC.md 7.2), g just taken:
    /// the corners 0-3 after g's edge shared with the face it stepped from, then the
    /// previous face's (`prev`) input corners 0-3.
    fn corner_candidates(&self, g: u32, prev: &[u32]) -> [Option<usize>; C_SLOTS - 1] {
        let face = self.around.face(g as usize);
        let k = face.len();
        let shared = self.walk.from.and_then(|h| {
            (0..k).find(|&i| {
                self.around.across(g as usize, face[i], face[(i + 1) % k]) == Some(h)
            })
        });
        std::array::from_fn(|i| match i {
            0..4 => shared.filter(|_| i < k).map(|j| (j + i) % k),
            _ => prev
                .get(i - 4)
                .and_then(|&v| face.iter().position(|&c| c == v)),
        })
    }

    fn put(&mut self, e: &mut Encoder, g: u32, first: usize) {
        let faces: [Candidate; F_SLOTS - 1] = all_candidates(&F_GROUPS, |k| {
            face_group(&self.walk, self.around, &|g| self.corners(g), k)
        });
        let prev = self.walk.prev.map(|g| self.corners(g)).unwrap_or_default();
        let around = self.around;
        self.walk.put(e, &faces, g, &|a, b| around.faces_meet(a, b));
        let corners = self.corner_candidates(g, &prev);
        let slot = corners
            .iter()
            .position(|&c| c == Some(first))
            .unwrap_or(C_SLOTS - 1);
        e.symbol(&mut self.corner_models[self.corner_slot], slot);
        if slot == C_SLOTS - 1 {
            e.uniform(first as u64, self.around.face(g as usize).len() as u64);
        }
        self.corner_slot = slot;
        self.firsts[g as usize] = first;
    }

    fn get(&mut self, d: &mut Decoder) -> Result<u32> {
        let prev = self.walk.prev.map(|g| self.corners(g)).unwrap_or_default();
        let around = self.around;
        let firsts = &self.firsts;
        let corners = |g: u32| rotated(around.face(g as usize), firsts[g as usize]);
        let candidate = |w: &Walk, slot: usize| {
            let k = group_of(&F_GROUPS, slot);
            face_group(w, around, &corners, k)[slot - F_GROUPS[k]]
        };
        let g = self.walk.get(d, F_SLOTS - 1, &candidate, &|a, b| {
            around.faces_meet(a, b)
        })?;
        let k = self.around.face(g as usize).len();
        let corners = self.corner_candidates(g, &prev);
        let slot = d.symbol(&mut self.corner_models[self.corner_slot])?;
        let first = if slot == C_SLOTS - 1 {
            Some(d.uniform(k.max(1) as u64)? as usize)
        } else {
            corners[slot]
        };
        self.corner_slot = slot;
        self.firsts[g as usize] = first
            .filter(|&f| f < k)
            .ok_or_else(|| Error::corrupt(SECTION, "a face's first corner not in the face"))?;
        Ok(g)
    }
}

/// The vertex walk over `nv` vertices, with the faces' corners in input order
/// (`corners`) for the first-use candidate.
struct VertexWalk<'a> {
    around: &'a Around<'a>,
    walk: Walk,
    corners: Vec<u32>,
    cursor: usize,
}

impl<'a> VertexWalk<'a> {
    fn new(around: &'a Around<'a>, nv: usize, corners: Vec<u32>) -> Self {
        VertexWalk {
            around,
            walk: Walk::new(nv, V_SLOTS),
            corners,
            cursor: 0,
        }
    }

    /// The next vertex not met in the faces' corners.
    fn first_use(&mut self) -> Option<u32> {
        let met = &self.walk.met;
        while self
            .corners
            .get(self.cursor)
            .is_some_and(|&c| met.get(c as usize) != Some(&false))
        {
            self.cursor += 1;
        }
        self.corners.get(self.cursor).copied()
    }

    fn put(&mut self, e: &mut Encoder, v: u32) {
        let first_use = self.first_use();
        let around = self.around;
        let cands: [Candidate; V_SLOTS - 1] = all_candidates(&V_GROUPS, |k| {
            vertex_group(&self.walk, around, first_use, k)
        });
        self.walk
            .put(e, &cands, v, &|a, b| around.vertices_meet(a, b));
    }

    fn get(&mut self, d: &mut Decoder) -> Result<u32> {
        let first_use = self.first_use();
        let around = self.around;
        let candidate = |w: &Walk, slot: usize| {
            let k = group_of(&V_GROUPS, slot);
            vertex_group(w, around, first_use, k)[slot - V_GROUPS[k]]
        };
        self.walk.get(d, V_SLOTS - 1, &candidate, &|a, b| {
            around.vertices_meet(a, b)
        })
    }
}

/// Codes a permutation `order[new] = old` of `0..order.len()` (SPEC.md 7.1).
fn put_perm(e: &mut Encoder, order: &[u32]) {
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
fn get_perm(d: &mut Decoder, n: usize) -> Result<Vec<u32>> {
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
/// `faces`: a method byte, then the order as three lists (method 0) or as walks
/// (method 1), whichever is smaller.
pub fn encode(o: &InputOrder, faces: Faces<'_>) -> Vec<u8> {
    let lists = encode_lists(o);
    let walks = encode_walks(o, faces);
    let (method, body) = if walks.len() < lists.len() {
        (1, walks)
    } else {
        (0, lists)
    };
    let mut out = Vec::with_capacity(body.len() + 1);
    out.push(method);
    out.extend_from_slice(&body);
    out
}

/// Decodes an ORDR section for the canonical `faces`.
pub fn decode(payload: &[u8], faces: Faces<'_>) -> Result<InputOrder> {
    match payload.split_first() {
        Some((0, body)) => {
            let degrees: Vec<u32> = faces.starts.windows(2).map(|w| w[1] - w[0]).collect();
            decode_lists(body, faces.nv, &degrees)
        }
        Some((1, body)) => decode_walks(body, faces),
        Some((m, _)) => Err(Error::corrupt(SECTION, format!("unknown method {m}"))),
        None => Err(Error::corrupt(SECTION, "empty payload")),
    }
}

/// Codes the order as walks over the faces, then the vertices (SPEC.md 7.2, method 1).
fn encode_walks(o: &InputOrder, faces: Faces<'_>) -> Vec<u8> {
    let around = Around::new(faces);
    let mut e = Encoder::new();
    let mut in_face = vec![0u32; o.faces.len()];
    for (c, &p) in o.faces.iter().enumerate() {
        in_face[p as usize] = c as u32;
    }
    let mut fw = FaceWalk::new(&around);
    for &g in &in_face {
        let k = around.face(g as usize).len().max(1);
        let first = (k - o.rotations[g as usize] as usize % k) % k;
        fw.put(&mut e, g, first);
    }
    let corners: Vec<u32> = in_face.iter().flat_map(|&g| fw.corners(g)).collect();
    let mut in_vert = vec![0u32; o.vertices.len()];
    for (c, &p) in o.vertices.iter().enumerate() {
        in_vert[p as usize] = c as u32;
    }
    let mut vw = VertexWalk::new(&around, o.vertices.len(), corners);
    for &v in &in_vert {
        vw.put(&mut e, v);
    }
    e.finish()
}

/// Decodes method 1 (SPEC.md 7.2).
fn decode_walks(payload: &[u8], faces: Faces<'_>) -> Result<InputOrder> {
    let (nv, nf) = (faces.nv, faces.count());
    let around = Around::new(faces);
    let mut d = Decoder::new(payload, SECTION)?;
    let mut fw = FaceWalk::new(&around);
    let mut in_face = Vec::with_capacity(nf);
    for _ in 0..nf {
        in_face.push(fw.get(&mut d)?);
    }
    let corners: Vec<u32> = in_face.iter().flat_map(|&g| fw.corners(g)).collect();
    let mut vw = VertexWalk::new(&around, nv, corners);
    let mut vertices = vec![0u32; nv];
    for i in 0..nv {
        let v = vw.get(&mut d)?;
        vertices[v as usize] = i as u32;
    }
    let mut faces_out = vec![0u32; nf];
    let mut rotations = vec![0u32; nf];
    for (p, &g) in in_face.iter().enumerate() {
        faces_out[g as usize] = p as u32;
        let k = around.face(g as usize).len().max(1);
        rotations[g as usize] = ((k - fw.firsts[g as usize]) % k) as u32;
    }
    Ok(InputOrder {
        vertices,
        faces: faces_out,
        rotations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// An n x n grid of quads, row-major, and its faces.
    fn grid(n: u32) -> (usize, Vec<u32>, Vec<u32>) {
        let t = crate::topology::fixtures::quad_grid(n);
        (t.nv, t.starts, t.idx)
    }

    fn shuffle(p: &mut [u32], seed: u64, swaps: usize) {
        let mut s = seed | 1;
        let n = p.len();
        for _ in 0..swaps {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            if n > 0 {
                p.swap((s % n as u64) as usize, ((s >> 20) % n as u64) as usize);
            }
        }
    }

    proptest! {
        /// Any vertex and face permutation and any rotations round-trip.
        #[test]
        fn orders_round_trip(n in 2u32..14, seed in proptest::num::u64::ANY, swaps in 0usize..300) {
            let (nv, starts, idx) = grid(n);
            let faces = Faces { nv, starts: &starts, idx: &idx };
            let mut vertices: Vec<u32> = (0..nv as u32).collect();
            shuffle(&mut vertices, seed, swaps);
            let nf = starts.len() - 1;
            let mut fo: Vec<u32> = (0..nf as u32).collect();
            shuffle(&mut fo, seed.rotate_left(17), swaps);
            let rotations = fo.iter().map(|&x| (x ^ seed as u32) % 4).collect();
            let o = InputOrder { vertices, faces: fo, rotations };
            let bytes = encode(&o, faces);
            prop_assert_eq!(&decode(&bytes, faces).unwrap(), &o);
            // Each method on its own.
            let mut walks = vec![1];
            walks.extend(encode_walks(&o, faces));
            prop_assert_eq!(&decode(&walks, faces).unwrap(), &o);
            let mut lists = vec![0];
            lists.extend(encode_lists(&o));
            prop_assert_eq!(&decode(&lists, faces).unwrap(), &o);
        }
    }

    /// The canonical order, a grid's rows walked from another corner (every row
    /// reversed, the faces' first corners turned), and vertices in order of first use
    /// cost a few bytes; a random order about log2(n!) bits.
    #[test]
    fn predictable_orders_are_nearly_free() {
        let n = 100u32;
        let (nv, starts, idx) = grid(n);
        let faces = Faces { nv, starts: &starts, idx: &idx };
        let nf = starts.len() - 1;
        let identity = InputOrder {
            vertices: (0..nv as u32).collect(),
            faces: (0..nf as u32).collect(),
            rotations: vec![0; nf],
        };
        // Rows reversed: vertex (x, y) is input vertex y * n + (n - 1 - x).
        let m = n - 1;
        let mirrored = InputOrder {
            vertices: (0..nv as u32).map(|v| v / n * n + (n - 1 - v % n)).collect(),
            faces: (0..nf as u32).map(|f| f / m * m + (m - 1 - f % m)).collect(),
            rotations: vec![1; nf],
        };
        // Vertices numbered by first use in the faces (PLY exporters with seams).
        let mut first_use = vec![u32::MAX; nv];
        let mut next = 0;
        for &v in &idx {
            if first_use[v as usize] == u32::MAX {
                first_use[v as usize] = next;
                next += 1;
            }
        }
        let by_use = InputOrder {
            vertices: first_use,
            ..identity.clone()
        };
        for (name, o) in [("identity", identity.clone()), ("mirrored", mirrored), ("first use", by_use)] {
            let bytes = encode(&o, faces);
            assert!(bytes.len() < 400, "{name}: {} bytes", bytes.len());
            assert_eq!(decode(&bytes, faces).unwrap(), o, "{name}");
        }
        let mut random = identity;
        shuffle(&mut random.vertices, 99, 100_000);
        let bytes = encode(&random, faces);
        let bound = (1..=nv).map(|i| (i as f64).log2()).sum::<f64>() / 8.0;
        assert!((bytes.len() as f64) < bound * 1.05 + 200.0, "{} vs {bound}", bytes.len());
        assert_eq!(decode(&bytes, faces).unwrap(), random);
    }

    /// Damaged payloads give errors or another order, never a panic.
    #[test]
    fn damaged_payloads_are_errors_not_panics() {
        let (nv, starts, idx) = grid(9);
        let faces = Faces { nv, starts: &starts, idx: &idx };
        let nf = starts.len() - 1;
        let mut vertices: Vec<u32> = (0..nv as u32).collect();
        shuffle(&mut vertices, 5, 40);
        let o = InputOrder {
            vertices,
            faces: (0..nf as u32).rev().collect(),
            rotations: (0..nf as u32).map(|x| x % 4).collect(),
        };
        let bytes = encode(&o, faces);
        for cut in 0..bytes.len() {
            let _ = decode(&bytes[..cut], faces);
        }
        for i in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[i / 8] ^= 1 << (i % 8);
            if let Ok(back) = decode(&b, faces) {
                let mut seen = vec![false; nv];
                for &v in &back.vertices {
                    assert!(!std::mem::replace(&mut seen[v as usize], true));
                }
            }
        }
    }
}
