//! Canonical hierarchies: a recovered hierarchy renumbered into the order the decoder
//! rebuilds (SPEC.md 6.1, 8.2), the base's numbering, and the face index the recovery
//! and the checks share.

use super::{gates, sqrt2, Family, Level, PairMap, Topo, NONE};
use crate::error::{Error, Result};
use crate::transform::StencilCache;

/// A recovered hierarchy, in the input's vertex numbers.
#[derive(Debug, Clone)]
pub struct Recovered {
    /// The base mesh: faces over input vertex numbers (`nv` = the input's count).
    pub base: Topo,
    /// Per level (1 = first refinement): coarse edge (input numbers, smaller first) ->
    /// its edge point's input number.
    pub edge_points: Vec<PairMap>,
    /// Per level: coarse face, named by its `face_key` (input numbers) -> its face
    /// point's input number.
    pub face_points: Vec<PairMap>,
    /// Polar hierarchies: the poles (input numbers), the same vertices at every level;
    /// empty for Catmull-Clark ones.
    pub poles: Vec<u32>,
}

impl Recovered {
    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.edge_points.len()
    }
}

/// The canonical numbering of a recovered hierarchy: the base mesh in canonical base
/// order and, per level, the refinement, with the input number of every canonical vertex.
#[derive(Debug, Clone)]
pub struct Canonical {
    /// The base mesh, canonical numbering (SPEC.md 6.1).
    pub base: Topo,
    /// One [`Level`] per refinement, coarse first.
    pub levels: Vec<Level>,
    /// `order[c]` = the input number of canonical vertex `c` (finest level).
    pub order: Vec<u32>,
    /// Which refinement the levels follow: Catmull-Clark, polar (Catmull-Clark with
    /// poles) or sqrt(2) steps ([`crate::topology::sqrt2`]).
    pub family: Family,
    /// Polar hierarchies (SPEC.md 8.6): the poles in canonical numbers, increasing;
    /// empty for every other hierarchy.
    pub poles: Vec<u32>,
    /// The number of levels [`Canonical::stow`] freed (0 when they are here).
    pub(super) stowed: usize,
    /// The interp4 and interp6 stencils of the levels, once a coding has made them
    /// (emptied with the levels by [`Canonical::stow`]).
    pub(crate) stencils: StencilCache,
}

impl Canonical {
    /// The finest topology, canonical numbering: made again from the finest level when
    /// asked for (only keeping the input's order needs it), not held beside the levels
    /// (the memory of large meshes).
    pub fn fine(&self) -> Topo {
        debug_assert_eq!(self.stowed, 0, "the levels are stowed");
        match self.levels.last() {
            None => self.base.clone(),
            Some(l) if self.family == Family::Sqrt2 => sqrt2::fine(l),
            Some(l) => l.fine_with(&self.pole_flags()),
        }
    }

    /// A hierarchy of this family over `levels` (coarse first, not empty) with no
    /// order and no poles: the subdivision fit's base mesh glued at its seams.
    pub(crate) fn with_levels(&self, levels: Vec<Level>) -> Canonical {
        let levels_len = levels.len();
        Canonical {
            base: levels[0].coarse.clone(),
            levels,
            order: Vec::new(),
            family: self.family,
            poles: Vec::new(),
            stowed: 0,
            stencils: StencilCache::new(levels_len),
        }
    }

    /// Which canonical vertices are poles (the same at every level), by number.
    fn pole_flags(&self) -> Vec<bool> {
        let n = self.poles.iter().map(|&p| p as usize + 1).max().unwrap_or(0);
        let mut pole = vec![false; n];
        for &p in &self.poles {
            pole[p as usize] = true;
        }
        pole
    }

    /// Frees the levels, keeping what makes them again ([`Canonical::unstow`]): a
    /// candidate hierarchy that waits while another is coded holds its base and order
    /// only (the memory of large meshes).
    pub fn stow(&mut self) {
        if !self.levels.is_empty() {
            self.stowed = self.levels.len();
            self.levels = Vec::new();
            self.stencils = StencilCache::default();
        }
    }

