//! The sqrt(2) transforms (SPEC.md 9.6-9.8): `sqrt2-lazy`, `ir2w` and `sqrt2-sym` on the
//! levels of a sqrt(2) hierarchy (its refinement and recovery: [`crate::topology::sqrt2`]).
//!
//! One sqrt(2) step keeps every coarse vertex and inserts one face point per coarse face;
//! the fine faces are the quads (a, f2, b, f1), one per coarse edge a-b, f1 being the face
//! with the directed edge a -> b. The coarse adjacency is a [`Level`]; fine vertex
//! `nv + f` is face `f`'s point. Only closed meshes are sqrt(2) hierarchies here (SPEC.md
//! 8.4: with a boundary the refinement needs triangles and a second boundary rule).
//!
//! Like the Catmull-Clark transforms, every step but one changes one class from the
//! other: synthesis undoes analysis exactly for any weights. The exception is
//! `sqrt2-sym`'s 16/13 scaling, an injective rounding inverted exactly (SPEC.md 9.8).

#[cfg(any(test, feature = "reference"))]
pub mod solve;
pub mod tables;

use crate::topology::{Level, Topo, NONE};
use crate::transform::phase::{phase, Phases};
use crate::transform::{Sample, Wavelet};
use crate::topology::rings::Rings;

/// Largest valence with its own weights in the frozen tables.
pub const TABLE_MAX: usize = 16;

/// Fixed-point scale of the table weights.
const ONE: i128 = 1 << 16;

/// Weighted sums, precomputed once per level and transform: `targets[i]` gets
/// `sum(w * x[src]) / den[i]` (CSR rows).
#[derive(Debug, Default, Clone)]
struct Rows {
    starts: Vec<u32>,
    src: Vec<u32>,
    w: Vec<i32>,
    den: Vec<i64>,
}

impl Rows {
    fn new() -> Rows {
        Rows {
            starts: vec![0],
            ..Default::default()
        }
    }

    fn push(&mut self, den: i64) {
        self.starts.push(self.src.len() as u32);
        self.den.push(den);
    }

    /// Gives back the room the rows grew into (they stay for the level's transform).
    fn shrink(&mut self) {
        self.starts.shrink_to_fit();
        self.src.shrink_to_fit();
        self.w.shrink_to_fit();
        self.den.shrink_to_fit();
    }

    fn term(&mut self, src: u32, w: i32) {
        self.src.push(src);
        self.w.push(w);
    }

    #[inline]
    fn eval<T: Sample>(&self, i: usize, x: &[T]) -> T {
        let mut s = T::Acc::default();
        for k in self.starts[i] as usize..self.starts[i + 1] as usize {
            s += x[self.src[k] as usize].weighted(self.w[k] as i128);
        }
        T::round(s, self.den[i] as i128)
    }
}

/// The precomputed steps of one transform on one level. The codec takes a plan for
/// sqrt2-sym only: sqrt2-lazy and ir2w go through passes of their own
/// ([`predictions_with`], [`ir2w_analyse`], [`ir2w_synthesise`]), and their plans, with
/// the gathered rows, are the reference the tests hold those passes to.
pub struct Plan<'a> {
    nv: usize,
    nf: usize,
    wavelet: Wavelet,
    /// Prediction of each face point from the coarse vertices (lazy, ir2w).
    predict: Rows,
    /// ir2w: per coarse vertex, its update from the face points' details.
    update: Rows,
    /// The level (sqrt2-sym reads its faces and its vertices' face lists as it goes,
    /// rather than storing rows beside them).
    level: &'a Level,
    /// sqrt2-sym on a level without per-vertex lists (the encoder's sqrt(2) levels
    /// free them): its vertices' face lists, made for the transform (CSR).
    vert_faces: Option<(Vec<u32>, Vec<u32>)>,
}

/// Valences (ring lengths) and the neighbour of corner `c` at ring offset `j`.
struct Neighbours<'a> {
    rings: &'a Rings,
    topo: &'a Topo,
}

impl Neighbours<'_> {
    fn valence(&self, v: u32) -> usize {
        self.rings.of(v as usize).len()
    }

    /// `p_{i,j}` of corner `c` (SPEC.md 8.4): ring of the corner's vertex from its next
    /// corner, through the face.
    fn at(&self, c: usize, j: usize) -> u32 {
        let v = self.topo.idx[c] as usize;
        let r = self.rings.of(v);
        r[(self.rings.pos[c] as usize + j) % r.len()]
    }
}

fn table_valence(n: usize) -> bool {
    (3..=TABLE_MAX).contains(&n)
}

