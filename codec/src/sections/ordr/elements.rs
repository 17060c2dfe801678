//! Method 2 of ORDR (SPEC.md 7.3): the input's order as blocks of a Catmull-Clark
//! hierarchy's base elements. Every finest vertex belongs to one base element (a base
//! vertex, the inside of a base edge, the inside of a base face) and has a place in it;
//! every finest face lies in one base face. Exporters that write a subdivision surface
//! element by element (Blender: base vertices, then every base edge's points along it,
//! then every base face's inside, all levels at once) give one block per element, and
//! within a block the same order of places as the last block of its kind, turned: so
//! the order costs the element sequence and one turn per element.

use std::collections::HashMap;

use super::{get_perm, put_perm, Faces, InputOrder, Steps, Unused, OTHER, SECTION};
use crate::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::topology::{Family, Level, Topo};

/// Levels beyond which method 2 is not used (the places of a base edge, 2^L - 1, stay
/// far inside `u32`).
const MAX_LEVELS: u32 = 15;

/// The base mesh of the Catmull-Clark (SPEC.md 8.1), sqrt(2) (8.4) or polar (8.6)
/// hierarchy whose finest level the canonical faces are (methods 2 and 3 take
/// Catmull-Clark ones only).
#[derive(Debug, Clone, Copy)]
pub struct Hierarchy<'a> {
    /// Base vertices.
    pub nv: usize,
    /// Base face starts (one more than faces).
    pub starts: &'a [u32],
    /// Base corners.
    pub idx: &'a [u32],
    /// Refinement levels (at least 1).
    pub levels: u32,
    /// Catmull-Clark, polar or sqrt(2).
    pub family: Family,
    /// A polar hierarchy's poles (base vertices, SPEC.md 8.6); empty for the others.
    pub poles: &'a [u32],
}

/// Ways of numbering the base edges (SPEC.md 7.3): as 8.1 numbers them, or by a face
/// walk split into 1, 2, 4 or 8 parts.
const WALKS: usize = 5;

/// Faces of degree up to this have their turns coded with adaptive models; larger ones
/// uniformly.
const MAX_TURN_MODEL: usize = 16;

/// Element kinds, in the order of their numbers.
const KINDS: usize = 3;
const V: usize = 0;
const E: usize = 1;
const F: usize = 2;

/// The base elements of a hierarchy and their places (SPEC.md 7.3).
struct Elements {
    /// Base vertices, edges, faces.
    count: [usize; KINDS],
    /// Per element (vertices, then edges, then faces), where its points start in
    /// `points` (one more than elements).
    starts: Vec<usize>,
    /// Per element, its canonical vertices by place.
    points: Vec<u32>,
    /// Base face starts.
    base_starts: Vec<u32>,
    /// Per base corner, its face.
    corner_face: Vec<u32>,
    /// Finest faces per base corner: 4^(L - 1).
    per_corner: usize,
    /// Places of a base edge (2^L - 1) and of one corner's quarter of a base face
    /// (h (h - 1), h = 2^(L - 1)).
    edge_len: usize,
    quarter: usize,
    /// 2^L.
    side: i64,
    /// Base edges' ends, as first met.
    edges: Vec<[u32; 2]>,
    /// Per base corner, its edge to the next corner.
    face_edges: Vec<u32>,
    /// Per finest face, its place in its base face's block.
    face_place: Vec<u32>,
    /// Per base face block (from `base_starts[f] * per_corner`), its faces by place.
    face_at: Vec<u32>,
    /// Per finest face, its corner at the lowest coordinates of its base face's frame
    /// (a quad's, another face's quarter's): exporters start a face there.
    face_low: Vec<u8>,
}

