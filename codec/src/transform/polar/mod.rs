//! Pole discs of polar levels and the integer polar wavelets on them (SPEC.md 9.9): the
//! refinement rules of polar subdivision (Zhao et al. 2009, eq. 2-6) inverted in
//! integers (the lazy wavelet), optionally followed by the paper's local lifting (eq.
//! 11-13, weights from the frozen tables), inside the image of each pole's base fan,
//! joined to a Catmull-Clark transform outside it. `transform::polar::reference` holds the
//! floating-point reference.

#[cfg(any(test, feature = "reference"))]
pub mod reference;
pub mod tables;

use crate::topology::Level;
use crate::transform::round_div;

/// Which polar transform a polar hierarchy's discs take (the header's disc byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DiscTransform {
    /// No discs: the Catmull-Clark transform everywhere.
    None,
    /// The lazy polar wavelet, circular analysis first.
    LazyCircularFirst,
    /// The lazy polar wavelet, radial analysis first.
    LazyRadialFirst,
    /// The lifted polar wavelet (eq. 11-13), circular analysis first.
    LiftedCircularFirst,
    /// The lifted polar wavelet, radial analysis first.
    LiftedRadialFirst,
}

impl DiscTransform {
    /// Every choice, in code order.
    pub const ALL: [DiscTransform; 5] = [
        DiscTransform::None,
        DiscTransform::LazyCircularFirst,
        DiscTransform::LazyRadialFirst,
        DiscTransform::LiftedCircularFirst,
        DiscTransform::LiftedRadialFirst,
    ];

    /// The header code.
    pub fn code(self) -> u8 {
        match self {
            DiscTransform::None => 0,
            DiscTransform::LazyCircularFirst => 1,
            DiscTransform::LazyRadialFirst => 2,
            DiscTransform::LiftedCircularFirst => 3,
            DiscTransform::LiftedRadialFirst => 4,
        }
    }

    /// Whether the radial analysis runs first.
    pub fn radial_first(self) -> bool {
        matches!(
            self,
            DiscTransform::LazyRadialFirst | DiscTransform::LiftedRadialFirst
        )
    }

    /// Whether the analysis steps are lifted (eq. 11-13).
    pub fn lifted(self) -> bool {
        matches!(
            self,
            DiscTransform::LiftedCircularFirst | DiscTransform::LiftedRadialFirst
        )
    }

    /// The transform of a header code.
    pub fn from_code(c: u8) -> Option<DiscTransform> {
        DiscTransform::ALL.into_iter().find(|d| d.code() == c)
    }

    /// The name `info` prints.
    pub fn name(self) -> &'static str {
        match self {
            DiscTransform::None => "none",
            DiscTransform::LazyCircularFirst => "polar-lazy (circular first)",
            DiscTransform::LazyRadialFirst => "polar-lazy (radial first)",
            DiscTransform::LiftedCircularFirst => "polar-lifted (circular first)",
            DiscTransform::LiftedRadialFirst => "polar-lifted (radial first)",
        }
    }
}

/// One pole's disc on a level, in fine vertex numbers: the pole and the fine rings
/// 1..=2R (R = 2^level rings on the coarse level, the last one the seam), each listing
/// its 2n fine vertices in spoke order (even positions on the coarse spokes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Disc {
    /// The pole.
    pub pole: u32,
    /// Fine rings, innermost first.
    pub rings: Vec<Vec<u32>>,
}

