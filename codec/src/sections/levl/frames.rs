//! The coding frames (SPEC.md 10.2, 10.3, 10.5, 10.7): coarse normals, the normal frame
//! and its predictions, tangent targets' tangential parts, and the exact integer
//! rotations of the rotated modes.

use super::*;

/// Newell's normal of coarse face `f`, in 128-bit integers (computed in 64 bits when
/// every product and sum fits, as they do for coordinates below about 2^30).
pub(super) fn face_normal(level: &Level, coarse: &[Vec<i64>; 3], f: usize) -> [i128; 3] {
    if let Some(n) = face_normal_64(level, coarse, f) {
        return n.map(|v| v as i128);
    }
    let c = level.coarse.face(f);
    let k = c.len();
    let mut n = [0i128; 3];
    for i in 0..k {
        let (a, b) = (c[i] as usize, c[(i + 1) % k] as usize);
        let (px, py, pz) = (
            coarse[0][a] as i128,
            coarse[1][a] as i128,
            coarse[2][a] as i128,
        );
        let (qx, qy, qz) = (
            coarse[0][b] as i128,
            coarse[1][b] as i128,
            coarse[2][b] as i128,
        );
        n[0] += (py - qy) * (pz + qz);
        n[1] += (pz - qz) * (px + qx);
        n[2] += (px - qx) * (py + qy);
    }
    n
}

/// [`face_normal`] in 64-bit integers, or `None` if a product or sum would overflow.
pub(super) fn face_normal_64(level: &Level, coarse: &[Vec<i64>; 3], f: usize) -> Option<[i64; 3]> {
    let c = level.coarse.face(f);
    let k = c.len();
    let mut n = [0i64; 3];
    // |values| <= 2^52, so their sums and differences fit; the products may not.
    let term = |d: i64, s: i64, acc: i64| acc.checked_add(d.checked_mul(s)?);
    let [x, y, z] = coarse;
    // Edges (c[k - 1], c[0]), (c[0], c[1]), ...: the same terms as in corner order.
    let mut a = *c.get(k.wrapping_sub(1))? as usize;
    for &b in c {
        let b = b as usize;
        let (px, py, pz) = (x[a], y[a], z[a]);
        let (qx, qy, qz) = (x[b], y[b], z[b]);
        n[0] = term(py - qy, pz + qz, n[0])?;
        n[1] = term(pz - qz, px + qx, n[1])?;
        n[2] = term(px - qx, py + qy, n[2])?;
        a = b;
    }
    Some(n)
}

/// [`face_normal_64`] of a face of at most eight corners whose values are below 2^28
/// in magnitude: no product or sum can overflow.
#[inline]
fn face_normal_small(level: &Level, coarse: [&[i64]; 3], f: usize) -> [i64; 3] {
    let c = level.coarse.face(f);
    let [x, y, z] = coarse;
    let mut n = [0i64; 3];
    let Some(&last) = c.last() else {
        return n;
    };
    let mut a = last as usize;
    for &b in c {
        let b = b as usize;
        let (px, py, pz) = (x[a], y[a], z[a]);
        let (qx, qy, qz) = (x[b], y[b], z[b]);
        n[0] += (py - qy) * (pz + qz);
        n[1] += (pz - qz) * (px + qx);
        n[2] += (px - qx) * (py + qy);
        a = b;
    }
    n
}

/// Every coarse face's normal, once per level: in 64 bits when each fits in 62 (so that
/// an edge's two faces sum in 64 bits), as coordinates below about 2^29 give; else in
/// 128.
pub(super) enum FaceNormals {
    Narrow(Vec<[i64; 3]>),
    Wide(Vec<[i128; 3]>),
}

/// Largest magnitude of a face normal kept in 64 bits.
const NARROW_NORMAL: i64 = (1 << 62) - 1;

