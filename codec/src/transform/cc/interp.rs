//! interp4 (SPEC.md 9.11, Kobbelt's 4-point rule on quads) and interp6 (9.12, the
//! 6-point Deslauriers-Dubuc rule): their stencils, predictions and phases.

use super::*;
use crate::transform::round_div;
use std::sync::Arc;

/// interp4's stencils (SPEC.md 9.11): per edge its two ends' beyond vertices, per quad
/// face the beyond edge of each of its edges ([`NONE`] where there is none; non-quads
/// take the lazy rule and no stencil). With `six` (interp6, 9.12) also the vertices and
/// edges beyond those. The tables are shared: interp6's hold interp4's, so one set made
/// for interp6 serves both ([`Interp4::with_six`]).
#[derive(Clone)]
pub(super) struct Interp4 {
    pub(super) six: bool,
    tables: Arc<Tables>,
}

/// [`Interp4`]'s tables.
pub(super) struct Tables {
    pub(super) edge: Vec<[u32; 2]>,
    pub(super) face: Vec<[u32; 4]>,
    /// interp6: per edge the vertices beyond its ends' beyond vertices.
    pub(super) edge2: Vec<[u32; 2]>,
    /// interp6: per quad face, per edge the edge beyond its beyond edge.
    pub(super) face2: Vec<[u32; 4]>,
    /// Per edge end, the edge that leads to its beyond vertex ([`NONE`] where there is
    /// none): what [`Interp4::derive`] reads.
    pub(super) via: Vec<[u32; 2]>,
    /// Whether no interior edge end of valence 4 had the same edge beside it in both
    /// quads (a fold): then the next level's tables follow from these.
    pub(super) unique: bool,
}

/// No quad across an edge (see [`Interp4::finish`]).
const NO_QUAD: (u32, u8) = (NONE, u8::MAX);

/// Per edge and side k (the face `edge_faces[e][k]`): the edge's slot in that face when
/// it is a quad (the edge runs from corner slot to corner slot + 1), `u8::MAX` otherwise.
fn quad_slots(level: &Level) -> Vec<[u8; 2]> {
    let mut slot = vec![[u8::MAX; 2]; level.ne()];
    for f in 0..level.nf() {
        let fe = level.f_edges(f);
        if fe.len() == 4 {
            for (i, &e) in fe.iter().enumerate() {
                let e = e as usize;
                slot[e][(level.edge_faces[e][0] as usize != f) as usize] = i as u8;
            }
        }
    }
    slot
}

/// The quad on side k of edge `e` and the edge's slot in it, from [`quad_slots`]'s
/// `slot`; `None` where that face is not a quad.
#[inline]
fn quad_slot(level: &Level, slot: &[[u8; 2]], e: usize, k: usize) -> Option<(usize, usize)> {
    let i = slot[e][k];
    (i != u8::MAX).then(|| (level.edge_faces[e][k] as usize, i as usize))
}

impl std::ops::Deref for Interp4 {
    type Target = Tables;

    fn deref(&self) -> &Tables {
        &self.tables
    }
}

impl Interp4 {
    fn of_tables(six: bool, tables: Tables) -> Interp4 {
        Interp4 {
            six,
            tables: Arc::new(tables),
        }
    }

    /// These tables as interp4's (`six` false) or interp6's stencils; `None` for
    /// interp6's from tables made without the far ones. (Interp4's tables are the same
    /// whether or not the far ones were made.)
    pub(super) fn with_six(&self, six: bool) -> Option<Interp4> {
        (self.six || !six).then(|| Interp4 {
            six,
            tables: Arc::clone(&self.tables),
        })
    }

