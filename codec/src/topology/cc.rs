//! Recovering Catmull-Clark hierarchies from flat quad meshes (encoder only).
//!
//! In a Catmull-Clark refinement the vertex graph is bipartite with the edge points on
//! one side, and every quad has its old vertex and its face point on one diagonal. Per
//! connected component there are at most 2 x 2 labelings; each is checked by rebuilding
//! the coarse faces (the fan of quads around each face point) and requiring that the
//! coarse mesh refines back to exactly the fine one. Among valid labelings the one with
//! the deepest hierarchy wins; ties go to fewer base vertices, then to the labeling whose
//! old vertices include the component's smallest input vertex number (SPEC.md 8.3).
//! Every step is linear in the mesh size; both choices are explored at each level, and as
//! a level has a quarter of the faces of the one above, the whole search stays linear.

use super::{PairMap, Recovered, Topo, NONE};

/// One coarsening of a component: the coarse mesh in the fine mesh's local numbers.
#[derive(Debug, Clone)]
pub(super) struct Coarsening {
    /// Coarse topology; vertex `i` is fine vertex `to_fine[i]`.
    pub(super) coarse: Topo,
    pub(super) to_fine: Vec<u32>,
    /// (coarse a, coarse b) with a < b -> fine edge point.
    edge_points: Vec<((u32, u32), u32)>,
    /// Per coarse face: its fine face point.
    pub(super) face_points: Vec<u32>,
}

/// A chain of coarsenings, finest first, with the number of base vertices it ends at.
#[derive(Debug, Clone, Default)]
pub(super) struct Chain {
    pub(super) steps: Vec<Coarsening>,
    pub(super) base_vertices: usize,
}

impl Chain {
    /// This chain of coarsenings of `first`'s coarse mesh, with `first` in front.
    pub(super) fn after(self, first: &Coarsening) -> Chain {
        let mut steps = Vec::with_capacity(self.steps.len() + 1);
        steps.push(first.clone());
        steps.extend(self.steps);
        Chain {
            steps,
            base_vertices: self.base_vertices,
        }
    }
}

/// Finds the deepest Catmull-Clark hierarchy of at most `max_levels` levels. Faces are
/// `topo.face(f)` over vertex numbers `< nv`. Returns `None` when there is no level.
#[cfg(any(test, feature = "internals"))]
pub fn recover(nv: usize, topo: &Topo, max_levels: usize) -> Option<Recovered> {
    recover_all(nv, topo, max_levels).into_iter().next()
}

/// Like [`recover`], also returning the equally deep alternative where every component
/// that ties takes its other labeling (a mesh and its dual refine to the same mesh; which
/// one codes smaller depends on the geometry). At most two results, preferred first.
#[cfg(any(test, feature = "internals"))]
pub fn recover_all(nv: usize, topo: &Topo, max_levels: usize) -> Vec<Recovered> {
    recover_candidates(nv, topo, max_levels, false)
}

/// Like `recover_all`; with `led`, first the candidate where every component takes
/// the labeling (of the common depth) whose base vertices include its smallest input
/// vertex number, when that differs from both: exporters that write a subdivision
/// surface write its base vertices first, so the input's order then codes as blocks of
/// base elements (SPEC.md 7.3) whichever labeling the geometry prefers.
pub fn recover_candidates(nv: usize, topo: &Topo, max_levels: usize, led: bool) -> Vec<Recovered> {
    if max_levels == 0 || topo.nf() == 0 || !topo.all_quads() {
        return Vec::new();
    }
    let comps = components(nv, topo);
    let mut per_comp: Vec<(Vec<u32>, Vec<Chain>)> = Vec::with_capacity(comps.len());
    let mut depth = max_levels;
    for (ids, local) in comps {
        let chains = chains(&local, max_levels);
        depth = depth.min(chains.first().map_or(0, |c| c.steps.len()));
        if depth == 0 {
            return Vec::new();
        }
        per_comp.push((ids, chains));
    }
    let primary: Vec<(&[u32], &Chain)> =
        per_comp.iter().map(|(ids, c)| (&ids[..], &c[0])).collect();
    let mut out = vec![merge(nv, depth, &primary)];
    let alt: Vec<(&[u32], &Chain)> = per_comp
        .iter()
        .map(|(ids, c)| match c.get(1) {
            Some(a) if a.steps.len() >= depth && c[0].steps.len() == depth => (&ids[..], a),
            _ => (&ids[..], &c[0]),
        })
        .collect();
    let differs = |a: &[(&[u32], &Chain)], b: &[(&[u32], &Chain)]| {
        a.iter().zip(b).any(|(a, b)| !std::ptr::eq(a.1, b.1))
    };
    if differs(&alt, &primary) {
        out.push(merge(nv, depth, &alt));
    }
    if led {
        let by_order: Vec<(&[u32], &Chain)> = per_comp
            .iter()
            .map(|(ids, c)| {
                let first = ids.iter().copied().min().unwrap_or(0);
                let chosen = c
                    .iter()
                    .filter(|ch| ch.steps.len() >= depth)
                    .find(|ch| base_has(ids, ch, depth, first))
                    .unwrap_or(&c[0]);
                (&ids[..], chosen)
            })
            .collect();
        if differs(&by_order, &primary) && differs(&by_order, &alt) {
            out.insert(0, merge(nv, depth, &by_order));
        } else if !differs(&by_order, &alt) && out.len() == 2 {
            out.swap(0, 1);
        }
    }
    out
}

