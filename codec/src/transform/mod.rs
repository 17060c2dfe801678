//! Bertram's B-spline wavelets on Catmull-Clark connectivity as lifting steps
//! (SPEC.md 9), in the integer form the codec runs (every step with b = 1, the sum of
//! averaged terms rounded once) and in floating point for the fidelity tests.
//!
//! A step changes one class using only the others, so synthesis (the same steps,
//! subtracted, in reverse order) undoes analysis exactly for any weights: boundary rules
//! and rounding can cost compression, never losslessness.

pub mod fit;
pub(crate) mod level;
pub mod phase;
pub mod polar;
pub mod sqrt2;

use crate::topology::{flag, Level, NONE};

/// The wavelet transforms on Catmull-Clark hierarchies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wavelet {
    /// Prediction only: edge and face points from the linear B-spline (the w-lift of
    /// `bilinear`), no update.
    Lazy,
    /// Linear B-spline: w-lift(-1/2), s-lift(1/4).
    Bilinear,
    /// Cubic B-spline (Catmull-Clark / MLCA): s-lift(-1/4), w-lift(-1), s-lift(3/16).
    Bicubic,
    /// Quintic B-spline: w-lift(-1/6), s-lift(-9/16), w-lift(-4/3), s-lift(5/32).
    Biquintic,
    /// The 4-fold symmetric three-step dyadic lifting of seed 003 (eq. 45-48), sums
    /// over neighbours written as (regular count) x (mean), the 1/j scaling expanded
    /// exactly (SPEC.md 9.5).
    DyadicSym,
    /// Prediction only, by the 4-point rule (-1, 9, 9, -1) / 16 along the mesh's lines
    /// where the quads around are regular (Kobbelt's interpolatory quad scheme), the
    /// lazy rules elsewhere; no update (SPEC.md 9.11).
    Interp4,
    /// Prediction only, by the 6-point rule (3, -25, 150, 150, -25, 3) / 256 along the
    /// mesh's lines where they run straight on for three coarse vertices each way
    /// (Deslauriers-Dubuc), interp4's rules elsewhere; no update (SPEC.md 9.12).
    Interp6,
    /// sqrt(2) levels: the interpolatory prediction of Wang & Ma 2009 (eq. 1) alone
    /// (SPEC.md 9.7).
    Sqrt2Lazy,
    /// sqrt(2) levels: the interpolatory prediction and the twelve-neighbour update of
    /// Wang & Ma 2009 (eq. 9, 10) with frozen fixed-point weights (SPEC.md 9.7).
    Ir2w,
    /// sqrt(2) levels: the three-step 4-fold symmetric lifting of seed 003 (eq. 83, 84,
    /// 91), the 1/j scaling an exact injective rounding (SPEC.md 9.8).
    Sqrt2Sym,
}

impl Wavelet {
    /// The Catmull-Clark transforms, in header-code order.
    pub const ALL: [Wavelet; 7] = [
        Wavelet::Lazy,
        Wavelet::Bilinear,
        Wavelet::Bicubic,
        Wavelet::Biquintic,
        Wavelet::DyadicSym,
        Wavelet::Interp4,
        Wavelet::Interp6,
    ];

    /// The sqrt(2) transforms, in header-code order.
    pub const SQRT2: [Wavelet; 3] = [Wavelet::Sqrt2Lazy, Wavelet::Ir2w, Wavelet::Sqrt2Sym];

    /// Whether the transform runs on sqrt(2) levels (else on Catmull-Clark levels).
    pub fn is_sqrt2(self) -> bool {
        Wavelet::SQRT2.contains(&self)
    }

    /// The name used on the command line and in `info`.
    pub fn name(self) -> &'static str {
        match self {
            Wavelet::Lazy => "lazy",
            Wavelet::Bilinear => "bilinear",
            Wavelet::Bicubic => "bicubic",
            Wavelet::Biquintic => "biquintic",
            Wavelet::DyadicSym => "dyadic-sym",
            Wavelet::Interp4 => "interp4",
            Wavelet::Interp6 => "interp6",
            Wavelet::Sqrt2Lazy => "sqrt2-lazy",
            Wavelet::Ir2w => "ir2w",
            Wavelet::Sqrt2Sym => "sqrt2-sym",
        }
    }

    /// The header code (SPEC.md 5).
    pub fn code(self) -> u8 {
        match self {
            Wavelet::Lazy => 1,
            Wavelet::Bilinear => 2,
            Wavelet::Bicubic => 3,
            Wavelet::Biquintic => 4,
            Wavelet::DyadicSym => 5,
            Wavelet::Sqrt2Lazy => 6,
            Wavelet::Ir2w => 7,
            Wavelet::Sqrt2Sym => 8,
            Wavelet::Interp4 => 10,
            Wavelet::Interp6 => 11,
        }
    }

    /// The transform with a header code.
    pub fn from_code(c: u8) -> Option<Wavelet> {
        Wavelet::ALL
            .into_iter()
            .chain(Wavelet::SQRT2)
            .find(|w| w.code() == c)
    }

    /// The transform with a name.
    pub fn from_name(s: &str) -> Option<Wavelet> {
        Wavelet::ALL
            .into_iter()
            .chain(Wavelet::SQRT2)
            .find(|w| w.name() == s)
    }

    /// Analysis steps in order of computation (Table 1 of Bertram et al., integer
    /// variant of their section 4.3); empty for `DyadicSym`, which has its own steps,
    /// and for the sqrt(2) transforms ([`crate::transform::sqrt2`]).
    pub(crate) fn steps(self) -> &'static [Step] {
        use Kind::{S, W};
        match self {
            Wavelet::DyadicSym
            | Wavelet::Interp4
            | Wavelet::Interp6
            | Wavelet::Sqrt2Lazy
            | Wavelet::Ir2w
            | Wavelet::Sqrt2Sym => &[],
            Wavelet::Lazy => &[Step {
                kind: W,
                p: -1,
                q: 2,
            }],
            Wavelet::Bilinear => &[
                Step {
                    kind: W,
                    p: -1,
                    q: 2,
                },
                Step {
                    kind: S,
                    p: 1,
                    q: 4,
                },
            ],
            Wavelet::Bicubic => &[
                Step {
                    kind: S,
                    p: -1,
                    q: 4,
                },
                Step {
                    kind: W,
                    p: -1,
                    q: 1,
                },
                Step {
                    kind: S,
                    p: 3,
                    q: 16,
                },
            ],
            Wavelet::Biquintic => &[
                Step {
                    kind: W,
                    p: -1,
                    q: 6,
                },
                Step {
                    kind: S,
                    p: -9,
                    q: 16,
                },
                Step {
                    kind: W,
                    p: -4,
                    q: 3,
                },
                Step {
                    kind: S,
                    p: 5,
                    q: 32,
                },
            ],
        }
    }
}

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

