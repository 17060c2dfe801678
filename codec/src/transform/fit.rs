//! The subdivision fit (SPEC.md 9.10): a Catmull-Clark hierarchy whose finest positions
//! are Catmull-Clark subdivision of a control mesh, rounded to the grid ("a subdivided
//! model"), is coded as that control mesh at `k` extra bits of precision plus, per
//! finest vertex, the difference between its value and the control mesh's subdivision,
//! computed in integers and rounded. The subdivision follows [`Rules`]: plain
//! refinement, or, as modelling tools write it (Blender's Subdivision Surface,
//! OpenSubdiv), with infinitely sharp creases and with the finest points placed on the
//! limit surface.
//!
//! The encoder finds the control mesh by least squares in floating point (any values
//! serve: the decoder only repeats the integer subdivision); the decoder runs only the
//! integer rules of [`subdivide`] and [`place_on_limit`].

use crate::error::{Error, Result};
use crate::topology::{Level, Topo, NONE};
use crate::transform::gregory::EndCaps;
use crate::transform::round_div;

/// Most extra bits of precision the control values may carry (SPEC.md 9.10).
pub const MAX_EXTRA_BITS: u8 = 16;

/// A crease sharpness of one level (SPEC.md 9.10): sharpness is in units of 2^-16 of a
/// level, as OpenSubdiv's (Blender's edge crease `c` is sharpness `10 c^2`).
pub const SHARP_ONE: u32 = 1 << 16;

/// Sharpness at or above which an edge or vertex is infinitely sharp (OpenSubdiv's 10).
pub const SHARP_INFINITE: u32 = 10 << 16;

/// A sharpness one level down (OpenSubdiv's uniform creasing): one less, at least
/// zero; infinitely sharp stays so.
pub fn decrement(s: u32) -> u32 {
    if s >= SHARP_INFINITE {
        SHARP_INFINITE
    } else {
        s.saturating_sub(SHARP_ONE)
    }
}

/// The rules a fit's subdivision follows (SPEC.md 9.10).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Rules {
    /// The finest values are placed on the limit surface (the limit masks of 9.10).
    pub limit: bool,
    /// Per base edge, its crease sharpness (0: smooth, [`SHARP_INFINITE`]: infinitely
    /// sharp); empty: no edge is creased.
    pub sharpness: Vec<u32>,
    /// Per base vertex, its crease sharpness (a vertex crease); empty: none.
    pub vertex_sharpness: Vec<u32>,
    /// Boundary vertices with one face keep their values (Blender's "Keep Corners",
    /// OpenSubdiv's sharp boundary corners).
    pub corners: bool,
    /// Every boundary vertex keeps its value, so boundaries stay piecewise linear
    /// (the UV rule Blender calls "Keep Boundaries", OpenSubdiv's linear face-varying
    /// boundaries: a UV chart's seams).
    pub linear: bool,
    /// Linear everywhere: every edge infinitely sharp and every vertex kept, so each
    /// face's values are a bilinear refinement of its corners' (the UV rule Blender
    /// calls "None", OpenSubdiv's `FVAR_LINEAR_ALL`; Blender's "Simple" subdivision).
    pub bilinear: bool,
    /// With the limit, a boundary vertex with one face (refined by the crease rule)
    /// keeps its refined value rather than the crease's limit: what Blender writes for
    /// a UV chart's corners with its UV smoothing "All" (OpenSubdiv's
    /// `FVAR_LINEAR_NONE`), whose face-varying patches take such a corner as sharp.
    pub limit_corners: bool,
    /// With the limit, `Some(e)`: `e` more levels are refined past the hierarchy's
    /// finest (by the same rules, the sharpnesses going down), and at their limit a
    /// finite sharpness left is smooth (an infinite one stays sharp); the finest
    /// vertices take their values there. OpenSubdiv's evaluation at an isolation level
    /// `e` past the levels written (Blender's Quality, 3 by default, over 1 or 2
    /// levels): the limit of semi-sharp creases as Blender writes it.
    pub extra_levels: Option<u8>,
    /// With the limit, `Some(q)`: the faces of level `q` beside an extraordinary
    /// vertex are OpenSubdiv's end-cap patches, not the limit surface (Gregory
    /// patches, [`crate::transform::gregory`]): the finest vertices inside them take
    /// the patches' values. OpenSubdiv's evaluation at isolation level `q` (Blender's
    /// Quality, 3 by default) over more levels than `q`.
    pub end_caps: Option<u8>,
}

/// Most extra levels [`Rules::extra_levels`] may refine (SPEC.md 9.10).
pub const MAX_EXTRA_LEVELS: u8 = 3;

/// Most vertices the extra levels of [`Rules::extra_levels`] may refine to (SPEC.md
/// 9.10): past it a container is refused and the encoder does not try them.
pub const MAX_EXTRA_VERTICES: usize = 1 << 22;

impl Rules {
    /// A level's sharp features under these rules, `sharp` its sharpnesses.
    pub fn hard<'a>(&self, sharp: &'a Sharpness) -> Hard<'a> {
        Hard {
            edges: &sharp.edges,
            vertices: &sharp.vertices,
            corners: self.corners,
            linear: self.linear,
            bilinear: self.bilinear,
            limit_corners: self.limit_corners,
        }
    }

    /// The base level's sharpnesses.
    pub fn base_sharpness(&self) -> Sharpness {
        Sharpness {
            edges: self.sharpness.clone(),
            vertices: self.vertex_sharpness.clone(),
        }
    }
}

/// The crease sharpnesses of one level, per edge and per vertex (each empty: all 0).
#[derive(Clone, Debug, Default)]
pub struct Sharpness {
    /// Per edge of the level.
    pub edges: Vec<u32>,
    /// Per vertex of the level.
    pub vertices: Vec<u32>,
}

impl Sharpness {
    /// The sharpnesses of `fine`, the level after `level`: both halves of every edge
    /// and every old vertex one less (9.10), the new vertices 0.
    pub fn below(&self, level: &Level, fine: &Level) -> Sharpness {
        let dec = |s: &[u32]| -> Option<Vec<u32>> {
            let d: Vec<u32> = s.iter().map(|&x| decrement(x)).collect();
            d.iter().any(|&x| x > 0).then_some(d)
        };
        let edges = dec(&self.edges).map_or_else(Vec::new, |d| tags_below(level, &d, 0, fine));
        let vertices = dec(&self.vertices).map_or_else(Vec::new, |mut d| {
            d.resize(fine.nv, 0);
            d
        });
        Sharpness { edges, vertices }
    }
}

/// A level's sharp features: its crease sharpnesses (empty: none) and which boundary
/// vertices keep their values (those with one face, or all).
#[derive(Clone, Copy, Debug)]
pub struct Hard<'a> {
    /// Per edge of the level, its sharpness.
    pub edges: &'a [u32],
    /// Per vertex of the level, its sharpness.
    pub vertices: &'a [u32],
    /// Boundary vertices with one face keep their values.
    pub corners: bool,
    /// Every boundary vertex keeps its value.
    pub linear: bool,
    /// Every edge is infinitely sharp and every vertex keeps its value.
    pub bilinear: bool,
    /// At the limit, a boundary vertex with one face keeps its value.
    pub limit_corners: bool,
}