/// Whether input vertex `v` is a base vertex of `chain` cut to `depth` steps (the
/// component's local vertices are input vertices `ids`).
fn base_has(ids: &[u32], chain: &Chain, depth: usize, v: u32) -> bool {
    let mut map = ids.to_vec();
    for step in chain.steps.iter().take(depth) {
        map = step.to_fine.iter().map(|&f| map[f as usize]).collect();
    }
    map.contains(&v)
}

/// Merges the components' chains, cut to the common depth, in input numbers.
pub(super) fn merge(nv: usize, depth: usize, parts: &[(&[u32], &Chain)]) -> Recovered {
    let mut edge_points: Vec<PairMap> = (0..depth).map(|_| PairMap::with_capacity(64)).collect();
    let mut face_points: Vec<PairMap> = (0..depth).map(|_| PairMap::with_capacity(64)).collect();
    let mut base = Topo::new(nv);
    for &(ids, chain) in parts {
        // ids: local fine vertex -> input number; walk down the chain.
        let mut map = ids.to_vec();
        for (l, step) in chain.steps.iter().take(depth).enumerate() {
            let level = depth - 1 - l; // coarse-first index of this refinement
            let coarse_ids: Vec<u32> = step.to_fine.iter().map(|&f| map[f as usize]).collect();
            for &((a, b), p) in &step.edge_points {
                let (ia, ib) = (coarse_ids[a as usize], coarse_ids[b as usize]);
                edge_points[level].insert(ia.min(ib), ia.max(ib), map[p as usize]);
            }
            for f in 0..step.coarse.nf() {
                let face = step.coarse.face(f);
                let p = map[step.face_points[f] as usize];
                // The face by its key: the canonical order may start anywhere.
                let (a, b) = super::face_key(face, |v| coarse_ids[v as usize]);
                face_points[level].insert(a, b, p);
            }
            if l + 1 == depth {
                for f in 0..step.coarse.nf() {
                    let face: Vec<u32> = step
                        .coarse
                        .face(f)
                        .iter()
                        .map(|&v| coarse_ids[v as usize])
                        .collect();
                    base.push(&face);
                }
            }
            map = coarse_ids;
        }
    }
    Recovered {
        base,
        edge_points,
        face_points,
        poles: Vec::new(),
    }
}