    /// The stencils of `level`, from one pass over the faces that records each edge's
    /// slot in the quads beside it, so that no edge end searches its faces. The tables
    /// are those that `beyond_vertex` and `beyond_edge` give at every edge end and face
    /// edge (the test's `Interp4::reference`).
    pub(super) fn new(level: &Level, six: bool) -> Interp4 {
        let (nv, ne) = (level.nv, level.ne());
        let slot = quad_slots(level);
        let quad_slot = |e: usize, k: usize| quad_slot(level, &slot, e, k);
        let on_boundary: Vec<bool> = (0..nv)
            .map(|v| level.v_edges(v).iter().any(|&e| level.is_boundary(e as usize)))
            .collect();
        let mut edge = Vec::with_capacity(ne);
        let mut via = Vec::with_capacity(ne);
        let mut unique = true;
        for e in 0..ne {
            let boundary = level.is_boundary(e);
            // An interior edge's other edge at each end in each quad beside it (NONE
            // beside a face that is not a quad): at the corner the edge starts from in
            // that quad the edge before it, at the other the edge after it.
            let mut side = [[NONE; 2]; 2];
            if !boundary {
                for k in 0..2 {
                    if let Some((g, i)) = quad_slot(e, k) {
                        let fe = level.f_edges(g);
                        let first = (level.edges[e][0] != level.coarse.face(g)[i]) as usize;
                        side[first][k] = fe[(i + 3) % 4];
                        side[1 - first][k] = fe[(i + 1) % 4];
                    }
                }
            }
            let mut found = [(NONE, NONE); 2];
            for (end, &a) in level.edges[e].iter().enumerate() {
                let a = a as usize;
                let edges = level.v_edges(a);
                found[end] = if boundary {
                    let (nb, be) = level.boundary_edges(a);
                    if nb != 2 || edges.len() != 3 {
                        continue;
                    }
                    let other = if be[0] as usize == e { be[1] } else { be[0] };
                    (level.other_end(other, a), other)
                } else {
                    let side = side[end];
                    if on_boundary[a] || edges.len() != 4 || side.contains(&NONE) {
                        continue;
                    }
                    unique &= side[0] != side[1];
                    match edges
                        .iter()
                        .copied()
                        .find(|&x| x as usize != e && !side.contains(&x))
                    {
                        Some(opp) => (level.other_end(opp, a), opp),
                        None => continue,
                    }
                };
            }
            edge.push(found.map(|b| b.0));
            via.push(found.map(|b| b.1));
        }
        Self::with_edges(level, &slot, six, edge, via, unique)
    }