impl Hard<'_> {
    /// The sharpness of edge `e` of `level`: a boundary edge is infinitely sharp.
    fn edge(&self, level: &Level, e: u32) -> u32 {
        if self.bilinear || level.is_boundary(e as usize) {
            SHARP_INFINITE
        } else {
            self.edges.get(e as usize).copied().unwrap_or(0)
        }
    }

    fn vertex(&self, v: usize) -> u32 {
        self.vertices.get(v).copied().unwrap_or(0)
    }
}

/// Which vertex rule of SPEC.md 9.10 coarse vertex `v` takes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum VertexRule {
    /// Exactly two sharp edges (boundary or creased), to these vertices.
    Crease([u32; 2]),
    /// No boundary edge, at most one sharp edge (a dart), at least two edges (a vertex
    /// between two faces only is smooth, as OpenSubdiv refines it) and as many face
    /// corners.
    Inside,
    /// Anything else (a corner): the value is kept.
    Kept,
}

/// The rule of vertex `v` by the sharpnesses of `hard`, or, with `child`, by those one
/// level down.
fn vertex_rule(level: &Level, v: usize, hard: Hard<'_>, child: bool) -> VertexRule {
    let now = |s: u32| if child { decrement(s) } else { s };
    // The count of sharp edges, the first two's other ends, and whether any is a boundary.
    let (mut count, mut boundary, mut ends) = (0usize, false, [0u32; 2]);
    for &e in level.v_edges(v) {
        if now(hard.edge(level, e)) > 0 {
            if count < 2 {
                ends[count] = level.other_end(e, v);
            }
            count += 1;
            boundary |= level.is_boundary(e as usize);
        }
    }
    let n = level.v_edges(v).len();
    if hard.bilinear
        || boundary && (hard.linear || hard.corners && level.v_faces(v).len() == 1)
        || now(hard.vertex(v)) > 0
    {
        return VertexRule::Kept;
    }
    match count {
        2 => VertexRule::Crease(ends),
        0 | 1 if !boundary && n >= 2 && level.v_faces(v).len() == n => VertexRule::Inside,
        _ => VertexRule::Kept,
    }
}

/// A value a mask weighs: a coarse vertex, or the face point of a face (step 1).
#[derive(Clone, Copy, Debug)]
enum Src {
    Vertex(u32),
    Face(u32),
}

/// Appends the weights of `rule` at `v` (its neighbours coarse, its faces' points) to
/// `out`; returns their denominator.
fn rule_terms(level: &Level, v: usize, rule: VertexRule, out: &mut Vec<(Src, i128)>) -> i128 {
    match rule {
        VertexRule::Crease([a, b]) => {
            out.extend([(Src::Vertex(a), 1), (Src::Vertex(v as u32), 6), (Src::Vertex(b), 1)]);
            8
        }
        VertexRule::Kept => {
            out.push((Src::Vertex(v as u32), 1));
            1
        }
        VertexRule::Inside => {
            let edges = level.v_edges(v);
            let n = edges.len() as i128;
            out.push((Src::Vertex(v as u32), n * (n - 2)));
            out.extend(edges.iter().map(|&e| (Src::Vertex(level.other_end(e, v)), 1)));
            out.extend(level.v_faces(v).iter().map(|&f| (Src::Face(f), 1)));
            n * n
        }
    }
}

/// The weights of coarse vertex `v`'s new value (step 3 of SPEC.md 9.10) into `out`
/// (cleared); returns their denominator. Where the rule one level down differs, the
/// two rules' masks are blended by OpenSubdiv's fractional weight: the mean sharpness
/// of the vertex and of its edges that are sharp now and smooth one level down (at
/// most one).
fn vertex_terms(level: &Level, v: usize, hard: Hard<'_>, out: &mut Vec<(Src, i128)>) -> i128 {
    out.clear();
    let parent = vertex_rule(level, v, hard, false);
    if parent == VertexRule::Inside {
        return rule_terms(level, v, parent, out);
    }
    let child = vertex_rule(level, v, hard, true);
    if child == parent {
        return rule_terms(level, v, parent, out);
    }
    let (mut sum, mut count) = (0i128, 0i128);
    let sharp = hard.vertex(v);
    let edges = level.v_edges(v).iter().map(|&e| hard.edge(level, e));
    for s in std::iter::once(sharp).chain(edges) {
        if s > 0 && s <= SHARP_ONE {
            sum += s as i128;
            count += 1;
        }
    }
    let full = count * SHARP_ONE as i128;
    if count == 0 {
        return rule_terms(level, v, child, out);
    }
    if sum >= full {
        return rule_terms(level, v, parent, out);
    }
    let dp = rule_terms(level, v, parent, out);
    let split = out.len();
    let dc = rule_terms(level, v, child, out);
    for (i, t) in out.iter_mut().enumerate() {
        t.1 *= if i < split { sum * dc } else { (full - sum) * dp };
    }
    dp * dc * full
}

/// The weights of edge `e`'s point (step 2 of SPEC.md 9.10) into `out` (cleared);
/// returns their denominator. Sharpness `s` of at least one level gives the midpoint,
/// 0 the smooth rule, and between, `s` of the way from the smooth point to the midpoint.
fn edge_terms(level: &Level, e: usize, hard: Hard<'_>, out: &mut Vec<(Src, i128)>) -> i128 {
    out.clear();
    let [a, b] = level.edges[e];
    let s = hard.edge(level, e as u32) as i128;
    let one = SHARP_ONE as i128;
    let [f0, f1] = level.edge_faces[e];
    if s >= one {
        out.extend([(Src::Vertex(a), 1), (Src::Vertex(b), 1)]);
        2
    } else if s == 0 {
        out.extend([
            (Src::Vertex(a), 1),
            (Src::Vertex(b), 1),
            (Src::Face(f0), 1),
            (Src::Face(f1), 1),
        ]);
        4
    } else {
        out.extend([
            (Src::Vertex(a), one + s),
            (Src::Vertex(b), one + s),
            (Src::Face(f0), one - s),
            (Src::Face(f1), one - s),
        ]);
        4 * one
    }
}

/// The two halves in `fine` (the level after `level`, `level.next()`) of `level`'s
/// edge `e`: the fine edges from each end to the edge point.
pub fn halves<'a>(level: &Level, e: usize, fine: &'a Level) -> impl Iterator<Item = u32> + 'a {
    let mid = (level.nv + e) as u32;
    level.edges[e].into_iter().filter_map(move |end| {
        fine.v_edges(end as usize)
            .iter()
            .copied()
            .find(|&h| fine.other_end(h, end as usize) == mid)
    })
}

/// Carries per-edge tags of `level` to `fine` (the level after it): both halves of each
/// edge whose tag is not `none` get its tag, every other fine edge `none`.
pub fn tags_below<T: Copy + PartialEq>(level: &Level, tags: &[T], none: T, fine: &Level) -> Vec<T> {
    let mut out = vec![none; fine.ne()];
    for (e, &t) in tags.iter().enumerate().filter(|&(_, &t)| t != none) {
        for h in halves(level, e, fine) {
            out[h as usize] = t;
        }
    }
    out
}

/// The value of weights `terms` over `d` in integers: vertices from `x`, face points
/// from `x[faces + f]`.
fn weigh(terms: &[(Src, i128)], d: i128, x: &[i64], faces: usize) -> i64 {
    let s: i128 = terms
        .iter()
        .map(|&(src, c)| {
            c * match src {
                Src::Vertex(u) => x[u as usize],
                Src::Face(f) => x[faces + f as usize],
            } as i128
        })
        .sum();
    round_div(s, d)
}

