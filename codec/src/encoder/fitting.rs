//! The encoder's subdivision fit (not part of the format beyond SPEC.md 9.10): which
//! rules a subdivided model follows, its control mesh by least squares, and the
//! precision that codes it smallest.

use super::*;
use crate::topology::Level;
use crate::transform::fit::Rules;
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Mean [`fit::defect`] over the axes of the finest level above which `auto` does not
/// try the fit, unless [`ROUGH_SCREEN`] lets it: rounded subdivision gives about 70 /
/// 12 (the variance of the rounding noise it sums), fitted detail far more.
pub(crate) const FIT_SCREEN: f64 = 12.0;

/// Mean `fit::roughness` over the axes of the finest level above which `auto` does
/// not try the fit, unless [`FIT_SCREEN`] lets it: a rounded subdivision surface
/// (refined or on the limit) gives about 3 in its regular patches, Blender's limit
/// surfaces 1 to 3, detail hundreds and more.
pub(crate) const ROUGH_SCREEN: f64 = 16.0;

/// The least-squares fit stops when no control value moves by more than this (units of
/// the grid): far below the 2^-10 of the finest precision tried.
pub(crate) const FIT_TOLERANCE: f64 = 1e-5;

/// Extra bits `auto` tries for the fit's control values.
pub(crate) const FIT_BITS: [u8; 3] = [6, 8, 10];

/// Codes a Catmull-Clark hierarchy as a subdivision fit (SPEC.md 9.10): the control
/// values from least squares, then for each precision in `bits` the integer subdivision
/// and the residuals; the smallest coding (B = 0 when no precision in `bits` keeps the
/// values in range). `None` when `screen` is set and the finest level is far from any
/// subdivision. The rule sets' fits run on up to `threads` threads at once; the result
/// is the same for every count.
pub(crate) fn code_fit(
    canon: &Canonical,
    pos: &[Vec<i64>; 3],
    header: &Header,
    bits: &[u8],
    screen: bool,
    finest: Option<Level>,
    threads: usize,
) -> Option<Payloads> {
    if !canon.poles.is_empty() {
        return None;
    }
    // The level whose coarse mesh is the finest one (`finest` where made).
    let finest = match finest {
        Some(f) => f,
        None => canon.levels.last()?.next(),
    };
    let budget = Budget::new(&finest);
    let mut target = Target {
        canon,
        pos,
        finest: &finest,
        glued: None,
        budget: &budget,
        threads: threads.max(1),
    };
    let cut = search(&target, header, bits, screen);
    // Where the mesh is cut at seams, the search again on it glued (the cut codes
    // smaller where the seams follow creases: its pieces have their own control
    // values along them).
    let Some(g) = glue_seams(canon, pos) else {
        return cut;
    };
    target.glued = Some(&g);
    let glued = search(&target, header, bits, screen);
    match (cut, glued) {
        (Some(c), Some(g)) => Some(if g.size() < c.size() { g } else { c }),
        (c, g) => c.or(g),
    }
}

/// The fit's search for `target`, on its hierarchy or, where it has one, the same
/// glued at its seams: as [`code_fit`].
fn search(target: &Target<'_>, header: &Header, bits: &[u8], screen: bool) -> Option<Payloads> {
    let (canon, pos, finest) = match target.glued {
        Some(g) => (&g.canon, &g.pos, &g.finest),
        None => (target.canon, target.pos, target.finest),
    };
    if canon.levels.is_empty() {
        return None;
    }
    let mut sets = None;
    if screen {
        match screened(canon, pos, finest) {
            Screen::Open => {}
            Screen::Away => return None,
            Screen::Chart => {
                sets = Some(vec![
                    Rules {
                        limit: true,
                        linear: true,
                        ..Rules::default()
                    },
                    BILINEAR,
                ])
            }
        }
    }
    let fine = floats(pos, pos[0].len());
    let nb = canon.base.nv;
    // The smallest coding, its rules and control values.
    let mut best: Option<(Payloads, Rules, Vec<[f64; 3]>)> = None;
    let keep = |best: &mut Option<(Payloads, Rules, Vec<[f64; 3]>)>,
                p: (Payloads, Rules),
                control: &[[f64; 3]]| {
        if best.as_ref().is_none_or(|q| p.0.size() < q.0.size()) {
            *best = Some((p.0, p.1, control.to_vec()));
        }
    };
    let sets = sets.unwrap_or_else(|| rule_sets(canon, finest, pos));
    // Every vertex counts; then, where the hierarchy has them, without the points of
    // Blender's end-cap patches (the smaller coding is kept: on a surface that is the
    // limit everywhere they carry its creases' sharpness).
    let caps = end_caps(canon, finest, END_CAP_LEVEL);
    let mut counts = vec![vec![false; finest.nv]];
    let has_caps = caps.contains(&true);
    if has_caps {
        counts.push(caps);
    }
    for caps in &counts {
        // Without the end-cap points (and, where the hierarchy has them, with a finite
        // sharpness, which may outlast their level), each limit rule set is coded also
        // with the end caps at Blender's default quality; the smallest coding is kept.
        let capped = caps.contains(&true);
        let code = |rules: &Rules, control: &[[f64; 3]]| -> Option<(Payloads, Rules)> {
            let p = code_rules(target, header, bits, rules, control).map(|p| (p, rules.clone()));
            let finite = |s: &[u32]| s.iter().any(|&s| s > 0 && s < fit::SHARP_INFINITE);
            let semi = has_caps && (finite(&rules.sharpness) || finite(&rules.vertex_sharpness));
            if !(capped || semi) || !rules.limit || rules.extra_levels.is_some() {
                return p;
            }
            let gregory = Rules {
                end_caps: Some(END_CAP_LEVEL as u8),
                ..rules.clone()
            };
            let g =
                code_rules(target, header, bits, &gregory, control).map(|g| (g, gregory.clone()));
            let smaller = |a: Option<(Payloads, Rules)>, b: Option<(Payloads, Rules)>| match (a, b)
            {
                (Some(a), Some(b)) => Some(if b.0.size() < a.0.size() { b } else { a }),
                (a, b) => a.or(b),
            };
            let best = smaller(p, g);
            // Sharpnesses found near the isolation level: OpenSubdiv drops what is left
            // of a sharpness there and makes its faces end caps, so any value past the
            // level is one rule, which the fit without the end-cap points cannot tell
            // from one just short of it; such sharpnesses also past it, fitted again
            // with the patches.
            let (edges, vertices) = (
                outlasting(&gregory.sharpness),
                outlasting(&gregory.vertex_sharpness),
            );
            if edges.is_none() && vertices.is_none() {
                return best;
            }
            let lifted = Rules {
                sharpness: edges.unwrap_or_else(|| gregory.sharpness.clone()),
                vertex_sharpness: vertices.unwrap_or_else(|| gregory.vertex_sharpness.clone()),
                ..gregory
            };
            let op = fit::Operator::new(&canon.levels, finest, &lifted);
            let control = op.fit(&fine, control, &[], 400, FIT_TOLERANCE);
            drop(op);
            let l = code_rules(target, header, bits, &lifted, &control).map(|l| (l, lifted));
            smaller(best, l)
        };
        // The smooth rule sets' sizes and the limit surface's distances, for the
        // search for semi-sharp creases.
        let mut smooth: Vec<(usize, bool)> = Vec::new();
        let mut distances = None;
        // The smallest coding with kept corners: its size, rules and control values.
        let mut kept_corners = None;
        // Each rule set's control values by least squares, the limit surface's
        // distances where it is the plain limit, and its coding: on the threads at
        // once, taken in the sets' order (the same for every count).
        let fitted = super::search::par_map(&sets, target.threads, |rules| {
            let op = fit::Operator::new(&canon.levels, finest, rules);
            let control = robust_fit(&op, &fine, nb, caps);
            // (Smooth: no rule but the limit's.)
            let plain = *rules
                == Rules {
                    limit: rules.limit,
                    ..Rules::default()
                };
            let d = (plain && rules.limit).then(|| distances_from(&op, &control, &fine));
            let p = code(rules, &control);
            drop(op);
            (plain, control, d, p)
        });
        for (rules, (plain, control, d, p)) in sets.iter().zip(fitted) {
            if let Some(d) = d {
                distances = Some((d, control.clone()));
            }
            if let Some(p) = p {
                if plain {
                    smooth.push((p.0.size(), rules.limit));
                }
                if rules.corners
                    && kept_corners
                        .as_ref()
                        .is_none_or(|k: &(usize, Rules, Vec<[f64; 3]>)| p.0.size() < k.0)
                {
                    kept_corners = Some((p.0.size(), rules.clone(), control.clone()));
                }
                keep(&mut best, p, &control);
            }
        }
        // Kept boundary vertices (Blender's UV junctions and concave corners) on the
        // best coding with kept corners, where it codes near the smallest (junctions
        // are kept corners too, and a few of them miss little).
        let smallest = best.as_ref().map_or(0, |b| b.0.size()) as f64;
        let kept = kept_corners
            .take()
            .filter(|k| k.0 as f64 <= JUNCTION_GATE * smallest);
        if let Some(rules) = kept.and_then(|(_, r, c)| junctions(canon, finest, &fine, &r, c, caps))
        {
            let op = fit::Operator::new(&canon.levels, finest, &rules);
            let control = robust_fit(&op, &fine, nb, caps);
            let p = code(&rules, &control);
            drop(op);
            if let Some(p) = p {
                keep(&mut best, p, &control);
            }
        }
        let limit = smooth.iter().min().is_none_or(|&(_, l)| l);
        let found = distances.map_or_else(Vec::new, |d| {
            semi_sharp(canon, finest, pos, &fine, &d, limit, caps, target.budget)
        });
        for rules in found.iter().filter(|r| !sets.contains(r)) {
            let op = fit::Operator::new(&canon.levels, finest, rules);
            let control = robust_fit(&op, &fine, nb, caps);
            let p = code(rules, &control);
            drop(op);
            if let Some(p) = p {
                keep(&mut best, p, &control);
            }
        }
    }
    // Blender's lower qualities: the best rules with end caps from an earlier level,
    // fitted with them (most points may lie in them): a short fit first, and where its
    // coding is the smallest, the whole fit.
    if let Some((_, rules, control)) = best.as_ref().filter(|b| !b.1.bilinear) {
        let tries: Vec<Rules> = (1..END_CAP_LEVEL as u8)
            .filter(|&q| (q as usize) < canon.levels.len())
            .map(|q| Rules {
                limit: true,
                extra_levels: None,
                end_caps: Some(q),
                ..rules.clone()
            })
            .collect();
        let start = control.clone();
        let size = best.as_ref().map_or(usize::MAX, |b| b.0.size());
        let coded = super::search::par_map(&tries, target.threads, |rules| {
            let op = fit::Operator::new(&canon.levels, finest, rules);
            let short = op.fit(&fine, &start, &[], SHORT_FIT, FIT_TOLERANCE);
            let p = code_rules(target, header, bits, rules, &short)?;
            if p.size() >= size {
                return None;
            }
            let control = op.fit(&fine, &short, &[], 400, FIT_TOLERANCE);
            drop(op);
            let q =
                code_rules(target, header, bits, rules, &control).filter(|q| q.size() < p.size());
            Some(match q {
                Some(q) => (q, rules.clone(), control),
                None => (p, rules.clone(), short),
            })
        });
        for (p, rules, control) in coded.into_iter().flatten() {
            keep(&mut best, (p, rules), &control);
        }
    }
    best.map(|b| b.0)
}