    /// The stencils of `fine`, the level [`Level::next_mapped`] made of `coarse` with
    /// `map`, from `coarse`'s stencils `st`, by index arithmetic where `coarse` is all
    /// quads (then every fine vertex's neighbourhood is a coarse one's, an edge point's
    /// or a quad's face point's): per half of a coarse edge, at its coarse end the half
    /// of the coarse beyond edge, at the edge point the other half; per spoke, at the face
    /// point the opposite spoke, at the edge point the spoke across the edge. The same
    /// tables as [`Interp4::new`] of `fine` (test `derived_stencils_are_the_next_levels`);
    /// `None` where `coarse` is not all quads or folds on itself.
    pub(super) fn derive(coarse: &Level, st: &Interp4, fine: &Level, map: &NextMap) -> Option<Interp4> {
        let (nv, ne, nf) = (coarse.nv, coarse.ne(), coarse.nf());
        if !st.unique
            || st.via.len() != ne
            || coarse.face_edges.len() != 4 * nf
            || !coarse.coarse.all_quads()
            || map.half.len() != ne
            || map.spokes.len() != 4 * nf
        {
            return None;
        }
        let (e0, f0) = (nv as u32, (nv + ne) as u32);
        let mut edge = vec![[NONE; 2]; fine.ne()];
        let mut via = vec![[NONE; 2]; fine.ne()];
        // Fine edge `id`'s beyond vertex `b` at its end `x`, reached by fine edge `g`.
        let mut put = |id: u32, x: u32, b: u32, g: u32| {
            let id = id as usize;
            let end = (fine.edges[id][0] != x) as usize;
            edge[id][end] = b;
            via[id][end] = g;
        };
        for (e, ends) in coarse.edges.iter().enumerate() {
            for end in 0..2 {
                let (v, w) = (ends[end], ends[1 - end]);
                let h = map.half[e][end];
                // At the coarse vertex: the half, at the same vertex, of the coarse edge
                // beyond (its edge point is the beyond vertex).
                let g = st.via[e][end];
                if g != NONE {
                    let gi = (coarse.edges[g as usize][0] != v) as usize;
                    put(h, v, e0 + g, map.half[g as usize][gi]);
                }
                // At the edge point: straight on, the other half.
                put(h, e0 + e as u32, w, map.half[e][1 - end]);
            }
        }
        for f in 0..nf {
            let s = 4 * f;
            let fe = coarse.f_edges(f);
            for i in 0..4 {
                let (e, sp) = (fe[i] as usize, map.spokes[s + i]);
                // At the face point: the opposite spoke, to the opposite edge point.
                let o = (i + 2) % 4;
                put(sp, f0 + f as u32, e0 + fe[o], map.spokes[s + o]);
                // At the edge point of an interior edge: across the edge, the other
                // face's spoke (none on a boundary, whose edge points lie on it).
                let [f1, f2] = coarse.edge_faces[e];
                if f2 == NONE {
                    continue;
                }
                let g = if f1 as usize == f { f2 } else { f1 } as usize;
                if g == f {
                    return None;
                }
                let j = coarse.f_edges(g).iter().position(|&x| x as usize == e)?;
                put(sp, e0 + e as u32, f0 + g as u32, map.spokes[4 * g + j]);
            }
        }
        // Fine quad 4 f + i (at corner i of coarse face f) has the edges: the half of
        // coarse edge e_i at the corner, the spokes of e_i and of e_(i-1), the half of
        // e_(i-1) at the corner.
        let nq = 4 * nf;
        let mut face = vec![[NONE; 4]; nq];
        let mut across = vec![[NO_QUAD; 4]; if st.six { nq } else { 0 }];
        let half_at = |e: u32, v: u32| map.half[e as usize][(coarse.edges[e as usize][0] != v) as usize];
        for f in 0..nf {
            let (c, fe) = (coarse.coarse.face(f), coarse.f_edges(f));
            for i in 0..4 {
                let (n, p, pp) = ((i + 1) % 4, (i + 3) % 4, (i + 2) % 4);
                let q = 4 * f + i;
                let mut y = [NONE; 4];
                let mut h = [NO_QUAD; 4];
                // Across the spokes, the quads of the same face at the next corner and
                // the previous: the halves there of the next edge and of the one before
                // the previous.
                y[1] = half_at(fe[n], c[n]);
                h[1] = ((4 * f + n) as u32, 0);
                y[2] = half_at(fe[pp], c[p]);
                h[2] = ((4 * f + p) as u32, 3);
                // Across the halves (of e_i, slot 0; of e_(i-1), slot 3), the quad of the
                // edge's other face g at the corner: its spoke opposite the half.
                for (slot, e) in [(0, fe[i]), (3, fe[p])] {
                    let [f1, f2] = coarse.edge_faces[e as usize];
                    if f2 == NONE {
                        continue;
                    }
                    let g = if f1 as usize == f { f2 } else { f1 } as usize;
                    let (gc, ge) = (coarse.coarse.face(g), coarse.f_edges(g));
                    let jg = ge.iter().position(|&x| x == e)?;
                    // The edge runs from g's corner jg to jg + 1: the corner is one of them.
                    let (jc, at) = if gc[jg] == c[i] { (jg, 0) } else { ((jg + 1) % 4, 3) };
                    let opposite = (at + 2) % 4;
                    y[slot] = map.spokes[4 * g + if opposite == 2 { (jc + 3) % 4 } else { jc }];
                    h[slot] = ((4 * g + jc) as u32, opposite as u8);
                }
                face[q] = y;
                if st.six {
                    across[q] = h;
                }
            }
        }
        Some(Self::finish(fine, st.six, edge, via, face, &across, true))
    }