/// Connected components (through faces) as (local -> input numbers, local topology).
pub(crate) fn components(nv: usize, topo: &Topo) -> Vec<(Vec<u32>, Topo)> {
    let mut parent: Vec<u32> = (0..nv as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for f in 0..topo.nf() {
        let face = topo.face(f);
        for w in face.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    // Each face's component (in order of first face), and each component's faces and
    // corners, so that the copies are sized once (the memory of large meshes).
    let mut comp_of_root = vec![usize::MAX; nv];
    let mut sizes: Vec<(usize, usize)> = Vec::new();
    let mut comp_of_face = Vec::with_capacity(topo.nf());
    for f in 0..topo.nf() {
        let face = topo.face(f);
        let r = find(&mut parent, face[0]) as usize;
        if comp_of_root[r] == usize::MAX {
            comp_of_root[r] = sizes.len();
            sizes.push((0, 0));
        }
        let c = comp_of_root[r];
        sizes[c].0 += 1;
        sizes[c].1 += face.len();
        comp_of_face.push(c as u32);
    }
    drop((parent, comp_of_root));
    let mut out: Vec<(Vec<u32>, Topo)> = sizes
        .iter()
        .map(|&(faces, corners)| {
            let mut t = Topo::new(0);
            t.starts.reserve_exact(faces);
            t.idx.reserve_exact(corners);
            (Vec::new(), t)
        })
        .collect();
    let mut local = vec![NONE; nv];
    for (f, &c) in comp_of_face.iter().enumerate() {
        let face = topo.face(f);
        let (ids, t) = &mut out[c as usize];
        let start = t.idx.len();
        for &v in face {
            if local[v as usize] == NONE {
                local[v as usize] = ids.len() as u32;
                ids.push(v);
            }
            t.idx.push(local[v as usize]);
        }
        debug_assert!(t.idx.len() > start);
        t.starts.push(t.idx.len() as u32);
    }
    for (ids, t) in &mut out {
        t.nv = ids.len();
        ids.shrink_to_fit();
    }
    out
}

/// The deepest chains of coarsenings of a component, best first, at most two: ranked by
/// depth, then fewer base vertices, then the fixed candidate order.
pub(super) fn chains(topo: &Topo, max_levels: usize) -> Vec<Chain> {
    if max_levels == 0 || !topo.all_quads() {
        return vec![Chain {
            steps: Vec::new(),
            base_vertices: topo.nv,
        }];
    }
    let mut all: Vec<Chain> = Vec::new();
    for cand in candidates(topo) {
        let rests = chains(&cand.coarse, max_levels - 1);
        all.extend(rests.into_iter().map(|rest| rest.after(&cand)));
    }
    best(all, topo.nv, 2)
}

/// The (at most `keep`) best of `all`: deepest, then fewest base vertices, then first;
/// a chain of no steps when `all` is empty.
pub(super) fn best(mut all: Vec<Chain>, nv: usize, keep: usize) -> Vec<Chain> {
    if all.is_empty() {
        return vec![Chain {
            steps: Vec::new(),
            base_vertices: nv,
        }];
    }
    // Stable sort keeps the candidate order among equals.
    all.sort_by(|a, b| {
        b.steps
            .len()
            .cmp(&a.steps.len())
            .then(a.base_vertices.cmp(&b.base_vertices))
    });
    let depth = all[0].steps.len();
    all.retain(|c| c.steps.len() == depth);
    all.truncate(keep);
    all
}

/// 2-colouring over an adjacency given as CSR; `None` if not bipartite or not
/// connected (a component must be one piece).
pub(super) fn two_colour(
    n: usize,
    starts: &[u32],
    adj: &[u32],
    members: &[bool],
) -> Option<Vec<u8>> {
    two_colour_with(n, members, |v| {
        adj[starts[v as usize] as usize..starts[v as usize + 1] as usize]
            .iter()
            .copied()
    })
}

/// [`two_colour`] over the graph whose neighbours of `v` are `neighbours(v)` (repeats
/// allowed): the same colouring for the same edges, without a CSR adjacency (the
/// memory of large meshes). A connected bipartite graph has one colouring with the
/// first member's colour fixed, and the walk (depth first) checks every edge among
/// the vertices it reaches, so any walk gives the same answer.
pub(super) fn two_colour_with<I: IntoIterator<Item = u32>>(
    n: usize,
    members: &[bool],
    neighbours: impl Fn(u32) -> I,
) -> Option<Vec<u8>> {
    let mut colour = vec![2u8; n];
    let first = members.iter().position(|&m| m)?;
    colour[first] = 0;
    let mut stack = vec![first as u32];
    let mut reached = 1usize;
    while let Some(v) = stack.pop() {
        let c = colour[v as usize];
        for w in neighbours(v) {
            match colour[w as usize] {
                2 => {
                    colour[w as usize] = 1 - c;
                    reached += 1;
                    stack.push(w);
                }
                x if x == c => return None,
                _ => {}
            }
        }
    }
    (reached == members.iter().filter(|&&m| m).count()).then_some(colour)
}

/// The CSR adjacency of the undirected graph of `n` vertices with edges `pairs`:
/// each vertex's neighbours in the order of the pairs.
pub(super) fn adjacency(n: usize, pairs: &[(u32, u32)]) -> (Vec<u32>, Vec<u32>) {
    super::csr(n, pairs.iter().flat_map(|&(a, b)| [(a, b), (b, a)]))
}

/// Every valid coarsening of a connected all-quad component, in a fixed order: edge
/// class first the colour class of vertex 0's opposite, then vertex 0's; within that, the
/// old-vertex class containing the smallest non-edge vertex number first.
pub(super) fn candidates(t: &Topo) -> Vec<Coarsening> {
    let n = t.nv;
    // (All quads: face f's corners are idx[4 f..4 f + 4].)
    for q in t.idx.chunks_exact(4) {
        if q[0] == q[1]
            || q[1] == q[2]
            || q[2] == q[3]
            || q[3] == q[0]
            || q[0] == q[2]
            || q[1] == q[3]
        {
            return Vec::new();
        }
    }
    // The corners of each vertex (corner c is corner c % 4 of quad c / 4): the graphs
    // coloured below are walked through them.
    let (vc_starts, vc) = super::csr(n, t.idx.iter().enumerate().map(|(c, &v)| (v, c as u32)));
    let corners = Corners {
        idx: &t.idx,
        starts: &vc_starts,
        of: &vc,
    };
    // The edges' graph: a vertex's neighbours are the corners beside it in its quads.
    let all = vec![true; n];
    let Some(colour) = corners.two_colour(&all, &[1, 3]) else {
        return Vec::new();
    };
    drop(all);
    let mut out = Vec::new();
    for e_colour in [1 - colour[0], colour[0]] {
        // The other class: one diagonal of every quad, between its corners of that
        // class (a vertex's neighbours are the corners opposite it in its quads).
        let members: Vec<bool> = colour.iter().map(|&c| c != e_colour).collect();
        let Some(vf) = corners.two_colour(&members, &[2]) else {
            continue;
        };
        let smallest = members.iter().position(|&m| m).unwrap_or(0);
        for v_colour in [vf[smallest], 1 - vf[smallest]] {
            // Each vertex's class: an old vertex, a face point or an edge point.
            let class: Vec<Class> = (0..n)
                .map(|x| match (members[x], vf[x] == v_colour) {
                    (false, _) => Class::E,
                    (true, true) => Class::V,
                    (true, false) => Class::F,
                })
                .collect();
            if let Some(c) = build(t, &corners, &class) {
                out.push(c);
            }
        }
    }
    out
}

/// A vertex's part in a labeling ([`candidates`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Class {
    /// An old vertex.
    V,
    /// A face point.
    F,
    /// An edge point.
    E,
}

/// An all-quad topology's corners per vertex: corner `c` is corner `c % 4` of quad
/// `c / 4`, vertex `idx[c]`.
struct Corners<'a> {
    idx: &'a [u32],
    starts: &'a [u32],
    of: &'a [u32],
}