/// What the fit's screen makes of a hierarchy's finest values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Screen {
    /// Near a subdivision: every rule set is tried.
    Open,
    /// Far from one, but a flat chart: its UV rule alone is tried.
    Chart,
    /// Far from one: not tried.
    Away,
}

/// The fit's screen on hierarchy `canon` with finest values `pos` (`finest` the level
/// after the hierarchy's last). Refinement (small defect) is fitted;
/// else a surface: five finest vertices in a row inside one level-1 face, which
/// roughness measures, take three levels, and a shallower hierarchy is screened by one
/// fit on the limit. A flat mesh with a boundary (one axis constant: a UV map's charts,
/// cut at their seams) may still be a modelling tool's subdivision, by its UV rule:
/// linear boundaries on the limit surface. That rule set alone is tried when the
/// screens turn the fit away, and on a shallow chart.
fn screened(canon: &Canonical, pos: &[Vec<i64>; 3], finest: &Level) -> Screen {
    let (Some(last), Some(base)) = (canon.levels.last(), canon.levels.first()) else {
        return Screen::Away;
    };
    let mean = |f: &dyn Fn(&[i64]) -> Option<f64>| {
        pos.iter().map(|x| f(x).unwrap_or(f64::MAX)).sum::<f64>() / 3.0
    };
    let chart =
        pos.iter().any(|x| x.iter().all(|&v| v == x[0])) && !crate::topology::sqrt2::closed(base);
    let far = mean(&|x| fit::defect(last, x)) > FIT_SCREEN
        && if canon.levels.len() < 3 {
            chart || !near_limit(&canon.levels, finest, &floats(pos, finest.nv))
        } else {
            // Many extraordinary vertices leave few regular runs: the limit fit
            // decides then, on the first two levels alone (the vertices of level
            // two keep their limit positions at every level below: a prefix of
            // the finest values).
            let two = &canon.levels[2];
            let runs = fit::Runs::new(&canon.levels, finest);
            mean(&|x| runs.as_ref()?.roughness(x)) > ROUGH_SCREEN
                && (chart || !near_limit(&canon.levels[..2], two, &floats(pos, two.nv)))
        };
    // A smooth surface of few vertices: creases (semi-sharp, or at vertices) break
    // the runs and the two-level fit but fold few finest edges, so every rule set is
    // tried where the finest faces meet at a small angle at their median (detail
    // folds most by far more; a flat chart keeps its UV rule).
    // A tiny mesh is tried whatever it folds (over fewer levels a smooth surface
    // folds more: Blender's creased cylinders over two levels by 0.2, as much as
    // scans do), since the search there is cheap.
    let far = far
        && (chart
            || finest.nv > SMOOTH_VERTICES
            || (finest.nv > TINY_VERTICES && median_fold(finest, pos) > SMOOTH_FOLD));
    match (far, chart) {
        (false, _) => Screen::Open,
        (true, true) => Screen::Chart,
        (true, false) => Screen::Away,
    }
}

/// Finest vertices up to which a smooth surface is screened by its folds alone
/// ([`screened`]): the fit's whole search there takes about a second at most.
const SMOOTH_VERTICES: usize = 16_384;

/// Finest vertices up to which every rule set is tried whatever the screens say
/// ([`screened`]): the fit's whole search there takes a few tenths of a second at
/// most.
const TINY_VERTICES: usize = 1024;

/// The crease searches' budget per finest vertex on a mesh of at most
/// [`TINY_VERTICES`] of them, in weights applied ([`fit::Operator::work`]; about 30
/// instructions each with callgrind). Blender's creased cylinders over two levels (194
/// vertices) take 190,000 to 250,000 a vertex to the end of the search (their creases
/// are found by 80,000), seven creased prisms over two levels (910 vertices, `tests/fit.rs`)
/// 160,000; `corpus/two_components_cc2.obj` (132 vertices) took 740,000, 0.28 s of
/// its encoding's 0.29 s, where a fuzzing build runs about 20 times slower.
const TINY_WORK: u64 = 1 << 18;

/// The median fold (radians) at the finest edges ([`median_fold`]) at or below which a
/// small mesh is smooth enough for the fit: Blender's creased subdivision surfaces of
/// a few thousand vertices fold by 0.05 to 0.09, detail (displaced, scanned) by 0.15
/// and more.
const SMOOTH_FOLD: f64 = 0.1;

/// The median angle (radians) between the finest faces at the finest edges inside the
/// mesh (at most every `step`-th edge, about 20,000).
fn median_fold(finest: &Level, pos: &[Vec<i64>; 3]) -> f64 {
    let step = (finest.ne() / 20_000).max(1);
    let a: Vec<f64> = (0..finest.ne())
        .step_by(step)
        .filter(|&h| !finest.is_boundary(h))
        .filter_map(|h| {
            let [f0, f1] = finest.edge_faces[h];
            fold(face_normal(finest, pos, f0), face_normal(finest, pos, f1))
        })
        .collect();
    if a.is_empty() {
        return f64::MAX;
    }
    median_of(&a)
}