impl Elements {
    /// The elements of `h`, whose finest level `faces` is; `None` when it is not.
    fn new(h: Hierarchy<'_>, faces: Faces<'_>) -> Option<Elements> {
        let l = h.levels;
        if !(1..=MAX_LEVELS).contains(&l) || h.family != Family::Cc {
            return None;
        }
        let topo = Topo {
            nv: h.nv,
            starts: h.starts.to_vec(),
            idx: h.idx.to_vec(),
        };
        let base = Level::new(&topo).ok()?;
        let s = 1i64 << l;
        let half = s / 2;
        let per_corner = 1usize << (2 * (l - 1));
        let corners = h.idx.len();
        if faces.count() != corners.checked_mul(per_corner)? {
            return None;
        }
        let edge_len = (s - 1) as usize;
        let quarter = (half * (half - 1)) as usize;
        let nf = topo.nf();
        let count = [h.nv, base.ne(), nf];
        let mut starts = Vec::with_capacity(count.iter().sum::<usize>() + 1);
        starts.push(0usize);
        let mut push = |n: usize| starts.push(starts.last().copied().unwrap_or(0) + n);
        (0..h.nv).for_each(|_| push(1));
        (0..base.ne()).for_each(|_| push(edge_len));
        for f in 0..nf {
            push(topo.face(f).len() * quarter + 1);
        }
        let total = *starts.last()?;
        if total != faces.nv {
            return None;
        }
        let mut points = vec![u32::MAX; total];
        (0..h.nv).for_each(|v| points[v] = v as u32);
        let mut corner_face = vec![0u32; corners];
        for f in 0..nf {
            corner_face[h.starts[f] as usize..h.starts[f + 1] as usize].fill(f as u32);
        }
        let first_face = h.nv + base.ne();
        let mut face_place = vec![0u32; faces.count()];
        let mut face_at = vec![u32::MAX; faces.count()];
        let mut face_low = vec![0u8; faces.count()];
        for g in 0..faces.count() {
            let face = faces.face(g);
            if face.len() != 4 {
                return None;
            }
            let bc = g / per_corner;
            let f = corner_face[bc] as usize;
            let st = h.starts[f] as usize;
            let (i, k) = (bc - st, h.starts[f + 1] as usize - st);
            // The face's corners in the frame of base corner i's quarter: the corner
            // at (0, 0), its edge's point at (h, 0), the face point at (h, h).
            let mut p = [[0, 0], [half, 0], [half, half], [0, half]];
            let q = g % per_corner;
            for d in (0..l - 1).rev() {
                let j = (q >> (2 * d)) & 3;
                let mid = |a: [i64; 2], b: [i64; 2]| [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2];
                p = [
                    p[j],
                    mid(p[j], p[(j + 1) % 4]),
                    mid(p[0], p[2]),
                    mid(p[(j + 3) % 4], p[j]),
                ];
            }
            // A quad's places are its grid's, row-major from corner 0 (the full
            // face's frame: corner 1 at (s, 0), corner 3 at (0, s)); another face's
            // are its quarters' in turn, each row-major in its frame.
            let full = |[u, v]: [i64; 2]| match i {
                0 => [u, v],
                1 => [s - v, u],
                2 => [s - u, s - v],
                _ => [v, s - u],
            };
            // The cell's place, and which of the face's corners is at its lowest
            // coordinates in the frame (a quad's, another face's quarter's).
            let c = if k == 4 { p.map(full) } else { p };
            let (x, y) = (c.iter().map(|c| c[0]).min()?, c.iter().map(|c| c[1]).min()?);
            let cell = if k == 4 {
                y * s + x
            } else {
                i as i64 * half * half + y * half + x
            };
            face_low[g] = c.iter().position(|&c| c == [x, y])? as u8;
            let at = st * per_corner + cell as usize;
            if face_at[at] != u32::MAX {
                return None;
            }
            face_at[at] = g as u32;
            face_place[g] = cell as u32;
            for (&w, &[u, v]) in face.iter().zip(&p) {
                let ci = h.idx[st + i];
                let (elem, place) = if u == 0 && v == 0 {
                    if w != ci {
                        return None;
                    }
                    (w as usize, 0)
                } else if u == 0 || v == 0 {
                    // On the base edge from corner i (v = 0) or into it (u = 0).
                    let (side, d) = if v == 0 { (i, u) } else { ((i + k - 1) % k, v) };
                    let e = base.face_edges[st + side] as usize;
                    let t = if base.edges[e][0] == ci { d } else { s - d };
                    (h.nv + e, (t - 1) as usize)
                } else if k == 4 {
                    let [x, y] = full([u, v]);
                    (first_face + f, ((y - 1) * (s - 1) + x - 1) as usize)
                } else if u == half && v == half {
                    (first_face + f, 0)
                } else {
                    // A point on the line to the previous corner's edge point is the
                    // previous quarter's.
                    let (i, u, v) = if v == half {
                        ((i + k - 1) % k, half, u)
                    } else {
                        (i, u, v)
                    };
                    let at = (v - 1) * half + (u - 1);
                    (first_face + f, 1 + i * quarter + at as usize)
                };
                let slot = &mut points[starts[elem] + place];
                if *slot != u32::MAX && *slot != w {
                    return None;
                }
                *slot = w;
            }
        }
        // Every place taken, by every vertex once.
        let mut seen = vec![false; total];
        for &w in &points {
            if w as usize >= total || std::mem::replace(&mut seen[w as usize], true) {
                return None;
            }
        }
        Some(Elements {
            count,
            starts,
            points,
            base_starts: h.starts.to_vec(),
            corner_face,
            per_corner,
            edge_len,
            quarter,
            side: s,
            edges: base.edges.clone(),
            face_edges: base.face_edges.clone(),
            face_place,
            face_at,
            face_low,
        })
    }

    fn kind(&self, elem: usize) -> (usize, usize) {
        let [nv, ne, _] = self.count;
        match elem {
            e if e < nv => (V, e),
            e if e < nv + ne => (E, e - nv),
            e => (F, e - nv - ne),
        }
    }

    fn element(&self, kind: usize, x: usize) -> usize {
        match kind {
            V => x,
            E => self.count[V] + x,
            _ => self.count[V] + self.count[E] + x,
        }
    }

    fn degree(&self, f: usize) -> usize {
        (self.base_starts[f + 1] - self.base_starts[f]) as usize
    }

    /// Template key of an element of `kind` (0 for an edge, its base face's degree for
    /// a face) and its turns: an edge's two directions, a face's corners.
    fn shape(&self, kind: usize, x: usize) -> (usize, usize) {
        match kind {
            E => (0, 2),
            _ => (self.degree(x), self.degree(x)),
        }
    }

    /// Place `a` of an element of `kind` (a face of degree `k`), turned by `r`: an
    /// edge's reversed, a face's `r` corners on.
    fn turn(&self, kind: usize, k: usize, a: u32, r: usize) -> u32 {
        let s = self.side;
        match (kind, k, a) {
            (E, _, a) if r == 1 => (self.edge_len - 1) as u32 - a,
            (E, _, a) => a,
            (_, 4, a) => {
                // Corner 0's quarter to corner 1's: (x, y) -> (s - y, x).
                let (mut x, mut y) = (a as i64 % (s - 1) + 1, a as i64 / (s - 1) + 1);
                for _ in 0..r {
                    (x, y) = (s - y, x);
                }
                ((y - 1) * (s - 1) + x - 1) as u32
            }
            (_, _, 0) => 0,
            (_, k, a) => {
                let x = a as usize - 1;
                (1 + ((x / self.quarter + r) % k) * self.quarter + x % self.quarter) as u32
            }
        }
    }

    /// The place of a finest face of a block of degree `k` at place `a`, turned by `r`.
    fn turn_face(&self, k: usize, a: u32, r: usize) -> u32 {
        let s = self.side;
        if k == 4 {
            let (mut x, mut y) = (a as i64 % s, a as i64 / s);
            for _ in 0..r {
                (x, y) = (s - 1 - y, x);
            }
            return (y * s + x) as u32;
        }
        let a = a as usize;
        (((a / self.per_corner + r) % k) * self.per_corner + a % self.per_corner) as u32
    }