/// The discs of a polar level (coarse level `index`, 0 = the base mesh) and the mask of
/// the fine values they own (the Catmull-Clark transform skips them). Poles are taken in
/// increasing order; a pole gets no disc when its fan is not a closed fan of 4 to
/// [`MAX_VALENCE`] triangles (for `order`'s radial step), when the rings beyond it do
/// not continue through valence-4 vertices and quads, or when the disc would share a
/// fine vertex with an earlier disc (SPEC.md 9.9).
pub fn discs(level: &Level, poles: &[u32], index: u32, d: DiscTransform) -> (Vec<Disc>, Vec<bool>) {
    let mut out = Vec::new();
    if d == DiscTransform::None || poles.is_empty() || index > 20 {
        return (out, Vec::new());
    }
    let mut owned = vec![false; level.fine_nv()];
    for &p in poles {
        if let Some(disc) = disc(level, p, 1usize << index, d) {
            let all = || std::iter::once(&disc.pole).chain(disc.rings.iter().flatten());
            if all().all(|&v| !owned[v as usize]) {
                for &v in all() {
                    owned[v as usize] = true;
                }
                out.push(disc);
            }
        }
    }
    (out, owned)
}

/// The largest valence the radial step takes (the frozen gamma table's range).
pub const MAX_VALENCE: usize = tables::GAMMA_MIN + tables::GAMMA.len() - 1;

/// The edge joining coarse vertices a and b.
fn edge(level: &Level, a: u32, b: u32) -> Option<u32> {
    level.v_edges(a as usize).iter().copied().find(|&e| {
        let [x, y] = level.edges[e as usize];
        (x == a && y == b) || (x == b && y == a)
    })
}

/// The face with corners `c` in this rotation (any start).
fn face(level: &Level, c: &[u32]) -> Option<u32> {
    level.v_faces(c[0] as usize).iter().copied().find(|&f| {
        let face = level.coarse.face(f as usize);
        let k = face.len();
        k == c.len() && (0..k).any(|r| (0..k).all(|i| face[(r + i) % k] == c[i]))
    })
}

fn disc(level: &Level, p: u32, rings: usize, d: DiscTransform) -> Option<Disc> {
    // The fan, in rotation order: triangle j = (p, v_j, v_{j+1}).
    let fan = level.v_faces(p as usize);
    let n = fan.len();
    let radial_valence = if d.radial_first() { 2 * n } else { n };
    if n < 4 || radial_valence > MAX_VALENCE || level.v_edges(p as usize).len() != n {
        return None;
    }
    let next = |f: u32| -> Option<(u32, u32)> {
        let face = level.coarse.face(f as usize);
        let i = face.iter().position(|&c| c == p)?;
        (face.len() == 3).then(|| (face[(i + 1) % 3], face[(i + 2) % 3]))
    };
    let mut ring: Vec<u32> = Vec::with_capacity(n);
    let mut tris: Vec<u32> = Vec::with_capacity(n);
    let (mut a, _) = next(fan[0])?;
    for _ in 0..n {
        let f = fan
            .iter()
            .copied()
            .find(|&f| next(f).map(|(x, _)| x) == Some(a))?;
        ring.push(a);
        tris.push(f);
        a = next(f)?.1;
    }
    if a != ring[0] {
        return None;
    }
    // Coarse rings 1..=rings (ring 0 = the pole), each vertex's outward neighbour the one
    // edge neighbour that is neither inward nor on its ring.
    let mut coarse: Vec<Vec<u32>> = vec![vec![p; n], ring];
    while coarse.len() <= rings {
        let (inner, cur) = (&coarse[coarse.len() - 2], &coarse[coarse.len() - 1]);
        let mut outer = Vec::with_capacity(n);
        for j in 0..n {
            let v = cur[j];
            let skip = [inner[j], cur[(j + n - 1) % n], cur[(j + 1) % n]];
            let edges = level.v_edges(v as usize);
            if edges.len() != 4 {
                return None;
            }
            let others = edges.iter().map(|&e| {
                let [x, y] = level.edges[e as usize];
                if x == v {
                    y
                } else {
                    x
                }
            });
            let w: Vec<u32> = others.filter(|o| !skip.contains(o)).collect();
            if w.len() != 1 {
                return None;
            }
            outer.push(w[0]);
        }
        coarse.push(outer);
    }
    let (nv, ne) = (level.nv as u32, level.ne() as u32);
    let mut fine = Vec::with_capacity(2 * rings);
    for i in 1..=rings {
        // Fine ring 2i - 1: spoke edge points and the face points between rings i-1, i.
        let mut odd = Vec::with_capacity(2 * n);
        for j in 0..n {
            odd.push(nv + edge(level, coarse[i - 1][j], coarse[i][j])?);
            let f = if i == 1 {
                tris[j]
            } else {
                let q = [
                    coarse[i - 1][j],
                    coarse[i - 1][(j + 1) % n],
                    coarse[i][(j + 1) % n],
                    coarse[i][j],
                ];
                face(level, &q).or_else(|| face(level, &[q[3], q[2], q[1], q[0]]))?
            };
            odd.push(nv + ne + f);
        }
        // Fine ring 2i: the ring's vertices and its edges' points.
        let mut even = Vec::with_capacity(2 * n);
        for j in 0..n {
            even.push(coarse[i][j]);
            even.push(nv + edge(level, coarse[i][j], coarse[i][(j + 1) % n])?);
        }
        fine.push(odd);
        fine.push(even);
    }
    // Every vertex once.
    let mut all: Vec<u32> = fine.iter().flatten().copied().chain([p]).collect();
    all.sort_unstable();
    if all.windows(2).any(|w| w[0] == w[1]) {
        return None;
    }
    Some(Disc {
        pole: p,
        rings: fine,
    })
}