impl<'a> Plan<'a> {
    /// Precomputes the steps of sqrt(2) wavelet `w` on `level`.
    pub fn new(level: &'a Level, w: Wavelet) -> Plan<'a> {
        let (nv, nf) = (level.nv, level.nf());
        let topo = &level.coarse;
        let mut plan = Plan {
            nv,
            nf,
            wavelet: w,
            predict: Rows::new(),
            update: Rows::new(),
            level,
            vert_faces: None,
        };
        if w == Wavelet::Sqrt2Sym && level.vertex_lists_freed() {
            plan.vert_faces = Some(crate::topology::vertex_faces(&level.coarse));
        }
        if let Wavelet::Sqrt2Lazy | Wavelet::Ir2w = w {
            let rings = Rings::of_level(level);
            let nb = Neighbours {
                rings: &rings,
                topo,
            };
            plan.predict = predict_rows(level, &nb);
            plan.predict.shrink();
            if w == Wavelet::Ir2w {
                plan.update = ir2w_update(level, &nb);
                plan.update.shrink();
            }
        }
        plan
    }

    /// IR2W's prediction rows, for the transforms that predict with them (sqrt2-lazy, ir2w).
    fn prediction(&self) -> Option<&Rows> {
        matches!(self.wavelet, Wavelet::Sqrt2Lazy | Wavelet::Ir2w).then_some(&self.predict)
    }

    /// Analysis: fine values `x[..nv + nf]` to coarse values and face-point details.
    pub fn analyse<T: Sample>(&self, x: &mut [T]) {
        match self.wavelet {
            Wavelet::Sqrt2Lazy => self.predict_faces(x, true),
            Wavelet::Ir2w => {
                self.predict_faces(x, true);
                self.ir2w_vertices(x, true);
            }
            Wavelet::Sqrt2Sym => {
                self.sym_scale(x, true);
                self.sym_faces(x, true);
                self.sym_vertices(x, true);
            }
            _ => {}
        }
    }

    /// Synthesis: the exact inverse of [`Plan::analyse`], its steps inverted in reverse.
    pub fn synthesise<T: Sample>(&self, x: &mut [T]) {
        match self.wavelet {
            Wavelet::Sqrt2Lazy => self.predict_faces(x, false),
            Wavelet::Ir2w => {
                self.ir2w_vertices(x, false);
                self.predict_faces(x, false);
            }
            Wavelet::Sqrt2Sym => {
                self.sym_vertices(x, false);
                self.sym_faces(x, false);
                self.sym_scale(x, false);
            }
            _ => {}
        }
    }

    /// Every face point `f -= P_f` (analysis) or `f += P_f` (SPEC.md 9.7).
    fn predict_faces<T: Sample>(&self, x: &mut [T], forward: bool) {
        let nv = self.nv;
        for f in 0..self.nf {
            let p = self.predict.eval(f, x);
            x[nv + f] = if forward {
                x[nv + f].minus(p)
            } else {
                x[nv + f].plus(p)
            };
        }
    }

    /// ir2w's update: every coarse vertex `v -= U_v` (analysis) or `v += U_v`, all computed
    /// from the details first (SPEC.md 9.7).
    fn ir2w_vertices<T: Sample>(&self, x: &mut [T], forward: bool) {
        let (nv, nf) = (self.nv, self.nf);
        let d = &x[nv..nv + nf];
        let u: Vec<T> = (0..nv).map(|v| self.update.eval(v, d)).collect();
        for (v, u) in u.into_iter().enumerate() {
            x[v] = if forward { x[v].minus(u) } else { x[v].plus(u) };
        }
    }

    /// sqrt2-sym step 1: `v'' = [(16 n v - 3 S) / (13 n)]` with S the sum of v's face
    /// points (analysis), or its exact inverse (SPEC.md 9.8). (It reads face points
    /// and writes vertices, so in place.)
    fn sym_scale<T: Sample>(&self, x: &mut [T], forward: bool) {
        for v in 0..self.nv {
            x[v] = match self.own_sum(v, x) {
                (0, _) => x[v],
                (n, s) if forward => T::sym_scale(x[v], s, n as i128),
                (n, s) => T::sym_unscale(x[v], s, n as i128),
            };
        }
    }

    /// Vertex `v`'s faces, once per corner.
    fn v_faces(&self, v: usize) -> &[u32] {
        match &self.vert_faces {
            Some((starts, faces)) => &faces[starts[v] as usize..starts[v + 1] as usize],
            None => self.level.v_faces(v),
        }
    }

    /// Vertex `v`'s face count (once per corner) and the sum of its faces' values.
    fn own_sum<T: Sample>(&self, v: usize, x: &[T]) -> (usize, T::Acc) {
        let faces = self.v_faces(v);
        let mut s = T::Acc::default();
        for &f in faces {
            s += x[self.nv + f as usize].acc();
        }
        (faces.len(), s)
    }

    /// sqrt2-sym step 2: `f'' = f - [sum of corners / k]` (analysis) or its inverse.
    fn sym_faces<T: Sample>(&self, x: &mut [T], forward: bool) {
        let topo = &self.level.coarse;
        for f in 0..self.nf {
            let face = topo.face(f);
            let mut sum = T::Acc::default();
            for &v in face {
                sum += x[v as usize].acc();
            }
            let p = T::combine(1, sum, 0, T::Acc::default(), face.len() as i128);
            let i = self.nv + f;
            x[i] = if forward { x[i].minus(p) } else { x[i].plus(p) };
        }
    }

    /// The faces across the edges of v's faces that do not touch v (SPEC.md 9.8's
    /// `R_v`, repeats kept): their number and the sum of their values.
    fn ring_sum<T: Sample>(&self, v: usize, x: &[T]) -> (usize, T::Acc) {
        let level = self.level;
        let (mut r, mut s) = (0, T::Acc::default());
        for &f in self.v_faces(v) {
            let face = level.coarse.face(f as usize);
            let fe = level.f_edges(f as usize);
            for (i, &e) in fe.iter().enumerate() {
                let (a, b) = (face[i], face[if i + 1 == face.len() { 0 } else { i + 1 }]);
                if a as usize == v || b as usize == v {
                    continue;
                }
                let [g0, g1] = level.edge_faces[e as usize];
                let g = if g0 == f { g1 } else { g0 };
                if g != NONE {
                    s += x[self.nv + g as usize].acc();
                    r += 1;
                }
            }
        }
        (r, s)
    }

    /// sqrt2-sym step 3: `v~ = v'' - [n1 (4/n) S1 + m1 (8/r) S2]` (analysis) or its inverse.
    fn sym_vertices<T: Sample>(&self, x: &mut [T], forward: bool) {
        for v in 0..self.nv {
            let (n, s1) = self.own_sum(v, x);
            if n == 0 {
                continue;
            }
            let (r, s2) = self.ring_sum(v, x);
            let (n, r) = (n as i128, r as i128);
            // n1 = -15/64, m1 = 11/256: -(240 r S1 - 88 n S2) / (256 n r).
            let p = if r == 0 {
                T::combine(-240, s1, 0, s2, 256 * n)
            } else {
                T::combine(-240 * r, s1, 88 * n, s2, 256 * n * r)
            };
            x[v] = if forward { x[v].minus(p) } else { x[v].plus(p) };
        }
    }
}

/// IR2W's prediction of every face point from the coarse vertices (SPEC.md 9.7, eq. 1).
fn predict_rows(level: &Level, nb: &Neighbours<'_>) -> Rows {
    let topo = &level.coarse;
    let mut rows = Rows::new();
    for f in 0..level.nf() {
        let s = topo.starts[f] as usize;
        let k = topo.face(f).len();
        for c in s..s + k {
            let v = topo.idx[c];
            let n = nb.valence(v);
            if table_valence(n) {
                rows.term(v, (ONE / 2) as i32);
                for (j, &a) in tables::ALPHA[n - 3].iter().enumerate() {
                    rows.term(nb.at(c, j), a);
                }
            } else {
                rows.term(v, ONE as i32);
            }
        }
        rows.push(k as i64 * ONE as i64);
    }
    rows
}

/// IR2W's prediction `P_f` of every face point of `level` (SPEC.md 9.7), all three axes
/// in one pass over the corners, from the coarse values `x[k][..nv]`: the same numbers as
/// a [`Plan`]'s prediction rows, without building them. sqrt2-lazy's synthesis adds them
/// and its analysis subtracts them ([`apply_predictions`]); the tangent targets
/// subtract them from the centroids ([`tangent_targets_from`]).
pub fn predictions(level: &Level, x: &[Vec<i64>; 3]) -> [Vec<i64>; 3] {
    predictions_with(level, x, false).0
}

/// [`predictions`], and when `phases`, each prediction's phase (SPEC.md 10.6): where the
/// unrounded prediction lies between its rounded value's neighbours, which mode 6 reads.
pub fn predictions_with(
    level: &Level,
    x: &[Vec<i64>; 3],
    phases: bool,
) -> ([Vec<i64>; 3], Option<Phases>) {
    let rings = Rings::of_level(level);
    let nb = Neighbours {
        rings: &rings,
        topo: &level.coarse,
    };
    let small = small_values(x, level.nv);
    let nf = level.nf();
    let mut out: [Vec<i64>; 3] = std::array::from_fn(|_| Vec::with_capacity(nf));
    let mut ph: Option<Phases> = phases.then(|| Phases {
        codes: std::array::from_fn(|_| Vec::with_capacity(nf)),
        fracs: Default::default(),
    });
    // Small values: each coarse vertex's three values side by side, so that a ring term
    // reads one place (the same sums as `face_prediction`'s).
    let pts: Vec<[i64; 3]> = if small {
        (0..level.nv).map(|v| [x[0][v], x[1][v], x[2][v]]).collect()
    } else {
        Vec::new()
    };
    for f in 0..nf {
        let (p, q) = match (ph.is_some(), small) {
            (true, true) => face_prediction_small::<true>(&level.coarse, &nb, f, &pts),
            (false, true) => face_prediction_small::<false>(&level.coarse, &nb, f, &pts),
            (true, false) => face_prediction::<true>(&level.coarse, &nb, f, x, small),
            (false, false) => face_prediction::<false>(&level.coarse, &nb, f, x, small),
        };
        for (o, p) in out.iter_mut().zip(p) {
            o.push(p);
        }
        if let Some(ph) = &mut ph {
            for (o, q) in ph.codes.iter_mut().zip(q) {
                o.push(q);
            }
        }
    }
    (out, ph)
}

/// Whether every coarse value `x[k][..nv]` is below 2^40 in magnitude: then a face of
/// at most eight corners sums its prediction (weights below 2^18 per corner) in 64 bits.
fn small_values(x: &[Vec<i64>; 3], nv: usize) -> bool {
    x.iter().all(|xk| {
        xk[..nv.min(xk.len())]
            .iter()
            .all(|v| v.unsigned_abs() < 1 << 40)
    })
}

/// [`face_prediction`] of values that [`small_values`] finds small, given as `pts[v]`,
/// the three values of coarse vertex `v`: the same numbers.
#[inline]
fn face_prediction_small<const PHASES: bool>(
    topo: &Topo,
    nb: &Neighbours<'_>,
    f: usize,
    pts: &[[i64; 3]],
) -> ([i64; 3], [u8; 3]) {
    let s = topo.starts[f] as usize;
    let k = topo.starts[f + 1] as usize - s;
    let d = k as i128 * ONE;
    if k > 8 {
        // (Sums of more than eight corners may pass 64 bits.)
        let mut acc = [0i128; 3];
        corner_terms(topo, nb, s..s + k, |u, w| {
            for (a, &xa) in acc.iter_mut().zip(&pts[u]) {
                *a += w as i128 * xa as i128;
            }
        });
        let p = acc.map(|a| crate::transform::round_div(a, d));
        let q = match PHASES {
            true => std::array::from_fn(|i| phase(acc[i] - p[i] as i128 * d, d)),
            false => [0; 3],
        };
        return (p, q);
    }
    let mut acc = [0i64; 3];
    corner_terms(topo, nb, s..s + k, |u, w| {
        let (p, w) = (pts[u], w as i64);
        acc[0] += w * p[0];
        acc[1] += w * p[1];
        acc[2] += w * p[2];
    });
    let p = acc.map(|a| crate::transform::round_div(a as i128, d));
    if !PHASES {
        return (p, [0; 3]);
    }
    // |a| < 2^61 and |p d| <= |a| + d: the remainder fits 64 bits.
    let q = std::array::from_fn(|i| phase((acc[i] - p[i] * d as i64) as i128, d));
    (p, q)
}

/// `P_f` of face f on the three axes (SPEC.md 9.7, eq. 1), from the coarse values
/// `x[k][..nv]`, and with `PHASES` their phases (10.6; else zeros); `small` from
/// [`small_values`] of the same values (the same numbers in 64-bit sums).
fn face_prediction<const PHASES: bool>(
    topo: &Topo,
    nb: &Neighbours<'_>,
    f: usize,
    x: &[Vec<i64>; 3],
    small: bool,
) -> ([i64; 3], [u8; 3]) {
    let s = topo.starts[f] as usize;
    let k = topo.starts[f + 1] as usize - s;
    let d = k as i128 * ONE;
    if small && k <= 8 {
        let mut acc = [0i64; 3];
        corner_terms(topo, nb, s..s + k, |u, w| {
            for (a, xa) in acc.iter_mut().zip(x) {
                *a += w as i64 * xa[u];
            }
        });
        let p = acc.map(|a| crate::transform::round_div(a as i128, d));
        if !PHASES {
            return (p, [0; 3]);
        }
        // |a| < 2^61 and |p d| <= |a| + d: the remainder fits 64 bits.
        let q = std::array::from_fn(|i| phase((acc[i] - p[i] * d as i64) as i128, d));
        return (p, q);
    }
    let mut acc = [0i128; 3];
    corner_terms(topo, nb, s..s + k, |u, w| {
        for (a, xa) in acc.iter_mut().zip(x) {
            *a += w as i128 * xa[u] as i128;
        }
    });
    let p = acc.map(|a| crate::transform::round_div(a, d));
    if !PHASES {
        return (p, [0; 3]);
    }
    let q = std::array::from_fn(|i| phase(acc[i] - p[i] as i128 * d, d));
    (p, q)
}

/// The terms (vertex, weight) of eq. 1 at the corners `cs` of a face: `2^15` at a
/// corner's vertex and `A_n` over its ring from the corner's place (`p_j` of 8.4), or
/// `2^16` at a vertex of valence outside the table.
#[inline]
fn corner_terms(
    topo: &Topo,
    nb: &Neighbours<'_>,
    cs: std::ops::Range<usize>,
    mut add: impl FnMut(usize, i32),
) {
    for c in cs {
        let v = topo.idx[c];
        let ring = nb.rings.of(v as usize);
        let n = ring.len();
        if let Ok(r) = <&[u32; 4]>::try_from(ring) {
            // Valence 4, nearly every vertex of a fine level: the same terms, unrolled.
            add(v as usize, (ONE / 2) as i32);
            let i = nb.rings.pos[c] as usize;
            let a = tables::ALPHA[1];
            for j in 0..4 {
                add(r[(i + j) & 3] as usize, a[j]);
            }
        } else if table_valence(n) {
            add(v as usize, (ONE / 2) as i32);
            // The ring from the corner's place (always below n) to its end, then from
            // its start: no division and no wrap test per term.
            let i = nb.rings.pos[c] as usize;
            let i = if i < n { i } else { i % n };
            let (head, tail) = tables::ALPHA[n - 3].split_at(n - i);
            for (&u, &a) in ring[i..].iter().zip(head) {
                add(u as usize, a);
            }
            for (&u, &a) in ring[..i].iter().zip(tail) {
                add(u as usize, a);
            }
        } else {
            add(v as usize, ONE as i32);
        }
    }
}

/// sqrt2-lazy on one axis with [`predictions`] from the same coarse values: analysis
/// (`forward`, `f -= P_f`) or synthesis (`f += P_f`) of the face points `x[nv..]`.
pub fn apply_predictions(x: &mut [i64], nv: usize, p: &[i64], forward: bool) {
    for (d, &p) in x[nv..nv + p.len()].iter_mut().zip(p) {
        *d = if forward {
            d.wrapping_sub(p)
        } else {
            d.wrapping_add(p)
        };
    }
}

/// The tangent targets of a level's face points (SPEC.md 10.3): per face, the rounded
/// centroid of its corners minus IR2W's prediction (eq. 1), both from the coarse values
/// `coarse`. Reuses the prediction of `plan` (this level's) when it has one.
pub fn tangent_targets(level: &Level, plan: &Plan<'_>, coarse: &[Vec<i64>; 3]) -> Vec<[i64; 3]> {
    match plan.prediction() {
        Some(rows) => targets(level, coarse, |k, f| rows.eval(f, &coarse[k][..])),
        None => tangent_targets_from(level, coarse, &predictions(level, coarse)),
    }
}

/// [`tangent_targets`] with the predictions at hand (from [`predictions`]).
pub fn tangent_targets_from(
    level: &Level,
    coarse: &[Vec<i64>; 3],
    predictions: &[Vec<i64>; 3],
) -> Vec<[i64; 3]> {
    targets(level, coarse, |k, f| predictions[k][f])
}

/// Per face and axis, the rounded centroid of its corners less `prediction(axis, face)`.
fn targets(
    level: &Level,
    coarse: &[Vec<i64>; 3],
    prediction: impl Fn(usize, usize) -> i64,
) -> Vec<[i64; 3]> {
    (0..level.nf())
        .map(|f| {
            let face = level.coarse.face(f);
            std::array::from_fn(|k| {
                let x = &coarse[k];
                let sum: i128 = face.iter().map(|&v| x[v as usize] as i128).sum();
                let centroid = crate::transform::round_div(sum, face.len() as i128);
                centroid - prediction(k, f)
            })
        })
        .collect()
}

/// Visits every term of the ir2w update (SPEC.md 9.7) as `visit(f, v, w)`: every quad
/// face f whose corners have table valences, at most one of them other than 4, lifts its
/// twelve scaling functions v with the frozen weights w of that corner's valence (the
/// regular row when none); other faces lift none. Faces in order, each face's terms in
/// slot order.
fn ir2w_terms(level: &Level, nb: &Neighbours<'_>, mut visit: impl FnMut(usize, u32, i32)) {
    let topo = &level.coarse;
    for f in 0..level.nf() {
        let face = topo.face(f);
        if face.len() != 4 {
            continue;
        }
        let mut n = [0usize; 4];
        for (n, &v) in n.iter_mut().zip(face) {
            *n = nb.valence(v);
        }
        if !n.iter().all(|&n| table_valence(n)) {
            continue;
        }
        let mut odd = (0..4).filter(|&i| n[i] != 4);
        let e = odd.next().unwrap_or(0);
        if odd.next().is_some() {
            continue;
        }
        let row = tables::OMEGA[n[e] - 3];
        let s = topo.starts[f] as usize;
        let corner = |i: usize| s + (e + i) % 4;
        let w = [
            row[0], row[1], row[2], row[1], row[3], row[4], row[5], row[6], row[6], row[5], row[4],
            row[3],
        ];
        let mut phi = [0u32; 12];
        for i in 0..4 {
            let c = corner(i);
            let ni = nb.valence(topo.idx[c]);
            phi[i] = topo.idx[c];
            phi[4 + 2 * i] = nb.at(c, ni - 1);
            phi[4 + 2 * ((i + 3) % 4) + 1] = nb.at(c, 2);
        }
        // At a valence-3 corner the last scaling function is the first ring one again
        // and takes no weight.
        let k = if n[e] == 3 { 11 } else { 12 };
        for (&v, &wk) in phi[..k].iter().zip(&w[..k]) {
            visit(f, v, wk);
        }
    }
}

/// The ir2w update rows (SPEC.md 9.7) in gather form: per coarse vertex its (face,
/// weight) terms in face order, counted first, then placed.
fn ir2w_update(level: &Level, nb: &Neighbours<'_>) -> Rows {
    let nv = level.nv;
    let mut starts = vec![0u32; nv + 1];
    // (Ring entries are coarse vertices; anything else would have no row.)
    ir2w_terms(level, nb, |_, v, _| {
        if let Some(s) = starts.get_mut(v as usize + 1).filter(|_| (v as usize) < nv) {
            *s += 1;
        }
    });
    for v in 0..nv {
        starts[v + 1] += starts[v];
    }
    let total = starts[nv] as usize;
    let mut at: Vec<u32> = starts[..nv].to_vec();
    let (mut src, mut w) = (vec![0u32; total], vec![0i32; total]);
    ir2w_terms(level, nb, |f, v, wk| {
        if let Some(slot) = at.get_mut(v as usize) {
            src[*slot as usize] = f as u32;
            w[*slot as usize] = wk;
            *slot += 1;
        }
    });
    Rows {
        starts,
        src,
        w,
        den: vec![ONE as i64; nv],
    }
}

/// A decoder's ir2w synthesis of a level, all three axes (SPEC.md 9.7): every coarse
/// vertex `v += U_v` from the decoded details `x[k][nv..]`, then every face point
/// `f += P_f` from the updated coarse values. The same numbers as a [`Plan`]'s
/// synthesis, with the level's rings built once and neither update rows nor
/// predictions stored: the update is scattered face by face into one 128-bit sum per
/// vertex, an axis at a time, and each prediction is added where it is made.
pub fn ir2w_synthesise(level: &Level, x: &mut [Vec<i64>; 3]) {
    let rings = Rings::of_level(level);
    let nb = Neighbours {
        rings: &rings,
        topo: &level.coarse,
    };
    ir2w_update_pass(level, &nb, x, false);
    ir2w_predict_pass(level, &nb, x, false);
}

/// The encoder's ir2w analysis of a level, all three axes: the exact inverse of
/// [`ir2w_synthesise`] (and the same numbers as a [`Plan`]'s analysis) without storing
/// prediction or update rows (the memory of large meshes): every face point
/// `f -= P_f` from the fine vertex values, then every coarse vertex `v -= U_v` from the
/// details.
pub fn ir2w_analyse(level: &Level, x: &mut [Vec<i64>; 3]) {
    let rings = Rings::of_level(level);
    let nb = Neighbours {
        rings: &rings,
        topo: &level.coarse,
    };
    ir2w_predict_pass(level, &nb, x, true);
    ir2w_update_pass(level, &nb, x, true);
}

/// ir2w's update, all three axes: every coarse vertex `v -= U_v` (`forward`) or
/// `v += U_v` from the details `x[k][nv..]`, scattered face by face into one 128-bit sum
/// per vertex, an axis at a time (one sum per vertex alive, not three).
fn ir2w_update_pass(level: &Level, nb: &Neighbours<'_>, x: &mut [Vec<i64>; 3], forward: bool) {
    let nv = level.nv;
    let mut acc = vec![0i128; nv];
    for xk in x.iter_mut() {
        ir2w_terms(level, nb, |f, v, w| {
            if let Some(a) = acc.get_mut(v as usize) {
                *a += xk[nv + f].weighted(w as i128);
            }
        });
        for (xv, a) in xk.iter_mut().zip(acc.iter_mut()) {
            let u = i64::round(std::mem::take(a), ONE);
            *xv = if forward { xv.minus(u) } else { xv.plus(u) };
        }
    }
}

/// ir2w's prediction, all three axes: every face point `f -= P_f` (`forward`) or
/// `f += P_f`, from the coarse vertex values, each added where it is made.
fn ir2w_predict_pass(level: &Level, nb: &Neighbours<'_>, x: &mut [Vec<i64>; 3], forward: bool) {
    let nv = level.nv;
    let small = small_values(x, nv);
    for f in 0..level.nf() {
        let (p, _) = face_prediction::<false>(&level.coarse, nb, f, x, small);
        for (xk, p) in x.iter_mut().zip(p) {
            xk[nv + f] = if forward { xk[nv + f].minus(p) } else { xk[nv + f].plus(p) };
        }
    }
}

#[cfg(test)]
mod prediction_tests {
    use super::*;
    use crate::topology::fixtures::prism_with_triangles;
    use crate::topology::sqrt2::{fine, fine_nv};

