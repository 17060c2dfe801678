//! Recovering polar hierarchies from flat meshes (SPEC.md 8.7, encoder only).
//!
//! A polar level (SPEC.md 8.6) is a Catmull-Clark level whose quads at the corners of the
//! poles' fan triangles are split along (pole, face point). So a pole is a vertex whose
//! faces are all triangles, every triangle of a refined level has exactly one pole corner,
//! and merging each pole's triangles in pairs across their (pole, face point) edges gives
//! back the Catmull-Clark refinement of the same coarse mesh. Which of a pole's two
//! pairings is the right one follows from the 2-colouring of the quads' vertex graph
//! (edge points on one side, face points on the other); both colours are tried and a
//! coarsening is kept only if every pole is a coarse vertex and every merged quad's far
//! corner is the face point of a coarse triangle. The poles are the same vertices at
//! every level. Components are recovered separately and share the smallest depth; the
//! result must refine back to the input face for face.

use super::cc::{self, Chain, Coarsening};
use super::{canonicalise, Canonical, FaceIndex, PairMap, Recovered, Topo};

/// The deepest polar hierarchy of at most `max_levels` levels of `topo` (vertex numbers
/// `< nv`), canonicalised and checked against `topo`; `None` if the mesh has no pole or
/// no polar level.
#[cfg(any(test, feature = "internals"))]
pub fn recover(nv: usize, topo: &Topo, max_levels: usize) -> Option<Canonical> {
    recover_all(nv, topo, max_levels, true, KEEP).into_iter().next()
}

/// Like `recover`, also returning the equally deep alternatives where every component
/// that ties takes its second, third or fourth coarsening (a regular polar grid coarsens
/// in several ways; which codes smaller depends on the geometry). At most `keep`
/// results ([`KEEP`], or [`KEEP_FOR_ORDER`] when the input's order is kept: the one its
/// producer made may be any of them), preferred first.
/// `gates` as [`super::canonicalise`] takes it.
pub fn recover_all(nv: usize, topo: &Topo, max_levels: usize, gates: bool, keep: usize) -> Vec<Canonical> {
    let recs = recover_raw(nv, topo, max_levels, keep);
    if recs.is_empty() {
        return Vec::new();
    }
    let index = FaceIndex::new(topo);
    recs.into_iter()
        .filter_map(|rec| {
            let canon = canonicalise(&rec, gates).ok()?;
            index.check(&canon.fine(), &canon.order, topo).ok()?;
            Some(canon)
        })
        .collect()
}

/// [`recover_all`] before canonicalisation.
fn recover_raw(nv: usize, topo: &Topo, max_levels: usize, keep: usize) -> Vec<Recovered> {
    if max_levels == 0 || topo.nf() == 0 {
        return Vec::new();
    }
    // Poles: vertices whose faces are all triangles.
    let mut triangles = vec![0u32; nv];
    let mut others = vec![0u32; nv];
    for f in 0..topo.nf() {
        let face = topo.face(f);
        let count = if face.len() == 3 {
            &mut triangles
        } else {
            &mut others
        };
        for &v in face {
            count[v as usize] += 1;
        }
    }
    let pole: Vec<bool> = (0..nv)
        .map(|v| triangles[v] > 0 && others[v] == 0)
        .collect();
    if !pole.contains(&true) {
        return Vec::new();
    }
    let mut parts = Vec::new();
    let mut depth = max_levels;
    for (ids, local) in cc::components(nv, topo) {
        let local_pole: Vec<bool> = ids.iter().map(|&i| pole[i as usize]).collect();
        let chains = chains(&local, &local_pole, max_levels, keep);
        depth = depth.min(chains[0].steps.len());
        if depth == 0 {
            return Vec::new();
        }
        parts.push((ids, chains));
    }
    let poles: Vec<u32> = (0..nv as u32).filter(|&v| pole[v as usize]).collect();
    let mut out = Vec::new();
    for alternative in 0..keep {
        let mut differs = false;
        let refs: Vec<(&[u32], &Chain)> = parts
            .iter()
            .map(|(ids, c)| match c.get(alternative) {
                Some(a) if alternative > 0 && a.steps.len() >= depth => {
                    differs = true;
                    (&ids[..], a)
                }
                _ => (&ids[..], &c[0]),
            })
            .collect();
        if alternative > 0 && !differs {
            break;
        }
        let mut rec = cc::merge(nv, depth, &refs);
        rec.poles = poles.clone();
        out.push(rec);
    }
    out
}

/// How many equally deep chains a component keeps: a polar grid coarsens in up to four
/// ways (two pairings of the fans' triangles, two labelings of the merged quads).
pub const KEEP: usize = 4;