/// The normal of face `f` of `finest`'s coarse mesh (its diagonals' cross product; a
/// triangle's two edges'), unnormalised.
fn face_normal(finest: &Level, pos: &[Vec<i64>; 3], f: u32) -> [f64; 3] {
    let p = |v: u32| -> [f64; 3] { std::array::from_fn(|k| pos[k][v as usize] as f64) };
    let c = finest.coarse.face(f as usize);
    let (a, b) = if c.len() == 4 {
        ((c[0], c[2]), (c[1], c[3]))
    } else {
        ((c[0], c[1]), (c[0], c[2]))
    };
    let (u, w) = (sub(p(a.1), p(a.0)), sub(p(b.1), p(b.0)));
    [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ]
}

/// The angle (radians) between two normals; `None` where one is zero.
fn fold(n0: [f64; 3], n1: [f64; 3]) -> Option<f64> {
    let dot: f64 = (0..3).map(|k| n0[k] * n1[k]).sum();
    let len = (0..3).map(|k| n0[k] * n0[k]).sum::<f64>().sqrt()
        * (0..3).map(|k| n1[k] * n1[k]).sum::<f64>().sqrt();
    (len > 0.0).then(|| (dot / len).clamp(-1.0, 1.0).acos())
}

/// Whether `auto`'s fit would turn hierarchy `canon` with finest values `pos` away
/// unseen ([`code_fit`] with its screen returns `None` without a fit): a polar
/// hierarchy, or one without seams to glue that the screen turns away. `finest` is the
/// level after the hierarchy's last.
pub(crate) fn turned_away(canon: &Canonical, pos: &[Vec<i64>; 3], finest: &Level) -> bool {
    if !canon.poles.is_empty() || canon.levels.is_empty() {
        return true;
    }
    if glue_seams(canon, pos).is_some() {
        return false;
    }
    screened(canon, pos, finest) == Screen::Away
}

/// Whether hierarchy `canon`'s finest values `pos` are near a subdivision of its base:
/// the finest level a plain refinement (small defect), or near the limit surface of a
/// control mesh (one short least-squares fit). The screen of a hierarchy the fit has
/// already seen deeper, where [`screened`]'s roughness is the same (the runs lie in
/// the same finest faces) but the control mesh is finer.
pub(crate) fn near_subdivision(canon: &Canonical, pos: &[Vec<i64>; 3]) -> bool {
    let Some(last) = canon.levels.last() else {
        return false;
    };
    let defect = pos
        .iter()
        .map(|x| fit::defect(last, x).unwrap_or(f64::MAX))
        .sum::<f64>()
        / 3.0;
    if defect <= FIT_SCREEN {
        return true;
    }
    near_limit(&canon.levels, &last.next(), &floats(pos, pos[0].len()))
}

/// OpenSubdiv's isolation level in Blender's default ("Quality" 3): below it, beside
/// an extraordinary vertex, Blender evaluates end-cap patches (Gregory basis), not the
/// limit surface.
const END_CAP_LEVEL: usize = 3;

/// Per finest vertex of `canon` (`finest` the level after its last), whether it lies
/// where Blender's quality `level` (3 by default, [`END_CAP_LEVEL`]) evaluates an
/// end-cap patch rather than the limit surface: made after `level` inside a face of
/// that level beside an extraordinary vertex (inside the mesh, not four edges; a
/// boundary, sharp in OpenSubdiv, takes patches of its own that are on the limit). The
/// fits leave them out (the end caps' rule then predicts them); all false for
/// hierarchies of that many levels or fewer. This mask is made once, before any rule
/// set (so without sharpness), and is not [`EndCaps::new`]'s set of the faces a rule
/// set predicts (SPEC.md 9.10: it leaves out faces at creased corners and adds those
/// at semi-sharp ones): the mask only keeps the faces most likely off the limit out of
/// the least squares, and the coding of each rule set measures the rule itself.
///
/// [`EndCaps::new`]: crate::transform::gregory::EndCaps::new
fn end_caps(canon: &Canonical, finest: &Level, level: usize) -> Vec<bool> {
    let mut caps = vec![false; finest.nv];
    let Some(at) = canon.levels.get(level) else {
        return caps;
    };
    let irregular: Vec<bool> = (0..at.nv)
        .map(|v| {
            let edges = at.v_edges(v);
            edges.len() != 4 && edges.iter().all(|&e| !at.is_boundary(e as usize))
        })
        .collect();
    if !irregular.contains(&true) {
        return caps;
    }
    // Per face of each level from END_CAP_LEVEL down, whether it lies in a marked face
    // of that level (a face's children are its coarse corners, SPEC.md 8.1).
    let mut marked: Vec<bool> = (0..at.coarse.nf())
        .map(|f| at.coarse.face(f).iter().any(|&v| irregular[v as usize]))
        .collect();
    for l in &canon.levels[level..] {
        let mut next = vec![false; l.coarse.idx.len()];
        for (f, &m) in marked.iter().enumerate().filter(|&(_, &m)| m) {
            let (a, b) = (l.coarse.starts[f] as usize, l.coarse.starts[f + 1] as usize);
            next[a..b].fill(m);
        }
        marked = next;
    }
    for (f, _) in marked.iter().enumerate().filter(|&(_, &m)| m) {
        for &v in finest.coarse.face(f) {
            caps[v as usize] |= v as usize >= at.nv;
        }
    }
    caps
}

/// Iterations of the short fit that tells whether end caps from a lower level are
/// worth the whole fit.
const SHORT_FIT: usize = 30;

/// `sharpness` with the finite sharpnesses from half a level below the end caps' level
/// ([`END_CAP_LEVEL`]) up to it set half a level past it, if there are any.
fn outlasting(sharpness: &[u32]) -> Option<Vec<u32>> {
    let q = END_CAP_LEVEL as u32 * fit::SHARP_ONE;
    let near = |s: u32| (q - fit::SHARP_ONE / 2..=q).contains(&s);
    sharpness.iter().any(|&s| near(s)).then(|| {
        sharpness
            .iter()
            .map(|&s| if near(s) { q + fit::SHARP_ONE / 2 } else { s })
            .collect()
    })
}

/// The first `n` values per axis as points of floats.
fn floats(pos: &[Vec<i64>; 3], n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|i| std::array::from_fn(|k| pos[k][i] as f64))
        .collect()
}

/// What a fit codes: the hierarchy and its finest values, and, where the mesh is cut at
/// seams, the same glued, whose levels the rules refine.
struct Target<'a> {
    canon: &'a Canonical,
    pos: &'a [Vec<i64>; 3],
    /// The level after the hierarchy's last.
    finest: &'a Level,
    glued: Option<&'a GluedMesh>,
    /// The crease searches' budget, shared by every search on the mesh.
    budget: &'a Budget,
    /// Threads the rule sets' fits may take at once (at least 1).
    threads: usize,
}

/// A hierarchy glued at its seams (SPEC.md 9.10): the glued levels and finest values,
/// and where each vertex of the cut one went.
struct GluedMesh {
    /// The seams as the header lists them.
    pairs: Vec<(u32, u32)>,
    /// The glued hierarchy.
    canon: Canonical,
    /// The level after its last.
    finest: Level,
    /// Its finest values.
    pos: [Vec<i64>; 3],
    /// Per base vertex of the cut hierarchy, its glued vertex.
    base: Vec<u32>,
    /// Per finest vertex of the cut hierarchy, its glued vertex.
    map: Vec<u32>,
}

