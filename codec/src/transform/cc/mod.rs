//! The Catmull-Clark transforms (SPEC.md 9.2-9.5, 9.11, 9.12) on one level: Bertram et
//! al.'s integer lifting (lazy, bilinear, bicubic, biquintic), the 4-fold symmetric
//! dyadic lifting, and the predict-only interp4 / interp6 (`interp`), with their
//! phases ([`Phaser`]).

mod interp;
#[cfg(test)]
mod tests;

pub use interp::Phaser;
use interp::{interp4, interp4_axes, Interp4};

use crate::topology::{flag, Level, NextMap, NONE};
use crate::transform::{Sample, Wavelet};

/// Which lifting operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// s-lift: old vertices from edge and face points, then edge points from face points.
    S,
    /// w-lift: face points from old vertices and edge points, then edge points from old
    /// vertices.
    W,
}

/// One lifting step with parameter `a = p / q` (and b = 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Step {
    /// The operation.
    pub kind: Kind,
    /// Numerator of a.
    pub p: i64,
    /// Denominator of a (> 0).
    pub q: i64,
}

/// The values a lifting step reads and updates (SPEC.md 9.2): one axis of samples
/// (`[T]`: integers, or the f64 references), or the three axes of integer positions at
/// once (`[Vec<i64>; 3]`: each element's neighbours looked up once for the three). The
/// steps below are written once for both: each element's update is `(c1 s1 + c2 s2) /
/// d` of sums `s` of its neighbours, per axis.
trait Lanes {
    /// A widened sum of values (per axis).
    type Acc: Copy + Default + std::ops::AddAssign;
    /// An update (per axis).
    type Val: Copy;
    /// Element `i`, widened.
    fn acc(&self, i: usize) -> Self::Acc;
    /// `(c1 s1 + c2 s2) / d` ([`Sample::combine`]) per axis.
    fn combine(c1: i128, s1: Self::Acc, c2: i128, s2: Self::Acc, d: i128) -> Self::Val;
    /// `c1 s1 / d`: [`Lanes::combine`] of one sum.
    fn combine1(c1: i128, s1: Self::Acc, d: i128) -> Self::Val;
    /// Element `i` plus `d` (`forward`) or minus it.
    fn apply(&mut self, i: usize, d: Self::Val, forward: bool);
}

impl<T: Sample> Lanes for [T] {
    type Acc = T::Acc;
    type Val = T;
    #[inline(always)]
    fn acc(&self, i: usize) -> T::Acc {
        self[i].acc()
    }
    #[inline(always)]
    fn combine(c1: i128, s1: T::Acc, c2: i128, s2: T::Acc, d: i128) -> T {
        T::combine(c1, s1, c2, s2, d)
    }
    #[inline(always)]
    fn combine1(c1: i128, s1: T::Acc, d: i128) -> T {
        T::combine(c1, s1, 0, T::Acc::default(), d)
    }
    #[inline(always)]
    fn apply(&mut self, i: usize, d: T, forward: bool) {
        self[i] = if forward { self[i].plus(d) } else { self[i].minus(d) };
    }
}

/// Three axes' widened sums ([`Lanes`] of `[Vec<i64>; 3]`).
#[derive(Clone, Copy, Default)]
struct Acc3([<i64 as Sample>::Acc; 3]);

impl std::ops::AddAssign for Acc3 {
    #[inline(always)]
    fn add_assign(&mut self, o: Acc3) {
        for k in 0..3 {
            self.0[k] += o.0[k];
        }
    }
}

impl Lanes for [Vec<i64>; 3] {
    type Acc = Acc3;
    type Val = [i64; 3];
    #[inline(always)]
    fn acc(&self, i: usize) -> Acc3 {
        Acc3([self[0][i].acc(), self[1][i].acc(), self[2][i].acc()])
    }
    #[inline(always)]
    fn combine(c1: i128, s1: Acc3, c2: i128, s2: Acc3, d: i128) -> [i64; 3] {
        std::array::from_fn(|k| i64::combine(c1, s1.0[k], c2, s2.0[k], d))
    }
    #[inline(always)]
    fn combine1(c1: i128, s1: Acc3, d: i128) -> [i64; 3] {
        s1.0.map(|s| i64::combine(c1, s, 0, 0, d))
    }
    #[inline(always)]
    fn apply(&mut self, i: usize, d: [i64; 3], forward: bool) {
        for (xk, d) in self.iter_mut().zip(d) {
            xk.as_mut_slice().apply(i, d, forward);
        }
    }
}

