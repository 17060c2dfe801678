//! Method 1 of ORDR (SPEC.md 7.2): walks over the faces and then the vertices in the
//! input's order, each next item coded as the slot of a prediction.

use super::around::Around;
use super::{Faces, InputOrder, Unused, SECTION};
use crate::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};

/// Vertex walk slots (SPEC.md 7.2), the last one the escape.
const V_SLOTS: usize = 13;
/// Face walk slots (SPEC.md 7.2), the last one the escape.
const F_SLOTS: usize = 14;
/// First-corner slots (SPEC.md 7.2), the last one the escape.
const C_SLOTS: usize = 9;

/// A candidate: the item, and the item it steps from.
type Candidate = (Option<u32>, Option<u32>);

/// Whether two items are neighbours (vertices on an edge, faces across one).
type Adjacent<'a> = &'a dyn Fn(u32, u32) -> bool;

/// A walk over vertices or faces in the input's order (SPEC.md 7.2): the items met,
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
    /// The last two slots, and how many slots there are.
    slot: usize,
    slot2: usize,
    slots: usize,
    /// Items in the current row, and in the one before (0 before the first).
    run: usize,
    last_run: usize,
    /// Per context ([`Walk::context`]), a model of the slots.
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
            slot2: 0,
            slots,
            run: 0,
            last_run: 0,
            models: (0..2 * slots * slots).map(|_| AdaptiveModel::new(slots)).collect(),
            jumped: 0,
            jump: IntModel::new(),
        }
    }

    /// The model of the next slot (SPEC.md 7.2): by the previous two slots, and whether
    /// the current row is as long as the one before (where grids' rows end).
    fn context(&self) -> usize {
        2 * (self.slot2 * self.slots + self.slot) + (self.run == self.last_run) as usize
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
        let ctx = self.context();
        let model = &self.models[ctx];
        let slot = (0..escape)
            .filter(|&i| cands[i].0 == Some(x))
            .fold(None, |best: Option<usize>, i| match best {
                Some(b) if model.count_of(b) >= model.count_of(i) => Some(b),
                _ => Some(i),
            })
            .unwrap_or(escape);
        e.symbol(&mut self.models[ctx], slot);
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
        let ctx = self.context();
        let slot = d.symbol(&mut self.models[ctx])?;
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
            self.run += 1;
        } else {
            self.last_row = self.row;
            self.row = Some(x);
            self.row_next = None;
            self.last_run = self.run;
            self.run = 1;
        }
        self.from = from.or(self.prev.filter(|_| step));
        self.prev = Some(x);
        self.slot2 = self.slot;
        self.slot = slot;
    }
}


/// The vertex walk's slot groups (SPEC.md 7.2): the first slot of each, then the end.
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

/// The vertex walk's candidates of slot group k (SPEC.md 7.2).
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
            corner_models: (0..C_SLOTS * F_SLOTS).map(|_| AdaptiveModel::new(C_SLOTS)).collect(),
            corner_slot: 0,
        }
    }

    /// The model of the face just taken's first corner (SPEC.md 7.2): by the previous
    /// face's corner slot and the slot the face was coded with.
    fn corner_context(&self) -> usize {
        self.corner_slot * F_SLOTS + self.walk.slot
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
        let ctx = self.corner_context();
        e.symbol(&mut self.corner_models[ctx], slot);
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
        let ctx = self.corner_context();
        let slot = d.symbol(&mut self.corner_models[ctx])?;
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

/// Codes the order as walks over the faces, then the vertices (SPEC.md 7.2, method 1).
pub(super) fn encode_walks(o: &InputOrder, faces: Faces<'_>) -> Vec<u8> {
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
pub(super) fn decode_walks(payload: &[u8], faces: Faces<'_>) -> Result<InputOrder> {
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