    /// Pseudo-random fine values of `level` in `-2^(bits - 1)..2^(bits - 1)` (xorshift
    /// from the state `s`).
    fn values(level: &Level, bits: u32, s: &mut u64) -> [Vec<i64>; 3] {
        std::array::from_fn(|_| {
            (0..fine_nv(level))
                .map(|_| {
                    *s ^= *s << 13;
                    *s ^= *s >> 7;
                    *s ^= *s << 17;
                    (*s % (1 << bits)) as i64 - (1 << (bits - 1))
                })
                .collect()
        })
    }

    #[test]
    fn phases_tell_where_the_unrounded_prediction_lies() {
        // sqrt2-lazy's details less their unrounded counterparts (the same analysis on
        // floating point values) are the predictions' rounding offsets: the phase is
        // their sign and size. Two depths, values from 2^10 to 2^41 (64 and 128-bit sums).
        let mut t = prism_with_triangles();
        let mut s = 7u64;
        let mut seen = [0usize; 8];
        for bits in [10, 41, 10, 56] {
            if bits == 41 {
                t = fine(&Level::new(&t).unwrap());
            }
            let level = Level::new(&t).unwrap();
            let x = values(&level, bits, &mut s);
            let (p, ph) = predictions_with(&level, &x, true);
            let ph = ph.unwrap();
            assert_eq!(predictions(&level, &x), p);
            let plan = Plan::new(&level, Wavelet::Sqrt2Lazy);
            for k in 0..3 {
                let mut d = x[k].clone();
                plan.analyse(&mut d);
                let mut e: Vec<f64> = x[k].iter().map(|&v| v as f64).collect();
                plan.analyse(&mut e);
                for f in 0..level.nf() {
                    let i = level.nv + f;
                    if bits > 41 {
                        continue; // beyond f64's exact integers
                    }
                    if let Some(want) = crate::transform::phase::expected_phase(d[i], e[i]) {
                        assert_eq!(
                            ph.codes[k][f], want,
                            "face {f} axis {k}: {} vs {}",
                            d[i], e[i]
                        );
                        seen[want as usize] += 1;
                    }
                }
            }
        }
        // Every sign and bin occurs (bins 0..=2, bit 2 the sign).
        for q in [0, 1, 2, 4, 5, 6] {
            assert!(seen[q] > 0, "phase {q} never seen: {seen:?}");
        }
    }