/// The sum of `x` over indices `it`.
#[inline(always)]
fn lanes_sum<L: Lanes + ?Sized>(x: &L, it: impl Iterator<Item = usize>) -> L::Acc {
    let mut s = L::Acc::default();
    for i in it {
        s += x.acc(i);
    }
    s
}

/// The s-lift update of old vertex `v` (SPEC.md 9.2).
#[inline(always)]
fn v_update<L: Lanes + ?Sized>(level: &Level, x: &L, v: usize, s: Step) -> Option<L::Val> {
    let (e0, f0) = (level.nv, level.nv + level.ne());
    let (p, q) = (s.p as i128, s.q as i128);
    let edges = level.v_edges(v);
    if edges.is_empty() {
        return None;
    }
    let (nb, be) = level.boundary_edges(v);
    if nb > 0 {
        if nb != 2 {
            return None;
        }
        // 1-D s-lift along the boundary curve: 2a * mean of the two boundary edge points.
        let se = lanes_sum(x, be.iter().map(|&e| e0 + e as usize));
        return Some(L::combine1(p, se, q));
    }
    let faces = level.v_faces(v);
    let se = lanes_sum(x, edges.iter().map(|&e| e0 + e as usize));
    let sf = lanes_sum(x, faces.iter().map(|&f| f0 + f as usize));
    let (ne, nf) = (edges.len() as i128, faces.len() as i128);
    // 4a^2 fbar + 4a ebar = (4p^2 ne Sf + 4pq nf Se) / (q^2 nf ne)
    Some(L::combine(
        4 * p * p * ne,
        sf,
        4 * p * q * nf,
        se,
        q * q * nf * ne,
    ))
}

/// The s-lift update of edge point `e`: 2a * mean of its two faces (interior only).
#[inline(always)]
fn e_from_faces<L: Lanes + ?Sized>(level: &Level, x: &L, e: usize, s: Step) -> Option<L::Val> {
    if level.is_boundary(e) {
        return None;
    }
    let f0 = level.nv + level.ne();
    let sf = lanes_sum(x, level.edge_faces[e].iter().map(|&f| f0 + f as usize));
    Some(L::combine1(s.p as i128, sf, s.q as i128))
}

/// The w-lift update of face point `f` (SPEC.md 9.2).
#[inline(always)]
fn f_update<L: Lanes + ?Sized>(level: &Level, x: &L, f: usize, s: Step) -> L::Val {
    let e0 = level.nv;
    let (p, q) = (s.p as i128, s.q as i128);
    let corners = level.coarse.face(f);
    let sv = lanes_sum(x, corners.iter().map(|&v| v as usize));
    let se = lanes_sum(x, level.f_edges(f).iter().map(|&e| e0 + e as usize));
    let k = corners.len() as i128;
    // 4a^2 vbar + 4a ebar = (4p^2 Sv + 4pq Se) / (q^2 k)
    L::combine(4 * p * p, sv, 4 * p * q, se, q * q * k)
}

/// The w-lift update of edge point `e`: 2a * mean of its end points.
#[inline(always)]
fn e_from_ends<L: Lanes + ?Sized>(level: &Level, x: &L, e: usize, s: Step) -> L::Val {
    let sv = lanes_sum(x, level.edges[e].iter().map(|&v| v as usize));
    L::combine1(s.p as i128, sv, s.q as i128)
}

