//! Per-axis value maps (SPEC.md 3.1, the `VMAP` section): when an axis's integer values
//! take only a sparse set of the integers between their least and greatest (heights
//! stored in whole metres on a finer grid, rows and columns of a terrain grid), the
//! container codes each value's rank in the sorted set of distinct values instead, and
//! the set itself, once. Ranks keep the order of the values, so a smooth surface stays
//! smooth, while the spacing the set left empty costs nothing.

use crate::entropy::{Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::mesh::MAX_COORD;

const SECTION: &str = "VMAP";

/// An axis is a candidate when its values span at least this many times as many
/// integers as it has distinct values (one bit of saving per vertex at most otherwise).
const SPARSE: u64 = 2;

/// ... and when at most one in this many of the steps between its consecutive distinct
/// values is 1. Values on a lattice (a grid's rows, heights in whole metres on a finer
/// step) leave no such steps; a scan's coordinates at `--bits 16` are sparse too but
/// random, with a step of 1 at every eighth value or more often, and their ranks never
/// made a smaller file: without this test `auto` coded most meshes twice at 16 bits.
const LATTICE: usize = 32;

/// The sorted distinct values of the mapped axes; `None` axes are coded as they are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValueMap {
    /// Per axis (x, y, z), the distinct values in increasing order.
    pub axes: [Option<Vec<i64>>; 3],
}

fn distinct(positions: &[[i64; 3]], k: usize) -> Vec<i64> {
    let (Some(lo), Some(hi)) = (
        positions.iter().map(|p| p[k]).min(),
        positions.iter().map(|p| p[k]).max(),
    ) else {
        return Vec::new();
    };
    // A range of at most 64 values per position (and any up to 2^22) is marked in a
    // bit set, one bit per value (at most 8 bytes per position); a wider one sorted.
    let span = hi.abs_diff(lo);
    if span >= (positions.len() as u64 * 64).max(1 << 22) {
        let mut v: Vec<i64> = positions.iter().map(|p| p[k]).collect();
        v.sort_unstable();
        v.dedup();
        return v;
    }
    let mut seen = vec![0u64; (span / 64 + 1) as usize];
    for p in positions {
        let o = p[k].abs_diff(lo);
        seen[(o / 64) as usize] |= 1 << (o % 64);
    }
    let mut v = Vec::new();
    for (w, &bits) in seen.iter().enumerate() {
        let mut b = bits;
        while b != 0 {
            let o = w as u64 * 64 + u64::from(b.trailing_zeros());
            v.push(lo.wrapping_add_unsigned(o));
            b &= b - 1;
        }
    }
    v
}

/// `round(k span / steps)`, halves up: lattice point k's offset from the first value.
fn lattice_offset(k: i128, span: i128, steps: i128) -> i128 {
    (2 * k * span + steps).div_euclid(2 * steps)
}

/// The lattice points of the sorted distinct values `v` on a lattice of `steps` steps
/// from `v[0]` to the last value: each value's nearest point, kept increasing, the last
/// value on the last point; `None` when they do not fit.
fn lattice_points(v: &[i64], steps: i64) -> Option<Vec<i64>> {
    let n = v.len() - 1;
    let span = (v[n] - v[0]) as i128;
    if n == 0 || (steps as usize) < n || steps as i128 > span {
        return None;
    }
    let mut k = Vec::with_capacity(v.len());
    k.push(0i64);
    for (i, &x) in v.iter().enumerate().skip(1).take(n - 1) {
        let nearest = ((2 * (x - v[0]) as i128 * steps as i128 + span) / (2 * span)) as i64;
        // Leave room for the values still to come.
        let hi = steps - (n - i) as i64;
        k.push(nearest.max(k[i - 1] + 1).min(hi));
    }
    k.push(steps);
    k.windows(2).all(|w| w[0] < w[1]).then_some(k)
}

