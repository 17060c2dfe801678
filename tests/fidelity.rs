#![allow(clippy::needless_range_loop)]
//! The floating-point forms of the transforms against the papers' subdivision rules:
//! with all details zero, bicubic synthesis is Catmull-Clark refinement (face and edge
//! points everywhere, vertex points at valence 4), and bilinear analysis on a regular
//! periodic grid is the separable 5/3 (linear B-spline) wavelet.

use subwave_codec::topology::{Level, Topo};
use subwave_codec::transform::{analyse, synthesise, Wavelet};
use subwave_corpus::PolyMesh;

fn topo(p: &PolyMesh) -> Topo {
    let mut t = Topo::new(p.positions.len());
    for f in &p.faces {
        t.push(f);
    }
    t
}

fn torus(n: u32, m: u32) -> PolyMesh {
    let mut positions = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let (u, v) = (
                i as f64 / n as f64 * std::f64::consts::TAU,
                j as f64 / m as f64 * std::f64::consts::TAU,
            );
            let r = 2.0 + 0.7 * v.cos() + 0.1 * (3.0 * u).sin();
            positions.push([
                r * u.cos(),
                r * u.sin(),
                0.7 * v.sin() + 0.05 * (5.0 * u).cos(),
            ]);
        }
    }
    let id = |i: u32, j: u32| (i % n) + n * (j % m);
    let faces = (0..m)
        .flat_map(|j| {
            (0..n).map(move |i| vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
        })
        .collect();
    PolyMesh { positions, faces }
}

/// Bicubic synthesis of coarse values P/4 (the b = 1 form keeps 1/4 per level) with zero
/// details, per axis.
fn bicubic_refine(coarse: &PolyMesh) -> (Level, Vec<[f64; 3]>) {
    let level = Level::new(&topo(coarse)).unwrap();
    let n = level.fine_nv();
    let mut out = vec![[0.0; 3]; n];
    for k in 0..3 {
        let mut x = vec![0.0f64; n];
        for (v, p) in coarse.positions.iter().enumerate() {
            x[v] = p[k] / 4.0;
        }
        synthesise(&level, Wavelet::Bicubic, &mut x);
        for i in 0..n {
            out[i][k] = x[i];
        }
    }
    (level, out)
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() < 1e-9)
}

#[test]
fn bicubic_with_zero_details_is_catmull_clark_on_a_regular_torus() {
    let coarse = torus(8, 6);
    let (level, ours) = bicubic_refine(&coarse);
    // The generator numbers the refinement exactly as SPEC.md 8.1 does.
    let cc = coarse.catmull_clark();
    assert_eq!(cc.positions.len(), level.fine_nv());
    for (i, (a, b)) in ours.iter().zip(&cc.positions).enumerate() {
        assert!(close(*a, *b), "vertex {i}: {a:?} vs Catmull-Clark {b:?}");
    }
}

#[test]
fn bicubic_face_and_edge_points_are_catmull_clarks_at_any_valence() {
    // The cube has valence-3 corners, the prism a pentagon, triangles and valence 5.
    for coarse in [subwave_corpus::cube(), subwave_corpus::mixed_polygons()] {
        let (level, ours) = bicubic_refine(&coarse);
        let cc = coarse.catmull_clark();
        for i in level.nv..level.fine_nv() {
            assert!(
                close(ours[i], cc.positions[i]),
                "point {i}: {:?} vs {:?}",
                ours[i],
                cc.positions[i]
            );
        }
    }
}

/// Periodic 1-D linear B-spline (5/3) analysis in floating point, in place on a line of
/// even length: odd -= mean of even neighbours; even += quarter of the odd neighbours.
fn lift_53(line: &mut [f64]) {
    let n = line.len();
    for i in (1..n).step_by(2) {
        line[i] -= 0.5 * (line[i - 1] + line[(i + 1) % n]);
    }
    for i in (0..n).step_by(2) {
        line[i] += 0.25 * (line[(i + n - 1) % n] + line[i + 1]);
    }
}