    /// The stencils of `level` from its beyond vertices `edge` and their edges `via`:
    /// the beyond edges of its quads (from the edges' slots in them, `slot`) and, with
    /// `six`, the far tables.
    fn with_edges(
        level: &Level,
        slot: &[[u8; 2]],
        six: bool,
        edge: Vec<[u32; 2]>,
        via: Vec<[u32; 2]>,
        unique: bool,
    ) -> Interp4 {
        let nf = level.nf();
        let mut face = Vec::with_capacity(nf);
        let mut across = Vec::with_capacity(if six { nf } else { 0 });
        for f in 0..nf {
            let mut y = [NONE; 4];
            let mut h = [NO_QUAD; 4];
            let fe = level.f_edges(f);
            if fe.len() == 4 {
                for i in 0..4 {
                    // The quad on the edge's other side and the slot opposite it there.
                    let e = fe[i] as usize;
                    let [f1, f2] = level.edge_faces[e];
                    if f2 == NONE {
                        continue;
                    }
                    if let Some((g, j)) = quad_slot(level, slot, e, (f1 as usize == f) as usize) {
                        let j = (j + 2) % 4;
                        y[i] = level.f_edges(g)[j];
                        h[i] = (g as u32, j as u8);
                    }
                }
            }
            face.push(y);
            if six {
                across.push(h);
            }
        }
        Self::finish(level, six, edge, via, face, &across, unique)
    }

    /// The stencils from the beyond vertices `edge`, their edges `via`, the beyond
    /// edges `face` and (with `six`) per quad edge the quad across it and the slot of
    /// the beyond edge there (`across`): with `six`, the far tables made.
    fn finish(
        level: &Level,
        six: bool,
        edge: Vec<[u32; 2]>,
        via: Vec<[u32; 2]>,
        face: Vec<[u32; 4]>,
        across: &[[(u32, u8); 4]],
        unique: bool,
    ) -> Interp4 {
        let (mut edge2, mut face2) = (Vec::new(), Vec::new());
        if six {
            // Edge e's beyond vertex b at an end, reached by edge g: b's beyond vertex on
            // g (b is g's end other than e's).
            edge2.reserve(edge.len());
            for (e, b) in edge.iter().enumerate() {
                edge2.push(std::array::from_fn(|end| match (b[end], via[e][end]) {
                    (NONE, _) => NONE,
                    (b, g) => edge[g as usize][(level.edges[g as usize][0] != b) as usize],
                }));
            }
            // Face f's beyond edge y of an edge, in quad h at slot j: the beyond edge of
            // h's edge y.
            face2.reserve(face.len());
            for (y, h) in face.iter().zip(across) {
                face2.push(std::array::from_fn(|i| match (y[i], h[i]) {
                    (NONE, _) | (_, NO_QUAD) => NONE,
                    (_, (h, j)) => face[h as usize][j as usize],
                }));
            }
        }
        Interp4::of_tables(
            six,
            Tables {
                edge,
                face,
                edge2,
                face2,
                via,
                unique,
            },
        )
    }

    /// interp6's far tables from the beyond tables, as SPEC.md 9.12 defines them: per
    /// edge end, the beyond vertex's own beyond vertex on the edge `via` that leads to
    /// it; per quad edge, the beyond edge's own beyond edge in the quad it lies in.
    #[cfg(test)]
    fn far(
        level: &Level,
        edge: &[[u32; 2]],
        via: &[[u32; 2]],
        face: &[[u32; 4]],
        quad: &[[u32; 4]],
    ) -> (Vec<[u32; 2]>, Vec<[u32; 4]>) {
        // Edge e's beyond vertex b at an end, reached by edge g: b's beyond vertex on g.
        let edge2 = (0..edge.len())
            .map(|e| {
                std::array::from_fn(|end| {
                    let (b, g) = (edge[e][end], via[e][end] as usize);
                    let at = (b != NONE).then(|| level.edges[g].iter().position(|&v| v == b));
                    at.flatten().map_or(NONE, |j| edge[g][j])
                })
            })
            .collect();
        // Face f's beyond edge y of an edge, in quad h: the beyond edge of h's edge y.
        let face2 = (0..face.len())
            .map(|f| {
                std::array::from_fn(|i| {
                    let (y, h) = (face[f][i], quad[f][i] as usize);
                    let at = (y != NONE).then(|| level.f_edges(h).iter().position(|&x| x == y));
                    at.flatten().map_or(NONE, |j| face[h][j])
                })
            })
            .collect();
        (edge2, face2)
    }

