//! OpenSubdiv's end-cap patches (SPEC.md 9.10, "End caps"): where a modelling tool
//! evaluates its limit surface through OpenSubdiv at an isolation level Q (Blender's
//! "Quality", 3 by default), a face of level Q beside an extraordinary vertex is not
//! refined further: its points are evaluated on a Gregory patch (OpenSubdiv's
//! `GregoryConverter` and `EvalBasisGregory`, Loop, Schaefer, Ni and Castano 2009)
//! whose twenty points are fixed combinations of the face's corners' one-rings. This
//! module computes those patches from the level-Q values in integers (the masks'
//! cosines and eigenvalue terms at 2^-40) and evaluates them at the finest vertices
//! inside the faces.

use super::fit::{Hard, SHARP_INFINITE};
use crate::topology::{Level, Topo, NONE};

/// Fixed point of the patch masks' weights: 2^40.
const W: i128 = 1 << 40;
/// A patch point's value is its mask's sum over 2^24: the values at 2^-16.
const POINT_SHIFT: u32 = 24;
/// Fixed point of the evaluation weights: 2^32.
const EVAL_BITS: u32 = 32;

/// Most edges a corner of an end-cap patch may have (SPEC.md 9.10): a face beside a
/// vertex with more is left at the limit.
pub const MAX_VALENCE: usize = 64;

/// Most levels past the isolation level the end caps are evaluated over (SPEC.md
/// 9.10): a container asking for more is malformed.
pub const MAX_DEPTH: u32 = 12;

/// Rounding of 9.1 in 128 bits: `[n / d]` for `d > 0`.
fn round128(n: i128, d: i128) -> i128 {
    (2 * n + d).div_euclid(2 * d)
}

/// π at 2^-60.
const PI_Q60: i128 = 3_622_009_729_038_561_421;
const ONE_Q60: i128 = 1 << 60;