/// The hierarchy glued where base vertices on its boundary share their finest values
/// (a file cut at its UV seams, as Blender's PLY exporter writes one), if gluing them
/// gives a mesh that Catmull-Clark refines and every finest vertex glued together has
/// the same values; `None` otherwise.
fn glue_seams(canon: &Canonical, pos: &[Vec<i64>; 3]) -> Option<GluedMesh> {
    let base = &canon.levels[0];
    let mut first: HashMap<[i64; 3], u32> = HashMap::new();
    let mut pairs = Vec::new();
    for v in (0..base.nv).filter(|&v| base.boundary_edges(v).0 > 0) {
        let p = [pos[0][v], pos[1][v], pos[2][v]];
        match first.entry(p) {
            std::collections::hash_map::Entry::Occupied(o) => pairs.push((v as u32, *o.get())),
            std::collections::hash_map::Entry::Vacant(o) => {
                o.insert(v as u32);
            }
        }
    }
    // A seam joins boundary edges: a copy is kept where one of its boundary edges
    // becomes, glued, the same edge as another (not where two pieces touch at a point).
    let mut rep: Vec<u32> = (0..base.nv as u32).collect();
    for &(c, p) in &pairs {
        rep[c as usize] = p;
    }
    let key = |e: usize| {
        let [a, b] = base.edges[e].map(|v| rep[v as usize]);
        (a.min(b), a.max(b))
    };
    let mut sides: HashMap<(u32, u32), u32> = HashMap::new();
    for e in (0..base.ne()).filter(|&e| base.is_boundary(e)) {
        *sides.entry(key(e)).or_insert(0) += 1;
    }
    pairs.retain(|&(c, _)| {
        base.v_edges(c as usize)
            .iter()
            .any(|&e| base.is_boundary(e as usize) && sides[&key(e as usize)] > 1)
    });
    if pairs.is_empty() {
        return None;
    }
    let g = fit::Glued::new(&base.coarse, &pairs).ok()?;
    let mut levels = vec![g.level];
    let mut map = g.map.clone();
    for (l, cut) in canon.levels.iter().enumerate() {
        let glued = &levels[l];
        map = fit::glued_below(cut, glued, &map);
        let next = glued.next();
        levels.push(next);
    }
    let finest = levels.pop()?;
    // Every finest vertex glued together has the same values.
    let glued_pos = pos.each_ref().map(|xs| fit::gather(&map, finest.nv, xs));
    if (0..3).any(|k| fit::spread(&map, &glued_pos[k]) != pos[k]) {
        return None;
    }
    Some(GluedMesh {
        pairs,
        canon: canon.with_levels(levels),
        finest,
        pos: glued_pos,
        base: g.map,
        map,
    })
}

/// The smallest coding of `rules` with the control values `control` (of the glued
/// hierarchy where `target` has one), over the precisions in `bits` (B = 0 last, for
/// values too large for any of them).
fn code_rules(
    target: &Target<'_>,
    header: &Header,
    bits: &[u8],
    rules: &Rules,
    control: &[[f64; 3]],
) -> Option<Payloads> {
    let mut best: Option<Payloads> = None;
    let mut found = false;
    let canon = target.canon;
    for b in bits.iter().copied().chain([0]) {
        if b == 0 && found {
            break;
        }
        let s = (1u64 << b) as f64;
        let mut x: [Vec<i64>; 3] =
            std::array::from_fn(|k| control.iter().map(|v| (v[k] * s).round() as i64).collect());
        if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
            continue;
        }
        found = true;
        // With seams, each base vertex takes its glued vertex's control value, and each
        // finest vertex its glued vertex's refined value.
        let (mut h, base_bytes) = match target.glued {
            None => hierarchy_base(canon, &x, header),
            Some(g) => hierarchy_base(
                canon,
                &x.each_ref().map(|xs| fit::spread(&g.base, xs)),
                header,
            ),
        };
        match target.glued {
            None => fit::refine(&canon.levels, target.finest, rules, &mut x).ok()?,
            Some(g) => {
                h.seams = g.pairs.clone();
                fit::refine(&g.canon.levels, &g.finest, rules, &mut x).ok()?;
                x = x.each_ref().map(|xs| fit::spread(&g.map, xs));
            }
        }
        let finest_bytes = levl::fit::encode_residuals(&x, target.pos, b);
        let mut level_bytes = vec![Vec::new(); canon.levels.len() - 1];
        level_bytes.push(finest_bytes);
        h.transform = Transform::Fit {
            bits: b,
            limit: rules.limit,
            corners: rules.corners,
            linear: rules.linear,
            bilinear: rules.bilinear,
            limit_corners: rules.limit_corners,
            extra_levels: rules.extra_levels,
            end_caps: rules.end_caps,
        };
        let listed = |sharpness: &[u32]| -> (Vec<u32>, Vec<u32>) {
            sharpness
                .iter()
                .enumerate()
                .filter(|&(_, &s)| s > 0)
                .map(|(i, &s)| (i as u32, s.min(fit::SHARP_INFINITE)))
                .unzip()
        };
        let (creases, sharpness) = listed(&rules.sharpness);
        h.creases = creases;
        // (Lists of infinitely sharp creases only leave their sharpnesses out.)
        let finite = |s: Vec<u32>| {
            if s.iter().all(|&s| s == fit::SHARP_INFINITE) {
                Vec::new()
            } else {
                s
            }
        };
        h.crease_sharpness = finite(sharpness);
        let (vertices, sharpness) = listed(&rules.vertex_sharpness);
        h.vertex_creases = vertices;
        h.vertex_sharpness = finite(sharpness);
        let p = Payloads {
            header: h,
            base: base_bytes,
            levels: level_bytes,
            order: None,
        };
        if best.as_ref().is_none_or(|q| p.size() < q.size()) {
            best = Some(p);
        }
    }
    best
}

/// Rounds of [`junctions`]' search: each keeps the boundary vertices still far off.
const JUNCTION_ROUNDS: usize = 10;

/// [`junctions`] runs where the smallest coding with kept corners is at most this
/// many times the smallest of all.
const JUNCTION_GATE: f64 = 1.5;

/// Each round of [`junctions`] keeps the vertices within this factor of the farthest
/// (a wrong rule's error at a vertex is far above what it leaves at its neighbours
/// once the fit is right elsewhere).
const JUNCTION_SPAN: f64 = 4.0;

/// Boundary base vertices that keep their values besides the corners of `rules` (with
/// `control` its fitted control values), as infinitely sharp vertex creases: Blender's
/// UV smoothing "Keep Corners, Junctions" keeps every UV value of a vertex where three
/// or more charts meet, and "... and Concave" both values where one is a chart's
/// corner, and a chart alone does not say which. Each round keeps those far off the
/// fit (above [`OUTLIER_FACTOR`] times the median distance and [`JUNCTION_SPAN`]
/// times less than the farthest), each the farthest of its neighbours, and fits
/// again. `None` when none is far off.
fn junctions(
    canon: &Canonical,
    finest: &Level,
    fine: &[[f64; 3]],
    rules: &Rules,
    control: Vec<[f64; 3]>,
    caps: &[bool],
) -> Option<Rules> {
    let base = &canon.levels[0];
    let nb = base.nv;
    let on_boundary = |v: usize| {
        base.v_faces(v).len() > 1
            && base
                .v_edges(v)
                .iter()
                .any(|&e| base.is_boundary(e as usize))
    };
    let mut rules = rules.clone();
    let mut control = control;
    let mut kept = vec![0u32; nb];
    for _ in 0..JUNCTION_ROUNDS {
        let op = fit::Operator::new(&canon.levels, finest, &rules);
        if rules.vertex_sharpness.iter().any(|&s| s > 0) {
            control = op.fit(fine, &control, caps, 400, FIT_TOLERANCE);
        }
        let d = distances_from(&op, &control, fine);
        let cut = outlier_cut(median_of(&d));
        // A wrong rule at one vertex moves its neighbours too, less: only the
        // farthest of its neighbourhood counts.
        let peak = |v: usize| {
            base.v_edges(v).iter().all(|&e| {
                let u = base.other_end(e, v) as usize;
                kept[u] > 0 || d[u] < d[v] || d[u] == d[v] && u > v
            })
        };
        let free = |v: usize| kept[v] == 0 && on_boundary(v);
        let top = (0..nb)
            .filter(|&v| free(v))
            .map(|v| d[v])
            .fold(0.0, f64::max);
        let cut = cut.max(top / JUNCTION_SPAN);
        let far: Vec<usize> = (0..nb)
            .filter(|&v| free(v) && d[v] > cut && peak(v))
            .collect();
        if far.is_empty() {
            break;
        }
        for v in far {
            kept[v] = fit::SHARP_INFINITE;
        }
        rules.vertex_sharpness = kept.clone();
    }
    kept.iter().any(|&s| s > 0).then_some(rules)
}