/// Codes one axis's sorted distinct values `v` (SPEC.md 3.1): its count less one, its
/// first value, then a flag and either the gaps' changes or, given the
/// values' points `lattice` ([`lattice_points`]), the lattice's steps' excess over the
/// count, the span's excess over the steps, then per value its skipped lattice points
/// (when there are any) and its residual.
fn put_axis(e: &mut Encoder, v: &[i64], lattice: Option<&[i64]>) {
    let (mut count, mut first, mut extra, mut spread, mut skips, mut gaps) = (
        IntModel::new(),
        IntModel::new(),
        IntModel::new(),
        IntModel::new(),
        IntModel::new(),
        IntModel::new(),
    );
    let n = v.len() - 1;
    e.int(&mut count, n as i64);
    e.int(&mut first, v[0]);
    if n > 0 {
        e.uniform(lattice.is_some() as u64, 2);
    }
    if let Some(k) = lattice {
        let (steps, span) = (k[n], v[n] - v[0]);
        e.int(&mut extra, steps - n as i64);
        e.int(&mut spread, span - steps);
        for i in 1..n {
            if steps > n as i64 {
                e.int(&mut skips, k[i] - k[i - 1] - 1);
            }
            let p = v[0] as i128 + lattice_offset(k[i] as i128, span as i128, steps as i128);
            e.int(&mut gaps, (v[i] as i128 - p) as i64);
        }
        return;
    }
    let mut prev_gap = 0;
    for w in v.windows(2) {
        let gap = w[1] - w[0] - 1;
        e.int(&mut gaps, gap - prev_gap);
        prev_gap = gap;
    }
}

/// Lattices worth trying for the sorted distinct values `v`: one step per value, and
/// steps near the span over the mean of the gaps of at most 1.5 times the least (the
/// gaps of one step, on a lattice with points left out).
fn lattice_candidates(v: &[i64]) -> Vec<i64> {
    let n = v.len() as i64 - 1;
    if n < 1 {
        return Vec::new();
    }
    let least = v.windows(2).map(|w| w[1] - w[0]).min().unwrap_or(1);
    let (sum, count) = v
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&g| 2 * g as i128 <= 3 * least as i128)
        .fold((0i128, 0i128), |(s, c), g| (s + g as i128, c + 1));
    let span = (v[n as usize] - v[0]) as i128;
    let guess = ((2 * span * count + sum) / (2 * sum)) as i64;
    let mut c: Vec<i64> = [n, guess - 1, guess, guess + 1]
        .into_iter()
        .filter(|&s| s >= n && s as i128 <= span && s <= 64 * (n + 1))
        .collect();
    c.sort_unstable();
    c.dedup();
    c
}

impl ValueMap {
    /// The map `auto` tries: every axis whose distinct values are sparse in their span
    /// and lie apart, as on a lattice (`SPARSE`, `LATTICE`); `None` when no axis is.
    pub fn candidate(positions: &[[i64; 3]]) -> Option<ValueMap> {
        let axes = std::array::from_fn(|k| {
            let v = distinct(positions, k);
            let (&lo, &hi) = (v.first()?, v.last()?);
            let span = (hi - lo) as u64 + 1;
            let unit = v.windows(2).filter(|w| w[1] - w[0] == 1).count();
            (span / v.len() as u64 >= SPARSE && unit * LATTICE < v.len()).then_some(v)
        });
        let m = ValueMap { axes };
        m.axes.iter().any(Option::is_some).then_some(m)
    }

    /// The map of every axis (an explicit request).
    pub fn every_axis(positions: &[[i64; 3]]) -> Option<ValueMap> {
        (!positions.is_empty()).then(|| ValueMap {
            axes: std::array::from_fn(|k| Some(distinct(positions, k))),
        })
    }

    /// The positions as ranks on the mapped axes. Every value must be in the map.
    pub fn ranks(&self, positions: &[[i64; 3]]) -> Vec<[i64; 3]> {
        positions
            .iter()
            .map(|p| {
                std::array::from_fn(|k| match &self.axes[k] {
                    Some(v) => v.binary_search(&p[k]).map_or(p[k], |r| r as i64),
                    None => p[k],
                })
            })
            .collect()
    }

