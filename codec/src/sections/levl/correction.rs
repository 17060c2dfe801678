//! Modes 8 and 9 (SPEC.md 10.8, 10.9): details less a weighted sum of the level's
//! earlier details nearby; the weights, the features and the encoder's fit of them.

use super::*;

/// Mode 8's weights are in 32nds, at most 2 in magnitude.
pub(super) const CORR_DIV: i128 = 32;

pub(super) const CORR_MAX: i8 = 64;

/// Mode 8's features per detail (SPEC.md 10.8).
pub(super) const NFEAT: usize = 2;

/// Mode 8's weights: per class (edge points, face points) and axis, those of the
/// features of [`corr_features`].
pub(super) type Weights = [[[i8; NFEAT]; 3]; 2];

/// Mode 8's (and 9's) features of detail `i` of a Catmull-Clark level, per axis, from
/// the details `x[k][nv + j]` of the details `j < i` (SPEC.md 10.8). An edge point: the
/// sum of its ends' earlier edges that share no face with it (the edge's continuation on
/// a regular grid), and of the earlier edges opposite it in its quadrilateral faces. A
/// face point: the sum of the earlier faces beside its edges, and of its own edge
/// points.
pub(super) fn corr_features(level: &Level, x: &[Vec<i64>; 3], i: usize) -> [[i128; 3]; NFEAT] {
    use crate::topology::NONE;
    let nv = level.nv;
    let mut f = [[0i128; 3]; NFEAT];
    let mut add = |which: usize, j: usize| {
        for k in 0..3 {
            f[which][k] += x[k][nv + j] as i128;
        }
    };
    let ne = level.ne();
    if i < ne {
        let faces = level.edge_faces[i];
        let beside = |g: u32| {
            let gf = level.edge_faces[g as usize];
            gf.iter().any(|&h| h != NONE && faces.contains(&h))
        };
        for v in level.edges[i] {
            for &g in level.v_edges(v as usize) {
                if (g as usize) < i && !beside(g) {
                    add(0, g as usize);
                }
            }
        }
        for h in faces {
            if h == NONE {
                continue;
            }
            let fe = level.f_edges(h as usize);
            if fe.len() == 4 {
                if let Some(p) = fe.iter().position(|&g| g as usize == i) {
                    let g = fe[(p + 2) % 4] as usize;
                    if g < i {
                        add(1, g);
                    }
                }
            }
        }
    } else {
        let fi = i - ne;
        for &g in level.f_edges(fi) {
            for h in level.edge_faces[g as usize] {
                if h != NONE && (h as usize) < fi {
                    add(0, ne + h as usize);
                }
            }
            add(1, g as usize);
        }
    }
    f
}

/// Mode 8's correction numerators of detail `i`: per axis `sum w_j F_j` (SPEC.md 10.8).
pub(super) fn correction_sums(
    level: &Level,
    x: &[Vec<i64>; 3],
    w: &Weights,
    i: usize,
) -> [i128; 3] {
    let class = (i >= level.ne()) as usize;
    let f = corr_features(level, x, i);
    std::array::from_fn(|k| match w[class][k] {
        [0, 0] => 0,
        wk => (0..NFEAT).map(|j| wk[j] as i128 * f[j][k]).sum(),
    })
}

/// Mode 8's correction from its numerators: per axis `[n / 32]`; `None` beyond the
/// bound of a detail.
pub(super) fn correction(n: [i128; 3]) -> Option<[i64; 3]> {
    let mut c = [0i64; 3];
    for k in 0..3 {
        // (Floor division by a power of two: an arithmetic shift.)
        let q = (2 * n[k] + CORR_DIV) >> (2 * CORR_DIV).trailing_zeros();
        c[k] = i64::try_from(q).ok().filter(|q| q.abs() <= MAX_LIFTED)?;
    }
    Some(c)
}

/// Mode 9's joint correction (SPEC.md 10.9), from mode 8's numerators `n` and
/// the predictions' fractions: per axis `[(frac + 16 n) / 512]` and the phase of its
/// remainder; `None` beyond the bound of a detail.
pub(super) fn joint_correction(n: [i128; 3], frac: [i16; 3]) -> Option<([i64; 3], [u8; 3])> {
    let mut c = [0i64; 3];
    let mut q = [0u8; 3];
    for k in 0..3 {
        let a = frac[k] as i128 + (FRAC_DIV / CORR_DIV) * n[k];
        let v = (2 * a + FRAC_DIV) >> (2 * FRAC_DIV).trailing_zeros();
        c[k] = i64::try_from(v).ok().filter(|v| v.abs() <= MAX_LIFTED)?;
        q[k] = phase(a - FRAC_DIV * v, FRAC_DIV);
    }
    Some((c, q))
}

/// Whether a prediction's fraction `frac` alone makes a 0 joint correction: the axis
/// of [`joint_correction`] with a 0 numerator, without its other axes and phase.
pub(super) fn joint_rounds_to_0(frac: i16) -> bool {
    (2 * frac as i128 + FRAC_DIV) >> (2 * FRAC_DIV).trailing_zeros() == 0
}

/// Modes 8 and 9's correction numerators of every detail of the level whose details are
/// `x[k][nv..]`; `None` if a correction (mode 8's) is beyond the bound of a detail (the
/// numerators then fit 64 bits).
pub(super) fn corrections(level: &Level, x: &[Vec<i64>; 3], w: &Weights) -> Option<Vec<[i64; 3]>> {
    sampled_corrections(level, x, w, Sample::All)
}