    /// Makes the levels that [`Canonical::stow`] freed again, the same as
    /// canonicalisation made them (each from the one before, from the base).
    pub fn unstow(&mut self) -> Result<()> {
        let n = std::mem::take(&mut self.stowed);
        let pole = self.pole_flags();
        self.levels.reserve_exact(n);
        for _ in 0..n {
            let level = next_canonical_level(self.family, &self.base, self.levels.last(), &pole)?;
            self.levels.push(level);
        }
        if n > 0 {
            self.stencils = StencilCache::new(self.levels.len());
        }
        Ok(())
    }
}

/// The level after `prev` in a canonical hierarchy of `family` (with no `prev`, the
/// refinement of `base`), as canonicalisation makes it: a Catmull-Clark or polar level
/// from the fine faces of the one before (a pole's triangle corners split as `pole`
/// says, SPEC.md 8.6); a sqrt(2) level from the one before without looking edges up, and
/// without per-vertex lists (sqrt2-sym makes its vertices' face lists for the level it
/// transforms).
pub(crate) fn next_canonical_level(
    family: Family,
    base: &Topo,
    prev: Option<&Level>,
    pole: &[bool],
) -> Result<Level> {
    match prev {
        Some(prev) if family == Family::Sqrt2 => sqrt2::next_level_of(prev, false, false),
        Some(prev) => Level::new(&prev.fine_with(pole)),
        None => {
            let mut level = Level::new(base)?;
            if family == Family::Sqrt2 {
                level.free_vertex_adjacency();
            }
            Ok(level)
        }
    }
}

/// The canonical base numbering (SPEC.md 8.2): base vertices in order of first use
/// walking the base faces, then the input's vertices that no face at any level uses
/// (`finer` lists the vertices that appear at finer levels). Returns `order[c]` = input
/// number of canonical vertex `c`, and the base faces renumbered.
pub(crate) fn base_numbering(
    base_in: &Topo,
    finer: impl Iterator<Item = u32>,
    gates: bool,
) -> (Vec<u32>, Topo) {
    // With `gates`, faces in the order the connectivity coder's gates visit them
    // (SPEC.md 6.2); else as recovered (which keeps a file's own order cheap to record).
    let (forder, rot) = if gates {
        gates::gate_order(&base_in.starts, &base_in.idx)
    } else {
        ((0..base_in.nf() as u32).collect(), vec![0; base_in.nf()])
    };
    let mut visited = Topo::new(base_in.nv);
    let mut buf = Vec::new();
    for (&f, &r) in forder.iter().zip(&rot) {
        let face = base_in.face(f as usize);
        buf.clear();
        buf.extend((0..face.len()).map(|i| face[(r as usize + i) % face.len()]));
        visited.push(&buf);
    }
    let base_in = &visited;
    let n = base_in.nv;
    let mut order: Vec<u32> = Vec::new();
    let mut seen = vec![false; n];
    for &v in &base_in.idx {
        if !seen[v as usize] {
            seen[v as usize] = true;
            order.push(v);
        }
    }
    for v in finer {
        seen[v as usize] = true;
    }
    for v in 0..n as u32 {
        if !seen[v as usize] {
            order.push(v);
        }
    }
    let mut inv = vec![NONE; n];
    for (c, &v) in order.iter().enumerate() {
        inv[v as usize] = c as u32;
    }
    let mut base = Topo::new(order.len());
    for f in 0..base_in.nf() {
        let face: Vec<u32> = base_in.face(f).iter().map(|&v| inv[v as usize]).collect();
        base.push(&face);
    }
    (order, base)
}

/// A face's key in a [`PairMap`]: its directed edge that starts at its smallest vertex
/// (as `id` numbers its corners), the same wherever the face's corners start.
#[inline]
pub(crate) fn face_key(face: &[u32], id: impl Fn(u32) -> u32) -> (u32, u32) {
    let k = face.len();
    let (i, a) = face
        .iter()
        .map(|&v| id(v))
        .enumerate()
        .min_by_key(|&(_, v)| v)
        .unwrap_or((0, 0));
    (a, face.get((i + 1) % k.max(1)).map_or(0, |&v| id(v)))
}