/// A sample type the steps can run on: `i64` rounds each update (SPEC.md 9.1), `f64`
/// computes it exactly.
pub trait Sample: Copy {
    /// `self + d` (wrapping for integers: hostile data cannot panic, and the decoder
    /// range-checks what comes out).
    fn plus(self, d: Self) -> Self;
    /// `self - d`, likewise.
    fn minus(self, d: Self) -> Self;
    /// Wide accumulator for sums of samples.
    type Acc: Copy + Default + std::ops::AddAssign;
    /// Widens a sample.
    fn acc(self) -> Self::Acc;
    /// `(c1 * s1 + c2 * s2) / d`, rounded half up for integers.
    fn combine(c1: i128, s1: Self::Acc, c2: i128, s2: Self::Acc, d: i128) -> Self;
    /// `(c1 * s1 + c2 * s2 + c3 * s3) / d`, rounded half up for integers.
    #[allow(clippy::too_many_arguments)]
    fn combine3(
        c1: i128,
        s1: Self::Acc,
        c2: i128,
        s2: Self::Acc,
        c3: i128,
        s3: Self::Acc,
        d: i128,
    ) -> Self;
    /// `self * n / d`, rounded half up for integers.
    fn scale(self, n: i128, d: i128) -> Self;
    /// `self * w`, widened.
    fn weighted(self, w: i128) -> Self::Acc;
    /// `s / d`, rounded half up for integers.
    fn round(s: Self::Acc, d: i128) -> Self;
    /// sqrt2-sym's scaling step (SPEC.md 9.8): `[(16 n v - 3 s) / (13 n)]`.
    fn sym_scale(self, s: Self::Acc, n: i128) -> Self;
    /// Its inverse: the `v` that [`Sample::sym_scale`] maps to `self`.
    fn sym_unscale(self, s: Self::Acc, n: i128) -> Self;
    /// Whether an interp4 / interp6 sum over values of `x` of weights up to 712 in
    /// magnitude may be taken in 64 bits (integers: every value within 2^52, so every
    /// partial sum is below 2^62): the same sum, found faster. False by default.
    fn narrow(_x: &[Self]) -> bool {
        false
    }
    /// `sum of w x[i]` over `terms`, widened; in 64 bits when `narrow` (from
    /// [`Sample::narrow`] of values holding every `x[i]`).
    #[inline(always)]
    fn sum_terms<const N: usize>(x: &[Self], terms: [(usize, i32); N], _narrow: bool) -> Self::Acc {
        let mut s = Self::Acc::default();
        for (i, w) in terms {
            s += x[i].weighted(w as i128);
        }
        s
    }
}

/// `[n / d]`: `floor((2n + d) / 2d)` for `d > 0` (SPEC.md 9.1).
#[inline]
pub fn round_div(n: i128, d: i128) -> i64 {
    let (t, dd) = (2 * n + d, 2 * d);
    // The same floor division, fast: a power-of-two divisor is an arithmetic shift
    // (floor for negatives too), and most numerators fit 64 bits.
    if dd & (dd - 1) == 0 {
        return (t >> dd.trailing_zeros()) as i64;
    }
    match (i64::try_from(t), i64::try_from(dd)) {
        (Ok(t), Ok(dd)) => t.div_euclid(dd),
        _ => t.div_euclid(dd) as i64,
    }
}

impl Sample for i64 {
    type Acc = i128;
    fn narrow(x: &[i64]) -> bool {
        x.iter().all(|v| v.unsigned_abs() <= 1 << 52)
    }
    #[inline(always)]
    fn sum_terms<const N: usize>(x: &[i64], terms: [(usize, i32); N], narrow: bool) -> i128 {
        if narrow {
            let mut s = 0i64;
            for (i, w) in terms {
                s += x[i] * w as i64;
            }
            return s as i128;
        }
        let mut s = 0i128;
        for (i, w) in terms {
            s += x[i] as i128 * w as i128;
        }
        s
    }
    #[inline]
    fn plus(self, d: i64) -> i64 {
        self.wrapping_add(d)
    }
    #[inline]
    fn minus(self, d: i64) -> i64 {
        self.wrapping_sub(d)
    }
    #[inline]
    fn acc(self) -> i128 {
        self as i128
    }
    #[inline]
    fn combine(c1: i128, s1: i128, c2: i128, s2: i128, d: i128) -> i64 {
        round_div(c1 * s1 + c2 * s2, d)
    }
    #[inline]
    fn combine3(c1: i128, s1: i128, c2: i128, s2: i128, c3: i128, s3: i128, d: i128) -> i64 {
        round_div(c1 * s1 + c2 * s2 + c3 * s3, d)
    }
    #[inline]
    fn scale(self, n: i128, d: i128) -> i64 {
        round_div(self as i128 * n, d)
    }
    #[inline]
    fn weighted(self, w: i128) -> i128 {
        self as i128 * w
    }
    #[inline]
    fn round(s: i128, d: i128) -> i64 {
        round_div(s, d)
    }
    #[inline]
    fn sym_scale(self, s: i128, n: i128) -> i64 {
        round_div(16 * n * self as i128 - 3 * s, 13 * n)
    }
    #[inline]
    fn sym_unscale(self, s: i128, n: i128) -> i64 {
        // y = [(A v - B s) / D] <=> D y - D/2 <= A v - B s < D y + D/2, so
        // v = ceil((2 D y - D + 2 B s) / (2 A)), A = 16 n, B = 3, D = 13 n.
        let num = 26 * n * self as i128 - 13 * n + 6 * s;
        let den = 32 * n;
        (-((-num).div_euclid(den))) as i64
    }
}