pub(super) fn face_normals(level: &Level, coarse: &[Vec<i64>; 3]) -> FaceNormals {
    let mut narrow = Vec::with_capacity(level.nf());
    // Values below 2^28: a face of up to eight corners sums its terms (each below 2^58)
    // without a check.
    let small = coarse
        .iter()
        .all(|xk| xk[..level.nv.min(xk.len())].iter().all(|v| v.unsigned_abs() < 1 << 28));
    // The three axes cut to one length: a corner's three values take one bounds check.
    let n = coarse.iter().map(Vec::len).min().unwrap_or(0).min(level.nv);
    let cut = [&coarse[0][..n], &coarse[1][..n], &coarse[2][..n]];
    for f in 0..level.nf() {
        if small && level.coarse.face(f).len() <= 8 {
            narrow.push(face_normal_small(level, cut, f));
            continue;
        }
        match face_normal_64(level, coarse, f) {
            Some(n) if n.iter().all(|v| v.abs() <= NARROW_NORMAL) => narrow.push(n),
            _ => {
                return FaceNormals::Wide(
                    (0..level.nf())
                        .map(|f| face_normal(level, coarse, f))
                        .collect(),
                )
            }
        }
    }
    FaceNormals::Narrow(narrow)
}

/// The coding frame of a detail (SPEC.md 10.2): the axis where the coarse normal is
/// largest (coded first) and the normal reduced to at most 24 bits, or `None` when the
/// normal is zero.
#[inline(always)]
pub(super) fn frame(
    level: &Level,
    normals: &FaceNormals,
    detail: usize,
) -> Option<(usize, [i64; 3])> {
    match normals {
        FaceNormals::Narrow(n) => frame_of(level, n, detail),
        FaceNormals::Wide(n) => frame_of(level, n, detail),
    }
}

/// An integer wide enough for a detail's coarse normal.
trait NormalSum: Copy + Default + std::ops::AddAssign {
    /// Bit length of the magnitude.
    fn bits(self) -> u32;
    /// `self >> shift`, which fits 64 bits.
    fn shr(self, shift: u32) -> i64;
}

impl NormalSum for i64 {
    #[inline]
    fn bits(self) -> u32 {
        64 - self.unsigned_abs().leading_zeros()
    }
    #[inline]
    fn shr(self, shift: u32) -> i64 {
        self >> shift
    }
}

impl NormalSum for i128 {
    #[inline]
    fn bits(self) -> u32 {
        128 - self.unsigned_abs().leading_zeros()
    }
    #[inline]
    fn shr(self, shift: u32) -> i64 {
        (self >> shift) as i64
    }
}

/// [`frame`] for normals of type `T` (the same integers in either width).
#[inline(always)]
fn frame_of<T: NormalSum>(level: &Level, normals: &[[T; 3]], detail: usize) -> Option<(usize, [i64; 3])> {
    let mut n = [T::default(); 3];
    if detail < level.ne() {
        for &f in &level.edge_faces[detail] {
            if f != crate::topology::NONE {
                let m = normals[f as usize];
                for d in 0..3 {
                    n[d] += m[d];
                }
            }
        }
    } else {
        n = normals[detail - level.ne()];
    }
    let bits = n.iter().map(|v| v.bits()).max().unwrap_or(0);
    if bits == 0 {
        return None;
    }
    let shift = bits.saturating_sub(24);
    let r = n.map(|v| v.shr(shift));
    // The first axis of largest magnitude (after reduction it is still non-zero).
    let mut k = 0;
    for d in 1..3 {
        if r[d].abs() > r[k].abs() {
            k = d;
        }
    }
    Some((k, r))
}

/// Order of the coded components and their predictions from the first one.
pub(super) fn plan(fr: Option<(usize, [i64; 3])>) -> ([usize; 3], Option<[i64; 3]>) {
    match fr {
        None => ([0, 1, 2], None),
        // The first component, then the other two in axis order.
        Some((k, n)) => ([[0, 1, 2], [1, 0, 2], [2, 0, 1]][k], Some(n)),
    }
}