    /// The stencils straight from their definitions, [`beyond_vertex`] at every edge end
    /// and [`beyond_edge`] at every quad edge: what [`Interp4::new`] must equal.
    #[cfg(test)]
    pub(super) fn reference(level: &Level, six: bool) -> Interp4 {
        // The found items' first and second parts as tables, NONE where none was found.
        fn split<const N: usize>(found: &[[Option<(usize, usize)>; N]]) -> [Vec<[u32; N]>; 2] {
            let some = |v: Option<usize>| v.map_or(NONE, |v| v as u32);
            [0, 1].map(|part| {
                found
                    .iter()
                    .map(|f| f.map(|b| some(b.map(|b| if part == 0 { b.0 } else { b.1 }))))
                    .collect()
            })
        }
        let (ne, nf) = (level.ne(), level.nf());
        let found: Vec<[Option<(usize, usize)>; 2]> = (0..ne)
            .map(|e| level.edges[e].map(|a| beyond_vertex(level, e, a as usize)))
            .collect();
        let [edge, via] = split(&found);
        let found: Vec<[Option<(usize, usize)>; 4]> = (0..nf)
            .map(|f| {
                let fe = level.f_edges(f);
                match fe.len() {
                    4 => std::array::from_fn(|i| beyond_edge(level, f, fe[i])),
                    _ => [None; 4],
                }
            })
            .collect();
        let [face, quad] = split(&found);
        let (edge2, face2) = if six {
            Self::far(level, &edge, &via, &face, &quad)
        } else {
            (Vec::new(), Vec::new())
        };
        Interp4::of_tables(
            six,
            Tables {
                edge,
                face,
                edge2,
                face2,
                via,
                unique: false,
            },
        )
    }
}

/// Edge point `e`'s prediction from the coarse values: `[(-x_a' + 9 x_a + 9 x_b - x_b') /
/// 16]` with both beyond vertices, else `[(x_a + x_b) / 2]`.
#[inline]
pub(super) fn interp4_edge<T: Sample>(level: &Level, st: &Interp4, x: &[T], e: usize, narrow: bool) -> T {
    let (s, d) = interp4_edge_sum(level, st, x, e, narrow);
    T::round(s, d)
}

/// [`interp4_edge`] before its rounding: the sum and its divisor.
#[inline(always)]
pub(super) fn interp4_edge_sum<T: Sample>(
    level: &Level,
    st: &Interp4,
    x: &[T],
    e: usize,
    narrow: bool,
) -> (T::Acc, i128) {
    let (t, d) = edge_stencil(level, st, e);
    (T::sum_terms(x, t.map(|(i, w)| (i, w as i32)), narrow), d)
}

#[inline]
pub(super) fn interp4_face<T: Sample>(level: &Level, st: &Interp4, x: &[T], f: usize, narrow: bool) -> T {
    let (s, d) = interp4_face_sum(level, st, x, f, narrow);
    T::round(s, d)
}

/// [`interp4_face`] before its rounding: the sum and its divisor.
#[inline(always)]
pub(super) fn interp4_face_sum<T: Sample>(
    level: &Level,
    st: &Interp4,
    x: &[T],
    f: usize,
    narrow: bool,
) -> (T::Acc, i128) {
    if let Some((t, d)) = face_stencil(level, st, f) {
        return (T::sum_terms(x, t.map(|(i, w)| (i, w as i32)), narrow), d);
    }
    let e0 = level.nv;
    let fe = level.f_edges(f);
    let mut s = T::Acc::default();
    for &e in fe {
        s += x[e0 + e as usize].weighted(2);
    }
    for &v in level.coarse.face(f) {
        s += x[v as usize].weighted(-1);
    }
    (s, fe.len() as i128)
}

/// The predictions of a predict-only Catmull-Clark transform (lazy, interp4 or interp6) on one
/// level and their phases (SPEC.md 10.6), which mode 6 reads. Its edge points are
/// predicted from the coarse values, its face points also from the fine edge points.
pub struct Phaser<'a> {
    level: &'a Level,
    interp4: Option<std::borrow::Cow<'a, Interp4>>,
}

