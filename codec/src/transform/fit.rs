//! The subdivision fit (SPEC.md 9.10): a Catmull-Clark hierarchy whose finest positions
//! are plain Catmull-Clark subdivision of a control mesh, rounded to the grid ("a
//! subdivided model"), is coded as that control mesh at `k` extra bits of precision
//! plus, per finest vertex, the difference between its value and the control mesh's
//! subdivision, computed in integers and rounded.
//!
//! The encoder finds the control mesh by least squares in floating point (any values
//! serve: the decoder only repeats the integer subdivision); the decoder runs only the
//! integer rules of [`subdivide`].

use crate::topology::Level;
use crate::transform::round_div;

/// Most extra bits of precision the control values may carry (SPEC.md 9.10).
pub const MAX_EXTRA_BITS: u8 = 16;

/// Which vertex rule of SPEC.md 9.10 coarse vertex `v` takes.
enum VertexRule {
    /// Exactly two boundary edges, to these vertices.
    Boundary([u32; 2]),
    /// No boundary edge, at least three edges and as many face corners.
    Inside,
    /// Anything else: the value is kept.
    Kept,
}

fn vertex_rule(level: &Level, v: usize) -> VertexRule {
    match level.boundary_edges(v) {
        (2, be) => VertexRule::Boundary(be.map(|e| level.other_end(e, v))),
        (0, _)
            if level.v_edges(v).len() >= 3 && level.v_faces(v).len() == level.v_edges(v).len() =>
        {
            VertexRule::Inside
        }
        _ => VertexRule::Kept,
    }
}

/// One plain Catmull-Clark refinement in integers (SPEC.md 9.10): `x` holds the
/// coarse values (`level.nv`) and gets the fine ones (`level.fine_nv()`), every rule
/// rounded with `[n / d]`:
/// * face point: `[sum of corners / k]`;
/// * edge point: `[(a + b + f0 + f1) / 4]` inside, `[(a + b) / 2]` on a boundary;
/// * vertex, inside, `n` edges: `[(n (n - 2) v + sum of neighbours + sum of the face
///   points of its faces) / n^2]`; on a boundary with two boundary edges to `a`, `b`:
///   `[(a + 6 v + b) / 8]`; otherwise (a corner, or a vertex with no faces) unchanged.
pub fn subdivide(level: &Level, x: &mut Vec<i64>) {
    let (nv, ne) = (level.nv, level.ne());
    x.resize(level.fine_nv(), 0);
    for f in 0..level.nf() {
        let face = level.coarse.face(f);
        let s: i128 = face.iter().map(|&v| x[v as usize] as i128).sum();
        x[nv + ne + f] = round_div(s, face.len() as i128);
    }
    for (e, &[a, b]) in level.edges.iter().enumerate() {
        let ends = x[a as usize] as i128 + x[b as usize] as i128;
        x[nv + e] = if level.is_boundary(e) {
            round_div(ends, 2)
        } else {
            let [f0, f1] = level.edge_faces[e];
            round_div(
                ends + x[nv + ne + f0 as usize] as i128 + x[nv + ne + f1 as usize] as i128,
                4,
            )
        };
    }
    let moved: Vec<i64> = (0..nv).map(|v| moved_vertex(level, v, x)).collect();
    x[..nv].copy_from_slice(&moved);
}

/// The vertex rule of [`subdivide`] for coarse vertex `v` (its neighbours still
/// coarse, the face points already written).
fn moved_vertex(level: &Level, v: usize, x: &[i64]) -> i64 {
    let xv = x[v] as i128;
    match vertex_rule(level, v) {
        VertexRule::Boundary([a, b]) => {
            round_div(x[a as usize] as i128 + 6 * xv + x[b as usize] as i128, 8)
        }
        VertexRule::Kept => x[v],
        VertexRule::Inside => {
            let (nv, ne) = (level.nv, level.ne());
            let edges = level.v_edges(v);
            let n = edges.len() as i128;
            let mut s = n * (n - 2) * xv;
            for &e in edges {
                s += x[level.other_end(e, v) as usize] as i128;
            }
            for &f in level.v_faces(v) {
                s += x[nv + ne + f as usize] as i128;
            }
            round_div(s, n * n)
        }
    }
}