/// Per finest vertex, its largest distance over the axes from the refinement of
/// `control` by `op`.
fn distances_from(op: &fit::Operator, control: &[[f64; 3]], fine: &[[f64; 3]]) -> Vec<f64> {
    op.apply(control)
        .iter()
        .zip(fine)
        .map(|(p, y)| (0..3).map(|k| (p[k] - y[k]).abs()).fold(0.0, f64::max))
        .collect()
}

/// Median distance (grid units, per axis) from the finest values to the limit surface
/// of their least-squares control mesh at or below which `auto` tries the fit on a
/// hierarchy of one or two levels: rounding leaves about 0.25, a modelling tool's
/// creases or corners move few vertices, detail moves most by hundreds.
const NEAR_LIMIT: f64 = 4.0;

/// Iterations of that screening fit: its median settles within a few (the fit that is
/// coded runs to [`FIT_TOLERANCE`]).
const NEAR_ITERATIONS: usize = 10;

/// Whether the finest values `fine` of `canon` are near the limit surface of a control
/// mesh (one least-squares fit with the limit rules: cheap next to coding the fit).
fn near_limit(levels: &[Level], finest: &Level, fine: &[[f64; 3]]) -> bool {
    let rules = Rules {
        limit: true,
        ..Rules::default()
    };
    let op = fit::Operator::new(levels, finest, &rules);
    let nb = levels[0].nv;
    let control = op.fit(fine, &fine[..nb], &[], NEAR_ITERATIONS, FIT_TOLERANCE);
    let dist: Vec<f64> = op
        .apply(&control)
        .iter()
        .zip(fine)
        .flat_map(|(p, y)| (0..3).map(move |k| (p[k] - y[k]).abs()))
        .collect();
    if dist.is_empty() {
        return false;
    }
    median_of(&dist) <= NEAR_LIMIT
}

/// Finest vertices whose distance from the first fit exceeds this many times the
/// median distance (and [`OUTLIER_FLOOR`]) do not count in the second: a few points a
/// modelling tool places by other rules (OpenSubdiv's patches beside extraordinary
/// vertices) would otherwise pull the whole control mesh off.
const OUTLIER_FACTOR: f64 = 16.0;

/// Grid units below which no vertex is an outlier.
const OUTLIER_FLOOR: f64 = 4.0;