/// The part of target `g` tangent to the plane of normal `n` (SPEC.md 10.3):
/// `g - [(g . n) n / |n|^2]`, every component rounded alone.
pub(super) fn tangential(g: [i64; 3], n: [i64; 3]) -> [i64; 3] {
    let n2: i128 = n.iter().map(|&v| v as i128 * v as i128).sum();
    let gn: i128 = (0..3).map(|k| g[k] as i128 * n[k] as i128).sum();
    std::array::from_fn(|k| g[k] - crate::transform::round_div(gn * n[k] as i128, n2))
}

/// Prediction of component `j` from the first component's value `dk`: `[dk n_j / n_k]`.
pub(super) fn predict(dk: i64, n: [i64; 3], k: usize, j: usize) -> i64 {
    let (mut num, mut den) = (dk as i128 * n[j] as i128, n[k] as i128);
    if den < 0 {
        num = -num;
        den = -den;
    }
    crate::transform::round_div(num, den)
}

// A level may code its details in an orthonormal frame: the coarse normal, a tangent

// along the detail's coarse edge (or face diagonal) and their cross product, reached by

// exact integer rotations (SPEC.md 10.5).

/// Fixed-point bits of the rotations' lifting factors.
pub(super) const ROT_BITS: u32 = 30;

/// `[p y / 2^30]`, rounded half up.
#[inline]
pub(super) fn mul_q(p: i64, y: i64) -> i64 {
    ((p as i128 * y as i128 + (1 << (ROT_BITS - 1))) >> ROT_BITS) as i64
}

/// Bits of a plane rotation's table index: the tangent of its residual angle (at most
/// 45 degrees) in steps of 2^-10 (SPEC.md 10.5).
pub(super) const TURN_BITS: u32 = 10;

/// `TURNS[m]`: the lifting factors `(p, u)` of the exact rotation taking `(2^28, m 2^18)`
/// onto the positive first axis (SPEC.md 10.5), for `0 <= m <= 2^10`: with
/// `r = floor(sqrt(a^2 + b^2))`, `p = [b 2^30 / (r + a)]`, `u = [-b 2^30 / r]`.
pub(super) static TURNS: [(i32, i32); (1 << TURN_BITS) + 1] = {
    let mut t = [(0i32, 0i32); (1 << TURN_BITS) + 1];
    let mut m = 0;
    while m < t.len() {
        let a = 1i64 << 28;
        let b = (m as i64) << (28 - TURN_BITS);
        let v = (a * a + b * b) as u64;
        // Floor of the square root by bisection (a const context: no table, no floats).
        let (mut lo, mut hi) = (0u64, 1u64 << 30);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if mid * mid <= v {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let r = lo as i64;
        // [n / d] rounded half up (9.1), d > 0.
        let p = (2 * (b << ROT_BITS) + (r + a)).div_euclid(2 * (r + a));
        let u = (2 * (-b << ROT_BITS) + r).div_euclid(2 * r);
        t[m] = (p as i32, u as i32);
        m += 1;
    }
    t
};

/// One plane rotation of a pair of components (SPEC.md 10.5): `turns` quarter turns,
/// then three lifting steps by table factors: exactly invertible on integers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Givens {
    /// Quarter turns `(a, b) -> (b, -a)` made first, 0 to 3.
    pub(super) turns: u8,
    /// The lifting factors, `|p|, |u| <= 2^30`.
    pub(super) p: i32,
    pub(super) u: i32,
}

/// `(cos, sin)` of 0 to 3 quarter turns: a pair turned `t` times is
/// `(c a + s b, c b - s a)`, without a branch on `t`.
const TURN: [(i64, i64); 4] = [(1, 0), (0, 1), (-1, 0), (0, -1)];

