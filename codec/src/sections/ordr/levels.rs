//! Method 4 of ORDR (SPEC.md 7.5): the order a refinement produces, level by level.
//! A tool that refines a mesh L times and writes each level's vertices as blocks (its
//! old vertices, its edges' points, its faces' points, in some order of the three),
//! numbers each level's new points from the level it refines: the edges' points by
//! their ends' numbers (lowest end first, then the other), the faces' points by the
//! faces' order, and each face's children in its corner order. So the whole order
//! follows from the base mesh's: its vertices' order, its faces' order and each face's
//! first corner.

use super::{get_perm, put_perm, Faces, Hierarchy, InputOrder, SECTION};
use crate::entropy::{Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::topology::{Level, Topo};

/// The orders of a level's three blocks (0: its old vertices, 1: its edges' points, 2:
/// its faces' points), by number.
const ARRANGEMENTS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

/// Levels beyond which method 4 is not used.
const MAX_LEVELS: u32 = 15;

/// The coarse levels of `h` (the base mesh's, then each refinement's but the last),
/// canonical numbering; `None` when `h` has no level or too many, or its base is no
/// mesh.
fn levels(h: Hierarchy<'_>) -> Option<Vec<Level>> {
    if !(1..=MAX_LEVELS).contains(&h.levels) {
        return None;
    }
    let topo = Topo {
        nv: h.nv,
        starts: h.starts.to_vec(),
        idx: h.idx.to_vec(),
    };
    let mut out = vec![Level::new(&topo).ok()?];
    for _ in 1..h.levels {
        let next = out.last()?.next();
        out.push(next);
    }
    Some(out)
}

/// What the stream gives (SPEC.md 7.5): the blocks' arrangement, the base vertices in
/// order, the base faces in order, and per base face (by number) its first corner.
struct Base {
    arrangement: usize,
    vertices: Vec<u32>,
    faces: Vec<u32>,
    first: Vec<u32>,
}

/// The order the refinement of `levels` produces from `base`, as an [`InputOrder`] of
/// the finest level (`nv` vertices, `nf` faces); `None` when the finest level does not
/// have these counts.
fn produce(levels: &[Level], base: &Base, nv: usize, nf: usize) -> Option<InputOrder> {
    let blocks = ARRANGEMENTS[base.arrangement];
    // Per vertex of the current level, its number; the faces in order with their
    // first corners.
    let mut number = vec![0u32; levels[0].nv];
    for (i, &v) in base.vertices.iter().enumerate() {
        number[v as usize] = i as u32;
    }
    let mut faces: Vec<(u32, u32)> = base
        .faces
        .iter()
        .map(|&f| (f, base.first[f as usize]))
        .collect();
    for level in levels {
        let (lnv, ne, lnf) = (level.nv, level.ne(), level.nf());
        // The edges by their ends' numbers, lowest end first.
        let mut by_ends: Vec<(u32, u32, u32)> = level
            .edges
            .iter()
            .enumerate()
            .map(|(e, &[a, b])| {
                let (x, y) = (number[a as usize], number[b as usize]);
                (x.min(y), x.max(y), e as u32)
            })
            .collect();
        by_ends.sort_unstable();
        let sizes = [lnv, ne, lnf];
        let mut offset = [0usize; 3];
        let mut at = 0;
        for &b in &blocks {
            offset[b] = at;
            at += sizes[b];
        }
        let mut next = vec![0u32; lnv + ne + lnf];
        for (v, &n) in number.iter().enumerate() {
            next[v] = (offset[0] + n as usize) as u32;
        }
        for (rank, &(_, _, e)) in by_ends.iter().enumerate() {
            next[lnv + e as usize] = (offset[1] + rank) as u32;
        }
        let mut children = Vec::with_capacity(level.coarse.idx.len());
        for (rank, &(f, r)) in faces.iter().enumerate() {
            next[lnv + ne + f as usize] = (offset[2] + rank) as u32;
            // Each face's children from its first corner on, each from its corner.
            let (start, k) = (
                level.coarse.starts[f as usize],
                level.coarse.face(f as usize).len() as u32,
            );
            children.extend((0..k).map(|i| (start + (r + i) % k, 0)));
        }
        number = next;
        faces = children;
    }
    if number.len() != nv || faces.len() != nf {
        return None;
    }
    let mut forder = vec![0u32; nf];
    let mut rotations = vec![0u32; nf];
    for (pos, &(g, r)) in faces.iter().enumerate() {
        forder[g as usize] = pos as u32;
        rotations[g as usize] = r;
    }
    Some(InputOrder {
        vertices: number,
        faces: forder,
        rotations,
    })
}

/// Codes `o` by method 4 if it is the order the refinement of the hierarchy produces;
/// `None` when it is not (or the faces are not the hierarchy's finest level).
pub(super) fn encode_levels(o: &InputOrder, faces: Faces<'_>, h: Hierarchy<'_>) -> Option<Vec<u8>> {
    let levels = levels(h)?;
    let (nb, nbf) = (h.nv, h.starts.len() - 1);
    let nf = faces.count();
    // Finest faces per base corner.
    let per_corner = nf.checked_div(h.idx.len())?;
    if per_corner == 0 || per_corner * h.idx.len() != nf || o.vertices.len() != faces.nv {
        return None;
    }
    let last = levels.last()?;
    // The arrangement: the finest level's blocks by their first input numbers.
    let (lnv, ne) = (last.nv, last.ne());
    let first_of = |r: std::ops::Range<usize>| o.vertices.get(r).and_then(|v| v.iter().min().copied());
    let mut firsts = [
        (first_of(0..lnv)?, 0),
        (first_of(lnv..lnv + ne)?, 1),
        (first_of(lnv + ne..faces.nv)?, 2),
    ];
    firsts.sort_unstable();
    let arrangement = ARRANGEMENTS
        .iter()
        .position(|a| *a == firsts.map(|(_, b)| b))?;
    // The base vertices by input number; the base faces by their finest faces' first
    // input number, each from the corner of that face.
    let mut vertices: Vec<u32> = (0..nb as u32).collect();
    vertices.sort_unstable_by_key(|&v| o.vertices[v as usize]);
    let mut face_first = vec![(u32::MAX, 0u32); nbf];
    for (g, &pos) in o.faces.iter().enumerate() {
        let corner = (g / per_corner) as u32;
        let f = h.starts.partition_point(|&s| s <= corner) - 1;
        if pos < face_first[f].0 {
            face_first[f] = (pos, corner - h.starts[f]);
        }
    }
    let mut base_faces: Vec<u32> = (0..nbf as u32).collect();
    base_faces.sort_unstable_by_key(|&f| face_first[f as usize].0);
    let base = Base {
        arrangement,
        vertices,
        faces: base_faces,
        first: face_first.iter().map(|&(_, c)| c).collect(),
    };
    if produce(&levels, &base, faces.nv, nf)? != *o {
        return None;
    }
    let mut e = Encoder::new();
    e.uniform(arrangement as u64, ARRANGEMENTS.len() as u64);
    put_perm(&mut e, &base.vertices);
    put_perm(&mut e, &base.faces);
    let mut m = IntModel::new();
    for &f in &base.faces {
        e.int(&mut m, base.first[f as usize] as i64);
    }
    Some(e.finish())
}

/// Decodes method 4 (SPEC.md 7.5).
pub(super) fn decode_levels(payload: &[u8], faces: Faces<'_>, h: Option<Hierarchy<'_>>) -> Result<InputOrder> {
    let corrupt = |what: &str| Error::corrupt(SECTION, what.to_string());
    let h = h.ok_or_else(|| corrupt("method 4 without a Catmull-Clark hierarchy"))?;
    let levels = levels(h).ok_or_else(|| corrupt("method 4 on a hierarchy it does not take"))?;
    let mut d = Decoder::new(payload, SECTION)?;
    let arrangement = d.uniform(ARRANGEMENTS.len() as u64)? as usize;
    let vertices = get_perm(&mut d, h.nv)?;
    let nbf = h.starts.len() - 1;
    let base_faces = get_perm(&mut d, nbf)?;
    let mut first = vec![0u32; nbf];
    let mut m = IntModel::new();
    for &f in &base_faces {
        let k = h.starts[f as usize + 1] - h.starts[f as usize];
        let r = d.int(&mut m)?;
        if !(0..k as i64).contains(&r) {
            return Err(corrupt("a base face's first corner out of range"));
        }
        first[f as usize] = r as u32;
    }
    let base = Base {
        arrangement,
        vertices,
        faces: base_faces,
        first,
    };
    produce(&levels, &base, faces.nv, faces.count())
        .ok_or_else(|| corrupt("method 4 on faces that are not the hierarchy's"))
}

#[cfg(test)]
mod tests {
    use super::super::{decode, encode};
    use super::*;

    /// A quad, a triangle and a pentagon side by side, refined `levels` times: the base
    /// and the finest faces.
    fn hierarchy(levels: u32) -> (Topo, Topo) {
        let mut base = Topo::new(8);
        base.idx = vec![0, 1, 2, 3, 1, 4, 2, 4, 5, 6, 7, 2];
        base.starts = vec![0, 4, 7, 12];
        let mut level = Level::new(&base).unwrap();
        for _ in 1..levels {
            level = level.next();
        }
        (base, level.fine())
    }

    /// The order a tool refining the base in its own order produces, made from `seed`:
    /// a shuffle of the base's vertices and faces, each face's first corner, an
    /// arrangement of the blocks.
    fn produced(levels: &[Level], base: &Topo, seed: u64, nv: usize, nf: usize) -> InputOrder {
        let mut x = seed | 1;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut vertices: Vec<u32> = (0..base.nv as u32).collect();
        let mut faces: Vec<u32> = (0..base.nf() as u32).collect();
        for i in (1..vertices.len()).rev() {
            vertices.swap(i, next() as usize % (i + 1));
        }
        for i in (1..faces.len()).rev() {
            faces.swap(i, next() as usize % (i + 1));
        }
        let first = (0..base.nf()).map(|f| (next() % base.face(f).len() as u64) as u32).collect();
        let b = Base {
            arrangement: (next() % 6) as usize,
            vertices,
            faces,
            first,
        };
        produce(levels, &b, nv, nf).unwrap()
    }

    /// Every arrangement and base order round-trips by method 4, which the encoder
    /// keeps, for the base's bytes alone; cut or flipped, the payload is an error or an
    /// order of the mesh.
    #[test]
    fn refinement_orders_round_trip_for_the_bases_bytes() {
        for levels in 1..=3u32 {
            let (base, fine) = hierarchy(levels);
            let h = Hierarchy {
                nv: base.nv,
                starts: &base.starts,
                idx: &base.idx,
                levels,
            };
            let faces = Faces {
                nv: fine.nv,
                starts: &fine.starts,
                idx: &fine.idx,
                hierarchy: Some(h),
            };
            let lv = super::levels(h).unwrap();
            for seed in 0..12u64 {
                let o = produced(&lv, &base, seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) + 1, fine.nv, fine.nf());
                let bytes = encode(&o, faces);
                assert_eq!(bytes[0], 4, "levels {levels} seed {seed}: method {}", bytes[0]);
                assert!(bytes.len() <= 16, "levels {levels}: {} B", bytes.len());
                assert_eq!(decode(&bytes, faces).unwrap(), o);
                for bit in 8..bytes.len() * 8 {
                    let mut b = bytes.clone();
                    b[bit / 8] ^= 1 << (bit % 8);
                    if let Ok(p) = decode(&b, faces) {
                        assert_eq!(p.vertices.len(), fine.nv);
                        assert_eq!(p.faces.len(), fine.nf());
                    }
                }
                for n in 0..bytes.len() {
                    if let Ok(p) = decode(&bytes[..n], faces) {
                        assert_eq!(p.vertices.len(), fine.nv);
                    }
                }
            }
            // One vertex pair swapped: no longer the refinement's order.
            let mut o = produced(&lv, &base, 99, fine.nv, fine.nf());
            let (a, b) = (fine.nv - 1, fine.nv - 2);
            o.vertices.swap(a, b);
            assert!(encode_levels(&o, faces, h).is_none());
            assert_eq!(decode(&encode(&o, faces), faces).unwrap(), o);
        }
    }

    /// Method 4 on faces without a hierarchy is corrupt.
    #[test]
    fn method_4_needs_a_hierarchy() {
        let (_, fine) = hierarchy(2);
        let faces = Faces {
            nv: fine.nv,
            starts: &fine.starts,
            idx: &fine.idx,
            hierarchy: None,
        };
        assert!(decode(&[4, 0, 0, 0], faces).is_err());
    }
}
