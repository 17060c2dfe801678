//! The program behind the frozen IR2W tables (SPEC.md 9.7): the interpolatory sqrt(2)
//! prediction weights of Wang & Ma 2009 (eq. 1) and the lifting weights of their local
//! orthogonalisation (eq. 6-7, discrete inner product), in floating point.
//!
//! Nothing here runs while coding: the codec uses the fixed-point tables in
//! [`super::tables`], and a test checks they are exactly what [`alpha_table`] and
//! [`omega_table`] produce. `cargo run -p subwave-codec --example sqrt2_tables` prints them.

use crate::topology::rings::Rings;
use crate::topology::Topo;

/// Fixed-point scale of every table weight: 2^16.
pub const ONE: i64 = 1 << 16;

/// The paper's prediction weight `alpha_{i,j}` of neighbour `j` of a corner of valence `n`
/// (eq. 1), neighbours counted from the face's next corner through the face.
pub fn alpha(n: usize, j: usize) -> f64 {
    let t = |j: isize| 2.0 * std::f64::consts::PI * j as f64 / n as f64;
    let (a, b) = (t(j as isize), t(j as isize - 1));
    (1.0 + a.cos() + a.sin() + b.cos() - b.sin()) / (2.0 * n as f64)
}

/// The fixed-point neighbour weights of a corner of valence `n` (each weight times 2^16,
/// rounded half away from zero), re-balanced so that they sum to exactly 2^15: the
/// corner keeps 1/2, so every corner's stencil sums to one. The residual goes to j = 0.
pub fn alpha_fixed(n: usize) -> Vec<i64> {
    let mut a: Vec<i64> = (0..n)
        .map(|j| (alpha(n, j) * ONE as f64).round() as i64)
        .collect();
    let s: i64 = a.iter().sum();
    a[0] += ONE / 2 - s;
    a
}

/// Every valence's fixed-point prediction weights, valences 3..=`max`.
pub fn alpha_table(max: usize) -> Vec<Vec<i64>> {
    (3..=max).map(alpha_fixed).collect()
}

/// A quad mesh around one vertex of valence `n` (vertex 0): `n` sectors of `k x k` quads,
/// every other inner vertex of valence 4. Returns the topology and the face of sector 0
/// at the centre, whose corners are (centre, spoke 0, diagonal, spoke 1).
pub fn star(n: usize, k: usize) -> (Topo, usize) {
    // Vertex (s, u, v), 0 <= u, v <= k; (s, 0, v) is (s + 1, v, 0); (s, 0, 0) the centre.
    let id = |s: usize, u: usize, v: usize| -> u32 {
        if u == 0 && v == 0 {
            return 0;
        }
        let (s, u, v) = if u == 0 {
            ((s + 1) % n, v, 0)
        } else {
            (s, u, v)
        };
        (1 + s * k * (k + 1) + (u - 1) * (k + 1) + v) as u32
    };
    let mut t = Topo::new(1 + n * k * (k + 1));
    let mut centre = 0;
    for s in 0..n {
        for u in 0..k {
            for v in 0..k {
                if s == 0 && u == 0 && v == 0 {
                    centre = t.nf();
                }
                t.push(&[
                    id(s, u, v),
                    id(s, u + 1, v),
                    id(s, u + 1, v + 1),
                    id(s, u, v + 1),
                ]);
            }
        }
    }
    (t, centre)
}

/// The prediction stencil of every face whose corners all have closed rings:
/// `(vertex, weight)` pairs, with the exact weights of eq. 1 (1/degree per corner).
fn stencils(t: &Topo, rings: &Rings) -> Vec<Option<Vec<(u32, f64)>>> {
    (0..t.nf())
        .map(|f| {
            let face = t.face(f);
            let k = face.len();
            let mut st = Vec::new();
            for i in 0..k {
                let c = t.starts[f] as usize + i;
                let r = rings.of(face[i] as usize);
                if r.is_empty() {
                    return None;
                }
                let n = r.len();
                st.push((face[i], 0.5 / k as f64));
                for j in 0..n {
                    let p = r[(rings.pos[c] as usize + j) % n];
                    st.push((p, alpha(n, j) / k as f64));
                }
            }
            Some(st)
        })
        .collect()
}

