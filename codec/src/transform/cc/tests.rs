//! The Catmull-Clark transforms' tests.

use super::interp::*;
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

/// A hierarchy's stencil cache gives interp4 and interp6 what their own stencils give,
/// whichever is asked for first (interp6's tables serve interp4), and on a level of
/// another size than the cached one its own stencils.
#[test]
fn cached_stencils_are_each_wavelets_own() {
    let levels: Vec<Level> = [grid(5), mixed(), open_mixed()]
        .iter()
        .map(|t| Level::new(t).unwrap())
        .collect();
    let transformed = |level: &Level, w: Wavelet, st: &Stencils| {
        let orig: Vec<i64> = (0..level.fine_nv() as i64)
            .map(|i| i * i * 37 % 1001 - 500)
            .collect();
        let mut x = orig.clone();
        analyse_with(level, w, st, &mut x, &[]);
        let analysed = x.clone();
        synthesise_with(level, w, st, &mut x, &[]);
        assert_eq!(x, orig);
        analysed
    };
    for order in [[Wavelet::Interp4, Wavelet::Interp6], [Wavelet::Interp6, Wavelet::Interp4]] {
        let cache = StencilCache::new(levels.len());
        for (i, level) in levels.iter().enumerate() {
            for w in order {
                let want = transformed(level, w, &Stencils::new(level, w));
                assert_eq!(transformed(level, w, &cache.stencils(i, level, w)), want, "{w:?} level {i}");
            }
        }
        // Level 0's tables are the grid's: the prism at index 0 is not that level.
        for w in order {
            let want = transformed(&levels[1], w, &Stencils::new(&levels[1], w));
            assert_eq!(transformed(&levels[1], w, &cache.stencils(0, &levels[1], w)), want);
        }
        // Past the cache's levels: made apart.
        let w = order[0];
        let want = transformed(&levels[2], w, &Stencils::new(&levels[2], w));
        assert_eq!(transformed(&levels[2], w, &cache.stencils(9, &levels[2], w)), want);
    }
    // interp4's tables alone do not serve interp6.
    let four = Interp4::new(&levels[0], false);
    assert!(four.with_six(true).is_none());
    assert!(four.with_six(false).is_some_and(|st| !st.six));
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

/// Every level of corpus/'s hierarchies (quads, triangles and pentagons, open and
/// closed, polar fans) and of ../shared/corpus when it is there, and refined grids.
fn stencil_levels() -> Vec<(String, Level)> {
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
    levels
}

#[test]
fn stencil_tables_equal_their_definitions() {
    // The one-pass tables are the definitions' tables.
    let levels = stencil_levels();
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

/// The stencils of a level's successor derived from its own are the successor's tables
/// (every table, interp4 and interp6), on every level that is all quads; a level with a
/// triangle or pentagon derives none.
#[test]
fn derived_stencils_are_the_next_levels() {
    let mut levels = stencil_levels();
    // Boundaries, corners and extraordinary vertices two levels down.
    let mut t = crate::topology::fixtures::prism_with_triangles();
    for _ in 0..3 {
        let level = Level::new(&t).unwrap();
        t = level.fine();
        levels.push(("prism".to_string(), level));
    }
    let (mut derived, mut refused) = (0, 0);
    for (name, level) in &levels {
        let (fine, map) = level.next_mapped();
        for six in [false, true] {
            let st = Interp4::new(level, six);
            let Some(got) = Interp4::derive(level, &st, &fine, &map) else {
                assert!(!level.coarse.all_quads() || !st.unique, "{name}: not derived");
                refused += 1;
                continue;
            };
            let want = Interp4::new(&fine, six);
            assert!(got.edge == want.edge, "{name}: beyond vertices ({six})");
            assert!(got.via == want.via, "{name}: their edges ({six})");
            assert!(got.face == want.face, "{name}: beyond edges ({six})");
            assert!(got.edge2 == want.edge2, "{name}: far vertices ({six})");
            assert!(got.face2 == want.face2, "{name}: far edges ({six})");
            assert_eq!((got.six, got.unique), (six, want.unique), "{name}");
            derived += 1;
        }
    }
    assert!(derived >= 20 && refused >= 2, "derived {derived}, refused {refused}");
}

/// interp4, interp6 and the lifting wavelets on the three axes at once are each axis
/// alone, both ways: a level of triangles, a pentagon and quads, and an all-quad one;
/// an open level (boundary rules); values that sum in 64 bits and values that need 128.
#[test]
fn stencils_on_three_axes_are_each_axis() {
    let t = crate::topology::fixtures::prism_with_triangles();
    let first = Level::new(&t).unwrap();
    let second = first.next();
    let open = Level::new(&open_mixed()).unwrap().next();
    for (name, level) in [("prism", &first), ("refined prism", &second), ("open", &open)] {
        for w in [
            Wavelet::Interp4,
            Wavelet::Interp6,
            Wavelet::Lazy,
            Wavelet::Bilinear,
            Wavelet::Bicubic,
            Wavelet::Biquintic,
        ] {
            let st = Stencils::new(level, w);
            for (seed, bits) in [(3u64, 20u32), (4, 53), (5, 60)] {
                let x: [Vec<i64>; 3] = std::array::from_fn(|k| {
                    crate::topology::fixtures::pseudo(seed + k as u64, level.fine_nv(), bits)
                });
                for forward in [true, false] {
                    let mut one = x.clone();
                    for xk in one.iter_mut() {
                        match forward {
                            true => analyse_with(level, w, &st, xk, &[]),
                            false => synthesise_with(level, w, &st, xk, &[]),
                        }
                    }
                    let mut all = x.clone();
                    assert!(st.lift_axes(level, w, &mut all, forward));
                    assert_eq!(all, one, "{name}, {w:?}, {bits}-bit values, forward {forward}");
                }
            }
        }
        // Another wavelet's stencils do not serve.
        let st = Stencils::new(level, Wavelet::Interp4);
        assert!(!st.lift_axes(level, Wavelet::Interp6, &mut [vec![0; level.fine_nv()], vec![0; level.fine_nv()], vec![0; level.fine_nv()]], true));
        // Nor for dyadic-sym, which has no three-axis form.
        let st = Stencils::new(level, Wavelet::DyadicSym);
        assert!(!st.lift_axes(level, Wavelet::DyadicSym, &mut [vec![0; level.fine_nv()], vec![0; level.fine_nv()], vec![0; level.fine_nv()]], true));
    }
}

/// A phaser's phases and fractions of the three axes at once are each axis's
/// [`Phaser::predict_frac`], for lazy, interp4 and interp6: triangles, a pentagon and
/// quads, an all-quad grid; values that sum in 64 bits and values that need 128 (one
/// axis narrow beside wide ones).
#[test]
fn phases_on_three_axes_are_each_axis() {
    let t = crate::topology::fixtures::prism_with_triangles();
    let first = Level::new(&t).unwrap();
    let levels = [first.next(), first, Level::new(&grid(5)).unwrap()];
    for level in &levels {
        let n = level.ne() + level.nf();
        for w in [Wavelet::Lazy, Wavelet::Interp4, Wavelet::Interp6] {
            let st = Stencils::new(level, w);
            let p = Phaser::new(level, w, &st).unwrap();
            for (seed, bits) in [(3u64, [20u32, 20, 20]), (4, [53, 12, 60]), (5, [60, 60, 3])] {
                let x: [Vec<i64>; 3] = std::array::from_fn(|k| {
                    crate::topology::fixtures::pseudo(seed + k as u64, level.fine_nv(), bits[k])
                });
                for fracs in [true, false] {
                    let got = p.phases(&x, n, fracs);
                    for k in 0..3 {
                        let want: Vec<(u8, i16)> =
                            (0..n).map(|i| p.predict_frac(&x[k], i)).map(|(_, q, f)| (q, f)).collect();
                        let codes: Vec<u8> = want.iter().map(|w| w.0).collect();
                        assert_eq!(got.codes[k], codes, "{w:?}, axis {k}, {bits:?}");
                        let f: Vec<i16> = want.iter().map(|w| w.1).filter(|_| fracs).collect();
                        assert_eq!(got.fracs[k], f, "{w:?}, axis {k}, {bits:?}");
                    }
                }
            }
        }
    }
}