    /// The places of a base face of degree `k`'s finest faces in the order Blender's
    /// subdivision writes them (SPEC.md 7.3): a quad's inner cells row-major, then its
    /// border from each corner; another face's quarters' inner cells, the cells along
    /// each quarter's line to the next, the cells at the face point, then each
    /// quarter's border cells along its edge and along the edge before.
    fn blender_faces(&self, k: usize) -> Vec<u32> {
        let s = self.side;
        let mut order = Vec::with_capacity(k * self.per_corner);
        if k == 4 {
            for y in 1..s - 1 {
                order.extend((1..s - 1).map(|x| y * s + x));
            }
            for c in 0..4 {
                order.extend((0..s - 1).map(|i| match c {
                    0 => i,
                    1 => i * s + s - 1,
                    2 => (s - 1) * s + s - 1 - i,
                    _ => (s - 1 - i) * s,
                }));
            }
        } else {
            let h = s / 2;
            let cell = |c: usize, x: i64, y: i64| c as i64 * h * h + y * h + x;
            for c in 0..k {
                for y in 1..h - 1 {
                    order.extend((1..h).map(|x| cell(c, x, y)));
                }
            }
            for c in 0..k {
                order.extend((1..h - 1).map(|row| cell((c + 1) % k, row, h - 1)));
            }
            if h >= 2 {
                order.extend((0..k).map(|c| cell(c, h - 1, h - 1)));
            }
            for c in 0..k {
                order.extend((0..h).map(|i| cell(c, i, 0)));
                order.extend((1..h).map(|i| cell(c, 0, i)));
            }
        }
        order.into_iter().map(|a| a as u32).collect()
    }

    /// The first order of a face block of degree `k` starting at finest face `first`:
    /// Blender's, every face from its corner at the lowest coordinates.
    fn first_face_order(&self, k: usize, first: usize) -> Vec<(u32, u32)> {
        self.blender_faces(k)
            .into_iter()
            .map(|a| {
                let low = self.face_low[self.face_at[first + a as usize] as usize] as u32;
                (a, (4 - low) % 4)
            })
            .collect()
    }

    fn size(&self, elem: usize) -> usize {
        self.starts[elem + 1] - self.starts[elem]
    }
}

/// The adaptive state both sides keep (SPEC.md 7.3).
struct State {
    kinds: Vec<AdaptiveModel>,
    prev_kind: usize,
    ids: [Ids; KINDS + 1],
    /// Whether a block's order is a turn of the last one of its shape: per kind, and
    /// for face blocks.
    same: [AdaptiveModel; KINDS + 1],
    places: HashMap<(usize, usize), Vec<u32>>,
    faces: HashMap<usize, Vec<(u32, u32)>>,
    /// A new face order's first corners, per previous face's in the block.
    rot: [AdaptiveModel; 4],
    /// An edge's turn against the one its ends' order among the base vertices met
    /// predicts (an exporter's edges run from its lower vertex, or from its higher).
    direction: AdaptiveModel,
    /// Per base vertex, when its element was met (`u32::MAX`: not yet).
    met_at: Vec<u32>,
    /// Faces' turns per (element or block, degree), degrees up to [`MAX_TURN_MODEL`].
    turns: HashMap<(usize, usize), AdaptiveModel>,
    /// How the edges' numbers are predicted (SPEC.md 7.3): 0 as numbered, `m > 0` in
    /// the order of a face walk split into `2^(m - 1)` parts by their lower ends.
    edge_walk: usize,
    /// Per edge, its number in that order, and per number its edge (made when the
    /// first edge block comes).
    edge_number: Vec<u32>,
    edge_of_number: Vec<u32>,
}

/// The numbers of one kind's items in the order met, coded as a permutation's values
/// are (SPEC.md 7.1: the last one's next, the last one plus either of the last two
/// steps other than 1, as when an exporter's order is the canonical one transposed or
/// paired), but a jump is an integer: its rank among those not yet met less the rank of
/// the last one's next.
struct Ids {
    step: Steps,
    jump: IntModel,
    unused: Unused,
    met: Vec<bool>,
    taken: usize,
}

impl Ids {
    fn new(n: usize) -> Self {
        Ids {
            step: Steps::new(),
            jump: IntModel::new(),
            unused: Unused::new(n),
            met: vec![false; n],
            taken: 0,
        }
    }

    fn left(&self) -> usize {
        self.met.len() - self.taken
    }

    /// The rank among those not yet met of the last one's next.
    fn next_rank(&self) -> i64 {
        self.unused.rank(((self.step.last + 1) as usize).min(self.met.len())) as i64
    }

    fn take(&mut self, x: usize, sym: usize) {
        self.met[x] = true;
        self.unused.remove(x);
        self.step.take(x as i64, sym);
        self.taken += 1;
    }

    fn put(&mut self, e: &mut Encoder, x: usize) {
        let sym = self.step.symbol_of(x as i64);
        e.symbol(self.step.model(), sym);
        if sym == OTHER {
            let jump = self.unused.rank(x) as i64 - self.next_rank();
            e.int(&mut self.jump, jump);
        }
        self.take(x, sym);
    }

    fn get(&mut self, d: &mut Decoder) -> Result<usize> {
        let sym = d.symbol(self.step.model())?;
        let x = match (sym, self.step.value(sym)) {
            (OTHER, _) => {
                let r = self.next_rank().saturating_add(d.int(&mut self.jump)?);
                if !(0..self.left() as i64).contains(&r) {
                    return Err(Error::corrupt(SECTION, "an element's rank out of range"));
                }
                self.unused.select(r as u64) as i64
            }
            (_, Some(x)) => x,
            _ => return Err(Error::corrupt(SECTION, "a step of no number yet")),
        };
        if !(0..self.met.len() as i64).contains(&x) || self.met[x as usize] {
            return Err(Error::corrupt(SECTION, "an element met twice"));
        }
        self.take(x as usize, sym);
        Ok(x as usize)
    }
}