/// How many a component keeps when the input's order is kept (the encoder then puts
/// first the candidate whose order codes smallest).
pub const KEEP_FOR_ORDER: usize = 16;

/// The best chains of polar coarsenings of a component whose poles are `pole`.
fn chains(t: &Topo, pole: &[bool], max_levels: usize, keep: usize) -> Vec<Chain> {
    if max_levels == 0 {
        return cc::best(Vec::new(), t.nv, keep);
    }
    if t.all_quads() {
        return cc::chains(t, max_levels);
    }
    let mut all = Vec::new();
    for (merged, diagonals) in merges(t, pole) {
        for cand in cc::candidates(&merged) {
            if !fits(&cand, t.nv, &diagonals) {
                continue;
            }
            let coarse_pole: Vec<bool> = cand.to_fine.iter().map(|&f| pole[f as usize]).collect();
            let rests = chains(&cand.coarse, &coarse_pole, max_levels - 1, keep);
            all.extend(rests.into_iter().map(|rest| rest.after(&cand)));
        }
    }
    cc::best(all, t.nv, keep)
}

/// The all-quad meshes made by merging the poles' triangles in pairs (at most two, one per
/// choice of the face points' colour), each with its merged (pole, face point) diagonals.
/// Empty unless every face is a quad with no pole corner or a triangle with exactly one.
fn merges(t: &Topo, pole: &[bool]) -> Vec<(Topo, Vec<(u32, u32)>)> {
    let n = t.nv;
    let mut quad_edges = Vec::new();
    let mut in_quad = vec![false; n];
    // Triangle of each directed (pole, next corner) edge, and the triangles rotated to
    // start at their pole.
    let mut tri_of = PairMap::with_capacity(t.nf());
    let mut tris: Vec<(usize, [u32; 3])> = Vec::new();
    for f in 0..t.nf() {
        let face = t.face(f);
        let poles = face.iter().filter(|&&v| pole[v as usize]).count();
        match (face.len(), poles) {
            (4, 0) => {
                for i in 0..4 {
                    quad_edges.push((face[i], face[(i + 1) % 4]));
                    in_quad[face[i] as usize] = true;
                }
            }
            (3, 1) => {
                let r = face.iter().position(|&v| pole[v as usize]).unwrap_or(0);
                let tri = [face[r], face[(r + 1) % 3], face[(r + 2) % 3]];
                tri_of.insert(tri[0], tri[1], tris.len() as u32);
                tris.push((f, tri));
            }
            _ => return Vec::new(),
        }
    }
    let (starts, adj) = cc::adjacency(n, &quad_edges);
    let Some(colour) = cc::two_colour(n, &starts, &adj, &in_quad) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    'choice: for face_colour in [0u8, 1] {
        let is_fp = |v: u32| colour[v as usize] == face_colour;
        let mut merged = Topo::new(n);
        let mut diagonals = Vec::with_capacity(tris.len() / 2);
        let mut used = vec![false; tris.len()];
        let mut next_tri = 0;
        for f in 0..t.nf() {
            let face = t.face(f);
            if face.len() == 4 {
                merged.push(face);
                continue;
            }
            let i = next_tri;
            next_tri += 1;
            let [p, x, y] = tris[i].1;
            if !in_quad[x as usize] || !in_quad[y as usize] || is_fp(x) == is_fp(y) {
                continue 'choice;
            }
            if is_fp(x) {
                // The second triangle of its pair: merged with the first.
                continue;
            }
            let Some(j) = tri_of.get(p, y) else {
                continue 'choice;
            };
            let z = tris[j as usize].1[2];
            if std::mem::replace(&mut used[i], true)
                || std::mem::replace(&mut used[j as usize], true)
            {
                continue 'choice;
            }
            merged.push(&[p, x, y, z]);
            diagonals.push((p, y));
        }
        if used.iter().all(|&u| u) {
            out.push((merged, diagonals));
        }
    }
    out
}