/// The same refinement in floating point, without rounding, as a linear map: the
/// weights of fine vertex `i` on coarse vertices, as `(coarse, weight)` rows.
fn rows(level: &Level) -> Vec<Vec<(u32, f64)>> {
    let (nv, ne) = (level.nv, level.ne());
    let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); level.fine_nv()];
    for f in 0..level.nf() {
        let face = level.coarse.face(f);
        let w = 1.0 / face.len() as f64;
        rows[nv + ne + f] = face.iter().map(|&v| (v, w)).collect();
    }
    for (e, &[a, b]) in level.edges.iter().enumerate() {
        rows[nv + e] = if level.is_boundary(e) {
            vec![(a, 0.5), (b, 0.5)]
        } else {
            let mut r = vec![(a, 0.25), (b, 0.25)];
            for &f in &level.edge_faces[e] {
                for &(c, w) in &rows[nv + ne + f as usize] {
                    r.push((c, 0.25 * w));
                }
            }
            r
        };
    }
    for v in 0..nv {
        rows[v] = match vertex_rule(level, v) {
            VertexRule::Boundary([a, b]) => vec![(a, 0.125), (v as u32, 0.75), (b, 0.125)],
            VertexRule::Kept => vec![(v as u32, 1.0)],
            VertexRule::Inside => {
                let edges = level.v_edges(v);
                let n = edges.len() as f64;
                let nn = n * n;
                let mut r = vec![(v as u32, (n - 2.0) / n)];
                for &e in edges {
                    r.push((level.other_end(e, v), 1.0 / nn));
                }
                for &f in level.v_faces(v) {
                    for &(c, w) in &rows[nv + ne + f as usize] {
                        r.push((c, w / nn));
                    }
                }
                r
            }
        };
    }
    rows
}

/// One level's weights in compressed rows.
struct Csr {
    starts: Vec<u32>,
    cols: Vec<u32>,
    weights: Vec<f64>,
    coarse: usize,
}

/// The linear map from control values to finest values, level by level.
pub struct Operator {
    levels: Vec<Csr>,
}

impl Operator {
    /// The composed refinement of `levels` (coarsest first).
    pub fn new(levels: &[Level]) -> Operator {
        let levels = levels
            .iter()
            .map(|l| {
                let mut m = Csr {
                    starts: vec![0],
                    cols: Vec::new(),
                    weights: Vec::new(),
                    coarse: l.nv,
                };
                for row in rows(l) {
                    for (c, w) in row {
                        m.cols.push(c);
                        m.weights.push(w);
                    }
                    m.starts.push(m.cols.len() as u32);
                }
                m
            })
            .collect();
        Operator { levels }
    }

    /// Finest values from control values (three axes at once).
    pub fn apply(&self, base: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut x = base.to_vec();
        for m in &self.levels {
            x = m
                .starts
                .windows(2)
                .map(|s| {
                    let (a, b) = (s[0] as usize, s[1] as usize);
                    let mut acc = [0.0; 3];
                    for (&c, &w) in m.cols[a..b].iter().zip(&m.weights[a..b]) {
                        let v = x[c as usize];
                        for k in 0..3 {
                            acc[k] += w * v[k];
                        }
                    }
                    acc
                })
                .collect();
        }
        x
    }

    /// The transpose: control-sized values from finest-sized ones.
    pub fn apply_t(&self, fine: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut y = fine.to_vec();
        for m in self.levels.iter().rev() {
            let mut z = vec![[0.0; 3]; m.coarse];
            for (s, yi) in m.starts.windows(2).zip(&y) {
                let (a, b) = (s[0] as usize, s[1] as usize);
                for (&c, &w) in m.cols[a..b].iter().zip(&m.weights[a..b]) {
                    let t = &mut z[c as usize];
                    for k in 0..3 {
                        t[k] += w * yi[k];
                    }
                }
            }
            y = z;
        }
        y
    }