/// `floor(a / 2)` of a 128-bit sum, wrapped to 64 bits (only corrupt data gets near).
#[inline]
fn half(a: i128) -> i64 {
    a.div_euclid(2) as i64
}

/// The circular lifting of one ring after its analysis (even positions coarse values,
/// odd positions details): per coarse value m, `[sum_k w_k d_(m+2-k) / 2^16]` with w
/// the frozen Table 2 weights (SPEC.md 9.9), subtracted in analysis, added in synthesis.
fn circular_lift(x: &mut [i64], ring: &[u32], analysis: bool) {
    let n = ring.len() / 2;
    let d = |j: usize| x[ring[2 * (j % n) + 1] as usize] as i128;
    let up: Vec<i64> = (0..n)
        .map(|m| {
            let acc = (0..6)
                .map(|k| tables::LIFT_W[k] as i128 * d(m + 2 * n + 2 - k))
                .sum::<i128>();
            round_div(acc, 1 << 16)
        })
        .collect();
    for (m, u) in up.into_iter().enumerate() {
        let v = &mut x[ring[2 * m] as usize];
        *v = if analysis {
            v.wrapping_sub(u)
        } else {
            v.wrapping_add(u)
        };
    }
}

/// Circular analysis of one closed ring of 2n values (even positions old vertices, odd
/// positions edge points; SPEC.md 9.9), lifted or not.
fn circular_analysis(x: &mut [i64], ring: &[u32], lifted: bool) {
    let m = ring.len();
    let at = |x: &[i64], i: usize| x[ring[i % m] as usize] as i128;
    let v: Vec<i64> = (0..m / 2)
        .map(|j| {
            let r = round_div(at(x, 2 * j + m - 1) + at(x, 2 * j + 1), 2);
            (2 * at(x, 2 * j) - r as i128) as i64
        })
        .collect();
    let n = v.len();
    for j in 0..n {
        x[ring[2 * j] as usize] = v[j];
    }
    for j in 0..n {
        let r = round_div(v[j] as i128 + v[(j + 1) % n] as i128, 2);
        let e = &mut x[ring[2 * j + 1] as usize];
        *e = e.wrapping_sub(r);
    }
    if lifted {
        circular_lift(x, ring, true);
    }
}