impl State {
    fn new(el: &Elements) -> Self {
        State {
            kinds: (0..=KINDS).map(|_| AdaptiveModel::new(KINDS)).collect(),
            prev_kind: KINDS,
            ids: [
                Ids::new(el.count[V]),
                Ids::new(el.count[E]),
                Ids::new(el.count[F]),
                Ids::new(el.count[F]),
            ],
            same: std::array::from_fn(|_| AdaptiveModel::new(2)),
            places: HashMap::new(),
            faces: HashMap::new(),
            rot: std::array::from_fn(|_| AdaptiveModel::new(4)),
            direction: AdaptiveModel::new(2),
            met_at: vec![u32::MAX; el.count[V]],
            turns: HashMap::new(),
            edge_walk: 0,
            edge_number: Vec::new(),
            edge_of_number: Vec::new(),
        }
    }
}

impl State {
    /// The turn an edge's ends predict: 1 when its first end was met after its second.
    fn predicted(&self, el: &Elements, x: usize) -> usize {
        let [a, b] = el.edges[x];
        (self.met_at[a as usize] > self.met_at[b as usize]) as usize
    }

    /// The model of a face's turn (`which`: 0 a face element's, 1 a face block's) of
    /// degree `k`; `None` above [`MAX_TURN_MODEL`] (then uniform).
    fn turn_model(&mut self, which: usize, k: usize) -> Option<&mut AdaptiveModel> {
        (k <= MAX_TURN_MODEL).then(|| {
            self.turns
                .entry((which, k))
                .or_insert_with(|| AdaptiveModel::new(k))
        })
    }

    fn put_face_turn(&mut self, e: &mut Encoder, which: usize, k: usize, r: usize) {
        match self.turn_model(which, k) {
            Some(m) => e.symbol(m, r),
            None => e.uniform(r as u64, k as u64),
        }
    }

    fn get_face_turn(&mut self, d: &mut Decoder, which: usize, k: usize) -> Result<usize> {
        match self.turn_model(which, k) {
            Some(m) => d.symbol(m),
            None => Ok(d.uniform(k as u64)? as usize),
        }
    }

    /// Codes an element's turn (an edge's against its prediction).
    fn put_turn(&mut self, e: &mut Encoder, el: &Elements, kind: usize, x: usize, r: usize, turns: usize) {
        match kind {
            E => {
                let p = self.predicted(el, x);
                e.symbol(&mut self.direction, r ^ p);
            }
            _ => self.put_face_turn(e, 0, turns, r),
        }
    }

    fn get_turn(&mut self, d: &mut Decoder, el: &Elements, kind: usize, x: usize, turns: usize) -> Result<usize> {
        match kind {
            E => {
                let p = self.predicted(el, x);
                Ok(d.symbol(&mut self.direction)? ^ p)
            }
            _ => self.get_face_turn(d, 0, turns),
        }
    }

    /// The number an edge is coded as: its place in the walk `edge_walk` chooses
    /// (SPEC.md 7.3), made from the base vertices met so far when first asked.
    fn edge_numbers(&mut self, el: &Elements) {
        if !self.edge_number.is_empty() || self.edge_walk == 0 {
            return;
        }
        let mask = (1u32 << (self.edge_walk - 1)) - 1;
        let ne = el.count[E];
        // The faces' edges, each face from its last corner's edge, first met first;
        // then split by the lower of the ends' meeting ranks.
        let mut seen = vec![false; ne];
        let mut walk = Vec::with_capacity(ne);
        for f in 0..el.count[F] {
            let (st, k) = (el.base_starts[f] as usize, el.degree(f));
            for i in 0..k {
                let e = el.face_edges[st + (i + k - 1) % k] as usize;
                if !std::mem::replace(&mut seen[e], true) {
                    walk.push(e as u32);
                }
            }
        }
        let part = |e: u32| {
            let [a, b] = el.edges[e as usize];
            self.met_at[a as usize].min(self.met_at[b as usize]) & mask
        };
        walk.sort_by_key(|&e| part(e));
        let mut number = vec![0u32; ne];
        for (n, &e) in walk.iter().enumerate() {
            number[e as usize] = n as u32;
        }
        self.edge_number = number;
        self.edge_of_number = walk;
    }

    /// The number element `x` of `kind` is coded as.
    fn number(&mut self, el: &Elements, kind: usize, x: usize) -> usize {
        if kind == E && self.edge_walk > 0 {
            self.edge_numbers(el);
            return self.edge_number[x] as usize;
        }
        x
    }

    /// Decodes the number of an element of `kind`.
    fn get_id(&mut self, d: &mut Decoder, el: &Elements, kind: usize) -> Result<usize> {
        let n = self.ids[kind].get(d)?;
        if kind == E && self.edge_walk > 0 {
            self.edge_numbers(el);
            return Ok(self.edge_of_number[n] as usize);
        }
        Ok(n)
    }

    /// Notes when the element of kind `kind`, number `x`, just taken, was met.
    fn met(&mut self, kind: usize, x: usize) {
        if kind == V {
            self.met_at[x] = self.ids[V].taken as u32 - 1;
        }
    }
}

/// The turn of `template` that gives `seen` (the first), if any.
fn turn_of<T: PartialEq + Copy>(
    template: Option<&Vec<T>>,
    seen: &[T],
    turns: usize,
    turn: impl Fn(T, usize) -> T,
) -> Option<usize> {
    let t = template?;
    (0..turns).find(|&r| t.len() == seen.len() && t.iter().zip(seen).all(|(&a, &b)| turn(a, r) == b))
}