impl<'a> Phaser<'a> {
    /// The phaser of `w` on `level` with its stencils `st`; `None` for a transform with
    /// an update step (no phases).
    pub fn new(level: &'a Level, w: Wavelet, st: &'a Stencils) -> Option<Phaser<'a>> {
        match w {
            Wavelet::Lazy => Some(Phaser {
                level,
                interp4: None,
            }),
            Wavelet::Interp4 | Wavelet::Interp6 => Some(Phaser {
                level,
                interp4: Some(st.interp4(level, w == Wavelet::Interp6)),
            }),
            _ => None,
        }
    }

    /// The phases of details `0..n` on the three axes of `x` (for face points, the
    /// values must hold the fine edge points), and with `fracs` their fractions
    /// (SPEC.md 10.9).
    pub fn phases(
        &self,
        x: &[Vec<i64>; 3],
        n: usize,
        fracs: bool,
    ) -> crate::transform::phase::Phases {
        use crate::transform::phase::{phase, FRAC_DIV};
        let mut p = crate::transform::phase::Phases::default();
        for k in 0..3 {
            p.codes[k].reserve_exact(n);
            if fracs {
                p.fracs[k].reserve_exact(n);
            }
        }
        let mut push = |k: usize, r: i128, d: i128| {
            p.codes[k].push(phase(r, d));
            if fracs {
                p.fracs[k].push(round_div(FRAC_DIV * r, d) as i16);
            }
        };
        let level = self.level;
        match self.interp4.as_deref() {
            // Each stencil looked up once for the three axes, summed in 64 bits where
            // the values it reads allow (as [`interp4_axes`]): the same phases and
            // fractions as [`Phaser::predict_frac`] gives axis by axis.
            Some(st) => {
                let ne = level.ne();
                let read = (level.nv + ne).min(x.iter().map(Vec::len).min().unwrap_or(0));
                let narrow = x.each_ref().map(|xk| i64::narrow(&xk[..read]));
                for i in 0..n {
                    if i < ne {
                        let (t, d) = edge_stencil(level, st, i);
                        for k in 0..3 {
                            let s = stencil_sum(&x[k], &t, narrow[k]);
                            push(k, s - round_div(s, d) as i128 * d, d);
                        }
                    } else if let Some((t, d)) = face_stencil(level, st, i - ne) {
                        for k in 0..3 {
                            let s = stencil_sum(&x[k], &t, narrow[k]);
                            push(k, s - round_div(s, d) as i128 * d, d);
                        }
                    } else {
                        for k in 0..3 {
                            let (_, r, d) = self.exact(&x[k], i);
                            push(k, r, d);
                        }
                    }
                }
            }
            None => {
                for i in 0..n {
                    for k in 0..3 {
                        let (_, r, d) = self.exact(&x[k], i);
                        push(k, r, d);
                    }
                }
            }
        }
        p
    }

    /// Detail `i`'s (edge points `0..ne`, then face points) correction and phase on one
    /// axis, from the values `x` (the coarse values and, for a face point, the fine edge
    /// points): the fine value is the detail plus the correction (SPEC.md 10.6).
    #[inline]
    pub fn predict(&self, x: &[i64], i: usize) -> (i64, u8) {
        let (p, r, d) = self.exact(x, i);
        (p, crate::transform::phase::phase(r, d))
    }

    /// [`Phaser::predict`] and the fraction: the unrounded prediction lies about
    /// `fraction / 512` above the correction (SPEC.md 10.9).
    #[inline]
    pub fn predict_frac(&self, x: &[i64], i: usize) -> (i64, u8, i16) {
        let (p, r, d) = self.exact(x, i);
        // (|r| <= d / 2, so the fraction is at most 256 in magnitude.)
        let frac = round_div(crate::transform::phase::FRAC_DIV * r, d) as i16;
        (p, crate::transform::phase::phase(r, d), frac)
    }

    /// Detail `i`'s correction `p`, and where its unrounded prediction lies: `r / d`
    /// above `p`.
    #[inline(always)]
    fn exact(&self, x: &[i64], i: usize) -> (i64, i128, i128) {
        let level = self.level;
        let ne = level.ne();
        let (n, d, sign) = match &self.interp4 {
            Some(st) if i < ne => {
                let (s, d) = interp4_edge_sum(level, st, x, i, false);
                (s, d, 1)
            }
            Some(st) => {
                let (s, d) = interp4_face_sum(level, st, x, i - ne, false);
                (s, d, 1)
            }
            // The lazy w-lift (SPEC.md 9.2, a = -1/2) adds `[N / D]` in analysis: for an
            // edge point `N = -(x_a + x_b)`, `D = 2`; for a face point of k corners
            // `N = 4 (sum of corners) - 8 (sum of edge points)`, `D = 4 k`.
            None if i < ne => {
                let [a, b] = level.edges[i];
                (-(x[a as usize] as i128 + x[b as usize] as i128), 2, -1)
            }
            None => {
                let f = i - ne;
                let corners = level.coarse.face(f);
                let sv: i128 = corners.iter().map(|&v| x[v as usize] as i128).sum();
                let se: i128 = level
                    .f_edges(f)
                    .iter()
                    .map(|&e| x[level.nv + e as usize] as i128)
                    .sum();
                (4 * sv - 8 * se, 4 * corners.len() as i128, -1)
            }
        };
        let p = round_div(n, d);
        // The detail is `x - [N / D]` (interp4) or `x + [N / D]` (lazy): the unrounded
        // prediction lies `r / D` above (or below) the rounded one.
        (sign * p, sign as i128 * (n - p as i128 * d), d)
    }
}