impl Givens {
    /// The rotation that turns `(a, b)` to within half a table step of the positive
    /// first axis (SPEC.md 10.5): the quarter turns that leave `a' >= |b'|`, `a' > 0`,
    /// then the table's rotation for `m = [|b'| 2^10 / a']`, negated when `b' < 0`.
    /// Only the ratio of `a` and `b` matters (|a|, |b| < 2^40). Without a branch on the
    /// quadrant (normals point every way): the same rotation as
    /// `Givens::towards_by_cases` (a test), SPEC.md's cases in order.
    #[inline]
    pub(super) fn towards(a: i64, b: i64) -> Givens {
        // Steep when |b| > |a|: one turn (b > 0) or three; else none (a >= 0) or two.
        // (a = b = 0 takes no turn and table entry 0, which is no rotation.)
        let steep = b.unsigned_abs() > a.unsigned_abs();
        let turns = if steep {
            1 + 2 * (b < 0) as u8
        } else {
            2 * (a < 0) as u8
        };
        let (c, s) = TURN[turns as usize];
        let (a, b) = (c * a + s * b, c * b - s * a);
        // 0 <= |b| <= a: m in 0..=2^10, one division.
        let d = 2 * (a.max(1) as u64);
        let m = (((b.unsigned_abs() << (TURN_BITS + 1)) + a as u64) / d) as usize;
        let (p, u) = TURNS[m.min(1 << TURN_BITS)];
        let neg = -((b < 0) as i32);
        // (x ^ -1) - -1 = -x; (x ^ 0) - 0 = x.
        Givens {
            turns,
            p: (p ^ neg) - neg,
            u: (u ^ neg) - neg,
        }
    }

    /// [`Givens::towards`] as SPEC.md 10.5 states it, case by case.
    #[cfg(test)]
    pub(super) fn towards_by_cases(a: i64, b: i64) -> Givens {
        let (turns, a, b) = if a > 0 && b.abs() <= a {
            (0, a, b)
        } else if b > 0 && a.abs() < b {
            (1, b, -a)
        } else if a < 0 && b.abs() <= -a {
            (2, -a, -b)
        } else if b < 0 {
            (3, -b, a)
        } else {
            // a = b = 0: no rotation.
            return Givens { turns: 0, p: 0, u: 0 };
        };
        let m = (((b.unsigned_abs() << (TURN_BITS + 1)) + a as u64) / (2 * a as u64)) as usize;
        let (p, u) = TURNS[m];
        let (p, u) = if b < 0 { (-p, -u) } else { (p, u) };
        Givens { turns, p, u }
    }

    /// The rotation applied to the pair `(a, b)`.
    #[inline]
    pub(super) fn apply(&self, a: i64, b: i64) -> (i64, i64) {
        let (c, s) = TURN[self.turns as usize & 3];
        let (p, u) = (self.p as i64, self.u as i64);
        let (a, b) = (c * a + s * b, c * b - s * a);
        let a = a + mul_q(p, b);
        let b = b + mul_q(u, a);
        (a + mul_q(p, b), b)
    }

    /// [`Givens::apply`] undone.
    #[inline]
    pub(super) fn undo(&self, a: i64, b: i64) -> (i64, i64) {
        let (c, s) = TURN[self.turns as usize & 3];
        let (p, u) = (self.p as i64, self.u as i64);
        let a = a - mul_q(p, b);
        let b = b - mul_q(u, a);
        let a = a - mul_q(p, b);
        (c * a - s * b, c * b + s * a)
    }
}

/// `v` shifted so that its largest magnitude has 24 bits (unchanged when zero).
pub(super) fn to_24_bits(v: [i64; 3]) -> [i64; 3] {
    let big = v.iter().map(|x| x.unsigned_abs()).max().unwrap_or(0);
    if big == 0 {
        return [0; 3];
    }
    let bits = 64 - big.leading_zeros() as i32;
    let shift = bits - 24;
    if shift >= 0 {
        v.map(|x| x >> shift)
    } else {
        v.map(|x| x << -shift)
    }
}

/// A level's values per axis as slices (what the frames read of the coarse values).
pub(super) fn slices(x: &[Vec<i64>; 3]) -> [&[i64]; 3] {
    [&x[0], &x[1], &x[2]]
}