/// The smaller of methods 2 and 3 (method 2 on a tie) that codes `o` on the finest
/// level of `h`, with its method number; `None` when neither does.
pub(super) fn encode_by_elements(
    o: &InputOrder,
    faces: Faces<'_>,
    h: Hierarchy<'_>,
) -> Option<(u8, Vec<u8>)> {
    let el = Elements::new(h, faces)?;
    let by_blocks = (0..WALKS)
        .filter_map(|walk| encode_elements(&el, o, faces, walk))
        .min_by_key(|b| b.len())
        .map(|b| (2, b));
    let by_first_use = encode_first_use(&el, o, faces).map(|b| (3, b));
    match (by_blocks, by_first_use) {
        (Some(a), Some(b)) => Some(if b.1.len() < a.1.len() { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// Codes the order by elements (method 2); `None` when the input's order is not one
/// block per element, vertices and faces alike.
fn encode_elements(el: &Elements, o: &InputOrder, faces: Faces<'_>, walk: usize) -> Option<Vec<u8>> {
    let nv = faces.nv;
    let elements = el.starts.len() - 1;
    let mut of = vec![(0u32, 0u32); nv];
    for elem in 0..elements {
        for (place, &w) in el.points[el.starts[elem]..el.starts[elem + 1]].iter().enumerate() {
            of[w as usize] = (elem as u32, place as u32);
        }
    }
    let mut in_vert = vec![0u32; nv];
    for (c, &p) in o.vertices.iter().enumerate() {
        in_vert[p as usize] = c as u32;
    }
    let mut e = Encoder::new();
    let mut st = State::new(el);
    e.uniform(walk as u64, WALKS as u64);
    st.edge_walk = walk;
    let mut face_rank = vec![0u32; el.count[F]];
    let mut pos = 0;
    while pos < nv {
        let elem = of[in_vert[pos] as usize].0 as usize;
        let n = el.size(elem);
        let block = in_vert.get(pos..pos + n)?;
        let mut places = Vec::with_capacity(n);
        for &w in block {
            let (x, place) = of[w as usize];
            if x as usize != elem {
                return None;
            }
            places.push(place);
        }
        let (kind, x) = el.kind(elem);
        let number = st.number(el, kind, x);
        if st.ids[kind].met[number] {
            return None;
        }
        e.symbol(&mut st.kinds[st.prev_kind], kind);
        st.prev_kind = kind;
        if kind == F {
            face_rank[x] = st.ids[F].taken as u32;
        }
        st.ids[kind].put(&mut e, number);
        st.met(kind, x);
        if kind != V {
            let (key, turns) = el.shape(kind, x);
            let hit = turn_of(st.places.get(&(kind, key)), &places, turns, |a, r| {
                el.turn(kind, key, a, r)
            });
            e.symbol(&mut st.same[kind], hit.is_some() as usize);
            match hit {
                Some(r) => st.put_turn(&mut e, el, kind, x, r, turns),
                None => {
                    put_perm(&mut e, &places);
                    st.places.insert((kind, key), places);
                }
            }
        }
        pos += n;
    }
    // The faces: a block per base face, numbered by the rank of its inside.
    put_face_blocks(&mut e, &mut st, el, o, |f| face_rank[f] as usize)?;
    Some(e.finish())
}

/// What decoding method 2 or 3 starts from: the elements of `h` (which the faces must
/// be the finest level of), the decoder, the models.
fn start(
    method: u8,
    payload: &[u8],
    faces: Faces<'_>,
    h: Option<Hierarchy<'_>>,
) -> Result<(Elements, Decoder, State)> {
    let h = h.filter(|h| h.family == Family::Cc).ok_or_else(|| {
        Error::corrupt(SECTION, format!("method {method} without a Catmull-Clark hierarchy"))
    })?;
    let el = Elements::new(h, faces).ok_or_else(|| {
        Error::corrupt(SECTION, format!("method {method} on faces that are not the hierarchy's"))
    })?;
    let d = Decoder::new(payload, SECTION)?;
    let st = State::new(&el);
    Ok((el, d, st))
}

/// Decodes method 2 (SPEC.md 7.3).
pub(super) fn decode_elements(
    payload: &[u8],
    faces: Faces<'_>,
    h: Option<Hierarchy<'_>>,
) -> Result<InputOrder> {
    let (el, mut d, mut st) = start(2, payload, faces, h)?;
    st.edge_walk = d.uniform(WALKS as u64)? as usize;
    let nv = faces.nv;
    let mut vertices = vec![0u32; nv];
    let mut face_of_rank = Vec::with_capacity(el.count[F]);
    let mut pos = 0u32;
    for _ in 0..el.starts.len() - 1 {
        let kind = d.symbol(&mut st.kinds[st.prev_kind])?;
        st.prev_kind = kind;
        if st.ids[kind].left() == 0 {
            return Err(Error::corrupt(SECTION, "more elements of a kind than the mesh has"));
        }
        let x = st.get_id(&mut d, &el, kind)?;
        st.met(kind, x);
        if kind == F {
            face_of_rank.push(x);
        }
        let elem = el.element(kind, x);
        let points = &el.points[el.starts[elem]..el.starts[elem + 1]];
        let places: Vec<u32> = if kind == V {
            vec![0]
        } else {
            let (key, turns) = el.shape(kind, x);
            if d.symbol(&mut st.same[kind])? == 1 {
                if !st.places.contains_key(&(kind, key)) {
                    return Err(Error::corrupt(SECTION, "a turn of no order met"));
                }
                let r = st.get_turn(&mut d, &el, kind, x, turns)?;
                let t = &st.places[&(kind, key)];
                t.iter().map(|&a| el.turn(kind, key, a, r)).collect()
            } else {
                let p = get_perm(&mut d, points.len())?;
                st.places.insert((kind, key), p.clone());
                p
            }
        };
        if places.len() != points.len() {
            return Err(Error::corrupt(SECTION, "an element's order of the wrong size"));
        }
        for &a in &places {
            vertices[points[a as usize] as usize] = pos;
            pos += 1;
        }
    }
    let (forder, rotations) = get_face_blocks(&mut d, &mut st, &el, faces.count(), |r| {
        face_of_rank.get(r).copied()
    })?;
    Ok(InputOrder {
        vertices,
        faces: forder,
        rotations,
    })
}

/// Codes the faces in input order as blocks, one per base face (SPEC.md 7.3), each
/// numbered `number(f)`; `None` when they are not such blocks.
fn put_face_blocks(
    e: &mut Encoder,
    st: &mut State,
    el: &Elements,
    o: &InputOrder,
    number: impl Fn(usize) -> usize,
) -> Option<()> {
    let nfaces = o.faces.len();
    let mut in_face = vec![0u32; nfaces];
    for (c, &p) in o.faces.iter().enumerate() {
        in_face[p as usize] = c as u32;
    }
    let mut pos = 0;
    while pos < nfaces {
        let g = in_face[pos] as usize;
        let f = el.corner_face[g / el.per_corner] as usize;
        let k = el.degree(f);
        let first = el.base_starts[f] as usize * el.per_corner;
        let block = in_face.get(pos..pos + k * el.per_corner)?;
        let mut seen = Vec::with_capacity(block.len());
        for &c in block {
            let c = c as usize;
            if !(first..first + block.len()).contains(&c) || o.rotations[c] >= 4 {
                return None;
            }
            seen.push((el.face_place[c], o.rotations[c]));
        }
        if st.ids[KINDS].met[number(f)] {
            return None;
        }
        st.ids[KINDS].put(e, number(f));
        st.faces
            .entry(k)
            .or_insert_with(|| el.first_face_order(k, first));
        let hit = turn_of(st.faces.get(&k), &seen, k, |(a, rot), r| {
            (el.turn_face(k, a, r), rot)
        });
        e.symbol(&mut st.same[KINDS], hit.is_some() as usize);
        match hit {
            Some(r) => st.put_face_turn(e, 1, k, r),
            None => {
                let order: Vec<u32> = seen.iter().map(|s| s.0).collect();
                put_perm(e, &order);
                let mut prev = 0;
                for (&(_, rot), &c) in seen.iter().zip(block) {
                    let r = (rot as usize + el.face_low[c as usize] as usize) % 4;
                    e.symbol(&mut st.rot[prev], r);
                    prev = r;
                }
                st.faces.insert(k, seen);
            }
        }
        pos += block.len();
    }
    Some(())
}

/// Decodes the face blocks of [`put_face_blocks`]: the base face of each number from
/// `face_of`.
fn get_face_blocks(
    d: &mut Decoder,
    st: &mut State,
    el: &Elements,
    nfaces: usize,
    face_of: impl Fn(usize) -> Option<usize>,
) -> Result<(Vec<u32>, Vec<u32>)> {
    let mut forder = vec![0u32; nfaces];
    let mut rotations = vec![0u32; nfaces];
    let mut pos = 0u32;
    for _ in 0..el.count[F] {
        let number = st.ids[KINDS].get(d)?;
        let f = face_of(number)
            .ok_or_else(|| Error::corrupt(SECTION, "a face block of no base face"))?;
        let k = el.degree(f);
        let first = el.base_starts[f] as usize * el.per_corner;
        let n = k * el.per_corner;
        st.faces
            .entry(k)
            .or_insert_with(|| el.first_face_order(k, first));
        let seen: Vec<(u32, u32)> = if d.symbol(&mut st.same[KINDS])? == 1 {
            let r = st.get_face_turn(d, 1, k)?;
            st.faces[&k]
                .iter().map(|&(a, rot)| (el.turn_face(k, a, r), rot)).collect()
        } else {
            let order = get_perm(d, n)?;
            let mut s = Vec::with_capacity(n);
            let mut prev = 0;
            for a in order {
                prev = d.symbol(&mut st.rot[prev])?;
                let c = el.face_at[first + a as usize] as usize;
                let low = el.face_low[c] as usize;
                s.push((a, ((prev + 4 - low) % 4) as u32));
            }
            st.faces.insert(k, s.clone());
            s
        };
        if seen.len() != n {
            return Err(Error::corrupt(SECTION, "a face block of the wrong size"));
        }
        for (a, rot) in seen {
            let c = el.face_at[first + a as usize] as usize;
            forder[c] = pos;
            rotations[c] = rot;
            pos += 1;
        }
    }
    Ok((forder, rotations))
}

/// The vertices in order of first use by the faces in input order, each face's corners
/// from its first input corner, then those no face uses in canonical order (SPEC.md
/// 7.4): `vertices[c]`, the input number of canonical vertex c.
fn first_use(faces: Faces<'_>, forder: &[u32], rotations: &[u32]) -> Vec<u32> {
    let mut in_face = vec![0u32; forder.len()];
    for (c, &p) in forder.iter().enumerate() {
        in_face[p as usize] = c as u32;
    }
    let mut vertices = vec![u32::MAX; faces.nv];
    let mut next = 0u32;
    for &c in &in_face {
        let face = faces.face(c as usize);
        let k = face.len();
        let first = (k - rotations[c as usize] as usize % k) % k;
        for i in 0..k {
            let v = face[(first + i) % k] as usize;
            if vertices[v] == u32::MAX {
                vertices[v] = next;
                next += 1;
            }
        }
    }
    for v in vertices.iter_mut().filter(|v| **v == u32::MAX) {
        *v = next;
        next += 1;
    }
    vertices
}

/// Codes the order as face blocks, the vertices by first use (method 3); `None` when
/// the input's order is not so.
fn encode_first_use(el: &Elements, o: &InputOrder, faces: Faces<'_>) -> Option<Vec<u8>> {
    if first_use(faces, &o.faces, &o.rotations) != o.vertices {
        return None;
    }
    let mut e = Encoder::new();
    let mut st = State::new(el);
    put_face_blocks(&mut e, &mut st, el, o, |f| f)?;
    Some(e.finish())
}

/// Decodes method 3 (SPEC.md 7.4).
pub(super) fn decode_first_use(
    payload: &[u8],
    faces: Faces<'_>,
    h: Option<Hierarchy<'_>>,
) -> Result<InputOrder> {
    let (el, mut d, mut st) = start(3, payload, faces, h)?;
    let nf = el.count[F];
    let (forder, rotations) =
        get_face_blocks(&mut d, &mut st, &el, faces.count(), |f| (f < nf).then_some(f))?;
    Ok(InputOrder {
        vertices: first_use(faces, &forder, &rotations),
        faces: forder,
        rotations,
    })
}

/// Per point inside the base face 0 of `h`: its vertex and place (the tests').
#[cfg(test)]
pub(super) fn tests_places(h: Hierarchy<'_>, faces: Faces<'_>) -> Option<Vec<(u32, u32)>> {
    let el = Elements::new(h, faces)?;
    let f0 = el.element(F, 0);
    Some(
        el.points[el.starts[f0]..el.starts[f0 + 1]]
            .iter()
            .enumerate()
            .map(|(p, &w)| (w, p as u32))
            .collect(),
    )
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::{decode, encode};
    use super::*;

    /// A quad, a triangle and a pentagon side by side, refined `levels` times: the base
    /// and the finest faces.
    pub(in super::super) fn hierarchy(levels: u32) -> (Topo, Topo) {
        let mut base = Topo::new(8);
        base.idx = vec![0, 1, 2, 3, 1, 4, 2, 4, 5, 6, 7, 2];
        base.starts = vec![0, 4, 7, 12];
        let mut level = Level::new(&base).unwrap();
        for _ in 1..levels {
            level = level.next();
        }
        (base, level.fine())
    }

    /// Blender's order of [`hierarchy`] (README of the shared Blender files, SPEC.md
    /// 7.3): base vertices, base edges as its edge table lists them (the faces' edges,
    /// each face from its last corner's, in two tables by the lower end's parity), each
    /// from its lower end, base faces' insides, then the finest faces base face by base
    /// face, a quad's inner cells row by row and then its border round from corner 0,
    /// every face from its corner at the lowest coordinates.
    fn blender_order(el: &Elements, fine: &Topo) -> InputOrder {
        let mut edges: Vec<usize> = Vec::new();
        for f in 0..el.count[F] {
            let (st, k) = (el.base_starts[f] as usize, el.degree(f));
            for i in 0..k {
                let e = el.face_edges[st + (i + k - 1) % k] as usize;
                if !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        edges.sort_by_key(|&e| el.edges[e][0].min(el.edges[e][1]) & 1);
        let mut vertices = vec![u32::MAX; fine.nv];
        let mut pos = 0;
        let mut put = |elem: usize, turn: usize, kind: usize| {
            for p in 0..el.size(elem) as u32 {
                let p = if kind == E { el.turn(E, 0, p, turn) } else { p };
                vertices[el.points[el.starts[elem] + p as usize] as usize] = pos;
                pos += 1;
            }
        };
        (0..el.count[V]).for_each(|v| put(el.element(V, v), 0, V));
        for &e in &edges {
            put(el.element(E, e), (el.edges[e][0] > el.edges[e][1]) as usize, E);
        }
        (0..el.count[F]).for_each(|f| put(el.element(F, f), 0, F));
        let mut forder = vec![u32::MAX; fine.nf()];
        let mut rotations = vec![0; fine.nf()];
        let mut pos = 0;
        let s = el.side;
        for f in 0..el.count[F] {
            let k = el.degree(f);
            let first = el.base_starts[f] as usize * el.per_corner;
            let places: Vec<u32> = if k == 4 {
                let mut cells: Vec<i64> = (1..s - 1)
                    .flat_map(|y| (1..s - 1).map(move |x| y * s + x))
                    .collect();
                // The border, walked from (0, 0) along +x, +y, -x, -y.
                let (mut x, mut y) = (0i64, 0i64);
                for (dx, dy) in [(1, 0), (0, 1), (-1, 0), (0, -1)] {
                    for _ in 0..s - 1 {
                        cells.push(y * s + x);
                        (x, y) = (x + dx, y + dy);
                    }
                }
                cells.into_iter().map(|c| c as u32).collect()
            } else {
                el.blender_faces(k)
            };
            for a in places {
                let c = el.face_at[first + a as usize] as usize;
                forder[c] = pos;
                rotations[c] = (4 - el.face_low[c] as u32) % 4;
                pos += 1;
            }
        }
        assert!(!vertices.contains(&u32::MAX) && !forder.contains(&u32::MAX));
        InputOrder {
            vertices,
            faces: forder,
            rotations,
        }
    }

    #[test]
    fn blenders_order_costs_a_few_bytes() {
        for levels in 1..=3u32 {
            let (base, fine) = hierarchy(levels);
            let h = view(&base, levels, Family::Cc, &[]);
            let faces = faces_of(&fine, Some(h));
            let el = Elements::new(h, faces).expect("the finest level's elements");
            let o = blender_order(&el, &fine);
            let sizes: Vec<usize> = (0..WALKS)
                .map(|w| {
                    let body = encode_elements(&el, &o, faces, w).expect("blocks");
                    assert_eq!(decode_elements(&body, faces, Some(h)).unwrap(), o);
                    body.len()
                })
                .collect();
            eprintln!("{levels} levels: {sizes:?}");
            // Two tables of edges (the walk's parts by parity) are Blender's; every
            // face block is its order (nothing but the turns' symbols).
            let least = sizes.iter().min().unwrap();
            assert_eq!(sizes[2], *least, "{levels} levels: {sizes:?}");
            // (ANS streams, SPEC.md 4.1, end with their 16-bit start state: 2 bytes.)
            assert!(sizes[2] <= 14, "{levels} levels: {sizes:?}");
            let bytes = encode(&o, faces);
            assert_eq!(decode(&bytes, faces).unwrap(), o);
            assert_eq!(bytes[0], 2, "{levels} levels: method {}", bytes[0]);
        }
    }

    /// The ORDR view of `base` refined `levels` times as a `family` hierarchy with
    /// `poles`.
    pub(in super::super) fn view<'a>(base: &'a Topo, levels: u32, family: Family, poles: &'a [u32]) -> Hierarchy<'a> {
        Hierarchy {
            nv: base.nv,
            starts: &base.starts,
            idx: &base.idx,
            levels,
            family,
            poles,
        }
    }

    /// The finest faces `fine` of `h`, as ORDR sees them.
    pub(in super::super) fn faces_of<'a>(fine: &'a Topo, h: Option<Hierarchy<'a>>) -> Faces<'a> {
        Faces {
            nv: fine.nv,
            starts: &fine.starts,
            idx: &fine.idx,
            hierarchy: h,
        }
    }

    /// A xorshift step.
    fn next(x: &mut u64) -> u64 {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        *x
    }

    #[test]
    fn element_blocks_round_trip_and_cost_little() {
        for levels in 1..=3u32 {
            check(levels, 0x9e37_79b9_7f4a_7c15u64 ^ levels as u64, true);
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
        /// Any shuffle and any turns round-trip, by methods 2 and 3 and as chosen.
        #[test]
        fn element_orders_round_trip(levels in 1u32..=3, seed in proptest::num::u64::ANY) {
            check(levels, seed, false);
        }
    }

    /// Orders of [`hierarchy`]'s elements made from `seed`: each method's round trip,
    /// cuts and flips; with `sizes`, which method the encoder keeps.
    fn check(levels: u32, seed: u64, sizes: bool) {
        {
            let (base, fine) = hierarchy(levels);
            let h = view(&base, levels, Family::Cc, &[]);
            let faces = faces_of(&fine, Some(h));
            let el = Elements::new(h, faces).expect("the finest level's elements");
            let mut seed = seed | 1;
            // Elements in a shuffled order (kinds mixed), each block its shape's places
            // turned at random; face blocks likewise, each face's rotation that of its
            // place before the turn.
            // Kinds in turn, each kind's numbers in a stride's order (an exporter's
            // order the canonical one transposed) at 2 levels, shuffled at 3.
            let n = el.starts.len() - 1;
            let mut order: Vec<usize> = Vec::with_capacity(n);
            for kind in [V, E, F] {
                let m = el.count[kind];
                let mut ids: Vec<usize> = (0..3)
                    .flat_map(|r| (r..m).step_by(3))
                    .collect();
                if levels == 3 {
                    for i in (1..m).rev() {
                        ids.swap(i, next(&mut seed) as usize % (i + 1));
                    }
                }
                order.extend(ids.into_iter().map(|x| el.element(kind, x)));
            }
            let mut vertices = vec![u32::MAX; fine.nv];
            let mut pos = 0;
            for &elem in &order {
                let (kind, x) = el.kind(elem);
                let (k, turns) = if kind == V { (0, 1) } else { el.shape(kind, x) };
                let r = next(&mut seed) as usize % turns;
                for p in 0..el.size(elem) as u32 {
                    let p = if kind == V { p } else { el.turn(kind, k, p, r) };
                    vertices[el.points[el.starts[elem] + p as usize] as usize] = pos;
                    pos += 1;
                }
            }
            let nf = el.count[F];
            let mut blocks: Vec<usize> = (0..nf).collect();
            for i in (1..nf).rev() {
                blocks.swap(i, next(&mut seed) as usize % (i + 1));
            }
            let mut forder = vec![u32::MAX; fine.nf()];
            let mut rotations = vec![0; fine.nf()];
            let mut pos = 0;
            for &f in &blocks {
                let k = el.degree(f);
                let r = next(&mut seed) as usize % k;
                let first = el.base_starts[f] as usize * el.per_corner;
                for p in 0..(k * el.per_corner) as u32 {
                    let c = el.face_at[first + el.turn_face(k, p, r) as usize] as usize;
                    forder[c] = pos;
                    rotations[c] = p % 4;
                    pos += 1;
                }
            }
            assert!(!vertices.contains(&u32::MAX) && !forder.contains(&u32::MAX));
            let o = InputOrder {
                vertices,
                faces: forder,
                rotations,
            };
            let body = encode_elements(&el, &o, faces, 0).expect("blocks of elements");
            assert_eq!(decode_elements(&body, faces, Some(h)).unwrap(), o);
            // Walks pay an escape at most blocks; here a block costs its number and
            // turn (and each shape's first order once), and the smallest is kept
            // (shuffled numbers cost about what the walks' escapes do).
            let walks = super::super::walks::encode_walks(&o, faces).len();
            assert!(!sizes || levels != 2 || body.len() < walks, "{levels}: {} B, walks {walks} B", body.len());
            let bytes = encode(&o, faces);
            if sizes && levels == 2 {
                assert_eq!(bytes[0], 2, "{levels} levels: method {}", bytes[0]);
            }
            assert_eq!(decode(&bytes, faces).unwrap(), o, "{levels} levels");
            // Without the hierarchy, method 2 is corrupt; a cut or flipped payload
            // is an error or an order, never a panic.
            let flat = Faces {
                hierarchy: None,
                ..faces
            };
            assert_eq!(decode(&bytes, flat).is_err(), bytes[0] >= 2);
            for cut in 1..bytes.len() {
                let _ = decode(&bytes[..cut], faces);
            }
            for bit in 8..bytes.len() * 8 {
                let mut b = bytes.clone();
                b[bit / 8] ^= 1 << (bit % 8);
                let _ = decode(&b, faces);
            }
            // The same faces with the vertices numbered by first use (a PLY cut at
            // its seams): method 3, the vertices for free.
            let fu = InputOrder {
                vertices: first_use(faces, &o.faces, &o.rotations),
                ..o.clone()
            };
            let body3 = encode_first_use(&el, &fu, faces).expect("face blocks");
            assert_eq!(decode_first_use(&body3, faces, Some(h)).unwrap(), fu);
            let bytes3 = encode(&fu, faces);
            if sizes && levels > 1 {
                assert_eq!(bytes3[0], 3, "{levels} levels: method {}", bytes3[0]);
                assert!(body3.len() < body.len(), "{levels} levels");
            }
            assert_eq!(decode(&bytes3, faces).unwrap(), fu);
            for bit in 8..bytes3.len() * 8 {
                let mut b = bytes3.clone();
                b[bit / 8] ^= 1 << (bit % 8);
                let _ = decode(&b, faces);
            }
            assert!(encode_first_use(&el, &o, faces).is_none() || o.vertices == fu.vertices);
            // An order that is no blocks of elements is coded otherwise.
            let mut shuffled = o.clone();
            let (edge, face) = (el.element(E, 0), el.element(F, 0));
            let (a, b) = (el.points[el.starts[edge]], el.points[el.starts[face] + 1]);
            shuffled.vertices.swap(a as usize, b as usize);
            // (With one level an edge and a quad hold one point each: still blocks.)
            assert_eq!(encode_elements(&el, &shuffled, faces, 1).is_none(), levels > 1);
            assert_eq!(decode(&encode(&shuffled, faces), faces).unwrap(), shuffled);
        }
    }
}