/// The 4-point interpolating transform and its inverse (SPEC.md 9.11): details are the
/// fine values less their predictions; analysis predicts the face points first (from the
/// fine edge points), synthesis the edge points first.
pub(super) fn interp4<T: Sample>(level: &Level, st: &Interp4, x: &mut [T], forward: bool, skip: &[bool]) {
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    let (e0, f0) = (nv, nv + ne);
    let live = |i: usize| !flag(skip, i);
    // The edge points read coarse values, the face points edge points (and, beside a
    // face that is not a quad, coarse values): each pass checks what it reads.
    if forward {
        let narrow = T::narrow(&x[..f0]);
        for f in (0..nf).filter(|&f| live(f0 + f)) {
            let p = interp4_face(level, st, x, f, narrow);
            x[f0 + f] = x[f0 + f].minus(p);
        }
        let narrow = T::narrow(&x[..e0]);
        for e in (0..ne).filter(|&e| live(e0 + e)) {
            let p = interp4_edge(level, st, x, e, narrow);
            x[e0 + e] = x[e0 + e].minus(p);
        }
    } else {
        let narrow = T::narrow(&x[..e0]);
        for e in (0..ne).filter(|&e| live(e0 + e)) {
            let p = interp4_edge(level, st, x, e, narrow);
            x[e0 + e] = x[e0 + e].plus(p);
        }
        let narrow = T::narrow(&x[..f0]);
        for f in (0..nf).filter(|&f| live(f0 + f)) {
            let p = interp4_face(level, st, x, f, narrow);
            x[f0 + f] = x[f0 + f].plus(p);
        }
    }
}

/// An edge point's interp4 / interp6 terms (SPEC.md 9.11, 9.12) and divisor, padded
/// with zero weights to six: the 6-point rule where both far vertices are there (they
/// imply the beyond vertices), else the 4-point rule, else the mean of the ends.
#[inline(always)]
fn edge_stencil(level: &Level, st: &Interp4, e: usize) -> ([(usize, i64); 6], i128) {
    let [a, b] = level.edges[e];
    let (a, b) = (a as usize, b as usize);
    if st.six {
        let ([a2, b2], [a3, b3]) = (st.edge[e], st.edge2[e]);
        if a3 != NONE && b3 != NONE {
            let (a2, b2, a3, b3) = (a2 as usize, b2 as usize, a3 as usize, b3 as usize);
            return ([(a, 150), (b, 150), (a2, -25), (b2, -25), (a3, 3), (b3, 3)], 256);
        }
    }
    match st.edge[e] {
        [a2, b2] if a2 != NONE && b2 != NONE => {
            let (a2, b2) = (a2 as usize, b2 as usize);
            ([(a, 9), (b, 9), (a2, -1), (b2, -1), (a, 0), (a, 0)], 16)
        }
        _ => ([(a, 1), (b, 1), (a, 0), (a, 0), (a, 0), (a, 0)], 2),
    }
}