#[test]
fn bilinear_is_the_separable_5_3_wavelet_on_a_periodic_grid() {
    let (n, m) = (6u32, 4u32);
    let coarse = torus(n, m);
    let level = Level::new(&topo(&coarse)).unwrap();
    // Fine grid coordinates (2n x 2m, periodic) of every canonical fine vertex.
    let mut at = vec![(0u32, 0u32); level.fine_nv()];
    for v in 0..level.nv as u32 {
        at[v as usize] = (2 * (v % n), 2 * (v / n));
    }
    for (e, &[a, b]) in level.edges.iter().enumerate() {
        let (pa, pb) = (at[a as usize], at[b as usize]);
        let mid = |x: u32, y: u32, w: u32| {
            if (x + 2) % w == y {
                (x + 1) % w
            } else {
                (y + 1) % w
            }
        };
        at[level.nv + e] = if pa.1 == pb.1 {
            (mid(pa.0, pb.0, 2 * n), pa.1)
        } else {
            (pa.0, mid(pa.1, pb.1, 2 * m))
        };
    }
    for f in 0..level.nf() {
        let c = level.coarse.face(f)[0];
        let (x, y) = at[c as usize];
        at[level.nv + level.ne() + f] = ((x + 1) % (2 * n), (y + 1) % (2 * m));
    }
    let (w, h) = (2 * n as usize, 2 * m as usize);
    // Any data will do: a smooth field plus a ripple.
    let value = |x: u32, y: u32| {
        (x as f64 * 0.7).sin() * 3.0 + (y as f64 * 1.3).cos() + (x * y) as f64 * 0.01
    };
    let mut grid = vec![0.0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            grid[y * w + x] = value(x as u32, y as u32);
        }
    }
    let mut ours: Vec<f64> = at
        .iter()
        .map(|&(x, y)| grid[y as usize * w + x as usize])
        .collect();
    analyse(&level, Wavelet::Bilinear, &mut ours);
    // Rows, then columns.
    for y in 0..h {
        lift_53(&mut grid[y * w..(y + 1) * w]);
    }
    for x in 0..w {
        let mut col: Vec<f64> = (0..h).map(|y| grid[y * w + x]).collect();
        lift_53(&mut col);
        for y in 0..h {
            grid[y * w + x] = col[y];
        }
    }
    for (i, &(x, y)) in at.iter().enumerate() {
        let want = grid[y as usize * w + x as usize];
        assert!(
            (ours[i] - want).abs() < 1e-12,
            "fine vertex {i} at ({x},{y}): {} vs 5/3 {}",
            ours[i],
            want
        );
    }
}

#[test]
fn dyadic_sym_keeps_constants_exactly_in_floating_point() {
    // Weights of every prediction sum to one and 1/j undoes the first step's gain:
    // constant data give zero detail and unchanged coarse values, also at valence 3
    // and 5 and on a boundary.
    for coarse in [
        torus(6, 5),
        subwave_corpus::cube(),
        subwave_corpus::mixed_polygons(),
        subwave_corpus::open_grid(3, 2),
    ] {
        let level = Level::new(&topo(&coarse)).unwrap();
        let mut x = vec![2.5f64; level.fine_nv()];
        analyse(&level, Wavelet::DyadicSym, &mut x);
        for (i, &v) in x.iter().enumerate() {
            let want = if i < level.nv { 2.5 } else { 0.0 };
            assert!((v - want).abs() < 1e-12, "value {i}: {v}");
        }
        synthesise(&level, Wavelet::DyadicSym, &mut x);
        assert!(x.iter().all(|&v| (v - 2.5).abs() < 1e-12));
    }
}