impl Corners<'_> {
    /// The corners of vertex `v`.
    #[inline]
    fn of(&self, v: u32) -> &[u32] {
        &self.of[self.starts[v as usize] as usize..self.starts[v as usize + 1] as usize]
    }

    /// The corner `at` places after corner `c` in its quad.
    #[inline]
    fn after(&self, c: u32, at: u32) -> u32 {
        self.idx[((c & !3) | ((c + at) & 3)) as usize]
    }

    /// [`two_colour_with`] of the graph whose neighbours of `v` are the corners at
    /// `offsets` from `v`'s in each of its quads.
    fn two_colour(&self, members: &[bool], offsets: &[u32]) -> Option<Vec<u8>> {
        two_colour_with(members.len(), members, |v| {
            self.of(v)
                .iter()
                .flat_map(move |&corner| offsets.iter().map(move |&at| self.after(corner, at)))
        })
    }
}

/// Whether `v` holds a value twice (sorted into `scratch` when long).
fn repeats(v: &[u32], scratch: &mut Vec<u32>) -> bool {
    if v.len() <= 16 {
        return v.iter().enumerate().any(|(i, x)| v[i + 1..].contains(x));
    }
    scratch.clear();
    scratch.extend_from_slice(v);
    scratch.sort_unstable();
    scratch.windows(2).any(|w| w[0] == w[1])
}