/// One Catmull-Clark refinement in integers (SPEC.md 9.10): `x` holds the coarse
/// values (`level.nv`) and gets the fine ones (`level.fine_nv()`), every rule rounded
/// with `[n / d]`; `hard` holds `level`'s crease sharpnesses and which boundary
/// vertices are kept (corners, or all with linear boundaries; a kept vertex is
/// unchanged):
/// * face point: `[sum of corners / k]`;
/// * edge point: `[(a + b + f0 + f1) / 4]` smooth, `[(a + b) / 2]` on a boundary or a
///   crease of sharpness at least one, blended between;
/// * vertex, inside, `n` edges: `[(n (n - 2) v + sum of neighbours + sum of the face
///   points of its faces) / n^2]`; with two sharp edges to `a`, `b`:
///   `[(a + 6 v + b) / 8]`; a corner unchanged; blended where the rule changes.
pub fn subdivide(level: &Level, hard: Hard<'_>, x: &mut Vec<i64>) {
    let (nv, ne) = (level.nv, level.ne());
    x.resize(level.fine_nv(), 0);
    for f in 0..level.nf() {
        let face = level.coarse.face(f);
        let s: i128 = face.iter().map(|&v| x[v as usize] as i128).sum();
        x[nv + ne + f] = round_div(s, face.len() as i128);
    }
    let mut terms = Vec::new();
    for e in 0..ne {
        let d = edge_terms(level, e, hard, &mut terms);
        x[nv + e] = weigh(&terms, d, x, nv + ne);
    }
    let moved: Vec<i64> = (0..nv)
        .map(|v| {
            let d = vertex_terms(level, v, hard, &mut terms);
            weigh(&terms, d, x, nv + ne)
        })
        .collect();
    x[..nv].copy_from_slice(&moved);
}

/// The corner of face `f` of `level` opposite vertex `v` (two places on), for a quad;
/// `None` for any other face.
fn opposite(level: &Level, f: u32, v: usize) -> Option<u32> {
    let face = level.coarse.face(f as usize);
    let i = face.iter().position(|&c| c as usize == v)?;
    (face.len() == 4).then(|| face[(i + 2) % 4])
}

/// The limit weights of vertex `v` of `level` (whose coarse mesh is the finest one),
/// as `(vertex, weight)` over a common denominator: `None` where the value is kept.
/// An edge or vertex with any sharpness left is sharp here.
fn limit_mask(level: &Level, v: usize, hard: Hard<'_>) -> Option<(Vec<(u32, i128)>, i128)> {
    match vertex_rule(level, v, hard, false) {
        // A corner of one face refined by the crease rule keeps its value at the
        // limit with `limit_corners` (Blender's UV smoothing "All").
        VertexRule::Crease(_) if hard.limit_corners && level.v_faces(v).len() == 1 => None,
        VertexRule::Crease([a, b]) => Some((vec![(a, 1), (v as u32, 4), (b, 1)], 6)),
        VertexRule::Kept => None,
        VertexRule::Inside => {
            let edges = level.v_edges(v);
            let n = edges.len() as i128;
            let mut w = Vec::with_capacity(1 + edges.len() + level.v_faces(v).len());
            w.push((v as u32, n * n));
            for &e in edges {
                w.push((level.other_end(e, v), 4));
            }
            for &f in level.v_faces(v) {
                w.push((opposite(level, f, v)?, 1));
            }
            Some((w, n * (n + 5)))
        }
    }
}

/// Places refined values on the limit surface (SPEC.md 9.10): `level` is the level
/// whose coarse mesh is the finest one (its faces quads), `hard` its sharp features.
/// Inside, a vertex of `n` edges becomes `[(n^2 v + 4 sum of neighbours + sum of the
/// opposite corners of its faces) / (n (n + 5))]`; with two sharp edges to `a`, `b`,
/// `[(a + 4 v + b) / 6]`; otherwise (or beside a face that is not a quad) it is kept.
pub fn place_on_limit(level: &Level, hard: Hard<'_>, x: &mut [i64]) {
    let placed: Vec<i64> = (0..level.nv)
        .map(|v| match limit_mask(level, v, hard) {
            Some((w, d)) => round_div(w.iter().map(|&(u, c)| c * x[u as usize] as i128).sum(), d),
            None => x[v],
        })
        .collect();
    x[..level.nv].copy_from_slice(&placed);
}

/// The whole refinement of `rules` over `levels` (coarsest first), per axis: `x` holds
/// the control values and gets the finest ones. `finest` is the level after the last
/// (`levels.last().next()`), whose coarse mesh is the finest one. An error only where
/// the extra levels would refine to more than [`MAX_EXTRA_VERTICES`].
pub fn refine(
    levels: &[Level],
    finest: &Level,
    rules: &Rules,
    x: &mut [Vec<i64>; 3],
) -> Result<()> {
    let mut sharp = rules.base_sharpness();
    let mut caps = None;
    for (i, l) in levels.iter().enumerate() {
        if caps.is_none() {
            caps = end_caps_at(rules, i, l, &mut sharp, x);
        }
        for xs in x.iter_mut() {
            subdivide(l, rules.hard(&sharp), xs);
        }
        if let Some(c) = &mut caps {
            c.below(l);
        }
        sharp = sharp.below(l, levels.get(i + 1).unwrap_or(finest));
    }
    place_finest(finest, rules, sharp, x)?;
    if let Some(c) = caps {
        c.place(&finest.coarse, x);
    }
    Ok(())
}

/// The end caps of `rules` (SPEC.md 9.10) where level `i` (`level`'s coarse mesh,
/// values `x`) is their isolation level; there every finite sharpness of `sharp` is
/// taken as 0 from then on (OpenSubdiv's patches do not refine past it), and the faces
/// at a vertex with such a sharpness, its own or an edge's, are end caps too.
pub fn end_caps_at(
    rules: &Rules,
    i: usize,
    level: &Level,
    sharp: &mut Sharpness,
    x: &[Vec<i64>; 3],
) -> Option<EndCaps> {
    let mut caps = isolated(rules, i, level, sharp)?;
    caps.values(x);
    Some(caps)
}

/// [`end_caps_at`] without values. (Never with extra levels: a header with both is
/// refused, and the encoder never makes one; the check keeps every caller to that.)
fn isolated(rules: &Rules, i: usize, level: &Level, sharp: &mut Sharpness) -> Option<EndCaps> {
    if !(rules.limit && rules.end_caps == Some(i as u8) && i > 0 && rules.extra_levels.is_none()) {
        return None;
    }
    let finite = |s: u32| s > 0 && s < SHARP_INFINITE;
    let mut semi = vec![false; level.nv];
    for (v, &s) in sharp.vertices.iter().enumerate() {
        semi[v] |= finite(s);
    }
    for (e, &s) in sharp.edges.iter().enumerate() {
        if finite(s) {
            for v in level.edges[e] {
                semi[v as usize] = true;
            }
        }
    }
    *sharp = infinite_only(sharp);
    EndCaps::new(level, rules.hard(sharp), &semi)
}