/// One lifting step (`forward`) or its inverse on `x`, leaving the elements `i` with
/// `skip[i]` unchanged. On the three axes of `[Vec<i64>; 3]` the same values as on each
/// axis apart (an element's update reads no element of its own kind, so the order of
/// the axes does not matter).
fn step<L: Lanes + ?Sized>(level: &Level, x: &mut L, s: Step, forward: bool, skip: &[bool]) {
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    let (e0, f0) = (nv, nv + ne);
    let live = |i: usize| !flag(skip, i);
    let vertices = |x: &mut L| {
        for v in (0..nv).filter(|&v| live(v)) {
            if let Some(d) = v_update(level, x, v, s) {
                x.apply(v, d, forward);
            }
        }
    };
    let edges_from_faces = |x: &mut L| {
        for e in (0..ne).filter(|&e| live(e0 + e)) {
            if let Some(d) = e_from_faces(level, x, e, s) {
                x.apply(e0 + e, d, forward);
            }
        }
    };
    let faces = |x: &mut L| {
        for f in (0..nf).filter(|&f| live(f0 + f)) {
            let d = f_update(level, x, f, s);
            x.apply(f0 + f, d, forward);
        }
    };
    let edges_from_ends = |x: &mut L| {
        for e in (0..ne).filter(|&e| live(e0 + e)) {
            let d = e_from_ends(level, x, e, s);
            x.apply(e0 + e, d, forward);
        }
    };
    match (s.kind, forward) {
        (Kind::S, true) => {
            vertices(x);
            edges_from_faces(x);
        }
        (Kind::S, false) => {
            edges_from_faces(x);
            vertices(x);
        }
        (Kind::W, true) => {
            faces(x);
            edges_from_ends(x);
        }
        (Kind::W, false) => {
            edges_from_ends(x);
            faces(x);
        }
    }
}

/// Analysis of one level, in place: `x` holds the fine values (`level.fine_nv()`); after
/// it, `x[..nv]` are the coarse values and the rest the details.
#[cfg(any(test, feature = "internals"))]
pub fn analyse<T: Sample>(level: &Level, w: Wavelet, x: &mut [T]) {
    analyse_except(level, w, x, &[]);
}

/// [`analyse`] leaving the fine values `i` with `skip[i]` unchanged (they are read as
/// they are; indices past the end of `skip` are not skipped). Polar levels skip their
/// pole discs, which the polar transform codes (SPEC.md 9.9).
#[cfg(any(test, feature = "internals"))]
pub fn analyse_except<T: Sample>(level: &Level, w: Wavelet, x: &mut [T], skip: &[bool]) {
    analyse_with(level, w, &Stencils::new(level, w), x, skip);
}

/// A level's neighbourhoods that a transform would otherwise look up for every value:
/// interp4's beyond vertices and beyond edges (SPEC.md 9.11), and interp6's further
/// ones (9.12). Made once per level, they serve all three axes.
pub struct Stencils(Option<Interp4>);

impl Stencils {
    /// The stencils of wavelet `w` on `level` (none for the transforms without any).
    pub fn new(level: &Level, w: Wavelet) -> Stencils {
        Stencils(match w {
            Wavelet::Interp4 => Some(Interp4::new(level, false)),
            Wavelet::Interp6 => Some(Interp4::new(level, true)),
            _ => None,
        })
    }

    /// These stencils if they are interp4's or interp6's for wavelet `w`.
    fn of(&self, w: Wavelet) -> Option<&Interp4> {
        let six = match w {
            Wavelet::Interp4 => false,
            Wavelet::Interp6 => true,
            _ => return None,
        };
        self.0.as_ref().filter(|st| st.six == six)
    }

    /// The stencils of wavelet `w` on `fine`, the level that [`Level::next_mapped`]
    /// made of `coarse` with `map`, derived from these (of `w` on `coarse`) where they
    /// follow by index arithmetic (`Interp4::derive`): the tables
    /// [`Stencils::new`] would make. `None` where they do not follow (the level's
    /// transform then makes them).
    pub fn next(&self, coarse: &Level, fine: &Level, map: &NextMap, w: Wavelet) -> Option<Stencils> {
        let st = Interp4::derive(coarse, self.of(w)?, fine, map)?;
        Some(Stencils(Some(st)))
    }

    /// Analysis (`forward`) or synthesis of a level on the three axes at once, where no
    /// value is skipped: interp4 or interp6 with these stencils where they are `w`'s,
    /// and the lifting wavelets (lazy, bilinear, bicubic, biquintic); the same values as
    /// [`analyse_with`] or [`synthesise_with`] on each axis. False (nothing done)
    /// otherwise.
    pub fn lift_axes(&self, level: &Level, w: Wavelet, x: &mut [Vec<i64>; 3], forward: bool) -> bool {
        if x.iter().any(|xk| xk.len() < level.fine_nv()) {
            return false;
        }
        if let Some(st) = self.of(w) {
            interp4_axes(level, st, x, forward);
            return true;
        }
        let steps = w.steps();
        if steps.is_empty() {
            return false;
        }
        if forward {
            for &s in steps {
                step(level, x, s, true, &[]);
            }
        } else {
            for &s in steps.iter().rev() {
                step(level, x, s, false, &[]);
            }
        }
        true
    }