/// The coarse face of face point `fp`, from the fine quads around it (`fp`'s
/// corners): its corners in order into `ring` and the edge points between them into
/// `edges` (edge point `i` joins corners `i` and `i + 1`); `None` unless the quads make
/// one closed fan of at least three with distinct corners and edge points.
fn face_ring(
    corners: &Corners<'_>,
    fp: u32,
    class: &[Class],
    fan: &mut Vec<(u32, u32, u32)>,
    ring: &mut Vec<u32>,
    edges: &mut Vec<u32>,
    scratch: &mut Vec<u32>,
) -> Option<()> {
    fan.clear();
    for &c in corners.of(fp) {
        let (a, v, b) = (corners.after(c, 1), corners.after(c, 2), corners.after(c, 3));
        if class[v as usize] != Class::V
            || class[a as usize] != Class::E
            || class[b as usize] != Class::E
        {
            return None;
        }
        fan.push((a, v, b));
    }
    let k = fan.len();
    if k < 3 {
        return None;
    }
    // Walk the fan: the quad after (a, v, b) is the one whose a is this b.
    ring.clear();
    edges.clear();
    let mut cur = 0usize;
    for _ in 0..k {
        let (_, v, b) = fan[cur];
        ring.push(v);
        edges.push(b);
        cur = fan.iter().position(|&(a2, _, _)| a2 == b)?;
    }
    if cur != 0 {
        return None;
    }
    // Every quad of the fan visited once: the ring's edge points are distinct.
    if repeats(edges, scratch) || repeats(ring, scratch) {
        return None;
    }
    Some(())
}