/// [`corrections`] of the details in `sample` (0 for the others).
pub(super) fn sampled_corrections(
    level: &Level,
    x: &[Vec<i64>; 3],
    w: &Weights,
    sample: Sample,
) -> Option<Vec<[i64; 3]>> {
    // Sized once (collecting into an Option would grow the vector to twice its length).
    let nd = level.ne() + level.nf();
    let mut out = Vec::with_capacity(nd);
    for i in 0..nd {
        if !sample.has(i) {
            out.push([0; 3]);
            continue;
        }
        let n = correction_sums(level, x, w, i);
        correction(n)?;
        out.push(n.map(|v| v as i64));
    }
    Some(out)
}

/// Modes 8 and 9's weights after the mode byte (SPEC.md 10.8), whether the mask's joint
/// flag is set (mode 9 only, 10.9: open where `joint_open`), and the stream after
/// them.
pub(super) fn read_weights(rest: &[u8], joint_open: bool) -> Result<(Weights, Rounding, &[u8])> {
    let bad = || Error::corrupt("LEVL", "bad correction weights");
    let (&mask, mut rest) = rest.split_first().ok_or_else(bad)?;
    let rounding = match mask >> 6 {
        0 => Rounding::Apart,
        1 if joint_open => Rounding::Joint,
        _ => return Err(bad()),
    };
    let mut w: Weights = [[[0; NFEAT]; 3]; 2];
    for (j, p) in w.iter_mut().flatten().enumerate() {
        if mask >> j & 1 == 1 {
            let (c, r) = rest.split_first_chunk::<NFEAT>().ok_or_else(bad)?;
            *p = c.map(|v| v as i8);
            // (unsigned_abs: -128's abs overflows an i8.)
            if p.iter().any(|v| v.unsigned_abs() > CORR_MAX as u8) {
                return Err(bad());
            }
            rest = r;
        }
    }
    Ok((w, rounding, rest))
}

/// The encoder's mode 8 weights for a level whose details are `x[k][nv..]`: per class and
/// axis, the least-squares fit of the details by their features, in 32nds; `None` when
/// every weight rounds to 0.
#[cfg(test)]
pub(super) fn corr_weights(level: &Level, x: &[Vec<i64>; 3]) -> Option<Weights> {
    sampled_corr_weights(level, x, Sample::All)
}

/// `corr_weights` fitted on the details in `sample`.
pub(super) fn sampled_corr_weights(
    level: &Level,
    x: &[Vec<i64>; 3],
    sample: Sample,
) -> Option<Weights> {
    let nd = level.ne() + level.nf();
    // Per class and axis: the normal equations, F^T F and F^T y.
    let mut a = [[[[0f64; NFEAT]; NFEAT]; 3]; 2];
    let mut b = [[[0f64; NFEAT]; 3]; 2];
    for i in (0..nd).filter(|&i| sample.has(i)) {
        let class = (i >= level.ne()) as usize;
        let f = corr_features(level, x, i);
        for k in 0..3 {
            let y = x[k][level.nv + i] as f64;
            for p in 0..NFEAT {
                let fp = f[p][k] as f64;
                b[class][k][p] += fp * y;
                for q in 0..NFEAT {
                    a[class][k][p][q] += fp * f[q][k] as f64;
                }
            }
        }
    }
    let mut w: Weights = [[[0; NFEAT]; 3]; 2];
    for c in 0..2 {
        for k in 0..3 {
            if let Some(sol) = solve(a[c][k], b[c][k]) {
                w[c][k] = sol.map(|v| {
                    (v * CORR_DIV as f64)
                        .round()
                        .clamp(-(CORR_MAX as f64), CORR_MAX as f64) as i8
                });
            }
        }
    }
    (w != [[[0; NFEAT]; 3]; 2]).then_some(w)
}

/// The least-squares solution of `a w = b` by Gaussian elimination, with a small ridge
/// that keeps a feature that is (nearly) always 0 out of the fit.
pub(super) fn solve(mut a: [[f64; NFEAT]; NFEAT], mut b: [f64; NFEAT]) -> Option<[f64; NFEAT]> {
    for (p, row) in a.iter_mut().enumerate() {
        row[p] = row[p] * 1.0001 + 1.0;
    }
    for p in 0..NFEAT {
        let piv = (p..NFEAT).max_by(|&i, &j| a[i][p].abs().total_cmp(&a[j][p].abs()))?;
        a.swap(p, piv);
        b.swap(p, piv);
        if a[p][p].abs() < 1e-12 || !a[p][p].is_finite() {
            return None;
        }
        for r in p + 1..NFEAT {
            let m = a[r][p] / a[p][p];
            for q in p..NFEAT {
                a[r][q] -= m * a[p][q];
            }
            b[r] -= m * b[p];
        }
    }
    let mut w = [0f64; NFEAT];
    for p in (0..NFEAT).rev() {
        let s: f64 = (p + 1..NFEAT).map(|q| a[p][q] * w[q]).sum();
        w[p] = (b[p] - s) / a[p][p];
    }
    w.iter().all(|v| v.is_finite()).then_some(w)
}