    /// interp4's stencils (`six`: interp6's): these, or made now if they were made for
    /// another wavelet.
    fn interp4(&self, level: &Level, six: bool) -> std::borrow::Cow<'_, Interp4> {
        match &self.0 {
            Some(st) if st.six == six => std::borrow::Cow::Borrowed(st),
            _ => std::borrow::Cow::Owned(Interp4::new(level, six)),
        }
    }
}

/// Per level of one hierarchy, the interp4 and interp6 stencils once made: interp6's
/// tables, which hold interp4's ([`Stencils`]). The encoder ranks and codes one
/// hierarchy with several transforms, and codes it more than once with the one it
/// keeps; each level's tables are made once for all of them.
#[derive(Default)]
pub struct StencilCache(Vec<std::sync::OnceLock<Interp4>>);

impl StencilCache {
    /// An empty cache for a hierarchy of `levels` levels.
    pub fn new(levels: usize) -> StencilCache {
        StencilCache((0..levels).map(|_| std::sync::OnceLock::new()).collect())
    }

    /// The stencils of wavelet `w` on `level`, level `index` of the hierarchy (0 = the
    /// coarsest): the same as [`Stencils::new`] gives, from the cache (made now, for
    /// interp6, if not yet); made apart if the cache has no such level.
    pub fn stencils(&self, index: usize, level: &Level, w: Wavelet) -> Stencils {
        let six = match w {
            Wavelet::Interp4 => false,
            Wavelet::Interp6 => true,
            _ => return Stencils(None),
        };
        // (A level of another size than the one cached is not the hierarchy's.)
        let cached = self.0.get(index).map(|cell| cell.get_or_init(|| Interp4::new(level, true)));
        match cached.filter(|st| st.edge.len() == level.ne() && st.face.len() == level.nf()) {
            Some(st) => Stencils(st.with_six(six)),
            None => Stencils::new(level, w),
        }
    }
}

impl std::fmt::Debug for StencilCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let made = self.0.iter().filter(|c| c.get().is_some()).count();
        write!(f, "StencilCache({made} of {} levels made)", self.0.len())
    }
}

impl Clone for StencilCache {
    /// A cache of as many levels, empty: a clone of a hierarchy may change its levels.
    fn clone(&self) -> StencilCache {
        StencilCache::new(self.0.len())
    }
}

/// `analyse_except` with the level's [`Stencils`] made beforehand.
pub fn analyse_with<T: Sample>(
    level: &Level,
    w: Wavelet,
    st: &Stencils,
    x: &mut [T],
    skip: &[bool],
) {
    lift(level, w, st, x, skip, true);
}

/// Synthesis of one level, in place: the exact inverse of [`analyse`].
#[cfg(any(test, feature = "internals"))]
pub fn synthesise<T: Sample>(level: &Level, w: Wavelet, x: &mut [T]) {
    synthesise_except(level, w, x, &[]);
}

/// The exact inverse of [`analyse_except`] with the same `skip`.
#[cfg(any(test, feature = "internals"))]
pub fn synthesise_except<T: Sample>(level: &Level, w: Wavelet, x: &mut [T], skip: &[bool]) {
    synthesise_with(level, w, &Stencils::new(level, w), x, skip);
}

/// `synthesise_except` with the level's [`Stencils`] made beforehand.
pub fn synthesise_with<T: Sample>(
    level: &Level,
    w: Wavelet,
    st: &Stencils,
    x: &mut [T],
    skip: &[bool],
) {
    lift(level, w, st, x, skip, false);
}

/// One level's analysis (`forward`) or synthesis: the steps of `w` in order, or their
/// inverses in reverse order.
fn lift<T: Sample>(
    level: &Level,
    w: Wavelet,
    st: &Stencils,
    x: &mut [T],
    skip: &[bool],
    forward: bool,
) {
    match w {
        Wavelet::DyadicSym => dyadic_sym(level, x, forward, skip),
        Wavelet::Interp4 | Wavelet::Interp6 => {
            let six = w == Wavelet::Interp6;
            interp4(level, &st.interp4(level, six), x, forward, skip)
        }
        _ if forward => {
            for &s in w.steps() {
                step(level, x, s, true, skip);
            }
        }
        _ => {
            for &s in w.steps().iter().rev() {
                step(level, x, s, false, skip);
            }
        }
    }
}

