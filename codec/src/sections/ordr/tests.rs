//! ORDR's tests: both methods round-trip, predictable orders are cheap, damage is an
//! error.

use super::walks::encode_walks;
use super::*;
use proptest::prelude::*;

/// An n x n grid of quads, row-major, and its faces.
fn grid(n: u32) -> (usize, Vec<u32>, Vec<u32>) {
    let t = crate::topology::fixtures::quad_grid(n);
    (t.nv, t.starts, t.idx)
}

fn shuffle(p: &mut [u32], seed: u64, swaps: usize) {
    let mut s = seed | 1;
    let n = p.len();
    for _ in 0..swaps {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        if n > 0 {
            p.swap((s % n as u64) as usize, ((s >> 20) % n as u64) as usize);
        }
    }
}

proptest! {
    /// Any vertex and face permutation and any rotations round-trip.
    #[test]
    fn orders_round_trip(n in 2u32..14, seed in proptest::num::u64::ANY, swaps in 0usize..300) {
        let (nv, starts, idx) = grid(n);
        let faces = Faces { nv, starts: &starts, idx: &idx, hierarchy: None };
        let mut vertices: Vec<u32> = (0..nv as u32).collect();
        shuffle(&mut vertices, seed, swaps);
        let nf = starts.len() - 1;
        let mut fo: Vec<u32> = (0..nf as u32).collect();
        shuffle(&mut fo, seed.rotate_left(17), swaps);
        let rotations = fo.iter().map(|&x| (x ^ seed as u32) % 4).collect();
        let o = InputOrder { vertices, faces: fo, rotations };
        let bytes = encode(&o, faces);
        prop_assert_eq!(&decode(&bytes, faces).unwrap(), &o);
        // Each method on its own.
        let mut walks = vec![1];
        walks.extend(encode_walks(&o, faces));
        prop_assert_eq!(&decode(&walks, faces).unwrap(), &o);
        let mut lists = vec![0];
        lists.extend(encode_lists(&o));
        prop_assert_eq!(&decode(&lists, faces).unwrap(), &o);
    }
}

/// The canonical order, a grid's rows walked from another corner (every row
/// reversed, the faces' first corners turned), and vertices in order of first use
/// cost a few bytes; a random order about log2(n!) bits.
#[test]
fn predictable_orders_are_nearly_free() {
    let n = 100u32;
    let (nv, starts, idx) = grid(n);
    let faces = Faces { nv, starts: &starts, idx: &idx, hierarchy: None };
    let nf = starts.len() - 1;
    let identity = InputOrder {
        vertices: (0..nv as u32).collect(),
        faces: (0..nf as u32).collect(),
        rotations: vec![0; nf],
    };
    // Rows reversed: vertex (x, y) is input vertex y * n + (n - 1 - x).
    let m = n - 1;
    let mirrored = InputOrder {
        vertices: (0..nv as u32).map(|v| v / n * n + (n - 1 - v % n)).collect(),
        faces: (0..nf as u32).map(|f| f / m * m + (m - 1 - f % m)).collect(),
        rotations: vec![1; nf],
    };
    // Vertices numbered by first use in the faces (PLY exporters with seams).
    let mut first_use = vec![u32::MAX; nv];
    let mut next = 0;
    for &v in &idx {
        if first_use[v as usize] == u32::MAX {
            first_use[v as usize] = next;
            next += 1;
        }
    }
    let by_use = InputOrder {
        vertices: first_use,
        ..identity.clone()
    };
    for (name, o) in [("identity", identity.clone()), ("mirrored", mirrored), ("first use", by_use)] {
        let bytes = encode(&o, faces);
        assert!(bytes.len() < 400, "{name}: {} bytes", bytes.len());
        assert_eq!(decode(&bytes, faces).unwrap(), o, "{name}");
    }
    let mut random = identity;
    shuffle(&mut random.vertices, 99, 100_000);
    let bytes = encode(&random, faces);
    let bound = (1..=nv).map(|i| (i as f64).log2()).sum::<f64>() / 8.0;
    assert!((bytes.len() as f64) < bound * 1.05 + 200.0, "{} vs {bound}", bytes.len());
    assert_eq!(decode(&bytes, faces).unwrap(), random);
}

/// Damaged payloads give errors or another order, never a panic.
#[test]
fn damaged_payloads_are_errors_not_panics() {
    let (nv, starts, idx) = grid(9);
    let faces = Faces { nv, starts: &starts, idx: &idx, hierarchy: None };
    let nf = starts.len() - 1;
    let mut vertices: Vec<u32> = (0..nv as u32).collect();
    shuffle(&mut vertices, 5, 40);
    let o = InputOrder {
        vertices,
        faces: (0..nf as u32).rev().collect(),
        rotations: (0..nf as u32).map(|x| x % 4).collect(),
    };
    let bytes = encode(&o, faces);
    for cut in 0..bytes.len() {
        let _ = decode(&bytes[..cut], faces);
    }
    for i in 0..bytes.len() * 8 {
        let mut b = bytes.clone();
        b[i / 8] ^= 1 << (i % 8);
        if let Ok(back) = decode(&b, faces) {
            let mut seen = vec![false; nv];
            for &v in &back.vertices {
                assert!(!std::mem::replace(&mut seen[v as usize], true));
            }
        }
    }
}