/// The inverse of [`circular_analysis`].
fn circular_synthesis(x: &mut [i64], ring: &[u32], lifted: bool) {
    if lifted {
        circular_lift(x, ring, false);
    }
    let m = ring.len();
    let n = m / 2;
    for j in 0..n {
        let r = round_div(
            x[ring[2 * j] as usize] as i128 + x[ring[(2 * j + 2) % m] as usize] as i128,
            2,
        );
        let e = &mut x[ring[2 * j + 1] as usize];
        *e = e.wrapping_add(r);
    }
    let v: Vec<i64> = (0..n)
        .map(|j| {
            let at = |i: usize| x[ring[i % m] as usize] as i128;
            let r = round_div(at(2 * j + m - 1) + at(2 * j + 1), 2);
            half(at(2 * j) + r as i128)
        })
        .collect();
    for j in 0..n {
        x[ring[2 * j] as usize] = v[j];
    }
}

/// The radial structure a radial step works on: the pole, then per fine ring the
/// positions on its spokes (every `stride`-th value).
struct Spokes<'a> {
    pole: usize,
    rings: &'a [Vec<u32>],
    stride: usize,
}

impl Spokes<'_> {
    fn n(&self) -> usize {
        self.rings[0].len() / self.stride
    }
    /// Fine ring m (1-based), spoke j.
    fn at(&self, m: usize, j: usize) -> usize {
        self.rings[m - 1][j * self.stride] as usize
    }
}

/// The gamma prediction of spoke point j next to the pole (SPEC.md 9.9).
fn gamma_prediction(x: &[i64], s: &Spokes<'_>, p: i64, ring1: usize, j: usize) -> i64 {
    let n = s.n();
    let g = tables::GAMMA[n - tables::GAMMA_MIN];
    let mut acc = (p as i128) << 15;
    for k in 0..n {
        acc += g[(k + n - j) % n] as i128 * x[s.at(ring1, k)] as i128;
    }
    round_div(acc, 1 << 16)
}

/// The radial lifting after a radial analysis (SPEC.md 9.9): each coarse value of the
/// disc other than the seam's (the pole, coarse rings 1..R-1) moves by `[U / 2^16]`, U
/// the sum of the details times the frozen weights of Table 1 whose stencils reach it
/// (t for the spoke points next to the pole, s for the others by their distance from
/// it); subtracted in analysis, added in synthesis.
fn radial_lift(x: &mut [i64], s: &Spokes<'_>, analysis: bool) {
    let n = s.n();
    let r = s.rings.len() / 2;
    let t = tables::LIFT_T[n - tables::GAMMA_MIN];
    let st = &tables::LIFT_S[n - tables::GAMMA_MIN];
    // Slot 0 the pole, 1 + (i - 1) n + j coarse ring i (1 <= i < R) at spoke j.
    let slot = |i: usize, j: usize| match i {
        0 => Some(0),
        i if i < r => Some(1 + (i - 1) * n + j % n),
        _ => None,
    };
    let mut up = vec![0i128; 1 + (r - 1) * n];
    for j in 0..n {
        let e = x[s.at(1, j)] as i128;
        up[0] += t[0] as i128 * e;
        for m in 0..n {
            if let Some(q) = slot(1, j + m) {
                up[q] += t[1 + m] as i128 * e;
            }
        }
        if let Some(q) = slot(2, j) {
            up[q] += t[n + 1] as i128 * e;
        }
        for i in 2..=r {
            let e = x[s.at(2 * i - 1, j)] as i128;
            let w = &st[(i - 1).min(3) - 1];
            let stencil = [
                (i - 2, j),
                (i - 1, j + n - 1),
                (i - 1, j),
                (i - 1, j + 1),
                (i, j + 1),
                (i, j),
                (i, j + n - 1),
                (i + 1, j),
            ];
            for (&wk, (ri, jj)) in w.iter().zip(stencil) {
                if let Some(q) = slot(ri, jj).filter(|_| wk != 0) {
                    up[q] += wk as i128 * e;
                }
            }
        }
    }
    let mut apply = |at: usize, acc: i128| {
        let u = round_div(acc, 1 << 16);
        x[at] = if analysis {
            x[at].wrapping_sub(u)
        } else {
            x[at].wrapping_add(u)
        };
    };
    apply(s.pole, up[0]);
    for i in 1..r {
        for j in 0..n {
            apply(s.at(2 * i, j), up[1 + (i - 1) * n + j]);
        }
    }
}