/// The rotation of a detail into its orthonormal frame (SPEC.md 10.5): normal `n` onto
/// the first component, then the tangent reference `t` onto the second.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Rotation(pub(super) [Givens; 3]);

impl Rotation {
    pub(super) fn new(n: [i64; 3], t: [i64; 3]) -> Rotation {
        let g0 = Givens::towards(n[0], n[1]);
        let (n0, _) = g0.apply(n[0], n[1]);
        let g1 = Givens::towards(n0, n[2]);
        let t = to_24_bits(t);
        let (t0, t1) = g0.apply(t[0], t[1]);
        let (_, t2) = g1.apply(t0, t[2]);
        let g2 = Givens::towards(t1, t2);
        Rotation([g0, g1, g2])
    }

    /// `g0` on components 0 and 1, `g1` on 0 and 2, `g2` on 1 and 2.
    #[inline]
    pub(super) fn forward(&self, [x, y, z]: [i64; 3]) -> [i64; 3] {
        let [g0, g1, g2] = &self.0;
        let (x, y) = g0.apply(x, y);
        let (x, z) = g1.apply(x, z);
        let (y, z) = g2.apply(y, z);
        [x, y, z]
    }

    #[inline]
    pub(super) fn inverse(&self, [x, y, z]: [i64; 3]) -> [i64; 3] {
        let [g0, g1, g2] = &self.0;
        let (y, z) = g2.undo(y, z);
        let (x, z) = g1.undo(x, z);
        let (x, y) = g0.undo(x, y);
        [x, y, z]
    }
}

/// The tangent reference of detail `fd` (SPEC.md 10.5): an edge point's coarse edge,
/// from its first end to its second; a face point's diagonal from its face's first
/// corner to its third (to the second for a triangle).
/// (Values are at most 2^52 in magnitude, 9.3: their differences fit 64 bits.)
pub(super) fn tangent_ref(level: &Level, coarse: [&[i64]; 3], fd: usize) -> [i64; 3] {
    let (a, b) = if fd < level.ne() {
        let [a, b] = level.edges[fd];
        (a, b)
    } else {
        let c = level.coarse.face(fd - level.ne());
        (c[0], if c.len() >= 4 { c[2] } else { c[1] })
    };
    std::array::from_fn(|k| coarse[k][b as usize] - coarse[k][a as usize])
}

/// Format 17's along-edge offset (SPEC.md 10.5): sixteen times the offset of the mean of
/// an interior edge's two coarse face centroids from the edge's midpoint, rounded; `None`
/// for a boundary edge or a component above 2^52.
pub(super) fn edge_offset(level: &Level, coarse: [&[i64]; 3], e: usize) -> Option<[i64; 3]> {
    let [f1, f2] = level.edge_faces[e];
    if f1 == crate::topology::NONE || f2 == crate::topology::NONE {
        return None;
    }
    let (c1, c2) = (
        level.coarse.face(f1 as usize),
        level.coarse.face(f2 as usize),
    );
    let (k1, k2) = (c1.len() as i128, c2.len() as i128);
    let [a, b] = level.edges[e];
    let mut out = [0i64; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let x = &coarse[k];
        let sum = |c: &[u32]| c.iter().map(|&v| x[v as usize] as i128).sum::<i128>();
        let ends = x[a as usize] as i128 + x[b as usize] as i128;
        let num = 16 * (k2 * sum(c1) + k1 * sum(c2) - k1 * k2 * ends);
        let v = crate::transform::round_div(num, 2 * k1 * k2);
        if v.abs() > 1 << 52 {
            return None;
        }
        *o = v;
    }
    Some(out)
}

/// A detail's rotation into its frame (SPEC.md 10.5) and, for an interior edge point,
/// its rotated edge offset (see [`edge_offset`]).
#[derive(Clone, Copy)]
pub(super) struct RotFrame {
    pub(super) rot: Rotation,
    pub(super) offset: Option<[i64; 2]>,
}