    /// The control values whose refinement is nearest `fine` in least squares, each
    /// axis on its own (conjugate gradients on the normal equations, from `start`),
    /// stopping after `iterations` or once no value moves by more than `tolerance`.
    pub fn fit(
        &self,
        fine: &[[f64; 3]],
        start: &[[f64; 3]],
        iterations: usize,
        tolerance: f64,
    ) -> Vec<[f64; 3]> {
        let dot = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            let mut s = [0.0; 3];
            for (u, v) in a.iter().zip(b) {
                for k in 0..3 {
                    s[k] += u[k] * v[k];
                }
            }
            s
        };
        let mut b = start.to_vec();
        let ab = self.apply(&b);
        let resid: Vec<[f64; 3]> = fine
            .iter()
            .zip(&ab)
            .map(|(y, p)| std::array::from_fn(|k| y[k] - p[k]))
            .collect();
        let mut r = self.apply_t(&resid);
        let mut p = r.clone();
        let mut rr = dot(&r, &r);
        // Axes still iterating.
        let mut live = [true; 3];
        for _ in 0..iterations {
            for k in 0..3 {
                live[k] &= rr[k] > 0.0;
            }
            if !live.contains(&true) {
                break;
            }
            let q = self.apply_t(&self.apply(&p));
            let pq = dot(&p, &q);
            let mut alpha = [0.0; 3];
            for k in 0..3 {
                live[k] &= pq[k] > 0.0 && pq[k].is_finite();
                if live[k] {
                    alpha[k] = rr[k] / pq[k];
                }
            }
            let mut moved = [0.0f64; 3];
            for i in 0..b.len() {
                for k in 0..3 {
                    b[i][k] += alpha[k] * p[i][k];
                    r[i][k] -= alpha[k] * q[i][k];
                    moved[k] = moved[k].max((alpha[k] * p[i][k]).abs());
                }
            }
            let rr2 = dot(&r, &r);
            for k in 0..3 {
                live[k] &= moved[k] >= tolerance;
                let beta = if live[k] { rr2[k] / rr[k] } else { 0.0 };
                rr[k] = rr2[k];
                for pi in p.iter_mut().zip(&r) {
                    pi.0[k] = if live[k] {
                        pi.1[k] + beta * pi.0[k]
                    } else {
                        0.0
                    };
                }
            }
        }
        b
    }
}