/// Radial analysis with the seam (the last fine ring) fixed.
fn radial_analysis(x: &mut [i64], s: &Spokes<'_>, lifted: bool) {
    let n = s.n();
    let r = s.rings.len() / 2; // coarse rings, the last one the seam
    let e = |x: &[i64], i: usize, j: usize| x[s.at(2 * i - 1, j)] as i128;
    let w = |x: &[i64], i: usize, j: usize| x[s.at(2 * i, j)] as i128;
    let sum: i128 = (0..n).map(|j| e(x, 1, j)).sum();
    let p = (2 * x[s.pole] as i128 - round_div(sum, n as i128) as i128) as i64;
    let mut v = vec![0i64; r * n]; // coarse ring i (1-based) at (i - 1) * n + j
    for i in 1..=r {
        for j in 0..n {
            v[(i - 1) * n + j] = if i == r {
                w(x, i, j) as i64
            } else if i == 1 {
                round_div(8 * w(x, 1, j) - p as i128 - 2 * e(x, 2, j), 5)
            } else {
                let q = round_div(e(x, i, j) + e(x, i + 1, j), 2);
                (2 * w(x, i, j) - q as i128) as i64
            };
        }
    }
    x[s.pole] = p;
    for i in 1..r {
        for j in 0..n {
            x[s.at(2 * i, j)] = v[(i - 1) * n + j];
        }
    }
    for j in 0..n {
        let pred = gamma_prediction(x, s, p, 2, j);
        let at = s.at(1, j);
        x[at] = x[at].wrapping_sub(pred);
        for i in 2..=r {
            let pred = round_div(v[(i - 2) * n + j] as i128 + v[(i - 1) * n + j] as i128, 2);
            let at = s.at(2 * i - 1, j);
            x[at] = x[at].wrapping_sub(pred);
        }
    }
    if lifted {
        radial_lift(x, s, true);
    }
}

/// The inverse of [`radial_analysis`].
fn radial_synthesis(x: &mut [i64], s: &Spokes<'_>, lifted: bool) {
    if lifted {
        radial_lift(x, s, false);
    }
    let n = s.n();
    let r = s.rings.len() / 2;
    let p = x[s.pole];
    for j in 0..n {
        let pred = gamma_prediction(x, s, p, 2, j);
        let at = s.at(1, j);
        x[at] = x[at].wrapping_add(pred);
        for i in 2..=r {
            let pred = round_div(x[s.at(2 * i - 2, j)] as i128 + x[s.at(2 * i, j)] as i128, 2);
            let at = s.at(2 * i - 1, j);
            x[at] = x[at].wrapping_add(pred);
        }
    }
    let e = |x: &[i64], i: usize, j: usize| x[s.at(2 * i - 1, j)] as i128;
    for i in 1..r {
        for j in 0..n {
            let at = s.at(2 * i, j);
            let v = x[at] as i128;
            x[at] = if i == 1 {
                // The one w' with [(8 w' - c) / 5] = v: ceil((10 v + 2 c - 5) / 16).
                let c = p as i128 + 2 * e(x, 2, j);
                -(-(10 * v + 2 * c - 5)).div_euclid(16) as i64
            } else {
                let q = round_div(e(x, i, j) + e(x, i + 1, j), 2);
                half(v + q as i128)
            };
        }
    }
    let sum: i128 = (0..n).map(|j| e(x, 1, j)).sum();
    x[s.pole] = half(p as i128 + round_div(sum, n as i128) as i128);
}