impl RotFrame {
    /// The frame of detail `fd` with coarse normal `n`; without an edge point's offset
    /// unless `offset` (only [`Mode::Shifted`] reads it).
    pub(super) fn new(
        level: &Level,
        coarse: [&[i64]; 3],
        family: Family,
        fd: usize,
        n: [i64; 3],
        offset: bool,
    ) -> Self {
        let rot = Rotation::new(n, tangent_ref(level, coarse, fd));
        RotFrame::with(level, coarse, family, fd, rot, offset)
    }

    /// [`RotFrame::new`] with its rotation made.
    #[inline]
    pub(super) fn with(
        level: &Level,
        coarse: [&[i64]; 3],
        family: Family,
        fd: usize,
        rot: Rotation,
        offset: bool,
    ) -> Self {
        let offset = if offset && family != Family::Sqrt2 && fd < level.ne() {
            edge_offset(level, coarse, fd).map(|v| {
                let [_, a, b] = rot.forward(v);
                [a, b]
            })
        } else {
            None
        };
        RotFrame { rot, offset }
    }

    /// What mode `mode` subtracts from the rotated values: eighths `(a, b)` of the
    /// offset's tangential values with [`Mode::Shifted`], else nothing.
    pub(super) fn pred(&self, mode: Mode<'_>) -> [i64; 3] {
        match (mode, self.offset) {
            (Mode::Shifted(a, b), Some(w)) => [
                0,
                crate::transform::round_div(a as i128 * w[0] as i128, 128),
                crate::transform::round_div(b as i128 * w[1] as i128, 128),
            ],
            _ => [0; 3],
        }
    }
}

/// A detail's normal frame as [`frame`] gives it, packed in 16 bytes (the reduced
/// normal fits 32 bits): the encoder keeps one per detail for a level's modes rather
/// than the coarse faces' 128-bit normals (48 bytes a face), for the memory of large
/// meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct NormalFrame {
    /// The axis coded first; 3 where the normal is zero (no frame).
    axis: u8,
    n: [i32; 3],
}

impl NormalFrame {
    /// Packs what [`frame`] gives.
    pub(super) fn pack(fr: Option<(usize, [i64; 3])>) -> NormalFrame {
        match fr {
            Some((k, n)) => NormalFrame {
                axis: k as u8,
                n: n.map(|v| v as i32),
            },
            None => NormalFrame { axis: 3, n: [0; 3] },
        }
    }

    /// What [`frame`] gave.
    pub(super) fn get(self) -> Option<(usize, [i64; 3])> {
        (self.axis < 3).then(|| (self.axis as usize, self.n.map(i64::from)))
    }
}

/// Every detail's normal frame (SPEC.md 10.2), once per level for the encoder's
/// framed and rotated modes: detail `i` is frame detail `fd` = `i` (Catmull-Clark,
/// polar) or the edge count plus `i` (sqrt(2): every detail is a face point).
pub(super) fn normal_frames(level: &Level, coarse: &[Vec<i64>; 3], family: Family) -> Vec<NormalFrame> {
    sampled_normal_frames(level, coarse, family, Sample::All)
}

/// [`normal_frames`] of the details in `sample` (none, `NormalFrame::pack(None)`, for
/// the others).
pub(super) fn sampled_normal_frames(
    level: &Level,
    coarse: &[Vec<i64>; 3],
    family: Family,
    sample: Sample,
) -> Vec<NormalFrame> {
    let normals = face_normals(level, coarse);
    let ne = if family == Family::Sqrt2 { level.ne() } else { 0 };
    (0..family.details(level))
        .map(|i| NormalFrame::pack(sample.has(i).then(|| frame(level, &normals, ne + i)).flatten()))
        .collect()
}

/// Every detail's [`RotFrame`] for the encoder's rotated modes, made once per level and
/// stored in two parts (the memory of large meshes): the rotations per detail, and the
/// edge offsets per edge detail (none on sqrt(2) levels).
#[derive(Default)]
pub(super) struct RotFrames {
    rots: Vec<Option<Rotation>>,
    offsets: Vec<Option<[i64; 2]>>,
}