/// How far a level's fine values are from any plain Catmull-Clark refinement: the mean
/// square, over inner quads, of a combination of fine values that refinement makes
/// zero (up to rounding). Per quad (a, b, c, d) with edge points E and face points F on
/// either side of each edge, `a + b = 4 E_ab - F - F'`, so `(a + b) + (c + d) = 4 F`.
/// About 4 for rounded subdivision, large for fitted detail; `None` without such quads.
pub fn defect(level: &Level, x: &[i64]) -> Option<f64> {
    let (nv, ne) = (level.nv, level.ne());
    let fp = |f: u32| x[nv + ne + f as usize] as f64;
    let side = |e: u32| {
        let [f0, f1] = level.edge_faces[e as usize];
        4.0 * x[nv + e as usize] as f64 - fp(f0) - fp(f1)
    };
    let (mut sum, mut n) = (0.0, 0usize);
    for f in 0..level.nf() {
        let es = level.f_edges(f);
        if es.len() != 4 || es.iter().any(|&e| level.is_boundary(e as usize)) {
            continue;
        }
        for pair in [[es[0], es[2]], [es[1], es[3]]] {
            let d = side(pair[0]) + side(pair[1]) - 4.0 * fp(f as u32);
            sum += d * d;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topo;

    /// A closed base (a cube with one face split into two triangles, one corner of
    /// valence 4) and an open one (a 3 x 2 grid), refined `n` times.
    fn hierarchies(n: usize) -> Vec<Vec<Level>> {
        let mut cube = Topo::new(8);
        for f in [
            [0u32, 1, 3, 2].as_slice(),
            &[4, 6, 7, 5],
            &[0, 4, 5, 1],
            &[2, 3, 7, 6],
            &[0, 2, 6],
            &[0, 6, 4],
            &[1, 5, 7, 3],
        ] {
            cube.push(f);
        }
        let mut grid = Topo::new(12);
        for y in 0..2u32 {
            for x in 0..3u32 {
                let v = y * 4 + x;
                grid.push(&[v, v + 1, v + 5, v + 4]);
            }
        }
        [cube, grid]
            .into_iter()
            .map(|mut t| {
                let mut levels = Vec::new();
                for _ in 0..n {
                    let l = Level::new(&t).unwrap();
                    t = l.fine();
                    levels.push(l);
                }
                levels
            })
            .collect()
    }

    fn values(n: usize, seed: u64) -> Vec<i64> {
        crate::topology::fixtures::pseudo(seed, n, 21)
    }

    fn triples(v: &[i64]) -> Vec<[f64; 3]> {
        v.chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect()
    }

    #[test]
    fn the_transpose_is_the_transpose() {
        for levels in hierarchies(2) {
            let op = Operator::new(&levels);
            let nb = levels[0].nv;
            let nf = levels.last().unwrap().fine_nv();
            let b = triples(&values(3 * nb, 1));
            let y = triples(&values(3 * nf, 2));
            for k in 0..3 {
                let ab: f64 = op.apply(&b).iter().zip(&y).map(|(a, b)| a[k] * b[k]).sum();
                let bt: f64 = b.iter().zip(op.apply_t(&y)).map(|(a, b)| a[k] * b[k]).sum();
                assert!((ab - bt).abs() <= 1e-9 * ab.abs().max(1.0), "{ab} {bt}");
            }
        }
    }

    #[test]
    fn integer_refinement_follows_the_linear_map() {
        // The rounded refinement stays within a unit per level of the exact one, so
        // the integer rules and the weights the encoder fits with agree.
        for levels in hierarchies(3) {
            let op = Operator::new(&levels);
            let b = values(3 * levels[0].nv, 3);
            let exact = op.apply(&triples(&b));
            for k in 0..3 {
                let mut x: Vec<i64> = b.iter().skip(k).step_by(3).copied().collect();
                for l in &levels {
                    subdivide(l, &mut x);
                }
                assert_eq!(x.len(), exact.len());
                for (i, (&a, e)) in x.iter().zip(&exact).enumerate() {
                    assert!(
                        (a as f64 - e[k]).abs() <= 3.0,
                        "vertex {i}: {a} vs {}",
                        e[k]
                    );
                }
            }
        }
    }

    #[test]
    fn least_squares_recovers_the_control_values() {
        for levels in hierarchies(2) {
            let op = Operator::new(&levels);
            let b = triples(&values(3 * levels[0].nv, 4));
            let y = op.apply(&b);
            let start = vec![[0.0; 3]; b.len()];
            let got = op.fit(&y, &start, 400, 1e-9);
            for (g, w) in got.iter().zip(&b) {
                for k in 0..3 {
                    assert!((g[k] - w[k]).abs() < 1e-3, "{g:?} vs {w:?}");
                }
            }
        }
    }

    #[test]
    fn the_defect_of_a_rounded_refinement_is_small_and_of_detail_large() {
        for levels in hierarchies(3) {
            let mut x = values(levels[0].nv, 5);
            let last = levels.last().unwrap();
            for l in &levels {
                subdivide(l, &mut x);
            }
            let d = defect(last, &x).unwrap();
            assert!(d < 12.0, "{d}");
            let noise = values(x.len(), 6);
            for (v, n) in x.iter_mut().zip(noise) {
                *v += n / 1000;
            }
            assert!(defect(last, &x).unwrap() > 1000.0);
        }
    }
}
