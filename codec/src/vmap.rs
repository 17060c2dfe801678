//! Per-axis value maps (SPEC.md 3.1, the `VMAP` section): when an axis's integer values
//! take only a sparse set of the integers between their least and greatest (heights
//! stored in whole metres on a finer grid, rows and columns of a terrain grid), the
//! container codes each value's rank in the sorted set of distinct values instead, and
//! the set itself, once. Ranks keep the order of the values, so a smooth surface stays
//! smooth, while the spacing the set left empty costs nothing.

use crate::coder::{Decoder, Encoder, IntModel};
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
    let mut v: Vec<i64> = positions.iter().map(|p| p[k]).collect();
    v.sort_unstable();
    v.dedup();
    v
}

impl ValueMap {
    /// The map `auto` tries: every axis whose distinct values are sparse in their span
    /// and lie apart, as on a lattice ([`SPARSE`], [`LATTICE`]); `None` when no axis is.
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
            let (mut count, mut first, mut gaps) =
                (IntModel::new(), IntModel::new(), IntModel::new());
            e.int(&mut count, v.len() as i64 - 1);
            e.int(&mut first, v[0]);
            let mut prev_gap = 0;
            for w in v.windows(2) {
                let gap = w[1] - w[0] - 1;
                e.int(&mut gaps, gap - prev_gap);
                prev_gap = gap;
            }
        }
        e.finish()
    }

    /// Reads a VMAP payload of a mesh of `vertices` vertices, refusing (before
    /// allocating) more values than the mesh has or than the payload can hold
    /// (SPEC.md 2.6).
    pub fn decode(payload: &[u8], vertices: u64, version: u16) -> Result<ValueMap> {
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
            let (mut count, mut first, mut gaps) = (
                IntModel::for_version(version),
                IntModel::for_version(version),
                IntModel::for_version(version),
            );
            let n = d.int(&mut count)?;
            if n < 0 || n as u64 >= vertices || n as u64 > 2048 * room {
                return Err(Error::corrupt(
                    SECTION,
                    "more values than the mesh has vertices or the section can hold",
                ));
            }
            let mut v = Vec::with_capacity(n as usize + 1);
            let mut x = d.int(&mut first)? as i128;
            let mut gap: i128 = 0;
            for i in 0..=n {
                if i > 0 {
                    gap += d.int(&mut gaps)? as i128;
                    if gap < 0 {
                        return Err(Error::corrupt(SECTION, "values out of order"));
                    }
                    x += gap + 1;
                }
                if x.abs() > MAX_COORD as i128 {
                    return Err(Error::corrupt(SECTION, "a value out of range"));
                }
                v.push(x as i64);
            }
            *axis = Some(v);
        }
        Ok(ValueMap { axes })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use subwave_container::FORMAT_VERSION;

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
        let back = ValueMap::decode(&m.encode(), 50, FORMAT_VERSION).unwrap();
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

    #[test]
    fn dense_axes_are_no_candidate() {
        let pos: Vec<[i64; 3]> = (0..100).map(|i| [i, i / 2, 99 - i]).collect();
        assert_eq!(ValueMap::candidate(&pos), None);
        let every = ValueMap::every_axis(&pos).unwrap();
        assert!(every.axes.iter().all(Option::is_some));
        assert_eq!(
            ValueMap::decode(&every.encode(), 100, FORMAT_VERSION).unwrap(),
            every
        );
    }

    #[test]
    fn hostile_maps_are_refused() {
        let m = ValueMap {
            axes: [Some(vec![-5, 0, 9, MAX_COORD]), None, None],
        };
        let bytes = m.encode();
        assert_eq!(ValueMap::decode(&bytes, 4, FORMAT_VERSION).unwrap(), m);
        // More values than vertices.
        assert!(ValueMap::decode(&bytes, 3, FORMAT_VERSION).is_err());
        // Values past the range, and out of order.
        for v in [vec![0, MAX_COORD + 1], vec![5, 3]] {
            let mut e = Encoder::new();
            e.uniform(1, 8);
            let (mut c, mut f, mut g) = (IntModel::new(), IntModel::new(), IntModel::new());
            e.int(&mut c, 1);
            e.int(&mut f, v[0]);
            e.int(&mut g, v[1] - v[0] - 1);
            assert!(
                ValueMap::decode(&e.finish(), 10, FORMAT_VERSION).is_err(),
                "{v:?}"
            );
        }
        // No axis; garbage; empty.
        let mut e = Encoder::new();
        e.uniform(0, 8);
        assert!(ValueMap::decode(&e.finish(), 10, FORMAT_VERSION).is_err());
        assert!(ValueMap::decode(&[0xff; 7], 10, FORMAT_VERSION).is_err());
        let _ = ValueMap::decode(&[], 10, FORMAT_VERSION);
    }
}