/// Whether a coarsening of a merged mesh is a polar one: every merged diagonal joins a
/// coarse vertex (the pole) and the face point of a coarse triangle.
fn fits(cand: &Coarsening, n: usize, diagonals: &[(u32, u32)]) -> bool {
    let mut is_coarse = vec![false; n];
    for &f in &cand.to_fine {
        is_coarse[f as usize] = true;
    }
    let mut triangle_point = vec![false; n];
    for (f, &fp) in cand.face_points.iter().enumerate() {
        triangle_point[fp as usize] = cand.coarse.face(f).len() == 3;
    }
    diagonals
        .iter()
        .all(|&(p, c)| is_coarse[p as usize] && triangle_point[c as usize])
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{prism_with_triangles, shuffle};
    use super::super::{check_matches, Level, Topo};
    use super::*;

    /// Refines `base` `levels` times with the polar rule, poles `poles`.
    fn refine(base: &Topo, poles: &[u32], levels: usize) -> Topo {
        let mut pole = vec![false; base.nv];
        for &p in poles {
            pole[p as usize] = true;
        }
        let mut cur = base.clone();
        for _ in 0..levels {
            let lvl = Level::new(&cur).unwrap();
            assert_eq!(lvl.fine_faces_with(&pole), lvl.fine_with(&pole).nf());
            cur = lvl.fine_with(&pole);
        }
        cur
    }

    /// A closed cylinder capped by two fans: `n` spokes, poles 0 and 1.
    fn capped_cylinder(n: u32, rings: u32) -> Topo {
        let mut t = Topo::new((2 + n * rings) as usize);
        let v = |r: u32, j: u32| 2 + r * n + j % n;
        for j in 0..n {
            t.push(&[0, v(0, j + 1), v(0, j)]);
            t.push(&[1, v(rings - 1, j), v(rings - 1, j + 1)]);
            for r in 0..rings - 1 {
                t.push(&[v(r, j), v(r, j + 1), v(r + 1, j + 1), v(r + 1, j)]);
            }
        }
        t
    }

    #[test]
    fn a_pole_doubles_its_valence_and_keeps_triangles() {
        let base = capped_cylinder(5, 2);
        let fine = refine(&base, &[0, 1], 2);
        // Each pole: 5 -> 10 -> 20 triangles; every other face a quad.
        let tris = (0..fine.nf()).filter(|&f| fine.face(f).len() == 3).count();
        assert_eq!(tris, 40);
        assert_eq!(
            (0..fine.nf())
                .filter(|&f| fine.face(f).contains(&0))
                .count(),
            20
        );
        assert!((0..fine.nf()).all(|f| fine.face(f).len() == 3 || fine.face(f).len() == 4));
    }

    #[test]
    fn recovers_polar_hierarchies_from_shuffled_meshes() {
        // Fans inside a mesh whose base has other triangles (the prism's split side has
        // no pole), and a capped cylinder with two poles of valence 5 (odd: no coarser level).
        let mut prism_poles = prism_with_triangles();
        // A fan around a new vertex on the top pentagon's place: replace face 0 by a fan.
        let top: Vec<u32> = prism_poles.face(0).to_vec();
        let mut t = Topo::new(prism_poles.nv + 1);
        let hub = prism_poles.nv as u32;
        for i in 0..top.len() {
            t.push(&[hub, top[i], top[(i + 1) % top.len()]]);
        }
        for f in 1..prism_poles.nf() {
            t.push(prism_poles.face(f));
        }
        prism_poles = t;
        for (base, poles, levels) in [
            (capped_cylinder(5, 3), vec![0u32, 1], 3usize),
            (prism_poles, vec![10], 2),
        ] {
            let fine = refine(&base, &poles, levels);
            for seed in 1..4 {
                let input = shuffle(&fine, seed);
                let mut canon = recover(input.nv, &input, 16).expect("a polar hierarchy");
                assert_eq!(canon.levels.len(), levels);
                // Stowed levels come back the same (the poles' triangles included).
                let kept = canon.levels.clone();
                canon.stow();
                canon.unstow().unwrap();
                assert_eq!(canon.levels, kept);
                assert_eq!(canon.poles.len(), poles.len());
                assert_eq!(canon.base.nf(), base.nf());
                // Canonical poles are base vertices whose faces are all triangles.
                for &p in &canon.poles {
                    let faces: Vec<usize> = (0..canon.base.nf())
                        .filter(|&f| canon.base.face(f).contains(&p))
                        .collect();
                    assert!(!faces.is_empty());
                    assert!(faces.iter().all(|&f| canon.base.face(f).len() == 3));
                }
                check_matches(&canon.fine(), &canon.order, &input).unwrap();
                // The level cap.
                let capped = recover(input.nv, &input, 1).unwrap();
                assert_eq!(capped.levels.len(), 1);
            }
        }
    }

    #[test]
    fn no_poles_no_polar_hierarchy() {
        let cc = Level::new(&capped_cylinder(5, 2)).unwrap().fine();
        assert!(recover(cc.nv, &cc, 4).is_none());
        // A fan alone with no quads around it, and a triangle mesh.
        let fan = capped_cylinder(5, 1);
        assert!(recover(fan.nv, &fan, 4).is_none());
    }
}
