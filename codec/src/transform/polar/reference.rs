//! Polar wavelets (Zhao et al. 2009), floating-point reference forms: the lifting weights
//! of their local orthogonalisation (eq. 7/8 with Bertram's discrete inner product, for
//! any pole valence) and the lazy and lifted analysis and synthesis on a closed polar net
//! (two poles joined by rings of quads), in either order (radial or circular first).
//!
//! Nothing here runs while coding: this is the program behind future fixed-point tables
//! and the stability experiment of the paper's Tables 3 and 4 (`tests/fidelity.rs`).
//! The rules are those of `TRANSFORMS.md` section 4 (the seed's off-by-one in the ring
//! vertex rule corrected): beta = 1/2, alpha = 1/4, so C = sum(gamma) = 1/2 and U = 1/2
//! for valences n >= 4.

use crate::transform::sqrt2::solve::solve;

/// The spoke weights gamma_0..gamma_{n-1} of a pole of valence n (eq. 1, beta = 1/2).
pub fn gamma(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let c = (std::f64::consts::TAU * k as f64 / n as f64).cos();
            (0.625 * c + c * c + 0.5 * c * c * c) / n as f64
        })
        .collect()
}

/// Fixed-point scale of the frozen gamma table: 2^16.
pub const ONE: i64 = 1 << 16;

/// Gamma of valence `n` times 2^16, rounded half away from zero, re-balanced so that the
/// weights sum to exactly 2^15 (one half, the pole keeping the other half): the residual
/// goes to k = 0. This is what the frozen table (`crate::transform::polar::GAMMA`) holds.
pub fn gamma_fixed(n: usize) -> Vec<i64> {
    let mut g: Vec<i64> = gamma(n)
        .iter()
        .map(|&x| (x * ONE as f64).round() as i64)
        .collect();
    let s: i64 = g.iter().sum();
    g[0] += ONE / 2 - s;
    g
}

/// A weight times 2^16, rounded half away from zero: the lifting tables' fixed point.
fn fixed(w: f64) -> i32 {
    (w * ONE as f64).round() as i32
}

/// The circular lifting weights w_{-2..3} (Table 2) times 2^16: what the frozen table
/// (`crate::transform::polar::tables::LIFT_W`) holds.
pub fn circular_weights_fixed() -> [i32; 6] {
    circular_weights().map(fixed)
}

/// The radial lifting weights of valence `n` times 2^16: t (n + 2 entries) and s (three
/// cases of eight), what the frozen tables (`crate::transform::polar::tables::LIFT_T`, `LIFT_S`)
/// hold.
pub fn radial_weights_fixed(n: usize) -> (Vec<i32>, [[i32; 8]; 3]) {
    let w = radial_weights(n);
    (
        w.t.iter().map(|&t| fixed(t)).collect(),
        w.s.map(|row| row.map(fixed)),
    )
}

/// A closed polar net: poles `a` and `b`, `k` rings of `n` vertices between them (ring
/// 0 next to `a`), each spoke a path a - ring 0 - ... - ring k-1 - b. Values per axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Net {
    /// Spokes (the poles' valence).
    pub n: usize,
    /// Rings.
    pub k: usize,
    /// The two poles.
    pub poles: [f64; 2],
    /// Ring vertices, ring-major: `rings[r * n + j]`.
    pub rings: Vec<f64>,
}

/// The details of one analysis step, as the synthesis step takes them back.
#[derive(Debug, Clone, PartialEq)]
pub struct Details {
    /// Radial details: per segment s = 0..=k of the coarse net (s joins ring s - 1 and
    /// ring s; segment 0 starts at pole a, segment k ends at pole b), per spoke.
    pub radial: Vec<f64>,
    /// Circular details: per ring of the net the circular step ran on, per spoke.
    pub circular: Vec<f64>,
}

/// Which lifting the transform uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lifting {
    /// None: the lazy wavelet (the refinement rules inverted).
    Lazy,
    /// The paper's local lifting (eq. 11-13).
    Lifted,
}

/// The order of the two analysis steps (the paper's Table 5: A radial first, B circular).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// Radial analysis first (synthesis: circular, then radial).
    RadialFirst,
    /// Circular analysis first (synthesis: radial, then circular).
    CircularFirst,
}

impl Net {
    fn at(&self, r: usize, j: usize) -> f64 {
        self.rings[r * self.n + j % self.n]
    }
}