impl RotFrames {
    /// Number of details.
    pub(super) fn len(&self) -> usize {
        self.rots.len()
    }

    /// Detail `i`'s frame; `None` where its coarse normal is zero.
    pub(super) fn get(&self, i: usize) -> Option<RotFrame> {
        Some(RotFrame {
            rot: (*self.rots.get(i)?)?,
            offset: self.offsets.get(i).copied().flatten(),
        })
    }

    /// Every detail's frame, in order.
    pub(super) fn iter(&self) -> impl Iterator<Item = Option<RotFrame>> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

/// Every detail's [`RotFrame`] (`None` where the coarse normal is zero), computed once
/// per level for all the encoder's rotated modes, from the details' normal `frames`;
/// with the edge points' offsets where `offsets` (only [`Mode::Shifted`] reads them).
pub(super) fn rot_frames(
    level: &Level,
    coarse: &[Vec<i64>; 3],
    frames: &[NormalFrame],
    family: Family,
    offsets: bool,
) -> RotFrames {
    let ne = if family == Family::Sqrt2 { level.ne() } else { 0 };
    let edges = if family == Family::Sqrt2 || !offsets { 0 } else { level.ne() };
    let mut out = RotFrames {
        rots: Vec::with_capacity(frames.len()),
        offsets: Vec::with_capacity(edges.min(frames.len())),
    };
    for (i, f) in frames.iter().enumerate() {
        let fd = ne + i;
        let made = f.get().map(|(_, n)| RotFrame::new(level, slices(coarse), family, fd, n, offsets));
        out.rots.push(made.map(|r| r.rot));
        if i < edges {
            out.offsets.push(made.and_then(|r| r.offset));
        }
    }
    out
}

/// The encoder's choice of mode 5's shift weights for a level (not normative): for
/// each tangential value the eighth in 0..=8 whose residuals have the fewest bits.
pub(super) fn shift_weights(
    level: &Level,
    x: &[Vec<i64>; 3],
    frames: &RotFrames,
) -> (u8, u8) {
    let mut cost = [[0u64; 9]; 2];
    for (i, f) in frames.iter().enumerate() {
        let Some(RotFrame {
            rot,
            offset: Some(w),
        }) = f
        else {
            continue;
        };
        let d = rot.forward([x[0][level.nv + i], x[1][level.nv + i], x[2][level.nv + i]]);
        for (slot, c) in cost.iter_mut().enumerate() {
            for (q, cq) in c.iter_mut().enumerate() {
                let p = crate::transform::round_div(q as i128 * w[slot] as i128, 128);
                *cq += class_of(d[slot + 1].saturating_sub(p)) as u64;
            }
        }
    }
    let best = |c: &[u64; 9]| (0..9).min_by_key(|&q| (c[q], q)).unwrap_or(0) as u8;
    (best(&cost[0]), best(&cost[1]))
}

/// How a detail's values are phased (SPEC.md 10.6, 10.7).
#[derive(Clone, Copy)]
pub(super) enum Phased {
    /// Not at all (modes 0 to 5).
    No,
    /// Mode 6: every value signed and modelled by the phase of its axis.
    Axes([u8; 3]),
    /// Mode 7: the values after the first shifted by their expected part and phased.
    Tangent(TanTerms),
}

/// Mode 7's terms of a detail (SPEC.md 10.7): `u_d = rho_d + c Q_d` per axis, with `rho`
/// the remainders of its face's centroid, `Q` the normal part of its tangent target, `c`
/// its face's corner count.
#[derive(Clone, Copy)]
pub(super) struct TanTerms {
    pub(super) u: [i128; 3],
    pub(super) c: i128,
}

impl TanTerms {
    /// The terms of the face point of face `f` whose tangent target `g` has the
    /// tangential part `t` (so `Q = g - t`), from the coarse values.
    pub(super) fn new(
        level: &Level,
        coarse: &[Vec<i64>; 3],
        f: usize,
        g: [i64; 3],
        t: [i64; 3],
    ) -> Self {
        let face = level.coarse.face(f);
        let c = face.len() as i128;
        let mut u = [0i128; 3];
        for (k, uk) in u.iter_mut().enumerate() {
            let x = &coarse[k];
            // Values below 2^52 (9.3): a face of up to 2^10 corners sums in 64 bits.
            let s = if face.len() <= 1 << 10 {
                face.iter().map(|&v| x[v as usize]).sum::<i64>() as i128
            } else {
                face.iter().map(|&v| x[v as usize] as i128).sum()
            };
            let rho = s - c * crate::transform::round_div(s, c) as i128;
            *uk = rho + c * (g[k] as i128 - t[k] as i128);
        }
        TanTerms { u, c }
    }