/// Builds and checks the coarse mesh for one labeling (`class`).
fn build(t: &Topo, corners: &Corners<'_>, class: &[Class]) -> Option<Coarsening> {
    let n = t.nv;
    let mut coarse_id = vec![NONE; n];
    let mut to_fine = Vec::new();
    let mut coarse = Topo::new(0);
    let mut face_points = Vec::new();
    // Per edge point: its coarse end points as first seen (a, b) in face order.
    let mut e_ends: Vec<[u32; 2]> = vec![[NONE, NONE]; n];
    let mut e_faces = vec![0u8; n];
    let mut visited_quads = 0usize;
    let mut fan: Vec<(u32, u32, u32)> = Vec::new(); // (a, v, b) per quad around f
    let (mut ring, mut edges, mut face, mut scratch) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for fp in 0..n as u32 {
        if class[fp as usize] != Class::F {
            continue;
        }
        face_ring(corners, fp, class, &mut fan, &mut ring, &mut edges, &mut scratch)?;
        let k = ring.len();
        visited_quads += k;
        face.clear();
        for &v in &ring {
            if coarse_id[v as usize] == NONE {
                coarse_id[v as usize] = to_fine.len() as u32;
                to_fine.push(v);
            }
            face.push(coarse_id[v as usize]);
        }
        for i in 0..k {
            // edges[i] joins ring[i] and ring[i + 1].
            let e = edges[i] as usize;
            let (a, b) = (face[i], face[(i + 1) % k]);
            if a == b {
                return None;
            }
            match e_ends[e] {
                [NONE, _] => e_ends[e] = [a, b],
                [x, y] if (x == b && y == a) => {}
                _ => return None, // inconsistent or same orientation twice
            }
            e_faces[e] += 1;
            if e_faces[e] > 2 {
                return None;
            }
        }
        coarse.push(&face);
        face_points.push(fp);
    }
    if visited_quads != t.nf() {
        return None;
    }
    coarse.nv = to_fine.len();
    // Distinct edge points for distinct coarse edges; each has valence 2 + faces.
    let mut edge_points = Vec::new();
    let mut seen = PairMap::with_capacity(n / 2);
    for (e, ends) in e_ends.iter().enumerate() {
        if ends[0] == NONE {
            continue;
        }
        let key = (ends[0].min(ends[1]), ends[0].max(ends[1]));
        if !seen.get_or_insert(key.0, key.1, || e as u32).1 {
            return None;
        }
        // An edge point lies in two quads per coarse face beside it, and in no others.
        if corners.of(e as u32).len() != 2 * e_faces[e] as usize {
            return None;
        }
        edge_points.push((key, e as u32));
    }
    // Every vertex that is neither v nor f must be an edge point that was met.
    for x in 0..n {
        if class[x] == Class::E && e_ends[x][0] == NONE {
            return None;
        }
    }
    Some(Coarsening {
        coarse,
        to_fine,
        edge_points,
        face_points,
    })
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{prism_with_triangles, shuffle};
    use super::super::{canonicalise, Level};
    use super::*;

    use crate::topology::fixtures::cube;

    fn refine(t: &Topo, n: usize) -> Topo {
        let mut cur = t.clone();
        for _ in 0..n {
            cur = Level::new(&cur).unwrap().fine();
        }
        cur
    }

    fn face_set(t: &Topo, order: Option<&[u32]>) -> Vec<Vec<u32>> {
        let mut v: Vec<Vec<u32>> = (0..t.nf())
            .map(|f| {
                let face: Vec<u32> = t
                    .face(f)
                    .iter()
                    .map(|&x| order.map_or(x, |o| o[x as usize]))
                    .collect();
                let k = (0..face.len()).min_by_key(|&i| face[i]).unwrap();
                face[k..].iter().chain(&face[..k]).copied().collect()
            })
            .collect();
        v.sort();
        v
    }

    #[test]
    fn recovers_full_depth_from_shuffled_meshes() {
        for (base, levels) in [(cube(), 3), (prism_with_triangles(), 2)] {
            let fine = refine(&base, levels);
            for seed in 1..4 {
                let input = shuffle(&fine, seed);
                let rec = recover(input.nv, &input, 16).expect("a hierarchy");
                assert_eq!(rec.levels(), levels);
                // The base or its dual (equally deep; the tie rule picks one).
                let used = rec
                    .base
                    .idx
                    .iter()
                    .collect::<std::collections::BTreeSet<_>>()
                    .len();
                assert_eq!(rec.base.nf() + used, base.nf() + base.nv);
                let mut canon = canonicalise(&rec, true).unwrap();
                assert_eq!(
                    face_set(&canon.fine(), Some(&canon.order)),
                    face_set(&input, None)
                );
                let mut sorted = canon.order.clone();
                sorted.sort();
                assert_eq!(sorted, (0..input.nv as u32).collect::<Vec<_>>());
                // Stowed levels come back the same.
                let levels = canon.levels.clone();
                canon.stow();
                assert!(canon.levels.is_empty());
                canon.unstow().unwrap();
                assert_eq!(canon.levels, levels);
            }
        }
    }

    #[test]
    fn level_cap_and_no_structure() {
        let fine = refine(&cube(), 3);
        assert_eq!(recover(fine.nv, &fine, 2).unwrap().levels(), 2);
        assert!(recover(fine.nv, &fine, 0).is_none());
        assert!(recover(cube().nv, &cube(), 5).is_none());
        // Two quads sharing an edge: a 1x2 grid is no refinement.
        let mut t = Topo::new(6);
        t.push(&[0, 1, 4, 3]);
        t.push(&[1, 2, 5, 4]);
        assert!(recover(6, &t, 5).is_none());
    }

    #[test]
    fn open_grids_and_components() {
        // A 4x4 grid is two levels of one quad.
        let mut g = Topo::new(25);
        for y in 0..4u32 {
            for x in 0..4u32 {
                let i = y * 5 + x;
                g.push(&[i, i + 1, i + 6, i + 5]);
            }
        }
        let rec = recover(25, &g, 16).unwrap();
        assert_eq!(rec.levels(), 2);
        assert_eq!(rec.base.nf(), 1);
        // Two components of different depths: the common depth.
        let a = refine(&cube(), 2);
        let b = refine(&cube(), 1);
        let mut u = Topo::new(a.nv + b.nv);
        for f in 0..a.nf() {
            u.push(a.face(f));
        }
        for f in 0..b.nf() {
            let face: Vec<u32> = b.face(f).iter().map(|&v| v + a.nv as u32).collect();
            u.push(&face);
        }
        let rec = recover(u.nv, &u, 16).unwrap();
        assert_eq!(rec.levels(), 1);
        let canon = canonicalise(&rec, true).unwrap();
        assert_eq!(
            face_set(&canon.fine(), Some(&canon.order)),
            face_set(&u, None)
        );
    }
}