/// Solves `a x = b` by Gaussian elimination with partial pivoting.
pub(crate) fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for col in 0..n {
        let p = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, p);
        b.swap(col, p);
        for r in col + 1..n {
            let m = a[r][col] / a[col][col];
            for c in col..n {
                a[r][c] -= m * a[col][c];
            }
            b[r] -= m * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|c| a[r][c] * x[c]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

/// The twelve lifting weights `omega_0..omega_11` (eq. 7) of the face whose corner `p0`
/// has valence `n` and every other vertex valence 4 (Table 1 of the paper; `n = 4` is
/// the regular case). Scaling functions: `phi_i = p_i` (corners), `phi_{4+2i}` =
/// `p_{i,n_i-1}`, `phi_{4+2((i+3)%4)+1}` = `p_{i,2}`; at valence 3 the two coincide and
/// `omega_11 = 0` (the paper's rule).
pub fn omega(n: usize) -> [f64; 12] {
    let (t, centre) = star(n, 6);
    let rings = Rings::new(&t);
    let st = stencils(&t, &rings);
    let face = t.face(centre);
    let mut phi = [0u32; 12];
    for i in 0..4 {
        phi[i] = face[i];
        let c = t.starts[centre] as usize + i;
        let r = rings.of(face[i] as usize);
        let ni = r.len();
        let at = |j: usize| r[(rings.pos[c] as usize + j) % ni];
        phi[4 + 2 * i] = at(ni - 1);
        phi[4 + 2 * ((i + 3) % 4) + 1] = at(2);
    }
    // Discrete functions on the fine points: vertex points (unit spikes) and face points.
    let value = |v: u32, f: usize| -> f64 {
        st[f].as_ref().map_or(0.0, |s| {
            s.iter().filter(|(p, _)| *p == v).map(|(_, w)| w).sum()
        })
    };
    let on_faces: Vec<Vec<f64>> = phi
        .iter()
        .map(|&v| (0..t.nf()).map(|f| value(v, f)).collect())
        .collect();
    let mut g = vec![vec![0.0; 12]; 12];
    let mut h = [0.0; 12];
    for i in 0..12 {
        for j in 0..12 {
            let spikes = if phi[i] == phi[j] { 1.0 } else { 0.0 };
            let faces: f64 = (0..t.nf()).map(|f| on_faces[i][f] * on_faces[j][f]).sum();
            g[i][j] = spikes + faces;
        }
        h[i] = on_faces[i][centre];
    }
    if n == 3 {
        for k in 0..12 {
            g[11][k] = 0.0;
            g[k][11] = 0.0;
        }
        g[11][11] = 1.0;
        h[11] = 0.0;
    }
    let x = solve(g, h.iter().map(|v| -v).collect());
    std::array::from_fn(|i| x[i])
}

/// The seven distinct weights of [`omega`] (`omega_0`, `omega_1 = omega_3`, `omega_2`,
/// `omega_4 = omega_11`, `omega_5 = omega_10`, `omega_6 = omega_9`, `omega_7 = omega_8`)
/// times 2^16, rounded, for valences 3..=`max`.
pub fn omega_table(max: usize) -> Vec<[i64; 7]> {
    (3..=max)
        .map(|n| {
            let w = omega(n);
            [w[0], w[1], w[2], w[4], w[5], w[6], w[7]].map(|v| (v * ONE as f64).round() as i64)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_weights_match_the_paper() {
        let w = omega(4);
        for i in 0..4 {
            assert!((w[i] - (-265312.0 / 1449569.0)).abs() < 1e-9, "{w:?}");
        }
        for i in 4..12 {
            assert!((w[i] - 55648.0 / 1449569.0).abs() < 1e-9, "{w:?}");
        }
        // The regular prediction: 5/16 per corner, -1/32 per outer neighbour.
        assert_eq!(
            alpha_fixed(4),
            vec![3 << 13, 3 << 13, -(1 << 13), -(1 << 13)]
        );
    }

    #[test]
    fn table_1_of_the_paper() {
        // n0, omega0, omega1=3, omega2, omega4=11, omega5=10, omega6=9, omega7=8.
        let table: [[f64; 8]; 10] = [
            [
                3.0, -0.194948, -0.187294, -0.179998, 0.070769, 0.033456, 0.039126, 0.037738,
            ],
            [
                4.0, -0.183028, -0.183028, -0.183028, 0.038389, 0.038389, 0.038389, 0.038389,
            ],
            [
                5.0, -0.167962, -0.177081, -0.187028, 0.018896, 0.039953, 0.038052, 0.039126,
            ],
            [
                6.0, -0.156338, -0.171716, -0.189868, 0.008222, 0.040061, 0.037848, 0.039609,
            ],
            [
                7.0, -0.146869, -0.167518, -0.191976, 0.003050, 0.039585, 0.037777, 0.039954,
            ],
            [
                8.0, -0.138752, -0.164354, -0.193600, 0.000622, 0.038932, 0.037794, 0.040219,
            ],
            [
                9.0, -0.131590, -0.161965, -0.194887, -0.000468, 0.038260, 0.037863, 0.040433,
            ],
            [
                10.0, -0.125168, -0.160137, -0.195932, -0.000898, 0.037627, 0.037960, 0.040610,
            ],
            [
                11.0, -0.119353, -0.158715, -0.196797, -0.000999, 0.037050, 0.038069, 0.040761,
            ],
            [
                12.0, -0.114054, -0.157591, -0.197526, -0.000938, 0.036531, 0.038184, 0.040890,
            ],
        ];
        for row in table {
            let n = row[0] as usize;
            let w = omega(n);
            let got = [w[0], w[1], w[2], w[4], w[5], w[6], w[7]];
            for k in 0..7 {
                assert!(
                    (got[k] - row[k + 1]).abs() < 1e-6,
                    "valence {n}, weight {k}: {} vs the paper's {}",
                    got[k],
                    row[k + 1]
                );
            }
            // The symmetric pairs.
            let pairs = [(1, 3), (4, 11), (5, 10), (6, 9), (7, 8)];
            for (a, b) in pairs {
                if n == 3 && b == 11 {
                    assert_eq!(w[11], 0.0);
                } else {
                    assert!((w[a] - w[b]).abs() < 1e-9, "valence {n}: {a} vs {b}");
                }
            }
        }
    }
}
