//! The encoder's subdivision fit (not part of the format beyond SPEC.md 9.10): which
//! rules a subdivided model follows, its control mesh by least squares, and the
//! precision that codes it smallest.

use super::*;
use crate::topology::Level;
use crate::transform::fit::Rules;

/// Mean [`fit::defect`] over the axes of the finest level above which `auto` does not
/// try the fit, unless [`ROUGH_SCREEN`] lets it: rounded subdivision gives about 70 /
/// 12 (the variance of the rounding noise it sums), fitted detail far more.
pub(crate) const FIT_SCREEN: f64 = 12.0;

/// Mean [`fit::roughness`] over the axes of the finest level above which `auto` does
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
/// subdivision.
pub(crate) fn code_fit(
    canon: &Canonical,
    pos: &[Vec<i64>; 3],
    header: &Header,
    bits: &[u8],
    screen: bool,
) -> Option<Payloads> {
    if !canon.poles.is_empty() {
        return None;
    }
    // The level whose coarse mesh is the finest one.
    let last = canon.levels.last()?;
    let finest = last.next();
    let base = &canon.levels[0];
    let fine: Vec<[f64; 3]> = (0..pos[0].len())
        .map(|i| std::array::from_fn(|k| pos[k][i] as f64))
        .collect();
    let mut sets = None;
    if screen {
        let mean = |f: &dyn Fn(&[i64]) -> Option<f64>| {
            pos.iter().map(|x| f(x).unwrap_or(f64::MAX)).sum::<f64>() / 3.0
        };
        // Refinement (small defect) is fitted; else a surface: five finest vertices
        // in a row inside one level-1 face, which roughness measures, take three
        // levels, and a shallower hierarchy is screened by one fit on the limit.
        // A flat mesh with a boundary (one axis constant: a UV map's charts, cut at
        // their seams) may still be a modelling tool's subdivision, by its UV rule:
        // linear boundaries on the limit surface. That rule set alone is tried when
        // the screens turn the fit away, and on a shallow chart.
        let chart = pos.iter().any(|x| x.iter().all(|&v| v == x[0]))
            && !crate::topology::sqrt2::closed(base);
        let far = mean(&|x| fit::defect(last, x)) > FIT_SCREEN
            && if canon.levels.len() < 3 {
                chart || !near_limit(canon, &finest, &fine)
            } else {
                mean(&|x| fit::roughness(&canon.levels, &finest, x)) > ROUGH_SCREEN
            };
        if far {
            if !chart {
                return None;
            }
            sets = Some(vec![Rules {
                limit: true,
                linear: true,
                ..Rules::default()
            }]);
        }
    }
    let nb = canon.base.nv;
    let mut best: Option<Payloads> = None;
    let sets = sets.unwrap_or_else(|| rule_sets(canon, &finest, pos));
    for rules in sets {
        let op = fit::Operator::new(&canon.levels, &finest, &rules);
        let control = robust_fit(&op, &fine, nb);
        drop(op);
        // B = 0 last, for values too large for any precision asked for.
        let mut found = false;
        for b in bits.iter().copied().chain([0]) {
            if b == 0 && found {
                break;
            }
            let s = (1u64 << b) as f64;
            let mut x: [Vec<i64>; 3] = std::array::from_fn(|k| {
                control.iter().map(|v| (v[k] * s).round() as i64).collect()
            });
            if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
                continue;
            }
            found = true;
            let (mut h, base_bytes) = hierarchy_base(canon, &x, header);
            fit::refine(&canon.levels, &finest, &rules, &mut x);
            let mut level_bytes = vec![Vec::new(); canon.levels.len() - 1];
            level_bytes.push(levl::fit::encode_residuals(&x, pos, b));
            h.transform = Transform::Fit {
                bits: b,
                limit: rules.limit,
                corners: rules.corners,
                linear: rules.linear,
            };
            h.creases = (0..rules.sharp.len() as u32)
                .filter(|&e| rules.sharp[e as usize])
                .collect();
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
    }
    best
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
fn near_limit(canon: &Canonical, finest: &Level, fine: &[[f64; 3]]) -> bool {
    let rules = Rules {
        limit: true,
        ..Rules::default()
    };
    let op = fit::Operator::new(&canon.levels, finest, &rules);
    let nb = canon.base.nv;
    let control = op.fit(fine, &fine[..nb], &[], NEAR_ITERATIONS, FIT_TOLERANCE);
    let mut dist: Vec<f64> = op
        .apply(&control)
        .iter()
        .zip(fine)
        .flat_map(|(p, y)| (0..3).map(move |k| (p[k] - y[k]).abs()))
        .collect();
    if dist.is_empty() {
        return false;
    }
    let mid = dist.len() / 2;
    *dist.select_nth_unstable_by(mid, f64::total_cmp).1 <= NEAR_LIMIT
}

/// Finest vertices whose distance from the first fit exceeds this many times the
/// median distance (and [`OUTLIER_FLOOR`]) do not count in the second: a few points a
/// modelling tool places by other rules (OpenSubdiv's patches beside extraordinary
/// vertices) would otherwise pull the whole control mesh off.
const OUTLIER_FACTOR: f64 = 16.0;

/// Grid units below which no vertex is an outlier.
const OUTLIER_FLOOR: f64 = 4.0;

/// The control values of `op` nearest `fine` in least squares, fitted again without
/// the outliers of the first fit.
fn robust_fit(op: &fit::Operator, fine: &[[f64; 3]], nb: usize) -> Vec<[f64; 3]> {
    let first = op.fit(fine, &fine[..nb], &[], 400, FIT_TOLERANCE);
    let dist: Vec<f64> = op
        .apply(&first)
        .iter()
        .zip(fine)
        .map(|(p, y)| (0..3).map(|k| (p[k] - y[k]).abs()).fold(0.0, f64::max))
        .collect();
    let mut sorted = dist.clone();
    sorted.sort_by(f64::total_cmp);
    let cut = (OUTLIER_FACTOR * sorted[sorted.len() / 2]).max(OUTLIER_FLOOR);
    let ignored: Vec<bool> = dist.iter().map(|&d| d > cut).collect();
    // Refit only where a few points are outliers (many are no rule's misses).
    let n = ignored.iter().filter(|&&i| i).count();
    if n == 0 || n * 8 > dist.len() {
        return first;
    }
    op.fit(fine, &first, &ignored, 400, FIT_TOLERANCE)
}

/// The rule sets the fit tries: plain refinement, the limit surface, and the limit
/// surface with the creases the finest level shows; each also with boundary corners
/// kept where the base mesh has a boundary vertex with one face, and with every
/// boundary vertex kept (linear boundaries) where it has a boundary.
fn rule_sets(canon: &Canonical, finest: &Level, pos: &[Vec<i64>; 3]) -> Vec<Rules> {
    let mut sets = vec![
        Rules::default(),
        Rules {
            limit: true,
            ..Rules::default()
        },
    ];
    let sharp = creases(canon, finest, pos);
    if !sharp.is_empty() {
        sets.push(Rules {
            limit: true,
            sharp: sharp.clone(),
            ..Rules::default()
        });
        sets.push(Rules {
            sharp,
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
        let kept: Vec<Rules> = sets
            .iter()
            .map(|r| Rules {
                corners: true,
                ..r.clone()
            })
            .collect();
        sets.extend(kept);
    }
    sets.extend(linear);
    sets
}

/// The mean angle (radians) between the finest faces beside a base edge's descendants
/// above which the encoder tries the edge as a crease: a smooth surface's finest faces
/// meet at a few degrees, a crease at its fold.
const CREASE_ANGLE: f64 = 0.3;

/// The base edges along which the finest surface folds (mean angle between the finest
/// faces beside the edge's descendants above [`CREASE_ANGLE`]): the creases the fit
/// tries. Empty when there is none.
fn creases(canon: &Canonical, finest: &Level, pos: &[Vec<i64>; 3]) -> Vec<bool> {
    // Per edge of each level, the base edge it descends from (NONE: none).
    let none = u32::MAX;
    let mut owner: Vec<u32> = (0..canon.levels[0].ne() as u32).collect();
    for (l, level) in canon.levels.iter().enumerate() {
        let fine = canon.levels.get(l + 1).unwrap_or(finest);
        owner = fit::tags_below(level, &owner, none, fine);
    }
    let p = |v: u32| -> [f64; 3] { std::array::from_fn(|k| pos[k][v as usize] as f64) };
    let normal = |f: u32| {
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
    };
    let mut sum = vec![(0.0f64, 0usize); canon.levels[0].ne()];
    for (h, &o) in owner.iter().enumerate().filter(|&(_, &o)| o != none) {
        if finest.is_boundary(h) {
            continue;
        }
        let [f0, f1] = finest.edge_faces[h];
        let (n0, n1) = (normal(f0), normal(f1));
        let dot: f64 = (0..3).map(|k| n0[k] * n1[k]).sum();
        let len = (0..3).map(|k| n0[k] * n0[k]).sum::<f64>().sqrt()
            * (0..3).map(|k| n1[k] * n1[k]).sum::<f64>().sqrt();
        if len > 0.0 {
            let s = &mut sum[o as usize];
            s.0 += (dot / len).clamp(-1.0, 1.0).acos();
            s.1 += 1;
        }
    }
    let sharp: Vec<bool> = sum
        .iter()
        .map(|&(a, n)| n > 0 && a / n as f64 > CREASE_ANGLE)
        .collect();
    if sharp.contains(&true) {
        sharp
    } else {
        Vec::new()
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| a[k] - b[k])
}