/// The noise-filtering experiment of Wang & Ma 2009 (section 5, Table 2) in kind: a
/// smooth surface made by interpolatory sqrt(2) subdivision of a closed base (all
/// details zero), white noise on every vertex of the finest level, then analysis one
/// level at a time; each low-pass version is refined back to the finest level with zero
/// details and compared with the undisturbed surface (RMS distance per vertex). With
/// ir2w's update the noise error
/// falls level by level and ends well below a tenth of the start; without it
/// (sqrt2-lazy) the coarse vertices keep their noise.
#[test]
fn ir2w_low_pass_filters_noise_level_by_level() {
    use subwave_codec::topology::sqrt2::{fine, fine_nv};
    use subwave_codec::transform::sqrt2::Plan;
    const STEPS: usize = 8;
    // A quad base whose extraordinary vertices (valence 3) are isolated, like the
    // paper's: the cube after two Catmull-Clark steps, 98 vertices.
    let base = subwave_corpus::cube().refined(2);
    let mut levels = Vec::new();
    let mut t = topo(&base);
    for _ in 0..STEPS {
        let l = Level::new(&t).unwrap();
        t = fine(&l);
        levels.push(l);
    }
    let smooth: [Vec<f64>; 3] = std::array::from_fn(|k| {
        let mut x: Vec<f64> = base.positions.iter().map(|p| p[k]).collect();
        for l in &levels {
            x.resize(fine_nv(l), 0.0);
            Plan::new(l, Wavelet::Sqrt2Lazy).synthesise(&mut x);
        }
        x
    });
    let n = smooth[0].len();
    let mut rng = subwave_corpus::Rng::new(11);
    let noisy: [Vec<f64>; 3] = std::array::from_fn(|k| {
        (0..n)
            .map(|i| smooth[k][i] + 0.02 * (rng.unit() - 0.5))
            .collect()
    });
    let errors = |w: Wavelet| -> Vec<f64> {
        let plans: Vec<Plan> = levels.iter().map(|l| Plan::new(l, w)).collect();
        let mut x = noisy.clone();
        let mut out = Vec::new();
        for k in (0..=STEPS).rev() {
            // Low-pass version at level k: coarse values, details above k zero.
            let mut y: [Vec<f64>; 3] = std::array::from_fn(|a| {
                x[a][..if k == 0 {
                    base.positions.len()
                } else {
                    fine_nv(&levels[k - 1])
                }]
                    .to_vec()
            });
            for (l, p) in levels.iter().zip(&plans).skip(k) {
                for ya in y.iter_mut() {
                    ya.resize(fine_nv(l), 0.0);
                    p.synthesise(ya);
                }
            }
            let e: f64 = (0..n)
                .map(|i| {
                    (0..3)
                        .map(|a| (y[a][i] - smooth[a][i]).powi(2))
                        .sum::<f64>()
                })
                .sum();
            out.push((e / n as f64).sqrt());
            if k > 0 {
                let m = fine_nv(&levels[k - 1]);
                for xa in x.iter_mut() {
                    plans[k - 1].analyse(&mut xa[..m]);
                }
            }
        }
        out
    };
    let ir2w = errors(Wavelet::Ir2w);
    let lazy = errors(Wavelet::Sqrt2Lazy);
    eprintln!("level  ir2w        sqrt2-lazy");
    for (i, (a, b)) in ir2w.iter().zip(&lazy).enumerate() {
        eprintln!("{:>5}  {a:.6}  {b:.6}", STEPS - i);
    }
    for w in ir2w.windows(2) {
        assert!(
            w[1] < w[0],
            "ir2w noise error must fall every level: {ir2w:?}"
        );
    }
    let ratio = ir2w[STEPS] / ir2w[0];
    let lazy_ratio = lazy[STEPS] / lazy[0];
    eprintln!("final / initial: ir2w {ratio:.4}, sqrt2-lazy {lazy_ratio:.4}");
    assert!(ratio < 0.1, "ir2w final / initial = {ratio}");
    assert!(lazy_ratio > ratio, "the update is what filters");
}

/// A closed surface of revolution as three polar nets (x, y, z): `n` spokes, `k` rings
/// between the poles, a mushroom-like profile.
fn polar_mushroom(n: usize, k: usize) -> [subwave_codec::transform::polar::reference::Net; 3] {
    use std::f64::consts::{PI, TAU};
    let profile = |t: f64| {
        // t in [0, 1] from the top pole to the bottom one: (radius, height).
        let th = PI * t;
        (
            th.sin() * (1.0 + 0.5 * (th * 1.5).cos().max(0.0)),
            1.2 * th.cos() - 0.3 * (2.0 * th).sin(),
        )
    };
    std::array::from_fn(|a| {
        let mut rings = Vec::with_capacity(n * k);
        for r in 0..k {
            let (rho, z) = profile((r + 1) as f64 / (k + 1) as f64);
            for j in 0..n {
                let phi = TAU * j as f64 / n as f64;
                rings.push([rho * phi.cos(), rho * phi.sin(), z][a]);
            }
        }
        let (_, za) = profile(0.0);
        let (_, zb) = profile(1.0);
        subwave_codec::transform::polar::reference::Net {
            n,
            k,
            poles: if a == 2 { [za, zb] } else { [0.0, 0.0] },
            rings,
        }
    })
}