/// The levels [`Rules::extra_levels`] refines past `finest` (the level whose coarse
/// mesh is the finest one): the `e` levels after it, each the next of the one before;
/// an error where they would refine to more than [`MAX_EXTRA_VERTICES`].
pub fn extra_levels(finest: &Level, e: u8) -> Result<Vec<Level>> {
    let n = extra_vertices(finest, e);
    if n > MAX_EXTRA_VERTICES {
        return Err(Error::InvalidMesh(format!(
            "the fit's extra levels refine to {n} vertices, more than {MAX_EXTRA_VERTICES}"
        )));
    }
    let mut levels: Vec<Level> = Vec::new();
    for _ in 0..e {
        let next = levels.last().unwrap_or(finest).next();
        levels.push(next);
    }
    Ok(levels)
}

/// The vertices of the last of `e` levels refined past `finest` (the level whose
/// coarse mesh is the finest one; its own for `e = 0`), counted without making them:
/// each refinement adds a vertex per edge and per face, doubles the edges and adds one
/// per face corner, and makes a quad per corner.
pub fn extra_vertices(finest: &Level, e: u8) -> usize {
    let (mut nv, mut ne, mut nf) = (finest.nv, finest.ne(), finest.nf());
    let mut corners = finest.coarse.idx.len();
    for _ in 0..e {
        (nv, ne, nf) = (
            nv.saturating_add(ne).saturating_add(nf),
            ne.saturating_mul(2).saturating_add(corners),
            corners,
        );
        corners = nf.saturating_mul(4);
    }
    nv
}

/// The sharpnesses the limit sees past the extra levels: a finite one is smooth.
fn infinite_only(sharp: &Sharpness) -> Sharpness {
    let keep = |s: &[u32]| -> Vec<u32> {
        s.iter()
            .map(|&v| if v >= SHARP_INFINITE { v } else { 0 })
            .collect()
    };
    Sharpness {
        edges: keep(&sharp.edges),
        vertices: keep(&sharp.vertices),
    }
}

/// The finest values from those refined to `finest` (the level whose coarse mesh is
/// the finest one), `sharp` its sharpnesses: placed on the limit where `rules` say so,
/// past the extra levels where they have them (SPEC.md 9.10). An error only where the
/// extra levels would refine to more than [`MAX_EXTRA_VERTICES`].
pub fn place_finest(
    finest: &Level,
    rules: &Rules,
    mut sharp: Sharpness,
    x: &mut [Vec<i64>; 3],
) -> Result<()> {
    if !rules.limit {
        return Ok(());
    }
    let Some(e) = rules.extra_levels else {
        for xs in x.iter_mut() {
            place_on_limit(finest, rules.hard(&sharp), xs);
        }
        return Ok(());
    };
    let extra = extra_levels(finest, e)?;
    let mut now = finest;
    for next in &extra {
        for xs in x.iter_mut() {
            subdivide(now, rules.hard(&sharp), xs);
        }
        sharp = sharp.below(now, next);
        now = next;
    }
    let smooth = infinite_only(&sharp);
    for xs in x.iter_mut() {
        place_on_limit(now, rules.hard(&smooth), xs);
        xs.truncate(finest.nv);
    }
    Ok(())
}

/// A base mesh glued at its seams (SPEC.md 9.10): each listed copy identified with its
/// partner, as a file cut at its UV seams (a PLY's) was before the cut. The fit's
/// rules refine the glued mesh; each vertex of the cut mesh takes its glued vertex's
/// value.
#[derive(Clone, Debug)]
pub struct Glued {
    /// The glued base level.
    pub level: Level,
    /// Per base vertex of the cut mesh, its glued vertex.
    pub map: Vec<u32>,
}

impl Glued {
    /// Glues `base` at `pairs`, each `(copy, partner)` with `partner < copy` and the
    /// copies increasing (as the header lists them). The glued vertices are the base
    /// vertices that are no copy, in order; the faces keep their order. An error where
    /// the glued mesh is not one Catmull-Clark refines (a face with a repeated corner,
    /// an edge with more than two faces or with one face twice).
    pub fn new(base: &Topo, pairs: &[(u32, u32)]) -> Result<Glued> {
        let nv = base.nv;
        let mut rep: Vec<u32> = (0..nv as u32).collect();
        for &(c, p) in pairs {
            // Copies increase and partners precede them: rep[p] is final.
            rep[c as usize] = rep[p as usize];
        }
        let mut id = vec![NONE; nv];
        let mut n = 0u32;
        for v in 0..nv {
            if rep[v] == v as u32 {
                id[v] = n;
                n += 1;
            }
        }
        let map: Vec<u32> = rep.iter().map(|&r| id[r as usize]).collect();
        let mut topo = Topo::new(n as usize);
        topo.starts = base.starts.clone();
        topo.idx = base.idx.iter().map(|&v| map[v as usize]).collect();
        let level = Level::new(&topo)
            .map_err(|e| Error::InvalidMesh(format!("the mesh glued at its seams: {e}")))?;
        if level.edge_faces.iter().any(|f| f[0] == f[1]) {
            return Err(Error::InvalidMesh(
                "the mesh glued at its seams has a face on both sides of an edge".into(),
            ));
        }
        Ok(Glued { level, map })
    }

    /// The control values of the glued vertices from those of the cut base mesh: each
    /// glued vertex takes the value of the first base vertex glued into it.
    pub fn gather(&self, x: &[i64]) -> Vec<i64> {
        gather(&self.map, self.level.nv, x)
    }
}

/// The values of `n` glued vertices from those of the cut vertices, `map` the glued
/// vertex of each: each takes the value of the first cut vertex glued into it.
pub fn gather(map: &[u32], n: usize, x: &[i64]) -> Vec<i64> {
    let mut out = vec![0; n];
    let mut seen = vec![false; n];
    for (&g, &v) in map.iter().zip(x) {
        if !std::mem::replace(&mut seen[g as usize], true) {
            out[g as usize] = v;
        }
    }
    out
}

/// The values of the cut vertices from those of the glued ones, `map` the glued
/// vertex of each.
pub fn spread(map: &[u32], x: &[i64]) -> Vec<i64> {
    map.iter().map(|&g| x[g as usize]).collect()
}

/// The glued vertex of each vertex of `cut.next()` (the level after `cut`), from
/// `map`, the glued vertex of each of `cut`'s: `glued` is the glued mesh's level of
/// the same faces. Old vertices keep theirs, an edge point takes that of the glued
/// edge in the same place of the same face, a face point its face's.
pub fn glued_below(cut: &Level, glued: &Level, map: &[u32]) -> Vec<u32> {
    let mut edge = vec![0u32; cut.ne()];
    for (&e, &g) in cut.face_edges.iter().zip(&glued.face_edges) {
        edge[e as usize] = g;
    }
    let (nv, ne) = (glued.nv as u32, glued.ne() as u32);
    let mut out = Vec::with_capacity(cut.fine_nv());
    out.extend_from_slice(map);
    out.extend(edge.iter().map(|&g| nv + g));
    out.extend((0..cut.nf() as u32).map(|f| nv + ne + f));
    out
}