/// Radial synthesis (eq. 2), lifted by `w` (when given, before the rules):
/// a net of k rings and its 2k + 1 segment details -> a net of 2k + 1 rings.
fn radial_synthesis(c: &Net, d: &[f64], w: Option<&RadialWeights>) -> Net {
    let (n, k) = (c.n, c.k);
    assert!(k >= 2, "a closed polar net needs at least two rings");
    let mut v = c.clone();
    if let Some(w) = w {
        lift_radial(&mut v, d, w, 1.0);
    }
    let g = gamma(n);
    // Segment points.
    let mut e = vec![0.0; (k + 1) * n];
    for j in 0..n {
        let (mut sa, mut sb) = (0.0, 0.0);
        for m in 0..n {
            sa += g[(m + n - j) % n] * v.at(0, m);
            sb += g[(m + n - j) % n] * v.at(k - 1, m);
        }
        e[j] = d[j] + 0.5 * v.poles[0] + sa;
        e[k * n + j] = d[k * n + j] + 0.5 * v.poles[1] + sb;
        for s in 1..k {
            e[s * n + j] = d[s * n + j] + 0.5 * (v.at(s - 1, j) + v.at(s, j));
        }
    }
    let mut f = Net {
        n,
        k: 2 * k + 1,
        poles: [0.0; 2],
        rings: vec![0.0; (2 * k + 1) * n],
    };
    for s in 0..=k {
        f.rings[2 * s * n..(2 * s + 1) * n].copy_from_slice(&e[s * n..(s + 1) * n]);
    }
    for r in 0..k {
        for j in 0..n {
            let (ea, eb) = (e[r * n + j], e[(r + 1) * n + j]);
            f.rings[(2 * r + 1) * n + j] = if r == 0 {
                v.poles[0] / 8.0 + 0.625 * v.at(r, j) + eb / 4.0
            } else if r == k - 1 {
                v.poles[1] / 8.0 + 0.625 * v.at(r, j) + ea / 4.0
            } else {
                0.5 * v.at(r, j) + 0.25 * (ea + eb)
            };
        }
    }
    let sum = |s: usize| e[s * n..(s + 1) * n].iter().sum::<f64>();
    f.poles[0] = 0.5 * v.poles[0] + sum(0) / (2 * n) as f64;
    f.poles[1] = 0.5 * v.poles[1] + sum(k) / (2 * n) as f64;
    f
}

/// Radial analysis (eq. 3, 13): the inverse of [`radial_synthesis`].
fn radial_analysis(f: &Net, w: Option<&RadialWeights>) -> (Net, Vec<f64>) {
    let n = f.n;
    assert!(
        f.k % 2 == 1 && f.k >= 5,
        "radial analysis needs 2k + 1 rings, k >= 2"
    );
    let k = (f.k - 1) / 2;
    let e = |s: usize, j: usize| f.at(2 * s, j);
    let mut c = Net {
        n,
        k,
        poles: [0.0; 2],
        rings: vec![0.0; k * n],
    };
    let sum = |s: usize| (0..n).map(|j| e(s, j)).sum::<f64>();
    c.poles[0] = 2.0 * f.poles[0] - sum(0) / n as f64;
    c.poles[1] = 2.0 * f.poles[1] - sum(k) / n as f64;
    for r in 0..k {
        for j in 0..n {
            let vp = f.at(2 * r + 1, j);
            c.rings[r * n + j] = if r == 0 {
                1.6 * (vp - c.poles[0] / 8.0 - e(1, j) / 4.0)
            } else if r == k - 1 {
                1.6 * (vp - c.poles[1] / 8.0 - e(k - 1, j) / 4.0)
            } else {
                2.0 * (vp - 0.25 * (e(r, j) + e(r + 1, j)))
            };
        }
    }
    let g = gamma(n);
    let mut d = vec![0.0; (k + 1) * n];
    for j in 0..n {
        let (mut sa, mut sb) = (0.0, 0.0);
        for m in 0..n {
            sa += g[(m + n - j) % n] * c.at(0, m);
            sb += g[(m + n - j) % n] * c.at(k - 1, m);
        }
        d[j] = e(0, j) - 0.5 * c.poles[0] - sa;
        d[k * n + j] = e(k, j) - 0.5 * c.poles[1] - sb;
        for s in 1..k {
            d[s * n + j] = e(s, j) - 0.5 * (c.at(s - 1, j) + c.at(s, j));
        }
    }
    if let Some(w) = w {
        lift_radial(&mut c, &d, w, -1.0);
    }
    (c, d)
}

