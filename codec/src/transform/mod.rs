//! Bertram's B-spline wavelets on Catmull-Clark connectivity as lifting steps
//! (SPEC.md 9), in the integer form the codec runs (every step with b = 1, the sum of
//! averaged terms rounded once) and in floating point for the fidelity tests.
//!
//! A step changes one class using only the others, so synthesis (the same steps,
//! subtracted, in reverse order) undoes analysis exactly for any weights: boundary rules
//! and rounding can cost compression, never losslessness.

pub mod cc;
pub mod fit;
pub mod gregory;
pub(crate) mod level;
pub mod phase;
pub mod polar;
pub mod sqrt2;

pub use cc::{analyse_with, synthesise_with, Kind, Phaser, StencilCache, Stencils, Step};
#[cfg(any(test, feature = "internals"))]
pub use cc::{analyse, synthesise};
#[cfg(feature = "internals")]
pub use cc::{analyse_except, synthesise_except};

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

/// `floor(sqrt(v))`.
pub fn isqrt(v: u128) -> u128 {
    if v < 2 {
        return v;
    }
    let mut r = 1u128 << (64 - (v.leading_zeros() / 2) as u128).min(127) as u32;
    // Newton's iteration from above: decreasing to the floor.
    loop {
        let next = (r + v / r) / 2;
        if next >= r {
            return r;
        }
        r = next;
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