/// Appends the input number of every coarse face's point, in face order: `points` maps
/// a face's [`face_key`] (input numbers, through `order`) to its point.
pub(crate) fn push_face_points(
    lvl: &Level,
    order: &[u32],
    points: &PairMap,
    next: &mut Vec<u32>,
) -> Result<()> {
    for f in 0..lvl.nf() {
        let (a, b) = face_key(lvl.coarse.face(f), |v| order[v as usize]);
        let p = points
            .get(a, b)
            .ok_or_else(|| Error::InvalidMesh("inconsistent hierarchy (face point)".into()))?;
        next.push(p);
    }
    Ok(())
}

/// Canonicalises a recovered hierarchy (SPEC.md 8.2). `all_vertices` is the input's
/// vertex count: vertices no face uses are kept in the base mesh.
pub fn canonicalise(rec: &Recovered, gates: bool) -> Result<Canonical> {
    let finer = (0..rec.levels()).flat_map(|l| {
        rec.edge_points[l]
            .values()
            .chain(rec.face_points[l].values())
    });
    let (mut order, base) = base_numbering(&rec.base, finer, gates);
    let mut is_pole = vec![false; rec.base.nv];
    for &p in &rec.poles {
        is_pole[p as usize] = true;
    }
    // Canonical numbers: a pole keeps its number at every level.
    let pole: Vec<bool> = order.iter().map(|&o| is_pole[o as usize]).collect();
    let poles: Vec<u32> = (0..pole.len() as u32)
        .filter(|&c| pole[c as usize])
        .collect();
    let family = if poles.is_empty() {
        Family::Cc
    } else {
        Family::Polar
    };
    let mut levels: Vec<Level> = Vec::with_capacity(rec.levels());
    for l in 0..rec.levels() {
        let lvl = next_canonical_level(family, &base, levels.last(), &pole)?;
        let mut next = order.clone();
        for &[a, b] in &lvl.edges {
            let (ia, ib) = (order[a as usize], order[b as usize]);
            let p = rec.edge_points[l]
                .get(ia.min(ib), ia.max(ib))
                .ok_or_else(|| Error::InvalidMesh("inconsistent hierarchy (edge point)".into()))?;
            next.push(p);
        }
        push_face_points(&lvl, &order, &rec.face_points[l], &mut next)?;
        levels.push(lvl);
        order = next;
    }
    Ok(Canonical {
        base,
        stencils: StencilCache::new(levels.len()),
        levels,
        order,
        family,
        poles,
        stowed: 0,
    })
}

/// Checks that the finest level of a canonical hierarchy (`fine`, with `order[c]` the
/// input number of canonical vertex c) is `input`, face for face (each face once, up to
/// corner rotation).
pub(crate) fn check_matches(fine: &Topo, order: &[u32], input: &Topo) -> Result<()> {
    FaceIndex::new(input).check(fine, order, input)
}

/// The input's faces by their directed edges, to check several candidate hierarchies
/// against one input without rebuilding the table.
pub(crate) struct FaceIndex(PairMap);

impl FaceIndex {
    pub(crate) fn new(input: &Topo) -> FaceIndex {
        // One entry per face, by its face_key (a quarter of the entries of every
        // directed edge, for the memory of large meshes).
        let mut by_key = PairMap::with_capacity(input.nf() + 4);
        for f in 0..input.nf() {
            let (a, b) = face_key(input.face(f), |v| v);
            by_key.insert(a, b, f as u32);
        }
        FaceIndex(by_key)
    }

    /// [`check_matches`] with this index of `input`.
    pub(crate) fn check(&self, fine: &Topo, order: &[u32], input: &Topo) -> Result<()> {
        let mismatch = || Error::InvalidMesh("the hierarchy does not match the input".into());
        if fine.nf() != input.nf() || order.len() != input.nv {
            return Err(mismatch());
        }
        let mut hit = vec![false; input.nf()];
        for f in 0..fine.nf() {
            let c = fine.face(f);
            let k = c.len();
            let first = order[c[0] as usize];
            let (a, b) = face_key(c, |v| order[v as usize]);
            let g = self.0.get(a, b).ok_or_else(mismatch)? as usize;
            let face = input.face(g);
            let r = face.iter().position(|&v| v == first).ok_or_else(mismatch)?;
            let same = face.len() == k && (0..k).all(|i| face[(r + i) % k] == order[c[i] as usize]);
            if !same || std::mem::replace(&mut hit[g], true) {
                return Err(mismatch());
            }
        }
        Ok(())
    }
}