impl Sample for f64 {
    type Acc = f64;
    #[inline]
    fn plus(self, d: f64) -> f64 {
        self + d
    }
    #[inline]
    fn minus(self, d: f64) -> f64 {
        self - d
    }
    #[inline]
    fn acc(self) -> f64 {
        self
    }
    #[inline]
    fn combine(c1: i128, s1: f64, c2: i128, s2: f64, d: i128) -> f64 {
        (c1 as f64 * s1 + c2 as f64 * s2) / d as f64
    }
    #[inline]
    fn combine3(c1: i128, s1: f64, c2: i128, s2: f64, c3: i128, s3: f64, d: i128) -> f64 {
        (c1 as f64 * s1 + c2 as f64 * s2 + c3 as f64 * s3) / d as f64
    }
    #[inline]
    fn scale(self, n: i128, d: i128) -> f64 {
        self * n as f64 / d as f64
    }
    #[inline]
    fn weighted(self, w: i128) -> f64 {
        self * w as f64
    }
    #[inline]
    fn round(s: f64, d: i128) -> f64 {
        s / d as f64
    }
    #[inline]
    fn sym_scale(self, s: f64, n: i128) -> f64 {
        (16.0 * n as f64 * self - 3.0 * s) / (13.0 * n as f64)
    }
    #[inline]
    fn sym_unscale(self, s: f64, n: i128) -> f64 {
        (13.0 * n as f64 * self + 3.0 * s) / (16.0 * n as f64)
    }
}

/// The s-lift update of old vertex `v` (SPEC.md 9.2).
#[inline]
fn v_update<T: Sample>(level: &Level, x: &[T], v: usize, s: Step) -> Option<T> {
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
        let mut se = T::Acc::default();
        se += x[e0 + be[0] as usize].acc();
        se += x[e0 + be[1] as usize].acc();
        return Some(T::combine(p, se, 0, T::Acc::default(), q));
    }
    let faces = level.v_faces(v);
    let mut se = T::Acc::default();
    for &e in edges {
        se += x[e0 + e as usize].acc();
    }
    let mut sf = T::Acc::default();
    for &f in faces {
        sf += x[f0 + f as usize].acc();
    }
    let (ne, nf) = (edges.len() as i128, faces.len() as i128);
    // 4a^2 fbar + 4a ebar = (4p^2 ne Sf + 4pq nf Se) / (q^2 nf ne)
    Some(T::combine(
        4 * p * p * ne,
        sf,
        4 * p * q * nf,
        se,
        q * q * nf * ne,
    ))
}

/// The s-lift update of edge point `e`: 2a * mean of its two faces (interior only).
#[inline]
fn e_from_faces<T: Sample>(level: &Level, x: &[T], e: usize, s: Step) -> Option<T> {
    if level.is_boundary(e) {
        return None;
    }
    let f0 = level.nv + level.ne();
    let [a, b] = level.edge_faces[e];
    let mut sf = T::Acc::default();
    sf += x[f0 + a as usize].acc();
    sf += x[f0 + b as usize].acc();
    Some(T::combine(
        s.p as i128,
        sf,
        0,
        T::Acc::default(),
        s.q as i128,
    ))
}

/// The w-lift update of face point `f` (SPEC.md 9.2).
#[inline]
fn f_update<T: Sample>(level: &Level, x: &[T], f: usize, s: Step) -> T {
    let e0 = level.nv;
    let (p, q) = (s.p as i128, s.q as i128);
    let corners = level.coarse.face(f);
    let mut sv = T::Acc::default();
    for &v in corners {
        sv += x[v as usize].acc();
    }
    let mut se = T::Acc::default();
    for &e in level.f_edges(f) {
        se += x[e0 + e as usize].acc();
    }
    let k = corners.len() as i128;
    // 4a^2 vbar + 4a ebar = (4p^2 Sv + 4pq Se) / (q^2 k)
    T::combine(4 * p * p, sv, 4 * p * q, se, q * q * k)
}

/// The w-lift update of edge point `e`: 2a * mean of its end points.
#[inline]
fn e_from_ends<T: Sample>(level: &Level, x: &[T], e: usize, s: Step) -> T {
    let [a, b] = level.edges[e];
    let mut sv = T::Acc::default();
    sv += x[a as usize].acc();
    sv += x[b as usize].acc();
    T::combine(s.p as i128, sv, 0, T::Acc::default(), s.q as i128)
}