/// Interior old vertices (edges, none on a boundary) take part in the 4-fold symmetric
/// steps; boundary vertices follow the 1-D linear B-spline along their curve.
fn interior(level: &Level, v: usize) -> bool {
    let edges = level.v_edges(v);
    !edges.is_empty() && edges.iter().all(|&e| !level.is_boundary(e as usize))
}

/// Sum of `x` over an iterator of indices, and the count.
#[inline]
fn sum<T: Sample>(x: &[T], it: impl Iterator<Item = usize>) -> (T::Acc, i128) {
    let mut s = T::Acc::default();
    let mut n = 0;
    for i in it {
        s += x[i].acc();
        n += 1;
    }
    (s, n)
}

/// dyadic-sym step 1 (lifting part): `u = v - [4m ebar_v]`, m = 5/64 (n = 0).
fn ds_step1<T: Sample>(level: &Level, x: &[T], v: usize) -> T {
    let (se, ne) = sum(x, level.v_edges(v).iter().map(|&e| level.nv + e as usize));
    T::combine(5, se, 0, T::Acc::default(), 16 * ne)
}

/// dyadic-sym step 2 for an edge point: interior `[2mu mean(ends) + 4nu mean(other
/// corners of the faces beside it)]` with mu = 55/128, nu = 9/256; boundary: mean(ends).
fn ds_step2_e<T: Sample>(level: &Level, x: &[T], e: usize) -> T {
    let [a, b] = level.edges[e];
    let (sa, _) = sum(x, [a as usize, b as usize].into_iter());
    if level.is_boundary(e) {
        return T::combine(1, sa, 0, T::Acc::default(), 2);
    }
    let others = level.edge_faces[e].iter().flat_map(|&f| {
        level
            .coarse
            .face(f as usize)
            .iter()
            .filter(move |&&c| c != a && c != b)
            .map(|&c| c as usize)
    });
    let (so, no) = sum(x, others);
    // 110/256 * Sa + 36/256 * So / no
    T::combine(110 * no, sa, 36, so, 256 * no)
}

/// dyadic-sym step 3 for an interior old vertex: `[4g0 ebar'' + 4o0 fbar'' + 8h0
/// obar'']` with g0 = -65/256, o0 = -1/16, h0 = 7/128; obar'' is the mean over the edges
/// of v's faces that do not touch v.
fn ds_step3<T: Sample>(level: &Level, x: &[T], v: usize) -> T {
    let (e0, f0) = (level.nv, level.nv + level.ne());
    let (se, ne) = sum(x, level.v_edges(v).iter().map(|&e| e0 + e as usize));
    let (sf, nf) = sum(x, level.v_faces(v).iter().map(|&f| f0 + f as usize));
    let outer = level.v_faces(v).iter().flat_map(|&f| {
        level.f_edges(f as usize).iter().filter_map(move |&e| {
            let [a, b] = level.edges[e as usize];
            (a as usize != v && b as usize != v).then_some(e0 + e as usize)
        })
    });
    let (so, no) = sum(x, outer);
    if no == 0 {
        // -65/64 ebar - 1/4 fbar
        return T::combine(-65 * nf, se, -16 * ne, sf, 64 * ne * nf);
    }
    // -65/64 ebar - 1/4 fbar + 7/16 obar
    T::combine3(
        -65 * nf * no,
        se,
        -16 * ne * no,
        sf,
        28 * ne * nf,
        so,
        64 * ne * nf * no,
    )
}

/// The coarse vertex beyond coarse vertex `a` on the line of edge `e` (SPEC.md 9.11): on
/// a boundary edge, the other end of `a`'s other boundary edge when `a` has three edges,
/// two on the boundary (a regular boundary vertex; a corner turns);
/// on an interior edge with two quads beside it, when `a` is interior with four edges,
/// the other end of the one edge of `a` that is neither `e` nor beside `e` in those quads.
/// Returns the vertex and the edge that leads to it from `a`. ([`Interp4::new`] finds
/// the same in one pass; this definition is its test's reference.)
#[cfg(test)]
fn beyond_vertex(level: &Level, e: usize, a: usize) -> Option<(usize, usize)> {
    let (nb, be) = level.boundary_edges(a);
    if level.is_boundary(e) {
        if nb != 2 || level.v_edges(a).len() != 3 {
            return None;
        }
        let other = if be[0] as usize == e { be[1] } else { be[0] };
        return Some((level.other_end(other, a) as usize, other as usize));
    }
    let edges = level.v_edges(a);
    if nb != 0 || edges.len() != 4 {
        return None;
    }
    let mut side = [u32::MAX; 2];
    for (k, &f) in level.edge_faces[e].iter().enumerate() {
        let f = f as usize;
        let c = level.coarse.face(f);
        if c.len() != 4 {
            return None;
        }
        let fe = level.f_edges(f);
        let j = c.iter().position(|&v| v as usize == a)?;
        let (next, prev) = (fe[j], fe[(j + 3) % 4]);
        side[k] = if next as usize == e { prev } else { next };
    }
    let opp = edges
        .iter()
        .copied()
        .find(|&x| x as usize != e && !side.contains(&x))?;
    Some((level.other_end(opp, a) as usize, opp as usize))
}