    /// The shift and phase of the value at axis `j` (not the first, `k`) given the first
    /// value `rk` and the value's prediction `pred = [rk n_j / n_k]`: `A / D` with
    /// `A = n_k u_j - n_j u_k + c (rk n_j - n_k pred)`, `D = c n_k` (both negated when
    /// `n_k < 0`) is its expected value; the shift is `[A / D]`, the phase that of the
    /// remainder. `None` when the shift's magnitude passes 2^52.
    pub(super) fn shift(
        &self,
        n: [i64; 3],
        k: usize,
        j: usize,
        rk: i64,
        pred: i64,
    ) -> Option<(i64, u8)> {
        self.shift_64(n, k, j, rk, pred)
            .unwrap_or_else(|| self.shift_128(n, k, j, rk, pred))
    }

    /// [`TanTerms::shift`] in 128-bit arithmetic.
    pub(super) fn shift_128(
        &self,
        n: [i64; 3],
        k: usize,
        j: usize,
        rk: i64,
        pred: i64,
    ) -> Option<(i64, u8)> {
        let (nk, nj) = (n[k] as i128, n[j] as i128);
        let mut a =
            nk * self.u[j] - nj * self.u[k] + self.c * (rk as i128 * nj - nk * pred as i128);
        let mut d = self.c * nk;
        if d < 0 {
            a = -a;
            d = -d;
        }
        // 9.1's rounding, in 64 bits when it fits (a 128-bit division is slow).
        let q = match (i64::try_from(2 * a + d), i64::try_from(2 * d)) {
            (Ok(t), Ok(dd)) => t.div_euclid(dd) as i128,
            _ => (2 * a + d).div_euclid(2 * d),
        };
        if q.abs() > MAX_LIFTED as i128 {
            return None;
        }
        Some((q as i64, phase(a - q * d, d)))
    }

    /// [`TanTerms::shift`] in 64-bit arithmetic, the same integers exactly; `None`
    /// when a term would overflow (then 128 bits decide).
    #[inline]
    pub(super) fn shift_64(
        &self,
        n: [i64; 3],
        k: usize,
        j: usize,
        rk: i64,
        pred: i64,
    ) -> Option<Option<(i64, u8)>> {
        let (nk, nj) = (n[k], n[j]);
        let (uj, uk, c) = (
            i64::try_from(self.u[j]).ok()?,
            i64::try_from(self.u[k]).ok()?,
            i64::try_from(self.c).ok()?,
        );
        let inner = rk.checked_mul(nj)?.checked_sub(nk.checked_mul(pred)?)?;
        let mut a = nk
            .checked_mul(uj)?
            .checked_sub(nj.checked_mul(uk)?)?
            .checked_add(c.checked_mul(inner)?)?;
        let mut d = c.checked_mul(nk)?;
        if d < 0 {
            a = a.checked_neg()?;
            d = d.checked_neg()?;
        }
        let q = a
            .checked_mul(2)?
            .checked_add(d)?
            .div_euclid(d.checked_mul(2)?);
        if q.abs() > MAX_LIFTED {
            return Some(None);
        }
        let r = a.checked_sub(q.checked_mul(d)?)?;
        Some(Some((q, phase(r as i128, d as i128))))
    }
}