/// Analysis of one disc, in place (SPEC.md 9.9).
pub fn analyse(disc: &Disc, d: DiscTransform, x: &mut [i64]) {
    let lifted = d.lifted();
    if d == DiscTransform::None {
    } else if d.radial_first() {
        radial_analysis(x, &spokes(disc, 1), lifted);
        for ring in disc.rings.iter().skip(1).step_by(2) {
            circular_analysis(x, ring, lifted);
        }
    } else {
        for ring in &disc.rings {
            circular_analysis(x, ring, lifted);
        }
        radial_analysis(x, &spokes(disc, 2), lifted);
    }
}

/// Synthesis of one disc, the exact inverse of [`analyse`].
pub fn synthesise(disc: &Disc, d: DiscTransform, x: &mut [i64]) {
    let lifted = d.lifted();
    if d == DiscTransform::None {
    } else if d.radial_first() {
        for ring in disc.rings.iter().skip(1).step_by(2) {
            circular_synthesis(x, ring, lifted);
        }
        radial_synthesis(x, &spokes(disc, 1), lifted);
    } else {
        radial_synthesis(x, &spokes(disc, 2), lifted);
        for ring in disc.rings.iter().rev() {
            circular_synthesis(x, ring, lifted);
        }
    }
}

fn spokes(disc: &Disc, stride: usize) -> Spokes<'_> {
    Spokes {
        pole: disc.pole as usize,
        rings: &disc.rings,
        stride,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topo;

    #[test]
    fn the_frozen_tables_are_the_reference_solvers() {
        for (i, row) in tables::GAMMA.iter().enumerate() {
            let n = i + tables::GAMMA_MIN;
            let want = crate::transform::polar::reference::gamma_fixed(n);
            assert_eq!(
                row.iter().map(|&g| g as i64).collect::<Vec<_>>(),
                want,
                "n = {n}"
            );
            assert_eq!(want.iter().sum::<i64>(), 1 << 15);
            let (t, s) = crate::transform::polar::reference::radial_weights_fixed(n);
            assert_eq!(tables::LIFT_T[i], &t[..], "t, n = {n}");
            assert_eq!(tables::LIFT_S[i], s, "s, n = {n}");
        }
        assert_eq!(
            tables::LIFT_W,
            crate::transform::polar::reference::circular_weights_fixed()
        );
    }

    /// A lat-long sphere with poles 0 and 1, refined `levels` times by the polar rule.
    fn sphere_levels(n: u32, rings: u32, levels: usize) -> Vec<Level> {
        let mut t = Topo::new((2 + n * rings) as usize);
        let v = |r: u32, j: u32| 2 + r * n + j % n;
        for j in 0..n {
            t.push(&[0, v(0, j), v(0, j + 1)]);
            t.push(&[1, v(rings - 1, j + 1), v(rings - 1, j)]);
            for r in 0..rings - 1 {
                t.push(&[v(r, j), v(r + 1, j), v(r + 1, j + 1), v(r, j + 1)]);
            }
        }
        let mut out = Vec::new();
        for _ in 0..levels {
            let l = Level::new(&t).unwrap();
            let mut pole = vec![false; l.nv];
            pole[0] = true;
            pole[1] = true;
            t = l.fine_with(&pole);
            out.push(l);
        }
        out
    }

    #[test]
    fn discs_are_found_on_every_level_and_invert_exactly() {
        let levels = sphere_levels(5, 6, 3);
        let mut s = 12345u64;
        for (index, level) in levels.iter().enumerate() {
            for d in DiscTransform::ALL.into_iter().skip(1) {
                let (discs, owned) = discs(level, &[0, 1], index as u32, d);
                assert_eq!(discs.len(), 2, "level {index}");
                let rings = 1usize << index;
                for disc in &discs {
                    assert_eq!(disc.rings.len(), 2 * rings);
                    assert!(disc.rings.iter().all(|r| r.len() == (2 * 5) << index));
                }
                let count = owned.iter().filter(|&&o| o).count();
                assert_eq!(count, 2 * (1 + 2 * rings * 2 * (5 << index)));
                for bits in [3u32, 20, 44] {
                    let x0: Vec<i64> = (0..level.fine_nv())
                        .map(|_| {
                            s ^= s << 13;
                            s ^= s >> 7;
                            s ^= s << 17;
                            (s % (1 << bits)) as i64 - (1 << (bits - 1))
                        })
                        .collect();
                    let mut x = x0.clone();
                    for disc in &discs {
                        analyse(disc, d, &mut x);
                    }
                    // Only the discs' values change.
                    for i in 0..x.len() {
                        if !owned[i] {
                            assert_eq!(x[i], x0[i]);
                        }
                    }
                    for disc in discs.iter().rev() {
                        synthesise(disc, d, &mut x);
                    }
                    assert_eq!(x, x0, "level {index}, {d:?}, {bits} bits");
                }
            }
        }
    }

    #[test]
    fn lifting_keeps_noise_out_of_the_coarse_values() {
        // The paper's stability property in kind, on the integer transforms: noise on a
        // constant surface reaches a disc's coarse values (pole and inner rings) much
        // weaker with lifting than without (the lazy wavelet's x2 and x8/5 amplify it).
        let levels = sphere_levels(8, 8, 3);
        let level = &levels[2];
        let mut s = 99u64;
        let x0: Vec<i64> = (0..level.fine_nv())
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                1_000_000 + (s % 2001) as i64 - 1000
            })
            .collect();
        let rms = |d: DiscTransform| {
            let (discs, _) = discs(level, &[0, 1], 2, d);
            let mut x = x0.clone();
            let (mut sum, mut count) = (0.0, 0.0);
            for disc in &discs {
                analyse(disc, d, &mut x);
                let r = disc.rings.len() / 2;
                let inner = (1..r).flat_map(|i| disc.rings[2 * i - 1].iter().step_by(2));
                for &v in std::iter::once(&disc.pole).chain(inner) {
                    sum += ((x[v as usize] - 1_000_000) as f64).powi(2);
                    count += 1.0;
                }
            }
            (sum / count).sqrt()
        };
        for (lazy, lifted) in [
            (
                DiscTransform::LazyCircularFirst,
                DiscTransform::LiftedCircularFirst,
            ),
            (
                DiscTransform::LazyRadialFirst,
                DiscTransform::LiftedRadialFirst,
            ),
        ] {
            let (a, b) = (rms(lazy), rms(lifted));
            assert!(b < 0.6 * a, "{lazy:?} {a} vs {lifted:?} {b}");
        }
    }

    #[test]
    fn smooth_values_leave_small_details() {
        // A linear function is reproduced by the refinement rules away from the pole's
        // gamma rule, so its details there are rounding only.
        let levels = sphere_levels(6, 6, 2);
        let level = &levels[1];
        let (discs, _) = discs(level, &[0, 1], 1, DiscTransform::LazyCircularFirst);
        let mut x: Vec<i64> = vec![1000; level.fine_nv()];
        let x0 = x.clone();
        for disc in &discs {
            analyse(disc, DiscTransform::LazyCircularFirst, &mut x);
        }
        // A constant: every detail 0, every coarse value the constant.
        for disc in &discs {
            assert_eq!(x[disc.pole as usize], 1000);
            for (m, ring) in disc.rings.iter().enumerate() {
                for (pos, &v) in ring.iter().enumerate() {
                    let coarse = m % 2 == 1 && pos % 2 == 0;
                    assert_eq!(
                        x[v as usize],
                        if coarse { 1000 } else { 0 },
                        "ring {m} pos {pos}"
                    );
                }
            }
        }
        assert_ne!(x, x0);
    }
}