/// The edge point beyond face `f`'s edge `e` (SPEC.md 9.11): the edge opposite `e` in the
/// quad on `e`'s other side.
/// Returns the edge and the quad it lies in.
#[cfg(test)]
fn beyond_edge(level: &Level, f: usize, e: u32) -> Option<(usize, usize)> {
    let [f1, f2] = level.edge_faces[e as usize];
    if f2 == NONE {
        return None;
    }
    let g = if f1 as usize == f { f2 } else { f1 } as usize;
    let fe = level.f_edges(g);
    if fe.len() != 4 {
        return None;
    }
    let i = fe.iter().position(|&x| x == e)?;
    Some((fe[(i + 2) % 4] as usize, g))
}

/// The three-step 4-fold symmetric dyadic lifting and its inverse (SPEC.md 9.5).
fn dyadic_sym<T: Sample>(level: &Level, x: &mut [T], forward: bool, skip: &[bool]) {
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    let (e0, f0) = (nv, nv + ne);
    let live = |i: usize| !flag(skip, i);
    let inner: Vec<bool> = (0..nv).map(|v| live(v) && interior(level, v)).collect();
    // Skipped vertices take no step: neither the interior ones nor the boundary rule.
    let two_boundary = |v: usize| {
        if live(v) {
            level.boundary_edges(v)
        } else {
            (0, [0; 2])
        }
    };
    if forward {
        for v in 0..nv {
            if inner[v] {
                let u = x[v].minus(ds_step1(level, x, v));
                x[v] = u.scale(16, 11);
            }
        }
        for e in (0..ne).filter(|&e| live(e0 + e)) {
            let d = ds_step2_e(level, x, e);
            x[e0 + e] = x[e0 + e].minus(d);
        }
        for f in (0..nf).filter(|&f| live(f0 + f)) {
            let (sv, k) = sum(x, level.coarse.face(f).iter().map(|&c| c as usize));
            let d = T::combine(1, sv, 0, T::Acc::default(), k);
            x[f0 + f] = x[f0 + f].minus(d);
        }
        for v in 0..nv {
            if inner[v] {
                let d = ds_step3(level, x, v);
                x[v] = x[v].minus(d);
            } else if let (2, be) = two_boundary(v) {
                let (s, _) = sum(x, be.iter().map(|&e| e0 + e as usize));
                x[v] = x[v].plus(T::combine(1, s, 0, T::Acc::default(), 4));
            }
        }
    } else {
        for v in 0..nv {
            if inner[v] {
                let d = ds_step3(level, x, v);
                x[v] = x[v].plus(d);
            } else if let (2, be) = two_boundary(v) {
                let (s, _) = sum(x, be.iter().map(|&e| e0 + e as usize));
                x[v] = x[v].minus(T::combine(1, s, 0, T::Acc::default(), 4));
            }
        }
        for f in (0..nf).filter(|&f| live(f0 + f)) {
            let (sv, k) = sum(x, level.coarse.face(f).iter().map(|&c| c as usize));
            let d = T::combine(1, sv, 0, T::Acc::default(), k);
            x[f0 + f] = x[f0 + f].plus(d);
        }
        for e in (0..ne).filter(|&e| live(e0 + e)) {
            let d = ds_step2_e(level, x, e);
            x[e0 + e] = x[e0 + e].plus(d);
        }
        for v in 0..nv {
            if inner[v] {
                let u = x[v].scale(11, 16);
                x[v] = u.plus(ds_step1(level, x, v));
            }
        }
    }
}