    #[test]
    fn one_pass_predictions_are_the_plans() {
        // A closed mesh with valences 3 to 5, its sqrt(2) step, and a level beyond.
        // Values below 2^40 (64-bit sums) and up to 2^55 (128-bit sums).
        let mut t = prism_with_triangles();
        let mut s = 99u64;
        for (depth, bits) in [(0, 41), (0, 56), (1, 41), (1, 56), (2, 41), (2, 56)] {
            if depth > 0 && bits == 41 {
                t = fine(&Level::new(&t).unwrap());
            }
            let level = Level::new(&t).unwrap();
            let x = values(&level, bits, &mut s);
            assert_eq!(small_values(&x, level.nv), bits == 41);
            let p = predictions(&level, &x);
            let plan = Plan::new(&level, Wavelet::Sqrt2Lazy);
            for k in 0..3 {
                let mut a = x[k].clone();
                plan.analyse(&mut a);
                let mut b = x[k].clone();
                apply_predictions(&mut b, level.nv, &p[k], true);
                assert_eq!(a, b);
                apply_predictions(&mut b, level.nv, &p[k], false);
                assert_eq!(b, x[k]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::fixtures::{prism_with_triangles, pseudo};
    use crate::topology::sqrt2::{closed, fine, fine_nv, fine_owned, next_level};

    /// The closed prism with its face `g` reversed (an inconsistent orientation).
    fn prism_with_face_reversed(g: usize) -> Topo {
        let prism = prism_with_triangles();
        let mut flipped = Topo::new(prism.nv);
        for f in 0..prism.nf() {
            let mut face = prism.face(f).to_vec();
            if f == g {
                face.reverse();
            }
            flipped.push(&face);
        }
        flipped
    }

    #[test]
    fn next_level_is_the_level_of_the_fine_faces() {
        for base in [prism_with_triangles(), prism_with_face_reversed(0)] {
            let mut level = Level::new(&base).unwrap();
            for _ in 0..5 {
                let next = next_level(level.clone(), true, false).unwrap();
                let mut lean = next.clone();
                lean.free_vertex_adjacency();
                assert_eq!(next_level(level.clone(), false, false).unwrap(), lean);
                assert_eq!(next, Level::new(&fine(&level)).unwrap());
                assert_eq!(fine_owned(level.clone()), fine(&level));
                level = next;
            }
        }
    }

    /// The rings a decoder's next level comes with, derived from the level's own (those
    /// derived the step before, from the third level on), are the fine level's rings made
    /// from its faces; a mesh with a face reversed derives none at first and makes them.
    #[test]
    fn derived_rings_are_the_fine_levels_rings() {
        let cases = [(prism_with_triangles(), true), (prism_with_face_reversed(2), false)];
        for (base, derives) in cases {
            let mut level = Level::new(&base).unwrap();
            for depth in 0..6 {
                let next = next_level(level.clone(), false, true).unwrap();
                let made = Rings::from_level(&next);
                assert_eq!(Rings::of_level(&next).into_owned(), made, "depth {depth}");
                // (The reversed face's inconsistency fades with the steps.)
                let given = matches!(Rings::of_level(&next), std::borrow::Cow::Borrowed(_));
                if derives || depth == 0 {
                    assert_eq!(given, derives, "depth {depth}");
                }
                if derives {
                    assert!((0..next.nv).all(|v| !made.of(v).is_empty()));
                }
                // The same level as without rings.
                assert_eq!(next, next_level(level, false, false).unwrap());
                level = next;
            }
        }
    }

    #[test]
    fn every_transform_inverts_exactly() {
        let mut t = prism_with_triangles();
        for depth in 0..5 {
            let level = Level::new(&t).unwrap();
            assert!(closed(&level));
            for w in Wavelet::SQRT2 {
                let plan = Plan::new(&level, w);
                let orig = pseudo(depth as u64 * 7 + w.code() as u64, fine_nv(&level), 30);
                let mut x = orig.clone();
                plan.analyse(&mut x);
                assert_ne!(x, orig, "{w:?} changed nothing");
                plan.synthesise(&mut x);
                assert_eq!(x, orig, "{w:?} at depth {depth}");
            }
            t = fine(&level);
            assert!(t.all_quads());
        }
    }

    /// The decoder frees a sqrt2-lazy or ir2w level's per-vertex lists: its predictions,
    /// synthesis plan, next level and fine faces come out the same without them.
    #[test]
    fn lazy_and_ir2w_steps_need_no_vertex_lists() {
        let mut t = prism_with_triangles();
        for depth in 0..4 {
            let level = Level::new(&t).unwrap();
            let mut lean = level.clone();
            lean.free_vertex_adjacency();
            assert!(lean.v_edges(0).is_empty() && lean.v_faces(0).is_empty());
            let x: [Vec<i64>; 3] =
                std::array::from_fn(|k| pseudo(40 + 3 * depth + k as u64, fine_nv(&level), 30));
            assert_eq!(predictions(&lean, &x), predictions(&level, &x));
            for w in [Wavelet::Sqrt2Lazy, Wavelet::Ir2w] {
                let (mut a, mut b) = (x[0].clone(), x[0].clone());
                Plan::new(&level, w).synthesise(&mut a);
                Plan::new(&lean, w).synthesise(&mut b);
                assert_eq!(a, b, "{w:?} at depth {depth}");
            }
            let (mut a, mut b) = (x.clone(), x.clone());
            ir2w_synthesise(&level, &mut a);
            ir2w_synthesise(&lean, &mut b);
            assert_eq!(a, b, "ir2w at depth {depth}");
            assert_eq!(
                next_level(lean.clone(), true, false).unwrap(),
                next_level(level.clone(), true, false).unwrap()
            );
            assert_eq!(fine_owned(lean), fine(&level));
            t = fine(&level);
        }
    }

    /// The ir2w passes (update scattered by face, predictions made in place) give the
    /// plan's analysis and synthesis (gathered rows) exactly, and invert each other, on
    /// valences 3 to 5, also with values near the range bound.
    #[test]
    fn ir2w_passes_are_the_plans_transforms() {
        let mut t = prism_with_triangles();
        for depth in 0..4 {
            let level = Level::new(&t).unwrap();
            let plan = Plan::new(&level, Wavelet::Ir2w);
            for bits in [12, 40, 52] {
                let orig: [Vec<i64>; 3] = std::array::from_fn(|k| {
                    pseudo(7 * depth + k as u64 + bits as u64, fine_nv(&level), bits)
                });
                let mut x = orig.clone();
                for xk in x.iter_mut() {
                    plan.analyse(xk);
                }
                assert_ne!(x, orig);
                let mut passed = orig.clone();
                ir2w_analyse(&level, &mut passed);
                assert_eq!(passed, x, "analysis pass at depth {depth}, {bits} bits");
                let mut gathered = x.clone();
                for xk in gathered.iter_mut() {
                    plan.synthesise(xk);
                }
                assert_eq!(gathered, orig, "plan at depth {depth}, {bits} bits");
                ir2w_synthesise(&level, &mut x);
                assert_eq!(x, orig, "pass at depth {depth}, {bits} bits");
            }
            t = fine(&level);
        }
    }

    #[test]
    fn constants_give_zero_details() {
        // Constant data on a refined prism: sqrt2-lazy and ir2w details are exactly zero
        // (every corner's stencil sums to one after quantisation).
        let mut t = prism_with_triangles();
        for _ in 0..3 {
            t = fine(&Level::new(&t).unwrap());
        }
        let level = Level::new(&t).unwrap();
        for w in [Wavelet::Sqrt2Lazy, Wavelet::Ir2w] {
            let plan = Plan::new(&level, w);
            let x0 = vec![5000i64; fine_nv(&level)];
            let mut x = x0.clone();
            plan.analyse(&mut x);
            assert!(
                x[level.nv..].iter().all(|&d| d == 0),
                "{w:?}: {:?}",
                &x[level.nv..]
            );
        }
    }
}