/// The radial lifting weights of one valence: `t` for the spoke points next to a pole
/// (pole, ring 0 at spokes j..j+n-1, ring 1 at spoke j) and `s` for the other segment
/// points, by how far the segment is from the nearer pole (Table 1's columns a, b, c).
#[derive(Debug, Clone, PartialEq)]
pub struct RadialWeights {
    /// `n + 2` weights.
    pub t: Vec<f64>,
    /// Per case (segment 1, 2, >= 3 from the pole): the weights of phi_0..phi_7.
    pub s: [[f64; 8]; 3],
}

/// Adds `sign` x the radial lifting of details `d` to the coarse values (synthesis +1,
/// analysis -1). A segment nearer pole b uses the mirrored stencil.
fn lift_radial(c: &mut Net, d: &[f64], w: &RadialWeights, sign: f64) {
    let (n, k) = (c.n, c.k);
    assert!(
        k >= 5,
        "lifting keeps the two poles' stencils apart: at least 5 rings"
    );
    let mut upd = vec![0.0; k * n];
    let mut pole = [0.0; 2];
    for j in 0..n {
        for (end, s, r0, r1) in [(0, 0, 0, 1), (1, k, k - 1, k - 2)] {
            let x = d[s * n + j];
            pole[end] += w.t[0] * x;
            for m in 0..n {
                upd[r0 * n + (j + m) % n] += w.t[1 + m] * x;
            }
            upd[r1 * n + j] += w.t[n + 1] * x;
        }
        for s in 1..k {
            let x = d[s * n + j];
            // The stencil from the nearer pole outward (Table 1's phi_0..phi_7): phi_0 on
            // the far side of the nearer ring (a pole for the segments next to one),
            // phi_1..3 on the nearer ring, phi_4..6 on the other, phi_7 beyond it.
            let (case, near, far, back, ahead) = if s <= k - s {
                (s.min(3) - 1, s - 1, s, s as isize - 2, s as isize + 1)
            } else {
                ((k - s).min(3) - 1, s, s - 1, s as isize + 1, s as isize - 2)
            };
            let st = &w.s[case];
            let mut add = |r: isize, jj: usize, wt: f64, pole: &mut [f64; 2]| {
                if r < 0 {
                    pole[0] += wt * x;
                } else if r as usize >= k {
                    pole[1] += wt * x;
                } else {
                    upd[r as usize * n + jj % n] += wt * x;
                }
            };
            add(back, j, st[0], &mut pole);
            add(near as isize, j + n - 1, st[1], &mut pole);
            add(near as isize, j, st[2], &mut pole);
            add(near as isize, j + 1, st[3], &mut pole);
            add(far as isize, j + 1, st[4], &mut pole);
            add(far as isize, j, st[5], &mut pole);
            add(far as isize, j + n - 1, st[6], &mut pole);
            add(ahead, j, st[7], &mut pole);
        }
    }
    for (v, u) in c.rings.iter_mut().zip(&upd) {
        *v += sign * u;
    }
    c.poles[0] += sign * pole[0];
    c.poles[1] += sign * pole[1];
}

/// The circular lifting weights w_{-2..3} (Table 2).
pub fn circular_weights() -> [f64; 6] {
    let n = 16;
    let phi = |j: usize| {
        let mut x = vec![0.0; n];
        x[j] = 1.0;
        circular_synthesis_ring(&x, &vec![0.0; n], None)
    };
    let psi = {
        let mut d = vec![0.0; n];
        d[5] = 1.0;
        circular_synthesis_ring(&vec![0.0; n], &d, None)
    };
    let stencil: Vec<Vec<f64>> = (0..6).map(|k| phi(5 + k - 2)).collect();
    let w = local_orthogonalisation(&psi, &stencil);
    std::array::from_fn(|i| w[i])
}

/// Solves eq. 8: the weights that make psi + sum w_k phi_k orthogonal to every phi_k.
fn local_orthogonalisation(psi: &[f64], phis: &[Vec<f64>]) -> Vec<f64> {
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let a = phis
        .iter()
        .map(|p| phis.iter().map(|q| dot(p, q)).collect())
        .collect();
    let b = phis.iter().map(|p| -dot(psi, p)).collect();
    solve(a, b)
}

/// One ring's circular synthesis (eq. 11): n coarse values and n details -> 2n values
/// (even positions the old vertices, odd ones the new points).
fn circular_synthesis_ring(v: &[f64], d: &[f64], w: Option<&[f64; 6]>) -> Vec<f64> {
    let n = v.len();
    let mut v = v.to_vec();
    if let Some(w) = w {
        for j in 0..n {
            for (i, wk) in w.iter().enumerate() {
                v[(j + n + i - 2) % n] += wk * d[j];
            }
        }
    }
    let e: Vec<f64> = (0..n)
        .map(|j| d[j] + 0.5 * (v[j] + v[(j + 1) % n]))
        .collect();
    let mut out = vec![0.0; 2 * n];
    for j in 0..n {
        out[2 * j] = 0.25 * (e[(j + n - 1) % n] + 2.0 * v[j] + e[j]);
        out[2 * j + 1] = e[j];
    }
    out
}