/// The same refinement in floating point, without rounding, as a linear map: the
/// weights of fine vertex `i` on coarse vertices, as `(coarse, weight)` rows.
fn rows(level: &Level, hard: Hard<'_>) -> Vec<Vec<(u32, f64)>> {
    let (nv, ne) = (level.nv, level.ne());
    let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); level.fine_nv()];
    for f in 0..level.nf() {
        let face = level.coarse.face(f);
        let w = 1.0 / face.len() as f64;
        rows[nv + ne + f] = face.iter().map(|&v| (v, w)).collect();
    }
    let expand = |rows: &[Vec<(u32, f64)>], terms: &[(Src, i128)], d: i128| {
        let len = terms.iter().map(|&(src, _)| match src {
            Src::Vertex(_) => 1,
            Src::Face(f) => rows[nv + ne + f as usize].len(),
        });
        let mut r = Vec::with_capacity(len.sum());
        for &(src, c) in terms {
            let w = c as f64 / d as f64;
            match src {
                Src::Vertex(u) => r.push((u, w)),
                Src::Face(f) => r.extend(rows[nv + ne + f as usize].iter().map(|&(u, x)| (u, w * x))),
            }
        }
        r
    };
    let mut terms = Vec::new();
    for e in 0..ne {
        let d = edge_terms(level, e, hard, &mut terms);
        let r = expand(&rows, &terms, d);
        rows[nv + e] = r;
    }
    for v in 0..nv {
        let d = vertex_terms(level, v, hard, &mut terms);
        let r = expand(&rows, &terms, d);
        rows[v] = r;
    }
    rows
}

/// One level's weights in compressed rows.
struct Csr {
    starts: Vec<u32>,
    cols: Vec<u32>,
    weights: Vec<f64>,
    coarse: usize,
}

/// The share of its starting value (squared) at which the normal equations' residual
/// counts as solved in [`Operator::fit`] (a residual norm 10^-12 of the start's).
const SOLVED: f64 = 1e-24;

/// What building an [`Operator`] costs, in applications ([`Operator::work`]): with
/// callgrind, in the encoder's crease search on `corpus/two_components_cc2.obj`, a
/// build took 2.6 M instructions on average and an application 0.16 M.
const BUILD_APPLICATIONS: u64 = 16;

/// The linear map from control values to finest values, level by level.
pub struct Operator {
    levels: Vec<Csr>,
    /// The weights applied so far ([`Operator::work`]).
    work: std::cell::Cell<u64>,
}

impl Operator {
    /// The composed refinement of `rules` over `levels` (coarsest first), `finest` the
    /// level after the last.
    pub fn new(levels: &[Level], finest: &Level, rules: &Rules) -> Operator {
        let csr = |rows: Vec<Vec<(u32, f64)>>, coarse: usize| {
            let n = rows.iter().map(Vec::len).sum();
            let mut m = Csr {
                starts: Vec::with_capacity(rows.len() + 1),
                cols: Vec::with_capacity(n),
                weights: Vec::with_capacity(n),
                coarse,
            };
            m.starts.push(0);
            for row in rows {
                for (c, w) in row {
                    m.cols.push(c);
                    m.weights.push(w);
                }
                m.starts.push(m.cols.len() as u32);
            }
            m
        };
        let mut out = Vec::with_capacity(levels.len() + 2);
        let mut sharp = rules.base_sharpness();
        // The end caps and the vertices of their level, whose values every level after
        // it carries past its own (`from` the first carried one's column).
        let mut caps: Option<(EndCaps, usize)> = None;
        let carry = |rows: &mut Vec<Vec<(u32, f64)>>, from: usize, n: usize| {
            rows.extend((0..n).map(|j| vec![((from + j) as u32, 1.0)]));
        };
        for (i, l) in levels.iter().enumerate() {
            // Until the end caps' level: whether this level makes them.
            let fresh = caps.is_none();
            if fresh {
                caps = isolated(rules, i, l, &mut sharp).map(|c| (c, l.nv));
            }
            let mut r = rows(l, rules.hard(&sharp));
            let mut coarse = l.nv;
            if fresh {
                if let Some((_, nq)) = caps {
                    carry(&mut r, 0, nq);
                }
            } else if let Some((_, nq)) = caps {
                carry(&mut r, l.nv, nq);
                coarse += nq;
            }
            if let Some((c, _)) = &mut caps {
                c.below(l);
            }
            out.push(csr(r, coarse));
            sharp = sharp.below(l, levels.get(i + 1).unwrap_or(finest));
        }
        if rules.limit {
            // Every one of `n` values kept (`carry`'s rows from column 0); a row's
            // columns moved past `n` others.
            let identity = |n: usize| {
                let mut r = Vec::with_capacity(n);
                carry(&mut r, 0, n);
                r
            };
            let shifted = |row: Vec<(u32, f64)>, n: usize| -> Vec<(u32, f64)> {
                row.into_iter().map(|(u, w)| (n as u32 + u, w)).collect()
            };
            let limit_rows = |level: &Level, hard: Hard<'_>| -> Vec<Vec<(u32, f64)>> {
                (0..level.nv)
                    .map(|v| match limit_mask(level, v, hard) {
                        Some((w, d)) => {
                            w.iter().map(|&(u, c)| (u, c as f64 / d as f64)).collect()
                        }
                        None => vec![(v as u32, 1.0)],
                    })
                    .collect()
            };
            match rules.extra_levels {
                None => match caps {
                    None => out.push(csr(limit_rows(finest, rules.hard(&sharp)), finest.nv)),
                    Some((c, nq)) => {
                        let n = finest.nv;
                        let mut r = limit_rows(finest, rules.hard(&sharp));
                        carry(&mut r, n, nq);
                        out.push(csr(r, n + nq));
                        // The finest values and the end caps' points from the values
                        // carried; then the finest values: the limit's, or the end
                        // caps' from their points.
                        let (points, vertices) = c.rows(&finest.coarse);
                        let np = points.len();
                        let mut r = identity(n);
                        r.extend(points.into_iter().map(|row| shifted(row, n)));
                        out.push(csr(r, n + nq));
                        let mut r = identity(n);
                        for (v, row) in vertices {
                            r[v] = shifted(row, n);
                        }
                        out.push(csr(r, n + np));
                    }
                },
                Some(e) => {
                    // (Callers keep extra levels within the bound: `extra_vertices`.)
                    let extra = extra_levels(finest, e).expect("extra levels within the bound");
                    let mut now = finest;
                    for next in &extra {
                        out.push(csr(rows(now, rules.hard(&sharp)), now.nv));
                        sharp = sharp.below(now, next);
                        now = next;
                    }
                    out.push(csr(limit_rows(now, rules.hard(&infinite_only(&sharp))), now.nv));
                    // The finest vertices' values: the first of the last level's.
                    out.push(csr(identity(finest.nv), now.nv));
                }
            }
        }
        let op = Operator {
            levels: out,
            work: std::cell::Cell::new(0),
        };
        op.charge(BUILD_APPLICATIONS);
        op
    }

    /// The operator's weights: one application's multiply-adds per axis.
    pub fn weights(&self) -> u64 {
        self.levels.iter().map(|m| m.cols.len() as u64).sum()
    }

    /// The work done with this operator: its building and every application (and
    /// transpose) so far, in weights applied ([`Operator::weights`] each). A measure
    /// of the time the encoder's searches take that is the same on every machine.
    pub fn work(&self) -> u64 {
        self.work.get()
    }

    fn charge(&self, applications: u64) {
        self.work
            .set(self.work.get() + applications * self.weights());
    }

    /// Finest values from control values (three axes at once).
    pub fn apply(&self, base: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.charge(1);
        // (Two buffers, each level read from one into the other.)
        let mut x = base.to_vec();
        let mut y = Vec::new();
        for m in &self.levels {
            y.clear();
            y.extend(m.starts.windows(2).map(|s| {
                let (a, b) = (s[0] as usize, s[1] as usize);
                let mut acc = [0.0; 3];
                for (&c, &w) in m.cols[a..b].iter().zip(&m.weights[a..b]) {
                    let v = x[c as usize];
                    for k in 0..3 {
                        acc[k] += w * v[k];
                    }
                }
                acc
            }));
            std::mem::swap(&mut x, &mut y);
        }
        x
    }

    /// The transpose: control-sized values from finest-sized ones.
    pub fn apply_t(&self, fine: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.charge(1);
        let mut y = fine.to_vec();
        let mut z = Vec::new();
        for m in self.levels.iter().rev() {
            z.clear();
            z.resize(m.coarse, [0.0; 3]);
            for (s, yi) in m.starts.windows(2).zip(&y) {
                let (a, b) = (s[0] as usize, s[1] as usize);
                for (&c, &w) in m.cols[a..b].iter().zip(&m.weights[a..b]) {
                    let t = &mut z[c as usize];
                    for k in 0..3 {
                        t[k] += w * yi[k];
                    }
                }
            }
            std::mem::swap(&mut y, &mut z);
        }
        y
    }

    /// The control values whose refinement is nearest `fine` in least squares, each
    /// axis on its own (conjugate gradients on the normal equations, from `start`),
    /// stopping after `iterations` or once no value moves by more than `tolerance`;
    /// finest vertices where `ignored` is set (if any) do not count.
    pub fn fit(
        &self,
        fine: &[[f64; 3]],
        start: &[[f64; 3]],
        ignored: &[bool],
        iterations: usize,
        tolerance: f64,
    ) -> Vec<[f64; 3]> {
        // A^T W v, W zero at the ignored vertices.
        let apply_tw = |mut v: Vec<[f64; 3]>| {
            for (x, _) in v.iter_mut().zip(ignored).filter(|(_, &i)| i) {
                *x = [0.0; 3];
            }
            self.apply_t(&v)
        };
        let dot = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            let mut s = [0.0; 3];
            for (u, v) in a.iter().zip(b) {
                for k in 0..3 {
                    s[k] += u[k] * v[k];
                }
            }
            s
        };
        let mut b = start.to_vec();
        let ab = self.apply(&b);
        let resid: Vec<[f64; 3]> = fine
            .iter()
            .zip(&ab)
            .map(|(y, p)| std::array::from_fn(|k| y[k] - p[k]))
            .collect();
        let mut r = apply_tw(resid);
        let mut p = r.clone();
        let mut rr = dot(&r, &r);
        // The normal equations' residual at which an axis is solved: past it, on
        // values a refinement fits exactly, the search directions are rounding noise
        // and a step along one can throw the values far off.
        let solved = rr.map(|r0| r0 * SOLVED);
        // Axes still iterating.
        let mut live = [true; 3];
        for _ in 0..iterations {
            for k in 0..3 {
                live[k] &= rr[k] > solved[k] && rr[k] > 0.0;
            }
            if !live.contains(&true) {
                break;
            }
            let q = apply_tw(self.apply(&p));
            let pq = dot(&p, &q);
            let mut alpha = [0.0; 3];
            for k in 0..3 {
                live[k] &= pq[k] > 0.0 && pq[k].is_finite();
                if live[k] {
                    alpha[k] = rr[k] / pq[k];
                }
            }
            let mut moved = [0.0f64; 3];
            for i in 0..b.len() {
                for k in 0..3 {
                    b[i][k] += alpha[k] * p[i][k];
                    r[i][k] -= alpha[k] * q[i][k];
                    moved[k] = moved[k].max((alpha[k] * p[i][k]).abs());
                }
            }
            let rr2 = dot(&r, &r);
            for k in 0..3 {
                live[k] &= moved[k] >= tolerance;
                let beta = if live[k] { rr2[k] / rr[k] } else { 0.0 };
                rr[k] = rr2[k];
                for pi in p.iter_mut().zip(&r) {
                    pi.0[k] = if live[k] {
                        pi.1[k] + beta * pi.0[k]
                    } else {
                        0.0
                    };
                }
            }
        }
        b
    }
}