/// The stability experiment of Zhao et al. 2009 (Tables 3 and 4) in kind, in floating
/// point: a closed polar net (two poles of valence 8, 5 rings) subdivided 4 times by
/// polar subdivision, white noise on every vertex of the finest level, then analysis one
/// level at a time; each low-pass version is refined back to level 4 with zero details
/// and compared with the undisturbed surface (RMS distance per vertex). With the
/// paper's lifting the error stays at the noise level or below; without it (the lazy
/// wavelet) it grows level by level. Both analysis orders (Table 5: radial first A,
/// circular first B) end close to each other.
#[test]
fn polar_lifting_keeps_the_noise_error_flat_over_levels() {
    use subwave_codec::transform::polar::reference::{analyse, synthesise, Lifting, Net, Order};
    const LEVELS: usize = 4;
    let base = polar_mushroom(8, 5);
    let refine = |net: &Net, levels: usize, order: Order| {
        let mut x = net.clone();
        for _ in 0..levels {
            x = synthesise(&x, None, Lifting::Lazy, order);
        }
        x
    };
    let flat = |x: &[Net; 3]| -> Vec<[f64; 3]> {
        let mut out: Vec<[f64; 3]> = (0..x[0].rings.len())
            .map(|i| std::array::from_fn(|a| x[a].rings[i]))
            .collect();
        out.extend((0..2).map(|p| std::array::from_fn(|a| x[a].poles[p])));
        out
    };
    let rms = |a: &[[f64; 3]], b: &[[f64; 3]]| {
        let s: f64 = a
            .iter()
            .zip(b)
            .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>())
            .sum();
        (s / a.len() as f64).sqrt()
    };
    let mut rng = subwave_corpus::Rng::new(17);
    let mut noise = vec![0.0; 3 * 200_000];
    for v in noise.iter_mut() {
        *v = 0.01 * (rng.unit() - 0.5);
    }
    // Low-pass versions at levels 4..0, refined back to level 4.
    let run = |lifting: Lifting, order: Order| -> (Vec<f64>, Vec<[f64; 3]>) {
        let smooth: [Net; 3] = std::array::from_fn(|a| refine(&base[a], LEVELS, order));
        let reference = flat(&smooth);
        let mut x = smooth.clone();
        let mut i = 0;
        for net in x.iter_mut() {
            for v in net.rings.iter_mut().chain(net.poles.iter_mut()) {
                *v += noise[i];
                i += 1;
            }
        }
        let mut errors = Vec::new();
        let mut last = Vec::new();
        for level in (0..=LEVELS).rev() {
            let up: [Net; 3] = std::array::from_fn(|a| refine(&x[a], LEVELS - level, order));
            last = flat(&up);
            errors.push(rms(&last, &reference));
            if level > 0 {
                x = std::array::from_fn(|a| analyse(&x[a], lifting, order).0);
            }
        }
        (errors, last)
    };
    let (lifted, b_final) = run(Lifting::Lifted, Order::CircularFirst);
    let (lazy, _) = run(Lifting::Lazy, Order::CircularFirst);
    let (lifted_a, a_final) = run(Lifting::Lifted, Order::RadialFirst);
    let (lazy_a, _) = run(Lifting::Lazy, Order::RadialFirst);
    let vertices = |level: usize| {
        let (mut n, mut k) = (8usize, 5usize);
        for _ in 0..level {
            n *= 2;
            k = 2 * k + 1;
        }
        n * k + 2
    };
    eprintln!("level  vertices  lifted (B)  lazy (B)    lifted (A)  lazy (A)");
    for i in 0..=LEVELS {
        eprintln!(
            "{:>5}  {:>8}  {:.7}   {:.7}   {:.7}   {:.7}",
            LEVELS - i,
            vertices(LEVELS - i),
            lifted[i],
            lazy[i],
            lifted_a[i],
            lazy_a[i]
        );
    }
    let ab = rms(&a_final, &b_final);
    eprintln!(
        "level 0 refined: A vs B {ab:.7}, B vs original {:.7}",
        lifted[LEVELS]
    );
    for errs in [&lifted, &lifted_a] {
        // Flat: never above the noise itself (level 4) by more than a fifth.
        assert!(
            errs.iter().all(|&e| e <= 1.2 * errs[0]),
            "lifted error must stay flat: {errs:?}"
        );
    }
    for (lz, lf) in [(&lazy, &lifted), (&lazy_a, &lifted_a)] {
        assert!(
            lz.windows(2).all(|w| w[1] > w[0]),
            "lazy error must grow every level: {lz:?}"
        );
        assert!(lz[LEVELS] > 10.0 * lf[LEVELS], "{lz:?} vs {lf:?}");
    }
    // Table 5 in kind: the two orders' results differ less than either from the original.
    assert!(
        ab < 0.5 * lifted[LEVELS].min(lifted_a[LEVELS]),
        "A vs B {ab}"
    );
}