/// A quad's face point terms and divisor (both pairs of opposite edges, padded with
/// zero weights to twelve); `None` for a face that is not a quad. Each pair by the
/// widest rule it has: interp6's 6-point rule over 256 (a far edge implies its beyond
/// edge), else the 4-point rule over 16, else the mean; interp6 scales the narrower two
/// to 256 (by `k` = 16) so both pairs share the divisor 512.
#[inline(always)]
fn face_stencil(level: &Level, st: &Interp4, f: usize) -> Option<([(usize, i64); 12], i128)> {
    let e0 = level.nv;
    let fe = level.f_edges(f);
    if fe.len() != 4 {
        return None;
    }
    let beyond = st.face[f];
    let (k, div) = if st.six { (16, 512) } else { (1, 32) };
    let mut t = [(e0, 0i64); 12];
    for d in 0..2 {
        let (m, m2) = (e0 + fe[d] as usize, e0 + fe[d + 2] as usize);
        let (y, y2) = (beyond[d], beyond[d + 2]);
        let far = match st.six {
            true => st.face2.get(f).map_or([NONE; 2], |z| [z[d], z[d + 2]]),
            false => [NONE; 2],
        };
        let part = &mut t[6 * d..6 * d + 6];
        if far.iter().all(|&z| z != NONE) {
            let (y, y2) = (e0 + y as usize, e0 + y2 as usize);
            let (z, z2) = (e0 + far[0] as usize, e0 + far[1] as usize);
            part.copy_from_slice(&[(m, 150), (m2, 150), (y, -25), (y2, -25), (z, 3), (z2, 3)]);
        } else if y != NONE && y2 != NONE {
            let (y, y2) = (e0 + y as usize, e0 + y2 as usize);
            part[..4].copy_from_slice(&[(m, 9 * k), (m2, 9 * k), (y, -k), (y2, -k)]);
        } else {
            part[..2].copy_from_slice(&[(m, 8 * k), (m2, 8 * k)]);
        }
    }
    Some((t, div))
}

/// `sum of w x[i]` over `terms`, in 64 bits when `narrow` (values within 2^52, weights
/// summing to at most 712 in magnitude), else 128.
#[inline(always)]
fn stencil_sum<const N: usize>(x: &[i64], terms: &[(usize, i64); N], narrow: bool) -> i128 {
    if narrow {
        let mut s = 0i64;
        for &(i, w) in terms {
            s += x[i] * w;
        }
        return s as i128;
    }
    terms.iter().map(|&(i, w)| x[i] as i128 * w as i128).sum()
}

/// [`interp4`] on the three axes at once (integers, no skipped values): each stencil
/// looked up once for the three. The same values.
pub(super) fn interp4_axes(level: &Level, st: &Interp4, x: &mut [Vec<i64>; 3], forward: bool) {
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    let (e0, f0) = (nv, nv + ne);
    let narrow = |x: &[Vec<i64>; 3], n: usize| x.each_ref().map(|xk| i64::narrow(&xk[..n]));
    let step = |v: i64, p: i64| if forward { v.wrapping_sub(p) } else { v.wrapping_add(p) };
    let edges = |x: &mut [Vec<i64>; 3]| {
        let wide = narrow(x, e0);
        for e in 0..ne {
            let (t, d) = edge_stencil(level, st, e);
            for (xk, &n) in x.iter_mut().zip(&wide) {
                let p = round_div(stencil_sum(xk, &t, n), d);
                xk[e0 + e] = step(xk[e0 + e], p);
            }
        }
    };
    let faces = |x: &mut [Vec<i64>; 3]| {
        let wide = narrow(x, f0);
        for f in 0..nf {
            match face_stencil(level, st, f) {
                Some((t, d)) => {
                    for (xk, &n) in x.iter_mut().zip(&wide) {
                        let p = round_div(stencil_sum(xk, &t, n), d);
                        xk[f0 + f] = step(xk[f0 + f], p);
                    }
                }
                None => {
                    for (xk, &n) in x.iter_mut().zip(&wide) {
                        let p = interp4_face(level, st, xk, f, n);
                        xk[f0 + f] = step(xk[f0 + f], p);
                    }
                }
            }
        }
    };
    // The edge points read coarse values, the face points edge points: analysis makes
    // the face points' details first, synthesis the edge points' values first.
    if forward {
        faces(x);
        edges(x);
    } else {
        edges(x);
        faces(x);
    }
}