#[test]
fn element_places_follow_the_refinement() {
    use crate::topology::{Level, Topo};
    // One quad, three levels: every finest point's place in its element is where
    // midpoint refinement of the quad's corners puts it, row-major.
    let l = 3u32;
    let s = 1i64 << l;
    let mut base = Topo::new(4);
    base.idx = vec![0, 1, 2, 3];
    base.starts = vec![0, 4];
    let mut pos: Vec<[i64; 2]> = vec![[0, 0], [s, 0], [s, s], [0, s]];
    let mut level = Level::new(&base).unwrap();
    for k in 0..l {
        let mut next = pos.clone();
        for &[a, b] in &level.edges {
            let (p, q) = (pos[a as usize], pos[b as usize]);
            next.push([(p[0] + q[0]) / 2, (p[1] + q[1]) / 2]);
        }
        for f in 0..level.nf() {
            let c = level.coarse.face(f);
            let sum = c.iter().fold([0, 0], |a, &v| [a[0] + pos[v as usize][0], a[1] + pos[v as usize][1]]);
            next.push([sum[0] / c.len() as i64, sum[1] / c.len() as i64]);
        }
        pos = next;
        if k + 1 < l {
            level = level.next();
        }
    }
    let fine = level.fine();
    let faces = super::elements::tests::faces_of(&fine, None);
    let h = super::elements::tests::view(&base, l, crate::topology::Family::Cc, &[]);
    let el = super::elements::tests_places(h, faces).expect("elements");
    for (w, place) in el {
        let [x, y] = pos[w as usize];
        // A quad's places: its grid, row-major from corner 0.
        let want = (y - 1) * (s - 1) + (x - 1);
        assert_eq!(place as i64, want, "vertex {w} at ({x}, {y})");
    }
}

/// A permutation coded alone (7.1) and decoded.
fn perm_round_trip(p: &[u32]) -> usize {
    let mut e = Encoder::new();
    put_perm(&mut e, p);
    let bytes = e.finish();
    let mut d = Decoder::new(&bytes, SECTION).unwrap();
    assert_eq!(get_perm(&mut d, p.len()).unwrap(), p);
    bytes.len()
}

/// Orders of a grid's cells as exporters write them cost about a bit per row: rows of a
/// sub-grid (each row's end a stride), such sub-grids in turn (two strides alternating),
/// columns (one stride throughout); a shuffled one about log2(n!) bits.
#[test]
fn grid_orders_cost_a_bit_per_row() {
    let (s, h) = (64u32, 32u32);
    // The inner cells of an s x s grid row by row, then its border ring.
    let mut inner: Vec<u32> = (1..s - 1).flat_map(|y| (1..s - 1).map(move |x| y * s + x)).collect();
    let ring = (0..s - 1)
        .chain((0..s - 1).map(|y| y * s + s - 1))
        .chain((1..s).rev().map(|x| (s - 1) * s + x))
        .chain((1..s).rev().map(|y| y * s));
    inner.extend(ring);
    // Four quarters of h x h cells, each one's inner rows (x, y >= 1) in turn, then the rest.
    let mut quarters: Vec<u32> = (0..4)
        .flat_map(|q| (1..h).flat_map(move |y| (1..h).map(move |x| q * h * h + y * h + x)))
        .collect();
    let rest: Vec<u32> = (0..4 * h * h).filter(|c| !quarters.contains(c)).collect();
    quarters.extend(rest);
    let columns: Vec<u32> = (0..s).flat_map(|x| (0..s).map(move |y| y * s + x)).collect();
    for (name, p, rows) in [("inner, ring", &inner, s), ("quarters", &quarters, 4 * h), ("columns", &columns, s)] {
        let bytes = perm_round_trip(p);
        assert!(bytes * 8 <= 3 * rows as usize + 96, "{name}: {bytes} B for {rows} rows");
    }
    let mut shuffled = columns.clone();
    shuffle(&mut shuffled, 7, 20_000);
    let bits: f64 = (1..=shuffled.len()).map(|k| (k as f64).log2()).sum();
    let bytes = perm_round_trip(&shuffled);
    assert!((bytes as f64) < bits / 8.0 * 1.01 + 16.0, "shuffled: {bytes} B, log2(n!) = {bits:.0} bits");
}

/// A stride symbol where no stride is kept, or one that leaves `0..n`, is corrupt.
#[test]
fn a_permutation_stream_out_of_step_is_corrupt() {
    for seed in 0..200u64 {
        let bytes: Vec<u8> = (0..12).map(|i| (seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (i * 5)) as u8).collect();
        if let Ok(mut d) = Decoder::new(&bytes, SECTION) {
            if let Ok(p) = get_perm(&mut d, 50) {
                let mut seen = p.clone();
                seen.sort_unstable();
                assert_eq!(seen, (0..50).collect::<Vec<u32>>());
            }
        }
    }
}
