//! Method 4 of ORDR (SPEC.md 7.5): the order a refinement produces, level by level.
//! A tool that refines a mesh L times and writes each level's vertices as blocks (its
//! old vertices, its edges' points, its faces' points, in some order of the three),
//! numbers each level's new points from the level it refines: the edges' points by
//! their ends' numbers (lowest end first, then the other), the faces' points by the
//! faces' order, and each face's children in its corner order. So the whole order
//! follows from the base mesh's: its vertices' order, its faces' order and each face's
//! first corner. A sqrt(2) step (SPEC.md 8.4) has no edge points: its blocks are the
//! old vertices and the faces' points, and its faces, one per coarse edge, come in the
//! order of their edges' ends' numbers, each from its lower end.

use super::{get_perm, put_perm, Faces, Hierarchy, InputOrder, SECTION};
use crate::entropy::{Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::topology::{sqrt2, Family, Level, Topo};

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

/// Which base vertices of `h` are poles (every level's, SPEC.md 8.6); `None` when a
/// pole is no base vertex.
fn pole_flags(h: Hierarchy<'_>) -> Option<Vec<bool>> {
    let mut pole = vec![false; h.nv];
    for &p in h.poles {
        *pole.get_mut(p as usize)? = true;
    }
    Some(pole)
}

/// The coarse levels of `h` (the base mesh's, then each refinement's but the last),
/// canonical numbering; `None` when `h` has no level or too many, or its base is no
/// mesh (or, for sqrt(2), no closed one).
fn levels(h: Hierarchy<'_>) -> Option<Vec<Level>> {
    if !(1..=MAX_LEVELS).contains(&h.levels) {
        return None;
    }
    let topo = Topo {
        nv: h.nv,
        starts: h.starts.to_vec(),
        idx: h.idx.to_vec(),
    };
    let pole = pole_flags(h)?;
    let mut out = vec![Level::new(&topo).ok()?];
    for _ in 1..h.levels {
        let last = out.last()?;
        let next = match h.family {
            Family::Cc => last.next(),
            Family::Polar => Level::new(&last.fine_with(&pole)).ok()?,
            Family::Sqrt2 if sqrt2::closed(last) => sqrt2::next_level(last.clone(), true, false).ok()?,
            _ => return None,
        };
        out.push(next);
    }
    if h.family == Family::Sqrt2 && !sqrt2::closed(out.last()?) {
        return None;
    }
    Some(out)
}

/// Per fine face of `level` (SPEC.md 8.1, 8.6), the coarse face and corner it lies at:
/// each corner's one quad, or a pole's two triangles in a triangle (`pole[v]`).
fn fine_faces(level: &Level, pole: &[bool]) -> Vec<(u32, u32)> {
    let mut out = Vec::with_capacity(level.coarse.idx.len());
    for f in 0..level.nf() {
        let face = level.coarse.face(f);
        for (i, &c) in face.iter().enumerate() {
            let n = if face.len() == 3 && pole.get(c as usize) == Some(&true) { 2 } else { 1 };
            out.extend(std::iter::repeat_n((f as u32, i as u32), n));
        }
    }
    out
}

/// What the stream gives (SPEC.md 7.5): the blocks' arrangement, the base vertices in
/// order, the base faces in order, and per base face (by number) its first corner.
struct Base {
    /// Per level, coarse first.
    arrangement: Vec<usize>,
    vertices: Vec<u32>,
    faces: Vec<u32>,
    first: Vec<u32>,
}

/// The order the refinement of `levels` produces from `base`, as an [`InputOrder`] of
/// the finest level (`nv` vertices, `nf` faces); `None` when the finest level does not
/// have these counts.
fn produce(levels: &[Level], family: Family, pole: &[bool], base: &Base, nv: usize, nf: usize) -> Option<InputOrder> {
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
    for (level, &arrangement) in levels.iter().zip(&base.arrangement) {
        let blocks = ARRANGEMENTS[arrangement];
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
        let cc = family != Family::Sqrt2;
        // A sqrt(2) step has no edge points: its faces' points follow its old vertices.
        let sizes = [lnv, if cc { ne } else { 0 }, lnf];
        let mut offset = [0usize; 3];
        let mut at = 0;
        for &b in &blocks {
            offset[b] = at;
            at += sizes[b];
        }
        let mut next = vec![0u32; lnv + sizes[1] + lnf];
        for (v, &n) in number.iter().enumerate() {
            next[v] = (offset[0] + n as usize) as u32;
        }
        let first_point = lnv + sizes[1];
        for (rank, &(f, _)) in faces.iter().enumerate() {
            next[first_point + f as usize] = (offset[2] + rank) as u32;
        }
        let children = if cc {
            for (rank, &(_, _, e)) in by_ends.iter().enumerate() {
                next[lnv + e as usize] = (offset[1] + rank) as u32;
            }
            // Each face's children from its first corner on, each from its corner; a
            // pole's two triangles in a triangle from the pole, the triangle's other
            // two quads from the edge point after the pole (the corner after it) or
            // from the face point (the corner before it).
            // Per coarse corner (numbered as the coarse faces' corners), its first fine
            // face (SPEC.md 8.1, 8.6).
            let mut corner_first = vec![0u32; level.coarse.idx.len()];
            for (g, &(f, i)) in fine_faces(level, pole).iter().enumerate().rev() {
                corner_first[(level.coarse.starts[f as usize] + i) as usize] = g as u32;
            }
            let is_pole = |v: u32| pole.get(v as usize) == Some(&true);
            let mut children = Vec::with_capacity(corner_first.len());
            for &(f, r) in &faces {
                let face = level.coarse.face(f as usize);
                let st = level.coarse.starts[f as usize] as usize;
                let k = face.len();
                let fan = k == 3 && face.iter().any(|&v| is_pole(v));
                for j in 0..k {
                    let i = (r as usize + j) % k;
                    let g = corner_first[st + i];
                    if !fan {
                        children.push((g, 0));
                    } else if is_pole(face[i]) {
                        children.push((g, 0));
                        children.push((g + 1, 0));
                    } else if is_pole(face[(i + k - 1) % k]) {
                        children.push((g, 3));
                    } else {
                        children.push((g, 2));
                    }
                }
            }
            children
        } else {
            // One face per edge (its quad (a, f2, b, f1)), from its lower end: corner 0
            // or 2.
            by_ends
                .iter()
                .map(|&(x, _, e)| {
                    let [a, _] = level.edges[e as usize];
                    (e, if number[a as usize] == x { 0 } else { 2 })
                })
                .collect()
        };
        number = next;
        faces = children;
    }
    if number.len() != nv || faces.len() != nf {
        return None;
    }
    let mut forder = vec![0u32; nf];
    let mut rotations = vec![0u32; nf];
    // A face whose first corner is its canonical corner c is rotated by (4 - c) mod
    // 4 (a finest triangle's is corner 0).
    for (pos, &(g, c)) in faces.iter().enumerate() {
        forder[g as usize] = pos as u32;
        rotations[g as usize] = (4 - c) % 4;
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
    if o.vertices.len() != faces.nv {
        return None;
    }
    let levels = levels(h)?;
    let pole = pole_flags(h)?;
    // From the base if it can, else from the first level that can (a file refined from
    // a mesh that is itself a refinement): the smallest start costs least.
    (0..levels.len()).find_map(|start| encode_from(o, faces, h.family, &levels, &pole, start))
}

/// Method 4 from level `start` of `levels` (its coarse mesh as the base whose order is
/// coded); `None` when `o` is not the order refining it produces.
fn encode_from(
    o: &InputOrder,
    faces: Faces<'_>,
    family: Family,
    levels: &[Level],
    pole: &[bool],
    start: usize,
) -> Option<Vec<u8>> {
    let produced = &levels[start..];
    let coarse = &produced[0].coarse;
    let (nb, nbf) = (coarse.nv, coarse.nf());
    let nf = faces.count();
    // Catmull-Clark and polar levels have edge points (and base faces' first corners).
    let cc = family != Family::Sqrt2;
    // Each level's arrangement, finest first: its blocks by their first numbers (a
    // sqrt(2) step's edge block is empty, taken as right after its old vertices); the
    // old vertices' numbers less their block's start are the coarser level's.
    let mut arrangement = vec![0usize; produced.len()];
    let mut number: Vec<u32> = o.vertices.clone();
    for (l, level) in produced.iter().enumerate().rev() {
        let (lnv, ne) = (level.nv, if cc { level.ne() } else { 0 });
        let first_of = |r: std::ops::Range<usize>| number.get(r).and_then(|v| v.iter().min().copied());
        let old = first_of(0..lnv)?;
        let mut firsts = [
            (old, 0, 0),
            (if cc { first_of(lnv..lnv + ne)? } else { old }, 1, 1),
            (first_of(lnv + ne..number.len())?, 2, 2),
        ];
        firsts.sort_unstable();
        arrangement[l] = ARRANGEMENTS
            .iter()
            .position(|a| *a == firsts.map(|(_, _, b)| b))?;
        number = number[..lnv].iter().map(|&n| n.checked_sub(old)).collect::<Option<_>>()?;
    }
    // The base vertices by input number. The base faces: Catmull-Clark, by their finest
    // faces' first input number, each from the corner of that face; sqrt(2), by their
    // points' input numbers.
    let mut vertices: Vec<u32> = (0..nb as u32).collect();
    vertices.sort_unstable_by_key(|&v| number[v as usize]);
    let mut face_first = vec![(u32::MAX, 0u32); nbf];
    if cc {
        // Per finest face, the base corner it lies at, level by level.
        let mut root: Vec<u32> = fine_faces(&produced[0], pole)
            .iter()
            .map(|&(f, i)| coarse.starts[f as usize] + i)
            .collect();
        for level in &produced[1..] {
            root = fine_faces(level, pole).iter().map(|&(f, _)| root[f as usize]).collect();
        }
        if root.len() != nf {
            return None;
        }
        for (g, &pos) in o.faces.iter().enumerate() {
            let corner = root[g];
            let f = coarse.starts.partition_point(|&s| s <= corner) - 1;
            if pos < face_first[f].0 {
                face_first[f] = (pos, corner - coarse.starts[f]);
            }
        }
    } else {
        // The level after the base: its old vertices, then the base faces' points.
        let points = o.vertices.get(nb..nb + nbf)?;
        // Their input numbers order them as the finest level's do (every step keeps
        // the order of what it refines).
        for (f, &pos) in points.iter().enumerate() {
            face_first[f] = (pos, 0);
        }
    }
    let mut base_faces: Vec<u32> = (0..nbf as u32).collect();
    base_faces.sort_unstable_by_key(|&f| face_first[f as usize].0);
    let base = Base {
        arrangement: arrangement.clone(),
        vertices,
        faces: base_faces,
        first: face_first.iter().map(|&(_, c)| c).collect(),
    };
    if produce(produced, family, pole, &base, faces.nv, nf)? != *o {
        return None;
    }
    let mut e = Encoder::new();
    e.uniform(start as u64, levels.len() as u64);
    for &a in &arrangement {
        e.uniform(a as u64, ARRANGEMENTS.len() as u64);
    }
    put_perm(&mut e, &base.vertices);
    put_perm(&mut e, &base.faces);
    if cc {
        let mut m = IntModel::new();
        for &f in &base.faces {
            e.int(&mut m, base.first[f as usize] as i64);
        }
    }
    Some(e.finish())
}

/// Decodes method 4 (SPEC.md 7.5).
pub(super) fn decode_levels(payload: &[u8], faces: Faces<'_>, h: Option<Hierarchy<'_>>) -> Result<InputOrder> {
    let corrupt = |what: &str| Error::corrupt(SECTION, what.to_string());
    let h = h.ok_or_else(|| corrupt("method 4 without a Catmull-Clark, sqrt(2) or polar hierarchy"))?;
    let levels = levels(h).ok_or_else(|| corrupt("method 4 on a hierarchy it does not take"))?;
    let mut d = Decoder::new(payload, SECTION)?;
    let start = d.uniform(levels.len() as u64)? as usize;
    let produced = &levels[start..];
    let coarse = &produced[0].coarse;
    let arrangement = (0..produced.len())
        .map(|_| Ok(d.uniform(ARRANGEMENTS.len() as u64)? as usize))
        .collect::<Result<Vec<usize>>>()?;
    let vertices = get_perm(&mut d, coarse.nv)?;
    let nbf = coarse.nf();
    let base_faces = get_perm(&mut d, nbf)?;
    let mut first = vec![0u32; nbf];
    let mut m = IntModel::new();
    // (A sqrt(2) hierarchy's base faces have no first corners: its finest faces come
    // from edges.)
    for &f in base_faces.iter().filter(|_| h.family != Family::Sqrt2) {
        let k = coarse.starts[f as usize + 1] - coarse.starts[f as usize];
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
    let pole = pole_flags(h).ok_or_else(|| corrupt("a pole that is no base vertex"))?;
    produce(produced, h.family, &pole, &base, faces.nv, faces.count())
        .ok_or_else(|| corrupt("method 4 on faces that are not the hierarchy's"))
}

#[cfg(test)]
mod tests {
    use super::super::elements::tests::{faces_of, hierarchy, view};
    use super::super::{decode, encode};
    use super::*;

    /// The order a tool refining the base in its own order produces, made from `seed`:
    /// a shuffle of the base's vertices and faces, each face's first corner, an
    /// arrangement of the blocks.
    fn produced(levels: &[Level], family: Family, pole: &[bool], base: &Topo, seed: u64, nv: usize, nf: usize) -> InputOrder {
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
            arrangement: levels.iter().map(|_| (next() % 6) as usize).collect(),
            vertices,
            faces,
            first,
        };
        produce(levels, family, pole, &b, nv, nf).unwrap()
    }

    /// Every arrangement and base order round-trips by method 4, which the encoder
    /// keeps, for the base's bytes alone; cut or flipped, the payload is an error or an
    /// order of the mesh.
    #[test]
    fn refinement_orders_round_trip_for_the_bases_bytes() {
        for levels in 1..=3u32 {
            let (base, fine) = hierarchy(levels);
            let h = view(&base, levels, Family::Cc, &[]);
            let faces = faces_of(&fine, Some(h));
            let lv = super::levels(h).unwrap();
            for seed in 0..12u64 {
                let o = produced(&lv, Family::Cc, &[], &base, seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) + 1, fine.nv, fine.nf());
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
            // A tool that refined level 1 (a mesh that is itself a refinement): method 4
            // from level 1, its orders coded.
            if levels >= 2 {
                let o = produced(&lv[1..], Family::Cc, &[], &lv[1].coarse, 77, fine.nv, fine.nf());
                assert!(encode_from(&o, faces, Family::Cc, &lv, &[], 0).is_none());
                let bytes = encode(&o, faces);
                assert_eq!(bytes[0], 4, "levels {levels}: method {}", bytes[0]);
                assert_eq!(decode(&bytes, faces).unwrap(), o);
            }
            // One vertex pair swapped: no longer the refinement's order.
            let mut o = produced(&lv, Family::Cc, &[], &base, 99, fine.nv, fine.nf());
            let (a, b) = (fine.nv - 1, fine.nv - 2);
            o.vertices.swap(a, b);
            assert!(encode_levels(&o, faces, h).is_none());
            assert_eq!(decode(&encode(&o, faces), faces).unwrap(), o);
        }
    }

    /// A sqrt(2) hierarchy's order (a cube refined 1 to 4 times) round-trips by method 4
    /// for its base's bytes; another order is not method 4's.
    #[test]
    fn sqrt2_refinement_orders_round_trip() {
        let mut base = Topo::new(8);
        for f in [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]] {
            base.push(&f);
        }
        for levels in 1..=4u32 {
            let h = view(&base, levels, Family::Sqrt2, &[]);
            let lv = super::levels(h).unwrap();
            let fine = sqrt2::fine(lv.last().unwrap());
            let faces = faces_of(&fine, Some(h));
            for seed in 0..8u64 {
                let o = produced(&lv, Family::Sqrt2, &[], &base, seed * 7919 + 3, fine.nv, fine.nf());
                let bytes = encode(&o, faces);
                assert_eq!(bytes[0], 4, "levels {levels} seed {seed}");
                assert!(bytes.len() <= 16, "levels {levels}: {} B", bytes.len());
                assert_eq!(decode(&bytes, faces).unwrap(), o);
            }
            let mut o = produced(&lv, Family::Sqrt2, &[], &base, 5, fine.nv, fine.nf());
            o.rotations[0] ^= 2;
            assert!(encode_levels(&o, faces, h).is_none());
            assert_eq!(decode(&encode(&o, faces), faces).unwrap(), o);
        }
    }

    /// A polar hierarchy's order (a pyramid whose apex is a pole, its fan triangles
    /// split at every level, SPEC.md 8.6) round-trips by method 4 for its base's bytes;
    /// the same faces as a Catmull-Clark hierarchy's do not decode.
    #[test]
    fn polar_refinement_orders_round_trip() {
        let mut base = Topo::new(5);
        for f in [[4, 0, 1], [4, 1, 2], [4, 2, 3], [4, 3, 0]] {
            base.push(&f);
        }
        base.push(&[0, 3, 2, 1]);
        let poles = [4u32];
        let pole = [false, false, false, false, true];
        for levels in 1..=3u32 {
            let h = view(&base, levels, Family::Polar, &poles);
            let lv = super::levels(h).unwrap();
            let fine = lv.last().unwrap().fine_with(&pole);
            // The pole's valence doubles per level: its fan has 4 * 2^levels triangles.
            let fans = (0..fine.nf()).filter(|&g| fine.face(g).len() == 3).count();
            assert_eq!(fans, 4 << levels);
            let faces = faces_of(&fine, Some(h));
            for seed in 0..8u64 {
                let o = produced(&lv, Family::Polar, &pole, &base, seed * 104_729 + 5, fine.nv, fine.nf());
                // A fan's quads start at an edge point or a face point.
                assert!(o.rotations.contains(&1) && o.rotations.contains(&2));
                let bytes = encode(&o, faces);
                assert_eq!(bytes[0], 4, "levels {levels} seed {seed}");
                assert!(bytes.len() <= 16, "levels {levels}: {} B", bytes.len());
                assert_eq!(decode(&bytes, faces).unwrap(), o);
                let cc = Faces {
                    hierarchy: Some(Hierarchy {
                        family: Family::Cc,
                        poles: &[],
                        ..h
                    }),
                    ..faces
                };
                assert!(decode(&bytes, cc).is_err());
            }
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