fn step<T: Sample>(level: &Level, x: &mut [T], s: Step, forward: bool, skip: &[bool]) {
    let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
    let e0 = nv;
    let f0 = nv + ne;
    let live = |i: usize| !flag(skip, i);
    match (s.kind, forward) {
        (Kind::S, true) => {
            for v in (0..nv).filter(|&v| live(v)) {
                if let Some(d) = v_update(level, x, v, s) {
                    x[v] = x[v].plus(d);
                }
            }
            for e in (0..ne).filter(|&e| live(e0 + e)) {
                if let Some(d) = e_from_faces(level, x, e, s) {
                    x[e0 + e] = x[e0 + e].plus(d);
                }
            }
        }
        (Kind::S, false) => {
            for e in (0..ne).filter(|&e| live(e0 + e)) {
                if let Some(d) = e_from_faces(level, x, e, s) {
                    x[e0 + e] = x[e0 + e].minus(d);
                }
            }
            for v in (0..nv).filter(|&v| live(v)) {
                if let Some(d) = v_update(level, x, v, s) {
                    x[v] = x[v].minus(d);
                }
            }
        }
        (Kind::W, true) => {
            for f in (0..nf).filter(|&f| live(f0 + f)) {
                let d = f_update(level, x, f, s);
                x[f0 + f] = x[f0 + f].plus(d);
            }
            for e in (0..ne).filter(|&e| live(e0 + e)) {
                let d = e_from_ends(level, x, e, s);
                x[e0 + e] = x[e0 + e].plus(d);
            }
        }
        (Kind::W, false) => {
            for e in (0..ne).filter(|&e| live(e0 + e)) {
                let d = e_from_ends(level, x, e, s);
                x[e0 + e] = x[e0 + e].minus(d);
            }
            for f in (0..nf).filter(|&f| live(f0 + f)) {
                let d = f_update(level, x, f, s);
                x[f0 + f] = x[f0 + f].minus(d);
            }
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

    /// interp4's stencils (`six`: interp6's): these, or made now if they were made for
    /// another wavelet.
    fn interp4(&self, level: &Level, six: bool) -> std::borrow::Cow<'_, Interp4> {
        match &self.0 {
            Some(st) if st.six == six => std::borrow::Cow::Borrowed(st),
            _ => std::borrow::Cow::Owned(Interp4::new(level, six)),
        }
    }
}

/// [`analyse_except`] with the level's [`Stencils`] made beforehand.
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

/// [`synthesise_except`] with the level's [`Stencils`] made beforehand.
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

/// interp4's stencils (SPEC.md 9.11): per edge its two ends' beyond vertices, per quad
/// face the beyond edge of each of its edges ([`NONE`] where there is none; non-quads
/// take the lazy rule and no stencil). With `six` (interp6, 9.12) also the vertices and
/// edges beyond those.
#[derive(Clone)]
struct Interp4 {
    six: bool,
    edge: Vec<[u32; 2]>,
    face: Vec<[u32; 4]>,
    /// interp6: per edge the vertices beyond its ends' beyond vertices.
    edge2: Vec<[u32; 2]>,
    /// interp6: per quad face, per edge the edge beyond its beyond edge.
    face2: Vec<[u32; 4]>,
}

impl Interp4 {
    /// The stencils of `level`, from one pass over the faces that records each edge's
    /// slot in the quads beside it, so that no edge end searches its faces. The tables
    /// are those that `beyond_vertex` and `beyond_edge` give at every edge end and face
    /// edge (the test's `Interp4::reference`).
    fn new(level: &Level, six: bool) -> Interp4 {
        let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
        // Per edge and side k (the face edge_faces[e][k]): the edge's slot in that face
        // when it is a quad (the edge runs from corner slot to corner slot + 1).
        let mut slot = vec![[u8::MAX; 2]; ne];
        for f in 0..nf {
            let fe = level.f_edges(f);
            if fe.len() == 4 {
                for (i, &e) in fe.iter().enumerate() {
                    let e = e as usize;
                    slot[e][(level.edge_faces[e][0] as usize != f) as usize] = i as u8;
                }
            }
        }
        // The slot of edge e in the quad on its side k, and that quad.
        let quad_slot = |e: usize, k: usize| {
            let i = slot[e][k];
            (i != u8::MAX).then(|| (level.edge_faces[e][k] as usize, i as usize))
        };
        let on_boundary: Vec<bool> = (0..nv)
            .map(|v| {
                level
                    .v_edges(v)
                    .iter()
                    .any(|&e| level.is_boundary(e as usize))
            })
            .collect();
        let mut edge = Vec::with_capacity(ne);
        let mut via = Vec::with_capacity(if six { ne } else { 0 });
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
            if six {
                via.push(found.map(|b| b.1));
            }
        }
        // Quad f's edge i: the quad on its other side and the slot opposite it there.
        let beyond = |f: usize, i: usize| {
            let e = level.f_edges(f)[i] as usize;
            let [f1, f2] = level.edge_faces[e];
            if f2 == NONE {
                return None;
            }
            quad_slot(e, (f1 as usize == f) as usize).map(|(g, j)| (g, (j + 2) % 4))
        };
        let mut face = Vec::with_capacity(nf);
        let mut quad = Vec::with_capacity(if six { nf } else { 0 });
        for f in 0..nf {
            let mut y = [NONE; 4];
            let mut h = [NONE; 4];
            if level.f_edges(f).len() == 4 {
                for i in 0..4 {
                    if let Some((g, j)) = beyond(f, i) {
                        y[i] = level.f_edges(g)[j];
                        h[i] = g as u32;
                    }
                }
            }
            face.push(y);
            if six {
                quad.push(h);
            }
        }
        let (mut edge2, mut face2) = (Vec::new(), Vec::new());
        if six {
            // Edge e's beyond vertex b at an end, reached by edge g: b's beyond vertex on
            // g (b is g's end other than e's).
            edge2.reserve(ne);
            for (e, b) in edge.iter().enumerate() {
                edge2.push(std::array::from_fn(|end| match (b[end], via[e][end]) {
                    (NONE, _) => NONE,
                    (b, g) => edge[g as usize][(level.edges[g as usize][0] != b) as usize],
                }));
            }
            // Face f's beyond edge y of an edge, in quad h at slot j: the beyond edge of
            // h's edge y.
            face2.reserve(nf);
            for f in 0..nf {
                face2.push(std::array::from_fn(|i| match face[f][i] {
                    NONE => NONE,
                    _ => beyond(f, i).map_or(NONE, |(h, j)| face[h][j]),
                }));
            }
        }
        Interp4 {
            six,
            edge,
            face,
            edge2,
            face2,
        }
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
    fn reference(level: &Level, six: bool) -> Interp4 {
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
        Interp4 {
            six,
            edge,
            face,
            edge2,
            face2,
        }
    }
}

/// Edge point `e`'s prediction from the coarse values: `[(-x_a' + 9 x_a + 9 x_b - x_b') /
/// 16]` with both beyond vertices, else `[(x_a + x_b) / 2]`.
#[inline]
fn interp4_edge<T: Sample>(level: &Level, st: &Interp4, x: &[T], e: usize, narrow: bool) -> T {
    let (s, d) = interp4_edge_sum(level, st, x, e, narrow);
    T::round(s, d)
}

/// [`interp4_edge`] before its rounding: the sum and its divisor.
#[inline(always)]
fn interp4_edge_sum<T: Sample>(
    level: &Level,
    st: &Interp4,
    x: &[T],
    e: usize,
    narrow: bool,
) -> (T::Acc, i128) {
    let [a, b] = level.edges[e];
    let (a, b) = (a as usize, b as usize);
    if st.six {
        let ([a2, b2], [a3, b3]) = (st.edge[e], st.edge2[e]);
        if a3 != NONE && b3 != NONE {
            // Both far vertices imply both beyond vertices.
            let (a2, b2, a3, b3) = (a2 as usize, b2 as usize, a3 as usize, b3 as usize);
            let t = [(a, 150), (b, 150), (a2, -25), (b2, -25), (a3, 3), (b3, 3)];
            return (T::sum_terms(x, t, narrow), 256);
        }
    }
    match st.edge[e] {
        [a2, b2] if a2 != NONE && b2 != NONE => {
            let t = [(a, 9), (b, 9), (a2 as usize, -1), (b2 as usize, -1)];
            (T::sum_terms(x, t, narrow), 16)
        }
        _ => (T::sum_terms(x, [(a, 1), (b, 1)], narrow), 2),
    }
}

/// Face point `f`'s prediction from its coarse corners and the fine edge points: for a
/// quad, the sum over its two pairs of opposite edges (m, m') of `-y + 9 m + 9 m' - y'`
/// with both beyond edge points y, y', else `8 (m + m')`, over 32; for other faces the
/// lazy rule `[(2 sum of edge points - sum of corners) / k]`.
#[inline]
fn interp4_face<T: Sample>(level: &Level, st: &Interp4, x: &[T], f: usize, narrow: bool) -> T {
    let (s, d) = interp4_face_sum(level, st, x, f, narrow);
    T::round(s, d)
}

/// [`interp4_face`] before its rounding: the sum and its divisor.
#[inline(always)]
fn interp4_face_sum<T: Sample>(
    level: &Level,
    st: &Interp4,
    x: &[T],
    f: usize,
    narrow: bool,
) -> (T::Acc, i128) {
    let e0 = level.nv;
    let fe = level.f_edges(f);
    if fe.len() == 4 {
        // Each pair of opposite edges by the widest rule it has: interp6's 6-point rule
        // over 256, else the 4-point rule over 16, else the mean; interp6 scales the
        // narrower two to 256 (by `k` = 16) so both pairs share the divisor 512.
        let beyond = st.face[f];
        let (k, div) = if st.six { (16, 512) } else { (1, 32) };
        let mut s = T::Acc::default();
        for d in 0..2 {
            let (m, m2) = (e0 + fe[d] as usize, e0 + fe[d + 2] as usize);
            let (y, y2) = (beyond[d], beyond[d + 2]);
            let far = st.face2.get(f).map_or([NONE; 2], |z| [z[d], z[d + 2]]);
            if far.iter().all(|&z| z != NONE) {
                // A far edge implies its beyond edge.
                let (y, y2) = (e0 + y as usize, e0 + y2 as usize);
                let (z, z2) = (e0 + far[0] as usize, e0 + far[1] as usize);
                let t = [(m, 150), (m2, 150), (y, -25), (y2, -25), (z, 3), (z2, 3)];
                s += T::sum_terms(x, t, narrow);
            } else if y != NONE && y2 != NONE {
                let (y, y2) = (e0 + y as usize, e0 + y2 as usize);
                let t = [(m, 9 * k), (m2, 9 * k), (y, -k), (y2, -k)];
                s += T::sum_terms(x, t, narrow);
            } else {
                s += T::sum_terms(x, [(m, 8 * k), (m2, 8 * k)], narrow);
            }
        }
        return (s, div);
    }
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
        let mut p = crate::transform::phase::Phases::default();
        for k in 0..3 {
            for i in 0..n {
                if fracs {
                    let (_, q, f) = self.predict_frac(&x[k], i);
                    p.codes[k].push(q);
                    p.fracs[k].push(f);
                } else {
                    p.codes[k].push(self.predict(&x[k], i).1);
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
fn interp4<T: Sample>(level: &Level, st: &Interp4, x: &mut [T], forward: bool, skip: &[bool]) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topo;
    use proptest::prelude::*;

    fn grid(n: u32) -> Topo {
        let mut t = Topo::new(((n + 1) * (n + 1)) as usize);
        for y in 0..n {
            for x in 0..n {
                let i = y * (n + 1) + x;
                t.push(&[i, i + 1, i + n + 2, i + n + 1]);
            }
        }
        t
    }

    fn mixed() -> Topo {
        crate::topology::fixtures::prism_with_triangles()
    }

    fn open_mixed() -> Topo {
        let mut t = Topo::new(7);
        t.push(&[0, 1, 2]);
        t.push(&[0, 2, 3, 4]);
        t.push(&[0, 4, 5, 6, 1]);
        t
    }

    #[test]
    fn phaser_gives_the_synthesis_and_the_rounding_offsets() {
        // For lazy, interp4 and interp6: a detail plus the phaser's correction is the fine value,
        // and the phase is where the unrounded prediction lies (the integer detail less
        // the same analysis on floating point values), on closed, open and mixed meshes.
        let mut seen = [0usize; 8];
        for (n, t) in [grid(6), mixed(), open_mixed()].into_iter().enumerate() {
            let level = Level::new(&t).unwrap();
            let t2 = level.fine();
            let level2 = Level::new(&t2).unwrap();
            for level in [&level, &level2] {
                for w in [Wavelet::Lazy, Wavelet::Interp4, Wavelet::Interp6] {
                    let st = Stencils::new(level, w);
                    let p = Phaser::new(level, w, &st).unwrap();
                    let x = crate::topology::fixtures::pseudo(n as u64 + 3, level.fine_nv(), 12);
                    let mut d = x.clone();
                    analyse(level, w, &mut d);
                    let mut e: Vec<f64> = x.iter().map(|&v| v as f64).collect();
                    analyse(level, w, &mut e);
                    for i in 0..level.ne() + level.nf() {
                        let j = level.nv + i;
                        let (c, q, frac) = p.predict_frac(&x, i);
                        assert_eq!(p.predict(&x, i), (c, q));
                        assert_eq!(d[j] + c, x[j], "{w:?} detail {i}");
                        // The unrounded prediction lies `d - e` above the rounded one:
                        // the fraction is that in 512ths, rounded.
                        let off = frac as f64 / 512.0 - (d[j] as f64 - e[j]);
                        assert!(off.abs() <= 1.0 / 1024.0 + 1e-9, "{w:?} detail {i}: {off}");
                        if let Some(want) = crate::transform::phase::expected_phase(d[j], e[j]) {
                            assert_eq!(q, want, "{w:?} detail {i}: {} vs {}", d[j], e[j]);
                            seen[q as usize] += 1;
                        }
                    }
                }
            }
        }
        for q in [0, 1, 2, 4, 5, 6] {
            assert!(seen[q] > 0, "phase {q} never seen: {seen:?}");
        }
        // No phases for transforms with an update step.
        let level = Level::new(&grid(2)).unwrap();
        let st = Stencils::new(&level, Wavelet::Bicubic);
        assert!(Phaser::new(&level, Wavelet::Bicubic, &st).is_none());
    }

    proptest! {
        #[test]
        fn synthesis_inverts_analysis_exactly(
            which in 0usize..3,
            seed in any::<u64>(),
            bits in 1u32..45,
            w in 0usize..Wavelet::ALL.len(),
        ) {
            let coarse = match which { 0 => grid(3), 1 => mixed(), _ => open_mixed() };
            let level = Level::new(&coarse).unwrap();
            let mut s = seed | 1;
            let max = (1i64 << bits) - 1;
            let orig: Vec<i64> = (0..level.fine_nv()).map(|_| {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                (s % (2 * max as u64 + 1)) as i64 - max
            }).collect();
            let mut x = orig.clone();
            let wav = Wavelet::ALL[w];
            analyse(&level, wav, &mut x);
            synthesise(&level, wav, &mut x);
            prop_assert_eq!(x, orig);
        }
    }

    /// Stencils made for another wavelet do not change interp4: it makes its own.
    #[test]
    fn interp4_with_stencils_of_another_wavelet_is_interp4() {
        let level = Level::new(&open_mixed()).unwrap();
        let orig: Vec<i64> = (0..level.fine_nv() as i64)
            .map(|i| i * i * 37 % 1001)
            .collect();
        let mut want = orig.clone();
        analyse(&level, Wavelet::Interp4, &mut want);
        assert_ne!(want, orig);
        let other = Stencils::new(&level, Wavelet::Lazy);
        let mut got = orig.clone();
        analyse_with(&level, Wavelet::Interp4, &other, &mut got, &[]);
        assert_eq!(got, want);
        synthesise_with(&level, Wavelet::Interp4, &other, &mut got, &[]);
        assert_eq!(got, orig);
    }

    /// An `n` x `n` grid's level and the fine coordinates (u, v) of its fine values:
    /// vertices at even u and v in 0..=2n, edge points at their midpoints, face points at
    /// their centres.
    fn refined_grid(n: u32) -> (Level, Vec<(i64, i64)>) {
        let level = Level::new(&grid(n)).unwrap();
        let (nv, ne, side) = (level.nv, level.ne(), n as i64 + 1);
        let mut coords = vec![(0i64, 0i64); level.fine_nv()];
        for (v, c) in coords.iter_mut().enumerate().take(nv) {
            *c = (2 * (v as i64 % side), 2 * (v as i64 / side));
        }
        for (e, &[a, b]) in level.edges.iter().enumerate() {
            let (pa, pb) = (coords[a as usize], coords[b as usize]);
            coords[nv + e] = ((pa.0 + pb.0) / 2, (pa.1 + pb.1) / 2);
        }
        for f in 0..level.nf() {
            let c = level.coarse.face(f);
            let sx: i64 = c.iter().map(|&v| coords[v as usize].0).sum();
            let sy: i64 = c.iter().map(|&v| coords[v as usize].1).sum();
            coords[nv + ne + f] = (sx / 4, sy / 4);
        }
        (level, coords)
    }

    #[test]
    fn narrow_interp_sums_are_the_wide_ones() {
        // interp4 and interp6 on a refined 8 x 8 grid, values up to the bound in either
        // sign: every edge and face sum in 64 bits equals the 128-bit sum, and a
        // value past the bound turns the 64-bit path off.
        let (level, _) = refined_grid(8);
        let n = level.fine_nv();
        let top = 1i64 << 52;
        let mut seed = 7u64;
        let mut values: Vec<Vec<i64>> = vec![vec![top; n], vec![-top; n]];
        values.push(
            (0..n)
                .map(|i| {
                    seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
                    // Alternating extremes, the worst case for the sums' magnitudes.
                    if (seed >> 33) % 2 == 0 {
                        top
                    } else {
                        -top + (i as i64 % 3)
                    }
                })
                .collect(),
        );
        for six in [false, true] {
            let st = Interp4::new(&level, six);
            for x in &values {
                assert!(i64::narrow(x));
                for e in 0..level.ne() {
                    let wide = interp4_edge_sum(&level, &st, x, e, false);
                    assert_eq!(interp4_edge_sum(&level, &st, x, e, true), wide, "edge {e}");
                }
                for f in 0..level.nf() {
                    let wide = interp4_face_sum(&level, &st, x, f, false);
                    assert_eq!(interp4_face_sum(&level, &st, x, f, true), wide, "face {f}");
                }
            }
        }
        let mut past = values[0].clone();
        past[n - 1] = top + 1;
        assert!(!i64::narrow(&past));
        assert!(!f64::narrow(&[0.0]));
    }

    #[test]
    fn interp4_reproduces_cubics_along_the_mesh_lines() {
        // A 6 x 6 grid refined once: fine coordinates (u, v) in 0..=12; data a cubic in u
        // plus a cubic in v. Where the 4-point rule applies its detail is exactly 0
        // (the lazy rule's is not), elsewhere it is the lazy rule's; and it inverts.
        let (level, coords) = refined_grid(6);
        let (nv, ne) = (level.nv, level.ne());
        let cubic = |t: i64| 7 * t * t * t - 40 * t * t + 3 * t + 11;
        let x: Vec<i64> = coords
            .iter()
            .map(|&(u, v)| cubic(u) - 2 * cubic(v))
            .collect();
        let mut y = x.clone();
        analyse(&level, Wavelet::Interp4, &mut y);
        let mut lazy = x.clone();
        analyse(&level, Wavelet::Lazy, &mut lazy);
        let mut four_point = 0;
        for e in 0..ne {
            let [a, b] = level.edges[e];
            let full = beyond_vertex(&level, e, a as usize).is_some()
                && beyond_vertex(&level, e, b as usize).is_some();
            if full {
                four_point += 1;
                assert_eq!(y[nv + e], 0, "edge {e}");
                assert_ne!(lazy[nv + e], 0, "edge {e}");
            } else {
                // The linear rule: the lazy detail, up to the rounding direction.
                assert!((y[nv + e] + lazy[nv + e]).abs() <= 1 || y[nv + e] == lazy[nv + e]);
            }
        }
        // The inner 4 of the 6 edges of every line: 5 interior lines each way, 4 boundary.
        assert_eq!(four_point, 2 * 5 * 4 + 4 * 4);
        // Face points whose both directions are complete (the inner 4 x 4) are exact.
        for f in 0..level.nf() {
            let (u, v) = coords[nv + ne + f];
            if (3..=9).contains(&u) && (3..=9).contains(&v) {
                assert_eq!(y[nv + ne + f], 0, "face at {u},{v}");
            }
        }
        synthesise(&level, Wavelet::Interp4, &mut y);
        assert_eq!(y, x);
    }

    /// The faces of an OBJ file (1-based corners, texture and normal indices ignored).
    fn obj_topology(text: &str) -> Topo {
        let mut t = Topo::new(0);
        for line in text.lines() {
            if let Some(rest) = line.strip_prefix("f ") {
                let c: Vec<u32> = rest
                    .split_whitespace()
                    .map(|w| w.split('/').next().unwrap().parse::<u32>().unwrap() - 1)
                    .collect();
                t.nv = t.nv.max(c.iter().max().map_or(0, |&m| m as usize + 1));
                t.push(&c);
            }
        }
        t
    }

    #[test]
    fn stencil_tables_equal_their_definitions() {
        // Every level of corpus/'s hierarchies (quads, triangles and pentagons, open
        // and closed, polar fans) and of ../shared/corpus when it is there, and the
        // refined grids: the one-pass tables are the definitions' tables.
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
        let mut files: Vec<std::path::PathBuf> = Vec::new();
        for dir in ["corpus", "../shared/corpus"] {
            let Ok(rd) = std::fs::read_dir(format!("{root}/{dir}")) else {
                continue;
            };
            let mut more: Vec<_> = rd
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    let name = p.to_string_lossy();
                    name.ends_with(".obj") && !name.contains(".shuffled.")
                })
                .collect();
            more.sort();
            files.extend(more);
        }
        let mut levels: Vec<(String, Level)> = Vec::new();
        for f in &files {
            let topo = obj_topology(&std::fs::read_to_string(f).unwrap());
            let name = f.display().to_string();
            if let Some(rec) = crate::topology::cc::recover(topo.nv, &topo, 16) {
                let canon = crate::topology::canonicalise(&rec, true).unwrap();
                levels.extend(canon.levels.into_iter().map(|l| (name.clone(), l)));
            }
            if let Some(canon) = crate::topology::polar::recover(topo.nv, &topo, 16) {
                levels.extend(canon.levels.into_iter().map(|l| (name.clone(), l)));
            }
        }
        let before = levels.len();
        for n in [2, 5, 8] {
            levels.push((format!("grid {n}"), refined_grid(n).0));
        }
        assert!(
            before >= 10,
            "only {before} levels found under {root}/corpus"
        );
        let mut sides = 0;
        for (name, level) in &levels {
            for six in [false, true] {
                let (fast, want) = (Interp4::new(level, six), Interp4::reference(level, six));
                assert!(fast.edge == want.edge, "{name}: beyond vertices ({six})");
                assert!(fast.face == want.face, "{name}: beyond edges ({six})");
                assert!(fast.edge2 == want.edge2, "{name}: far vertices ({six})");
                assert!(fast.face2 == want.face2, "{name}: far edges ({six})");
                sides += want.edge.iter().flatten().filter(|&&v| v != NONE).count();
            }
        }
        assert!(
            sides > 1000,
            "the levels have few beyond vertices ({sides})"
        );
    }

    #[test]
    fn interp6_reproduces_quintics_along_the_mesh_lines() {
        // An 8 x 8 grid refined once, data a quintic in u plus a quintic in v: where the
        // 6-point rule applies (three coarse vertices on each side) its detail is 0 and
        // interp4's is not; where only the 4-point rule fits, interp6 is interp4; faces
        // whose both directions reach three edges out are exact; and it inverts.
        let (level, coords) = refined_grid(8);
        let (nv, ne) = (level.nv, level.ne());
        let quintic = |t: i64| t.pow(5) - 30 * t.pow(4) + 7 * t * t * t - 40 * t * t + 3 * t + 11;
        let x: Vec<i64> = coords
            .iter()
            .map(|&(u, v)| quintic(u) - 2 * quintic(v))
            .collect();
        let (mut six, mut four) = (x.clone(), x.clone());
        analyse(&level, Wavelet::Interp6, &mut six);
        analyse(&level, Wavelet::Interp4, &mut four);
        let st = Interp4::new(&level, true);
        let mut six_point = 0;
        for e in 0..ne {
            if st.edge2[e].iter().all(|&v| v != NONE) {
                six_point += 1;
                assert_eq!(six[nv + e], 0, "edge {e}");
                assert_ne!(four[nv + e], 0, "edge {e}");
            } else {
                assert_eq!(six[nv + e], four[nv + e], "edge {e}");
            }
        }
        // The middle 4 of the 8 edges of each of the 18 lines, boundary lines included.
        assert_eq!(six_point, 18 * 4);
        let mut exact = 0;
        for f in 0..level.nf() {
            let (u, v) = coords[nv + ne + f];
            if (5..=11).contains(&u) && (5..=11).contains(&v) {
                assert_eq!(six[nv + ne + f], 0, "face at {u},{v}");
                assert_ne!(four[nv + ne + f], 0, "face at {u},{v}");
                exact += 1;
            }
        }
        assert_eq!(exact, 16);
        synthesise(&level, Wavelet::Interp6, &mut six);
        assert_eq!(six, x);
    }

    #[test]
    fn constant_and_linear_data_give_zero_detail_for_predictions() {
        // The lazy and bilinear predictions are affine-invariant: zero detail on linear
        // data over a regular grid's interior and boundary.
        let level = Level::new(&grid(4)).unwrap();
        let fine = level.fine();
        // Fine positions: coordinates of the refined grid, linear function 3x + 5y.
        let n = 9u32;
        let mut x = vec![0i64; level.fine_nv()];
        let mut coords = vec![(0i64, 0i64); level.fine_nv()];
        for v in 0..25 {
            coords[v] = (2 * (v as i64 % 5), 2 * (v as i64 / 5));
        }
        for (e, &[a, b]) in level.edges.iter().enumerate() {
            let (pa, pb) = (coords[a as usize], coords[b as usize]);
            coords[25 + e] = ((pa.0 + pb.0) / 2, (pa.1 + pb.1) / 2);
        }
        for f in 0..level.nf() {
            let c = level.coarse.face(f);
            let sx: i64 = c.iter().map(|&v| coords[v as usize].0).sum();
            let sy: i64 = c.iter().map(|&v| coords[v as usize].1).sum();
            coords[25 + level.ne() + f] = (sx / 4, sy / 4);
        }
        for (i, c) in coords.iter().enumerate() {
            x[i] = 3 * c.0 + 5 * c.1;
        }
        assert_eq!(fine.nv, (n * n) as usize);
        let mut y = x.clone();
        analyse(&level, Wavelet::Lazy, &mut y);
        assert!(y[25..].iter().all(|&d| d == 0), "{:?}", &y[25..]);
        let mut y = x.clone();
        analyse(&level, Wavelet::Bilinear, &mut y);
        assert!(y[25..].iter().all(|&d| d == 0));
    }
}

#[cfg(test)]
mod rounding {
    use super::round_div;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn fast_paths_equal_the_definition(n in any::<i64>(), shift in 0u32..70, d in 1i64..1_000_000, pow in any::<bool>()) {
            let n = (n as i128) << (shift % 40);
            let d = if pow { 1i128 << (d % 60) } else { d as i128 };
            let want = (2 * n + d).div_euclid(2 * d) as i64;
            prop_assert_eq!(round_div(n, d), want);
        }
    }
}