/// The median of `d` (not empty).
fn median_of(d: &[f64]) -> f64 {
    let mut sorted = d.to_vec();
    let mid = sorted.len() / 2;
    *sorted.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The distance from a fit above which a finest vertex is an outlier:
/// [`OUTLIER_FACTOR`] times the median of the distances (`median`), at least
/// [`OUTLIER_FLOOR`].
fn outlier_cut(median: f64) -> f64 {
    (OUTLIER_FACTOR * median).max(OUTLIER_FLOOR)
}

/// Rounds of [`robust_fit`]'s refits: each fits again without the outliers of the
/// fit before, until they stay the same.
const ROBUST_ROUNDS: usize = 2;

/// The control values of `op` nearest `fine` in least squares, fitted again without
/// the outliers of the fit before (a few rounds: a first fit pulled by many far
/// points, as beside the end-cap patches of a mesh with many extraordinary vertices,
/// is off everywhere, so its median hides them).
fn robust_fit(op: &fit::Operator, fine: &[[f64; 3]], nb: usize, caps: &[bool]) -> Vec<[f64; 3]> {
    let mut control = op.fit(fine, &fine[..nb], caps, 400, FIT_TOLERANCE);
    let mut ignored: Vec<bool> = caps.to_vec();
    for _ in 0..ROBUST_ROUNDS {
        let dist = distances_from(op, &control, fine);
        let cut = outlier_cut(median_of(&dist));
        let now: Vec<bool> = dist
            .iter()
            .enumerate()
            .map(|(i, &d)| d > cut || caps.get(i).is_some_and(|&c| c))
            .collect();
        // Refit only where a few points are outliers (many are no rule's misses).
        let n = now.iter().filter(|&&i| i).count();
        if n == 0 || n * 8 > dist.len() || now == ignored {
            break;
        }
        control = op.fit(fine, &control, &now, 400, FIT_TOLERANCE);
        ignored = now;
    }
    control
}

/// The rule sets the fit tries: plain refinement, the limit surface, and the limit
/// surface with the creases the finest level shows; each also with boundary corners
/// kept where the base mesh has a boundary vertex with one face, and with every
/// boundary vertex kept (linear boundaries) where it has a boundary; and linear
/// everywhere.
fn rule_sets(canon: &Canonical, finest: &Level, pos: &[Vec<i64>; 3]) -> Vec<Rules> {
    let mut sets = vec![
        Rules::default(),
        Rules {
            limit: true,
            ..Rules::default()
        },
    ];
    let sharpness = creases(canon, finest, pos);
    if !sharpness.is_empty() {
        sets.push(Rules {
            limit: true,
            sharpness: sharpness.clone(),
            ..Rules::default()
        });
        sets.push(Rules {
            sharpness,
            ..Rules::default()
        });
    }
    let base = &canon.levels[0];
    // With linear boundaries (UV charts' seams) every boundary vertex is kept, so
    // boundary corners say nothing more.
    let linear: Vec<Rules> = if !crate::topology::sqrt2::closed(base) {
        sets.iter()
            .map(|r| Rules {
                linear: true,
                ..r.clone()
            })
            .collect()
    } else {
        Vec::new()
    };
    let corner = |v: usize| {
        base.v_faces(v).len() == 1
            && base
                .v_edges(v)
                .iter()
                .any(|&e| base.is_boundary(e as usize))
    };
    if (0..base.nv).any(corner) {
        // Kept corners; and corners refined smoothly but kept at the limit.
        let kept: Vec<Rules> = sets
            .iter()
            .map(|r| Rules {
                corners: true,
                ..r.clone()
            })
            .chain(
                sets.iter()
                    .filter(|r| r.limit && r.sharpness.is_empty())
                    .map(|r| Rules {
                        limit_corners: true,
                        ..r.clone()
                    }),
            )
            .collect();
        sets.extend(kept);
    }
    sets.extend(linear);
    sets.push(BILINEAR);
    sets
}

/// Linear everywhere: Blender's UV smoothing "None" and its "Simple" subdivision.
const BILINEAR: Rules = Rules {
    limit: false,
    sharpness: Vec::new(),
    vertex_sharpness: Vec::new(),
    corners: false,
    linear: false,
    bilinear: true,
    limit_corners: false,
    extra_levels: None,
    end_caps: None,
};

/// The mean angle (radians) between the finest faces beside a base edge's descendants
/// above which the encoder tries the edge as a crease: a smooth surface's finest faces
/// meet at a few degrees, a crease at its fold.
const CREASE_ANGLE: f64 = 0.3;

/// Per edge of the finest level (the coarse mesh of `finest`), the base edge it
/// descends from, or `u32::MAX`.
fn owners(canon: &Canonical, finest: &Level) -> Vec<u32> {
    let mut owner: Vec<u32> = (0..canon.levels[0].ne() as u32).collect();
    for (l, level) in canon.levels.iter().enumerate() {
        let fine = canon.levels.get(l + 1).unwrap_or(finest);
        owner = fit::tags_below(level, &owner, u32::MAX, fine);
    }
    owner
}

/// Per base edge, the mean angle (radians) between the finest faces beside its
/// descendants: a smooth surface's finest faces meet at a few degrees, a crease at its
/// fold (0 for an edge whose descendants are all on a boundary).
fn fold_angles(canon: &Canonical, finest: &Level, pos: &[Vec<i64>; 3]) -> Vec<f64> {
    let owner = owners(canon, finest);
    let mut sum = vec![(0.0f64, 0usize); canon.levels[0].ne()];
    for (h, &o) in owner.iter().enumerate().filter(|&(_, &o)| o != u32::MAX) {
        if finest.is_boundary(h) {
            continue;
        }
        let [f0, f1] = finest.edge_faces[h];
        if let Some(a) = fold(face_normal(finest, pos, f0), face_normal(finest, pos, f1)) {
            let s = &mut sum[o as usize];
            s.0 += a;
            s.1 += 1;
        }
    }
    sum.iter()
        .map(|&(a, n)| if n > 0 { a / n as f64 } else { 0.0 })
        .collect()
}

/// The base edges along which the finest surface folds (mean angle above
/// [`CREASE_ANGLE`]), infinitely sharp: the creases the fit tries. Empty when there is
/// none.
fn creases(canon: &Canonical, finest: &Level, pos: &[Vec<i64>; 3]) -> Vec<u32> {
    let sharp: Vec<u32> = fold_angles(canon, finest, pos)
        .iter()
        .map(|&a| {
            if a > CREASE_ANGLE {
                fit::SHARP_INFINITE
            } else {
                0
            }
        })
        .collect();
    if sharp.iter().any(|&s| s > 0) {
        sharp
    } else {
        Vec::new()
    }
}

/// Most rounds of the sharpness search's last step.
const SETTLE_ROUNDS: usize = 12;

/// Golden-section steps of the sharpness search (from two levels' span to 2^-9).
const GOLDEN_STEPS: usize = 15;

/// Base edges whose finest vertices lie, at their median, more than one of these times
/// the median distance from the smooth limit surface make a set of creases to try.
const CREASE_FACTORS: [f64; 2] = [1.5, 3.0];

/// Base vertices whose finest vertex lies more than this many times the median
/// distance from the surface fitted so far are tried as vertex creases.
const VERTEX_FACTOR: f64 = 2.0;

/// A drop in fold angle by this factor between consecutive base edges (ranked by
/// fold) separates creases from smooth edges.
const FOLD_GAP: f64 = 1.25;

/// The largest drops in fold angle whose sets of edges are tried.
const FOLD_SETS: usize = 2;

/// Blender crease values at which each set of creases is screened.
const SCREEN_CREASES: [f64; 2] = [0.3, 0.7];

/// A set of creases is searched only if at a screening value it fits with less than
/// this share of the smooth surface's misfit.
const SCREEN_GAIN: f64 = 0.5;

/// Iterations of a screening fit and of a search's fits (warm started from the
/// smooth surface's control values), and the search's tolerance (grid units).
const SCREEN_ITERATIONS: usize = 15;
const SEARCH_ITERATIONS: usize = 200;
const SEARCH_TOLERANCE: f64 = 1e-3;

/// OpenSubdiv's isolation level by default (Blender's Subdivision Surface "Quality").
const ISOLATION: usize = 3;

/// Most vertices the encoder's search refines the extra levels to ([`isolation`]):
/// every least squares fit past the isolation level works on that many points, and
/// converges slowly there (a 48,898-vertex CAD model with one extra level, 196,000
/// points: 135 s for one sharpness search, 65 s for its robust fit). Blender's
/// shallow exports that need the extra levels are small (a creased 32-sided
/// cylinder over two levels, 2,306 vertices, refines to 9,218).
const EXTRA_SEARCH_VERTICES: usize = 1 << 15;

/// The extra levels that reach [`ISOLATION`] from the hierarchy's levels, where it
/// has at most that many and the extra levels stay within the search's bound
/// ([`EXTRA_SEARCH_VERTICES`], below the format's): Blender's default limit of
/// semi-sharp creases over 1 to 3 levels (SPEC.md 9.10).
fn isolation(canon: &Canonical, finest: &Level) -> Option<u8> {
    let e = ISOLATION.checked_sub(canon.levels.len())? as u8;
    (e > 0 && fit::extra_vertices(finest, e) <= EXTRA_SEARCH_VERTICES).then_some(e)
}

/// The sharpness (units of 2^-16) of Blender's crease value `c`.
fn crease_sharpness(c: f64) -> u32 {
    ((10.0 * c * c * fit::SHARP_ONE as f64).round() as u32).clamp(1, fit::SHARP_INFINITE)
}

/// Semi-sharp creases (SPEC.md 9.10), as a modelling tool's user sets them: a set of
/// base edges, or of base vertices, with one sharpness. Candidate edge sets are those
/// whose finest vertices lie far from the smooth surface (`smooth`: per finest vertex
/// its distance, and the control values) and those that fold far more than the rest;
/// each is screened at a few sharpnesses, and the best, if it fits far better than the
/// smooth surface, gets the sharpness that fits best by least squares. Then base
/// vertices still far off are tried as vertex creases the same way (on the creases
/// found, and alone); where vertex creases alone fit, edge sets are found again from
/// their fit and searched with them, and vertex creases once more on those edges (a
/// user's creased edges and creased corners on one mesh). The rules found that fit
/// better than the smooth surface (none where nothing does), within `budget` (what it
/// has found when that is spent).
#[allow(clippy::too_many_arguments)]
fn semi_sharp(
    canon: &Canonical,
    finest: &Level,
    pos: &[Vec<i64>; 3],
    fine: &[[f64; 3]],
    smooth: &(Vec<f64>, Vec<[f64; 3]>),
    limit: bool,
    caps: &[bool],
    budget: &Budget,
) -> Vec<Rules> {
    let (distances, start) = (&smooth.0[..], &smooth.1[..]);
    // Every operator's work is charged to the budget; once it is spent, the search
    // keeps what it has found and tries nothing more.
    let operator = |rules: &Rules| Charged {
        op: fit::Operator::new(&canon.levels, finest, rules),
        to: budget,
    };
    let exhausted = || budget.exhausted();
    let median = median_of(distances);
    let cut = outlier_cut(median);
    let base = &canon.levels[0];
    // Per base edge, the median distance of the finest vertices on its descendants
    // (a median: one vertex beside an extraordinary vertex does not make a crease).
    let owner = owners(canon, finest);
    // Candidate sets from finest distances `d`: the edges scoring above each factor of
    // their median, each set once.
    let scored_sets = |d: &[f64]| -> Vec<Vec<usize>> {
        let median = median_of(d);
        let mut along: Vec<Vec<f64>> = vec![Vec::new(); base.ne()];
        for (h, &o) in owner.iter().enumerate().filter(|&(_, &o)| o != u32::MAX) {
            along[o as usize].extend(finest.edges[h].iter().map(|&v| d[v as usize]));
        }
        let score: Vec<f64> = along
            .iter_mut()
            .map(|d| {
                let m = d.len() / 2;
                if d.is_empty() {
                    0.0
                } else {
                    *d.select_nth_unstable_by(m, f64::total_cmp).1
                }
            })
            .collect();
        let mut sets: Vec<Vec<usize>> = Vec::new();
        for f in CREASE_FACTORS {
            let set: Vec<usize> = (0..base.ne())
                .filter(|&e| score[e] > (f * median).max(OUTLIER_FLOOR))
                .collect();
            if !set.is_empty() && !sets.contains(&set) {
                sets.push(set);
            }
        }
        sets
    };
    let mut sets = scored_sets(distances);
    // And the edges folding most, cut where the fold angles drop by a gap (a crease
    // concentrates its edge's fold): the largest gaps' sets.
    let angles = fold_angles(canon, finest, pos);
    let mut by_angle: Vec<usize> = (0..base.ne()).filter(|&e| angles[e] > 0.0).collect();
    by_angle.sort_by(|&a, &b| angles[b].total_cmp(&angles[a]).then(a.cmp(&b)));
    let mut gaps: Vec<(f64, usize)> = (1..by_angle.len())
        .map(|k| (angles[by_angle[k - 1]] / angles[by_angle[k]], k))
        .filter(|&(g, _)| g >= FOLD_GAP)
        .collect();
    gaps.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    for &(_, k) in gaps.iter().take(FOLD_SETS) {
        let mut set = by_angle[..k].to_vec();
        set.sort_unstable();
        if !sets.contains(&set) {
            sets.push(set);
        }
    }
    let nb = base.nv;
    let levels = canon.levels.len() as u32;
    let smooth_rules = Rules {
        limit,
        ..Rules::default()
    };
    // Vertices far off the smooth surface (placed by other rules) do not count; but
    // a vertex crease's own vertices do while their search runs (else nothing in the
    // fit tells its sharpness).
    let counted: RefCell<Vec<bool>> = RefCell::new(
        distances
            .iter()
            .zip(caps)
            .map(|(&d, &c)| !c && d <= cut)
            .collect(),
    );
    let ignored = RefCell::new(counted.borrow().iter().map(|&c| !c).collect::<Vec<bool>>());
    let square = |p: &[[f64; 3]]| -> f64 {
        p.iter()
            .zip(fine)
            .zip(counted.borrow().iter())
            .filter(|(_, &c)| c)
            .map(|((p, y), _)| (0..3).map(|k| (y[k] - p[k]).powi(2)).sum::<f64>())
            .sum()
    };
    // The least-squares misfit of `rules` (the sum of squares over the counted
    // vertices), and every vertex's distance.
    let misfit = |rules: &Rules, iterations: usize| -> (f64, Vec<f64>) {
        let op = operator(rules);
        let control = op.fit(fine, start, &ignored.borrow(), iterations, SEARCH_TOLERANCE);
        let p = op.apply(&control);
        let d = p
            .iter()
            .zip(fine)
            .map(|(p, y)| (0..3).map(|k| (p[k] - y[k]).abs()).fold(0.0, f64::max))
            .collect();
        (square(&p), d)
    };
    // The best of a few crease values, as (misfit, crease value).
    let screen = |set: &dyn Fn(u32) -> Rules| -> (f64, f64) {
        SCREEN_CREASES
            .iter()
            .map(|&c| match exhausted() {
                true => (f64::MAX, c),
                false => (misfit(&set(crease_sharpness(c)), SCREEN_ITERATIONS).0, c),
            })
            .fold((f64::MAX, 1.0), |a, b| if b.0 < a.0 { b } else { a })
    };
    // The sharpness that fits best: the control values fitted at each whole
    // sharpness (and infinitely sharp), golden sections between the best's
    // neighbours, then, with the control values fixed, the exact best in the span
    // (between two whole sharpnesses k and k + 1 only level k's rules blend, by the
    // fraction, so the finest values move in proportion to it: a quadratic).
    let search = |set: &dyn Fn(u32) -> Rules| -> (u32, f64) {
        // (Past the extra levels' refinements a finite sharpness changes nothing.)
        let levels = levels + u32::from(set(1).extra_levels.unwrap_or(0));
        let fitted = |s: u32, from: &[[f64; 3]]| {
            let op = operator(&set(s));
            let control = op.fit(
                fine,
                from,
                &ignored.borrow(),
                SEARCH_ITERATIONS,
                SEARCH_TOLERANCE,
            );
            let m = square(&op.apply(&control));
            (m, control)
        };
        let one = fit::SHARP_ONE as f64;
        let mut best = (f64::MAX, fit::SHARP_INFINITE, start.to_vec());
        for s in (0..=levels)
            .map(|k| k * fit::SHARP_ONE)
            .chain([fit::SHARP_INFINITE])
        {
            if exhausted() {
                break;
            }
            let (m, c) = fitted(s.max(1), start);
            if m < best.0 {
                best = (m, s.max(1), c);
            }
        }
        if best.1 == fit::SHARP_INFINITE {
            return (best.1, best.0);
        }
        let k = (best.1 as f64 / one).round();
        let (mut lo, mut hi) = ((k - 1.0).max(0.0), (k + 1.0).min(levels as f64));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        let mut control = best.2.clone();
        let mut at = |x: f64| {
            let (m, c) = fitted(((x * one).round() as u32).max(1), &control);
            control = c;
            m
        };
        let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut f1, mut f2) = (at(x1), at(x2));
        for _ in 0..GOLDEN_STEPS {
            if exhausted() {
                break;
            }
            if f1 <= f2 {
                (hi, x2, f2) = (x2, x1, f1);
                x1 = hi - g * (hi - lo);
                f1 = at(x1);
            } else {
                (lo, x1, f1) = (x1, x2, f2);
                x2 = lo + g * (hi - lo);
                f2 = at(x2);
            }
        }
        let x = if f1 <= f2 { x1 } else { x2 };
        // Gauss-Newton steps in x's span: with the control values fixed, the finest
        // values move in proportion to the fraction (only level k's rules blend, by
        // it), along `v`; the control values and the step that fit best together come
        // from two least-squares fits (of the finest values, and of `v`).
        let k = (x.floor() as u32).min(levels - 1);
        let mut t = x - k as f64;
        let mut s = 0;
        let mut m = f64::MAX;
        let zero = vec![[0.0; 3]; nb];
        for _ in 0..SETTLE_ROUNDS {
            if exhausted() {
                break;
            }
            let now = (((k as f64 + t) * one).round() as u32).max(1);
            if now == s {
                break;
            }
            s = now;
            let op = operator(&set(s));
            control = op.fit(fine, &control, &ignored.borrow(), 400, FIT_TOLERANCE);
            let p = op.apply(&control);
            let p0 = operator(&set((k * fit::SHARP_ONE).max(1))).apply(&control);
            let p1 = operator(&set((k + 1) * fit::SHARP_ONE)).apply(&control);
            let v: Vec<[f64; 3]> = p1
                .iter()
                .zip(&p0)
                .map(|(a, b)| std::array::from_fn(|i| a[i] - b[i]))
                .collect();
            let along = op.fit(&v, &zero, &ignored.borrow(), 400, FIT_TOLERANCE);
            let q = op.apply(&along);
            let (mut rv, mut vv) = (0.0, 0.0);
            let counted = counted.borrow();
            for i in (0..fine.len()).filter(|&i| counted[i]) {
                for a in 0..3 {
                    let w = v[i][a] - q[i][a];
                    rv += (fine[i][a] - p[i][a]) * w;
                    vv += w * w;
                }
            }
            m = square(&p);
            if vv > 0.0 {
                t = (t + rv / vv).clamp(0.0, 1.0);
            }
        }
        if m < best.0 {
            (s, m)
        } else {
            (best.1, best.0)
        }
    };
    let smooth = square(&operator(&smooth_rules).apply(start));
    let mut best = (smooth_rules.clone(), smooth);
    // Edge creases: the set (and limit rule) that fits best at a few sharpnesses is
    // searched, if it fits far better than the smooth surface.
    let with = |list: &[usize], n: usize, s: u32| -> Vec<u32> {
        let mut v = vec![0; n];
        for &e in list {
            v[e] = s;
        }
        v
    };
    // The limits tried: the limit surface (and plain refinement where it coded
    // smaller), and past OpenSubdiv's isolation level (Blender's default Quality)
    // where the hierarchy has fewer levels.
    let isolated = isolation(canon, finest);
    let mut limits = vec![(true, None)];
    if !limit {
        limits.push((false, None));
    }
    if isolated.is_some() {
        limits.push((true, isolated));
    }
    // The best screened set of each kind of limit: without extra levels (the limit,
    // or plain refinement), and with them, each searched if it fits far better than
    // the smooth surface (a screen's two sharpnesses do not tell the kinds apart: a
    // crease sharp for all levels but the last fits either nearly as well).
    let screened = |kinds: &[(bool, Option<u8>)]| {
        sets.iter()
            .flat_map(|set| kinds.iter().map(move |&l| (set, l)))
            .map(|(set, (limit, extra_levels))| {
                let (m, _) = screen(&|s| Rules {
                    limit,
                    extra_levels,
                    sharpness: with(set, base.ne(), s),
                    ..Rules::default()
                });
                (m, set, limit, extra_levels)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .filter(|s| s.0 < SCREEN_GAIN * smooth)
    };
    let (plain_kinds, extra_kinds) = limits.split_at(limits.len() - isolated.is_some() as usize);
    let mut edge_found: Vec<(Rules, f64)> = Vec::new();
    // (The extra levels are screened only where a set screened well without them: at
    // the larger screening value a crease is infinitely sharp in either kind, so a
    // set that does not fit far better then is no crease set; and a screen past the
    // isolation level refines four to sixteen times the finest vertices.)
    for kinds in [plain_kinds, extra_kinds] {
        if kinds == extra_kinds && edge_found.is_empty() {
            break;
        }
        if let Some((_, edges, limit, extra_levels)) = screened(kinds) {
            let set = |s| Rules {
                limit,
                extra_levels,
                sharpness: with(edges, base.ne(), s),
                ..Rules::default()
            };
            let (s, m) = search(&set);
            edge_found.push((set(s), m));
        }
    }
    for f in &edge_found {
        if f.1 < best.1 {
            best = f.clone();
        }
    }
    // Vertex creases: base vertices still far off, on the creases found and on the
    // smooth surface (a vertex crease's edges may pass for creases).
    let vertex_creases = |rules: &Rules, d: &[f64], now: f64| -> Option<(Rules, f64)> {
        if exhausted() {
            return None;
        }
        let median = median_of(d);
        let vertices: Vec<usize> = (0..nb)
            .filter(|&v| d[v] > (VERTEX_FACTOR * median).max(OUTLIER_FLOOR))
            .collect();
        if vertices.is_empty() {
            return None;
        }
        let set = |s| Rules {
            vertex_sharpness: with(&vertices, nb, s),
            ..rules.clone()
        };
        if screen(&set).0 >= SCREEN_GAIN * now {
            return None;
        }
        // (Counted while searched: base vertex v is finest vertex v.)
        let was: Vec<bool> = vertices.iter().map(|&v| counted.borrow()[v]).collect();
        for &v in &vertices {
            counted.borrow_mut()[v] = true;
            ignored.borrow_mut()[v] = false;
        }
        let (s, m) = search(&set);
        for (&v, &c) in vertices.iter().zip(&was) {
            counted.borrow_mut()[v] = c;
            ignored.borrow_mut()[v] = !c;
        }
        Some((set(s), m))
    };
    let mut found = Vec::new();
    for (rules, _) in edge_found.iter().take_while(|_| !exhausted()) {
        let (m, d) = misfit(rules, SEARCH_ITERATIONS);
        found.extend(vertex_creases(rules, &d, m));
    }
    let alone = vertex_creases(&smooth_rules, distances, smooth);
    let vertices_found = alone.is_some();
    // Edge creases found from vertex creases' fit (a few creased corners pull the
    // smooth surface off along their edges too, which then pass for creases beside
    // the creased edges): its edge sets screened with those vertex creases, the best
    // searched with them, then the vertex creases searched again on the edges alone.
    let edges_on = |vertex_rules: &Rules| -> Vec<(Rules, f64)> {
        if exhausted() {
            return Vec::new();
        }
        let (now, d) = misfit(vertex_rules, SEARCH_ITERATIONS);
        let with_edges = |set: &[usize], s: u32| Rules {
            sharpness: with(set, base.ne(), s),
            ..vertex_rules.clone()
        };
        let best_set = scored_sets(&d)
            .into_iter()
            .map(|set| (screen(&|s| with_edges(&set, s)).0, set))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .filter(|(m, _)| *m < SCREEN_GAIN * now);
        let Some((_, set)) = best_set else {
            return Vec::new();
        };
        let (s, _) = search(&|s| with_edges(&set, s));
        let edges_alone = Rules {
            vertex_sharpness: Vec::new(),
            ..with_edges(&set, s)
        };
        let (m, d) = misfit(&edges_alone, SEARCH_ITERATIONS);
        let mut out: Vec<(Rules, f64)> = vertex_creases(&edges_alone, &d, m).into_iter().collect();
        out.push((edges_alone, m));
        out
    };
    if let Some((vertex_rules, _)) = &alone {
        found.extend(edges_on(vertex_rules));
    }
    found.extend(alone);
    // (Where the plain smooth surface coded smaller, the vertex creases on the limit
    // too: an infinitely sharp corner pulls the smooth limit fit further off.)
    if !limit {
        let on_limit = Rules {
            limit: true,
            ..smooth_rules.clone()
        };
        found.extend(vertex_creases(&on_limit, distances, smooth));
    }
    // (And past the isolation level, where a finite vertex sharpness is smooth at the
    // limit: where vertex creases screened well on the smooth surface.)
    if isolated.is_some() && vertices_found {
        let past = Rules {
            limit: true,
            extra_levels: isolated,
            ..Rules::default()
        };
        let past = vertex_creases(&past, distances, smooth);
        if let Some((vertex_rules, _)) = &past {
            found.extend(edges_on(vertex_rules));
        }
        found.extend(past);
    }
    // Each that fits better than the smooth surface is coded (the vertex creases'
    // misfits count their own vertices, so coding decides between them).
    let mut out: Vec<Rules> = Vec::new();
    for (rules, m) in std::iter::once(best).chain(edge_found).chain(found) {
        if m < smooth && !out.contains(&rules) {
            out.push(rules);
        }
    }
    out
}

/// The work ([`fit::Operator::work`]) the fit's crease searches on one mesh may do
/// ([`semi_sharp`]): bounded on tiny meshes ([`TINY_WORK`]), where every rule set is
/// tried whatever the screens say.
struct Budget {
    spent: AtomicU64,
    limit: Option<u64>,
}

impl Budget {
    fn new(finest: &Level) -> Budget {
        Budget {
            spent: AtomicU64::new(0),
            limit: (finest.nv <= TINY_VERTICES).then(|| TINY_WORK * finest.nv as u64),
        }
    }

    fn exhausted(&self) -> bool {
        self.limit.is_some_and(|b| self.spent.load(Relaxed) >= b)
    }
}

/// An operator whose work ([`fit::Operator::work`]) is charged to a budget when it
/// is dropped.
struct Charged<'a> {
    op: fit::Operator,
    to: &'a Budget,
}

impl std::ops::Deref for Charged<'_> {
    type Target = fit::Operator;
    fn deref(&self) -> &fit::Operator {
        &self.op
    }
}