/// The inverse of [`circular_synthesis_ring`] (eq. 12).
fn circular_analysis_ring(f: &[f64], w: Option<&[f64; 6]>) -> (Vec<f64>, Vec<f64>) {
    let n = f.len() / 2;
    let e = |j: usize| f[2 * (j % n) + 1];
    let mut v: Vec<f64> = (0..n)
        .map(|j| 2.0 * f[2 * j] - 0.5 * (e(j + n - 1) + e(j)))
        .collect();
    let d: Vec<f64> = (0..n)
        .map(|j| e(j) - 0.5 * (v[j] + v[(j + 1) % n]))
        .collect();
    if let Some(w) = w {
        for j in 0..n {
            for (i, wk) in w.iter().enumerate() {
                v[(j + n + i - 2) % n] -= wk * d[j];
            }
        }
    }
    (v, d)
}

/// The radial weights of valence `n`, from the refinement masks of a net far from its
/// second pole.
pub fn radial_weights(n: usize) -> RadialWeights {
    let k = 8;
    let zero = Net {
        n,
        k,
        poles: [0.0; 2],
        rings: vec![0.0; k * n],
    };
    let flat = |f: Net| {
        let mut x = f.rings;
        x.extend(f.poles);
        x
    };
    // phi: a unit coarse value (None = pole a); psi: a unit detail.
    let phi = |r: Option<usize>, j: usize| {
        let mut c = zero.clone();
        match r {
            None => c.poles[0] = 1.0,
            Some(r) => c.rings[r * n + j % n] = 1.0,
        }
        flat(radial_synthesis(&c, &vec![0.0; (k + 1) * n], None))
    };
    let psi = |s: usize| {
        let mut d = vec![0.0; (k + 1) * n];
        d[s * n] = 1.0;
        flat(radial_synthesis(&zero, &d, None))
    };
    let mut stencil = vec![phi(None, 0)];
    stencil.extend((0..n).map(|m| phi(Some(0), m)));
    stencil.push(phi(Some(1), 0));
    let t = local_orthogonalisation(&psi(0), &stencil);
    let s = std::array::from_fn(|case| {
        let s = case + 1;
        let back = if s == 1 { None } else { Some(s - 2) };
        let st = [
            phi(back, 0),
            phi(Some(s - 1), n - 1),
            phi(Some(s - 1), 0),
            phi(Some(s - 1), 1),
            phi(Some(s), 1),
            phi(Some(s), 0),
            phi(Some(s), n - 1),
            phi(Some(s + 1), 0),
        ];
        let w = local_orthogonalisation(&psi(s), &st);
        std::array::from_fn(|i| w[i])
    });
    RadialWeights { t, s }
}

/// The weights a lifted transform step of a net of valence `n` uses.
fn weights(lifting: Lifting, n: usize) -> Option<(RadialWeights, [f64; 6])> {
    (lifting == Lifting::Lifted).then(|| (radial_weights(n), circular_weights()))
}

/// One analysis step: a net of 2n spokes and 2k + 1 rings -> a net of n spokes and k
/// rings, and the details.
pub fn analyse(f: &Net, lifting: Lifting, order: Order) -> (Net, Details) {
    let circular = |net: &Net, w: Option<&[f64; 6]>| {
        let n = net.n / 2;
        let mut c = Net {
            n,
            k: net.k,
            poles: net.poles,
            rings: Vec::with_capacity(net.k * n),
        };
        let mut d = Vec::with_capacity(net.k * n);
        for r in 0..net.k {
            let (v, e) = circular_analysis_ring(&net.rings[r * net.n..(r + 1) * net.n], w);
            c.rings.extend(v);
            d.extend(e);
        }
        (c, d)
    };
    match order {
        Order::CircularFirst => {
            let wts = weights(lifting, f.n / 2);
            let (mid, dc) = circular(f, wts.as_ref().map(|w| &w.1));
            let (c, dr) = radial_analysis(&mid, wts.as_ref().map(|w| &w.0));
            (
                c,
                Details {
                    radial: dr,
                    circular: dc,
                },
            )
        }
        Order::RadialFirst => {
            let wr = weights(lifting, f.n);
            let (mid, dr) = radial_analysis(f, wr.as_ref().map(|w| &w.0));
            let (c, dc) = circular(&mid, wr.as_ref().map(|w| &w.1));
            (
                c,
                Details {
                    radial: dr,
                    circular: dc,
                },
            )
        }
    }
}