    /// Ranks back to values, in place. With `exact` (the finest level) a rank outside
    /// the map is a corrupt container; otherwise (a coarser level's approximation) it
    /// is clamped into the map.
    pub fn values(&self, positions: &mut [[i64; 3]], exact: bool) -> Result<()> {
        for (k, axis) in self.axes.iter().enumerate() {
            let Some(v) = axis else { continue };
            let last = v.len() as i64 - 1;
            for p in positions.iter_mut() {
                let r = p[k];
                if exact && !(0..=last).contains(&r) {
                    return Err(Error::corrupt(
                        SECTION,
                        "a coordinate's rank lies outside the value map",
                    ));
                }
                p[k] = v[r.clamp(0, last) as usize];
            }
        }
        Ok(())
    }

    /// The VMAP payload (SPEC.md 3.1).
    pub fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::new();
        let mask = (0..3)
            .filter(|&k| self.axes[k].is_some())
            .map(|k| 1 << k)
            .sum::<u64>();
        e.uniform(mask, 8);
        for v in self.axes.iter().flatten() {
            // Each axis in the smallest of its codings (the gaps on ties).
            let size = |lattice: Option<&[i64]>| {
                let mut t = Encoder::new();
                put_axis(&mut t, v, lattice);
                t.finish().len()
            };
            let mut best = (size(None), None);
            for k in lattice_candidates(v)
                .into_iter()
                .filter_map(|s| lattice_points(v, s))
            {
                let z = size(Some(&k));
                if z < best.0 {
                    best = (z, Some(k));
                }
            }
            put_axis(&mut e, v, best.1.as_deref());
        }
        e.finish()
    }

    /// Reads a VMAP payload of a mesh of `vertices` vertices, refusing (before
    /// allocating) more values than the mesh has or than the payload can hold
    /// (SPEC.md 2.6).
    pub fn decode(payload: &[u8], vertices: u64) -> Result<ValueMap> {
        let mut d = Decoder::new(payload, SECTION)?;
        let mask = d.uniform(8)?;
        if mask == 0 {
            return Err(Error::corrupt(SECTION, "a value map of no axis"));
        }
        let room = payload.len() as u64 + 8;
        let mut axes: [Option<Vec<i64>>; 3] = [None, None, None];
        for (k, axis) in axes.iter_mut().enumerate() {
            if mask & (1 << k) == 0 {
                continue;
            }
            let [mut count, mut first, mut extra, mut spread, mut skips, mut gaps] =
                std::array::from_fn(|_| IntModel::new());
            let n = d.int(&mut count)?;
            if n < 0 || n as u64 >= vertices || n as u64 > 2048 * room {
                return Err(Error::corrupt(
                    SECTION,
                    "more values than the mesh has vertices or the section can hold",
                ));
            }
            let mut v: Vec<i64> = Vec::with_capacity(n as usize + 1);
            // Appends a value: within the coordinate range and above the one before.
            let push = |v: &mut Vec<i64>, x: i128| {
                if x.abs() > MAX_COORD as i128 {
                    return Err(Error::corrupt(SECTION, "a value out of range"));
                }
                if v.last().is_some_and(|&p| p as i128 >= x) {
                    return Err(Error::corrupt(SECTION, "values out of order"));
                }
                v.push(x as i64);
                Ok(())
            };
            let first = d.int(&mut first)? as i128;
            let lattice = n > 0 && d.uniform(2)? == 1;
            if lattice {
                // Lattice point k_i, then the value rounded from it plus a residual.
                let steps = n as i128 + d.int(&mut extra)? as i128;
                let span = steps + d.int(&mut spread)? as i128;
                if steps < n as i128 || span < steps || first + span > MAX_COORD as i128 {
                    return Err(Error::corrupt(SECTION, "a lattice out of order or range"));
                }
                push(&mut v, first)?;
                let mut k: i128 = 0;
                for _ in 1..n {
                    k += 1;
                    if steps > n as i128 {
                        let skip = d.int(&mut skips)?;
                        if skip < 0 {
                            return Err(Error::corrupt(SECTION, "lattice points out of order"));
                        }
                        k += skip as i128;
                    }
                    if k >= steps {
                        return Err(Error::corrupt(SECTION, "a lattice point past the last"));
                    }
                    let x = first + lattice_offset(k, span, steps) + d.int(&mut gaps)? as i128;
                    push(&mut v, x)?;
                }
                push(&mut v, first + span)?;
            } else {
                let mut x = first;
                let mut gap: i128 = 0;
                for i in 0..=n {
                    if i > 0 {
                        gap += d.int(&mut gaps)? as i128;
                        if gap < 0 {
                            return Err(Error::corrupt(SECTION, "values out of order"));
                        }
                        x += gap + 1;
                    }
                    push(&mut v, x)?;
                }
            }
            *axis = Some(v);
        }
        Ok(ValueMap { axes })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::fixtures::pseudo;

    /// The distinct values of an axis, by bit set or by sorting (narrow and wide
    /// ranges, negative values, extremes), are its values sorted without repeats.
    #[test]
    fn distinct_values_are_sorted_without_repeats() {
        for (n, width) in [(1, 1), (50, 8), (1000, 12), (1000, 20), (200, 40), (100, 44)] {
            let axes: Vec<Vec<i64>> = (0..3).map(|k| pseudo(k + 1, n, width)).collect();
            let pos: Vec<[i64; 3]> = (0..n).map(|i| std::array::from_fn(|k| axes[k][i])).collect();
            for k in 0..3 {
                let mut want: Vec<i64> = pos.iter().map(|p| p[k]).collect();
                want.sort_unstable();
                want.dedup();
                assert_eq!(distinct(&pos, k), want, "{n} values of {width} bits");
            }
        }
        let ends = [[i64::MIN, -1, 0], [i64::MAX, 1, 0], [0, -1, 0]];
        assert_eq!(distinct(&ends, 0), vec![i64::MIN, 0, i64::MAX]);
        assert_eq!(distinct(&ends, 1), vec![-1, 1]);
        assert_eq!(distinct(&ends, 2), vec![0]);
        assert!(distinct(&[], 0).is_empty());
    }

    #[test]
    fn a_sparse_axis_is_mapped_and_comes_back_exactly() {
        // x dense, y a lattice of step 7 with a hole, z a single value.
        let pos: Vec<[i64; 3]> = (0..50)
            .map(|i| [i, 7 * (i % 10) - 3 + if i % 10 > 5 { 7 } else { 0 }, -40])
            .collect();
        let m = ValueMap::candidate(&pos).unwrap();
        assert!(m.axes[0].is_none());
        assert_eq!(m.axes[1].as_ref().unwrap().len(), 10);
        assert_eq!(m.axes[2].as_deref(), None, "a single value spans 1");
        let mut r = m.ranks(&pos);
        assert!(r.iter().all(|p| (0..10).contains(&p[1])));
        let back = ValueMap::decode(&m.encode(), 50).unwrap();
        assert_eq!(back, m);
        back.values(&mut r, true).unwrap();
        assert_eq!(r, pos);
        // A rank past the end: corrupt at the finest level, clamped at a coarser one.
        let mut bad = vec![[0, 10, 0]];
        assert!(back.values(&mut bad.clone(), true).is_err());
        back.values(&mut bad, false).unwrap();
        assert_eq!(bad[0][1], *m.axes[1].as_ref().unwrap().last().unwrap());
    }

    #[test]
    fn sparse_axes_with_unit_steps_are_no_candidate() {
        // x: steps 1, 3, 3, 3 over and over (2.5 integers a value, but a unit step in
        // four); y: a lattice of step 3 and the value 1 (one unit step in 63); z: a
        // lattice of step 3 and 1, 4, 7, 10 (four in 63).
        let x: Vec<i64> = (0..64)
            .map(|i| 10 * (i / 4) + [0, 1, 4, 7][i as usize % 4])
            .collect();
        let y: Vec<i64> = (0..63).map(|i| 3 * i).chain([1]).collect();
        let z: Vec<i64> = (0..60).map(|i| 3 * i).chain([1, 4, 7, 10]).collect();
        let unit_steps = |v: &[i64]| {
            let mut v = v.to_vec();
            v.sort_unstable();
            v.windows(2).filter(|w| w[1] - w[0] == 1).count()
        };
        assert_eq!([unit_steps(&x), unit_steps(&y), unit_steps(&z)], [16, 1, 4]);
        let pos: Vec<[i64; 3]> = (0..64).map(|i| [x[i], y[i], z[i]]).collect();
        let m = ValueMap::candidate(&pos).unwrap();
        assert_eq!(m.axes[0], None);
        assert_eq!(m.axes[1].as_ref().map(Vec::len), Some(64));
        assert_eq!(m.axes[2], None);
    }

    /// The payload of a map of axis x alone, `v`, coded as gaps or on `lattice`.
    fn one_axis(v: &[i64], lattice: Option<&[i64]>) -> Vec<u8> {
        let mut e = Encoder::new();
        e.uniform(1, 8);
        put_axis(&mut e, v, lattice);
        e.finish()
    }

    #[test]
    fn lattice_axes_cost_less_and_come_back_exactly() {
        // A grid's columns on Draco's grid: 65 values, 3311 apart in all (steps of 51
        // and 52), one off the lattice by 1.
        let mut cols: Vec<i64> = (0..65).map(|i| (2 * i * 3311 + 64) / 128 - 7).collect();
        cols[30] += 1;
        // Heights in whole metres at 16 bits: 191.6 apart, a few metres missing.
        let heights: Vec<i64> = (0..343)
            .filter(|h| ![17, 18, 90, 200, 341].contains(h))
            .map(|h| 40 + (2 * h * 65_535 + 342) / 684)
            .collect();
        // The payload of x coded as `lattice` (or gaps), then y and z, one value each.
        let expected = |v: &[i64], lattice: Option<&[i64]>| {
            let mut e = Encoder::new();
            e.uniform(7, 8);
            put_axis(&mut e, v, lattice);
            for _ in 0..2 {
                put_axis(&mut e, &[0], None);
            }
            e.finish()
        };
        for (v, steps) in [(&cols, 64), (&heights, 342)] {
            let n = v.len();
            let pos: Vec<[i64; 3]> = (0..n).map(|i| [v[i], 0, 0]).collect();
            let m = ValueMap::every_axis(&pos).unwrap();
            let bytes = m.encode();
            assert_eq!(ValueMap::decode(&bytes, n as u64).unwrap(), m);
            // The lattice of one step per value, or per metre, is found and chosen, and
            // costs at most half as much as the gaps.
            let k = lattice_points(v, steps).unwrap();
            assert_eq!(bytes, expected(v, Some(&k)));
            let (lattice, gaps) = (one_axis(v, Some(&k)).len(), one_axis(v, None).len());
            assert!(2 * lattice <= gaps, "{lattice} {gaps}");
        }
        // Scattered values stay coded as gaps.
        let scattered: Vec<i64> = (0..100i64).map(|i| i * i + 3 * i).collect();
        let pos: Vec<[i64; 3]> = scattered.iter().map(|&x| [x, 0, 0]).collect();
        let m = ValueMap::every_axis(&pos).unwrap();
        assert_eq!(m.encode(), expected(&scattered, None));
    }

    #[test]
    fn hostile_lattices_are_refused() {
        // count n = 3, first 10, lattice flag, then (extra, spread) and per value
        // (skip if extra > 0, residual), as `put_axis` writes them.
        let payload = |extra: i64, spread: i64, rest: &[i64]| {
            let mut e = Encoder::new();
            e.uniform(1, 8);
            let [mut c, mut f, mut x, mut s, mut k, mut g] =
                std::array::from_fn(|_| IntModel::new());
            e.int(&mut c, 3);
            e.int(&mut f, 10);
            e.uniform(1, 2);
            e.int(&mut x, extra);
            e.int(&mut s, spread);
            for (i, &r) in rest.iter().enumerate() {
                if extra > 0 && i % 2 == 0 {
                    e.int(&mut k, r);
                } else {
                    e.int(&mut g, r);
                }
            }
            e.finish()
        };
        let ok = |bytes: Vec<u8>| ValueMap::decode(&bytes, 10);
        // Steps 3, span 30: values 10, 20, 30, 40; and with a residual.
        let v = |m: ValueMap| m.axes[0].clone().unwrap();
        assert_eq!(v(ok(payload(0, 27, &[0, 0])).unwrap()), [10, 20, 30, 40]);
        assert_eq!(v(ok(payload(0, 27, &[-3, 4])).unwrap()), [10, 17, 34, 40]);
        // Steps 5 (two skipped), span 50: points 0, 2, 3, 5.
        assert_eq!(
            v(ok(payload(2, 45, &[1, 0, 0, 0])).unwrap()),
            [10, 30, 40, 60]
        );
        // Fewer steps than values; span below the steps; past the coordinate range.
        assert!(ok(payload(-1, 27, &[0, 0])).is_err());
        assert!(ok(payload(0, -1, &[0, 0])).is_err());
        assert!(ok(payload(0, MAX_COORD - 12, &[0, 0])).is_err());
        // A negative skip; a point past the last; values out of order.
        assert!(ok(payload(2, 45, &[-1, 0, 0, 0])).is_err());
        assert!(ok(payload(2, 45, &[1, 0, 2, 0])).is_err());
        assert!(ok(payload(0, 27, &[10, 0])).is_err());
        assert!(ok(payload(0, 27, &[0, 10])).is_err());
    }

    #[test]
    fn dense_axes_are_no_candidate() {
        let pos: Vec<[i64; 3]> = (0..100).map(|i| [i, i / 2, 99 - i]).collect();
        assert_eq!(ValueMap::candidate(&pos), None);
        let every = ValueMap::every_axis(&pos).unwrap();
        assert!(every.axes.iter().all(Option::is_some));
        assert_eq!(ValueMap::decode(&every.encode(), 100).unwrap(), every);
    }

    #[test]
    fn hostile_maps_are_refused() {
        let m = ValueMap {
            axes: [Some(vec![-5, 0, 9, MAX_COORD]), None, None],
        };
        let bytes = m.encode();
        assert_eq!(ValueMap::decode(&bytes, 4).unwrap(), m);
        // More values than vertices.
        assert!(ValueMap::decode(&bytes, 3).is_err());
        // Values past the range, and out of order.
        for v in [vec![0, MAX_COORD + 1], vec![5, 3]] {
            let mut e = Encoder::new();
            e.uniform(1, 8);
            let (mut c, mut f, mut g) = (IntModel::new(), IntModel::new(), IntModel::new());
            e.int(&mut c, 1);
            e.int(&mut f, v[0]);
            e.uniform(0, 2);
            e.int(&mut g, v[1] - v[0] - 1);
            assert!(ValueMap::decode(&e.finish(), 10).is_err(), "{v:?}");
        }
        // No axis; garbage; empty.
        let mut e = Encoder::new();
        e.uniform(0, 8);
        assert!(ValueMap::decode(&e.finish(), 10).is_err());
        assert!(ValueMap::decode(&[0xff; 7], 10).is_err());
        let _ = ValueMap::decode(&[], 10);
    }
}