impl Drop for Charged<'_> {
    fn drop(&mut self) {
        self.to.spent.fetch_add(self.op.work(), Relaxed);
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| a[k] - b[k])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::{self, fixtures::pseudo, Topo};

    /// A cube's six quads refined twice, its hierarchy (two levels) and values: a
    /// random control mesh refined with two of its edges creased (sharpness 1.5),
    /// plus a little noise.
    fn creased_cube() -> (Canonical, Level, [Vec<i64>; 3]) {
        let mut t = Topo::new(8);
        t.starts = (0..=6).map(|f| 4 * f).collect();
        t.idx = vec![
            0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3,
        ];
        for _ in 0..2 {
            t = Level::new(&t).unwrap().fine();
        }
        let rec = topology::cc::recover_all(t.nv, &t, 16).remove(0);
        let canon = topology::canonicalise(&rec, true).unwrap();
        let finest = canon.levels.last().unwrap().next();
        let mut sharpness = vec![0; canon.levels[0].ne()];
        sharpness[0] = 3 * fit::SHARP_ONE / 2;
        sharpness[1] = 3 * fit::SHARP_ONE / 2;
        let rules = Rules {
            limit: true,
            sharpness,
            ..Rules::default()
        };
        let mut x: [Vec<i64>; 3] = std::array::from_fn(|k| {
            pseudo(k as u64 + 7, canon.base.nv, 12)
                .iter()
                .map(|&v| v * 16)
                .collect()
        });
        fit::refine(&canon.levels, &finest, &rules, &mut x).unwrap();
        for (k, xs) in x.iter_mut().enumerate() {
            for (v, n) in xs.iter_mut().zip(pseudo(k as u64 + 20, finest.nv, 2)) {
                *v += n;
            }
        }
        (canon, finest, x)
    }

    /// The crease search stops once its budget is spent, well before it would have
    /// without one, and a budget it keeps within changes nothing.
    #[test]
    fn the_crease_search_stops_at_its_budget() {
        let (canon, finest, pos) = creased_cube();
        let fine = floats(&pos, pos[0].len());
        let smooth = Rules {
            limit: true,
            ..Rules::default()
        };
        let op = fit::Operator::new(&canon.levels, &finest, &smooth);
        let caps = vec![false; finest.nv];
        let control = robust_fit(&op, &fine, canon.base.nv, &caps);
        let start = (distances_from(&op, &control, &fine), control);
        let search = |limit: Option<u64>| {
            let budget = Budget {
                spent: AtomicU64::new(0),
                limit,
            };
            let found = semi_sharp(&canon, &finest, &pos, &fine, &start, true, &caps, &budget);
            (found, budget.spent.load(Relaxed))
        };
        let (found, free) = search(None);
        assert!(!found.is_empty(), "the creases are found");
        for limit in [free / 16, free / 8] {
            let (_, spent) = search(Some(limit));
            assert!(
                (limit..free / 2).contains(&spent),
                "{spent} spent on a budget of {limit} (unbounded {free})"
            );
        }
        assert_eq!(
            search(Some(free)),
            (found, free),
            "a budget it keeps within"
        );
    }
}