/// One synthesis step, the inverse of [`analyse`]; details `None` are all zero
/// (subdivision).
pub fn synthesise(c: &Net, d: Option<&Details>, lifting: Lifting, order: Order) -> Net {
    let circular = |net: &Net, d: Option<&[f64]>, w: Option<&[f64; 6]>| {
        let n = net.n;
        let zero = vec![0.0; n];
        let mut f = Net {
            n: 2 * n,
            k: net.k,
            poles: net.poles,
            rings: Vec::with_capacity(net.k * 2 * n),
        };
        for r in 0..net.k {
            let dr = d.map_or(&zero[..], |d| &d[r * n..(r + 1) * n]);
            f.rings.extend(circular_synthesis_ring(
                &net.rings[r * n..(r + 1) * n],
                dr,
                w,
            ));
        }
        f
    };
    match order {
        Order::CircularFirst => {
            let wts = weights(lifting, c.n);
            let zero = vec![0.0; (c.k + 1) * c.n];
            let dr = d.map_or(&zero[..], |d| &d.radial[..]);
            let mid = radial_synthesis(c, dr, wts.as_ref().map(|w| &w.0));
            circular(&mid, d.map(|d| &d.circular[..]), wts.as_ref().map(|w| &w.1))
        }
        Order::RadialFirst => {
            let wts = weights(lifting, 2 * c.n);
            let mid = circular(c, d.map(|d| &d.circular[..]), wts.as_ref().map(|w| &w.1));
            let zero = vec![0.0; (mid.k + 1) * mid.n];
            let dr = d.map_or(&zero[..], |d| &d.radial[..]);
            radial_synthesis(&mid, dr, wts.as_ref().map(|w| &w.0))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn gamma_sums_to_one_half_from_valence_four() {
        for n in 4..40 {
            assert!(
                (gamma(n).iter().sum::<f64>() - 0.5).abs() < 1e-12,
                "n = {n}"
            );
        }
        assert!((gamma(3).iter().sum::<f64>() - 0.625).abs() < 1e-12);
    }

    #[test]
    fn weights_reproduce_the_papers_tables() {
        // Table 2.
        let w = circular_weights();
        let table2 = [
            -0.082941, 0.226480, -0.535561, -0.535561, 0.226480, -0.082941,
        ];
        assert!(close(&w, &table2, 5e-7), "{w:?}");
        // Table 1 (n = 8): t, then s with v_0 the pole, a ring-0 vertex, further out.
        let r = radial_weights(8);
        let t = [
            -0.212173, -0.239089, -0.052675, 0.083197, 0.080547, 0.076314, 0.080547, 0.083197,
            -0.052675, 0.098667,
        ];
        assert!(close(&r.t, &t, 5e-7), "{:?}", r.t);
        let s = [
            [
                0.060810, 0.026201, -0.560051, 0.026201, -0.011349, -0.506860, -0.011349, 0.182173,
            ],
            [0.228947, 0.0, -0.544587, 0.0, 0.0, -0.516979, 0.0, 0.186000],
            [0.189068, 0.0, -0.525336, 0.0, 0.0, -0.525336, 0.0, 0.189068],
        ];
        for (got, want) in r.s.iter().zip(&s) {
            assert!(close(got, want, 5e-7), "{got:?}");
        }
    }

    fn random_net(n: usize, k: usize, seed: u64) -> Net {
        let mut s = seed | 1;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % 2001) as f64 / 1000.0 - 1.0
        };
        Net {
            n,
            k,
            poles: [rnd(), rnd()],
            rings: (0..n * k).map(|_| rnd()).collect(),
        }
    }

    #[test]
    fn analysis_inverts_synthesis_in_both_orders() {
        for lifting in [Lifting::Lazy, Lifting::Lifted] {
            for order in [Order::CircularFirst, Order::RadialFirst] {
                let f = random_net(12, 11, 5);
                let (c, d) = analyse(&f, lifting, order);
                assert_eq!((c.n, c.k), (6, 5));
                let back = synthesise(&c, Some(&d), lifting, order);
                assert!(close(&back.rings, &f.rings, 1e-9), "{lifting:?} {order:?}");
                assert!(close(&back.poles, &f.poles, 1e-9));
            }
        }
    }
}