/// How far a level's fine values are from any plain Catmull-Clark refinement: the mean
/// square, over inner quads, of a combination of fine values that refinement makes
/// zero (up to rounding). Per quad (a, b, c, d) with edge points E and face points F on
/// either side of each edge, `a + b = 4 E_ab - F - F'`, so `(a + b) + (c + d) = 4 F`.
/// About 4 for rounded subdivision, large for fitted detail; `None` without such quads.
pub fn defect(level: &Level, x: &[i64]) -> Option<f64> {
    let (nv, ne) = (level.nv, level.ne());
    let fp = |f: u32| x[nv + ne + f as usize] as f64;
    let side = |e: u32| {
        let [f0, f1] = level.edge_faces[e as usize];
        4.0 * x[nv + e as usize] as f64 - fp(f0) - fp(f1)
    };
    let (mut sum, mut n) = (0.0, 0usize);
    for f in 0..level.nf() {
        let es = level.f_edges(f);
        if es.len() != 4 || es.iter().any(|&e| level.is_boundary(e as usize)) {
            continue;
        }
        for pair in [[es[0], es[2]], [es[1], es[3]]] {
            let d = side(pair[0]) + side(pair[1]) - 4.0 * fp(f as u32);
            sum += d * d;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// How far the finest values are from any Catmull-Clark surface, refined or on the
/// limit: the median, over runs of five finest vertices along a line through regular
/// (four-edge, four-quad, inside) vertices within the closed domain of one level-1
/// face, of the square of the run's fourth difference `x0 - 4 x1 + 6 x2 - 4 x3 + x4`.
/// Inside a regular patch the surface is a bicubic, so both its refined control points
/// and its limit points make cubic runs whose fourth difference is only the rounding's
/// (about 70 / 12 in variance, a median square near 3); detail makes it far larger.
/// `levels` is the hierarchy, `finest` the level after its last; `None` without such
/// runs (fewer than three levels). (The encoder finds the runs once for every axis,
/// [`Runs`].)
#[cfg(test)]
pub fn roughness(levels: &[Level], finest: &Level, x: &[i64]) -> Option<f64> {
    Runs::new(levels, finest)?.roughness(x)
}

/// The runs `roughness` measures, found once for every axis.
pub struct Runs(Vec<[usize; 5]>);

impl Runs {
    /// The runs of five finest vertices of `finest`, the level after the hierarchy
    /// `levels`' last (at most about 40,000: a sample of vertices); `None` without any.
    pub fn new(levels: &[Level], finest: &Level) -> Option<Runs> {
        let runs = five_runs(levels, finest)?;
        (!runs.is_empty()).then_some(Runs(runs))
    }

    /// `roughness` of the values `x`.
    pub fn roughness(&self, x: &[i64]) -> Option<f64> {
        let mut squares: Vec<f64> = self
            .0
            .iter()
            .map(|r| {
                let d = [1i128, -4, 6, -4, 1]
                    .iter()
                    .zip(r)
                    .map(|(&c, &v)| c * x[v] as i128)
                    .sum::<i128>() as f64;
                d * d
            })
            .collect();
        if squares.is_empty() {
            return None;
        }
        let mid = squares.len() / 2;
        Some(*squares.select_nth_unstable_by(mid, f64::total_cmp).1)
    }
}

/// The runs of [`Runs::new`]; `None` without a level.
fn five_runs(levels: &[Level], finest: &Level) -> Option<Vec<[usize; 5]>> {
    // The level-1 face each finest face lies in (faces are numbered by their coarse
    // face's corners, SPEC.md 8.1).
    let mut piece: Vec<u32> = (0..levels.first()?.coarse.idx.len() as u32).collect();
    for l in &levels[1..] {
        let mut next = vec![0u32; l.coarse.idx.len()];
        for (f, &p) in piece.iter().enumerate() {
            let (a, b) = (l.coarse.starts[f] as usize, l.coarse.starts[f + 1] as usize);
            next[a..b].fill(p);
        }
        piece = next;
    }
    let in_piece = |v: usize, p: u32| finest.v_faces(v).iter().any(|&f| piece[f as usize] == p);
    let regular = |v: usize| {
        finest.v_edges(v).len() == 4
            && finest.v_faces(v).len() == 4
            && finest.v_edges(v).iter().all(|&e| !finest.is_boundary(e as usize))
    };
    // The edge of regular vertex v that shares no face with its edge e, and its end.
    let beyond = |v: usize, e: u32| -> Option<(u32, usize)> {
        let faces = finest.edge_faces[e as usize];
        let o = *finest.v_edges(v).iter().find(|&&o| {
            o != e && finest.edge_faces[o as usize].iter().all(|f| !faces.contains(f))
        })?;
        Some((o, finest.other_end(o, v) as usize))
    };
    let step = (finest.nv / 20_000).max(1);
    let mut runs = Vec::new();
    for v2 in (0..finest.nv).step_by(step).filter(|&v| regular(v)) {
        for &e in &finest.v_edges(v2)[..2] {
            let run = (|| {
                let v1 = finest.other_end(e, v2) as usize;
                let (e3, v3) = beyond(v2, e)?;
                if !regular(v1) || !regular(v3) {
                    return None;
                }
                let (_, v0) = beyond(v1, e)?;
                let (_, v4) = beyond(v3, e3)?;
                let run = [v0, v1, v2, v3, v4];
                finest.v_faces(v2).iter().any(|&f| {
                    run.iter().all(|&v| in_piece(v, piece[f as usize]))
                }).then_some(run)
            })();
            runs.extend(run);
        }
    }
    Some(runs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topo;

    /// A closed base (a cube with one face split into two triangles, one corner of
    /// valence 4) and an open one (a 3 x 2 grid), refined `n` times.
    fn hierarchies(n: usize) -> Vec<Vec<Level>> {
        let mut cube = Topo::new(8);
        for f in [
            [0u32, 1, 3, 2].as_slice(),
            &[4, 6, 7, 5],
            &[0, 4, 5, 1],
            &[2, 3, 7, 6],
            &[0, 2, 6],
            &[0, 6, 4],
            &[1, 5, 7, 3],
        ] {
            cube.push(f);
        }
        let mut grid = Topo::new(12);
        for y in 0..2u32 {
            for x in 0..3u32 {
                let v = y * 4 + x;
                grid.push(&[v, v + 1, v + 5, v + 4]);
            }
        }
        [cube, grid]
            .into_iter()
            .map(|mut t| {
                let mut levels = Vec::new();
                for _ in 0..n {
                    let l = Level::new(&t).unwrap();
                    t = l.fine();
                    levels.push(l);
                }
                levels
            })
            .collect()
    }

    fn values(n: usize, seed: u64) -> Vec<i64> {
        crate::topology::fixtures::pseudo(seed, n, 21)
    }

    fn triples(v: &[i64]) -> Vec<[f64; 3]> {
        v.chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect()
    }

    /// Every rule set of a hierarchy: plain, limit, creases (the base mesh's first
    /// face's edges) infinitely sharp, semi-sharp (1.7 and 0.4 levels, and a vertex
    /// crease of 0.6 at the first face's first corner), each with and without the limit;
    /// and linear everywhere, the limit with corners kept at it, the limit one
    /// extra level down (creases of 2.7 levels, the vertex crease), and the limit with
    /// end caps from level 1, smooth and with the infinitely sharp creases.
    fn rule_sets(levels: &[Level]) -> Vec<Rules> {
        let first = levels[0].f_edges(0).to_vec();
        let crease = |s: u32| -> Vec<u32> {
            (0..levels[0].ne() as u32)
                .map(|e| if first.contains(&e) { s } else { 0 })
                .collect()
        };
        let mut corner = vec![0; levels[0].nv];
        corner[levels[0].coarse.face(0)[0] as usize] = SHARP_ONE * 3 / 5;
        let sharp = [
            (Vec::new(), Vec::new()),
            (crease(SHARP_INFINITE), Vec::new()),
            (crease(SHARP_ONE * 17 / 10), Vec::new()),
            (crease(SHARP_ONE * 2 / 5), corner.clone()),
        ];
        [false, true]
            .into_iter()
            .flat_map(|limit| {
                sharp.clone().into_iter().map(move |(sharpness, vertex_sharpness)| Rules {
                    limit,
                    sharpness,
                    vertex_sharpness,
                    ..Rules::default()
                })
            })
            .chain([
                Rules {
                    bilinear: true,
                    ..Rules::default()
                },
                Rules {
                    limit: true,
                    limit_corners: true,
                    ..Rules::default()
                },
                Rules {
                    limit: true,
                    sharpness: crease(SHARP_ONE * 27 / 10),
                    vertex_sharpness: corner.clone(),
                    extra_levels: Some(1),
                    ..Rules::default()
                },
                Rules {
                    limit: true,
                    end_caps: Some(1),
                    ..Rules::default()
                },
                Rules {
                    limit: true,
                    sharpness: crease(SHARP_INFINITE),
                    end_caps: Some(1),
                    ..Rules::default()
                },
            ])
            .collect()
    }

    #[test]
    fn the_transpose_is_the_transpose() {
        for levels in hierarchies(2) {
            let finest = levels.last().unwrap().next();
            for rules in rule_sets(&levels) {
                let op = Operator::new(&levels, &finest, &rules);
                let nb = levels[0].nv;
                let nf = levels.last().unwrap().fine_nv();
                let b = triples(&values(3 * nb, 1));
                let y = triples(&values(3 * nf, 2));
                for k in 0..3 {
                    let ab: f64 = op.apply(&b).iter().zip(&y).map(|(a, b)| a[k] * b[k]).sum();
                    let bt: f64 = b.iter().zip(op.apply_t(&y)).map(|(a, b)| a[k] * b[k]).sum();
                    assert!((ab - bt).abs() <= 1e-9 * ab.abs().max(1.0), "{ab} {bt}");
                }
            }
        }
    }

    #[test]
    fn integer_refinement_follows_the_linear_map() {
        // The rounded refinement stays within a unit per level of the exact one, so
        // the integer rules and the weights the encoder fits with agree, for every
        // rule set; and the rule sets differ.
        for levels in hierarchies(3) {
            let finest = levels.last().unwrap().next();
            let b = values(3 * levels[0].nv, 3);
            let mut outputs = Vec::new();
            let sets = rule_sets(&levels);
            for rules in &sets {
                let op = Operator::new(&levels, &finest, rules);
                let exact = op.apply(&triples(&b));
                let mut x: [Vec<i64>; 3] =
                    std::array::from_fn(|k| b.iter().skip(k).step_by(3).copied().collect());
                refine(&levels, &finest, rules, &mut x).unwrap();
                for k in 0..3 {
                    assert_eq!(x[k].len(), exact.len());
                    for (i, (&a, e)) in x[k].iter().zip(&exact).enumerate() {
                        assert!(
                            (a as f64 - e[k]).abs() <= 4.0,
                            "{rules:?} vertex {i}: {a} vs {}",
                            e[k]
                        );
                    }
                }
                outputs.push(x);
            }
            // (Corners kept at the limit change only boundary vertices of one face,
            // which a closed hierarchy does not have.)
            let closed = (0..levels[0].nv).all(|v| levels[0].v_faces(v).len() > 1);
            for i in 0..outputs.len() {
                for j in 0..i {
                    if closed && (sets[i].limit_corners || sets[j].limit_corners) {
                        continue;
                    }
                    // (End caps change only faces beside extraordinary vertices inside,
                    // which the open grid does not have.)
                    if !closed && (sets[i].end_caps.is_some() || sets[j].end_caps.is_some()) {
                        continue;
                    }
                    assert_ne!(outputs[i], outputs[j], "rule sets {j} and {i}");
                }
            }
        }
    }

    #[test]
    fn extra_levels_are_counted_and_bounded() {
        // The count without making the levels is the count of the levels made; past
        // the bound the levels are refused before any is made.
        for levels in hierarchies(2) {
            let finest = levels.last().unwrap().next();
            for e in 0..=2u8 {
                let made = extra_levels(&finest, e).unwrap();
                assert_eq!(made.last().unwrap_or(&finest).nv, extra_vertices(&finest, e));
            }
        }
        let mut grid = Topo::new(301 * 301);
        for y in 0..300u32 {
            for x in 0..300u32 {
                let v = y * 301 + x;
                grid.push(&[v, v + 1, v + 302, v + 301]);
            }
        }
        let level = Level::new(&grid).unwrap();
        assert!(extra_vertices(&level, 2) <= MAX_EXTRA_VERTICES);
        assert!(extra_vertices(&level, 3) > MAX_EXTRA_VERTICES);
        let e = extra_levels(&level, 3).map(|l| l.len()).unwrap_err();
        assert!(e.to_string().contains("extra levels"), "{e}");
    }

    #[test]
    fn least_squares_recovers_the_control_values() {
        for levels in hierarchies(2) {
            let finest = levels.last().unwrap().next();
            for rules in rule_sets(&levels) {
                let op = Operator::new(&levels, &finest, &rules);
                let b = triples(&values(3 * levels[0].nv, 4));
                let y = op.apply(&b);
                let start = vec![[0.0; 3]; b.len()];
                let got = op.fit(&y, &start, &[], 400, 1e-9);
                for (g, w) in got.iter().zip(&b) {
                    for k in 0..3 {
                        assert!((g[k] - w[k]).abs() < 1e-3, "{rules:?}: {g:?} vs {w:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_converged_fit_stays_put() {
        // An 8-sided cylinder with octagonal caps as Blender makes it, on the limit
        // after four levels, rounded to a 1e-6 grid, fitted from its base vertices'
        // finest values as the encoder starts: the control values come back within
        // the rounding. (Blender's own export of it, fitted in the order its file
        // keeps, once stepped along a direction of rounding noise after converging
        // and came back 10^21 off; the fit now stops where the normal equations'
        // residual is 10^-12 of its start.)
        let mut base = Topo::new(16);
        for i in 0..8u32 {
            let j = (i + 1) % 8;
            base.push(&[i, j, j + 8, i + 8]);
        }
        base.push(&(0..8u32).rev().collect::<Vec<_>>());
        base.push(&(8..16u32).collect::<Vec<_>>());
        let mut levels = Vec::new();
        let mut t = base;
        for _ in 0..4 {
            let l = Level::new(&t).unwrap();
            t = l.fine();
            levels.push(l);
        }
        let finest = levels.last().unwrap().next();
        let b: Vec<[f64; 3]> = (0..16)
            .map(|i| {
                let a = std::f64::consts::PI * (i % 8) as f64 / 4.0;
                let z = if i < 8 { -800_000.0 } else { 800_000.0 };
                [(600_000.0 * a.cos()).round(), (600_000.0 * a.sin()).round(), z]
            })
            .collect();
        let rules = Rules {
            limit: true,
            ..Rules::default()
        };
        let op = Operator::new(&levels, &finest, &rules);
        let y: Vec<[f64; 3]> = op.apply(&b).iter().map(|v| v.map(f64::round)).collect();
        let got = op.fit(&y, &y[..16], &[], 400, 1e-5);
        for (g, w) in got.iter().zip(&b) {
            for k in 0..3 {
                assert!((g[k] - w[k]).abs() < 1.0, "{g:?} vs {w:?}");
            }
        }
    }

    #[test]
    fn ignored_vertices_do_not_pull_the_fit() {
        // A refinement with a few values moved far: fitted without them, the control
        // values come back; with them, they do not.
        let levels = hierarchies(2).remove(0);
        let finest = levels.last().unwrap().next();
        let op = Operator::new(&levels, &finest, &Rules::default());
        let b = triples(&values(3 * levels[0].nv, 4));
        let mut y = op.apply(&b);
        let mut ignored = vec![false; y.len()];
        for i in [3, 40, 77] {
            y[i][0] += 1e6;
            ignored[i] = true;
        }
        let start = vec![[0.0; 3]; b.len()];
        let near = |got: &[[f64; 3]]| got.iter().zip(&b).all(|(g, w)| (g[0] - w[0]).abs() < 1e-3);
        assert!(near(&op.fit(&y, &start, &ignored, 400, 1e-9)));
        assert!(!near(&op.fit(&y, &start, &[], 400, 1e-9)));
    }

    #[test]
    fn the_roughness_of_a_rounded_surface_is_small_and_of_detail_large() {
        // The open grid's hierarchy has runs of regular vertices; plain and limit
        // surfaces alike are cubic along them.
        let levels = hierarchies(3).remove(1);
        let finest = levels.last().unwrap().next();
        for rules in [Rules::default(), Rules {
            limit: true,
            ..Rules::default()
        }] {
            let b = values(3 * levels[0].nv, 5);
            let mut x: [Vec<i64>; 3] =
                std::array::from_fn(|k| b.iter().skip(k).step_by(3).copied().collect());
            refine(&levels, &finest, &rules, &mut x).unwrap();
            let r = roughness(&levels, &finest, &x[0]).unwrap();
            assert!(r < 16.0, "{rules:?}: {r}");
            let noise = values(x[0].len(), 6);
            for (v, n) in x[0].iter_mut().zip(noise) {
                *v += n / 1000;
            }
            assert!(roughness(&levels, &finest, &x[0]).unwrap() > 1000.0);
        }
    }

    #[test]
    fn the_defect_of_a_rounded_refinement_is_small_and_of_detail_large() {
        for levels in hierarchies(3) {
            let mut x = values(levels[0].nv, 5);
            let last = levels.last().unwrap();
            for l in &levels {
                subdivide(
                    l,
                    Hard {
                        edges: &[],
                        vertices: &[],
                        corners: false,
                        linear: false,
                        bilinear: false,
                        limit_corners: false,
                    },
                    &mut x,
                );
            }
            let d = defect(last, &x).unwrap();
            assert!(d < 12.0, "{d}");
            let noise = values(x.len(), 6);
            for (v, n) in x.iter_mut().zip(noise) {
                *v += n / 1000;
            }
            assert!(defect(last, &x).unwrap() > 1000.0);
        }
    }
}