/// cos and sin of `2 pi k / n` at 2^-60 (`k < n`): the quadrant exactly, the rest by
/// their Taylor series.
fn cos_sin_q60(k: usize, n: usize) -> (i128, i128) {
    let (q, r) = ((4 * k) / n, (4 * k) % n);
    let x = PI_Q60 * r as i128 / (2 * n as i128);
    let x2 = (x * x) >> 60;
    let (mut c, mut s) = (ONE_Q60, x);
    let (mut tc, mut ts) = (ONE_Q60, x);
    for i in 1..=24i128 {
        tc = -((tc * x2) >> 60) / ((2 * i - 1) * (2 * i));
        ts = -((ts * x2) >> 60) / ((2 * i) * (2 * i + 1));
        c += tc;
        s += ts;
    }
    if r == 0 {
        (c, s) = (ONE_Q60, 0);
    }
    match q {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

/// `cos(2 pi k / n)` at 2^-40 (SPEC.md 9.10). Each valence's cosines are made once
/// (`Valence`): a series of 24 terms in 128-bit divisions per value, where every
/// edge point of an end cap takes three per edge.
pub fn cos_q40(k: usize, n: usize) -> i128 {
    match Valence::of(n) {
        Some(v) => v.cos[k % n],
        None => cos_q40_series(k, n),
    }
}

fn cos_q40_series(k: usize, n: usize) -> i128 {
    round128(cos_sin_q60(k % n, n).0, 1 << 20)
}

/// A valence's cosines and tangent scale, made at their first use.
struct Valence {
    cos: Vec<i128>,
    tangent_scale: i128,
}

impl Valence {
    /// Valence `n`'s, for `1 <= n <= MAX_VALENCE` (the end caps' corners).
    fn of(n: usize) -> Option<&'static Valence> {
        static MADE: [std::sync::OnceLock<Valence>; MAX_VALENCE + 1] =
            [const { std::sync::OnceLock::new() }; MAX_VALENCE + 1];
        let made = MADE.get(n).filter(|_| n > 0)?;
        Some(made.get_or_init(|| Valence {
            cos: (0..n).map(|k| cos_q40_series(k, n)).collect(),
            tangent_scale: tangent_scale_series(n),
        }))
    }
}

/// OpenSubdiv's tangent scale of a vertex of `n` edges at 2^-40 (SPEC.md 9.10):
/// `16 / (n ((c + 5) + sqrt((c + 9)(c + 1))))`, `c = cos(2 pi / n)`; made once per
/// valence (`Valence`).
pub fn tangent_scale_q40(n: usize) -> i128 {
    match Valence::of(n) {
        Some(v) => v.tangent_scale,
        None => tangent_scale_series(n),
    }
}

fn tangent_scale_series(n: usize) -> i128 {
    let c = cos_sin_q60(1 % n, n).0;
    let prod = ((c + 9 * ONE_Q60) * (c + ONE_Q60)) as u128;
    let root = super::isqrt(prod) as i128;
    let den = n as i128 * ((c + 5 * ONE_Q60) + root);
    round128(16 << 100, den)
}

/// A corner of an end-cap patch: its vertex and one-ring, counterclockwise from the
/// patch's next corner: `edges[j]` the other end of edge j, `opp[j]` the corner of
/// face j opposite the vertex (face 0 the patch, between edges 0 and 1).
struct Corner {
    v: u32,
    edges: Vec<u32>,
    opp: Vec<u32>,
    /// Infinitely sharp (OpenSubdiv's sharp corner: kept, its edge points a third of
    /// the way to the patch's next and previous corners).
    sharp: bool,
}

impl Corner {
    /// The corner at `slot` of quad `f` of `level`, if smooth and inside: no boundary
    /// or sharp edge, not sharp itself, 3 to [`MAX_VALENCE`] edges, every face a quad
    /// and the faces around it one cycle with the orientation of `f`.
    fn new(level: &Level, f: usize, slot: usize, hard: Hard<'_>) -> Option<Corner> {
        let v = level.coarse.face(f)[slot];
        let n = level.v_edges(v as usize).len();
        // An infinitely sharp vertex is a sharp corner; any other sharpness, none.
        let sharp = match hard.vertices.get(v as usize).copied().unwrap_or(0) {
            0 => false,
            s if s >= SHARP_INFINITE => true,
            _ => return None,
        };
        if !(3..=MAX_VALENCE).contains(&n) || level.v_faces(v as usize).len() != n || hard.bilinear
        {
            return None;
        }
        for &e in level.v_edges(v as usize) {
            if level.is_boundary(e as usize) || hard.edges.get(e as usize).is_some_and(|&s| s > 0)
            {
                return None;
            }
        }
        let (mut edges, mut opp) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let (mut g, mut i) = (f, slot);
        for _ in 0..n {
            let face = level.coarse.face(g);
            if face.len() != 4 {
                return None;
            }
            edges.push(face[(i + 1) % 4]);
            opp.push(face[(i + 2) % 4]);
            // Across the edge to the previous corner, where it leaves v.
            let e = level.f_edges(g)[(i + 3) % 4];
            let [a, b] = level.edge_faces[e as usize];
            let h = if a as usize == g { b } else { a };
            if h == NONE {
                return None;
            }
            let h = h as usize;
            let j = level.coarse.face(h).iter().position(|&u| u == v)?;
            if level.f_edges(h)[j] != e {
                return None;
            }
            (g, i) = (h, j);
        }
        (g == f && i == slot).then_some(Corner {
            v,
            edges,
            opp,
            sharp,
        })
    }

    fn n(&self) -> usize {
        self.edges.len()
    }

    /// The limit mask (P) at 2^-40.
    fn position(&self) -> Vec<(u32, i128)> {
        if self.sharp {
            return vec![(self.v, W)];
        }
        let n = self.n() as i128;
        let mut row = vec![(self.v, round128(n * W, n + 5))];
        let (e, o) = (round128(4 * W, n * (n + 5)), round128(W, n * (n + 5)));
        for j in 0..self.n() {
            row.push((self.edges[j], e));
            row.push((self.opp[j], o));
        }
        row
    }

    /// The edge point along edge `r` (0: Ep, toward the next corner; 1: Em, toward
    /// the previous) at 2^-40: the limit mask plus the scaled limit tangent.
    fn edge_point(&self, r: usize) -> Vec<(u32, i128)> {
        if self.sharp {
            return vec![(self.v, round128(2 * W, 3)), (self.edges[r], round128(W, 3))];
        }
        let n = self.n();
        let scale = tangent_scale_q40(n);
        let cos = |k: usize| cos_q40((k + n * 2 - r) % n, n);
        let den = 2 * (n as i128 + 5) * W;
        let mut row = self.position();
        for j in 0..n {
            let (cp, c, cn) = (cos(j + n - 1), cos(j), cos(j + 1));
            row[1 + 2 * j].1 += round128(scale * (2 * cp + 4 * c + 2 * cn), den);
            row[2 + 2 * j].1 += round128(scale * (c + cn), den);
        }
        row
    }

    /// The face point's twist terms about edge `k` (SPEC.md 9.10) at 2^-40, signed.
    fn twist(&self, k: usize, sign: i128) -> Vec<(u32, i128)> {
        let n = self.n();
        let (p, x) = ((k + n - 1) % n, (k + 1) % n);
        let (ninth, eighteenth) = (round128(W, 9), round128(W, 18));
        vec![
            (self.edges[p], -sign * ninth),
            (self.opp[p], -sign * eighteenth),
            (self.opp[k], sign * eighteenth),
            (self.edges[x], sign * ninth),
        ]
    }
}

/// A mask's value on axis values `x`: its sum over 2^24 (the value at 2^-16).
fn value(mask: &[(u32, i128)], x: &[i64]) -> i128 {
    let s: i128 = mask.iter().map(|&(u, w)| w * x[u as usize] as i128).sum();
    round128(s, 1 << POINT_SHIFT)
}

/// `mask` scaled by `c` (at 2^-40), appended to `out`: each weight `[c w / 2^40]`.
fn scaled(out: &mut Vec<(u32, i128)>, mask: &[(u32, i128)], c: i128) {
    out.extend(mask.iter().map(|&(u, w)| (u, round128(c * w, W))));
}

/// The masks of the twenty points of the Gregory patch with corners `c` (SPEC.md
/// 9.10), at 2^-40: per corner `k`, `5 k + 0..5` = P, Ep, Em, Fp, Fm.
fn masks(c: &[Corner; 4]) -> [Vec<(u32, i128)>; 20] {
    let mut m: [Vec<(u32, i128)>; 20] = Default::default();
    for k in 0..4 {
        m[5 * k] = c[k].position();
        m[5 * k + 1] = c[k].edge_point(0);
        m[5 * k + 2] = c[k].edge_point(1);
    }
    let cos1: Vec<i128> = c.iter().map(|k| cos_q40(1, k.n())).collect();
    for k in 0..4 {
        let (next, prev) = ((k + 1) % 4, (k + 3) % 4);
        let near = cos1[k];
        let d = round128(2 * near, 3);
        for (far, e_near, e_far, edge, sign, slot) in [
            (cos1[next], 1, 5 * next + 2, 0, 1, 3),
            (cos1[prev], 2, 5 * prev + 1, 1, -1, 4),
        ] {
            let a = round128(far, 3);
            let b = round128(3 * W - 2 * near - far, 3);
            let mut f = Vec::new();
            scaled(&mut f, &m[5 * k], a);
            scaled(&mut f, &m[5 * k + e_near], b);
            scaled(&mut f, &m[e_far], d);
            f.extend(c[k].twist(edge, sign));
            m[5 * k + slot] = f;
        }
    }
    m
}

/// The Bernstein weights of the cubic at `a / d`, times `d^3`.
fn bernstein(a: i128, d: i128) -> [i128; 4] {
    let b = d - a;
    [b * b * b, 3 * a * b * b, 3 * a * a * b, a * a * a]
}

/// The Gregory patch's weights at `(a, b) / d` (`d = 2^depth`, not a corner) on its
/// twenty points, at 2^-32: OpenSubdiv's `EvalBasisGregory`.
fn weights([a, b]: [u32; 2], depth: u32) -> [i128; 20] {
    let d = 1i128 << depth;
    let (a, b) = (a as i128, b as i128);
    let (bs, bt) = (bernstein(a, d), bernstein(b, d));
    let d6 = 1i128 << (6 * depth);
    let weight = |i: usize, j: usize, num: i128, den: i128| {
        round128((bs[i] * bt[j] * num) << EVAL_BITS, d6 * den)
    };
    let mut w = [0i128; 20];
    // Boundary points: (point, column s, row t).
    const BOUNDARY: [(usize, usize, usize); 12] = [
        (0, 0, 0),
        (1, 1, 0),
        (7, 2, 0),
        (5, 3, 0),
        (2, 0, 1),
        (6, 3, 1),
        (16, 0, 2),
        (12, 3, 2),
        (15, 0, 3),
        (17, 1, 3),
        (11, 2, 3),
        (10, 3, 3),
    ];
    for (p, i, j) in BOUNDARY {
        w[p] = weight(i, j, 1, 1);
    }
    // Interior pairs (f+, f-) at (column, row), blended by (num+, num-) / their sum.
    let (ac, bc) = (d - a, d - b);
    for (plus, minus, i, j, np, nm) in [
        (3, 4, 1, 1, a, b),
        (8, 9, 2, 1, b, ac),
        (13, 14, 2, 2, ac, bc),
        (18, 19, 1, 2, bc, a),
    ] {
        w[plus] = weight(i, j, np, np + nm);
        w[minus] = weight(i, j, nm, np + nm);
    }
    w
}

/// The patch's value from its points (`pts`, at 2^-16) with `weights`.
fn evaluate(pts: &[i128; 20], weights: &[i128; 20]) -> i64 {
    let sum: i128 = pts.iter().zip(weights).map(|(p, w)| p * w).sum();
    round128(sum, 1 << (EVAL_BITS + 16)) as i64
}

/// The end caps of a refinement (SPEC.md 9.10): the Gregory patches of the faces of
/// level Q beside an extraordinary vertex, and, followed down the levels, the faces
/// they became with their corners' parameters.
pub struct EndCaps {
    /// Vertices of level Q (their values are the limit's: never replaced).
    nv: usize,
    /// Per patch, its corners (their rings; the points' masks are made from them
    /// when needed, and the corners dropped once the points have values).
    corners: Vec<[Corner; 4]>,
    /// Per patch, its points' values per axis (empty until [`EndCaps::values`]).
    points: Vec<[[i128; 20]; 3]>,
    /// Faces of the current level inside a patch: the face, its patch and its corners'
    /// parameters in units of `2^-depth` of the patch's side.
    faces: Vec<(u32, u32, [[u32; 2]; 4])>,
    /// Levels refined past Q.
    depth: u32,
}

impl EndCaps {
    /// The end caps of `level` (whose coarse mesh is level Q, every face a quad) with
    /// sharp features `hard`, also at the vertices set in `semi` (those with a finite
    /// sharpness there): `None` where it has none.
    pub fn new(level: &Level, hard: Hard<'_>, semi: &[bool]) -> Option<EndCaps> {
        let mut caps = EndCaps {
            nv: level.nv,
            corners: Vec::new(),
            points: Vec::new(),
            faces: Vec::new(),
            depth: 0,
        };
        for f in 0..level.nf() {
            let face = level.coarse.face(f);
            let sharp = |v: u32| hard.vertices.get(v as usize).is_some_and(|&s| s > 0);
            if face.len() != 4
                || face.iter().all(|&v| {
                    level.v_edges(v as usize).len() == 4 && !sharp(v) && !semi[v as usize]
                })
            {
                continue;
            }
            let corners: Option<Vec<Corner>> =
                (0..4).map(|k| Corner::new(level, f, k, hard)).collect();
            let Some(Ok(corners)) = corners.map(<[Corner; 4]>::try_from) else {
                continue;
            };
            caps.faces.push((
                f as u32,
                caps.corners.len() as u32,
                [[0, 0], [1, 0], [1, 1], [0, 1]],
            ));
            caps.corners.push(corners);
        }
        (!caps.corners.is_empty()).then_some(caps)
    }

    /// The patches' points from the values `x` of level Q (the corners are dropped:
    /// [`EndCaps::rows`] needs them, and is not for caps with values).
    pub fn values(&mut self, x: &[Vec<i64>; 3]) {
        self.points = self
            .corners
            .iter()
            .map(|c| {
                let m = masks(c);
                std::array::from_fn(|axis| std::array::from_fn(|i| value(&m[i], &x[axis])))
            })
            .collect();
        self.corners = Vec::new();
    }

    /// Follows the faces one level down, `level` the refinement just made (whose
    /// coarse mesh is the current one): a face's children are its corners (8.1).
    pub fn below(&mut self, level: &Level) {
        let mut next = Vec::with_capacity(self.faces.len() * 4);
        for &(f, p, c) in &self.faces {
            let start = level.coarse.starts[f as usize];
            let mid = [
                (c[0][0] + c[1][0] + c[2][0] + c[3][0]) / 2,
                (c[0][1] + c[1][1] + c[2][1] + c[3][1]) / 2,
            ];
            for i in 0..4 {
                let (n, q) = (c[(i + 1) % 4], c[(i + 3) % 4]);
                let k = c[i];
                next.push((
                    start + i as u32,
                    p,
                    [
                        [2 * k[0], 2 * k[1]],
                        [k[0] + n[0], k[1] + n[1]],
                        mid,
                        [k[0] + q[0], k[1] + q[1]],
                    ],
                ));
            }
        }
        self.faces = next;
        self.depth += 1;
    }

    /// The vertices of `topo` (the current level's mesh) inside a patch and not of
    /// level Q, each once with its patch and parameters (the first such face's, in
    /// face order).
    fn inside(&self, topo: &Topo) -> Vec<(usize, u32, [u32; 2])> {
        let mut done = vec![false; topo.nv];
        let mut out = Vec::new();
        if self.depth == 0 {
            return out;
        }
        for &(f, p, c) in &self.faces {
            for (&v, &at) in topo.face(f as usize).iter().zip(&c) {
                let v = v as usize;
                if v >= self.nv && !done[v] {
                    done[v] = true;
                    out.push((v, p, at));
                }
            }
        }
        out
    }

    /// Gives every vertex of `topo` (the current level's mesh) inside a patch and not
    /// of level Q the patch's value there ([`EndCaps::values`] first).
    pub fn place(&self, topo: &Topo, x: &mut [Vec<i64>; 3]) {
        for (v, p, at) in self.inside(topo) {
            let w = weights(at, self.depth);
            for (xs, pts) in x.iter_mut().zip(&self.points[p as usize]) {
                xs[v] = evaluate(pts, &w);
            }
        }
    }

    /// The same as a linear map in floating point, for the encoder's least squares:
    /// the patches' points, twenty per patch in order, as weights on the vertices of
    /// level Q; and per vertex of `topo` [`EndCaps::place`] gives a value, its weights
    /// on the points.
    #[allow(clippy::type_complexity)]
    pub fn rows(&self, topo: &Topo) -> (Vec<Vec<(u32, f64)>>, Vec<(usize, Vec<(u32, f64)>)>) {
        let points = self
            .corners
            .iter()
            .flat_map(masks)
            .map(|m| m.iter().map(|&(u, w)| (u, w as f64 / W as f64)).collect())
            .collect();
        let scale = 1.0 / (1u64 << EVAL_BITS) as f64;
        let vertices = self
            .inside(topo)
            .into_iter()
            .map(|(v, p, at)| {
                let w = weights(at, self.depth);
                let row = (0..20)
                    .filter(|&i| w[i] != 0)
                    .map(|i| (20 * p + i as u32, w[i] as f64 * scale))
                    .collect();
                (v, row)
            })
            .collect();
        (points, vertices)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transform::fit::{place_on_limit, subdivide, Rules, Sharpness};

    #[test]
    fn the_masks_trigonometry_is_the_nearest_fixed_point() {
        // (Floating point only here, to check the integers: within a unit at 2^-40.)
        for n in 3..=MAX_VALENCE {
            for k in 0..n {
                let c = (2.0 * std::f64::consts::PI * k as f64 / n as f64).cos();
                let want = (c * W as f64).round() as i128;
                assert!((cos_q40(k, n) - want).abs() <= 1, "cos {k}/{n}");
            }
            let c = (2.0 * std::f64::consts::PI / n as f64).cos();
            let s = 16.0 / (n as f64 * ((c + 5.0) + ((c + 9.0) * (c + 1.0)).sqrt()));
            let want = (s * W as f64).round() as i128;
            assert!((tangent_scale_q40(n) - want).abs() <= 1, "scale {n}");
        }
        // Exact where the value is: a quarter turn, and the regular vertex's 1/2.
        // The valences' tables are the series' values.
        for n in 1..=MAX_VALENCE + 2 {
            assert_eq!(tangent_scale_q40(n), tangent_scale_series(n), "scale {n}");
            for k in 0..2 * n {
                assert_eq!(cos_q40(k, n), cos_q40_series(k, n), "cos {k}/{n}");
            }
        }
        assert_eq!(cos_q40(1, 4), 0);
        assert_eq!(cos_q40(2, 4), -W);
        assert_eq!(tangent_scale_q40(4), W / 2);
        // OpenSubdiv's table (catmarkPatchBuilder.cpp) for 3 and 5 edges.
        assert!((tangent_scale_q40(3) as f64 / W as f64 - 8.128_157_290_637_231e-1).abs() < 1e-12);
        assert!((tangent_scale_q40(5) as f64 / W as f64 - 3.636_440_632_914_28e-1).abs() < 1e-12);
    }

    /// An 8 x 8 grid of quads, heights pseudo-random, at 2^10.
    fn grid() -> (Level, [Vec<i64>; 3]) {
        let mut t = Topo::new(81);
        for y in 0..8u32 {
            for x in 0..8u32 {
                let v = y * 9 + x;
                t.push(&[v, v + 1, v + 10, v + 9]);
            }
        }
        let z = crate::topology::fixtures::pseudo(5, 81, 20);
        let x = [
            (0..81).map(|v| (v % 9) << 16).collect(),
            (0..81).map(|v| (v / 9) << 16).collect(),
            z,
        ];
        (Level::new(&t).unwrap(), x)
    }

    #[test]
    fn a_patch_of_regular_corners_is_the_limit_surface() {
        // Where every corner has four edges the Gregory patch is the bicubic B-spline
        // patch, the limit surface: its values two levels down are the limit
        // placement's, within the roundings. This checks the rings' order, the masks
        // and the evaluation's points and parameters together.
        let (level, x0) = grid();
        let sharp = Sharpness::default();
        let rules = Rules::default();
        let f = 4 * 8 + 3; // a face well inside
        let corners: Vec<Corner> = (0..4)
            .map(|k| Corner::new(&level, f, k, rules.hard(&sharp)).unwrap())
            .collect();
        let corners: [Corner; 4] = corners.try_into().ok().unwrap();
        let mut caps = EndCaps {
            nv: level.nv,
            corners: vec![corners],
            points: Vec::new(),
            faces: vec![(f as u32, 0, [[0, 0], [1, 0], [1, 1], [0, 1]])],
            depth: 0,
        };
        caps.values(&x0);
        let mut x = x0.clone();
        let mut l = level;
        for _ in 0..2 {
            for xs in x.iter_mut() {
                subdivide(&l, rules.hard(&sharp), xs);
            }
            caps.below(&l);
            l = l.next();
        }
        let mut limit = x.clone();
        for xs in limit.iter_mut() {
            place_on_limit(&l, rules.hard(&sharp), xs);
        }
        let mut patch = limit.clone();
        caps.place(&l.coarse, &mut patch);
        let inside = caps.inside(&l.coarse);
        // 5 x 5 points, the 4 corners of level Q not among them.
        assert_eq!(inside.len(), 21);
        for &(v, _, _) in &inside {
            for k in 0..3 {
                assert!(
                    (patch[k][v] - limit[k][v]).abs() <= 3,
                    "vertex {v} axis {k}: {} vs {}",
                    patch[k][v],
                    limit[k][v]
                );
            }
        }
        // And they are not the refinement's (the test can tell).
        assert!(inside.iter().any(|&(v, _, _)| (x[2][v] - limit[2][v]).abs() > 100));
    }

    #[test]
    fn end_caps_lie_beside_extraordinary_vertices_only() {
        // A cube refined once: every face of level 1 has one corner of 3 edges (a
        // cube's corner), so each is an end cap; the grid (boundaries, four edges
        // inside) has none.
        let cube = crate::topology::fixtures::cube();
        let one = Level::new(&cube).unwrap().next();
        let sharp = Sharpness::default();
        let rules = Rules::default();
        let caps = EndCaps::new(&one, rules.hard(&sharp), &[false; 26]).unwrap();
        assert_eq!(caps.corners.len(), 24);
        // A sharp edge at a corner's ring takes its faces out.
        let mut edges = vec![0; one.ne()];
        edges[one.v_edges(0)[0] as usize] = crate::transform::fit::SHARP_ONE;
        let creased = Sharpness {
            edges,
            vertices: Vec::new(),
        };
        let fewer = EndCaps::new(&one, rules.hard(&creased), &[false; 26]).unwrap();
        assert!(fewer.corners.len() < 24 - 2, "{}", fewer.corners.len());
        let (g, _) = grid();
        assert!(EndCaps::new(&g, rules.hard(&sharp), &[false; 81]).is_none());
        // An infinitely sharp vertex of four edges inside the grid is a sharp corner:
        // its four faces are end caps; with a finite sharpness, none is, but a
        // semi-sharp vertex's faces are (its sharpness taken as 0 there).
        let v = 4 * 9 + 4;
        let mut semi = [false; 81];
        for (s, marked, caps) in [
            (crate::transform::fit::SHARP_INFINITE, false, 4),
            (3 << 16, false, 0),
            (0, true, 4),
        ] {
            let mut vertices = vec![0; g.nv];
            vertices[v] = s;
            semi[v] = marked;
            let corner = Sharpness {
                edges: Vec::new(),
                vertices,
            };
            let found = EndCaps::new(&g, rules.hard(&corner), &semi).map_or(0, |c| c.corners.len());
            assert_eq!(found, caps, "sharpness {s}, semi-sharp {marked}");
        }
    }
}
